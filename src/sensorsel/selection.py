"""Greedy sensor selection under a cost budget (the paper's Algorithm 1 and its variants).

One small class per rule, a name -> class registry (:data:`SELECTORS`), a deterministic tie-break.
At each step every remaining sensor that still fits the remaining budget is considered with the
current suite S; the one with the best objective J is bought. Candidates that add no information
(gain below round-off) are never bought; selection stops when no informative sensor fits.

Objectives (f is the score, f(S) = log det L(S) - log det L(empty), nats; costs in $):

``uniform``       J = f(S + s). The paper's Algorithm 1.
``cost-benefit``  J = f(S + s) / Cost(S + s). As the paper's Section V writes it: performance per
                  dollar of the whole suite. Not a marginal rule: it favours cheap sensors once S
                  is good, which is what spreads its architectures over low cost levels.
``marginal``      J = (f(S + s) - f(S)) / cost(s). The classic cost-benefit rule for budgeted
                  submodular maximization (Krause & Guestrin 2005; Leskovec et al. 2007).
``best-of``       runs ``uniform`` and ``marginal`` and returns the better suite. For a monotone
                  submodular f under a budget this carries the known constant-factor guarantee
                  f >= (1 - 1/e)/2 * f(OPT) (Leskovec et al. 2007), which neither rule has alone.

Ties: candidates whose J is within a relative 1e-9 of the best are tied (so that engines that agree
to round-off pick alike); among them the cheaper sensor wins, then the smaller id.

Lazy evaluation (Minoux's accelerated greedy) for ``uniform`` and ``marginal``: f is monotone
submodular, so a candidate's gain can only shrink as S grows, and its last computed gain is an upper
bound. Only candidates whose bound could still reach the best (within the tie tolerance) are
re-scored, so the picks are exactly those of the plain greedy, with far fewer evaluations.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from typing import Callable, ClassVar

import numpy as np

from .errors import InputError
from .evaluators import Evaluator, make_evaluator
from .problem import ProblemInfo
from .problem import Problem

#: Relative tolerance under which two objective values are tied, and a gain counts as zero.
REL_TOL = 1e-9

#: Lazy evaluation re-scores the candidates with the largest bounds this many at a time (in
#: parallel when the evaluator has threads). Fixed, not the job count, so that the suites scored,
#: and so every number of a result, are the same for any ``--jobs``; 2 fits a 2-core machine and
#: costs the single-threaded run ~1% more evaluations (KITTI 03: 184 against 183).
LAZY_BATCH = 2

#: progress(done, total): called after each pick; total is an upper bound on the number of picks.
Progress = Callable[[int, int], None]


@dataclass(frozen=True)
class Step:
    """One intermediate architecture of a greedy run: the suite right after a pick.

    Attributes:
        pick: id of the sensor bought at this step.
        index: its paper index.
        sensor_cost_usd: its cost [$].
        suite: ids of the whole suite after the pick, in pick order.
        cost_usd: cost of the suite [$].
        score: f(suite) [nats].
        gain: f(suite) - f(suite before the pick) [nats].
        objective_value: J of the pick under the run's rule.
    """

    pick: str
    index: int
    sensor_cost_usd: float
    suite: tuple[str, ...]
    cost_usd: float
    score: float
    gain: float
    objective_value: float


@dataclass(frozen=True)
class Certificate:
    """How close a greedy suite is to the best possible suite of its budget.

    Computed by :func:`sensorsel.certify.certificate` (the bound is explained there); defined here so
    that a :class:`GreedyResult` can carry its own certificate.

    Attributes:
        objective: the greedy rule that chose the suite.
        budget_usd: the budget B [$].
        suite: ids of the greedy suite.
        cost_usd: its cost [$].
        score: its score f [nats].
        bound: an upper bound on the score of every suite within the budget [nats]: the smallest
            U(S) over the empty suite and the greedy run's intermediate suites (and never below
            ``score``).
        ratio: score / bound in [0, 1]: the greedy suite scores at least this fraction of the best
            possible (1 when the bound is 0: nothing informative is affordable).
        percent_of_best: 100 * ratio: "at least X% of the best possible".
        gap: bound - score [nats]: the most the best possible suite can score above the greedy one.
        bound_step: where the smallest bound was attained: 0 = the empty suite, k = after the k-th pick.
        bound_suite: ids of that intermediate suite.
        step_bounds: U at the empty suite and after each pick [nats], shape (n_steps + 1,); None
            where the sweep was skipped because a lower bound on U there already reached ``bound``.
        knapsack_method: how the knapsacks were solved ("dp", or every method used, joined by "+").
        knapsack_exact: whether every knapsack was solved exactly (the bound is valid either way).
        n_evaluations: suites scored for the certificate.
        engine: the evaluator used.
        problem: what it was computed on.
        seconds: wall time [s] (the only field that varies between runs).
    """

    objective: str
    budget_usd: float
    suite: tuple[str, ...]
    cost_usd: float
    score: float
    bound: float
    ratio: float
    percent_of_best: float
    gap: float
    bound_step: int
    bound_suite: tuple[str, ...]
    step_bounds: tuple[float | None, ...]
    knapsack_method: str
    knapsack_exact: bool
    n_evaluations: int
    engine: str
    problem: ProblemInfo | None = None
    seconds: float = 0.0


@dataclass(frozen=True)
class GreedyResult:
    """A greedy run: the chosen suite and every intermediate architecture.

    Attributes:
        objective: the rule ("uniform", "cost-benefit", "marginal", "best-of").
        budget_usd: the budget [$].
        suite: ids of the chosen sensors, in pick order.
        cost_usd: total cost [$] (never above the budget).
        score: f(suite) [nats].
        steps: the suite after each pick.
        stop_reason: why selection stopped.
        n_evaluations: suites scored.
        engine: the evaluator used.
        lazy: whether lazy (Minoux) evaluation was used.
        chosen_rule: for best-of, which run won; else the objective itself.
        problem: what it was computed on.
        seconds: wall time of the selection [s] (timings are the only fields that vary between runs).
        certificate: how close the suite is to the best possible one of the budget (an upper bound
            on the optimum), when it was asked for (:func:`run_greedy` with ``certify=True``).
    """

    objective: str
    budget_usd: float
    suite: tuple[str, ...]
    cost_usd: float
    score: float
    steps: tuple[Step, ...]
    stop_reason: str
    n_evaluations: int
    engine: str
    lazy: bool
    chosen_rule: str
    problem: ProblemInfo | None = None
    seconds: float = 0.0
    certificate: Certificate | None = None


def check_budget(budget_usd: float) -> float:
    """A budget as a float [$]; refuses negative, NaN, infinite or non-numeric values."""
    if isinstance(budget_usd, bool) or not isinstance(budget_usd, (int, float)):
        raise InputError(f"budget must be a number of dollars, got {budget_usd!r}")
    b = float(budget_usd)
    if not math.isfinite(b) or b < 0:
        raise InputError(f"budget must be a finite, non-negative number of dollars, got {budget_usd!r}")
    return b


class Selector:
    """Greedy selection under a budget with one objective rule. Subclasses define :meth:`objective`.

    Args:
        evaluator: scores suites of one problem.
        lazy: use lazy (Minoux) evaluation where the rule allows it (same picks, fewer evaluations).
        exclude: library positions that may not be bought (e.g. sensors assumed to fail).
        progress: called as progress(picks_done, max_picks) after each pick.
    """

    name: ClassVar[str] = ""
    #: True when J is a gain (or a gain scaled by a constant per candidate): lazy bounds are valid.
    lazy_ok: ClassVar[bool] = False

    def __init__(self, evaluator: Evaluator, *, lazy: bool = True, exclude: frozenset[int] = frozenset(),
                 progress: Progress | None = None) -> None:
        self.evaluator = evaluator
        self.lazy = lazy and self.lazy_ok
        self.exclude = frozenset(exclude)
        self.progress = progress

    def objective(self, f_new: np.ndarray, f_old: float, suite_cost: float, cand_cost: np.ndarray) -> np.ndarray:
        """J for each candidate given f(S + s), f(S), Cost(S) and cost(s)."""
        raise NotImplementedError

    def select(self, budget_usd: float, *, start: tuple[int, ...] = (), info: ProblemInfo | None = None) -> GreedyResult:
        """Run greedy selection; ``start`` sensors are already in the suite (counted in cost)."""
        t0 = time.perf_counter()
        budget = check_budget(budget_usd)
        ev = self.evaluator
        lib = ev.library
        costs = lib.costs
        ids = lib.ids
        n0 = ev.n_evaluations
        suite: list[int] = list(start)
        cost = float(sum(costs[i] for i in suite))
        if cost > budget:
            raise InputError(f"the starting sensors cost ${cost:,.0f}, above the budget ${budget:,.0f}")
        f_cur = ev.score(suite) if suite else 0.0
        available = np.ones(len(lib), dtype=bool)
        available[list(self.exclude | set(suite))] = False
        # upper bounds on each candidate's gain (lazy), valid while f is submodular
        bound = np.full(len(lib), np.inf)
        max_picks = int(np.sum(np.cumsum(np.sort(costs[available])) <= budget - cost)) if available.any() else 0
        steps: list[Step] = []
        stop = ""
        while True:
            feasible = available & (costs <= budget - cost + 1e-9)
            if not feasible.any():
                cheapest = costs[available].min() if available.any() else None
                if cheapest is None:
                    stop = "every sensor of the library is in the suite or excluded"
                elif not steps and not start:
                    i_min = int(np.flatnonzero(available & (costs == cheapest))[0])
                    stop = f"budget ${budget:,.0f} is below the cheapest sensor ({ids[i_min]}, ${cheapest:,.0f})"
                else:
                    stop = f"no remaining sensor fits the remaining budget (${budget - cost:,.0f}; cheapest left ${cheapest:,.0f})"
                break
            pick, f_new, j_val = self._best(suite, f_cur, cost, feasible, bound, costs, ids)
            if pick is None:
                stop = "no remaining affordable sensor adds information"
                break
            suite.append(pick)
            available[pick] = False
            gain = f_new - f_cur
            f_cur = f_new
            cost += float(costs[pick])
            steps.append(Step(ids[pick], lib[pick].index, float(costs[pick]), tuple(ids[i] for i in suite), cost, f_cur, gain, j_val))
            if self.progress:
                self.progress(len(steps), max(max_picks, len(steps)))
        return GreedyResult(
            objective=self.name, budget_usd=budget, suite=tuple(ids[i] for i in suite), cost_usd=cost, score=f_cur,
            steps=tuple(steps), stop_reason=stop, n_evaluations=ev.n_evaluations - n0, engine=ev.name, lazy=self.lazy,
            chosen_rule=self.name, problem=info, seconds=round(time.perf_counter() - t0, 6),
        )

    def _best(self, suite: list[int], f_cur: float, cost: float, feasible: np.ndarray, bound: np.ndarray,
              costs: np.ndarray, ids: tuple[str, ...]) -> tuple[int | None, float, float]:
        """The pick among feasible candidates: (position, f(S + pick), J), or (None, ...) if none adds information."""
        ev = self.evaluator
        cand = np.flatnonzero(feasible)
        f_new = np.full(len(costs), -np.inf)
        fresh = np.zeros(len(costs), dtype=bool)
        gain_tol = REL_TOL * max(1.0, abs(f_cur))

        def refresh(idx: np.ndarray) -> None:
            vals = ev.scores_with(tuple(suite), [int(i) for i in idx])
            f_new[idx] = vals
            bound[idx] = vals - f_cur
            fresh[idx] = True

        if not self.lazy:
            refresh(cand)
        else:
            batch = LAZY_BATCH
            while True:
                informative = fresh & feasible & (f_new - f_cur > gain_tol)
                if informative.any():
                    j = self.objective(f_new[informative], f_cur, cost, costs[informative])
                    threshold = j.max() - REL_TOL * max(1.0, abs(j.max()))
                else:
                    threshold = -np.inf
                stale = feasible & ~fresh
                if not stale.any():
                    break
                j_bound = self.objective(f_cur + bound[stale], f_cur, cost, costs[stale])
                need = np.flatnonzero(stale)[j_bound >= threshold]
                if len(need) == 0:
                    break
                order = np.argsort(-self.objective(f_cur + bound[need], f_cur, cost, costs[need]), kind="stable")
                refresh(need[order[:batch]])
        informative = np.flatnonzero(fresh & feasible & (f_new - f_cur > gain_tol))
        if len(informative) == 0:
            return None, f_cur, 0.0
        j = self.objective(f_new[informative], f_cur, cost, costs[informative])
        best = j.max()
        tied = informative[j >= best - REL_TOL * max(1.0, abs(best))]
        pick = min(tied, key=lambda i: (costs[i], ids[i]))
        return int(pick), float(f_new[pick]), float(j[np.flatnonzero(informative == pick)[0]])


class UniformGreedy(Selector):
    """J = f(S + s): the most informative affordable sensor (the paper's Algorithm 1)."""

    name = "uniform"
    lazy_ok = True

    def objective(self, f_new, f_old, suite_cost, cand_cost):
        return np.asarray(f_new, dtype=float)


class CostBenefitGreedy(Selector):
    """J = f(S + s) / Cost(S + s): the paper's cost-benefit rule (performance per dollar of the suite)."""

    name = "cost-benefit"

    def objective(self, f_new, f_old, suite_cost, cand_cost):
        return np.asarray(f_new, dtype=float) / (suite_cost + np.asarray(cand_cost, dtype=float))


class MarginalGreedy(Selector):
    """J = (f(S + s) - f(S)) / cost(s): the classic marginal gain per dollar."""

    name = "marginal"
    lazy_ok = True

    def objective(self, f_new, f_old, suite_cost, cand_cost):
        return (np.asarray(f_new, dtype=float) - f_old) / np.asarray(cand_cost, dtype=float)


class BestOfGreedy(Selector):
    """The better of the uniform and marginal runs (constant-factor guarantee under a budget)."""

    name = "best-of"
    lazy_ok = True

    def select(self, budget_usd: float, *, start: tuple[int, ...] = (), info: ProblemInfo | None = None) -> GreedyResult:
        t0 = time.perf_counter()
        kw = dict(lazy=self.lazy, exclude=self.exclude, progress=self.progress)
        runs = [cls(self.evaluator, **kw).select(budget_usd, start=start, info=info) for cls in (UniformGreedy, MarginalGreedy)]
        best = better_run(runs)
        return GreedyResult(
            objective=self.name, budget_usd=best.budget_usd, suite=best.suite, cost_usd=best.cost_usd, score=best.score,
            steps=best.steps, stop_reason=best.stop_reason, n_evaluations=sum(r.n_evaluations for r in runs),
            engine=best.engine, lazy=best.lazy, chosen_rule=best.chosen_rule, problem=info,
            seconds=round(time.perf_counter() - t0, 6),
        )


def better_run(runs: "list[GreedyResult]") -> GreedyResult:
    """The run best-of keeps: the higher score; scores within a relative :data:`REL_TOL` are tied,
    and a tie goes to the cheaper suite, then to the earlier run (uniform before marginal)."""
    best = runs[0]
    for r in runs[1:]:
        tol = REL_TOL * max(1.0, abs(best.score), abs(r.score))
        if r.score > best.score + tol or (abs(r.score - best.score) <= tol and r.cost_usd < best.cost_usd):
            best = r
    return best


SELECTORS: dict[str, type[Selector]] = {c.name: c for c in (UniformGreedy, CostBenefitGreedy, MarginalGreedy, BestOfGreedy)}


def greedy(evaluator: Evaluator, budget_usd: float, objective: str = "uniform", *, lazy: bool = True,
           exclude: frozenset[int] = frozenset(), start: tuple[int, ...] = (), progress: Progress | None = None,
           info: ProblemInfo | None = None) -> GreedyResult:
    """Greedy selection under a budget with the named rule (see :data:`SELECTORS`)."""
    if objective not in SELECTORS:
        raise InputError(f"unknown objective {objective!r}; available: {', '.join(SELECTORS)}")
    sel = SELECTORS[objective](evaluator, lazy=lazy, exclude=exclude, progress=progress)
    return sel.select(budget_usd, start=start, info=info)


def run_greedy(problem: Problem, budget_usd: float, objective: str = "uniform", *, engine: str | None = None, jobs: int = 1,
               lazy: bool = True, progress: Progress | None = None,
               certify: bool = False, certify_progress: Progress | None = None) -> GreedyResult:
    """The ``sensorsel greedy`` pipeline: :func:`greedy` with a fresh evaluator of ``engine``, recording
    what the problem is (``spec``: the scenario as the user stated it).

    With ``certify``, the result carries its :class:`Certificate` (an upper bound on the best possible
    score within the budget), computed with the same evaluator: at most one sweep of the library per greedy
    step, fewer where a step provably cannot lower the bound (``certify_progress(done, total)`` after each).

    Raises:
        InputError: a bad budget or objective (before any evaluator is built).
    """
    check_budget(budget_usd)
    if objective not in SELECTORS:
        raise InputError(f"unknown objective {objective!r}; available: {', '.join(SELECTORS)}")
    ev = make_evaluator(problem, engine, jobs=jobs)
    res = greedy(ev, budget_usd, objective, lazy=lazy, progress=progress, info=problem.info)
    if not certify:
        return res
    # imported here: certify builds on this module (greedy, GreedyResult), not the other way round
    from .certify import certificate

    return replace(res, certificate=certificate(ev, res, progress=certify_progress))
