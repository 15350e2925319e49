"""How far from the best possible suite? A certificate for every greedy answer, and the exact optimum.

The score f(S) = log det L(S) - log det L(empty) is monotone and submodular in the suite S (each
sensor adds a positive semi-definite block to the information matrix L; log det of such a sum has
diminishing returns; ``tests/test_properties.py`` checks it). For such an f and any suite S:

    f(OPT) <= f(S ∪ OPT) <= f(S) + Σ_{e ∈ OPT \\ S} Δ(e | S),      Δ(e | S) = f(S + e) - f(S) >= 0

(monotonicity, then submodularity along any order of OPT \\ S). OPT \\ S costs at most the budget
B, and nothing more is known about it, so the sum is at most the best 0/1 knapsack of the marginal
gains over the sensors outside S with capacity **B** (not B - Cost(S): OPT need not contain S, so
the sensors it adds to S may use the whole budget). This is the "online bound" of Leskovec et al.
(2007) with the knapsack solved exactly instead of by its fractional relaxation:

    U(S) = f(S) + max { Σ_{e ∈ T} Δ(e | S) : T ⊆ V \\ S, Cost(T) <= B }  >=  f(OPT)

:func:`certificate` keeps the smallest U over the empty suite and every intermediate suite of a
greedy run (one sweep of ``scores_with`` per suite, skipping the suites whose U provably cannot be
smaller). The greedy suite then scores at
least ``score / bound`` of the best possible.

:func:`optimal` finds the best suite exactly by best-first branch and bound. A node is a suite S
with the sensors R still allowed to join it; every completion S ∪ T (T ⊆ R) costs at most B, so
T is limited to the *remaining* budget B - Cost(S), and

    f(S ∪ T) <= f(S) + max { Σ_{e ∈ T} Δ(e | S) : T ⊆ R, Cost(T) <= B - Cost(S) }

bounds the node. A node whose bound does not exceed the best suite found is dropped.

Knapsacks are solved exactly by dynamic programming over costs in units of the library's cost
resolution (the gcd of the costs, after scaling them to integers); when the table would be too
large, by an exact branch and bound with a node limit, whose unfinished search still gives a valid
upper bound (never below the true maximum); inside the exact search, by the LP relaxation (a
valid, looser bound). Which one was used is recorded.

Everything here is deterministic for a deterministic evaluator: same inputs, same bytes out (the
wall time sits in a separate ``seconds`` field). Numbers are exact up to floating-point round-off of
the scores (relative ~1e-12); a gain below round-off counts as zero.
"""

from __future__ import annotations

import heapq
import math
import time
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from .errors import InputError
from .evaluators import Evaluator, make_evaluator
from .pipeline import ProblemInfo
from .problem import Problem
from .selection import REL_TOL, Certificate, GreedyResult, better_run, check_budget, greedy

#: Largest dynamic-programming table (items x capacity cells) solved by DP; above it, branch and bound.
MAX_DP_CELLS = 50_000_000
#: Node limit of the knapsack branch and bound used when the DP table is too large.
MAX_KNAPSACK_NODES = 200_000
#: Default node limit of the exact suite search (nodes whose marginal gains are swept).
DEFAULT_MAX_NODES = 2_000
#: Decimal scales tried to make costs integral ($1, 10 cents, 1 cent, ... 1 micro-dollar).
_COST_SCALES = tuple(10**k for k in range(7))

#: progress(done, total)
Progress = Callable[[int, int], None]


# ------------------------------------------------------------------------------------- knapsack


@dataclass(frozen=True)
class CostUnits:
    """Costs as integers in units of the cost resolution.

    Attributes:
        costs: (n,) integer costs [units].
        capacity: the capacity [units], rounded down (a set of items fits in the real capacity
            iff its integer cost fits in this one, when ``exact``).
        unit_usd: one unit [$] (gcd of the scaled costs / scale).
        exact: False when the costs were not decimal numbers with <= 6 digits after the point and
            were rounded *down* to micro-dollars: the knapsack is then a relaxation (its value an
            upper bound, never below the true maximum).
    """

    costs: np.ndarray
    capacity: int
    unit_usd: float
    exact: bool


