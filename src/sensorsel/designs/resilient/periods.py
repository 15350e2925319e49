"""Resilient selection period by period: splitting the route, each period's scenario, the run (each
period written to its own file as it completes, reused on resume), and the failed / active grid."""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Unpack

import numpy as np

from sensorsel.designs.options import RunKeywords, RunOptions
from sensorsel.designs.parts import elapsed_s
from sensorsel.designs.resilient.algorithm import (
    check_alpha,
    check_rule,
    constraints_key,
    engine_name,
    recorded,
    resilient_select,
    worst_case,
)
from sensorsel.designs.resilient.cache import fingerprint
from sensorsel.designs.resilient.records import (
    ACTIVE,
    ALGORITHM_2,
    FAILED,
    METHODS,
    UNUSED,
    PeriodResult,
    PeriodSpan,
    PerPeriodResult,
    RobustChoice,
    SelectionGrid,
    WorstCase,
)
from sensorsel.designs.selection import check_budget
from sensorsel.errors import InputError
from sensorsel.information.evaluators import make_evaluator
from sensorsel.io import results
from sensorsel.io.files import atomic_write_text
from sensorsel.model.constraints import Constraints, feasible_set
from sensorsel.model.library import SensorLibrary
from sensorsel.model.problem import Problem, build_problem
from sensorsel.model.scenario import Scenario
from sensorsel.pipeline import Executor, FileStore, NoStore, Plan, Store, execute

#: progress(done, total): called after each period (computed or reused).

#: selector(evaluator, budget, alpha, info[, constraints=...]) -> (choice, its worst case): how
#: ``method="robust"`` chooses a suite (``constraints=`` is passed only when the run has some).
#: Robust selection lives in a layer above this package, so its caller passes it in
#: (:func:`sensorsel.designs.robust.robust_choice`; :func:`sensorsel.api.resilient_report` does).
Selector = Callable[..., tuple[RobustChoice, WorstCase]]


def check_method(method: str, selector: Selector | None) -> str:
    """``method`` if it is one of :data:`METHODS` and, for "robust", a selector is given."""
    if method not in METHODS:
        raise InputError(f"unknown method {method!r}; available: {', '.join(METHODS)}")
    if method == "robust" and selector is None:
        raise InputError(
            "method 'robust' needs robust selection: call sensorsel.api.resilient_report (or pass selector=)"
        )
    return method


#: Default length of a period [s] (the paper says "several seconds").
DEFAULT_PERIOD_S = 10.0


def check_period(period_s: float) -> float:
    """A period length [s]; refuses zero, negative, NaN and infinite values."""
    if (
        isinstance(period_s, bool)
        or not isinstance(period_s, (int, float))
        or not math.isfinite(period_s)
        or period_s <= 0
    ):
        raise InputError(f"period must be a positive number of seconds, got {period_s!r}")
    return float(period_s)


def split_periods(times: np.ndarray, period_s: float) -> list[tuple[int, float, float, np.ndarray]]:
    """Split keyframe timestamps into periods of ``period_s`` seconds from the first one.

    Keyframe i belongs to period k = floor((t_i - t_0) / period_s) (a 1e-9 s tolerance keeps a
    timestamp written as exactly k * period in period k despite round-off), so each keyframe is in
    exactly one period. Periods without keyframes (gaps in the timestamps) are left out.

    Returns:
        [(k, start_s, end_s, keyframe indices)] in time order; start_s = t_0 + k * period_s.
    """
    period = check_period(period_s)
    t = np.asarray(times, dtype=float)
    if len(t) == 0:
        return []
    k = np.floor((t - t[0]) / period + 1e-9).astype(int)
    out = []
    for kk in np.unique(k):
        idx = np.flatnonzero(k == kk)
        out.append((int(kk), float(t[0] + kk * period), float(t[0] + (kk + 1) * period), idx))
    return out


def period_scenario(problem: Problem, keyframes: np.ndarray, start_s: float, end_s: float, name: str) -> Scenario:
    """The scenario of one period: its keyframes (the first gets the first-pose prior when a problem
    is built on it) and the landmarks some library sensor sees from them, re-indexed 0..m-1."""
    kf = np.asarray(keyframes, dtype=int)
    seen: set[int] = set()
    for obs in problem.observations:
        seen.update(obs.landmark[np.isin(obs.pose, kf)].tolist())
    lm = np.asarray(sorted(seen), dtype=int)
    sc = problem.scenario
    route = None
    if sc.route is not None:
        r = sc.route
        route = r.select(np.flatnonzero((r.times >= start_s) & (r.times < end_s)))
        if len(route) == 0:
            route = None
    return Scenario(name, sc.keyframes.select(kf), sc.landmarks[lm].reshape(-1, 2), sc.landmark_source, route)


def period_file(outdir: str | Path, index: int) -> Path:
    """Where period ``index``'s result is written."""
    return Path(outdir) / "periods" / f"period-{index:04d}.json"


