"""The exact best suite within a budget, by best-first branch and bound (:func:`optimal`).

A node is a suite S with the sensors R still allowed to join it; every completion S ∪ T (T ⊆ R)
costs at most B, so T is limited to the *remaining* budget B - Cost(S), and

    f(S ∪ T) <= f(S) + max { Σ_{e ∈ T} Δ(e | S) : T ⊆ R, Cost(T) <= B - Cost(S) }

bounds the node (f monotone submodular; see :mod:`sensorsel.designs.certify.certificate`). A node whose
bound does not exceed the best suite found is dropped. The knapsacks are exact DP over the costs at
their resolution (:mod:`.knapsack`), or their LP relaxation when the table would be too large.
Deterministic for a deterministic evaluator (the wall time sits in a separate ``seconds`` field).

**Constraints** (:mod:`sensorsel.model.constraints`): the search starts from the required sensors
(S = R at the root) and never lets an excluded sensor or one that breaks a row of A x <= b join, so
every node's suite is feasible. A node's completions T must fit what S leaves of *every* row, so its
bound is f(S) + the integer program over the gains (:func:`~.knapsack.packing_bound`, HiGHS's
proved bound), and never above the budget-row knapsack (a relaxation: the other rows dropped),
which also bounds the children before their own sweep. With the budget as the only row and nothing
required or excluded, the search is exactly the single-knapsack one above.

Nothing fits: :func:`optimal` answers a budget below the cheapest sensor with the empty suite,
proved optimal, whose ``stop_reason`` says why (a library caller sweeping budgets may want it). The
CLI refuses such a request up front with :func:`sensorsel.designs.selection.check_affordable` (exit 2).
"""

from __future__ import annotations

import heapq
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sensorsel.designs.certify.certificate import certificate
from sensorsel.designs.certify.knapsack import MAX_DP_CELLS, CostUnits, cost_units, fractional_bound, packing_bound
from sensorsel.designs.certify.resume import (
    CHECKPOINT_EVERY,
    OptimalCheckpoint,
    heap_of,
    open_nodes,
    read_checkpoint,
    save_checkpoint,
    search_fingerprint,
)
from sensorsel.designs.parts import Provenance, SuiteQuality, provenance
from sensorsel.designs.selection import REL_TOL, RULES, GreedyResult, check_budget, check_rule, greedy
from sensorsel.errors import InputError
from sensorsel.information.evaluators import Evaluator
from sensorsel.io.progress import Progress, report
from sensorsel.io.records import Budget, SuiteScore
from sensorsel.io.results import result_kind
from sensorsel.model.constraints import Constraints, FeasibleSet, feasible_set
from sensorsel.model.library import SensorLibrary
from sensorsel.model.problem import TargetInfo

#: Default node limit of the exact suite search (nodes whose marginal gains are swept).
DEFAULT_MAX_NODES = 2_000

#: progress(done, total)

#: A node of the search on the heap: (-bound, tie counter, suite S (pick order), f(S), Cost(S) [units], R (candidates),
#: what S uses of each row of the feasible set (m,)).
_Node = tuple[float, int, tuple[int, ...], float, int, tuple[int, ...], np.ndarray]


