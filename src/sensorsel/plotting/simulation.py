"""Monte-Carlo SLAM runs (:mod:`sensorsel.simulation`): errors along the route and on the map."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import matplotlib
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from sensorsel.errors import InputError
from sensorsel.model.scenario import Scenario
from sensorsel.plotting.figures import new_axes, route_distance_m

if TYPE_CHECKING:  # the result types only (their modules need no matplotlib; simulate's imports gtsam)
    from sensorsel.simulation import SimulationResult


# ------------------------------------------------------------------------ Monte-Carlo simulation
# Results of sensorsel.simulation (imported only for type checking: that module imports gtsam).

ERROR_CMAP = "turbo"  # blue (small) to dark red (large): readable on white at both ends


def typical_run(result: SimulationResult) -> int:
    """Index of the run whose position RMSE is the median of the runs (the lower one for even N)."""
    rmse = np.array([r.position_rmse_m for r in result.runs])
    return int(np.argsort(rmse, kind="stable")[(len(rmse) - 1) // 2])


def _run_errors(
    result: SimulationResult, scenario: Scenario, run: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Estimated poses (K,3), their position errors (K,), estimated landmarks (m,2), their errors (m,)."""
    r = result.runs[run]
    poses = np.asarray(r.poses, dtype=float).reshape(-1, 3)
    lms = np.asarray(r.landmarks, dtype=float).reshape(-1, 2)
    idx = np.asarray(result.measured_landmarks, dtype=int)
    lm_err = np.hypot(*(lms - scenario.landmarks[idx]).T) if len(idx) else np.zeros(0)
    return poses, np.asarray(r.position_error_m, dtype=float), lms, lm_err


#: The solvers' names as a reader knows them (a result records the key, e.g. "lm").
SOLVER_WORDS = {"lm": "Levenberg-Marquardt", "isam2": "iSAM2"}


def _failure_text(result: SimulationResult) -> str:
    if not result.failures:
        return "no failure"
    return "failed: " + ", ".join(f.describe(result.problem.n_poses) for f in result.failures)


def plot_simulation(
    result: SimulationResult,
    scenario: Scenario,
    ax: Axes | None = None,
    *,
    run: int | None = None,
    norm: matplotlib.colors.Normalize | None = None,
    colorbar: bool = True,
) -> Axes:
    """One run's estimated trajectory and landmarks over the ground truth, coloured by error (Fig. 6).

    Args:
        result: a Monte-Carlo simulation of ``scenario``.
        scenario: the scenario simulated (ground truth).
        ax: axes to draw on; a new figure when None.
        run: which run to draw (default: the run of median position RMSE, see :func:`typical_run`).
        norm: colour scale of the errors [m] (default 0 .. the largest error drawn); share one
            between panels to compare them.
        colorbar: add a colour bar of the error next to the axes.
    Returns:
        The axes drawn on.
    """
    from matplotlib.colors import Normalize

    ax = ax or new_axes()
    if scenario.n_poses != result.problem.n_poses or scenario.n_landmarks != result.problem.n_landmarks:
        raise InputError(
            f"plot_simulation: the result is of a scenario with {result.problem.n_poses} keyframes and "
            f"{result.problem.n_landmarks} landmarks, not of {scenario.name!r} "
            f"({scenario.n_poses}, {scenario.n_landmarks})"
        )
    k = typical_run(result) if run is None else run
    if not 0 <= k < len(result.runs):
        raise InputError(f"run {k} is not among the {len(result.runs)} runs of {result.label!r}")
    poses, pos_err, lms, lm_err = _run_errors(result, scenario, k)
    if norm is None:
        norm = Normalize(0.0, float(max(np.max(pos_err), np.max(lm_err, initial=0.0))) or 1.0)
    truth = scenario.keyframes.poses
    ax.plot(truth[:, 0], truth[:, 1], "-", color="0.55", lw=3.0, alpha=0.5, label="true route", zorder=1)
    lm_true = scenario.landmarks
    ax.scatter(
        lm_true[:, 0],
        lm_true[:, 1],
        s=14,
        facecolors="none",
        edgecolors="0.55",
        lw=0.6,
        marker="o",
        label=f"true landmarks ({len(lm_true)})",
        zorder=1,
    )
    if result.unmeasured_landmarks:
        un = lm_true[np.asarray(result.unmeasured_landmarks, dtype=int)]
        ax.scatter(un[:, 0], un[:, 1], s=14, c="0.3", marker="x", lw=0.8, label=f"never measured ({len(un)})", zorder=2)
    ax.plot(poses[:, 0], poses[:, 1], "-", color="k", lw=0.6, zorder=3)
    # estimates coloured by their error, on one colour scale
    by_error: dict[str, Any] = {"cmap": ERROR_CMAP, "norm": norm, "edgecolors": "k", "linewidths": 0.3, "zorder": 4}
    sc = ax.scatter(poses[:, 0], poses[:, 1], c=pos_err, s=16, marker="o", label="estimated keyframes", **by_error)
    if len(lms):
        ax.scatter(lms[:, 0], lms[:, 1], c=lm_err, s=18, marker="^", label="estimated landmarks", **by_error)
    n = len(truth)
    for f in result.failures:
        stop = n if f.stop is None else f.stop
        if f.start == 0 and stop == n:
            continue  # a whole-route failure is in the title; ringing every keyframe would hide the errors
        seg = truth[f.start : stop]
        ax.plot(
            seg[:, 0],
            seg[:, 1],
            "-",
            color="tab:red",
            lw=6,
            alpha=0.25,
            zorder=0,
            label=f"{f.sensor} failed (keyframes {f.start}-{stop - 1})",
        )
    ax.plot(truth[0, 0], truth[0, 1], "s", color="tab:green", ms=7, zorder=5, label="start")
    if colorbar:
        ax.figure.colorbar(sc, ax=ax, label="position error [m]", shrink=0.8)
    lm_txt = "n/a" if result.runs[k].landmark_rmse_m is None else f"{result.runs[k].landmark_rmse_m:.2f} m"
    import textwrap

    suite = textwrap.fill(", ".join(result.suite) or "(no sensor)", 60)
    ax.set_title(
        f"{result.label}: {suite}\n{_failure_text(result)}; solver {SOLVER_WORDS.get(result.solver, result.solver)}, "
        f"run {k} {'(median of' if k == typical_run(result) else '(of'} {len(result.runs)})\nposition RMSE "
        f"{result.runs[k].position_rmse_m:.2f} m, "
        f"max {result.runs[k].max_position_error_m:.2f} m, landmarks {lm_txt}",
        fontsize=9,
    )
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.legend(loc="best", fontsize=7)
    ax.grid(True, alpha=0.3)
    return ax