@dataclass(frozen=True)
class PeriodRun:
    """What every period of a run shares (a plan's state, sent once to each place periods run):
    the whole route and the run's settings."""

    problem: Problem
    budget: float
    alpha: int
    rule: str
    engine: str
    jobs: int
    lazy: bool
    method: str = ALGORITHM_2
    selector: Selector | None = None
    constraints: Constraints | None = None


@dataclass(frozen=True)
class PeriodTask:
    """One period (a plan's task): its span, its scenario (its keyframes and the landmarks seen from
    them: a few kilobytes) and the fingerprint of its inputs (its file's)."""

    span: PeriodSpan
    scenario: Scenario
    fingerprint: str


def period_step(run: PeriodRun, task: PeriodTask) -> PeriodResult:
    """One period's selection: Algorithm 2 and its exact worst case, or ``run.selector``'s robust choice."""
    problem, budget, alpha = run.problem, run.budget, run.alpha
    # the route's condition itself, not through its spec (a problem built from objects has none)
    sub = build_problem(
        problem.library, task.scenario, problem.settings, spec=problem.info.spec, condition=problem.condition
    )
    ev = make_evaluator(sub, run.engine, jobs=run.jobs)
    if run.method == "robust":
        assert run.selector is not None
        extra: dict[str, Any] = {} if run.constraints is None else {"constraints": run.constraints}
        choice, w = run.selector(ev, budget, alpha, sub.info, **extra)
        return PeriodResult(
            fingerprint=task.fingerprint, period=task.span, result=None, worst=w, method=run.method, robust=choice
        )
    r = resilient_select(ev, budget, alpha, run.rule, lazy=run.lazy, info=sub.info, constraints=run.constraints)
    w = worst_case(ev, [sub.library.position(s) for s in r.suite], alpha)
    return PeriodResult(fingerprint=task.fingerprint, period=task.span, result=r, worst=w)


def period_plan(
    problem: Problem,
    budget: float,
    alpha: int,
    rule: str,
    engine: str,
    jobs: int,
    lazy: bool,
    period: float,
    method: str = ALGORITHM_2,
    selector: Selector | None = None,
    constraints: Constraints | None = None,
) -> Plan[PeriodResult]:
    """The per-period selection as a plan: one task per period of ``period`` seconds (inputs checked by the caller)."""
    feas = feasible_set(problem.library, budget, constraints) if constraints is not None else None
    tasks = []
    for k, a, b, kf in split_periods(problem.scenario.keyframes.times, period):
        sc = period_scenario(problem, kf, a, b, f"{problem.scenario.name} {a:g}-{b:g} s")
        span = PeriodSpan(
            index=k, start_s=a, end_s=b, first_keyframe=int(kf[0]), n_keyframes=len(kf), n_landmarks=sc.n_landmarks
        )
        what: dict[str, Any] = {"what": "period", "period_s": period, "span": results.to_jsonable(span)}
        if method != ALGORITHM_2:  # Algorithm 2's fingerprints stay as they were (no method): their files are reused
            what["method"] = method
        what.update(constraints_key(feas))
        fp = fingerprint(problem.fingerprint_on(sc), budget, alpha, rule, engine, lazy, what)
        tasks.append(PeriodTask(span, sc, fp))
    state = PeriodRun(problem, budget, alpha, rule, engine, jobs, lazy, method, selector, constraints)
    return Plan("period", period_step, tuple(tasks), states=(state,))


def period_store(plan: Plan[PeriodResult], outdir: str | Path | None, resume: bool) -> Store[PeriodResult]:
    """Where a period plan's results are kept: ``OUTDIR/periods/period-NNNN.json`` (none without ``outdir``)."""
    if outdir is None:
        return NoStore()
    tasks: Sequence[PeriodTask] = plan.tasks
    whole = plan.states[0].problem

    def differences(i: int, old: Any) -> list[str]:
        info = old.result.problem if getattr(old, "result", None) is not None else None
        if info is None or info.fingerprint is None:
            return []
        return list(info.fingerprint.differences(whole.fingerprint_on(tasks[i].scenario)))

    return FileStore(
        [period_file(outdir, t.span.index) for t in tasks],
        [t.fingerprint for t in tasks],
        PeriodResult,
        lambda i, r: r,
        lambda r: r,
        resume=resume,
        differences=differences,
        what="other inputs (scenario, library, settings, budget, failures, rule, engine or period)",
    )


