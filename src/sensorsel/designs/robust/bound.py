"""An upper bound on the best achievable worst case, OPT_r = max { g_a(S) : Cost(S) <= B },
g_a(S) = min { f(S minus F) : F ⊆ S, |F| <= a }.

The facts, each proved here (f monotone submodular, f(empty) = 0).

**(1) Knapsack with drops.** For any suite X (an *anchor*, feasible or not) and every S with
Cost(S) <= B, let D be the a sensors of S minus X with the largest gains Δ(e | X) = f(X + e) - f(X)
(all of them if fewer). D ⊆ S and |D| <= a, so

    g_a(S) <= f(S minus D) <= f(X ∪ (S minus D)) <= f(X) + Σ_{e ∈ S minus X minus D} Δ(e | X)

(monotonicity, then submodularity along any order). The right side is at most

    K_a(X, B) = f(X) + max { Σ_{e∈T} Δ(e|X) - (sum of the a largest Δ(e|X) in T) : T ⊆ V minus X, Cost(T) <= B }

a 0/1 knapsack in which the a most valuable items taken count nothing. It is solved exactly by a
dynamic program over (capacity, items dropped so far <= a), the items in decreasing gain: the first
a items a set takes in that order are its a largest (:func:`knapsack_drop`). a = 0 is the
certificate's knapsack bound U(X) of :mod:`sensorsel.designs.certify`. One anchor costs one sweep of
marginal gains. Anchors used: the empty suite (its gains are the singletons f({e})) and the
worst-case survivors S_c minus F_c of the best candidates (f of those is the candidate's worst case
itself, so a small knapsack means a small gap).

**(2) Case split on a sensor.** Write T(V', B', a) for max { g_a(S) : S ⊆ V', Cost(S) <= B' }. For any
e in V', a suite S either avoids e, and then S ⊆ V' - e, or contains e, and then the failure sets
that contain e give

    g_a(S) <= min { f(S - e - F') : F' ⊆ S - e, |F'| <= a - 1 } = g_{a-1}(S - e),   S - e ⊆ V' - e,
    Cost(S - e) <= B' - cost(e).

So T(V', B', a) <= max( T(V' - e, B', a), T(V' - e, B' - cost(e), a - 1) ). Splitting on the sensors
that dominate (the $100,000 LiDAR) separates "suites without it" from "suites that lose it and keep
only B - cost(e) of the rest", which no single knapsack sees. (Unrolled: OPT_r <= max over ... ; in
particular, for any set E of a sensors, OPT_r <= OPT_nominal(V minus E, B).) A node's value is the
minimum of its own bound and the larger of its children's.

**(3) Everything fits.** g_a is monotone (for S ⊆ S' and F' ⊆ S', f(S' minus F') >= f(S minus
(F' ∩ S)) >= g_a(S)), so when all affordable sensors of V' fit in B' together, T(V', B', a) is
exactly g_a of that set: one worst-case computation (enumerated when C(m, a) is small; else the
value after a greedy adversary's a removals, an upper bound).

**(4) Constraints** (:mod:`sensorsel.model.constraints`: resource limits, mounting slots, most sensors,
required and excluded sensors). The constrained suites are a subset of the suites within a budget
alone, so the bound of that larger problem bounds them too: the budget row is kept, every other row
dropped, the excluded sensors removed from the root's library. The budget row is the price, except
that with ``owned`` the required sensors R cost nothing: a constrained S holds R and prices
Cost(S minus R) <= B, so Cost(S) <= B + Cost(R), and the relaxation's budget is B + Cost(R). An
"exact" leaf is then the worst case of a suite that may break a dropped limit: it raises the
incumbent only when it fits them all. Used only on request (``relax_to_budget``), to compare.

**(5) Every limit kept** (the default under constraints). A node is (V', the sensors assumed failed
E, a), standing for the suites S = S' ∪ E with S' ⊆ V' keeping what E leaves of every row,
A S' <= b - A E (A >= 0), and holding the required sensors R' = R minus E. In fact (1), T = S' minus X
then holds R' minus X and uses at most b - A E - A(R' ∩ X) of every row; the knapsack with drops
over those item sets is an integer program (:func:`knapsack_drop_rows`, HiGHS; its dual bound when
it stops early), never above the budget knapsack of (4). Fact (2) splits the same way (the sensors
left to S - e are b - A E - A e; a node that removed a required sensor, or whose required sensors
break a row, holds no suite: 0); fact (3) holds with "fits" meaning every row. Each node also takes
the exact leaf of (4) when the budget relaxation has one, so a node is never looser than the same
node of the relaxation. The nominal leaves' branch and bound (:func:`sensorsel.designs.certify.optimal`)
still sees the budget alone (a relaxation).

The case split is explored best-first (the leaf with the highest bound is split, on its sensor of
largest f({e})), until every leaf is at or below the incumbent (then the incumbent is optimal,
``proved``) or ``max_nodes`` nodes were made.
"""

