"""Monte-Carlo validation of a design: drive the route with a suite's noisy sensors, solve SLAM, measure.

log det L(S) predicts how well SLAM will do with suite S. This module checks the prediction: for each
run it draws noisy odometry and range-bearing measurements from the same noise models the score uses
(:class:`~sensorsel.problem.GraphSettings` for odometry and the first-pose prior, the per-measurement
sigmas of :class:`~sensorsel.sensing.SensorObservations`), builds the nonlinear factor graph, starts
from dead reckoning (never from the truth), solves it with GTSAM and compares the estimate with the
ground truth.

Conventions (those of :class:`sensorsel.graph.GraphBuilder`): poses ``X(k)`` (``Pose2``), landmarks
``L(j)`` (``Point2``), ``BearingRangeFactor2D`` per measurement. Noise is drawn in each factor's own
error coordinates, so the factors' noise models are exactly right:

- first-pose prior: ``truth_0.retract(sigma * z)``; odometry: ``truth_{k-1}.between(truth_k).retract(sigma * z)``;
- bearing and range: truth + sigma * z.

Differences from the scoring graph, on purpose: there is no prior on landmarks (a car has none; a
prior at the true position would leak the truth into the estimate), and landmarks the suite never
measures (or measures only while failed) are left out and reported. The weak 100 m prior of the
score adds 1e-4 m^-2 of information per landmark, negligible against any measurement.

Random numbers: run ``r`` of seed ``s`` draws odometry from ``SeedSequence([s, r, 0])`` and the
measurements of library sensor ``i`` from ``SeedSequence([s, r, 1, i])``. So results do not depend on
``jobs``, and two suites (or a suite with and without a failure) see the same noise on the
odometry and on the sensors they share (common random numbers: their difference is the design's).

Consistency: each pose's error ``xi_k = truth_k.localCoordinates(estimate_k)`` (3-dof, GTSAM's tangent
space) is compared with the covariance predicted by the information matrix of the graph linearized
at the **ground truth** (``gtsam.Marginals``). That is the same information matrix whose log det is
the score, it does not depend on the draw, and it is computed once. (Marginals at each run's solution
would measure the estimator's own opinion of itself, not whether the design's prediction holds.)

- ``nees_mean``: the average of ``xi_k' P_k^-1 xi_k`` over N runs and K poses, with the two-sided 95 %
  chi-square bounds ``chi2.ppf([0.025, 0.975], 3 N K) / (N K)``. These bounds treat the N K terms as
  independent; poses along one route are correlated, so the true spread of this average is wider
  and the bounds are optimistic (a value slightly outside them is not, alone, a failure).
- ``nees_joint_mean``: the joint NEES of all poses of a run, ``xi' P^-1 xi`` with the full (3K x 3K)
  predicted covariance, averaged over runs and divided by K. Runs are independent, so
  ``N K nees_joint_mean ~ chi2(3 N K)`` exactly for a consistent linear-Gaussian estimator: the same
  bounds hold without approximation. This is the test to trust.

Worker processes (``jobs > 1``) are started by ``forkserver`` (``spawn`` where it does not exist):
they never inherit the parent's BLAS threads or gtsam objects, and only numbers travel between
processes (the measurement arrays once per worker, the estimates back).
"""

from __future__ import annotations

import math
import multiprocessing
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from typing import Iterable, Sequence

import gtsam
import numpy as np
from gtsam.symbol_shorthand import L, X
from scipy.stats import chi2

from .errors import InputError
from .objective import as_suite
from .problem import ProblemInfo
from .problem import Problem
from .progress import Progress
from .sensing import wrap_angle

SOLVERS = ("lm", "isam2")
DEFAULT_SOLVER = "lm"
NEES_CONFIDENCE = 0.95
LM_MAX_ITERATIONS = 100
ISAM2_MAX_FINAL_UPDATES = 20


# ----------------------------------------------------------------------------------------- records


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