def cost_units(costs: Sequence[float], capacity: float) -> CostUnits:
    """Express ``costs`` [$] and ``capacity`` [$] as integers at their resolution (gcd of the costs)."""
    c = np.asarray(costs, dtype=float).reshape(-1)
    if np.any(~np.isfinite(c)) or np.any(c < 0):
        raise InputError(f"knapsack costs must be finite and non-negative, got {c.tolist()!r}")
    if not math.isfinite(capacity) or capacity < 0:
        raise InputError(f"knapsack capacity must be finite and non-negative, got {capacity!r}")
    exact = False
    for scale in _COST_SCALES:
        scaled = c * scale
        if np.all(np.abs(scaled - np.round(scaled)) <= 1e-7 * np.maximum(1.0, scaled)):
            ints = np.round(scaled).astype(np.int64)
            exact = True
            break
    else:  # not decimal: round down, which only enlarges the feasible sets (a relaxation)
        scale = _COST_SCALES[-1]
        ints = np.floor(c * scale).astype(np.int64)
    g = int(np.gcd.reduce(ints[ints > 0])) if np.any(ints > 0) else 1
    # A tiny slack so that a budget equal to a sum of costs is not lost to float round-off.
    cap = int(math.floor(capacity * scale * (1 + 1e-12) + 1e-6)) // g
    return CostUnits(ints // g, cap, g / scale, exact)


@dataclass(frozen=True)
class KnapsackSolution:
    """A 0/1 knapsack solution.

    Attributes:
        value: the maximum of Σ values over item sets within the capacity (``exact``), or an upper
            bound on it (never below the maximum).
        chosen: positions of the items of the best set found, ascending.
        achieved: Σ values of ``chosen`` (equals ``value`` when exact).
        method: "trivial" (nothing or everything fits), "dp", "branch-and-bound", or
            "branch-and-bound (node limit: bound)" when the search stopped at its node limit.
        exact: whether ``value`` is the exact maximum.
    """

    value: float
    chosen: tuple[int, ...]
    achieved: float
    method: str
    exact: bool


def knapsack(values: Sequence[float], costs: Sequence[float], capacity: float, *,
             max_cells: int = MAX_DP_CELLS, max_nodes: int = MAX_KNAPSACK_NODES) -> KnapsackSolution:
    """max Σ_{i ∈ T} values[i] subject to Σ_{i ∈ T} costs[i] <= capacity, over sets T of items.

    Items with a value <= 0 or a cost above the capacity are never taken. Exact dynamic programming
    over costs at their resolution when items x capacity cells <= ``max_cells``; else an exact branch
    and bound (fractional bounds, items by value density), which returns a valid upper bound if it
    reaches ``max_nodes``.

    Args:
        values: (n,) item values (any unit; here nats).
        costs: (n,) item costs [$], >= 0.
        capacity: [$].
    """
    v = np.asarray(values, dtype=float).reshape(-1)
    c = np.asarray(costs, dtype=float).reshape(-1)
    if v.shape != c.shape:
        raise InputError(f"knapsack: {len(v)} values but {len(c)} costs")
    if np.any(~np.isfinite(v)):
        raise InputError(f"knapsack values must be finite, got {v.tolist()!r}")
    units = cost_units(c, capacity)
    keep = np.flatnonzero((v > 0) & (units.costs <= units.capacity))
    if len(keep) == 0:
        return KnapsackSolution(0.0, (), 0.0, "trivial", True)
    w = units.costs[keep]
    if int(w.sum()) <= units.capacity:
        total = float(v[keep].sum())
        return KnapsackSolution(total, tuple(int(i) for i in keep), total, "trivial", units.exact)
    cap = int(min(units.capacity, w.sum()))
    if len(keep) * (cap + 1) <= max_cells:
        value, chosen = _knapsack_dp(v[keep], w, cap)
        picked = tuple(int(keep[i]) for i in chosen)
        return KnapsackSolution(value, picked, float(v[list(picked)].sum()), "dp", units.exact)
    # Branch and bound on the real costs (no integer table needed).
    best, chosen, upper, done = _knapsack_bnb(v[keep], c[keep], capacity, max_nodes)
    picked = tuple(sorted(int(keep[i]) for i in chosen))
    if done:
        return KnapsackSolution(best, picked, best, "branch-and-bound", True)
    return KnapsackSolution(upper, picked, best, "branch-and-bound (node limit: bound)", False)


def _knapsack_dp(values: np.ndarray, costs: np.ndarray, capacity: int) -> tuple[float, list[int]]:
    """Exact 0/1 knapsack by DP over integer capacity 0..capacity: (max value, chosen item positions).

    dp[c] = best value with total cost <= c; one vectorised pass per item, a boolean table for the
    reconstruction. Ties keep the earlier items' solution, so the answer is deterministic.
    """
    n = len(values)
    dp = np.zeros(capacity + 1)
    take = np.zeros((n, capacity + 1), dtype=bool)
    for k in range(n):
        wk, vk = int(costs[k]), float(values[k])
        if wk == 0:
            dp += vk
            take[k, :] = True
            continue
        cand = dp[: capacity + 1 - wk] + vk
        better = cand > dp[wk:]
        take[k, wk:] = better
        dp[wk:] = np.where(better, cand, dp[wk:])
    chosen = []
    cap = capacity
    for k in range(n - 1, -1, -1):
        if take[k, cap]:
            chosen.append(k)
            cap -= int(costs[k])
    return float(dp[capacity]), sorted(chosen)


def _fractional_bound(values: np.ndarray, costs: np.ndarray, capacity: float) -> float:
    """The LP relaxation of the knapsack (Dantzig): items by value density, the last one in part.

    An upper bound on the 0/1 maximum. Items must have positive values; zero-cost items are taken.
    """
    free = costs <= 0
    total = float(values[free].sum())
    v, c = values[~free], costs[~free]
    order = np.lexsort((np.arange(len(v)), -(v / c)))
    room = capacity
    for i in order:
        if c[i] <= room:
            total += float(v[i])
            room -= float(c[i])
        else:
            total += float(v[i]) * room / float(c[i])
            break
    return total


def _knapsack_bnb(values: np.ndarray, costs: np.ndarray, capacity: float, max_nodes: int) -> tuple[float, list[int], float, bool]:
    """Exact 0/1 knapsack by depth-first branch and bound with fractional bounds (Horowitz-Sahni).

    Returns (best value, its items, an upper bound on the maximum, finished). When the node limit
    stops the search, the upper bound is the largest fractional bound of the unexplored nodes (or the
    best found, if larger): every unexplored set of items lies under one of them.
    """
    n = len(values)
    order = [int(i) for i in np.lexsort((np.arange(n), -(values / np.maximum(costs, 1e-300))))]
    v = values[order]
    c = costs[order]
    slack = 1e-9 * max(1.0, capacity)

    def bound(k: int, room: float, val: float) -> float:
        return val + _fractional_bound(v[k:], c[k:], room) if k < n else val

    best, best_set = 0.0, []
    # stack of (next item, room left, value so far, items taken, bound)
    stack = [(0, capacity, 0.0, (), bound(0, capacity, 0.0))]
    nodes = 0
    while stack:
        k, room, val, taken, ub = stack.pop()
        if ub <= best:
            continue
        if k == n:
            continue
        nodes += 1
        if nodes > max_nodes:
            stack.append((k, room, val, taken, ub))
            upper = max([best] + [s[4] for s in stack if s[4] > best])
            return best, [order[i] for i in best_set], upper, False
        # exclude item k (pushed first: explored after the include branch)
        ub_out = bound(k + 1, room, val)
        if ub_out > best:
            stack.append((k + 1, room, val, taken, ub_out))
        if c[k] <= room + slack:
            val_in = val + float(v[k])
            taken_in = taken + (k,)
            if val_in > best:
                best, best_set = val_in, list(taken_in)
            ub_in = bound(k + 1, room - float(c[k]), val_in)
            if ub_in > best:
                stack.append((k + 1, room - float(c[k]), val_in, taken_in, ub_in))
    return best, [order[i] for i in best_set], best, True


# -------------------------------------------------------------------------------- the certificate


@dataclass(frozen=True)
class SuiteBound:
    """The submodular upper bound U(S) on the best possible score, evaluated at one suite S.

    Attributes:
        suite: ids of S.
        score: f(S) [nats].
        bound: U(S) = f(S) + the knapsack of the marginal gains with capacity the budget [nats].
        knapsack_suite: ids of the sensors of the best knapsack (what the bound "adds" to S).
        knapsack_method: how the knapsack was solved (see :class:`KnapsackSolution`).
        knapsack_exact: whether the knapsack value is its exact maximum (else an upper bound).
    """

    suite: tuple[str, ...]
    score: float
    bound: float
    knapsack_suite: tuple[str, ...]
    knapsack_method: str
    knapsack_exact: bool


def suite_bound(evaluator: Evaluator, suite: Sequence[int], budget_usd: float, *, score: float | None = None,
                exclude: frozenset[int] = frozenset(), max_cells: int = MAX_DP_CELLS,
                gains_out: np.ndarray | None = None) -> SuiteBound:
    """U(S) >= f(OPT) for the best suite OPT within ``budget_usd`` (see the module docstring).

    Costs one sweep: ``scores_with(S, every sensor outside S that fits the budget)``. Negative gains (round-off of a
    sensor that adds nothing) count as zero, which can only raise the bound.

    Args:
        suite: library positions of S.
        budget_usd: the budget B [$]; the knapsack capacity is all of B.
        score: f(S) if already known [nats] (saves one evaluation).
        exclude: sensors that may not join (e.g. assumed failed); leaving them in only loosens the bound.
        gains_out: (n_sensors,) array; the swept sensors' marginal gains Δ(e | S) [nats] are written
            into it (others left as they are).
    """
    budget = check_budget(budget_usd)
    lib = evaluator.library
    s = tuple(int(i) for i in suite)
    f_s = evaluator.score(s) if score is None else float(score)
    inside = set(s) | set(exclude)
    costs = lib.costs
    # a sensor dearer than the whole budget is in no feasible T: no need to score it
    cand = [i for i in range(len(lib)) if i not in inside and costs[i] <= budget * (1 + 1e-12) + 1e-9]
    gains = np.maximum(evaluator.scores_with(s, cand) - f_s, 0.0) if cand else np.zeros(0)
    if gains_out is not None:
        gains_out[cand] = gains
    ks = knapsack(gains, costs[cand], budget, max_cells=max_cells)
    return SuiteBound(
        suite=lib.suite_ids(s), score=f_s, bound=f_s + ks.value,
        knapsack_suite=lib.suite_ids(sorted(cand[i] for i in ks.chosen)),
        knapsack_method=ks.method, knapsack_exact=ks.exact,
    )


def certificate(evaluator: Evaluator, greedy_result: GreedyResult, *, progress: Progress | None = None,
                max_cells: int = MAX_DP_CELLS, prune: bool = True) -> Certificate:
    """Certify a greedy run: an upper bound on the best possible score within its budget.

    The bound is the smallest U(S) (:func:`suite_bound`) over the empty suite and every
    ``greedy_result.steps`` suite. Valid for any suite the greedy returned, whatever its rule; with
    starting sensors or exclusions the bound over the whole library is still an upper bound (on a
    larger set of suites).

    Sweeps run from the final suite backwards. With ``prune``, a step is swept only if it could
    lower the bound: submodularity gives lower bounds on its marginal gains (a sensor's gain at S_k
    is at least its gain at any later, larger S_m already swept, and a later pick's gain at S_k is
    at least the gain it was bought with), so f(S_k) + the knapsack of those lower bounds is a lower
    bound on U(S_k); when it is not below the smallest U found (to a relative 1e-9), U(S_k) cannot
    improve the certificate and its sweep is skipped. On KITTI 03 and 00 at $110,000 this leaves
    two sweeps of eleven to fourteen (the final suite and the empty one). ``prune=False`` sweeps
    every step.

    Raises:
        InputError: the result names sensors that are not in the evaluator's library.
    """
    t0 = time.perf_counter()
    lib = evaluator.library
    n0 = evaluator.n_evaluations
    res = greedy_result
    budget = check_budget(res.budget_usd)
    try:
        step_suites = [()] + [tuple(lib.position(x) for x in st.suite) for st in res.steps]
    except InputError as exc:
        raise InputError(f"the greedy result does not belong to this library: {exc}") from None
    n_steps = len(step_suites)
    # f at each suite: the run's own numbers when it used this engine (no re-evaluation)
    if res.engine == evaluator.name:
        step_scores = [0.0] + [st.score for st in res.steps]
    else:
        step_scores = [0.0] + [evaluator.score(s) for s in step_suites[1:]]
    # step j bought one sensor on top of step j - 1 (not so from the empty suite to a run's first
    # step when it started from given sensors): its gain there is a lower bound on its gain earlier
    later_picks = [(step_suites[j][-1], step_scores[j] - step_scores[j - 1]) if step_suites[j][:-1] == step_suites[j - 1]
                   else None for j in range(1, n_steps)]
    costs = lib.costs
    gain_low = np.zeros(len(lib))  # lower bounds on each sensor's gain at the step being looked at
    bounds: list[SuiteBound | None] = [None] * n_steps
    best = math.inf
    for done, k in enumerate(range(n_steps - 1, -1, -1), start=1):
        s = step_suites[k]
        if prune and math.isfinite(best):
            low = gain_low.copy()
            for pick_gain in later_picks[k:]:  # sensors bought after step k
                if pick_gain is not None:
                    low[pick_gain[0]] = max(low[pick_gain[0]], pick_gain[1])
            inside = set(s)
            out = [i for i in range(len(lib)) if i not in inside and costs[i] <= budget * (1 + 1e-12) + 1e-9]
            lower = step_scores[k] + knapsack(np.maximum(low[out], 0.0), costs[out], budget, max_cells=max_cells).value
            if lower >= best - REL_TOL * max(1.0, abs(best)):
                if progress:
                    progress(done, n_steps)
                continue
        gains = np.zeros(len(lib))
        b = suite_bound(evaluator, s, budget, score=step_scores[k], max_cells=max_cells, gains_out=gains)
        np.maximum(gain_low, gains, out=gain_low)
        bounds[k] = b
        best = min(best, b.bound)
        if progress:
            progress(done, n_steps)
    final = tuple(lib.position(x) for x in res.suite)
    score = res.score if res.engine == evaluator.name else (evaluator.score(final) if final else 0.0)
    swept = [k for k in range(n_steps) if bounds[k] is not None]
    k_best = min(swept, key=lambda k: (bounds[k].bound, k))  # first of equal minima: deterministic
    # U(S) >= f(OPT) >= score in exact arithmetic; round-off could put U a hair below: keep it valid.
    bound = max(bounds[k_best].bound, score)
    ratio = 1.0 if bound <= 0 else min(1.0, max(0.0, score / bound))
    methods = sorted({bounds[k].knapsack_method for k in swept})
    return Certificate(
        objective=res.objective, budget_usd=res.budget_usd, suite=res.suite, cost_usd=res.cost_usd, score=score,
        bound=bound, ratio=ratio, percent_of_best=100.0 * ratio, gap=bound - score, bound_step=k_best,
        bound_suite=bounds[k_best].suite, step_bounds=tuple(None if b is None else b.bound for b in bounds),
        knapsack_method="+".join(methods), knapsack_exact=all(bounds[k].knapsack_exact for k in swept),
        n_evaluations=evaluator.n_evaluations - n0, engine=evaluator.name, problem=res.problem,
        seconds=round(time.perf_counter() - t0, 6),
    )


def certify_greedy(source: Evaluator | Problem, result: GreedyResult, *, jobs: int = 1,
                   progress: Progress | None = None) -> Certificate:
    """The certificate of a greedy result (what ``sensorsel greedy`` prints); see :func:`certificate`.

    Args:
        source: the evaluator the run used, or its problem (then a fresh evaluator of the run's
            engine is made, with ``jobs`` processes).
    """
    ev = source if isinstance(source, Evaluator) else make_evaluator(source, result.engine, jobs=jobs)
    return certificate(ev, result, progress=progress)


def format_certificate(cert: Certificate) -> str:
    """One line: 'certificate: at least 97.3% of the best possible suite under $110,000 (...)'."""
    where = "the empty suite" if cert.bound_step == 0 else f"step {cert.bound_step} of {len(cert.step_bounds) - 1}"
    return (
        f"certificate: at least {_pct(cert.percent_of_best)}% of the best possible suite under ${cert.budget_usd:,.0f} "
        f"(f = {cert.score:.3f} nats; best possible <= {cert.bound:.3f} nats, bound from {where}; "
        f"{cert.n_evaluations:,} evaluations, {cert.seconds:.1f} s)"
    )


def _pct(p: float) -> str:
    """A percentage with one decimal, never rounded up to 100.0 unless it is 100."""
    if p >= 100.0:
        return "100"
    return f"{math.floor(p * 10) / 10:.1f}"


# --------------------------------------------------------------------------- exact optimum (B&B)


@dataclass(frozen=True)
class OptimumResult:
    """The best suite within a budget, found by branch and bound (proved optimal or not).

    Attributes:
        budget_usd: the budget B [$].
        suite: ids of the best suite found, in library order.
        cost_usd: its cost [$].
        score: its score f [nats].
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
            the DP table was too large), or both.
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
        problem: what it was computed on.
        seconds: wall time [s] (the only field that varies between runs, unless ``max_seconds`` stopped it).
    """

    budget_usd: float
    suite: tuple[str, ...]
    cost_usd: float
    score: float
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
    problem: ProblemInfo | None = None
    seconds: float = 0.0


def optimal(evaluator: Evaluator, budget_usd: float, *, max_nodes: int = DEFAULT_MAX_NODES, max_seconds: float | None = None,
            exclude: frozenset[int] = frozenset(), incumbent: GreedyResult | None = None, greedy_rule: str = "best-of",
            progress: Progress | None = None, info: ProblemInfo | None = None, max_cells: int = MAX_DP_CELLS) -> OptimumResult:
    """The best suite within ``budget_usd`` by best-first branch and bound.

    The first incumbent is a greedy suite (``incumbent``, or a ``greedy_rule`` run now; for
    "best-of", both its uniform and marginal runs, keeping the better). A node is
    (S, R): the suites S ∪ T with T ⊆ R. Expanding it sweeps Δ(e | S) for e in R (one
    ``scores_with``; but when every sensor of R fits the remaining budget together, S ∪ R is the
    node's best suite by monotonicity and one evaluation settles it), drops the sensors that add nothing (by submodularity they add nothing to any
    larger suite either) or no longer fit, orders the rest by gain e_1, ..., e_m, and splits the
    node into the children (S + e_k, {e_(k+1), ..., e_m}), which together cover every suite of the
    node but S itself. Each child is bounded from the parent's gains, before its own sweep:

        f(S + e_k + T) <= f(S) + Δ(e_k | S) + knapsack(Δ(· | S) over e_(k+1..m), B - Cost(S) - cost(e_k))

    (all m children's knapsacks come from one DP over the items in reverse order). Nodes are expanded
    highest bound first; when the highest bound left does not beat the best suite found (by more than
    a relative 1e-9), that suite is optimal; so it is when the certificate bound of a greedy run
    (:func:`certificate`) does not beat it. Otherwise, at the node or time limit, the highest bound
    left (or the certificate bound, if smaller) is an upper bound on the optimum.

    Args:
        budget_usd: the budget B [$].
        max_nodes: at most this many node expansions (deterministic limit).
        max_seconds: also stop after this much wall time [s] (makes the result depend on speed).
        exclude: library positions that may not be bought.
        incumbent: a greedy result to start from (must be a run on this problem).
        greedy_rule: rule of the greedy run made when ``incumbent`` is None.
        progress: called as progress(nodes_expanded, max_nodes).
        info: what the problem is, recorded in the result.
    """
    t0 = time.perf_counter()
    budget = check_budget(budget_usd)
    if isinstance(max_nodes, bool) or not isinstance(max_nodes, int) or max_nodes < 1:
        raise InputError(f"max_nodes must be a positive integer, got {max_nodes!r}")
    if max_seconds is not None and not (isinstance(max_seconds, (int, float)) and max_seconds > 0):
        raise InputError(f"max_seconds must be a positive number of seconds, got {max_seconds!r}")
    ev = evaluator
    lib = ev.library
    n0 = ev.n_evaluations
    costs = lib.costs
    exclude = frozenset(int(i) for i in exclude)
    if incumbent is None:
        # best-of: both runs kept (not only the winner), so that both certificates bound the optimum
        rules = ("uniform", "marginal") if greedy_rule == "best-of" else (greedy_rule,)
        runs = [greedy(ev, budget, r, exclude=exclude, info=info) for r in rules]
        incumbent = better_run(runs)  # the run BestOfGreedy keeps
        rule_label = f"best-of ({incumbent.chosen_rule})" if greedy_rule == "best-of" else greedy_rule
    elif abs(incumbent.budget_usd - budget) > 1e-9 * max(1.0, budget):
        raise InputError(f"the incumbent greedy run has budget ${incumbent.budget_usd:,.0f}, not ${budget:,.0f}")
    else:
        runs = [incumbent]
        rule_label = incumbent.objective + (f" ({incumbent.chosen_rule})" if incumbent.objective == "best-of" else "")
    try:
        inc_pos = tuple(sorted(lib.position(x) for x in incumbent.suite))
    except InputError as exc:
        raise InputError(f"the incumbent greedy run does not belong to this library: {exc}") from None
    if set(inc_pos) & exclude:
        raise InputError("the incumbent greedy suite contains an excluded sensor")
    # The certificates of the greedy runs bound the optimum from the start (valid whatever the search
    # does); the search can only tighten that.
    cert_bound = min(certificate(ev, r, max_cells=max_cells).bound for r in runs)
    units = cost_units(costs, budget)
    w_all = units.costs
    cap_root = units.capacity

    best_suite: tuple[int, ...] = inc_pos
    best_score = incumbent.score if incumbent.engine == ev.name else (ev.score(inc_pos) if inc_pos else 0.0)
    best_cost = lib.cost(inc_pos)

    def tol(x: float) -> float:
        return REL_TOL * max(1.0, abs(x))

    def offer(suite: tuple[int, ...], score: float) -> None:
        nonlocal best_suite, best_score, best_cost
        s = tuple(sorted(suite))
        c = lib.cost(s)
        if score > best_score + tol(best_score) or (abs(score - best_score) <= tol(best_score) and (c, s) < (best_cost, best_suite)):
            best_suite, best_score, best_cost = s, score, c

    methods: set[str] = set()
    counter = 0
    # heap of (-bound, tie counter, suite S (pick order), f(S), Cost(S) [units], R (candidates))
    root_r = tuple(i for i in range(len(lib)) if i not in exclude and w_all[i] <= cap_root)
    heap: list[tuple[float, int, tuple[int, ...], float, int, tuple[int, ...]]] = [(-math.inf, 0, (), 0.0, 0, root_r)]
    nodes = pruned = solved = 0
    stop = ""
    while heap:
        neg_ub, _, s, f_s, c_s, r = heap[0]
        if min(-neg_ub, cert_bound) <= best_score + tol(best_score):
            pruned += len(heap)
            heap.clear()
            break
        if nodes >= max_nodes:
            stop = f"node limit ({max_nodes:,}) reached"
            break
        if max_seconds is not None and time.perf_counter() - t0 > max_seconds:
            stop = f"time limit ({max_seconds:g} s) reached"
            break
        heapq.heappop(heap)
        nodes += 1
        if progress:
            progress(nodes, max_nodes)
        room = cap_root - c_s
        r = tuple(e for e in r if w_all[e] <= room)  # what fitted the parent may not fit here
        if len(r) > 1 and int(w_all[list(r)].sum()) <= room:
            # everything left fits: by monotonicity S ∪ R is the node's best suite (one evaluation)
            offer(s + r, ev.score(s + r))
            solved += 1
            continue
        vals = ev.scores_with(s, list(r)) if r else np.zeros(0)
        for e, v in zip(r, vals):
            offer(s + (e,), float(v))
        gains = vals - f_s
        keep = [k for k in range(len(r)) if gains[k] > tol(f_s) and w_all[r[k]] <= room]
        # order: largest gain first; ties: cheaper, then library order
        keep.sort(key=lambda k: (-gains[k], costs[r[k]], r[k]))
        items = [r[k] for k in keep]
        g = np.array([gains[k] for k in keep], dtype=float)
        w = np.array([w_all[i] for i in items], dtype=np.int64)
        m = len(items)
        if m == 0:
            continue
        node_ub, child_ub, method = _node_bounds(g, w, int(room), f_s, max_cells, [costs[i] for i in items],
                                                 units.unit_usd)
        methods.add(method)
        node_ub = min(node_ub, -neg_ub)
        if node_ub <= best_score + tol(best_score):
            pruned += 1
            continue
        for k in range(m):
            ub = min(child_ub[k], node_ub)
            rest = tuple(items[k + 1:])
            if not rest or ub <= best_score + tol(best_score):
                pruned += 1 if rest else 0
                continue
            counter += 1
            heapq.heappush(heap, (-ub, counter, s + (items[k],), float(vals[keep[k]]), c_s + int(w[k]), rest))
    proved = not heap
    if proved:
        stop = "every other suite ruled out by its bound"
        upper = best_score
    else:
        upper = max(best_score, min(-heap[0][0], cert_bound))
    gap = max(0.0, upper - best_score)
    g_score = incumbent.score if incumbent.engine == ev.name else (ev.score(inc_pos) if inc_pos else 0.0)
    return OptimumResult(
        budget_usd=budget, suite=lib.suite_ids(best_suite), cost_usd=best_cost, score=best_score,
        proved_optimal=proved, upper_bound=upper, gap=gap, gap_percent=100.0 * gap / upper if upper > 0 else 0.0,
        stop_reason=stop, n_nodes=nodes, n_pruned=pruned, n_solved=solved, n_evaluations=ev.n_evaluations - n0, max_nodes=max_nodes,
        bound_method="+".join(sorted(methods)) or "none", greedy_rule=rule_label, greedy_suite=incumbent.suite,
        greedy_cost_usd=incumbent.cost_usd, greedy_score=g_score,
        greedy_percent_of_best=100.0 * g_score / best_score if best_score > 0 else 100.0,
        greedy_percent_of_bound=100.0 * g_score / upper if upper > 0 else 100.0, greedy_certificate_bound=cert_bound,
        engine=ev.name, problem=info, seconds=round(time.perf_counter() - t0, 6),
    )


def _node_bounds(gains: np.ndarray, w: np.ndarray, room: int, f_s: float, max_cells: int,
                 costs_usd: list[float], unit_usd: float) -> tuple[float, np.ndarray, str]:
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
        child[k] = f_s + gains[k] + _fractional_bound(gains[k + 1:], c[k + 1:], room_usd - c[k])
    return f_s + _fractional_bound(gains, c, room_usd), child, "fractional"