from __future__ import annotations

import heapq
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from sensorsel.designs.certify import MAX_DP_CELLS, cost_units, knapsack, optimal, quiet_stdout
from sensorsel.designs.parts import elapsed_s
from sensorsel.designs.resilient import check_alpha, worst_case
from sensorsel.designs.robust.records import BoundLeaf, RobustBound
from sensorsel.designs.selection import REL_TOL, check_budget, greedy
from sensorsel.information.evaluators import Evaluator, as_suite
from sensorsel.model.constraints import REL_SLACK, Constraints, FeasibleSet, feasible_set

#: Default number of case-split nodes of the bound.
DEFAULT_BOUND_NODES = 16
#: A leaf whose whole library fits is solved exactly when it has at most this many failure sets.
MAX_EXACT_SETS = 256
#: Node limit of the nominal branch and bound run on a leaf without failures left.
LEAF_SEARCH_NODES = 30
#: Anchors tried per node (the empty suite counts one).
MAX_ANCHORS = 2


def knapsack_drop(
    values: Sequence[float] | np.ndarray,
    costs: Sequence[float] | np.ndarray,
    capacity: float,
    drop: int,
    *,
    max_cells: int = MAX_DP_CELLS,
) -> float:
    """max over T with Σ costs <= capacity of Σ_T values - (sum of the ``drop`` largest values in T).

    Exact DP when costs are decimal and the table has at most ``max_cells`` cells per drop level;
    otherwise an upper bound (costs rounded down; or the plain knapsack, which ignores the drops).
    Items with value <= 0 or cost above the capacity are never useful and are left out.
    """
    v = np.asarray(values, dtype=float).reshape(-1)
    c = np.asarray(costs, dtype=float).reshape(-1)
    if drop <= 0:
        return knapsack(v.tolist(), c.tolist(), capacity, max_cells=max_cells).value
    units = cost_units(c.tolist(), capacity)
    keep = np.flatnonzero((v > 0) & (units.costs <= units.capacity))
    if len(keep) <= drop:
        return 0.0
    order = keep[np.lexsort((keep, -v[keep]))]  # decreasing value, ties by position
    w = units.costs[order]
    cap = int(min(units.capacity, w.sum()))
    if len(order) * (cap + 1) > max_cells:
        return knapsack(v.tolist(), c.tolist(), capacity, max_cells=max_cells).value
    neg = -np.inf
    dp = np.full((drop + 1, cap + 1), neg)  # dp[j, k]: best value, j items dropped (j = drop: from then on they count)
    dp[0, :] = 0.0
    for i, wi in zip(order, w):
        wi, vi = int(wi), float(v[i])
        new = dp.copy()
        if wi == 0:
            new[1:, :] = np.maximum(new[1:, :], dp[:-1, :])
            new[drop, :] = np.maximum(new[drop, :], dp[drop, :] + vi)
        else:
            new[1:, wi:] = np.maximum(new[1:, wi:], dp[:-1, : cap + 1 - wi])
            new[drop, wi:] = np.maximum(new[drop, wi:], dp[drop, : cap + 1 - wi] + vi)
        dp = new
    return float(max(0.0, dp[:, cap].max()))