@result_kind("optimum")
@dataclass(frozen=True)
class OptimumResult(SuiteQuality, Provenance, SuiteScore, Budget):
    """The best suite within a budget, found by branch and bound (proved optimal or not).

    Attributes:
        proved_optimal: True when every other suite was ruled out (up to a relative 1e-9).
        upper_bound: no suite within the budget scores above this [nats] (= score when proved): the
            smaller of the highest bound left in the search and the greedy run's certificate bound.
        gap: upper_bound - score [nats].
        gap_percent: 100 * gap / upper_bound: how much better than ``suite`` the optimum may be.
        stop_reason: why the search stopped.
        n_nodes: nodes expanded (the unit of ``max_nodes``): their marginal gains swept, or, when
            every candidate left fits the budget, the node solved by scoring S ∪ R.
        n_pruned: nodes dropped because their bound could not beat the best found.
        n_solved: nodes (among ``n_nodes``) settled by monotonicity: everything left fitted.
        n_evaluations: suites scored (including the greedy incumbent's run).
        max_nodes: the node limit.
        bound_method: how the node knapsacks were solved: "dp", "fractional" (LP relaxation, when
            the DP table was too large), with constraints also "milp" (the integer program over
            every row; "milp (node limit: dual bound)" or "lp relaxation" where HiGHS stopped early),
            each used joined by "+".
        greedy_rule: the greedy run that gave the first incumbent ("best-of (marginal)": the
            marginal run won).
        greedy_suite: its suite (ids, pick order).
        greedy_cost_usd: its cost [$].
        greedy_score: its score [nats].
        greedy_percent_of_best: 100 * greedy_score / score (of the best found).
        greedy_percent_of_bound: 100 * greedy_score / upper_bound (a guarantee even when not proved).
        greedy_certificate_bound: the greedy runs' certificate bound (:func:`certificate`; for
            best-of the smaller of the uniform and marginal runs' bounds) [nats].
        engine: the evaluator used.
        seconds, constraints: (:class:`~sensorsel.designs.parts.Provenance`'s) the wall time, the
            only field that varies between runs unless ``max_seconds`` stopped it; the limits every
            suite searched respects. Last come the suite's accuracy and integrity
            (:class:`~sensorsel.designs.parts.SuiteQuality`).
    """

    proved_optimal: bool
    upper_bound: float
    gap: float
    gap_percent: float
    stop_reason: str
    n_nodes: int
    n_pruned: int
    n_solved: int
    n_evaluations: int
    max_nodes: int
    bound_method: str
    greedy_rule: str
    greedy_suite: tuple[str, ...]
    greedy_cost_usd: float
    greedy_score: float
    greedy_percent_of_best: float
    greedy_percent_of_bound: float
    greedy_certificate_bound: float
    engine: str


def _target_info(ev: Evaluator) -> TargetInfo | None:
    """What an evaluator's target is (its problem's or domain's info), or None when it does not say."""
    target = getattr(ev, "problem", None) or getattr(ev, "domain", None)
    return getattr(target, "info", None)