@dataclass(frozen=True)
class SimulationTiming:
    """Wall times [s] (kept apart: they are the only part of a result that varies between runs)."""

    total_s: float
    runs_s: float
    covariance_s: float
    jobs: int


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


@dataclass(frozen=True)
class SimulationReport:
    """What ``sensorsel simulate`` writes: one :class:`SimulationResult` per suite simulated."""

    simulations: tuple[SimulationResult, ...] = field(default_factory=tuple)


COVARIANCE_NOTE = (
    "gtsam.Marginals of the simulated graph (same factors and noise, no landmark prior) linearized at the "
    "ground truth: the information matrix whose log det is the score, independent of the draw"
)


# ---------------------------------------------------------------------------------------- failures


def parse_failures(text: str, problem: Problem) -> tuple[Failure, ...]:
    """Failures from ``ID[@FROM-TO],...``: the whole route, keyframes FROM..TO-1, or seconds ``@30s-60s``.

    A period in seconds counts from the first keyframe's time and covers the keyframes with
    FROM <= t < TO. The same sensor may be listed with several periods.

    Raises:
        InputError: an unknown id, a malformed period, or one outside the route (names the item).
    """
    lib, kf = problem.library, problem.scenario.keyframes
    out = []
    for item in (t.strip() for t in text.split(",")):
        if not item:
            continue
        sid, _, period = item.partition("@")
        sensor = lib[lib.position(sid.strip())].id
        if not period:
            out.append(Failure(sensor))
            continue
        lo, sep, hi = period.partition("-")
        seconds = lo.strip().endswith("s") and hi.strip().endswith("s")
        try:
            if not sep:
                raise ValueError
            a, b = (float(v.strip().rstrip("s")) for v in (lo, hi))
        except ValueError:
            raise InputError(f"failure {item!r}: expected ID, ID@FROM-TO (keyframe indices, TO excluded) or ID@FROMs-TOs (seconds)") from None
        if seconds:
            t = kf.times - kf.times[0]
            idx = np.nonzero((t >= a) & (t < b))[0]
            if b <= a or len(idx) == 0:
                raise InputError(f"failure {item!r}: no keyframe in [{a:g} s, {b:g} s) (route lasts {t[-1]:g} s)")
            out.append(Failure(sensor, int(idx[0]), int(idx[-1]) + 1))
        else:
            if a != int(a) or b != int(b):
                raise InputError(f"failure {item!r}: keyframe indices must be integers (add 's' for seconds: @{lo}s-{hi}s)")
            out.append(Failure(sensor, int(a), int(b)))
    for f in out:
        _check_failure(f, problem)
    return tuple(out)


def _check_failure(f: Failure, problem: Problem) -> Failure:
    k = problem.scenario.n_poses
    stop = k if f.stop is None else f.stop
    if not (0 <= f.start < stop <= k):
        raise InputError(f"failure {f.describe()!r}: keyframes {f.start}..{stop - 1} are not inside the route (0..{k - 1})")
    return Failure(f.sensor, f.start, stop)


# ----------------------------------------------------------------------------------------- payload


@dataclass(frozen=True, eq=False)
class _Payload:
    """Everything a worker needs, as numbers only (pickled once per worker process).

    Measurements are grouped by sensor (``sensor_slices``) in sorted library order, each group in the
    problem's (pose, landmark) order; ``keep`` masks out those lost to failures.
    """

    poses: np.ndarray  # (K, 3) truth
    landmarks: np.ndarray  # (M, 2) truth
    first_pose_sigmas: np.ndarray  # (3,) scaled
    odometry_sigmas: np.ndarray  # (3,) scaled
    sensors: tuple[int, ...]
    sensor_slices: tuple[tuple[int, int], ...]
    pose: np.ndarray  # (n,) int
    landmark: np.ndarray  # (n,) int
    bearing_rad: np.ndarray  # (n,) truth
    range_m: np.ndarray  # (n,) truth
    sigma_bearing_rad: np.ndarray  # (n,) scaled
    sigma_range_m: np.ndarray  # (n,) scaled
    keep: np.ndarray  # (n,) bool
    solver: str
    seed: int