#: Node limit of the integer program of :func:`knapsack_drop_rows` (a node limit, not a time limit:
#: the same inputs give the same bound on any machine).
MILP_NODE_LIMIT = 20_000


def knapsack_drop_rows(
    values: Sequence[float] | np.ndarray,
    usage: np.ndarray,
    capacity: Sequence[float] | np.ndarray,
    drop: int,
    *,
    forced: Sequence[int] = (),
    slack: np.ndarray | None = None,
    node_limit: int = MILP_NODE_LIMIT,
) -> tuple[float, bool]:
    """max over T with usage[:, T].sum(axis=1) <= capacity (every row) and T ⊇ ``forced`` of
    Σ_T values - (sum of the ``drop`` largest values in T), by an integer program (HiGHS).

    For a 0/1 vector x the sum of the ``drop`` largest of {v_i x_i} (v >= 0) is, by LP duality,
    min over t of drop * t + Σ_i max(v_i x_i - t, 0); so the knapsack with drops is the MILP

        max Σ v_i x_i - drop * t - Σ u_i   s.t.  u_i >= v_i x_i - t,  u_i >= 0,  t >= 0,
            usage x <= capacity,  x_i in {0, 1},  x_i = 1 for the forced items.

    Args:
        values: (k,) item values (negative ones are clipped to 0: an item never lowers the value).
        usage: (m, k) what each item uses of each row (>= 0).
        capacity: (m,) the rows' limits.
        slack: (m,) added to ``capacity`` (default: a relative 1e-9 of it); pass the feasible set's
            slack on its limits so that every suite it accepts is a solution here.
        drop: how many of the largest chosen values count nothing.
        forced: item positions every T holds (e.g. required sensors outside the anchor).
        node_limit: HiGHS's branch-and-bound node limit.

    Returns:
        (value, proved): the maximum (``proved``), or HiGHS's dual bound when it stopped early (an
        upper bound, never below the maximum); -inf when the forced items do not fit.
    """
    from scipy.optimize import Bounds, LinearConstraint, milp

    v = np.maximum(np.asarray(values, dtype=float).reshape(-1), 0.0)
    cap = np.asarray(capacity, dtype=float).reshape(-1)
    use = np.asarray(usage, dtype=float).reshape(len(cap), len(v))
    cap = cap + (
        REL_SLACK * np.maximum(1.0, np.abs(cap)) if slack is None else np.asarray(slack, dtype=float).reshape(-1)
    )
    must = np.zeros(len(v), dtype=bool)
    must[list(forced)] = True
    # forced items worth nothing only use capacity; items worth nothing or too large are never chosen
    cap = cap - use[:, must & (v <= 0)].sum(axis=1)
    if np.any(cap < 0):
        return -math.inf, True
    keep = np.flatnonzero((v > 0) & (np.all(use <= cap[:, None], axis=0) | must))
    if np.any(must & (v > 0) & ~np.isin(np.arange(len(v)), keep)):
        return -math.inf, True
    k, d = len(keep), max(0, int(drop))
    if k == 0:
        return 0.0, True
    vk, uk, mk = v[keep], use[:, keep], must[keep].astype(float)
    # variables: x (k), then u (k) and t when there are drops
    nu = k + 1 if d else 0
    c = np.concatenate([-vk, np.ones(k), [float(d)]]) if d else -vk
    rows = [LinearConstraint(np.hstack([uk, np.zeros((len(cap), nu))]), -np.inf, cap)]
    if d:
        link = np.hstack([np.diag(vk), -np.eye(k), -np.ones((k, 1))])  # v_i x_i - u_i - t <= 0
        rows.append(LinearConstraint(link, -np.inf, 0.0))
    lb = np.concatenate([mk, np.zeros(nu)])
    ub = np.concatenate([np.ones(k), np.full(nu, np.inf)])
    integrality = np.concatenate([np.ones(k), np.zeros(nu)])
    with quiet_stdout():
        res = milp(
            c,
            integrality=integrality,
            bounds=Bounds(lb, ub),
            constraints=rows,
            options={"node_limit": int(node_limit), "mip_rel_gap": 0.0, "presolve": True},
        )
    if res.status == 2:  # infeasible: the forced items do not fit together
        return -math.inf, True
    dual = getattr(res, "mip_dual_bound", None)
    # the dual bound is the upper bound (a finished search closes the gap to HiGHS's absolute 1e-6)
    if dual is not None and math.isfinite(dual):
        return float(max(0.0, -dual)), bool(res.status == 0)
    if res.status == 0 and res.fun is not None:
        return float(max(0.0, -res.fun)), True
    return float(vk.sum()), False  # nothing proved: every positive value, a trivial bound


