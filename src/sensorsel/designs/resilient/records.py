"""The records of resilient selection: worst cases, selections, comparisons, periods, the grid, the report.

Plain frozen dataclasses (they serialize with :mod:`sensorsel.io.results`); no computation here.
"""

from __future__ import annotations

from dataclasses import dataclass

from sensorsel.designs.parts import Provenance, SuiteQuality
from sensorsel.designs.selection import GreedyResult
from sensorsel.errors import InputError
from sensorsel.io.records import AlphaBudget, MethodWorst
from sensorsel.io.results import result_kind
from sensorsel.model.constraints import Constraints

#: Cell states of the selection grid.
FAILED, ACTIVE, UNUSED = "failed", "active", ""


@result_kind("resilient-worst-case")
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


@result_kind("resilient-selection")
@dataclass(frozen=True)
class ResilientResult(Provenance, AlphaBudget):
    """A resilient selection: the failing set bought first, then greedy on the rest of the budget.

    Attributes:
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
        constraints: (:class:`~sensorsel.designs.parts.Provenance`'s) the limits the failing and the
            active set together respected.
    """

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


@result_kind("resilient-comparison")
@dataclass(frozen=True)
class Comparison(Provenance, AlphaBudget):
    """Greedy versus resilient selection at the same budget on one scenario, and their worst cases.

    Attributes:
        rule: the greedy rule of both.
        greedy: the plain greedy run.
        resilient: the resilient selection.
        greedy_worst: worst case of the greedy suite.
        resilient_worst: worst case of the resilient suite.
        engine: the evaluator used.
        fingerprint: digest of the inputs (for resuming).
        problem, seconds, constraints: :class:`~sensorsel.designs.parts.Provenance`'s; the
            constraints both selections respected.
    """

    rule: str
    greedy: GreedyResult
    resilient: ResilientResult
    greedy_worst: WorstCase
    resilient_worst: WorstCase
    engine: str
    fingerprint: str


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


#: The paper's Algorithm 2, by its one name: ``resilient --method``, robust selection's candidate,
#: a study's ``method``, every record and fingerprint.
ALGORITHM_2 = "algorithm-2"
#: How the suite of ``sensorsel resilient`` is chosen: the paper's Algorithm 2, or robust selection.
METHODS = (ALGORITHM_2, "robust")


@dataclass(frozen=True)
class RobustOutcome(MethodWorst):
    """What robust selection chose and how it compares: :class:`~sensorsel.io.records.MethodWorst`'s
    fields (the winning method, its suite in library order, its cost, nominal score and worst case,
    never below greedy's nor Algorithm 2's, with the failures attaining it), then these.

    Attributes:
        greedy_worst_score: the plain (uniform) greedy suite's exact worst case [nats].
        algorithm2_worst_score: Algorithm 2's [nats].
        bound: upper bound on the best achievable worst case [nats].
        gap_percent: 100 * (bound - worst_score) / bound.
    """

    greedy_worst_score: float
    algorithm2_worst_score: float
    bound: float
    gap_percent: float


@dataclass(frozen=True)
class RobustChoice(RobustOutcome):
    """The suite robust selection chose (:func:`sensorsel.designs.robust.robust_select`), in short:
    :class:`RobustOutcome`'s fields, then these.

    Attributes:
        n_evaluations: suites scored.
        seconds: wall time [s].
    """

    n_evaluations: int
    seconds: float = 0.0


@result_kind("resilient-period")
@dataclass(frozen=True)
class PeriodResult:
    """Resilient selection on one period, as written to its own file.

    Attributes:
        fingerprint: digest of every input of this period (resume reuses the file only if it matches).
        period: the span.
        result: the paper's resilient selection on the period's scenario (None with ``method="robust"``).
        worst: worst case of the period's chosen suite on the period's scenario (its ``failures`` are the
            failure set worst for that suite).
        method: "algorithm-2" or "robust".
        robust: with "robust", the robust selection's choice; else None.
    """

    fingerprint: str
    period: PeriodSpan
    result: ResilientResult | None
    worst: WorstCase
    method: str = ALGORITHM_2
    robust: RobustChoice | None = None

    @property
    def suite(self) -> tuple[str, ...]:
        """Ids of the period's chosen suite."""
        return self.worst.suite


