"""The records of resilient selection: worst cases, selections, comparisons, periods, the grid, the report.

Plain frozen dataclasses (they serialize with :mod:`sensorsel.results`); no computation here.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..errors import InputError
from ..problem import ProblemInfo, TargetInfo
from ..selection import GreedyResult

#: Cell states of the selection grid.
FAILED, ACTIVE, UNUSED = "failed", "active", ""


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
        rule: the greedy rule of the active set ("uniform", ...).
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
    rule: str
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
    problem: TargetInfo | None = None
    seconds: float = 0.0


@dataclass(frozen=True)
class Comparison:
    """Greedy versus resilient selection at the same budget on one scenario, and their worst cases.

    Attributes:
        alpha: failures designed for and evaluated.
        budget_usd: the budget of both [$].
        rule: the greedy rule of both.
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
    rule: str
    greedy: GreedyResult
    resilient: ResilientResult
    greedy_worst: WorstCase
    resilient_worst: WorstCase
    engine: str
    fingerprint: str
    problem: TargetInfo | None = None
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
        alpha, budget_usd, rule, engine: as in each period's selection.
        periods: one result per non-empty period, in time order.
        grid: the failed / active grid.
        seconds: wall time of this run [s] (periods reused from files count their stored time no more).
    """

    period_s: float
    alpha: int
    budget_usd: float
    rule: str
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
        alpha, budget_usd, rule, engine: the run's inputs.
        comparison: greedy versus resilient on the whole route.
        per_period: the per-period selection and its grid (None when not run).
        seconds: wall time [s].
    """

    suite: tuple[str, ...]
    failed: tuple[str, ...]
    alpha: int
    budget_usd: float
    rule: str
    engine: str
    comparison: Comparison
    per_period: PerPeriodResult | None = None
    seconds: float = 0.0
