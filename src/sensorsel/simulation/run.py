"""The driver: ``simulate`` checks its arguments, runs the Monte-Carlo draws (in worker processes when
``jobs > 1``), predicts the covariance once and summarises everything into a :class:`SimulationResult`.

The draws run on the pipeline's executors: here, on ``jobs`` worker processes
(:class:`~sensorsel.pipeline.LocalProcesses`, started by ``forkserver``: they never inherit the
parent's BLAS threads or gtsam objects) or on a cluster. Only numbers travel between processes (the
payload with each part of the draws, the estimates back; see the shared gtsam notes on pickling).
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterable, Sequence

import numpy as np

from sensorsel.errors import InputError
from sensorsel.information.evaluators import as_suite
from sensorsel.information.evaluators.accuracy import Z95, accuracy_from_covariances
from sensorsel.io.progress import Progress
from sensorsel.model.problem import Problem
from sensorsel.pipeline import Executor, LocalProcesses, Plan, execute
from sensorsel.simulation.consistency import (
    COVARIANCE_NOTE,
    Prediction,
    correlated_nees_bounds,
    nees_bounds,
    predict,
    rms,
    run_errors,
)
from sensorsel.simulation.failures import resolve_failures
from sensorsel.simulation.noise import Payload, make_payload
from sensorsel.simulation.records import (
    AccuracyCheck,
    ErrorSpread,
    Failure,
    RunResult,
    SimulationResult,
    SimulationTiming,
)
from sensorsel.simulation.solve import DEFAULT_SOLVER, SOLVERS, solve_run


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
    executor: Executor | None = None,
    map_sigma_m: float | None = None,
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
        executor: runs the draws elsewhere (:mod:`sensorsel.pipeline`, e.g. one Dask task per run, the
            payload sent once to each worker); default: here, with ``jobs`` processes. Run r draws from
            (seed, r) wherever it runs, so the result does not depend on it.
        map_sigma_m: None: the paper's SLAM graph (landmarks unknown, no landmark prior). A std [m]:
            localization in a prior map: each run draws the map (every landmark off by an isotropic
            error of this std, from (seed, r, 2)), starts each landmark there and adds a prior there
            of this std. Not scaled by ``noise_scale``.
    Raises:
        InputError: bad suite, failure, solver, runs, seed, noise scale, jobs or map sigma (names the value).
    """
    t0 = time.perf_counter()
    positions = problem.library.parse_suite(suite) if isinstance(suite, str) else as_suite(suite)
    _check_args(problem, positions, solver, runs, seed, noise_scale, jobs)
    if map_sigma_m is not None and (
        isinstance(map_sigma_m, bool)
        or not isinstance(map_sigma_m, (int, float))
        or not (math.isfinite(map_sigma_m) and map_sigma_m > 0)
    ):
        raise InputError(f"map sigma must be a positive, finite number of metres, got {map_sigma_m!r}")
    failures_t = resolve_failures(failures, problem, positions)
    payload = make_payload(
        problem,
        positions,
        failures_t,
        float(noise_scale),
        solver,
        seed,
        None if map_sigma_m is None else float(map_sigma_m),
    )
    t_runs = time.perf_counter()
    # the payload travels to each worker as it is; the draws are cut into parts across them
    plan = Plan("simulation run", solve_run, tuple(range(runs)), states=(payload,))
    raw = execute(plan, executor or LocalProcesses(jobs), progress=progress)
    t_cov = time.perf_counter()
    pred = predict(payload)
    t_end = time.perf_counter()
    timing = SimulationTiming(
        total_s=round(t_end - t0, 3), runs_s=round(t_cov - t_runs, 3), covariance_s=round(t_end - t_cov, 3), jobs=jobs
    )
    return _summarise(
        problem, payload, positions, failures_t, raw, pred, label=label, noise_scale=float(noise_scale), timing=timing
    )


def _check_args(
    problem: Problem, positions: tuple[int, ...], solver: str, runs: int, seed: int, noise_scale: float, jobs: int
) -> None:
    """Raise InputError naming the first bad argument of :func:`simulate`."""
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


# ---------------------------------------------------------------------------------- summary