def _payload(problem: Problem, suite: tuple[int, ...], failures: tuple[Failure, ...], noise_scale: float, solver: str, seed: int) -> _Payload:
    s = problem.settings
    parts: dict[str, list[np.ndarray]] = {k: [] for k in ("pose", "landmark", "bearing", "range", "sb", "sr", "keep")}
    slices, at = [], 0
    lib = problem.library
    for i in suite:
        o = problem.observations[i]
        keep = np.ones(len(o), dtype=bool)
        for f in failures:
            if lib[i].id == f.sensor:
                keep &= ~((o.pose >= f.start) & (o.pose < f.stop))
        for key, arr in zip(parts, (o.pose, o.landmark, o.bearing_rad, o.range_m, o.sigma_bearing_rad * noise_scale, o.sigma_range_m * noise_scale, keep)):
            parts[key].append(np.asarray(arr))
        slices.append((at, at + len(o)))
        at += len(o)

    def cat(key: str, dtype: type) -> np.ndarray:
        return np.concatenate(parts[key]).astype(dtype) if parts[key] else np.zeros(0, dtype)

    return _Payload(
        poses=np.array(problem.scenario.keyframes.poses, dtype=float),
        landmarks=np.array(problem.scenario.landmarks, dtype=float),
        first_pose_sigmas=np.asarray(s.first_pose_sigmas, float) * noise_scale,
        odometry_sigmas=np.asarray(s.odometry_sigmas, float) * noise_scale,
        sensors=suite,
        sensor_slices=tuple(slices),
        pose=cat("pose", int),
        landmark=cat("landmark", int),
        bearing_rad=cat("bearing", float),
        range_m=cat("range", float),
        sigma_bearing_rad=cat("sb", float),
        sigma_range_m=cat("sr", float),
        keep=cat("keep", bool),
        solver=solver,
        seed=seed,
    )


# ------------------------------------------------------------------------------------- one run


def _draw(p: _Payload, run: int) -> tuple[gtsam.Pose2, list[gtsam.Pose2], np.ndarray, np.ndarray]:
    """Noisy first-pose prior, odometry (index k: from k-1 to k; index 0 unused), bearings, ranges."""
    z = np.random.default_rng(np.random.SeedSequence([p.seed, run, 0])).standard_normal((len(p.poses), 3))
    truth = [gtsam.Pose2(*map(float, q)) for q in p.poses]
    prior = truth[0].retract(p.first_pose_sigmas * z[0])
    odometry = [gtsam.Pose2()] + [truth[k - 1].between(truth[k]).retract(p.odometry_sigmas * z[k]) for k in range(1, len(truth))]
    bearing = p.bearing_rad.copy()
    rng_m = p.range_m.copy()
    for sensor, (a, b) in zip(p.sensors, p.sensor_slices):
        # every measurement of the sensor is drawn, failed or not, so a failure does not shift the others' noise
        w = np.random.default_rng(np.random.SeedSequence([p.seed, run, 1, sensor])).standard_normal((b - a, 2))
        bearing[a:b] += p.sigma_bearing_rad[a:b] * w[:, 0]
        rng_m[a:b] += p.sigma_range_m[a:b] * w[:, 1]
    return prior, odometry, bearing, rng_m


class _Noise:
    """Noise models, shared between factors with equal sigmas (as GraphBuilder does)."""

    def __init__(self, p: _Payload) -> None:
        self.prior = gtsam.noiseModel.Diagonal.Sigmas(p.first_pose_sigmas)
        self.odometry = gtsam.noiseModel.Diagonal.Sigmas(p.odometry_sigmas)
        self._p = p
        self._cache: dict[tuple[float, float], gtsam.noiseModel.Base] = {}

    def measurement(self, i: int) -> gtsam.noiseModel.Base:
        key = (float(self._p.sigma_bearing_rad[i]), float(self._p.sigma_range_m[i]))
        m = self._cache.get(key)
        if m is None:
            m = self._cache[key] = gtsam.noiseModel.Diagonal.Sigmas(np.array(key))
        return m