def optimal(
    evaluator: Evaluator,
    budget_usd: float,
    *,
    max_nodes: int = DEFAULT_MAX_NODES,
    max_seconds: float | None = None,
    exclude: frozenset[int] = frozenset(),
    incumbent: GreedyResult | None = None,
    rule: str = "best-of",
    progress: Progress | None = None,
    info: TargetInfo | None = None,
    max_cells: int = MAX_DP_CELLS,
    constraints: Constraints | None = None,
    checkpoint: str | Path | None = None,
    resume: bool = False,
    checkpoint_every: int = CHECKPOINT_EVERY,
) -> OptimumResult:
    """The best suite within ``budget_usd`` by best-first branch and bound.

    The first incumbent is a greedy suite (``incumbent``, or a ``rule`` run now; for a strategy such
    as "best-of", every one of its component runs, keeping the one it keeps). A node is
    (S, R): the suites S ∪ T with T ⊆ R. Expanding it sweeps Δ(e | S) for e in R (one
    ``scores_with``; but when every sensor of R fits the remaining budget together, S ∪ R is the
    node's best suite by monotonicity and one evaluation settles it), drops the sensors that add
    nothing (by submodularity they add nothing to any larger suite either) or no longer fit, orders
    the rest by gain e_1, ..., e_m, and splits the node into the children (S + e_k, {e_(k+1), ..., e_m}),
    which together cover every suite of the node but S itself. Each child is bounded from the
    parent's gains, before its own sweep:

        f(S + e_k + T) <= f(S) + Δ(e_k | S) + knapsack(Δ(· | S) over e_(k+1..m), B - Cost(S) - cost(e_k))

    (all m children's knapsacks come from one DP over the items in reverse order). Nodes are expanded
    highest bound first; when the highest bound left does not beat the best suite found (by more than
    a relative 1e-9), that suite is optimal; so it is when the certificate bound of a greedy run
    (:func:`~sensorsel.designs.certify.certificate`) does not beat it. Otherwise, at the node or time limit,
    the highest bound left (or the certificate bound, if smaller) is an upper bound on the optimum.

    Args:
        budget_usd: the budget B [$].
        max_nodes: at most this many node expansions (deterministic limit).
        max_seconds: also stop after this much wall time [s] (makes the result depend on speed).
        exclude: library positions that may not be bought.
        incumbent: a greedy result to start from (must be a run on this problem).
        rule: the greedy rule or strategy (:data:`sensorsel.designs.selection.RULES`) run when ``incumbent`` is None.
        progress: called as progress(nodes_expanded, max_nodes).
        info: what the problem is, recorded in the result.
        constraints: limits besides the budget (:mod:`sensorsel.model.constraints`); None: the budget alone
            (the library's slots ignored). The greedy incumbent runs under them (a given ``incumbent``
            must have run under the same ones).
        checkpoint: a file where the greedy start, then every ``checkpoint_every`` expanded nodes the
            search's state, are kept (:mod:`.resume`); ``resume``: go on from it when its inputs match.

    Raises:
        InputError: a bad budget or limit; constraints the library cannot meet; an incumbent of
            another library, budget or constraints, or one holding an excluded sensor.
    """
    t0 = time.perf_counter()
    budget = check_budget(budget_usd)
    _check_limits(max_nodes, max_seconds)
    ev = evaluator
    lib = ev.library
    n0 = ev.n_evaluations
    exclude = frozenset(int(i) for i in exclude)
    feas = feasible_set(lib, budget, constraints if constraints is not None else Constraints(slots=False))
    plain = feas.plain
    recorded = feas.record
    path = Path(checkpoint) if checkpoint is not None else None
    # the target by content even when the caller records no info: a checkpoint is never keyed on nothing
    known = info if info is not None else _target_info(ev)
    fp = search_fingerprint(known, ev.name, budget, rule, incumbent, exclude, recorded, max_cells) if path else ""
    ck = read_checkpoint(path, fp, resume)
    if ck is not None:  # what was scored before this process counts too
        n0 -= ck.n_evaluations if ck.heap is not None else ck.n_start_evaluations
    else:
        incumbent, runs, rule_label = _greedy_start(
            ev, budget, rule, incumbent, exclude, info, None if plain else constraints, recorded
        )
        _incumbent_positions(lib, incumbent, exclude, None if plain else feas)
        # The certificates of the greedy runs bound the optimum from the start (valid whatever the search
        # does); the search can only tighten that.
        cert_bound = min(certificate(ev, r, max_cells=max_cells).bound for r in runs)
        ck = OptimalCheckpoint(fp, incumbent, rule_label, cert_bound, ev.n_evaluations - n0)
        if path is not None:
            save_checkpoint(path, ck)
    incumbent, rule_label, cert_bound = ck.incumbent, ck.rule_label, ck.cert_bound
    inc_pos = _incumbent_positions(lib, incumbent, exclude, None if plain else feas)
    best = _Best(
        lib, inc_pos, _score_of(ev, incumbent, inc_pos), _budget_use(lib, feas, plain, inc_pos), None if plain else feas
    )
    search = _Search(
        ev,
        cost_units(lib.costs if plain else feas.A[0], budget),
        best,
        exclude,
        cert_bound,
        max_cells,
        None if plain else feas,
    )
    if ck.heap is not None:  # go on from the stored state
        search.heap = heap_of(ck.heap)
        search.nodes, search.pruned, search.solved, search.counter = ck.nodes, ck.pruned, ck.solved, ck.counter
        search.methods = set(ck.methods)
        best.suite, best.score, best.cost = tuple(ck.best_suite), ck.best_score, ck.best_cost

    def keep(search: _Search) -> None:  # the state after every checkpoint_every nodes
        assert path is not None
        save_checkpoint(
            path,
            OptimalCheckpoint(
                fp,
                incumbent,
                rule_label,
                cert_bound,
                ck.n_start_evaluations,
                search.nodes,
                search.pruned,
                search.solved,
                search.counter,
                tuple(sorted(search.methods)),
                best.suite,
                best.score,
                best.cost,
                open_nodes(search.heap),
                ev.n_evaluations - n0,
            ),
        )

    stop = search.run(max_nodes, max_seconds, t0, progress, keep if path is not None else None, checkpoint_every)
    proved = not search.heap
    if proved:
        stop = "every other suite ruled out by its bound"
        if not best.suite and not incumbent.suite and incumbent.stop_reason:
            stop = f"the empty suite is the best: {incumbent.stop_reason}"  # e.g. a budget below the cheapest sensor
        upper = best.score
    else:
        upper = max(best.score, min(-search.heap[0][0], cert_bound))
    gap = max(0.0, upper - best.score)
    g_score = _score_of(ev, incumbent, inc_pos)
    return OptimumResult(
        budget_usd=budget,
        suite=lib.suite_ids(best.suite),
        cost_usd=best.cost,
        score=best.score,
        proved_optimal=proved,
        upper_bound=upper,
        gap=gap,
        gap_percent=100.0 * gap / upper if upper > 0 else 0.0,
        stop_reason=stop,
        n_nodes=search.nodes,
        n_pruned=search.pruned,
        n_solved=search.solved,
        n_evaluations=ev.n_evaluations - n0,
        max_nodes=max_nodes,
        bound_method="+".join(sorted(search.methods)) or "none",
        greedy_rule=rule_label,
        greedy_suite=incumbent.suite,
        greedy_cost_usd=incumbent.cost_usd,
        greedy_score=g_score,
        greedy_percent_of_best=100.0 * g_score / best.score if best.score > 0 else 100.0,
        greedy_percent_of_bound=100.0 * g_score / upper if upper > 0 else 100.0,
        greedy_certificate_bound=cert_bound,
        engine=ev.name,
        **provenance(info, t0, recorded),
    )


