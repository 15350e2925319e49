"""An upper bound on the best achievable worst case, OPT_r = max { g_a(S) : Cost(S) <= B },
g_a(S) = min { f(S minus F) : F ⊆ S, |F| <= a }.

Three facts, each proved here (f monotone submodular, f(empty) = 0).

**(1) Knapsack with drops.** For any suite X (an *anchor*, feasible or not) and every S with
Cost(S) <= B, let D be the a sensors of S minus X with the largest gains Δ(e | X) = f(X + e) - f(X)
(all of them if fewer). D ⊆ S and |D| <= a, so

    g_a(S) <= f(S minus D) <= f(X ∪ (S minus D)) <= f(X) + Σ_{e ∈ S minus X minus D} Δ(e | X)

(monotonicity, then submodularity along any order). The right side is at most

    K_a(X, B) = f(X) + max { Σ_{e∈T} Δ(e|X) - (sum of the a largest Δ(e|X) in T) : T ⊆ V minus X, Cost(T) <= B }

a 0/1 knapsack in which the a most valuable items taken count nothing. It is solved exactly by a
dynamic program over (capacity, items dropped so far <= a), the items in decreasing gain: the first
a items a set takes in that order are its a largest (:func:`knapsack_drop`). a = 0 is the
certificate's knapsack bound U(X) of :mod:`sensorsel.certify`. One anchor costs one sweep of
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

**(4) Constraints** (:mod:`sensorsel.constraints`: resource limits, mounting slots, most sensors,
required and excluded sensors). The constrained suites are a subset of the suites within a budget
alone, so the bound of that larger problem bounds them too: the budget row is kept, every other row
dropped, the excluded sensors removed from the root's library. The budget row is the price, except
that with ``owned`` the required sensors R cost nothing: a constrained S holds R and prices
Cost(S minus R) <= B, so Cost(S) <= B + Cost(R), and the relaxation's budget is B + Cost(R). An
"exact" leaf is then the worst case of a suite that may break a dropped limit: it raises the
incumbent only when it fits them all. (An integer program over every row would be tighter; this
relaxation is valid and cheap.)

The case split is explored best-first (the leaf with the highest bound is split, on its sensor of
largest f({e})), until every leaf is at or below the incumbent (then the incumbent is optimal,
``proved``) or ``max_nodes`` nodes were made.
"""

from __future__ import annotations

import heapq
import math
import time
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from ..certify import MAX_DP_CELLS, cost_units, knapsack, optimal
from ..constraints import Constraints, feasible_set
from ..evaluators import Evaluator, as_suite
from ..resilient import check_alpha, worst_case
from ..selection import REL_TOL, check_budget, greedy
from .records import BoundLeaf, RobustBound

#: Default number of case-split nodes of the bound.
DEFAULT_BOUND_NODES = 16
#: A leaf whose whole library fits is solved exactly when it has at most this many failure sets.
MAX_EXACT_SETS = 256
#: Node limit of the nominal branch and bound run on a leaf without failures left.
LEAF_SEARCH_NODES = 30
#: Anchors tried per node (the empty suite counts one).
MAX_ANCHORS = 2


def knapsack_drop(values: Sequence[float] | np.ndarray, costs: Sequence[float] | np.ndarray, capacity: float, drop: int, *,
                  max_cells: int = MAX_DP_CELLS) -> float:
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


def _adversary(ev: Evaluator, suite: tuple[int, ...], alpha: int) -> float:
    """f after ``alpha`` greedy removals (each the one that lowers f most): an upper bound on g_alpha."""
    s = list(suite)
    for _ in range(min(alpha, len(s))):
        vals = [ev.score([i for i in s if i != x]) for x in s]
        s.remove(s[int(np.argmin(vals))])
    return ev.score(s) if s else 0.0


