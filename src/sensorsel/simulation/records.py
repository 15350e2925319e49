"""The records of a Monte-Carlo simulation: failures, runs, timings, a suite's result, the report.

Plain frozen dataclasses of numbers and strings (they serialize with :mod:`sensorsel.io.results`);
nothing here imports gtsam, so :mod:`sensorsel.plotting` can use them for type checking.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from sensorsel.io.results import result_kind
from sensorsel.model.problem import ProblemInfo


@dataclass(frozen=True)
class Failure:
    """A sensor of the suite that returns nothing on keyframes ``start .. stop - 1``.

    Attributes:
        sensor: sensor id (``"LRL-roof"``).
        start: first failed keyframe index.
        stop: one past the last failed keyframe; None = to the end of the route.
    """

    sensor: str
    start: int = 0
    stop: int | None = None

    def describe(self, n_poses: int | None = None) -> str:
        """``LRL-roof`` for the whole route, else ``LRL-roof@20-40`` (keyframes, half-open)."""
        whole = self.start == 0 and (self.stop is None or self.stop == n_poses)
        return self.sensor if whole else f"{self.sensor}@{self.start}-{'end' if self.stop is None else self.stop}"


@dataclass(frozen=True)
class RunResult:
    """One Monte-Carlo run: its errors against the ground truth and its estimate.

    Attributes:
        run: run number r (its random streams are seeded by (seed, r)).
        position_rmse_m: RMS over keyframes of the position error [m].
        heading_rmse_rad: RMS over keyframes of the heading error [rad].
        landmark_rmse_m: RMS over measured landmarks of the position error [m]; None if none measured.
        max_position_error_m: largest position error along the route [m].
        initial_position_rmse_m: position RMSE of the dead-reckoned start [m] (what SLAM improved on).
        nees_mean: average over keyframes of the 3-dof pose NEES (expected 3).
        nees_joint: joint NEES of all poses / K (expected 3).
        iterations: LM iterations, or iSAM2 updates.
        final_error: the graph's error 0.5 * sum of squared whitened residuals at the estimate.
        position_error_m: (K,) position error at each keyframe [m].
        heading_error_rad: (K,) signed heading error at each keyframe [rad].
        poses: (K,) estimated (x [m], y [m], heading [rad]).
        landmarks: estimated (x [m], y [m]) of each measured landmark, in the order of
            :attr:`SimulationResult.measured_landmarks`.
        longitudinal_error_m, lateral_error_m: (K,) signed position error at each keyframe in the
            keyframe's own (true) frame [m]: x forward (longitudinal), y to the left (lateral), i.e.
            R(θ_true)ᵀ (t_estimate − t_true). Empty in files written before they existed.
    """

    run: int
    position_rmse_m: float
    heading_rmse_rad: float
    landmark_rmse_m: float | None
    max_position_error_m: float
    initial_position_rmse_m: float
    nees_mean: float
    nees_joint: float
    iterations: int
    final_error: float
    position_error_m: tuple[float, ...]
    heading_error_rad: tuple[float, ...]
    poses: tuple[tuple[float, float, float], ...]
    landmarks: tuple[tuple[float, float], ...]
    longitudinal_error_m: tuple[float, ...] = ()
    lateral_error_m: tuple[float, ...] = ()


@dataclass(frozen=True)
class ErrorSpread:
    """How one component's 95 % error is spread over a route's keyframes (one unit: m or deg).

    Attributes:
        median, p95, max: over the keyframes, the median, 95th percentile (linear interpolation)
            and largest of the per-keyframe 95 % error.
        worst_keyframe: the keyframe with the largest (the first such, by index).
    """

    median: float
    p95: float
    max: float
    worst_keyframe: int


@dataclass(frozen=True)
class AccuracyCheck:
    """Predicted against measured 95 % errors of one suite, per component, in its keyframes' own frames.

    Per keyframe k: ``measured`` is the 95th percentile over the runs of |error_k| (linear
    interpolation between runs: with few runs it is close to the largest); ``predicted`` is
    1.96 σ_k, σ_k from the covariance the information matrix predicts (the same as
    :func:`sensorsel.information.evaluators.accuracy.route_accuracy` of the suite in the same model).

    Attributes:
        model: ``"slam"`` (landmarks unknown) or ``"map"`` (a prior map whose landmarks are known to
            ``map_sigma_m``).
        map_sigma_m: the map's landmark std [m] with the map model; None with SLAM.
        measured_lateral_95_m, predicted_lateral_95_m: (K,) lateral (keyframe's y, left) [m].
        measured_longitudinal_95_m, predicted_longitudinal_95_m: (K,) longitudinal (x, forward) [m].
        measured_heading_95_deg, predicted_heading_95_deg: (K,) heading [deg].
        measured, predicted: per component ("lateral", "longitudinal", "heading") its
            :class:`ErrorSpread` over the keyframes.
        coverage: per component, the fraction of all (run, keyframe) errors inside ±1.96 σ_k
            (0.95 when the prediction holds).
    """

    model: str
    map_sigma_m: float | None
    measured_lateral_95_m: tuple[float, ...]
    predicted_lateral_95_m: tuple[float, ...]
    measured_longitudinal_95_m: tuple[float, ...]
    predicted_longitudinal_95_m: tuple[float, ...]
    measured_heading_95_deg: tuple[float, ...]
    predicted_heading_95_deg: tuple[float, ...]
    measured: tuple[tuple[str, ErrorSpread], ...]
    predicted: tuple[tuple[str, ErrorSpread], ...]
    coverage: tuple[tuple[str, float], ...]

    def spread(self, which: str, component: str) -> ErrorSpread:
        """The :class:`ErrorSpread` of ``component`` ("lateral", "longitudinal", "heading"),
        ``which`` "measured" or "predicted"."""
        return dict(getattr(self, which))[component]


@dataclass(frozen=True)
class SimulationTiming:
    """Wall times [s] (kept apart: they are the only part of a result that varies between runs)."""

    total_s: float
    runs_s: float
    covariance_s: float
    jobs: int


@result_kind("simulation-suite")
@dataclass(frozen=True)
class SimulationResult:
    """N Monte-Carlo runs of one suite (with its failures): summary, prediction and every run.

    Attributes:
        label: name shown in tables and plots ("greedy", "resilient", "suite").
        suite: sensor ids, in library order.
        cost_usd: total cost of the suite [$].
        failures: failed sensors and their keyframe ranges (stop resolved to the route's end).
        solver: "lm" (Levenberg-Marquardt, batch) or "isam2" (incremental, keyframes in order).
        seed: base seed; run r uses (seed, r).
        n_runs: N.
        noise_scale: factor applied to every sigma (odometry, prior, measurements); 1 = the models.
        n_measurements: range-bearing measurements per run (after failures).
        n_measurements_failed: measurements the suite would have made but lost to failures.
        measured_landmarks: indices of the landmarks measured at least once (estimated).
        unmeasured_landmarks: indices of the landmarks never measured (left out of the estimate).
        position_rmse_m, heading_rmse_rad: RMS over all runs and keyframes [m], [rad].
        landmark_rmse_m: RMS over all runs and measured landmarks [m]; None if none measured.
        max_position_error_m: largest position error over all runs and keyframes [m].
        mean_max_position_error_m: per-run maximum position error, averaged over runs [m].
        initial_position_rmse_m: RMSE of the dead-reckoned starting points [m].
        predicted_position_rmse_m: sqrt(mean_k trace of P_k's position block) [m].
        predicted_heading_rmse_rad: sqrt(mean_k P_k's heading variance) [rad].
        predicted_landmark_rmse_m: sqrt(mean_j trace P_j) over measured landmarks [m]; None if none.
        position_rmse_along_route_m: (K,) RMS over runs of the position error at each keyframe [m].
        predicted_position_sigma_m: (K,) sqrt(trace of P_k's position block) [m].
        nees_mean: average 3-dof pose NEES over N runs and K poses (expected 3).
        nees_joint_mean: joint NEES of the K poses / K, averaged over runs (expected 3).
        nees_bounds: two-sided 95 % chi-square bounds (lower, upper) of either average, for N K
            independent 3-dof terms (exact for ``nees_joint_mean``).
        nees_bounds_correlated: 95 % bounds of ``nees_mean`` that account for the correlation of
            the poses along the route (moment-matched scaled chi-square, see :func:`nees_bounds`).
        nees_inside_bounds, nees_joint_inside_bounds: whether each average lies inside them.
        covariance: how the predicted covariance was obtained.
        problem: what it was computed on.
        runs: every run.
        timing: wall times (None once stripped for comparisons).
        model: the localization model simulated: ``"slam"`` (the paper's graph, no landmark prior)
            or ``"map"`` (each run draws a prior map, landmarks off by ``map_sigma_m``, and adds a
            landmark prior there of that std).
        map_sigma_m: the map's landmark std [m] with the map model; None with SLAM.
        accuracy: predicted against measured 95 % lateral, longitudinal and heading errors (None in
            files written before it existed).
    """

    label: str
    suite: tuple[str, ...]
    cost_usd: float
    failures: tuple[Failure, ...]
    solver: str
    seed: int
    n_runs: int
    noise_scale: float
    n_measurements: int
    n_measurements_failed: int
    measured_landmarks: tuple[int, ...]
    unmeasured_landmarks: tuple[int, ...]
    position_rmse_m: float
    heading_rmse_rad: float
    landmark_rmse_m: float | None
    max_position_error_m: float
    mean_max_position_error_m: float
    initial_position_rmse_m: float
    predicted_position_rmse_m: float
    predicted_heading_rmse_rad: float
    predicted_landmark_rmse_m: float | None
    position_rmse_along_route_m: tuple[float, ...]
    predicted_position_sigma_m: tuple[float, ...]
    nees_mean: float
    nees_joint_mean: float
    nees_bounds: tuple[float, float]
    nees_bounds_correlated: tuple[float, float]
    nees_inside_bounds: bool
    nees_joint_inside_bounds: bool
    covariance: str
    problem: ProblemInfo
    runs: tuple[RunResult, ...]
    timing: SimulationTiming | None = None
    model: str = "slam"
    map_sigma_m: float | None = None
    accuracy: AccuracyCheck | None = None


@dataclass(frozen=True)
class AssociationKeyframe:
    """One keyframe of ``simulate --associate``: the predicted P(at least one wrong association)
    beside what the associator did on the draws.

    Attributes:
        keyframe: k; n_measurements: the suite's measurements there.
        predicted_estimate, predicted_bound: the integrity engine's estimate and bound.
        observed: the observed probability (importance sampling: Σ over measurements).
        standard_error: of ``observed``.
        wrong_draws: draws with a wrong association (plain Monte Carlo; −1 when importance sampled).
        draws: draws at this keyframe (per measurement when importance sampled).
        observed_clutter: P(a clutter detection matched to a landmark) (nan without clutter or when
            importance sampled).
        shift_lateral_m, shift_longitudinal_m, shift_heading_deg: mean largest shift of the pose
            estimate a wrong association causes (the filter's update with the wrong landmark; nan: none seen).
        p_beyond_alert: P(a wrong association shifts the estimate beyond an alert limit).
    """

    keyframe: int
    n_measurements: int
    predicted_estimate: float
    predicted_bound: float
    observed: float
    standard_error: float
    wrong_draws: int
    draws: int
    observed_clutter: float
    shift_lateral_m: float
    shift_longitudinal_m: float
    shift_heading_deg: float
    p_beyond_alert: float


@dataclass(frozen=True)
class SensorAssociation:
    """Wrong associations of one sensor of the suite: expected per keyframe, predicted (Σ of its
    measurements' estimates, mean over keyframes) and observed."""

    sensor: str
    predicted_per_keyframe: float
    observed_per_keyframe: float


@dataclass(frozen=True)
class CalibrationBin:
    """Keyframes whose predicted estimate lies in [lo, hi): their mean estimate and bound, and the
    observed rate pooled over them with its 99 % confidence interval (plain Monte Carlo:
    Clopper–Pearson on the pooled counts; importance sampling: normal, ±2.576 standard errors)."""

    lo: float
    hi: float
    keyframes: int
    predicted: float
    bound: float
    observed: float
    ci_low: float
    ci_high: float


@dataclass(frozen=True)
class AssociationCheck:
    """``simulate --associate`` of one suite: the stated associator run on simulated measurements.

    Attributes:
        label, suite: the design's name and sensor ids.
        model: ``"map"`` or ``"slam"``; map_sigma_m: the map's std [m] (None in SLAM).
        gate_probability: p_G of the associator's χ²₂ gate.
        draws, seed: draws per keyframe (per measurement when importance sampled) and the seed.
        importance_sampling: whether importance sampled (else plain Monte Carlo); sampling: how, in words.
        clutter_per_km: unmapped clutter objects per km of route; corridor_m: within this of the route.
        shift: how the error a wrong association causes is computed, in words.
        keyframes, sensors, bins: per keyframe, per sensor, calibration bins.
        keyframes_per_hour: n_h; predicted_per_hour, bound_per_hour, observed_per_hour: n_h × the
            mean per keyframe (wrong associations per hour of driving, to first order).
        resolved: keyframes Monte Carlo resolves (plain: ≥ 10 wrong draws; importance sampling: a
            relative standard error ≤ 0.3); within_factor_2: of those, the estimate within 2× of the
            observed; bound_below_lower: keyframes whose bound is below the observed 99 % lower limit.
    """

    label: str
    suite: tuple[str, ...]
    model: str
    map_sigma_m: float | None
    gate_probability: float
    draws: int
    seed: int
    importance_sampling: bool
    sampling: str
    clutter_per_km: float
    corridor_m: float
    shift: str
    keyframes: tuple[AssociationKeyframe, ...]
    sensors: tuple[SensorAssociation, ...]
    bins: tuple[CalibrationBin, ...]
    keyframes_per_hour: float
    predicted_per_hour: float
    bound_per_hour: float
    observed_per_hour: float
    resolved: int
    within_factor_2: int
    bound_below_lower: int


@result_kind("simulation")
@dataclass(frozen=True)
class SimulationReport:
    """What ``sensorsel simulate`` writes: one :class:`SimulationResult` per suite simulated, and
    with ``--associate`` one :class:`AssociationCheck` per suite instead."""

    simulations: tuple[SimulationResult, ...] = field(default_factory=tuple)
    associations: tuple[AssociationCheck, ...] = field(default_factory=tuple)


def without_timing(result: SimulationResult) -> SimulationResult:
    """The result with its wall times removed (what is byte-identical between equal runs)."""
    return replace(result, timing=None)