@dataclass
class _Node:
    removed: tuple[int, ...] = ()
    failed: tuple[int, ...] = ()
    budget: float = 0.0
    alpha: int = 0
    own: float = 0.0
    how: str = ""
    children: list = field(default_factory=list)
    final: bool = False
    cap: np.ndarray | None = None  # under constraints: what is left of every row (row 0: the budget)


def _adversary(ev: Evaluator, suite: tuple[int, ...], alpha: int) -> float:
    """f after ``alpha`` greedy removals (each the one that lowers f most): an upper bound on g_alpha."""
    s = list(suite)
    for _ in range(min(alpha, len(s))):
        vals = [ev.score([i for i in s if i != x]) for x in s]
        s.remove(s[int(np.argmin(vals))])
    return ev.score(s) if s else 0.0


def robust_bound(
    evaluator: Evaluator,
    budget_usd: float,
    alpha: int,
    *,
    anchors: Sequence[Sequence[int]] = (),
    incumbent: float = 0.0,
    max_nodes: int = DEFAULT_BOUND_NODES,
    constraints: Constraints | None = None,
    relax_to_budget: bool | None = None,
) -> RobustBound:
    """Upper bound on max { g_alpha(S) : Cost(S) <= budget } (see the module docstring for the proof).

    Args:
        evaluator: scores suites (a :class:`~sensorsel.designs.robust.memo.MemoEvaluator` saves re-scoring).
        anchors: suites X to anchor the knapsacks at, best first (e.g. worst-case survivors of the
            best candidates); the empty suite is always tried first.
        incumbent: a worst case already achieved [nats]: leaves at or below it are not refined. An
            "exact" leaf with no sensor assumed failed is a suite within the budget: its worst case
            raises the incumbent (and ``proved`` then refers to it).
        max_nodes: nodes of the case split (1: no split). Each node tries :data:`MAX_ANCHORS` anchors
            and solves its leaf exactly up to :data:`MAX_EXACT_SETS` failure sets; a leaf without failures
            left is anchored at a uniform greedy run on its library and budget and, when its knapsack bound
            is above the incumbent, bounded by :func:`sensorsel.designs.certify.optimal` (excluding the
            removed sensors) with :data:`LEAF_SEARCH_NODES` nodes, keeping that upper bound if smaller.
        constraints: limits besides the budget, kept by the knapsacks' integer programs (fact (5));
            with only excluded sensors, they are removed and the budget knapsack is exact as it is.
        relax_to_budget: under limits besides the budget (or required sensors): None (default) builds
            both case splits, the integer programs' (fact (5)) and the budget relaxation's (fact (4)),
            and keeps the smaller bound (both are valid; with a node limit either tree may end lower);
            False: the integer programs' alone; True: the relaxation's alone.
    """
    budget_usd, alpha = check_budget(budget_usd), check_alpha(alpha)
    feas = feasible_set(evaluator.library, budget_usd, constraints) if constraints is not None else None
    start = [as_suite(a) for a in anchors]
    if relax_to_budget is None and feas is not None and (not feas.only_budget or feas.required):
        t0, n_start = time.perf_counter(), evaluator.n_evaluations
        tight = _case_split(evaluator, budget_usd, alpha, feas, False, start, incumbent, max_nodes)
        loose = _case_split(evaluator, budget_usd, alpha, feas, True, start, incumbent, max_nodes)
        keep = tight if tight.bound <= loose.bound else loose
        other = loose if keep is tight else tight
        note = (
            f"; the budget relaxation's tree ended at {other.bound:,.6g}"
            if keep is tight
            else f"; the integer programs' tree ended at {other.bound:,.6g}"
        )
        return replace(
            keep,
            n_nodes=tight.n_nodes + loose.n_nodes,
            n_sweeps=tight.n_sweeps + loose.n_sweeps,
            n_evaluations=evaluator.n_evaluations - n_start,
            seconds=elapsed_s(t0),
            relaxation=keep.relaxation + note,
        )
    return _case_split(evaluator, budget_usd, alpha, feas, relax_to_budget, start, incumbent, max_nodes)