def _order(p: _Payload) -> np.ndarray:
    """Kept measurements in keyframe order (ties: sensor order), the order a car receives them."""
    idx = np.nonzero(p.keep)[0]
    return idx[np.argsort(p.pose[idx], kind="stable")]


def _bearing_range(p: _Payload, noise: _Noise, i: int, bearing: np.ndarray, rng_m: np.ndarray) -> gtsam.NonlinearFactor:
    return gtsam.BearingRangeFactor2D(X(int(p.pose[i])), L(int(p.landmark[i])), gtsam.Rot2.fromAngle(float(bearing[i])), float(rng_m[i]), noise.measurement(i))


def _graph(p: _Payload, noise: _Noise, prior: gtsam.Pose2, odometry: list[gtsam.Pose2], bearing: np.ndarray, rng_m: np.ndarray) -> gtsam.NonlinearFactorGraph:
    g = gtsam.NonlinearFactorGraph()
    g.add(gtsam.PriorFactorPose2(X(0), prior, noise.prior))
    for k in range(1, len(p.poses)):
        g.add(gtsam.BetweenFactorPose2(X(k - 1), X(k), odometry[k], noise.odometry))
    for i in _order(p):
        g.add(_bearing_range(p, noise, i, bearing, rng_m))
    return g


def _landmark_from(pose: gtsam.Pose2, bearing: float, rng_m: float) -> gtsam.Point2:
    return pose.transformFrom(gtsam.Point2(rng_m * math.cos(bearing), rng_m * math.sin(bearing)))


def _flat(values: gtsam.Values) -> np.ndarray:
    """All poses and points of ``values`` as one vector (to see when iSAM2 stops moving)."""
    return np.concatenate([gtsam.utilities.extractPose2(values).ravel(), gtsam.utilities.extractPoint2(values).ravel()])


def _pose_array(values: gtsam.Values, n: int) -> np.ndarray:
    out = np.empty((n, 3))
    for k in range(n):
        q = values.atPose2(X(k))
        out[k] = q.x(), q.y(), q.theta()
    return out


def _solve_run(p: _Payload, run: int) -> dict[str, np.ndarray | float | int]:
    """Draw, initialise, solve one run. Returns numbers only (estimates; errors are computed by the caller)."""
    prior, odometry, bearing, rng_m = _draw(p, run)
    noise = _Noise(p)
    n_poses = len(p.poses)
    dead = [prior]
    for k in range(1, n_poses):
        dead.append(dead[-1].compose(odometry[k]))
    order = _order(p)
    if p.solver == "lm":
        graph = _graph(p, noise, prior, odometry, bearing, rng_m)
        initial = gtsam.Values()
        for k, q in enumerate(dead):
            initial.insert(X(k), q)
        for i in order:  # landmarks from their first measurement, seen from the dead-reckoned pose
            j = int(p.landmark[i])
            if not initial.exists(L(j)):
                initial.insert(L(j), _landmark_from(dead[int(p.pose[i])], float(bearing[i]), float(rng_m[i])))
        params = gtsam.LevenbergMarquardtParams()
        params.setMaxIterations(LM_MAX_ITERATIONS)
        params.setRelativeErrorTol(1e-10)
        params.setAbsoluteErrorTol(1e-12)
        opt = gtsam.LevenbergMarquardtOptimizer(graph, initial, params)
        estimate = opt.optimize()
        iterations = int(opt.iterations())
    else:
        estimate, iterations, graph = _isam2(p, noise, prior, odometry, bearing, rng_m, order)
    lm_est = np.full((len(p.landmarks), 2), np.nan)
    for j in np.unique(p.landmark[order]):
        lm_est[j] = estimate.atPoint2(L(int(j)))
    return {
        "poses": _pose_array(estimate, n_poses),
        "landmarks": lm_est,
        "dead_reckoning": np.array([[q.x(), q.y(), q.theta()] for q in dead]),
        "iterations": iterations,
        "final_error": float(graph.error(estimate)),
    }