def _check_limits(max_nodes: object, max_seconds: object) -> None:
    if isinstance(max_nodes, bool) or not isinstance(max_nodes, int) or max_nodes < 1:
        raise InputError(f"max_nodes must be a positive integer, got {max_nodes!r}")
    if max_seconds is not None and not (isinstance(max_seconds, (int, float)) and max_seconds > 0):
        raise InputError(f"max_seconds must be a positive number of seconds, got {max_seconds!r}")


def _greedy_start(
    ev: Evaluator,
    budget: float,
    rule: str,
    incumbent: GreedyResult | None,
    exclude: frozenset[int],
    info: TargetInfo | None,
    constraints: Constraints | None = None,
    recorded: Constraints | None = None,
) -> tuple[GreedyResult, list[GreedyResult], str]:
    """(the first incumbent, the greedy runs whose certificates bound the optimum, its label).

    Without ``incumbent``: every component run of ``rule`` is kept (not only the one the rule keeps),
    so that each certificate bounds the optimum; the label is e.g. "best-of (marginal)". The runs
    respect ``constraints``; a given incumbent must record ``recorded`` (its certificate bounds the
    suites of its own constraints, which must be the search's).
    """
    if incumbent is None:
        entry = RULES[check_rule(rule)]
        runs = [
            greedy(ev, budget, r, exclude=exclude, info=info, constraints=constraints) for r in entry.component_rules
        ]
        kept = entry.keep(runs)
        return kept, runs, rule if kept.winning_rule == rule else f"{rule} ({kept.winning_rule})"
    if abs(incumbent.budget_usd - budget) > 1e-9 * max(1.0, budget):
        raise InputError(f"the incumbent greedy run has budget ${incumbent.budget_usd:,.0f}, not ${budget:,.0f}")
    if incumbent.constraints != recorded:
        theirs = incumbent.constraints.describe() if incumbent.constraints else "the budget alone"
        ours = recorded.describe() if recorded else "the budget alone"
        raise InputError(f"the incumbent greedy run respected {theirs}, not the search's {ours}")
    return incumbent, [incumbent], incumbent.rule_label


def _incumbent_positions(
    lib: SensorLibrary, incumbent: GreedyResult, exclude: frozenset[int], feas: FeasibleSet | None = None
) -> tuple[int, ...]:
    """The incumbent's suite as sorted library positions; refuses foreign or excluded sensors, and
    (with ``feas``) a suite outside the feasible set."""
    try:
        inc_pos = tuple(sorted(lib.position(x) for x in incumbent.suite))
    except InputError as exc:
        raise InputError(f"the incumbent greedy run does not belong to this library: {exc}") from None
    if set(inc_pos) & exclude:
        raise InputError("the incumbent greedy suite contains an excluded sensor")
    if feas is not None and not feas.fits(inc_pos):
        raise InputError(f"the incumbent greedy suite breaks the constraints: {'; '.join(feas.violations(inc_pos))}")
    return inc_pos


def _budget_use(lib: SensorLibrary, feas: FeasibleSet, plain: bool, suite: tuple[int, ...]) -> float:
    """What ``suite`` uses of the budget [$] (owned sensors not counted)."""
    return lib.cost(suite) if plain else float(feas.usage(suite)[0])


def _score_of(ev: Evaluator, run: GreedyResult, positions: tuple[int, ...]) -> float:
    """f of a greedy run's suite with ``ev``: the run's own number when it used the same engine."""
    return run.score if run.engine == ev.name else (ev.score(positions) if positions else 0.0)


def _tol(x: float) -> float:
    return REL_TOL * max(1.0, abs(x))