# Long on purpose (~110 lines): one proof, read top to bottom: the knapsack with the alpha best items
# dropped at each anchor, the case split on a dominant sensor, and the exact leaves; its docstring
# states the bound and each step cites it.
def robust_bound(evaluator: Evaluator, budget_usd: float, alpha: int, *, anchors: Sequence[Sequence[int]] = (),
                 incumbent: float = 0.0, max_nodes: int = DEFAULT_BOUND_NODES, max_anchors: int = MAX_ANCHORS,
                 max_exact_sets: int = MAX_EXACT_SETS, leaf_greedy: bool = True,
                 leaf_search_nodes: int = LEAF_SEARCH_NODES, constraints: Constraints | None = None) -> RobustBound:
    """Upper bound on max { g_alpha(S) : Cost(S) <= budget } (see the module docstring for the proof).

    Args:
        evaluator: scores suites (a :class:`~sensorsel.robust.memo.MemoEvaluator` saves re-scoring).
        anchors: suites X to anchor the knapsacks at, best first (e.g. worst-case survivors of the
            best candidates); the empty suite is always tried first.
        incumbent: a worst case already achieved [nats]: leaves at or below it are not refined. An
            "exact" leaf with no sensor assumed failed is a suite within the budget: its worst case
            raises the incumbent (and ``proved`` then refers to it).
        max_nodes: nodes of the case split (1: no split).
        leaf_search_nodes: on a leaf without failures left whose knapsack bound is above the incumbent,
            run :func:`sensorsel.certify.optimal` (excluding the removed sensors) with this node limit
            and keep its upper bound if smaller (0: never).
        leaf_greedy: anchor each leaf without failures left at a uniform greedy run on its library and budget.
        constraints: limits besides the budget: bounded through the budget-only relaxation of fact (4).
    """
    t0 = time.perf_counter()
    budget_usd, alpha = check_budget(budget_usd), check_alpha(alpha)
    ev = evaluator
    lib = ev.library
    feas = feasible_set(lib, budget_usd, constraints) if constraints is not None else None
    relaxation = ""
    root_removed: tuple[int, ...] = ()
    if feas is not None and not (feas.only_budget and not feas.required and not feas.excluded):
        extra = lib.cost(feas.required) if feas.constraints.owned else 0.0
        root_removed = tuple(sorted(feas.excluded))
        relaxation = (f"budget alone (${budget_usd + extra:,.0f}" + (" = the budget + the owned sensors' price" if extra else "")
                      + f"); dropped: {feas.constraints.describe()}")
        budget_usd = budget_usd + extra
    else:
        feas = None
    n0 = ev.n_evaluations
    costs, ids, n = lib.costs, lib.ids, len(lib)
    singles = ev.scores_with((), list(range(n)))
    anchor_list = [as_suite(a) for a in anchors]
    sweeps = 0
    tol = REL_TOL * max(1.0, abs(incumbent))

    def evaluate(node: _Node) -> None:
        nonlocal sweeps, incumbent, tol
        gone = set(node.removed)
        aff = tuple(i for i in range(n) if i not in gone and costs[i] <= node.budget * (1 + 1e-12) + 1e-9)
        if not aff or node.budget < 0:
            node.own, node.how, node.final = 0.0, "empty", True
            return
        if lib.cost(aff) <= node.budget * (1 + 1e-12) + 1e-9:
            k = min(node.alpha, len(aff))
            if math.comb(len(aff), k) <= max_exact_sets:
                node.own, node.how = worst_case(ev, aff, node.alpha, max_failure_sets=max_exact_sets).score, "exact"
                if not node.failed and node.own > incumbent and (feas is None or feas.fits(aff)):
                    # nothing assumed failed: the leaf's library is a suite within the whole budget, and its
                    # worst case is achieved: a better incumbent settles the other leaves sooner
                    incumbent, tol = node.own, REL_TOL * max(1.0, abs(node.own))
            else:
                node.own, node.how = _adversary(ev, aff, node.alpha), "everything fits (greedy adversary)"
            node.final = True
            return
        best, how = math.inf, ""
        tried = 0
        seen: set[tuple[int, ...]] = set()
        # anchors inside the node's library; those the node can afford first (a suite of the node)
        node_anchors = [tuple(i for i in x if i not in gone) for x in anchor_list]
        if node.alpha == 0 and leaf_greedy:
            # a nominal leaf: the greedy suite of its library and budget (for the failed-sensor branch of
            # the paper's failing sensor this is Algorithm 2's own greedy run: already scored)
            run = greedy(ev, node.budget, "uniform", exclude=frozenset(node.removed))
            node_anchors.insert(0, as_suite(lib.position(i) for i in run.suite))
        node_anchors.sort(key=lambda x: lib.cost(x) > node.budget + 1e-9)  # stable: keeps the given order
        for x in [()] + node_anchors:
            xs = x
            if tried >= max_anchors:
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
            b = f_x + knapsack_drop(gains, costs[items], node.budget, node.alpha)
            if b < best:
                best, how = b, "knapsack at " + (",".join(lib.suite_ids(xs)) or "the empty suite")
            if best <= incumbent + tol:
                break
        if node.alpha == 0 and leaf_search_nodes > 0 and best > incumbent + tol:
            # a nominal leaf: certify's branch and bound (its upper bound is valid even when stopped early)
            opt = optimal(ev, node.budget, max_nodes=leaf_search_nodes, exclude=frozenset(node.removed))
            if opt.upper_bound < best:
                best = opt.upper_bound
                how = "nominal optimum (proved)" if opt.proved_optimal else f"nominal branch and bound ({opt.n_nodes} nodes)"
        node.own, node.how = best, how

    counter = 0
    root = _Node(root_removed, (), float(budget_usd), int(alpha))
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
        aff = [i for i in range(n) if i not in gone and costs[i] <= node.budget + 1e-9]
        e = min(aff, key=lambda i: (-singles[i], -costs[i], ids[i]))
        kids = [_Node(node.removed + (e,), node.failed, node.budget, node.alpha)]
        if costs[e] <= node.budget + 1e-9:
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
            leaves.append(BoundLeaf(removed=lib.suite_ids(node.removed), failed=lib.suite_ids(node.failed),
                                    budget_usd=node.budget, alpha=node.alpha, bound=node.own, how=node.how))
            return node.own
        return min(node.own, max(value(k) for k in node.children))

    top = value(root)
    bound = max(top, incumbent)
    return RobustBound(bound=float(bound), leaves=tuple(leaves), n_nodes=n_nodes, n_sweeps=sweeps,
                       proved=bool(top <= incumbent + tol), n_evaluations=ev.n_evaluations - n0,
                       seconds=round(time.perf_counter() - t0, 6), relaxation=relaxation)