def _summarise(
    problem: Problem,
    p: Payload,
    positions: tuple[int, ...],
    failures: tuple[Failure, ...],
    raw: Sequence[dict],
    pred: Prediction,
    *,
    label: str,
    noise_scale: float,
    timing: SimulationTiming,
) -> SimulationResult:
    # long only because SimulationResult has 37 fields, each computed in one line
    measured = p.measured_landmarks()
    unmeasured = np.setdiff1d(np.arange(len(p.landmarks)), measured)
    rr = tuple(run_errors(p, pred, r, out, measured) for r, out in enumerate(raw))
    pos = np.array([r.position_error_m for r in rr])  # (N, K)
    hdg = np.array([r.heading_error_rad for r in rr])
    lm = (
        np.concatenate([np.hypot(*(np.asarray(r.landmarks).reshape(-1, 2) - p.landmarks[measured]).T) for r in rr])
        if len(measured)
        else np.zeros(0)
    )
    blocks = pred.pose_blocks()
    pos_var = blocks[:, 0, 0] + blocks[:, 1, 1]
    lbounds = nees_bounds(len(rr), len(p.poses))
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
        position_rmse_m=rms(pos),
        heading_rmse_rad=rms(hdg),
        landmark_rmse_m=rms(lm) if len(lm) else None,
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
        nees_bounds_correlated=correlated_nees_bounds(pred, len(rr)),
        nees_inside_bounds=bool(lbounds[0] <= nees_mean <= lbounds[1]),
        nees_joint_inside_bounds=bool(lbounds[0] <= nees_joint <= lbounds[1]),
        covariance=COVARIANCE_NOTE,
        problem=problem.info,
        runs=rr,
        timing=timing,
        model="slam" if p.map_sigma_m is None else "map",
        map_sigma_m=p.map_sigma_m,
        accuracy=accuracy_check(rr, blocks, p.map_sigma_m),
    )


def accuracy_check(runs: Sequence[RunResult], pose_blocks: np.ndarray, map_sigma_m: float | None) -> AccuracyCheck:
    """Measured against predicted 95 % lateral, longitudinal and heading errors.

    Measured, per keyframe: the 95th percentile over the runs of |error| (keyframe frame; heading
    in degrees). Predicted: 1.96 σ from ``pose_blocks`` (K, 3, 3) (Pose2 tangent: x forward, y left,
    θ), converted as :func:`sensorsel.information.evaluators.accuracy.accuracy_from_covariances` does for
    ``route_accuracy``. Each summarised over the keyframes (median / 95th percentile / worst)."""
    pred = accuracy_from_covariances(pose_blocks, map_sigma_m=map_sigma_m)
    errors = {
        "lateral": np.array([r.lateral_error_m for r in runs]),
        "longitudinal": np.array([r.longitudinal_error_m for r in runs]),
        "heading": np.degrees(np.array([r.heading_error_rad for r in runs])),
    }
    measured, predicted, coverage = {}, {}, {}
    for c, e in errors.items():
        sigma = pred.sigmas(c)
        measured[c] = np.percentile(np.abs(e), 95.0, axis=0)
        predicted[c] = Z95 * sigma
        coverage[c] = float(np.mean(np.abs(e) <= Z95 * sigma[None, :]))
    return AccuracyCheck(
        model=pred.model,
        map_sigma_m=map_sigma_m,
        measured_lateral_95_m=_t(measured["lateral"]),
        predicted_lateral_95_m=_t(predicted["lateral"]),
        measured_longitudinal_95_m=_t(measured["longitudinal"]),
        predicted_longitudinal_95_m=_t(predicted["longitudinal"]),
        measured_heading_95_deg=_t(measured["heading"]),
        predicted_heading_95_deg=_t(predicted["heading"]),
        measured=tuple((c, _spread(v)) for c, v in measured.items()),
        predicted=tuple((c, _spread(v)) for c, v in predicted.items()),
        coverage=tuple(coverage.items()),
    )


def _t(values: np.ndarray) -> tuple[float, ...]:
    return tuple(float(v) for v in values)


def _spread(values: np.ndarray) -> ErrorSpread:
    """Median / 95th percentile / largest over the keyframes, and where the largest is."""
    if values.size == 0:
        return ErrorSpread(math.nan, math.nan, math.nan, -1)
    return ErrorSpread(
        float(np.median(values)), float(np.percentile(values, 95.0)), float(values.max()), int(np.argmax(values))
    )