def plot_simulation_comparison(
    results: Sequence[SimulationResult],
    scenario: Scenario,
    axes: Sequence[Axes] | None = None,
    *,
    runs: Sequence[int | None] | None = None,
) -> list[Axes]:
    """Designs side by side (e.g. greedy and resilient, each with a failure), one colour scale for all.

    Args:
        results: simulations of the same scenario.
        scenario: the scenario (ground truth).
        axes: one axes per result; a new figure with one column per result when None.
        runs: which run to draw for each result (default: each one's median run, a typical outcome
            of each design; pass the same run for all to compare the designs on the same draw of
            odometry noise and of the shared sensors' noise).
    Returns:
        The axes drawn on, in the order of ``results``.
    """
    from matplotlib.colors import Normalize

    if not results:
        raise InputError("plot_simulation_comparison: no simulation to draw")
    if axes is None:
        fig = plt.figure(figsize=(5.5 * len(results) + 1.0, 8.0), layout="constrained")
        axes = list(fig.subplots(1, len(results), squeeze=False)[0])
    if len(axes) != len(results):
        raise InputError(f"plot_simulation_comparison: {len(results)} results but {len(axes)} axes")
    given: list[int | None] = [None] * len(results) if runs is None else list(runs)
    picks = [typical_run(r) if k is None else k for r, k in zip(results, given)]
    vmax = 0.0
    for res, k in zip(results, picks):
        _, pos_err, _, lm_err = _run_errors(res, scenario, k)
        vmax = max(vmax, float(np.max(pos_err)), float(np.max(lm_err, initial=0.0)))
    norm = Normalize(0.0, vmax or 1.0)
    for res, k, ax in zip(results, picks, axes):
        plot_simulation(res, scenario, ax, run=k, norm=norm, colorbar=False)
    mappable = plt.cm.ScalarMappable(norm=norm, cmap=ERROR_CMAP)
    axes[0].figure.colorbar(mappable, ax=list(axes), label="position error of keyframes and landmarks [m]", shrink=0.8)
    return list(axes)


def plot_error_along_route(results: Sequence[SimulationResult], scenario: Scenario, ax: Axes | None = None) -> Axes:
    """Position error along the route: every run (thin), RMS over runs (bold), predicted 1-sigma (dashed).

    The prediction is sqrt(trace) of each keyframe's position covariance from the information matrix;
    a consistent design has its RMS curve close to the dashed one. Partial failures are shaded.

    Returns:
        The axes drawn on.
    """
    ax = ax or new_axes((9.0, 4.0))
    s = route_distance_m(scenario)
    n = len(s)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, res in enumerate(results):
        if res.problem.n_poses != n:
            raise InputError(
                f"plot_error_along_route: {res.label!r} has {res.problem.n_poses} keyframes, the scenario {n}"
            )
        c = colours[i % len(colours)]
        for j, r in enumerate(res.runs):
            ax.plot(
                s,
                r.position_error_m,
                "-",
                color=c,
                lw=0.5,
                alpha=0.2,
                label=f"{res.label}: each run (thin)" if j == 0 else None,
            )
        ax.plot(
            s,
            res.position_rmse_along_route_m,
            "-",
            color=c,
            lw=2.0,
            label=f"{res.label} ({_failure_text(res)}): RMS of {res.n_runs} runs",
        )
        ax.plot(s, res.predicted_position_sigma_m, "--", color=c, lw=1.3, label=f"{res.label}: predicted 1-sigma")
        for f in res.failures:
            stop = n if f.stop is None else f.stop
            if f.start == 0 and stop == n:
                continue
            ax.axvspan(s[f.start], s[stop - 1], color=c, alpha=0.08, lw=0)
    ax.set_xlabel("distance along the route [m]")
    ax.set_ylabel("position error [m]")
    ax.set_title(f"Scenario {scenario.name}: position error along the route", fontsize=10)
    ax.set_xlim(s[0], s[-1])
    ax.set_ylim(bottom=0.0)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper left", fontsize=7)
    return ax


def plot_simulation_overview(results: Sequence[SimulationResult], scenario: Scenario) -> Figure:
    """The designs side by side (top) above the error along the route (bottom), in one figure."""
    fig = plt.figure(figsize=(max(6.5, 5.5 * len(results) + 1.0), 12.0), layout="constrained")
    top, bottom = fig.subfigures(2, 1, height_ratios=[2.3, 1.0])  # type: ignore[misc]  # an array of 2 subfigures
    axes = list(top.subplots(1, len(results), squeeze=False)[0])
    plot_simulation_comparison(results, scenario, axes)
    plot_error_along_route(results, scenario, bottom.subplots())
    return fig