@result_kind("resilient-grid")
@dataclass(frozen=True)
class SelectionGrid:
    """The paper's Fig. 5 as data: rows = periods, columns = sensors of the library.

    Attributes:
        sensors: column ids, in library order.
        models: model code of each column (columns of one model are consecutive).
        positions: clock position of each column ("12", "1", ...) or "roof".
        period_labels: row labels (time spans).
        period_start_s, period_end_s: row bounds [s].
        cells: rows x columns of "failed", "active" or "" ("failed": assumed to fail by the paper's
            Algorithm 2; robust selection assumes no sensor, so its suite is all "active").
        worst_failures: per row, the failure set worst for the row's suite (ids; empty rows when unknown).
        method: "algorithm-2" or "robust": how each row's suite was chosen.
    """

    sensors: tuple[str, ...]
    models: tuple[str, ...]
    positions: tuple[str, ...]
    period_labels: tuple[str, ...]
    period_start_s: tuple[float, ...]
    period_end_s: tuple[float, ...]
    cells: tuple[tuple[str, ...], ...]
    worst_failures: tuple[tuple[str, ...], ...] = ()
    method: str = ALGORITHM_2

    def __post_init__(self) -> None:
        n = len(self.sensors)
        if len(self.models) != n or len(self.positions) != n:
            raise InputError(
                f"selection grid: {n} sensors but {len(self.models)} models and {len(self.positions)} positions"
            )
        r = len(self.cells)
        if not (len(self.period_labels) == len(self.period_start_s) == len(self.period_end_s) == r):
            raise InputError(f"selection grid: {r} rows but {len(self.period_labels)} labels")
        for i, row in enumerate(self.cells):
            if len(row) != n:
                raise InputError(f"selection grid: row {i} has {len(row)} cells, expected {n}")
            for c in row:
                if c not in (FAILED, ACTIVE, UNUSED):
                    raise InputError(f"selection grid: row {i}: unknown cell state {c!r}")
        if self.worst_failures and len(self.worst_failures) != r:
            raise InputError(f"selection grid: {r} rows but {len(self.worst_failures)} worst failure sets")
        for i, f in enumerate(self.worst_failures):
            if not set(f) <= set(self.sensors):
                raise InputError(f"selection grid: row {i}: worst failures {f} are not all sensors of the grid")

    def failed(self, row: int) -> set[str]:
        """Ids marked failed in a row."""
        return {s for s, c in zip(self.sensors, self.cells[row]) if c == FAILED}

    def active(self, row: int) -> set[str]:
        """Ids marked active in a row."""
        return {s for s, c in zip(self.sensors, self.cells[row]) if c == ACTIVE}

    def worst(self, row: int) -> tuple[str, ...]:
        """Ids of the failure set worst for a row's suite (empty when unknown)."""
        return self.worst_failures[row] if self.worst_failures else ()

    def to_csv(self) -> str:
        """CSV text: one row per period (label, start, end, one cell per sensor, then ``worst_failures``:
        the failure set worst for the period's suite, ids joined by "+")."""
        lines = [",".join(["period", "start_s", "end_s", *self.sensors, "worst_failures"])]
        for k, (lab, a, b, row) in enumerate(
            zip(self.period_labels, self.period_start_s, self.period_end_s, self.cells)
        ):
            lines.append(",".join([lab, repr(a), repr(b), *row, "+".join(self.worst(k))]))
        return "\n".join(lines) + "\n"


@result_kind("resilient-periods")
@dataclass(frozen=True)
class PerPeriodResult:
    """Resilient selection period by period along the route, and its grid.

    Attributes:
        period_s: period length [s].
        alpha, budget_usd, rule, engine: as in each period's selection.
        periods: one result per non-empty period, in time order.
        grid: the failed / active grid.
        seconds: wall time of this run [s] (periods reused from files count their stored time no more).
        method: "algorithm-2" or "robust".
        constraints: the limits besides the budget every period's suite respected; None: the budget alone.
    """

    period_s: float
    alpha: int
    budget_usd: float
    rule: str
    engine: str
    periods: tuple[PeriodResult, ...]
    grid: SelectionGrid
    seconds: float = 0.0
    method: str = ALGORITHM_2
    constraints: Constraints | None = None


@result_kind("resilient")
@dataclass(frozen=True)
class ResilientReport(SuiteQuality):
    """What ``sensorsel resilient`` writes to ``resilient.json``, the chosen suite's accuracy and
    integrity last (:class:`~sensorsel.designs.parts.SuiteQuality`).

    Attributes:
        suite: ids of the whole-route chosen suite: Algorithm 2's (the failing sensors included), or with
            ``method="robust"`` the robust selection's.
        failed: ids of the sensors Algorithm 2 assumes to fail (empty with "robust": it assumes none;
            the failure set worst for its suite is ``robust.failures``).
        alpha, budget_usd, rule, engine: the run's inputs.
        comparison: greedy versus resilient on the whole route.
        per_period: the per-period selection and its grid (None when not run).
        seconds: wall time [s].
        method: "algorithm-2" (the paper's Algorithm 2) or "robust" (robust selection, whole route and
            each period).
        robust: with "robust", the whole route's robust choice (next to the greedy / Algorithm 2 comparison).
        constraints: the limits besides the budget every suite of the report respected; None: the budget alone.
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
    method: str = ALGORITHM_2
    robust: RobustChoice | None = None
    constraints: Constraints | None = None