class _Best:
    """The best suite found so far (sorted positions), its score and cost (what it uses of the budget)."""

    def __init__(
        self, lib: SensorLibrary, suite: tuple[int, ...], score: float, cost: float, feas: FeasibleSet | None = None
    ) -> None:
        self.lib, self.suite, self.score, self.cost, self.feas = lib, suite, score, cost, feas

    def rules_out(self, bound: float) -> bool:
        """True when a bound cannot beat the best score by more than a relative 1e-9."""
        return bound <= self.score + _tol(self.score)

    def offer(self, suite: tuple[int, ...], score: float) -> None:
        """Keep ``suite`` if it scores higher (ties to round-off: the cheaper, then the smaller positions)."""
        s = tuple(sorted(suite))
        c = self.lib.cost(s) if self.feas is None else float(self.feas.usage(s)[0])
        if score > self.score + _tol(self.score) or (
            abs(score - self.score) <= _tol(self.score) and (c, s) < (self.cost, self.suite)
        ):
            self.suite, self.score, self.cost = s, score, c


def _gap_text(best: float, upper: float) -> str:
    """The search's standing in words: best score and upper bound [nats], their gap [%]."""
    if not math.isfinite(best):
        return f"no suite yet, bound {upper:,.3f} nats"
    gap = 100.0 * max(0.0, upper - best) / upper if upper > 0 else 0.0
    return f"best {best:,.3f} nats, bound {upper:,.3f}, gap {gap:.2f}%"


class _Search:
    """The state of the best-first search: the heap of open nodes and the counts the result reports."""

    def __init__(
        self,
        ev: Evaluator,
        units: CostUnits,
        best: _Best,
        exclude: frozenset[int],
        cert_bound: float,
        max_cells: int,
        feas: FeasibleSet | None = None,
    ) -> None:
        self.ev, self.units, self.best, self.cert_bound, self.max_cells = ev, units, best, cert_bound, max_cells
        self.feas = feas
        self.costs = ev.library.costs if feas is None else feas.A[0]
        self.methods: set[str] = set()
        self.counter = 0
        self.nodes = self.pruned = self.solved = 0
        if feas is None:
            root_s: tuple[int, ...] = ()
            f_root, used = 0.0, np.zeros(1)
            fits = np.ones(len(self.costs), dtype=bool)
            out = set(exclude)
        else:  # the root holds the required sensors: every suite does
            root_s = tuple(feas.required)
            f_root = ev.score(root_s) if root_s else 0.0
            used = feas.usage(root_s)
            fits = self._fits(used)
            out = set(exclude) | set(root_s) | set(feas.excluded)
        c_root = int(units.costs[list(root_s)].sum()) if root_s else 0
        root_r = tuple(
            i for i in range(len(self.costs)) if i not in out and fits[i] and units.costs[i] <= units.capacity - c_root
        )
        self.heap: list[_Node] = [(-math.inf, 0, root_s, f_root, c_root, root_r, used)]

    def _fits(self, used: np.ndarray) -> np.ndarray:
        """(n,) bool: the sensors that fit every row on top of a suite using ``used`` (with constraints)."""
        assert self.feas is not None
        return self.feas.addable(used)

    def run(
        self,
        max_nodes: int,
        max_seconds: float | None,
        t0: float,
        progress: Progress | None,
        keep: Callable[[_Search], None] | None = None,
        every: int = CHECKPOINT_EVERY,
    ) -> str:
        """Expand nodes, highest bound first, until none can beat the best found or a limit stops it
        (returns the limit's stop reason, "" when the search finished). ``keep(self)`` after every
        ``every`` expanded nodes (a checkpoint)."""
        heap = self.heap
        while heap:
            if keep is not None and self.nodes and self.nodes % every == 0:
                keep(self)
            neg_ub = heap[0][0]
            if self.best.rules_out(min(-neg_ub, self.cert_bound)):
                self.pruned += len(heap)
                heap.clear()
                break
            if self.nodes >= max_nodes:
                return f"node limit ({max_nodes:,}) reached"
            if max_seconds is not None and time.perf_counter() - t0 > max_seconds:
                return f"time limit ({max_seconds:g} s) reached"
            node = heapq.heappop(heap)
            self.nodes += 1
            if progress:  # where the search stands: the best suite found and the bound still open above it
                upper = max(self.best.score, min(-neg_ub, self.cert_bound))
                report(progress, self.nodes, max_nodes, _gap_text(self.best.score, upper))
            self._expand(node)
        return ""

    def _expand(self, node: _Node) -> None:
        """Settle the node whole, or sweep its candidates' gains and push the children that may beat the best."""
        neg_ub, _, s, f_s, c_s, r, used = node
        ev, w_all, feas = self.ev, self.units.costs, self.feas
        room = self.units.capacity - c_s
        r = tuple(e for e in r if w_all[e] <= room)  # what fitted the parent may not fit here
        if feas is not None:
            fits = self._fits(used)
            r = tuple(e for e in r if fits[e])
        if len(r) > 1 and int(w_all[list(r)].sum()) <= room and (feas is None or feas.fits(s + r)):
            # everything left fits: by monotonicity S ∪ R is the node's best suite (one evaluation)
            self.best.offer(s + r, ev.score(s + r))
            self.solved += 1
            return
        vals = ev.scores_with(s, list(r)) if r else np.zeros(0)
        for e, v in zip(r, vals):
            self.best.offer(s + (e,), float(v))
        gains = vals - f_s
        keep = [k for k in range(len(r)) if gains[k] > _tol(f_s) and w_all[r[k]] <= room]
        # order: largest gain first; ties: cheaper, then library order
        keep.sort(key=lambda k: (-gains[k], self.costs[r[k]], r[k]))
        if keep:
            self._branch(s, f_s, c_s, int(room), -neg_ub, [r[k] for k in keep], gains[keep], vals[keep], used)

    def _branch(
        self,
        s: tuple[int, ...],
        f_s: float,
        c_s: int,
        room: int,
        parent_ub: float,
        items: list[int],
        g: np.ndarray,
        f_with: np.ndarray,
        used: np.ndarray,
    ) -> None:
        """Bound the node from its gains ``g`` at S (items in branching order) and push its children
        (S + e_k, items after k) whose bound can beat the best found."""
        g = np.asarray(g, dtype=float)
        w = np.array([self.units.costs[i] for i in items], dtype=np.int64)
        node_ub, child_ub, method = _node_bounds(
            g, w, room, f_s, self.max_cells, [self.costs[i] for i in items], self.units.unit_usd
        )
        self.methods.add(method)
        node_ub = min(node_ub, parent_ub)
        feas = self.feas
        if feas is not None and not self.best.rules_out(node_ub):
            # every row at once: the integer program over the gains (the budget-row DP is its relaxation)
            ip = packing_bound(g, feas.A[:, items], feas.b - used)
            self.methods.add(ip.method)
            node_ub = min(node_ub, f_s + ip.value)
        if self.best.rules_out(node_ub):
            self.pruned += 1
            return
        for k in range(len(items)):
            ub = min(child_ub[k], node_ub)
            rest = tuple(items[k + 1 :])
            if not rest or self.best.rules_out(ub):
                self.pruned += 1 if rest else 0
                continue
            self.counter += 1
            child_used = used if feas is None else used + feas.A[:, items[k]]
            heapq.heappush(
                self.heap, (-ub, self.counter, s + (items[k],), float(f_with[k]), c_s + int(w[k]), rest, child_used)
            )