def _isam2(p: _Payload, noise: _Noise, prior: gtsam.Pose2, odometry: list[gtsam.Pose2], bearing: np.ndarray, rng_m: np.ndarray,
           order: np.ndarray) -> tuple[gtsam.Values, int, gtsam.NonlinearFactorGraph]:
    """Keyframes in order, as a car would: each new pose starts at the current estimate of the previous
    one composed with the odometry, each new landmark at its first measurement from that pose."""
    params = gtsam.ISAM2Params()
    params.setRelinearizeThreshold(0.01)
    params.relinearizeSkip = 1
    isam = gtsam.ISAM2(params)
    full = gtsam.NonlinearFactorGraph()
    by_pose = np.split(order, np.searchsorted(p.pose[order], np.arange(1, len(p.poses))))
    seen: set[int] = set()
    updates = 0
    for k, meas in enumerate(by_pose):
        g, v = gtsam.NonlinearFactorGraph(), gtsam.Values()
        if k == 0:
            g.add(gtsam.PriorFactorPose2(X(0), prior, noise.prior))
            start = prior
        else:
            g.add(gtsam.BetweenFactorPose2(X(k - 1), X(k), odometry[k], noise.odometry))
            start = isam.calculateEstimatePose2(X(k - 1)).compose(odometry[k])
        v.insert(X(k), start)
        for i in meas:
            g.add(_bearing_range(p, noise, i, bearing, rng_m))
            j = int(p.landmark[i])
            if j not in seen:
                seen.add(j)
                v.insert(L(j), _landmark_from(start, float(bearing[i]), float(rng_m[i])))
        isam.update(g, v)
        full.push_back(g)
        updates += 1
    # a few more updates relinearize what moved since it was last linearized (the last keyframes)
    last = _flat(isam.calculateEstimate())
    for _ in range(ISAM2_MAX_FINAL_UPDATES):
        isam.update()
        updates += 1
        now = _flat(isam.calculateEstimate())
        done = np.max(np.abs(now - last)) < 1e-10
        last = now
        if done:
            break
    return isam.calculateEstimate(), updates, full


# worker processes only: the payload they were started with (see _init_worker)
_WORKER_PAYLOAD: _Payload | None = None


def _init_worker(payload: _Payload) -> None:
    global _WORKER_PAYLOAD
    _WORKER_PAYLOAD = payload


def _worker_run(run: int) -> dict[str, np.ndarray | float | int]:
    assert _WORKER_PAYLOAD is not None
    return _solve_run(_WORKER_PAYLOAD, run)


def _mp_context() -> multiprocessing.context.BaseContext:
    methods = multiprocessing.get_all_start_methods()
    return multiprocessing.get_context("forkserver" if "forkserver" in methods else "spawn")


# ---------------------------------------------------------------------------------- prediction


@dataclass(frozen=True, eq=False)
class _Prediction:
    pose_cov: np.ndarray  # (3K, 3K) joint covariance of the poses, tangent space at the truth
    pose_info_chol: tuple  # scipy cho_factor of pose_cov
    pose_block_inv: np.ndarray  # (K, 3, 3) inverses of the per-pose blocks
    landmark_cov: np.ndarray  # (M, 2, 2), NaN for unmeasured landmarks