@dataclass(frozen=True)
class ResilientRun:
    """A resilient run's inputs besides its target, budget and failures (:func:`run_periods`,
    :func:`sensorsel.designs.resilient.resilient_report`).

    Attributes:
        rule: the greedy rule of greedy selection and of the active set.
        options: engine, jobs, aggregate (a domain's comparison), laziness, limits besides the budget
            that every suite keeps (part of every stored file's fingerprint, so a resume never mixes
            runs under other limits) and ``progress(periods done, total)`` after each period
            (:class:`~sensorsel.designs.options.RunOptions`).
        outdir: folder whose ``periods/`` receives the whole route's comparison and one JSON file per
            period as it completes.
        resume: reuse stored files whose fingerprint matches this run's inputs (a file that does not
            match is reported with a :class:`~sensorsel.designs.resilient.cache.CacheWarning` and recomputed).
        method: "algorithm-2" (the paper's Algorithm 2) or "robust" (``selector``).
        selector: robust selection (see :data:`Selector`), needed by "robust".
        executor: where the periods run (:mod:`sensorsel.pipeline`; default this process). The
            files are written by this process as the periods' results arrive.
    """

    rule: str = "uniform"
    options: RunOptions = field(default_factory=RunOptions)
    outdir: str | Path | None = None
    resume: bool = False
    method: str = ALGORITHM_2
    selector: Selector | None = None
    executor: Executor | None = None

    @classmethod
    def of(cls, **keywords: Any) -> ResilientRun:
        """The run of :class:`ResilientKeywords` (the run options and this run's own keywords)."""
        options, own = RunOptions.split(keywords)
        return cls(options=options, **own)


class ResilientKeywords(RunKeywords, total=False):
    """:class:`ResilientRun` as the keywords of a run function: the run options and its own."""

    rule: str
    outdir: str | Path | None
    resume: bool
    method: str
    selector: Selector | None
    executor: Executor | None


def run_periods(
    problem: Problem,
    budget_usd: float,
    alpha: int,
    *,
    period_s: float = DEFAULT_PERIOD_S,
    **run: Unpack[ResilientKeywords],
) -> PerPeriodResult:
    """Resilient selection on each period of ``problem``, the whole route (its observations tell which
    landmarks each period sees), of ``period_s`` [s] of the keyframe timestamps; the keywords:
    :class:`ResilientRun`."""
    return periods_of(problem, budget_usd, alpha, period_s, ResilientRun.of(**run))


def periods_of(problem: Problem, budget_usd: float, alpha: int, period_s: float, run: ResilientRun) -> PerPeriodResult:
    """:func:`run_periods` of one :class:`ResilientRun`."""
    t0 = time.perf_counter()
    budget, alpha, rule = check_budget(budget_usd), check_alpha(alpha), check_rule(run.rule)
    method = check_method(run.method, run.selector)
    period = check_period(period_s)
    o = run.options
    name = engine_name(o.engine)
    feas = feasible_set(problem.library, budget, o.constraints) if o.constraints is not None else None  # refuses
    plan = period_plan(problem, budget, alpha, rule, name, o.jobs, o.lazy, period, method, run.selector, o.constraints)
    out = execute(plan, run.executor, period_store(plan, run.outdir, run.resume), o.progress)
    if run.outdir is not None:
        # files of periods this run does not have (an earlier run with another period length) would mislead
        keep = {period_file(run.outdir, t.span.index).name for t in plan.tasks}
        for f in sorted((Path(run.outdir) / "periods").glob("period-*.json")):
            if f.name not in keep:
                f.unlink()
    return PerPeriodResult(
        period_s=period,
        alpha=alpha,
        budget_usd=budget,
        rule=rule,
        engine=name,
        periods=tuple(out),
        grid=make_grid(problem.library, out),
        seconds=elapsed_s(t0),
        method=method,
        constraints=recorded(feas),
    )


def make_grid(library: SensorLibrary, periods: Sequence[PeriodResult]) -> SelectionGrid:
    """The failed / active grid of per-period results (columns: the library, in its order), with each
    period's failure set worst for its suite."""
    ids = library.ids
    rows = []
    for p in periods:
        if p.result is not None:
            failed, active = set(p.result.failed), set(p.result.active)
        else:  # robust selection assumes no sensor failed: its whole suite is active
            failed, active = set(), set(p.worst.suite)
        rows.append(tuple(FAILED if s in failed else ACTIVE if s in active else UNUSED for s in ids))
    methods = {p.method for p in periods}
    return SelectionGrid(
        sensors=ids,
        models=tuple(s.model.code for s in library),
        positions=tuple("roof" if s.clock is None else str(s.clock) for s in library),
        period_labels=tuple(p.period.label for p in periods),
        period_start_s=tuple(p.period.start_s for p in periods),
        period_end_s=tuple(p.period.end_s for p in periods),
        cells=tuple(rows),
        worst_failures=tuple(tuple(p.worst.failures) for p in periods),
        method=methods.pop() if len(methods) == 1 else ALGORITHM_2,
    )


def save_grid_csv(grid: SelectionGrid, path: str | Path) -> Path:
    """Write the grid as CSV, atomically."""
    return atomic_write_text(path, grid.to_csv())