# Long on purpose (~200 lines): one proof, read top to bottom: the knapsack with the alpha best items
# dropped at each anchor, the case split on a dominant sensor, and the exact leaves; robust_bound's
# docstring states the bound and each step cites it.
def _case_split(
    ev: Evaluator,
    budget_usd: float,
    alpha: int,
    feas: FeasibleSet | None,
    relax_to_budget: bool | None,
    anchor_list: list[tuple[int, ...]],
    incumbent: float,
    max_nodes: int,
) -> RobustBound:
    """One tree of :func:`robust_bound` (checked arguments): under limits besides the budget, the
    integer programs' (fact (5)) or, with ``relax_to_budget``, the budget relaxation's (fact (4))."""
    t0 = time.perf_counter()
    lib = ev.library
    relaxation = ""
    root_removed: tuple[int, ...] = ()
    rows: FeasibleSet | None = None  # every limit kept (fact (5)); None: the budget knapsack
    owned = False
    if feas is not None and not feas.plain:
        extra = lib.cost(feas.required) if feas.constraints.owned else 0.0
        root_removed = tuple(sorted(feas.excluded))
        if relax_to_budget or (feas.only_budget and not feas.required):
            relaxation = (
                f"budget alone (${budget_usd + extra:,.0f}"
                + (" = the budget + the owned sensors' price" if extra else "")
                + f"); dropped: {feas.constraints.describe()}"
            )
            budget_usd = budget_usd + extra
        else:
            rows, owned = feas, bool(feas.constraints.owned)
            relaxation = (
                f"none at the knapsacks (integer programs over {_rows_described(feas)}); the nominal leaves' "
                f"branch and bound sees the budget alone" + (" + the owned sensors' price" if extra else "")
            )
    else:
        feas = None
    n0 = ev.n_evaluations
    costs, ids, n = lib.costs, lib.ids, len(lib)
    A = rows.A if rows is not None else np.zeros((0, n))
    slack = REL_SLACK * np.maximum(1.0, np.abs(rows.b)) if rows is not None else np.zeros(0)
    singles = ev.scores_with((), list(range(n)))
    sweeps = 0
    tol = REL_TOL * max(1.0, abs(incumbent))

    def cap_of(node: _Node) -> np.ndarray:
        assert node.cap is not None  # every node carries its rows under constraints
        return node.cap

    def affordable(node: _Node) -> tuple[int, ...]:
        gone = set(node.removed)
        if rows is None:
            return tuple(i for i in range(n) if i not in gone and costs[i] <= node.budget * (1 + 1e-12) + 1e-9)
        fit = np.all(A <= (cap_of(node) + slack)[:, None], axis=0)
        return tuple(i for i in range(n) if i not in gone and fit[i])

    def relaxed_budget(node: _Node) -> float:
        """The node's budget in prices (fact (4)): its budget row, plus the owned sensors it still holds."""
        if rows is None or not owned:
            return node.budget
        return node.budget + lib.cost([i for i in rows.required if i not in node.failed])

    def knapsack_at(node: _Node, xs: tuple[int, ...], items: list[int], gains: np.ndarray) -> float:
        if rows is None:
            return knapsack_drop(gains, costs[items], node.budget, node.alpha)
        # fact (5): T = S' minus X holds the node's required sensors outside X; those inside X use the rows
        req = [i for i in rows.required if i not in node.failed]
        forced = [k for k, i in enumerate(items) if i in req]
        cap = cap_of(node) - A[:, [i for i in req if i in xs]].sum(axis=1)
        value, _ = knapsack_drop_rows(gains, A[:, items], cap, node.alpha, forced=forced, slack=slack)
        return value

    def evaluate(node: _Node) -> None:
        nonlocal sweeps, incumbent, tol
        gone = set(node.removed)
        if rows is not None:
            req = [i for i in rows.required if i not in node.failed]
            if any(i in gone for i in req) or np.any(rows.usage(req) > cap_of(node) + slack):
                node.own, node.how, node.final = 0.0, "infeasible", True  # no suite of the node keeps the limits
                return
        aff = affordable(node)
        if not aff or node.budget < 0:
            node.own, node.how, node.final = 0.0, "empty", True
            return
        fits_all = (
            lib.cost(aff) <= node.budget * (1 + 1e-12) + 1e-9
            if rows is None
            else bool(np.all(A[:, list(aff)].sum(axis=1) <= cap_of(node) + slack))
        )
        if fits_all:
            k = min(node.alpha, len(aff))
            if math.comb(len(aff), k) <= MAX_EXACT_SETS:
                node.own, node.how = (
                    worst_case(ev, aff, node.alpha, max_failure_sets=MAX_EXACT_SETS).score,
                    "exact",
                )
                if not node.failed and node.own > incumbent and (feas is None or feas.fits(aff)):
                    # nothing assumed failed: the leaf's library is a suite within the whole budget, and its
                    # worst case is achieved: a better incumbent settles the other leaves sooner
                    incumbent, tol = node.own, REL_TOL * max(1.0, abs(node.own))
            else:
                node.own, node.how = _adversary(ev, aff, node.alpha), "everything fits (greedy adversary)"
            node.final = True
            return
        best, how = math.inf, ""
        budget_p = relaxed_budget(node)
        if rows is not None:
            # the budget relaxation's own exact leaf, when it has one (fact (3) on the larger set of suites):
            # so a node is never looser than the relaxation's
            loose = tuple(i for i in range(n) if i not in gone and costs[i] <= budget_p * (1 + 1e-12) + 1e-9)
            if (
                loose
                and lib.cost(loose) <= budget_p * (1 + 1e-12) + 1e-9
                and math.comb(len(loose), min(node.alpha, len(loose))) <= MAX_EXACT_SETS
            ):
                best, how = (
                    worst_case(ev, loose, node.alpha, max_failure_sets=MAX_EXACT_SETS).score,
                    "exact (budget alone)",
                )
        tried = 0
        seen: set[tuple[int, ...]] = set()
        # anchors inside the node's library; those the node can afford first (a suite of the node)
        node_anchors = [tuple(i for i in x if i not in gone) for x in anchor_list]
        if node.alpha == 0:
            # a nominal leaf: the greedy suite of its library and budget (for the failed-sensor branch of
            # the paper's failing sensor this is Algorithm 2's own greedy run: already scored)
            run = greedy(ev, budget_p, "uniform", exclude=frozenset(node.removed))
            node_anchors.insert(0, as_suite(lib.position(i) for i in run.suite))
        node_anchors.sort(key=lambda x: lib.cost(x) > budget_p + 1e-9)  # stable: keeps the given order
        for x in [()] + node_anchors:
            xs = x
            if tried >= MAX_ANCHORS or best <= incumbent + tol:
                break
            if tried and (xs == () or xs in seen):
                continue
            seen.add(xs)
            tried += 1
            items = [i for i in aff if i not in xs]
            f_x = ev.score(xs) if xs else 0.0
            vals = singles[items] if not xs else ev.scores_with(xs, items)
            sweeps += 1 if xs else 0
            gains = np.maximum(np.asarray(vals, dtype=float) - f_x, 0.0)
            b = f_x + knapsack_at(node, xs, items, gains)
            if b < best:
                best, how = b, "knapsack at " + (",".join(lib.suite_ids(xs)) or "the empty suite")
        if node.alpha == 0 and best > incumbent + tol:
            # a nominal leaf: certify's branch and bound (its upper bound is valid even when stopped early;
            # under constraints it sees the budget alone, a relaxation)
            opt = optimal(ev, budget_p, max_nodes=LEAF_SEARCH_NODES, exclude=frozenset(node.removed))
            if opt.upper_bound < best:
                best = opt.upper_bound
                how = (
                    "nominal optimum (proved)"
                    if opt.proved_optimal
                    else f"nominal branch and bound ({opt.n_nodes} nodes)"
                )
        node.own, node.how = max(best, 0.0) if rows is not None else best, how

    counter = 0
    root = _Node(
        root_removed,
        (),
        float(budget_usd) if rows is None else float(rows.b[0]),
        int(alpha),
        cap=None if rows is None else rows.b.copy(),
    )
    evaluate(root)
    heap: list[tuple[float, int, _Node]] = [(-root.own, 0, root)]
    n_nodes = 1
    while heap:
        neg, _, node = heap[0]
        if -neg <= incumbent + tol or n_nodes + 2 > max_nodes:
            break
        heapq.heappop(heap)
        if node.final or node.alpha == 0:
            # a = 0 leaves could be split too, but a nominal bound's split is certify's business
            node.final = True
            continue
        gone = set(node.removed)
        aff_split = (
            list(affordable(node))
            if rows is not None
            else [i for i in range(n) if i not in gone and costs[i] <= node.budget + 1e-9]
        )
        e = min(aff_split, key=lambda i: (-singles[i], -costs[i], ids[i]))
        kids = [_Node(node.removed + (e,), node.failed, node.budget, node.alpha, cap=node.cap)]
        if rows is not None and node.cap is not None:
            cap = node.cap - A[:, e]
            kids.append(_Node(node.removed + (e,), node.failed + (e,), float(cap[0]), node.alpha - 1, cap=cap))
        elif costs[e] <= node.budget + 1e-9:
            kids.append(_Node(node.removed + (e,), node.failed + (e,), node.budget - float(costs[e]), node.alpha - 1))
        for k in kids:
            evaluate(k)
            n_nodes += 1
            counter += 1
            node.children.append(k)
            if not k.final:
                heapq.heappush(heap, (-k.own, counter, k))

    leaves: list[BoundLeaf] = []

    def value(node: _Node) -> float:
        if not node.children:
            leaves.append(
                BoundLeaf(
                    removed=lib.suite_ids(node.removed),
                    failed=lib.suite_ids(node.failed),
                    budget_usd=node.budget,
                    alpha=node.alpha,
                    bound=node.own,
                    how=node.how,
                )
            )
            return node.own
        return min(node.own, max(value(k) for k in node.children))

    top = value(root)
    bound = max(top, incumbent)
    return RobustBound(
        bound=float(bound),
        leaves=tuple(leaves),
        n_nodes=n_nodes,
        n_sweeps=sweeps,
        proved=bool(top <= incumbent + tol),
        n_evaluations=ev.n_evaluations - n0,
        seconds=elapsed_s(t0),
        relaxation=relaxation,
    )


def _rows_described(feas: FeasibleSet) -> str:
    """ "budget, power_w, 3 slots, sensors": the rows an integer program keeps."""
    slot = [k >= feas.n_resource_rows and nm != "sensors" for k, nm in enumerate(feas.names)]
    n_slots = sum(slot)
    named = [nm for nm, is_slot in zip(feas.names, slot) if not is_slot]
    parts = named[: feas.n_resource_rows] + ([f"{n_slots} slot{'s' if n_slots != 1 else ''}"] if n_slots else [])
    parts += named[feas.n_resource_rows :]
    if feas.required:
        parts.append("the required sensors")
    return ", ".join(parts)