def _predict(p: _Payload) -> _Prediction:
    """Covariance predicted by the information matrix of the graph linearized at the truth."""
    from scipy.linalg import cho_factor

    noise = _Noise(p)
    truth = [gtsam.Pose2(*map(float, q)) for q in p.poses]
    odometry = [gtsam.Pose2()] + [truth[k - 1].between(truth[k]) for k in range(1, len(truth))]
    graph = _graph(p, noise, truth[0], odometry, p.bearing_rad, p.range_m)
    values = gtsam.Values()
    for k, q in enumerate(truth):
        values.insert(X(k), q)
    measured = np.unique(p.landmark[p.keep])
    for j in measured:
        values.insert(L(int(j)), gtsam.Point2(*map(float, p.landmarks[j])))
    marginals = gtsam.Marginals(graph, values)
    n = len(truth)
    cov = marginals.jointMarginalCovariance(gtsam.KeyVector([X(k) for k in range(n)])).fullMatrix()
    cov = 0.5 * (cov + cov.T)
    blocks = np.array([np.linalg.inv(cov[3 * k:3 * k + 3, 3 * k:3 * k + 3]) for k in range(n)])
    lcov = np.full((len(p.landmarks), 2, 2), np.nan)
    for j in measured:
        lcov[j] = marginals.marginalCovariance(L(int(j)))
    return _Prediction(cov, cho_factor(cov), blocks, lcov)


# ---------------------------------------------------------------------------------- the driver


def simulate(
    problem: Problem,
    suite: str | Iterable[int],
    *,
    failures: Iterable[Failure] = (),
    runs: int = 20,
    solver: str = DEFAULT_SOLVER,
    seed: int = 0,
    noise_scale: float = 1.0,
    jobs: int = 1,
    label: str = "suite",
    progress: Progress | None = None,
) -> SimulationResult:
    """Monte-Carlo SLAM of ``suite`` on ``problem``: ``runs`` seeded draws, each solved with GTSAM.

    Args:
        problem: library, scenario (keyframes, landmarks), odometry/prior noise, observations.
        suite: comma-separated sensor ids, or library positions.
        failures: sensors of the suite that return nothing on some keyframes (or the whole route).
        runs: number of Monte-Carlo runs N (>= 1).
        solver: "lm" (batch Levenberg-Marquardt) or "isam2" (incremental, keyframes in order).
        seed: base seed (>= 0); run r draws from streams seeded by (seed, r).
        noise_scale: factor on every sigma (> 0); 1 is the sensor models.
        jobs: worker processes for the runs (results do not depend on it).
        label: name of this design in tables and plots.
        progress: called as progress(runs done, runs) after each finished run.
    Raises:
        InputError: bad suite, failure, solver, runs, seed, noise scale or jobs (names the value).
    """
    t0 = time.perf_counter()
    lib = problem.library
    positions = lib.parse_suite(suite) if isinstance(suite, str) else as_suite(suite)
    for i in positions:
        if not 0 <= i < problem.n_sensors:
            raise InputError(f"sensor position {i} is outside the library (0..{problem.n_sensors - 1})")
    if solver not in SOLVERS:
        raise InputError(f"unknown solver {solver!r}; choose one of {', '.join(SOLVERS)}")
    if isinstance(runs, bool) or not isinstance(runs, int) or runs < 1:
        raise InputError(f"runs must be a positive integer, got {runs!r}")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise InputError(f"seed must be a non-negative integer, got {seed!r}")
    if not (isinstance(noise_scale, (int, float)) and math.isfinite(noise_scale) and noise_scale > 0):
        raise InputError(f"noise scale must be a positive number, got {noise_scale!r}")
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
        raise InputError(f"jobs must be a positive integer, got {jobs!r}")
    ids = set(lib.suite_ids(positions))
    resolved = []
    for f in failures:
        if f.sensor not in ids:
            raise InputError(f"failed sensor {f.sensor!r} is not in the suite {','.join(lib.suite_ids(positions)) or '(empty)'}")
        resolved.append(_check_failure(f, problem))
    failures_t = tuple(resolved)

    payload = _payload(problem, positions, failures_t, float(noise_scale), solver, seed)
    t_runs = time.perf_counter()
    raw: list[dict] = []
    if jobs == 1 or runs == 1:
        for r in range(runs):
            raw.append(_solve_run(payload, r))
            if progress:
                progress(len(raw), runs)
    else:
        with ProcessPoolExecutor(max_workers=min(jobs, runs), mp_context=_mp_context(), initializer=_init_worker, initargs=(payload,)) as ex:
            for out in ex.map(_worker_run, range(runs)):
                raw.append(out)
                if progress:
                    progress(len(raw), runs)
    t_cov = time.perf_counter()
    pred = _predict(payload)
    t_end = time.perf_counter()
    timing = SimulationTiming(total_s=round(t_end - t0, 3), runs_s=round(t_cov - t_runs, 3), covariance_s=round(t_end - t_cov, 3), jobs=jobs)
    return _summarise(problem, payload, positions, failures_t, raw, pred, label=label, noise_scale=float(noise_scale), timing=timing)


