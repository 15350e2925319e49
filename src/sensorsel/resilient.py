"""Resilient sensor selection against alpha failures (the paper's Section VI, Algorithm 2).

After Tzoumas, Jadbabaie & Pappas, "Resilient Non-Submodular Maximization over Matroid
Constraints" (arXiv 1804.01013), Algorithm 1, with the matroid replaced by the cost budget:

1. **Failing set.** The alpha sensors with the largest individual scores f({e}) are bought and
   assumed to fail. They are picked greedily by f({e}): at each of alpha steps, among the sensors not
   yet picked that are *affordable* (the failing set's total cost stays within the budget once the
   sensor is added) and *informative* (f({e}) above round-off), the one with the largest f({e}) is
   picked; ties (relative 1e-9, as in :mod:`sensorsel.selection`) go to the cheaper sensor, then
   the smaller id. A sensor that does not fit is skipped and the next one is tried, as Tzoumas et
   al. skip an element that would leave the matroid. Fewer than alpha sensors are picked only when
   fewer are informative and fit (the result says so).
2. **Active set.** The rest of the budget (budget minus the failing set's cost) is spent by greedy
   selection (:func:`sensorsel.selection.greedy`, the uniform rule by default) on the library
   without the failing sensors, starting from the empty suite.

The resilient suite is the union; alpha = 0 is plain greedy selection.

**Worst case** of any suite S: min over F subset of S, |F| = alpha of f(S minus F), computed exactly
by enumerating the C(|S|, alpha) failure sets (one evaluation each; |S| for alpha = 1). A suite of
alpha sensors or fewer loses all of them (worst case 0).

**Per period.** The route is split into periods of ``period_s`` seconds of the keyframe
timestamps; each period gets its own scenario (its keyframes, the first one anchored by the
first-pose prior, and the landmarks any library sensor sees from them) and its own resilient
selection. The resulting grid of failed / active sensors is the paper's Fig. 5. Each period's result
is written to its own file as it completes, stamped with a fingerprint of its inputs, so an
interrupted run resumes where it stopped and ends with the same result as an uninterrupted one.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from . import results
from .errors import InputError, ResultFileError
from .evaluators import DEFAULT_ENGINE, ENGINES, Evaluator, as_suite, make_evaluator
from .fileio import atomic_write_text
from .problem import Problem, ProblemInfo, build_problem
from .scenario import Scenario
from .selection import REL_TOL, SELECTORS, GreedyResult, check_budget, greedy

#: progress(done, total): called after each period (computed or reused).
Progress = Callable[[int, int], None]

#: Default length of a period [s] (the paper says "several seconds").
DEFAULT_PERIOD_S = 10.0

#: Cell states of the selection grid.
FAILED, ACTIVE, UNUSED = "failed", "active", ""

#: Enumeration limit of the worst-case evaluation (failure sets scored).
MAX_FAILURE_SETS = 200_000

#: Bumped whenever what a period file holds, or how it is computed, changes (invalidates resume).
_FORMAT = 1


# ----------------------------------------------------------------------------------- records


@dataclass(frozen=True)
class WorstCase:
    """The score a suite keeps when its worst alpha sensors fail.

    Attributes:
        suite: ids of the suite, in library order.
        alpha: failures considered (at most the suite's size are applied).
        nominal_score: f(suite) with nothing failed [nats].
        score: min over failure sets F (|F| = min(alpha, |S|)) of f(S minus F) [nats].
        failures: ids of the failure set attaining it (ties within a relative 1e-9: the first in
            library order, i.e. lexicographic on library positions).
        survivors: ids left working in that case.
        n_failure_sets: failure sets enumerated, C(|S|, alpha).
        n_evaluations: suites scored.
    """

    suite: tuple[str, ...]
    alpha: int
    nominal_score: float
    score: float
    failures: tuple[str, ...]
    survivors: tuple[str, ...]
    n_failure_sets: int
    n_evaluations: int


@dataclass(frozen=True)
class ResilientResult:
    """A resilient selection: the failing set bought first, then greedy on the rest of the budget.

    Attributes:
        alpha: failures designed for.
        budget_usd: the whole budget [$] (the failing sensors count against it).
        objective: the greedy rule of the active set ("uniform", ...).
        suite: ids of the whole resilient suite: the failing set, then the active set, in pick order.
        failed: ids assumed to fail, in pick order (largest f({e}) first).
        failed_scores: f({e}) of each failing sensor [nats].
        failure_note: empty, or why fewer than alpha sensors were designated to fail.
        active: ids bought by greedy selection on the library without the failing set, in pick order.
        failed_cost_usd: cost of the failing set [$].
        cost_usd: cost of the whole suite [$] (never above the budget).
        score: f(suite), nothing failed [nats].
        active_score: f(active), the score left if the designated sensors do fail [nats].
        greedy: the greedy run that chose the active set (budget = budget - failed cost).
        n_evaluations: suites scored (singletons, greedy, the final suite).
        engine: the evaluator used.
        problem: what it was computed on.
        seconds: wall time [s] (varies between runs).
    """

    alpha: int
    budget_usd: float
    objective: str
    suite: tuple[str, ...]
    failed: tuple[str, ...]
    failed_scores: tuple[float, ...]
    failure_note: str
    active: tuple[str, ...]
    failed_cost_usd: float
    cost_usd: float
    score: float
    active_score: float
    greedy: GreedyResult
    n_evaluations: int
    engine: str
    problem: ProblemInfo | None = None
    seconds: float = 0.0


@dataclass(frozen=True)
class Comparison:
    """Greedy versus resilient selection at the same budget on one scenario, and their worst cases.

    Attributes:
        alpha: failures designed for and evaluated.
        budget_usd: the budget of both [$].
        objective: the greedy rule of both.
        greedy: the plain greedy run.
        resilient: the resilient selection.
        greedy_worst: worst case of the greedy suite.
        resilient_worst: worst case of the resilient suite.
        engine: the evaluator used.
        fingerprint: digest of the inputs (for resuming).
        problem: what it was computed on.
        seconds: wall time [s].
    """

    alpha: int
    budget_usd: float
    objective: str
    greedy: GreedyResult
    resilient: ResilientResult
    greedy_worst: WorstCase
    resilient_worst: WorstCase
    engine: str
    fingerprint: str
    problem: ProblemInfo | None = None
    seconds: float = 0.0


@dataclass(frozen=True)
class PeriodSpan:
    """One period of the route.

    Attributes:
        index: k, the period's number: its keyframes have floor((t - t0) / period) = k.
        start_s: t0 + k * period [s], in the route's timestamps (inclusive).
        end_s: t0 + (k + 1) * period [s] (exclusive).
        first_keyframe: index of its first keyframe in the whole route.
        n_keyframes: its keyframes (consecutive in the route).
        n_landmarks: landmarks some library sensor sees from them.
    """

    index: int
    start_s: float
    end_s: float
    first_keyframe: int
    n_keyframes: int
    n_landmarks: int

    @property
    def label(self) -> str:
        """Its time span, e.g. "10-20 s"."""
        return f"{self.start_s:g}-{self.end_s:g} s"

    @property
    def keyframes(self) -> range:
        return range(self.first_keyframe, self.first_keyframe + self.n_keyframes)


@dataclass(frozen=True)
class PeriodResult:
    """Resilient selection on one period, as written to its own file.

    Attributes:
        fingerprint: digest of every input of this period (resume reuses the file only if it matches).
        period: the span.
        result: resilient selection on the period's scenario.
        worst: worst case of the period's resilient suite on the period's scenario.
    """

    fingerprint: str
    period: PeriodSpan
    result: ResilientResult
    worst: WorstCase


@dataclass(frozen=True)
class SelectionGrid:
    """The paper's Fig. 5 as data: rows = periods, columns = sensors of the library.

    Attributes:
        sensors: column ids, in library order.
        models: model code of each column (columns of one model are consecutive).
        positions: clock position of each column ("12", "1", ...) or "roof".
        period_labels: row labels (time spans).
        period_start_s, period_end_s: row bounds [s].
        cells: rows x columns of "failed", "active" or "".
    """

    sensors: tuple[str, ...]
    models: tuple[str, ...]
    positions: tuple[str, ...]
    period_labels: tuple[str, ...]
    period_start_s: tuple[float, ...]
    period_end_s: tuple[float, ...]
    cells: tuple[tuple[str, ...], ...]

    def __post_init__(self) -> None:
        n = len(self.sensors)
        if len(self.models) != n or len(self.positions) != n:
            raise InputError(f"selection grid: {n} sensors but {len(self.models)} models and {len(self.positions)} positions")
        r = len(self.cells)
        if not (len(self.period_labels) == len(self.period_start_s) == len(self.period_end_s) == r):
            raise InputError(f"selection grid: {r} rows but {len(self.period_labels)} labels")
        for i, row in enumerate(self.cells):
            if len(row) != n:
                raise InputError(f"selection grid: row {i} has {len(row)} cells, expected {n}")
            for c in row:
                if c not in (FAILED, ACTIVE, UNUSED):
                    raise InputError(f"selection grid: row {i}: unknown cell state {c!r}")

    def failed(self, row: int) -> set[str]:
        """Ids marked failed in a row."""
        return {s for s, c in zip(self.sensors, self.cells[row]) if c == FAILED}

    def active(self, row: int) -> set[str]:
        """Ids marked active in a row."""
        return {s for s, c in zip(self.sensors, self.cells[row]) if c == ACTIVE}

    def to_csv(self) -> str:
        """CSV text: one row per period (label, start, end, then one cell per sensor)."""
        lines = [",".join(["period", "start_s", "end_s", *self.sensors])]
        for lab, a, b, row in zip(self.period_labels, self.period_start_s, self.period_end_s, self.cells):
            lines.append(",".join([lab, repr(a), repr(b), *row]))
        return "\n".join(lines) + "\n"


@dataclass(frozen=True)
class PerPeriodResult:
    """Resilient selection period by period along the route, and its grid.

    Attributes:
        period_s: period length [s].
        alpha, budget_usd, objective, engine: as in each period's selection.
        periods: one result per non-empty period, in time order.
        grid: the failed / active grid.
        seconds: wall time of this run [s] (periods reused from files count their stored time no more).
    """

    period_s: float
    alpha: int
    budget_usd: float
    objective: str
    engine: str
    periods: tuple[PeriodResult, ...]
    grid: SelectionGrid
    seconds: float = 0.0


@dataclass(frozen=True)
class ResilientReport:
    """What ``sensorsel resilient`` writes to ``resilient.json``.

    Attributes:
        suite: ids of the whole-route resilient suite, the failing sensors included.
        failed: ids of the sensors assumed to fail.
        alpha, budget_usd, objective, engine: the run's inputs.
        comparison: greedy versus resilient on the whole route.
        per_period: the per-period selection and its grid (None when not run).
        seconds: wall time [s].
    """

    suite: tuple[str, ...]
    failed: tuple[str, ...]
    alpha: int
    budget_usd: float
    objective: str
    engine: str
    comparison: Comparison
    per_period: PerPeriodResult | None = None
    seconds: float = 0.0


# ------------------------------------------------------------------------------------ checks


def check_alpha(alpha: int) -> int:
    """The number of failures as an int; refuses negatives and non-integers."""
    if isinstance(alpha, bool) or not isinstance(alpha, (int, np.integer)) or alpha < 0:
        raise InputError(f"failures (alpha) must be a non-negative integer, got {alpha!r}")
    return int(alpha)


def check_period(period_s: float) -> float:
    """A period length [s]; refuses zero, negative, NaN and infinite values."""
    if isinstance(period_s, bool) or not isinstance(period_s, (int, float)) or not math.isfinite(period_s) or period_s <= 0:
        raise InputError(f"period must be a positive number of seconds, got {period_s!r}")
    return float(period_s)


def check_objective(objective: str) -> str:
    if objective not in SELECTORS:
        raise InputError(f"unknown objective {objective!r}; available: {', '.join(SELECTORS)}")
    return objective


# ---------------------------------------------------------------------------- selection


def failing_set(evaluator: Evaluator, budget_usd: float, alpha: int) -> tuple[list[int], list[float], str]:
    """The alpha sensors assumed to fail: largest f({e}) first, skipping those that do not fit.

    Returns:
        (library positions in pick order, their f({e}) [nats], note: "" or why fewer than alpha).
    """
    budget = check_budget(budget_usd)
    alpha = check_alpha(alpha)
    lib = evaluator.problem.library
    if alpha == 0:
        return [], [], ""
    costs, ids = lib.costs, lib.ids
    singles = evaluator.scores_with((), list(range(len(lib))))
    gain_tol = REL_TOL  # f(empty) = 0: the round-off scale of a singleton's gain
    picked: list[int] = []
    spent = 0.0
    left = np.ones(len(lib), dtype=bool)
    for _ in range(alpha):
        ok = left & (costs <= budget - spent + 1e-9) & (singles > gain_tol)
        if not ok.any():
            break
        cand = np.flatnonzero(ok)
        best = singles[cand].max()
        tied = cand[singles[cand] >= best - REL_TOL * max(1.0, abs(best))]
        pick = int(min(tied, key=lambda i: (costs[i], ids[i])))
        picked.append(pick)
        left[pick] = False
        spent += float(costs[pick])
    note = ""
    if len(picked) < alpha:
        note = (f"only {len(picked)} informative sensor(s) fit the budget ${budget:,.0f} as failing sensors; "
                f"{alpha} requested")
    return picked, [float(singles[i]) for i in picked], note


def resilient_select(evaluator: Evaluator, budget_usd: float, alpha: int, objective: str = "uniform", *, lazy: bool = True,
                     info: ProblemInfo | None = None) -> ResilientResult:
    """Resilient selection for ``alpha`` failures under ``budget_usd`` (see the module docstring).

    Args:
        evaluator: scores suites of the problem.
        budget_usd: total budget [$], the failing sensors included.
        alpha: number of failures (0: plain greedy).
        objective: greedy rule of the active set (see :data:`sensorsel.selection.SELECTORS`).
        lazy: lazy (Minoux) evaluation in the greedy run (same picks).
        info: what the problem is, recorded in the result.
    """
    t0 = time.perf_counter()
    budget = check_budget(budget_usd)
    alpha = check_alpha(alpha)
    check_objective(objective)
    n0 = evaluator.n_evaluations
    lib = evaluator.problem.library
    failed, failed_scores, note = failing_set(evaluator, budget, alpha)
    failed_cost = lib.cost(failed)
    rest = max(0.0, budget - failed_cost)  # never negative: the failing set fits by construction
    run = greedy(evaluator, rest, objective, lazy=lazy, exclude=frozenset(failed), start=(), info=info)
    active = [lib.position(s) for s in run.suite]
    suite = failed + active
    score = evaluator.score(suite) if failed else run.score
    return ResilientResult(
        alpha=alpha, budget_usd=budget, objective=objective, suite=lib.suite_ids(suite), failed=lib.suite_ids(failed),
        failed_scores=tuple(failed_scores), failure_note=note, active=run.suite, failed_cost_usd=failed_cost,
        cost_usd=lib.cost(suite), score=float(score), active_score=run.score, greedy=run,
        n_evaluations=evaluator.n_evaluations - n0, engine=evaluator.name, problem=info,
        seconds=round(time.perf_counter() - t0, 6),
    )


def worst_case(evaluator: Evaluator, suite: Sequence[int] | str, alpha: int, *, max_failure_sets: int = MAX_FAILURE_SETS) -> WorstCase:
    """Exact worst case of a suite under ``alpha`` failures, by enumeration of the failure sets.

    Args:
        evaluator: scores suites of the problem.
        suite: library positions, or comma-separated ids.
        alpha: failures (a suite of alpha sensors or fewer loses them all).
        max_failure_sets: refuse to enumerate more failure sets than this.
    Raises:
        InputError: negative alpha, or C(|S|, alpha) above ``max_failure_sets``.
    """
    alpha = check_alpha(alpha)
    lib = evaluator.problem.library
    s = lib.parse_suite(suite) if isinstance(suite, str) else as_suite(suite)
    k = min(alpha, len(s))
    n_sets = math.comb(len(s), k)
    if n_sets > max_failure_sets:
        raise InputError(f"worst case of a {len(s)}-sensor suite with {alpha} failures needs {n_sets:,} evaluations "
                         f"(limit {max_failure_sets:,}); use fewer failures")
    n0 = evaluator.n_evaluations
    nominal = evaluator.score(s)
    # combinations() of a sorted tuple come in lexicographic order of library positions
    sets = list(itertools.combinations(s, k))
    vals = np.array([evaluator.score(tuple(i for i in s if i not in f)) if k < len(s) else 0.0 for f in sets])
    lo = vals.min()
    tied = np.flatnonzero(vals <= lo + REL_TOL * max(1.0, abs(lo)))
    worst = sets[int(tied[0])]
    return WorstCase(
        suite=lib.suite_ids(s), alpha=alpha, nominal_score=float(nominal), score=float(vals[tied[0]]),
        failures=lib.suite_ids(worst), survivors=lib.suite_ids(i for i in s if i not in worst),
        n_failure_sets=n_sets, n_evaluations=evaluator.n_evaluations - n0,
    )


# ------------------------------------------------------------------------------ fingerprints


def _digest(obj: object) -> str:
    return hashlib.sha256(json.dumps(obj, sort_keys=True, allow_nan=False).encode("utf-8")).hexdigest()


def _array_digest(*arrays: np.ndarray) -> str:
    h = hashlib.sha256()
    for a in arrays:
        a = np.ascontiguousarray(a, dtype=float)
        h.update(str(a.shape).encode())
        h.update(a.tobytes())
    return h.hexdigest()


def _fingerprint(problem: Problem, budget: float, alpha: int, objective: str, engine: str, lazy: bool,
                 what: dict) -> str:
    """Digest of everything a result depends on: scenario (spec and actual numbers), library (source
    and content), graph settings, budget, alpha, rule, engine, and ``what`` (e.g. the period bounds)."""
    sc = problem.scenario
    return _digest({
        "format": _FORMAT,
        "spec": results.to_jsonable(problem.spec),
        "scenario": _array_digest(sc.keyframes.poses, sc.keyframes.times, sc.landmarks),
        "library_source": problem.library.source,
        "library": _digest(results.to_jsonable(problem.library.sensors)),
        "settings": results.to_jsonable(problem.settings),
        "budget_usd": budget, "alpha": alpha, "objective": objective, "engine": engine, "lazy": lazy,
        **what,
    })


def _engine_name(engine: str | None) -> str:
    name = engine or DEFAULT_ENGINE
    if name not in ENGINES:
        raise InputError(f"unknown engine {name!r}; available: {', '.join(sorted(ENGINES))}")
    return name


def _load_matching(cls: type, path: Path, fingerprint: str):
    """The result stored at ``path`` if it is a ``cls`` with this fingerprint, else None."""
    if not path.is_file():
        return None
    try:
        old = results.load(cls, path)
    except ResultFileError:
        return None  # not ours or from an older format: recompute and overwrite
    return old if old.fingerprint == fingerprint else None


# ------------------------------------------------------------------------------- whole route


def compare(problem: Problem, budget_usd: float, alpha: int, objective: str = "uniform", *, engine: str | None = None,
            jobs: int = 1, lazy: bool = True, cache: str | Path | None = None,
            resume: bool = False) -> Comparison:
    """Greedy and resilient selection at the same budget, with the worst case of each suite.

    Args:
        cache: a file to save the result in (atomically); with ``resume``, reused when its inputs match.
    """
    t0 = time.perf_counter()
    budget, alpha, objective = check_budget(budget_usd), check_alpha(alpha), check_objective(objective)
    name = _engine_name(engine)
    fp = _fingerprint(problem, budget, alpha, objective, name, lazy, {"what": "whole route"})
    if cache is not None and resume:
        old = _load_matching(Comparison, Path(cache), fp)
        if old is not None:
            return old
    ev = make_evaluator(problem, name, jobs=jobs)
    info = problem.info
    g = greedy(ev, budget, objective, lazy=lazy, info=info)
    r = resilient_select(ev, budget, alpha, objective, lazy=lazy, info=info)
    lib = problem.library
    gw = worst_case(ev, [lib.position(s) for s in g.suite], alpha)
    rw = worst_case(ev, [lib.position(s) for s in r.suite], alpha)
    out = Comparison(alpha=alpha, budget_usd=budget, objective=objective, greedy=g, resilient=r, greedy_worst=gw,
                     resilient_worst=rw, engine=ev.name, fingerprint=fp, problem=info,
                     seconds=round(time.perf_counter() - t0, 6))
    if cache is not None:
        results.save(out, cache)
    return out


# -------------------------------------------------------------------------------- periods


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


def run_periods(problem: Problem, budget_usd: float, alpha: int, *, period_s: float = DEFAULT_PERIOD_S,
                objective: str = "uniform", engine: str | None = None, jobs: int = 1, lazy: bool = True,
                outdir: str | Path | None = None, resume: bool = False,
                progress: Progress | None = None) -> PerPeriodResult:
    """Resilient selection on each period of the route.

    Args:
        problem: the whole route (its observations tell which landmarks each period sees).
        period_s: period length [s] of the keyframe timestamps.
        outdir: folder whose ``periods/`` receives one JSON file per period as it completes.
        resume: reuse period files whose fingerprint matches this run's inputs.
        progress: progress(periods done, total) after each period.
    """
    t0 = time.perf_counter()
    budget, alpha, objective = check_budget(budget_usd), check_alpha(alpha), check_objective(objective)
    period = check_period(period_s)
    name = _engine_name(engine)
    spans = split_periods(problem.scenario.keyframes.times, period)
    out: list[PeriodResult] = []
    for n_done, (k, a, b, kf) in enumerate(spans, start=1):
        sc = period_scenario(problem, kf, a, b, f"{problem.scenario.name} {a:g}-{b:g} s")
        sub = build_problem(problem.library, sc, problem.settings, spec=problem.spec)
        span = PeriodSpan(index=k, start_s=a, end_s=b, first_keyframe=int(kf[0]), n_keyframes=len(kf), n_landmarks=sc.n_landmarks)
        fp = _fingerprint(sub, budget, alpha, objective, name, lazy,
                          {"what": "period", "period_s": period, "span": results.to_jsonable(span)})
        path = period_file(outdir, k) if outdir is not None else None
        res = _load_matching(PeriodResult, path, fp) if (path is not None and resume) else None
        if res is None:
            ev = make_evaluator(sub, name, jobs=jobs)
            info = sub.info
            r = resilient_select(ev, budget, alpha, objective, lazy=lazy, info=info)
            w = worst_case(ev, [sub.library.position(s) for s in r.suite], alpha)
            res = PeriodResult(fingerprint=fp, period=span, result=r, worst=w)
            if path is not None:
                results.save(res, path)
        out.append(res)
        if progress:
            progress(n_done, len(spans))
    if outdir is not None:
        # files of periods this run does not have (an earlier run with another period length) would mislead
        keep = {period_file(outdir, k).name for k, *_ in spans}
        for f in sorted((Path(outdir) / "periods").glob("period-*.json")):
            if f.name not in keep:
                f.unlink()
    return PerPeriodResult(period_s=period, alpha=alpha, budget_usd=budget, objective=objective, engine=name,
                           periods=tuple(out), grid=make_grid(problem.library, out),
                           seconds=round(time.perf_counter() - t0, 6))


def make_grid(library, periods: Sequence[PeriodResult]) -> SelectionGrid:
    """The failed / active grid of per-period results (columns: the library, in its order)."""
    ids = library.ids
    rows = []
    for p in periods:
        failed, active = set(p.result.failed), set(p.result.active)
        rows.append(tuple(FAILED if s in failed else ACTIVE if s in active else UNUSED for s in ids))
    return SelectionGrid(
        sensors=ids,
        models=tuple(s.model.code for s in library),
        positions=tuple("roof" if s.clock is None else str(s.clock) for s in library),
        period_labels=tuple(p.period.label for p in periods),
        period_start_s=tuple(p.period.start_s for p in periods),
        period_end_s=tuple(p.period.end_s for p in periods),
        cells=tuple(rows),
    )


def save_grid_csv(grid: SelectionGrid, path: str | Path) -> Path:
    """Write the grid as CSV, atomically."""
    return atomic_write_text(path, grid.to_csv())


def resilient_report(problem: Problem, budget_usd: float, alpha: int, *, period_s: float | None = DEFAULT_PERIOD_S,
                     objective: str = "uniform", engine: str | None = None, jobs: int = 1, lazy: bool = True,
                     outdir: str | Path | None = None, resume: bool = False,
                     progress: Progress | None = None) -> ResilientReport:
    """The whole-route comparison and (unless ``period_s`` is None) the per-period selection.

    With ``outdir``, the comparison is cached in ``outdir/periods/route.json`` and each period in
    ``outdir/periods/period-NNNN.json``; ``resume`` reuses those whose inputs match.
    """
    t0 = time.perf_counter()
    budget, alpha, objective = check_budget(budget_usd), check_alpha(alpha), check_objective(objective)
    if period_s is not None:
        check_period(period_s)
    cache = Path(outdir) / "periods" / "route.json" if outdir is not None else None
    cmp_ = compare(problem, budget, alpha, objective, engine=engine, jobs=jobs, lazy=lazy, cache=cache, resume=resume)
    per = None
    if period_s is not None:
        per = run_periods(problem, budget, alpha, period_s=period_s, objective=objective, engine=engine, jobs=jobs,
                          lazy=lazy, outdir=outdir, resume=resume, progress=progress)
    return ResilientReport(suite=cmp_.resilient.suite, failed=cmp_.resilient.failed, alpha=alpha, budget_usd=budget,
                           objective=objective, engine=cmp_.engine, comparison=cmp_, per_period=per,
                           seconds=round(time.perf_counter() - t0, 6))