def _node_bounds(
    gains: np.ndarray, w: np.ndarray, room: int, f_s: float, max_cells: int, costs_usd: list[float], unit_usd: float
) -> tuple[float, np.ndarray, str]:
    """Bounds of a node and of its children from the gains at S (items in branching order).

    Returns (node bound f(S) + KS(all items, room), child bounds f(S) + g_k + KS(items after k,
    room - w_k), method). Exact DP over the items in reverse order when the table fits in
    ``max_cells``: after adding items m..k+1 the table holds every suffix knapsack at every capacity.
    Else fractional (LP) bounds, which are larger but still valid.
    """
    m = len(gains)
    child = np.empty(m)
    if m * (room + 1) <= max_cells:
        dp = np.zeros(room + 1)
        for k in range(m - 1, -1, -1):
            wk = int(w[k])
            child[k] = f_s + gains[k] + dp[room - wk]
            if wk == 0:
                dp += gains[k]
                continue
            cand = dp[: room + 1 - wk] + gains[k]
            dp[wk:] = np.maximum(dp[wk:], cand)
        return f_s + float(dp[room]), child, "dp"
    c = np.asarray(costs_usd, dtype=float)
    room_usd = room * unit_usd
    for k in range(m):
        child[k] = f_s + gains[k] + fractional_bound(gains[k + 1 :], c[k + 1 :], room_usd - c[k])
    return f_s + fractional_bound(gains, c, room_usd), child, "fractional"