def _errors(p: _Payload, pred: _Prediction, run: int, out: dict, measured: np.ndarray) -> RunResult:
    est, truth = out["poses"], p.poses
    pos_err = np.hypot(*(est[:, :2] - truth[:, :2]).T)
    hdg_err = wrap_angle(est[:, 2] - truth[:, 2])
    xi = np.array([gtsam.Pose2(*map(float, t)).localCoordinates(gtsam.Pose2(*map(float, e))) for t, e in zip(truth, est)])
    nees = np.einsum("ki,kij,kj->k", xi, pred.pose_block_inv, xi)
    from scipy.linalg import cho_solve

    flat = xi.reshape(-1)
    nees_joint = float(flat @ cho_solve(pred.pose_info_chol, flat)) / len(truth)
    lm_err = np.hypot(*(out["landmarks"][measured] - p.landmarks[measured]).T) if len(measured) else np.zeros(0)
    dr = out["dead_reckoning"]
    return RunResult(
        run=run,
        position_rmse_m=_rms(pos_err),
        heading_rmse_rad=_rms(hdg_err),
        landmark_rmse_m=_rms(lm_err) if len(lm_err) else None,
        max_position_error_m=float(np.max(pos_err)),
        initial_position_rmse_m=_rms(np.hypot(*(dr[:, :2] - truth[:, :2]).T)),
        nees_mean=float(np.mean(nees)),
        nees_joint=nees_joint,
        iterations=int(out["iterations"]),
        final_error=float(out["final_error"]),
        position_error_m=tuple(float(v) for v in pos_err),
        heading_error_rad=tuple(float(v) for v in hdg_err),
        poses=tuple((float(a), float(b), float(c)) for a, b, c in est),
        landmarks=tuple((float(a), float(b)) for a, b in out["landmarks"][measured]),
    )


def _rms(a: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(a))))


def nees_bounds(n_runs: int, n_poses: int, dof: int = 3, confidence: float = NEES_CONFIDENCE, *, trace_sq: float | None = None) -> tuple[float, float]:
    """Two-sided bounds of an average NEES over ``n_runs`` runs of ``n_poses`` terms of ``dof`` each.

    Without ``trace_sq`` the terms are taken as independent: ``N K avg ~ chi2(dof N K)``. With it,
    the per-run sum ``q = sum_k xi_k' P_k^-1 xi_k = xi' A xi`` (A = blockdiag(P_k^-1)) of a Gaussian
    ``xi ~ N(0, P)`` has mean ``dof K`` and variance ``2 trace((A P)^2)`` = ``2 trace_sq``; the sum over
    runs is matched to a scaled chi-square ``c chi2(nu)`` with the same two moments (Welch-
    Satterthwaite). Independent poses give trace_sq = dof K, c = 1: the first case.
    """
    n = n_runs * n_poses
    mean = dof * n
    var = 2.0 * n_runs * (dof * n_poses if trace_sq is None else trace_sq)
    c, nu = var / (2.0 * mean), 2.0 * mean * mean / var
    lo, hi = c * chi2.ppf([(1 - confidence) / 2, (1 + confidence) / 2], nu) / n
    return float(lo), float(hi)


