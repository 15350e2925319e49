"""The greedy engine: selection under a cost budget with one rule (the paper's Algorithm 1 and its variants).

At each step every remaining sensor that still fits the remaining budget is considered with the
current suite S; the one with the best J of the rule (:mod:`.rules`) is bought. Candidates that add
no information (gain below round-off) are never bought; selection stops when no informative sensor
fits. A strategy (:mod:`.strategies`) runs its component rules and keeps one run.

Nothing fits: :func:`greedy` answers a budget below the cheapest sensor with the empty suite and a
stop reason that says so ("budget $300 is below the cheapest sensor (HD2K-3, $449)"): tradespace
grids, per-period runs and the active set of resilient selection legitimately ask for such budgets.
A *request* that can buy nothing (a command's --budget, or a budget that buys no more than the
sensors assumed to fail) is refused up front by :func:`check_affordable`, an :class:`InputError`
naming the option; every command (greedy, pareto, optimal, certify, resilient) calls it.

Constraints (:mod:`sensorsel.model.constraints`): besides the budget, a run may respect resource limits,
mounting slots, a largest number of sensors, required and excluded sensors. Required sensors start
the suite; a candidate is considered only when it fits every limit on top of the suite, so no run
ever returns a suite outside the feasible set. The cost-aware rules use each sensor's
dollar-equivalent cost (its price when the budget is the only limit).

Ties: candidates whose J is within a relative 1e-9 of the best are tied (so that engines that agree
to round-off pick alike); among them the cheaper sensor wins, then the smaller id.

Lazy evaluation (Minoux's accelerated greedy) for the rules whose J is a (scaled) gain, ``uniform``
and ``marginal``: f is monotone submodular, so a candidate's gain can only shrink as S grows, and its
last computed gain is an upper bound. Only candidates whose bound could still reach the best (within
the tie tolerance) are re-scored, so the picks are exactly those of the plain greedy, with far fewer
evaluations. Where the evaluator offers bounds on the gains (:meth:`Evaluator.gain_bounds`: the
fast engine's per-measurement log det bounds from the base covariance) or on the scores
(:meth:`Evaluator.score_bounds`: its Fischer bounds, poses and landmarks decoupled, which spare
most of the first step's evaluations), a candidate's bound is also capped by them (the same
picks and scores, fewer evaluations: docs/speed.md).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import Protocol

import numpy as np

from sensorsel.designs.parts import elapsed_s, provenance
from sensorsel.designs.selection.records import GreedyResult, Step
from sensorsel.designs.selection.registry import RULES, check_rule
from sensorsel.designs.selection.rules import REL_TOL, Rule
from sensorsel.errors import InputError
from sensorsel.information.evaluators import Evaluator
from sensorsel.io.progress import Progress
from sensorsel.model.constraints import Constraints, FeasibleSet, feasible_set, recorded
from sensorsel.model.library import SensorLibrary
from sensorsel.model.problem import TargetInfo

__all__ = ["BOUND_FROM", "LAZY_BATCH", "REL_TOL", "Selector", "check_affordable", "check_budget", "greedy"]

#: Lazy evaluation re-scores the candidates with the largest bounds this many at a time (in
#: parallel when the evaluator has threads). Fixed, not the job count, so that the suites scored,
#: and so every number of a result, are the same for any ``--jobs``; 2 fits a 2-core machine and
#: costs the single-threaded run ~1% more evaluations (KITTI 03: 184 against 183).
LAZY_BATCH = 2

#: Lazy evaluation asks the evaluator for bounds once per step, when more than this many candidates
#: would still be re-scored after the first batch: first its cheap bounds on the scores
#: (:meth:`Evaluator.score_bounds`: ~0.2 ms per candidate on the fast engine; also before the first
#: batch where a candidate was never scored, as in the first step), then, if as many remain, its
#: bounds on the gains (:meth:`Evaluator.gain_bounds`: one base covariance, ~3-6 evaluations' work
#: on the fast engine). 0: never (see docs/speed.md).
BOUND_FROM = 4


def check_budget(budget_usd: object) -> float:
    """A budget as a float [$]; refuses negative, NaN, infinite or non-numeric values."""
    if isinstance(budget_usd, bool) or not isinstance(budget_usd, (int, float)):
        raise InputError(f"budget must be a number of dollars, got {budget_usd!r}")
    b = float(budget_usd)
    if not math.isfinite(b) or b < 0:
        raise InputError(f"budget must be a finite, non-negative number of dollars, got {budget_usd!r}")
    return b


def check_affordable(
    library: SensorLibrary,
    budget_usd: float,
    alpha: int = 0,
    *,
    budget_option: str = "--budget",
    alpha_option: str = "--failures",
    constraints: Constraints | None = None,
) -> float:
    """The budget, when it buys at least one sensor more than the ``alpha`` assumed to fail (and,
    with ``constraints``, when they allow some suite: the required sensors, or one sensor).

    Raises:
        InputError: the library is empty; the budget is below the cheapest sensor (names
            ``budget_option``, the cheapest sensor and its cost); or, with ``alpha`` > 0, the budget
            buys at most ``alpha`` sensors, so every sensor bought could fail and every worst case
            is 0 (names ``alpha_option`` and ``budget_option``, how many sensors the budget buys and
            what ``alpha`` + 1 sensors cost).
    """
    budget = check_budget(budget_usd)
    if len(library) == 0:
        raise InputError(f"the library {library.source} has no sensor: nothing can be bought")
    if constraints is not None:
        feas = feasible_set(library, budget, constraints)  # refuses unknown ids and required sensors over a limit
        if feas.required:
            return budget
        none = np.zeros(len(feas.b))
        if not feas.addable(none).any() and not feas.only_budget:
            everything = np.ones(len(library), dtype=bool)
            everything[list(feas.excluded)] = False
            raise InputError(
                f"nothing can be bought: every sensor breaks a limit on its own "
                f"({feas.why_nothing_fits(none, everything)}); raise {budget_option} or a --limit"
            )
    costs = np.asarray(library.costs, dtype=float)
    order = np.argsort(costs, kind="stable")
    cheapest = int(order[0])
    total = np.cumsum(costs[order])
    k = int(np.sum(total <= budget + 1e-9))  # most sensors the budget buys
    if k == 0:
        c = costs[cheapest]
        raise InputError(
            f"{budget_option} ${budget:,.0f} is below the cheapest sensor ({library.ids[cheapest]}, ${c:,.0f}): "
            f"nothing can be bought; give {budget_option} {c:.0f} or more"
        )
    if alpha > 0 and k <= alpha:
        if alpha >= len(library):
            raise InputError(
                f"{alpha_option} {alpha}: the library has {len(library)} sensors, so all of them could fail "
                f"(every worst case 0); give {alpha_option} {len(library) - 1} or less"
            )
        raise InputError(
            f"{alpha_option} {alpha}: {budget_option} ${budget:,.0f} buys at most {k} sensor(s), so every sensor "
            f"bought could fail (every worst case 0); give {alpha_option} {k - 1} or less, or {budget_option} "
            f"{total[alpha]:.0f} or more (the {alpha + 1} cheapest sensors)"
        )
    return budget


class Journal(Protocol):
    """What a resumable greedy run recorded, and where it records each pick and each finished
    component run (:mod:`sensorsel.designs.checkpoint` keeps it in a checkpoint file).

    Attributes:
        runs: a strategy's finished component runs, in order (a single rule: its run, once finished).
        steps: the picks of the component run under way, as computed (taken as recorded on resume).
        n_evaluations: suites earlier sessions scored to make those picks.
    """

    @property
    def runs(self) -> tuple[GreedyResult, ...]: ...

    @property
    def steps(self) -> tuple[Step, ...]: ...

    @property
    def n_evaluations(self) -> int: ...

    def record_steps(self, steps: tuple[Step, ...], n_evaluations: int) -> None:
        """The run under way made ``steps``, scoring ``n_evaluations`` suites (every session's)."""

    def record_runs(self, runs: tuple[GreedyResult, ...]) -> None:
        """The component runs finished so far (the run under way is done: no steps under way)."""


def greedy(
    evaluator: Evaluator,
    budget_usd: float,
    rule: str = "uniform",
    *,
    lazy: bool = True,
    exclude: frozenset[int] = frozenset(),
    start: tuple[int, ...] = (),
    progress: Progress | None = None,
    info: TargetInfo | None = None,
    constraints: Constraints | None = None,
    reserved: tuple[int, ...] = (),
    journal: Journal | None = None,
) -> GreedyResult:
    """Greedy selection under a budget with the named rule or strategy of :data:`RULES`.

    Args:
        evaluator: scores suites of one problem.
        budget_usd: the budget [$].
        rule: a name of :data:`RULES`.
        lazy: use lazy (Minoux) evaluation where the rule allows it (same picks, fewer evaluations).
        exclude: library positions that may not be bought (e.g. sensors assumed to fail).
        start: library positions already in the suite (counted in its cost).
        progress: called as progress(picks_done, max_picks) after each pick (of each component run).
        info: what the problem is, recorded in the result.
        constraints: limits besides the budget (:class:`~sensorsel.model.constraints.Constraints`); None: the
            budget alone, as everywhere below the API (pass ``Constraints()`` to honour the library's slots).
        reserved: library positions bought outside the scored suite (Algorithm 2's failing set):
            they use their share of every limit (the budget included), are never picked and are not
            scored; the result's cost is the suite's own. Required sensors among them stay reserved.
        journal: resume from, and record to, a checkpoint (:class:`Journal`): its finished component
            runs are taken as recorded, its picks under way as computed, and greedy goes on from there;
            the same picks as an uninterrupted run (greedy is deterministic, lazy evaluation exact).
    """
    entry = RULES[check_rule(rule)]
    if journal is None:
        if isinstance(entry, Rule):
            return Selector(
                evaluator, entry, lazy=lazy, exclude=exclude, progress=progress, constraints=constraints
            ).select(budget_usd, start=start, info=info, reserved=reserved)
        t0 = time.perf_counter()
        runs = [
            greedy(
                evaluator,
                budget_usd,
                c,
                lazy=lazy,
                exclude=exclude,
                start=start,
                progress=progress,
                info=info,
                constraints=constraints,
                reserved=reserved,
            )
            for c in entry.component_rules
        ]
        return entry.combine(runs, info=info, seconds=elapsed_s(t0))
    t0 = time.perf_counter()
    components = entry.component_rules
    runs = list(journal.runs[: len(components)])
    for done in runs:  # the bar shows the component runs already finished
        if progress and done.steps:
            progress(len(done.steps), len(done.steps))
    for name in components[len(runs) :]:
        component = RULES[name]
        assert isinstance(component, Rule)
        n_before, n0 = journal.n_evaluations, evaluator.n_evaluations

        def record(steps: tuple[Step, ...], n_before: int = n_before, n0: int = n0) -> None:
            journal.record_steps(steps, n_before + evaluator.n_evaluations - n0)

        run = Selector(
            evaluator, component, lazy=lazy, exclude=exclude, progress=progress, constraints=constraints
        ).select(budget_usd, start=start, info=info, reserved=reserved, resume=journal.steps, on_step=record)
        runs.append(replace(run, n_evaluations=n_before + run.n_evaluations))
        journal.record_runs(tuple(runs))
    if isinstance(entry, Rule):
        return runs[0]
    return entry.combine(runs, info=info, seconds=elapsed_s(t0))


class Selector:
    """Greedy selection under a budget with one rule.

    Args:
        evaluator: scores suites of one problem.
        rule: the rule (J) to maximize at each step.
        lazy: use lazy (Minoux) evaluation where the rule allows it (same picks, fewer evaluations).
        exclude: library positions that may not be bought (e.g. sensors assumed to fail).
        progress: called as progress(picks_done, max_picks) after each pick.
        constraints: limits besides the budget; None: the budget alone.
        bound_from: lazy only: ask the evaluator for bounds (on the scores, then on the gains) when more than this many
            candidates would still be re-scored in a step (0: never). Same picks and scores
            either way; fewer evaluations when it helps.
    """

    def __init__(
        self,
        evaluator: Evaluator,
        rule: Rule,
        *,
        lazy: bool = True,
        exclude: frozenset[int] = frozenset(),
        progress: Progress | None = None,
        constraints: Constraints | None = None,
        bound_from: int = BOUND_FROM,
    ) -> None:
        self.evaluator = evaluator
        self.rule = rule
        self.lazy = lazy and rule.lazy_ok
        self.exclude = frozenset(exclude)
        self.progress = progress
        self.constraints = constraints
        self.bound_from = int(bound_from)

    def select(
        self,
        budget_usd: float,
        *,
        start: tuple[int, ...] = (),
        info: TargetInfo | None = None,
        reserved: tuple[int, ...] = (),
        resume: Sequence[Step] = (),
        on_step: Callable[[tuple[Step, ...]], None] | None = None,
    ) -> GreedyResult:
        """Run greedy selection; ``start`` sensors (and the required ones) are already in the suite;
        ``reserved`` sensors use their share of every limit outside it (see :func:`greedy`).

        ``resume``: the steps an interrupted run of the same selection recorded; they are taken as
        recorded (suite, cost and score, not recomputed) and selection goes on from there: the same
        picks as an uninterrupted run (lazy evaluation is exact), with its own count of evaluations
        (the lazy bounds start afresh). ``on_step(steps)`` is called after each pick with every step
        so far (to record them, e.g. :mod:`sensorsel.designs.checkpoint`)."""
        t0 = time.perf_counter()
        budget = check_budget(budget_usd)
        ev = self.evaluator
        lib = ev.library
        feas = feasible_set(lib, budget, recorded(self.constraints))
        costs = feas.cost  # dollar-equivalent: the price when the budget is the only limit
        prices = lib.costs
        ids = lib.ids
        n0 = ev.n_evaluations
        suite: list[int] = list(start) + [r for r in feas.required if r not in start and r not in reserved]
        outside = feas.usage(reserved)
        used = feas.usage(suite) + outside
        if (suite or reserved) and not feas.fits(list(suite) + list(reserved)):
            if feas.only_budget:
                raise InputError(f"the starting sensors cost ${used[0]:,.0f}, above the budget ${budget:,.0f}")
            raise InputError(
                f"the starting sensors {', '.join(ids[i] for i in suite)} break: {'; '.join(feas.violations(suite))}"
            )
        cost = float(costs[suite].sum()) if suite else 0.0
        f_cur = ev.score(suite) if suite else 0.0
        available = np.ones(len(lib), dtype=bool)
        available[list(self.exclude | feas.excluded | set(suite) | set(reserved))] = False
        # upper bounds on each candidate's gain (lazy), valid while f is submodular
        bound = np.full(len(lib), np.inf)
        room = budget - used[0]
        max_picks = int(np.sum(np.cumsum(np.sort(feas.A[0, available])) <= room + 1e-9)) if available.any() else 0
        steps: list[Step] = []
        for st in resume:  # an interrupted run's picks, as it recorded them
            done = lib.position(st.pick)
            suite.append(done)
            available[done] = False
            used = used + feas.A[:, done]
            cost += float(costs[done])
            steps.append(st)
            f_cur = st.score
        stop = ""
        while True:
            feasible = available & feas.addable(used)
            if not feasible.any():
                stop = self._why_nothing_fits(feas, available, used, bool(steps or suite))
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
            used = used + feas.A[:, pick]
            steps.append(
                Step(
                    ids[pick],
                    lib[pick].index,
                    float(prices[pick]),
                    tuple(ids[i] for i in suite),
                    float(used[0] - outside[0]) if reserved else float(used[0]),
                    f_cur,
                    gain,
                    j_val,
                )
            )
            if on_step:  # recorded before it is reported: an interruption in the report loses no pick
                on_step(tuple(steps))
            if self.progress:
                self.progress(len(steps), max(max_picks, len(steps)))
        name = self.rule.name
        return GreedyResult(
            rule=name,
            budget_usd=budget,
            suite=tuple(ids[i] for i in suite),
            cost_usd=float(used[0] - outside[0]) if reserved else float(used[0]),
            score=f_cur,
            steps=tuple(steps),
            stop_reason=stop,
            n_evaluations=ev.n_evaluations - n0,
            engine=ev.name,
            lazy=self.lazy,
            winning_rule=name,
            # required or excluded sensors are no row of A: record them too (an owned sensor's price is
            # not counted, so a certificate that forgot them could bound the wrong problem)
            **provenance(info, t0, feas.record),
        )

    def _relax(
        self,
        suite: list[int],
        need: np.ndarray,
        f_cur: float,
        cost: float,
        costs: np.ndarray,
        threshold: float,
        bound: np.ndarray,
        gain_tol: float,
    ) -> bool:
        """Cap the ``need`` candidates' gain bounds with the evaluator's cheap score bounds
        (:meth:`Evaluator.score_bounds`); False when it has none or they cannot help: each bound on
        a gain is at least the gap between the bound on f(S) and f(S), so when a gain of that gap
        already reaches ``threshold`` (the best J so far) for every candidate, nothing would change."""
        ev = self.evaluator
        got = ev.score_bounds(tuple(suite), [])
        if got is None:
            return False
        gap = max(got[0] - f_cur, 0.0)
        at_least = self.rule.value(np.full(len(need), f_cur + gap), f_cur, cost, costs[need])  # J of a gain of the gap
        if np.isfinite(threshold) and np.all(at_least >= threshold):
            return False
        got = ev.score_bounds(tuple(suite), [int(i) for i in need])
        if got is None:
            return False
        # the slack (the tie tolerance) as for gain_bounds; the evaluator allowed for its own round-off
        bound[need] = np.minimum(bound[need], got[1] - f_cur + gain_tol)
        return True

    @staticmethod
    def _why_nothing_fits(feas: FeasibleSet, available: np.ndarray, used: np.ndarray, bought: bool) -> str:
        """The stop reason when no available sensor fits on top of the suite."""
        if not available.any():
            return "every sensor of the library is in the suite or excluded"
        if not feas.only_budget:
            return f"no remaining sensor fits: {feas.why_nothing_fits(used, available)}"
        costs, ids, budget = feas.A[0], feas.library.ids, feas.budget_usd
        cheapest = costs[available].min()
        if not bought:
            i_min = int(np.flatnonzero(available & (costs == cheapest))[0])
            return f"budget ${budget:,.0f} is below the cheapest sensor ({ids[i_min]}, ${cheapest:,.0f})"
        return (
            f"no remaining sensor fits the remaining budget (${budget - used[0]:,.0f}; cheapest left ${cheapest:,.0f})"
        )

    def _best(
        self,
        suite: list[int],
        f_cur: float,
        cost: float,
        feasible: np.ndarray,
        bound: np.ndarray,
        costs: np.ndarray,
        ids: tuple[str, ...],
    ) -> tuple[int | None, float, float]:
        """The pick among feasible candidates: (position, f(S + pick), J), or (None, ...) if none adds information."""
        ev = self.evaluator
        value = self.rule.value
        cand = np.flatnonzero(feasible)
        f_new = np.full(len(costs), -np.inf)
        fresh = np.zeros(len(costs), dtype=bool)
        gain_tol = REL_TOL * max(1.0, abs(f_cur))

        def refresh(idx: np.ndarray, threshold: float | None = None, queue: np.ndarray | None = None) -> None:
            """Score ``idx``; lazily (a ``threshold``: the J a candidate must reach to matter, at
            least the best J so far, or −inf), the evaluator may answer a candidate that cannot
            reach it with a bound instead (a domain scoring its routes one at a time): it stays
            stale, its bound lowered, the tie tolerance as slack both ways."""
            if threshold is None:
                vals, exact = ev.scores_with(tuple(suite), [int(i) for i in idx]), np.ones(len(idx), dtype=bool)
            else:
                need = self.rule.needed(threshold, f_cur, cost, costs[idx]) - gain_tol
                # the queue after these: an evaluator that scores ahead fills its idle threads or
                # workers with it (same answers and counts: it only moves work earlier)
                ahead = (
                    {"ahead": [int(i) for i in queue]}
                    if queue is not None and getattr(ev, "scores_ahead", False)
                    else {}
                )
                vals, exact = ev.scores_or_bounds(tuple(suite), [int(i) for i in idx], need, **ahead)
            done, part = idx[exact], idx[~exact]
            f_new[done] = vals[exact]
            bound[done] = vals[exact] - f_cur
            fresh[done] = True
            bound[part] = np.minimum(bound[part], vals[~exact] - f_cur + gain_tol)

        if not self.lazy:
            refresh(cand)
        else:
            batch = LAZY_BATCH
            bounded = self.bound_from <= 0
            relaxed = self.bound_from <= 0  # the evaluator's cheap score bounds were asked for in this step
            while True:
                informative = fresh & feasible & (f_new - f_cur > gain_tol)
                if informative.any():
                    j = value(f_new[informative], f_cur, cost, costs[informative])
                    threshold = j.max() - REL_TOL * max(1.0, abs(j.max()))
                else:
                    threshold = -np.inf
                stale = feasible & ~fresh
                if not stale.any():
                    break
                j_bound = value(f_cur + bound[stale], f_cur, cost, costs[stale])
                need = np.flatnonzero(stale)[j_bound >= threshold]
                if len(need) == 0:
                    break
                if not relaxed and (np.isinf(bound[need]).any() or (len(need) > self.bound_from and fresh.any())):
                    # cheap bounds first: before the first batch where some candidate was never
                    # scored (they order the batches), else where many would be re-scored
                    relaxed = True
                    if self._relax(suite, need, f_cur, cost, costs, threshold, bound, gain_tol):
                        continue
                if not bounded and len(need) > self.bound_from and fresh.any():
                    # bounds at the current suite, valid from now on (gains only shrink): a candidate
                    # whose bound cannot reach the best is never re-scored. The slack (the tie
                    # tolerance) is far above the round-off of a computed gain or bound.
                    bounded = True
                    extra = ev.gain_bounds(tuple(suite), [int(i) for i in need])
                    if extra is not None:
                        bound[need] = np.minimum(bound[need], extra * (1.0 + REL_TOL) + gain_tol)
                        continue
                j_need = value(f_cur + bound[need], f_cur, cost, costs[need])
                order = np.argsort(-j_need, kind="stable")
                # an evaluator that answers with bounds gets the step's first candidate alone: the
                # others are then bounded against its J instead of scored in full
                first = not np.isfinite(threshold) and ev.bounds_candidates
                take = 1 if first else batch
                if ev.bounds_candidates and not first and len(order) > take:
                    # best first: a candidate is scored only while its bound stays at or above the
                    # best bound of the candidates left out of this batch (the rival); below it,
                    # the rival is the likelier pick and is scored next. Only the exact J of the
                    # best so far ends the step, so the pick and its numbers are the same; what
                    # changes is that a candidate whose heavy routes disappoint is not scored on
                    # its light ones (seven KITTI routes x four conditions at $110,000: 518 -> 460
                    # route evaluations; the seven routes alone 170 -> 153). Not for the step's
                    # first candidate: scored against rivals' bounds alone it wandered (754 on the routes alone)
                    rival = float(j_need[order[take]])
                    threshold = max(threshold, rival - REL_TOL * max(1.0, abs(rival)))
                refresh(need[order[:take]], threshold, need[order[take:]])
        informative_pos = np.flatnonzero(fresh & feasible & (f_new - f_cur > gain_tol))
        if len(informative_pos) == 0:
            return None, f_cur, 0.0
        j = value(f_new[informative_pos], f_cur, cost, costs[informative_pos])
        best = j.max()
        tied = informative_pos[j >= best - REL_TOL * max(1.0, abs(best))]
        pick = min(tied, key=lambda i: (costs[i], ids[i]))
        return int(pick), float(f_new[pick]), float(j[np.flatnonzero(informative_pos == pick)[0]])