def _summarise(problem: Problem, p: _Payload, positions: tuple[int, ...], failures: tuple[Failure, ...], raw: Sequence[dict], pred: _Prediction, *,
               label: str, noise_scale: float, timing: SimulationTiming) -> SimulationResult:
    measured = np.unique(p.landmark[p.keep]).astype(int)
    unmeasured = np.setdiff1d(np.arange(len(p.landmarks)), measured)
    rr = tuple(_errors(p, pred, r, out, measured) for r, out in enumerate(raw))
    pos = np.array([r.position_error_m for r in rr])  # (N, K)
    hdg = np.array([r.heading_error_rad for r in rr])
    lm = np.concatenate([np.hypot(*(np.asarray(r.landmarks).reshape(-1, 2) - p.landmarks[measured]).T) for r in rr]) if len(measured) else np.zeros(0)
    n_poses = len(p.poses)
    blocks = np.array([pred.pose_cov[3 * k:3 * k + 3, 3 * k:3 * k + 3] for k in range(n_poses)])
    pos_var = blocks[:, 0, 0] + blocks[:, 1, 1]
    lbounds = nees_bounds(len(rr), n_poses)
    inv_blocks = np.zeros_like(pred.pose_cov)
    for k in range(n_poses):
        inv_blocks[3 * k:3 * k + 3, 3 * k:3 * k + 3] = pred.pose_block_inv[k]
    ap = inv_blocks @ pred.pose_cov
    cbounds = nees_bounds(len(rr), n_poses, trace_sq=float(np.sum(ap * ap.T)))
    nees_mean = float(np.mean([r.nees_mean for r in rr]))
    nees_joint = float(np.mean([r.nees_joint for r in rr]))
    lcov = pred.landmark_cov[measured]
    dr = np.array([r.initial_position_rmse_m for r in rr])
    return SimulationResult(
        label=label,
        suite=problem.library.suite_ids(positions),
        cost_usd=problem.library.cost(positions),
        failures=failures,
        solver=p.solver,
        seed=p.seed,
        n_runs=len(rr),
        noise_scale=noise_scale,
        n_measurements=int(np.count_nonzero(p.keep)),
        n_measurements_failed=int(np.count_nonzero(~p.keep)),
        measured_landmarks=tuple(int(j) for j in measured),
        unmeasured_landmarks=tuple(int(j) for j in unmeasured),
        position_rmse_m=_rms(pos),
        heading_rmse_rad=_rms(hdg),
        landmark_rmse_m=_rms(lm) if len(lm) else None,
        max_position_error_m=float(np.max(pos)),
        mean_max_position_error_m=float(np.mean(np.max(pos, axis=1))),
        initial_position_rmse_m=float(np.sqrt(np.mean(dr**2))),
        predicted_position_rmse_m=float(np.sqrt(np.mean(pos_var))),
        predicted_heading_rmse_rad=float(np.sqrt(np.mean(blocks[:, 2, 2]))),
        predicted_landmark_rmse_m=float(np.sqrt(np.mean(lcov[:, 0, 0] + lcov[:, 1, 1]))) if len(measured) else None,
        position_rmse_along_route_m=tuple(float(v) for v in np.sqrt(np.mean(pos**2, axis=0))),
        predicted_position_sigma_m=tuple(float(v) for v in np.sqrt(pos_var)),
        nees_mean=nees_mean,
        nees_joint_mean=nees_joint,
        nees_bounds=lbounds,
        nees_bounds_correlated=cbounds,
        nees_inside_bounds=bool(lbounds[0] <= nees_mean <= lbounds[1]),
        nees_joint_inside_bounds=bool(lbounds[0] <= nees_joint <= lbounds[1]),
        covariance=COVARIANCE_NOTE,
        problem=problem.info,
        runs=rr,
        timing=timing,
    )


def without_timing(result: SimulationResult) -> SimulationResult:
    """The result with its wall times removed (what is byte-identical between equal runs)."""
    from dataclasses import replace

    return replace(result, timing=None)
