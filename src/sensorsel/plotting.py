"""Plots. The only module that imports matplotlib; nothing here calls ``plt.show()``.

Every function takes ``ax=None`` (a new figure is made when omitted) and returns what it drew.
:func:`save_figure` writes PNG, SVG or PDF by the file's extension, atomically.

Importing this module leaves matplotlib's backend alone (a notebook keeps its inline or widget
backend). Programs that only write files, like the CLI, call :func:`use_file_backend` first.
"""

from __future__ import annotations

import io
import textwrap
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterable, Sequence

import matplotlib
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure, SubFigure
from matplotlib.patches import Rectangle, Wedge

from sensorsel.errors import InputError
from sensorsel.io.files import atomic_write_bytes
from sensorsel.model.library import SensorLibrary
from sensorsel.model.problem import DomainInfo, ProblemInfo
from sensorsel.model.scenario import Scenario

if TYPE_CHECKING:  # simulate imports gtsam; plotting needs only its result types
    from sensorsel.designs.domain_design import DomainDesign
    from sensorsel.designs.requirements.front import FrontAcceptance
    from sensorsel.designs.requirements.spec import Specification
    from sensorsel.information.evaluators.accuracy import RouteAccuracy
    from sensorsel.simulate import SimulationResult

FORMATS = {".png": "png", ".svg": "svg", ".pdf": "pdf"}


def new_axes(figsize: tuple[float, float] = (7.0, 6.0)) -> Axes:
    fig = plt.figure(figsize=figsize, layout="constrained")
    return fig.add_subplot()


def use_file_backend() -> None:
    """Draw to files only: select matplotlib's non-interactive Agg backend (no window, no display).

    For programs that only save plots (the CLI calls it before drawing); never called at import, so
    that a notebook's backend stays the user's choice.
    """
    matplotlib.use("Agg")


def save_figure(fig: Figure | SubFigure, path: str | Path, *, dpi: int = 150, close: bool = False) -> Path:
    """Save ``fig`` as PNG/SVG/PDF (by extension) atomically; ``close``: then close it (a notebook
    keeps it open to display it).

    Raises:
        InputError: an extension other than .png, .svg, .pdf.
    """
    path = Path(path)
    fmt = FORMATS.get(path.suffix.lower())
    if fmt is None:
        raise InputError(f"{path}: unsupported plot format {path.suffix or '(none)'!r}; use .png, .svg or .pdf")
    if isinstance(fig, SubFigure):  # e.g. ax.figure of axes in a subfigure: save the whole figure
        fig = fig.figure
    buf = io.BytesIO()
    # fixed metadata so that the same plot gives the same bytes
    meta = {"Software": None} if fmt == "png" else ({"Date": None} if fmt == "svg" else {"CreationDate": None})
    fig.savefig(buf, format=fmt, dpi=dpi, metadata=meta)
    if close:
        plt.close(fig)
    return atomic_write_bytes(path, buf.getvalue())


#: One colour per sensor model of the stock library (Table I's codes), none of them the route's blue,
#: the start's green, the car's red or the landmarks' black; a model of your own library takes the
#: next unused colour of :data:`EXTRA_MODEL_COLOURS` in library order.
MODEL_COLOURS = {"LRL": "tab:purple", "MRL": "tab:pink", "LRR": "tab:orange", "MRR": "tab:brown",
                 "WSC": "tab:cyan", "HD2K": "tab:olive", "LSC": "tab:gray"}
EXTRA_MODEL_COLOURS = ("gold", "teal", "navy", "lime", "maroon", "magenta", "salmon", "indigo")
#: A cone shorter than this share of the route's extent is drawn again in a zoom at the car.
ZOOM_BELOW = 0.1


def model_colours(library: SensorLibrary) -> dict[str, str]:
    """A colour per model code of ``library`` (:data:`MODEL_COLOURS`, then the extra colours in library order)."""
    out: dict[str, str] = {}
    extra = iter(EXTRA_MODEL_COLOURS)
    for s in library:
        code = s.model.code
        if code not in out:
            out[code] = MODEL_COLOURS.get(code) or next(extra, "0.5")
    return out


def _short_source(source: str) -> str:
    """The landmark source with its folders dropped ("KITTI pole map .../landmarks/03.csv" -> "... 03.csv"):
    a title names the map, the result file keeps the whole path."""
    return " ".join(Path(w).name if ("/" in w or "\\" in w) else w for w in source.split())


def _draw_cones(ax: Axes, library: SensorLibrary, suite: Sequence[int], pose: np.ndarray,
                colours: dict[str, str], ranges_m: Sequence[float] | None = None) -> None:
    """The suite's sensing cones at one pose (x [m], y [m], heading [rad]), one legend entry per model;
    with ``ranges_m`` (each library sensor's range under a condition) drawn that far, the clear
    cone's edge dashed behind a shrunk one."""
    x, y, th = pose
    count: dict[str, int] = {}
    for i in suite:
        count[library[i].model.code] = count.get(library[i].model.code, 0) + 1
    drawn: set[str] = set()
    for i in suite:
        s = library[i]
        m = s.model
        centre = np.degrees(th + s.mount_angle_rad)
        half = np.degrees(m.fov_rad) / 2
        label = None
        if m.code not in drawn:
            label = f"{m.name} ({m.code}, {m.range_m:.0f} m, {np.degrees(m.fov_rad):.0f}°) × {count[m.code]}"
            drawn.add(m.code)
        reach = float(ranges_m[i]) if ranges_m is not None else m.range_m
        if reach < m.range_m:  # the clear cone's edge, to show how far it shrank
            ax.add_patch(Wedge((x, y), m.range_m, centre - half, centre + half, fill=False, ls=":", lw=0.8,
                               edgecolor=colours[m.code], alpha=0.7))
        if m.fov_rad >= 2 * np.pi - 1e-9:  # all around: an outline, so that the cones inside it stay readable
            ax.add_patch(Wedge((x, y), reach, 0.0, 360.0, fill=False, edgecolor=colours[m.code], lw=1.6, ls="--",
                               label=label))
        else:
            ax.add_patch(Wedge((x, y), reach, centre - half, centre + half, alpha=0.35, facecolor=colours[m.code],
                               edgecolor=colours[m.code], lw=0.8, label=label))


def plot_scene(
    scenario: Scenario,
    ax: Axes | None = None,
    *,
    library: SensorLibrary | None = None,
    suite: Iterable[int] = (),
    pose_index: int | None = None,
    ranges_m: Sequence[float] | None = None,
    condition: str | None = None,
) -> Axes:
    """The route and landmarks (the paper's Fig. 2); with a suite, its sensing cones at one keyframe.

    Each sensor model has its own colour (:func:`model_colours`) and legend entry. Where the shortest
    cone is small against the route (under :data:`ZOOM_BELOW` of its extent, e.g. 20 m cameras on a
    3 km route) the car is drawn again, zoomed: beside the route when ``ax`` is None, else in an
    inset in the upper right of ``ax``.

    Args:
        scenario: route and landmarks (coordinates in metres).
        ax: axes to draw on; a new figure when None.
        library: the sensor library of ``suite`` (needed with a suite).
        suite: library positions of the sensors whose cones to draw.
        pose_index: keyframe at which to draw the cones (default: the middle one).
        ranges_m: each library sensor's range under an operating condition [m], (n_sensors,)
            (:func:`sensorsel.model.sensing.condition_effects`): the cones are drawn that far, the clear
            cone's edge dashed behind a shrunk one. None: the models' own ranges.
        condition: the condition's label, for the title.
    Returns:
        The axes of the whole route.
    """
    suite = list(suite)
    route = scenario.route or scenario.keyframes
    kf = scenario.keyframes.poses
    lm = scenario.landmarks
    k = len(kf) // 2 if pose_index is None else pose_index
    zoom_half_m = 0.0
    if suite:
        if library is None:
            raise InputError("plot_scene: a suite needs its library")
        if not 0 <= k < len(kf):
            raise InputError(f"pose index {k} is outside the route (0..{len(kf) - 1})")
        extent = float(max(np.ptp(route.poses[:, 0]), np.ptp(route.poses[:, 1]), 1.0))
        shortest = min(library[i].model.range_m for i in suite)
        if shortest < ZOOM_BELOW * extent:
            zoom_half_m = 1.3 * shortest
    zoom: Axes | None = None
    if ax is None:
        if zoom_half_m:
            fig, (ax, zoom) = plt.subplots(1, 2, figsize=(12.0, 6.0), layout="constrained", width_ratios=(1.25, 1.0))
        else:
            ax = new_axes()
    elif zoom_half_m:
        zoom = ax.inset_axes((0.6, 0.6, 0.39, 0.39))

    def draw_map(a: Axes, legend: bool) -> None:
        a.plot(route.poses[:, 0], route.poses[:, 1], "-", color="tab:blue", lw=1.5,
               label=f"route ({route.length_m:,.0f} m)" if legend else None)
        a.plot(kf[:, 0], kf[:, 1], ".", color="tab:blue", ms=3, label=f"keyframes ({len(kf)})" if legend else None)
        a.plot(kf[0, 0], kf[0, 1], "o", color="tab:green", ms=7, label="start" if legend else None)
        a.scatter(lm[:, 0], lm[:, 1], s=6, c="k", marker="^", label=f"landmarks ({len(lm)})" if legend else None, zorder=3)

    draw_map(ax, True)
    if suite:
        assert library is not None
        colours = model_colours(library)
        _draw_cones(ax, library, suite, kf[k], colours, ranges_m)
        ax.plot(kf[k, 0], kf[k, 1], "s", color="tab:red", ms=7, label=f"car at keyframe {k}")
        if library.slots:  # the car's mounting slots, filled by this suite, in a corner
            plot_mounting(library, suite, ax=ax.inset_axes((0.0, 0.0, 0.38, 0.38)))
        if zoom is not None:
            draw_map(zoom, False)
            _draw_cones(zoom, library, suite, kf[k], colours, ranges_m)
            zoom.plot(kf[k, 0], kf[k, 1], "s", color="tab:red", ms=9)
            x, y = kf[k, 0], kf[k, 1]
            zoom.set_xlim(x - zoom_half_m, x + zoom_half_m)
            zoom.set_ylim(y - zoom_half_m, y + zoom_half_m)
            zoom.set_aspect("equal")
            zoom.grid(True, alpha=0.3)
            zoom.set_title(f"zoom at the car, keyframe {k} ({2 * zoom_half_m:.0f} m across)", fontsize=9)
            ax.indicate_inset((x - zoom_half_m, y - zoom_half_m, 2 * zoom_half_m, 2 * zoom_half_m), inset_ax=zoom,
                              edgecolor="tab:red", alpha=0.8)
            if zoom.get_subplotspec() is not None:  # beside the route: a full-size panel with its own labels
                zoom.set_xlabel("x [m]")
                zoom.set_ylabel("y [m]")
                zoom.legend(loc="upper center", bbox_to_anchor=(0.5, -0.1), fontsize=8, title="sensing cones (dashed: all around)",
                            title_fontsize=8)
            else:
                zoom.tick_params(labelsize=6)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    where = f" in {condition} (dotted: the clear range)" if condition else ""
    ax.set_title(textwrap.fill(f"{scenario.name}{where}: landmarks {_short_source(scenario.landmark_source)}", 60), fontsize=10)
    if zoom is not None and zoom.get_subplotspec() is not None:
        # the cones are listed beside their zoom; the route's own legend lists the map
        handles, labels = ax.get_legend_handles_labels()
        keep = [(h, lab) for h, lab in zip(handles, labels) if not isinstance(h, Wedge)]
        ax.legend([h for h, _ in keep], [lab for _, lab in keep], loc="best", fontsize=8)
    else:
        ax.legend(loc="best", fontsize=8)
    ax.grid(True, alpha=0.3)
    return ax


def plot_domain_scene(domain_path: str | Path, ax: Axes | None = None) -> Axes:
    """An operating domain seen from above: every route, and the landmarks by class when the
    landmark files say it (a ``class`` column, as ``sensorsel osm`` writes them), else in black.

    Args:
        domain_path: the domain YAML file (read as every ``--domain`` command reads it).
        ax: axes to draw on; a new figure when None.
    Returns:
        The axes drawn on.
    """
    from sensorsel.model.domain import load_domain_file, load_domain_scenarios
    from sensorsel.model.osm.city import ATTRIBUTION, read_landmark_classes

    ax = ax or new_axes((8.0, 8.0))
    spec = load_domain_file(domain_path)
    loaded = load_domain_scenarios(spec)
    cmap = plt.get_cmap("tab20")
    for i, d in enumerate(loaded):
        r = d.scenario.route or d.scenario.keyframes
        ax.plot(r.poses[:, 0], r.poses[:, 1], "-", color=cmap(i % 20), lw=1.2, alpha=0.8)
    by_class: dict[str, dict[tuple[float, float], None]] = {}
    osm = False
    for d in loaded:
        got = read_landmark_classes(d.spec.landmarks) if d.spec.landmarks not in (None, "real", "synthetic") else None
        xy, classes = got if got is not None else (d.scenario.landmarks, ("landmark",) * d.scenario.n_landmarks)
        osm = osm or got is not None
        for (x, y), c in zip(np.asarray(xy).tolist(), classes):
            by_class.setdefault(c, {})[(round(x, 3), round(y, 3))] = None
    markers = {"tree": ("o", "tab:green"), "street_lamp": ("^", "goldenrod"), "traffic_sign": ("s", "tab:red"),
               "traffic_signals": ("D", "tab:purple"), "utility_pole": ("v", "tab:brown"), "power_pole": ("v", "tab:gray"),
               "flagpole": ("P", "tab:cyan"), "stop": ("X", "darkred"), "give_way": ("x", "tab:pink"), "survey": ("*", "k")}
    for c in sorted(by_class, key=lambda c: -len(by_class[c])):
        pts = np.array(list(by_class[c]), dtype=float).reshape(-1, 2)
        m, col = markers.get(c, ("^", "k"))
        ax.scatter(pts[:, 0], pts[:, 1], s=6, marker=m, color=col, label=f"{c} ({len(pts)})", zorder=3)
    km = sum(d.weight for d in loaded) if spec.weight_unit == "km" else None
    ax.set_title(f"{Path(domain_path).parent.name or domain_path}: {len(loaded)} routes"
                 + (f", {km:.1f} km" if km is not None else ""))
    if osm:
        ax.annotate(ATTRIBUTION, (0.0, -0.08), xycoords="axes fraction", fontsize=6)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(loc="upper right", fontsize=7, markerscale=2)
    return ax


def plot_mounting(library: SensorLibrary, suite: Iterable[int] = (), ax: Axes | None = None) -> Axes:
    """The car seen from above with its mounting places (the roof, and each clock position) and, at
    each, the suite's sensors against the slot capacities ("R1/1": one radar of one); a full slot in red.

    Args:
        library: the sensors and their slots (:attr:`SensorLibrary.slots`; none: places only).
        suite: library positions of the suite.
        ax: axes to draw on; a new figure when None.
    Returns:
        The axes drawn on.
    """
    from matplotlib.patches import FancyBboxPatch

    ax = ax or new_axes((5.0, 5.0))
    chosen = set(int(i) for i in suite)
    ax.add_patch(FancyBboxPatch((-0.45, -0.9), 0.9, 1.8, boxstyle="round,pad=0.05", fc="0.93", ec="0.4"))
    places: dict[str, tuple[float, float]] = {"roof": (0.0, 0.0)}
    for s in library:
        if s.clock is not None and str(s.clock) not in places:
            a = s.mount_angle_rad + np.pi / 2  # 12 o'clock (ahead) points up the page
            places[str(s.clock)] = (0.62 * np.cos(a), 1.05 * np.sin(a))
    short = {"lidar": "L", "radar": "R", "stereo": "C", "any": "*"}
    for place, (px, py) in places.items():
        at = [i for i in chosen if (library[i].clock is None) == (place == "roof")
              and (place == "roof" or str(library[i].clock) == place)]
        parts, full = [], False
        for sl in library.slots:
            if sl.place == place:
                n = sum(1 for i in sl.members if i in chosen)
                full |= n >= sl.capacity
                parts.append(f"{short.get(sl.kind, sl.kind)}{n}/{sl.capacity}")
        if not library.slots:
            parts = [library[i].model.code for i in sorted(at)]
        colour = "tab:red" if full else ("tab:blue" if at else "0.6")
        ax.plot(px, py, "o", ms=4, color=colour)
        if parts:  # outward of the place (below the roof's dot)
            tx, ty = (0.0, -0.12) if place == "roof" else (1.45 * px, 1.22 * py)
            ax.text(tx, ty, " ".join(parts), ha="center", va="center", fontsize=5.5, color="tab:red" if full else "black")
    ax.set_xlim(-1.5, 1.5)
    ax.set_ylim(-1.5, 1.5)
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])
    ax.set_title("slots used/capacity (L lidar, R radar, C camera; red: full)", fontsize=5.5)
    return ax


# ------------------------------------------------------------------------ Monte-Carlo simulation
# Results of sensorsel.simulate (imported only for type checking: that module imports gtsam).

ERROR_CMAP = "turbo"  # blue (small) to dark red (large): readable on white at both ends


def _route_distance_m(scenario: Scenario) -> np.ndarray:
    """Distance along the route at each keyframe [m], shape (K,)."""
    xy = scenario.keyframes.poses[:, :2]
    return np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])


def typical_run(result: "SimulationResult") -> int:
    """Index of the run whose position RMSE is the median of the runs (the lower one for even N)."""
    rmse = np.array([r.position_rmse_m for r in result.runs])
    return int(np.argsort(rmse, kind="stable")[(len(rmse) - 1) // 2])


def _run_errors(result: "SimulationResult", scenario: Scenario, run: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Estimated poses (K,3), their position errors (K,), estimated landmarks (m,2), their errors (m,)."""
    r = result.runs[run]
    poses = np.asarray(r.poses, dtype=float).reshape(-1, 3)
    lms = np.asarray(r.landmarks, dtype=float).reshape(-1, 2)
    idx = np.asarray(result.measured_landmarks, dtype=int)
    lm_err = np.hypot(*(lms - scenario.landmarks[idx]).T) if len(idx) else np.zeros(0)
    return poses, np.asarray(r.position_error_m, dtype=float), lms, lm_err


#: The solvers' names as a reader knows them (a result records the key, e.g. "lm").
SOLVER_WORDS = {"lm": "Levenberg-Marquardt", "isam2": "iSAM2"}


def _failure_text(result: "SimulationResult") -> str:
    if not result.failures:
        return "no failure"
    return "failed: " + ", ".join(f.describe(result.problem.n_poses) for f in result.failures)


def plot_simulation(
    result: "SimulationResult",
    scenario: Scenario,
    ax: Axes | None = None,
    *,
    run: int | None = None,
    norm: "matplotlib.colors.Normalize | None" = None,
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
        raise InputError(f"plot_simulation: the result is of a scenario with {result.problem.n_poses} keyframes and "
                         f"{result.problem.n_landmarks} landmarks, not of {scenario.name!r} ({scenario.n_poses}, {scenario.n_landmarks})")
    k = typical_run(result) if run is None else run
    if not 0 <= k < len(result.runs):
        raise InputError(f"run {k} is not among the {len(result.runs)} runs of {result.label!r}")
    poses, pos_err, lms, lm_err = _run_errors(result, scenario, k)
    if norm is None:
        norm = Normalize(0.0, float(max(np.max(pos_err), np.max(lm_err, initial=0.0))) or 1.0)
    truth = scenario.keyframes.poses
    ax.plot(truth[:, 0], truth[:, 1], "-", color="0.55", lw=3.0, alpha=0.5, label="true route", zorder=1)
    lm_true = scenario.landmarks
    ax.scatter(lm_true[:, 0], lm_true[:, 1], s=14, facecolors="none", edgecolors="0.55", lw=0.6, marker="o",
               label=f"true landmarks ({len(lm_true)})", zorder=1)
    if result.unmeasured_landmarks:
        un = lm_true[np.asarray(result.unmeasured_landmarks, dtype=int)]
        ax.scatter(un[:, 0], un[:, 1], s=14, c="0.3", marker="x", lw=0.8, label=f"never measured ({len(un)})", zorder=2)
    ax.plot(poses[:, 0], poses[:, 1], "-", color="k", lw=0.6, zorder=3)
    sc = ax.scatter(poses[:, 0], poses[:, 1], c=pos_err, cmap=ERROR_CMAP, norm=norm, s=16, marker="o", edgecolors="k",
                    linewidths=0.3, label="estimated keyframes", zorder=4)
    if len(lms):
        ax.scatter(lms[:, 0], lms[:, 1], c=lm_err, cmap=ERROR_CMAP, norm=norm, s=18, marker="^", edgecolors="k",
                   linewidths=0.3, label="estimated landmarks", zorder=4)
    n = len(truth)
    for f in result.failures:
        stop = n if f.stop is None else f.stop
        if f.start == 0 and stop == n:
            continue  # a whole-route failure is in the title; ringing every keyframe would hide the errors
        seg = truth[f.start:stop]
        ax.plot(seg[:, 0], seg[:, 1], "-", color="tab:red", lw=6, alpha=0.25, zorder=0,
                label=f"{f.sensor} failed (keyframes {f.start}-{stop - 1})")
    ax.plot(truth[0, 0], truth[0, 1], "s", color="tab:green", ms=7, zorder=5, label="start")
    if colorbar:
        ax.figure.colorbar(sc, ax=ax, label="position error [m]", shrink=0.8)
    lm_txt = "n/a" if result.runs[k].landmark_rmse_m is None else f"{result.runs[k].landmark_rmse_m:.2f} m"
    import textwrap

    suite = textwrap.fill(", ".join(result.suite) or "(no sensor)", 60)
    ax.set_title(
        f"{result.label}: {suite}\n{_failure_text(result)}; solver {SOLVER_WORDS.get(result.solver, result.solver)}, "
        f"run {k} {'(median of' if k == typical_run(result) else '(of'} {len(result.runs)})\nposition RMSE {result.runs[k].position_rmse_m:.2f} m, "
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
    results: "Sequence[SimulationResult]",
    scenario: Scenario,
    axes: "Sequence[Axes] | None" = None,
    *,
    runs: "Sequence[int | None] | None" = None,
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


def plot_error_along_route(results: "Sequence[SimulationResult]", scenario: Scenario, ax: Axes | None = None) -> Axes:
    """Position error along the route: every run (thin), RMS over runs (bold), predicted 1-sigma (dashed).

    The prediction is sqrt(trace) of each keyframe's position covariance from the information matrix;
    a consistent design has its RMS curve close to the dashed one. Partial failures are shaded.

    Returns:
        The axes drawn on.
    """
    ax = ax or new_axes((9.0, 4.0))
    s = _route_distance_m(scenario)
    n = len(s)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, res in enumerate(results):
        if res.problem.n_poses != n:
            raise InputError(f"plot_error_along_route: {res.label!r} has {res.problem.n_poses} keyframes, the scenario {n}")
        c = colours[i % len(colours)]
        for j, r in enumerate(res.runs):
            ax.plot(s, r.position_error_m, "-", color=c, lw=0.5, alpha=0.2,
                    label=f"{res.label}: each run (thin)" if j == 0 else None)
        ax.plot(s, res.position_rmse_along_route_m, "-", color=c, lw=2.0,
                label=f"{res.label} ({_failure_text(res)}): RMS of {res.n_runs} runs")
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


def plot_simulation_overview(results: "Sequence[SimulationResult]", scenario: Scenario) -> Figure:
    """The designs side by side (top) above the error along the route (bottom), in one figure."""
    fig = plt.figure(figsize=(max(6.5, 5.5 * len(results) + 1.0), 12.0), layout="constrained")
    top, bottom = fig.subfigures(2, 1, height_ratios=[2.3, 1.0])  # type: ignore[misc]  # an array of 2 subfigures
    axes = list(top.subplots(1, len(results), squeeze=False)[0])
    plot_simulation_comparison(results, scenario, axes)
    plot_error_along_route(results, scenario, bottom.subplots())
    return fig


if TYPE_CHECKING:  # resilient needs no matplotlib; plotting needs only its grid type
    from sensorsel.designs.resilient import SelectionGrid


def plot_selection_grid(grid: "SelectionGrid", ax: Axes | None = None, *, title: str | None = None) -> Axes:
    """The per-period selection grid (the paper's Fig. 5): rows = periods, columns = sensors.

    Columns are grouped by sensor model (group label: the model code; column label: the clock
    position or "roof"); sensors assumed to fail are red, active sensors green, others blank. A black
    cross marks, in each period, the failure set worst for that period's suite (``grid.worst_failures``).
    Without ``ax`` the figure is sized for the grid (about 0.2 in per column, 0.24 in per row), so
    that the 62 columns of the paper's library stay readable.

    Args:
        grid: a :class:`sensorsel.designs.resilient.SelectionGrid`.
        ax: axes to draw on; a new figure when None.
        title: the axes' title (default: "Resilient selection per period").
    Returns:
        The axes drawn on.
    """
    from matplotlib.colors import to_rgb
    from matplotlib.patches import Patch

    n_rows, n_cols = len(grid.cells), len(grid.sensors)
    if ax is None:
        ax = new_axes(figsize=(max(6.0, 0.2 * n_cols + 2.6), max(2.6, 0.24 * n_rows + 1.9)))
    colours = {"failed": to_rgb("tab:red"), "active": to_rgb("tab:green"), "": (1.0, 1.0, 1.0)}
    img = np.ones((max(n_rows, 1), max(n_cols, 1), 3))
    for r, row in enumerate(grid.cells):
        for c, state in enumerate(row):
            img[r, c] = colours[state]
    ax.imshow(img, aspect="auto", interpolation="nearest", extent=(-0.5, n_cols - 0.5, max(n_rows, 1) - 0.5, -0.5))
    # thin cell borders, thick borders between sensor models
    ax.set_xticks(np.arange(-0.5, n_cols, 1.0), minor=True)
    ax.set_yticks(np.arange(-0.5, n_rows, 1.0), minor=True)
    ax.grid(True, which="minor", color="0.8", lw=0.5)
    ax.tick_params(which="minor", length=0)
    groups: list[tuple[str, int, int]] = []  # (model code, first column, last column)
    for c, m in enumerate(grid.models):
        if groups and groups[-1][0] == m:
            groups[-1] = (m, groups[-1][1], c)
        else:
            groups.append((m, c, c))
    for _, a, b in groups[1:]:
        ax.axvline(a - 0.5, color="k", lw=1.2)
    for m, a, b in groups:
        ax.text((a + b) / 2, -0.6, m, ha="center", va="bottom", fontsize=8, fontweight="bold",
                transform=ax.transData, clip_on=False)
    ax.set_xticks(np.arange(n_cols))
    ax.set_xticklabels(grid.positions, fontsize=6.5)
    for lab, pos in zip(ax.get_xticklabels(), grid.positions):
        if len(pos) > 2:
            lab.set_rotation(90)
    ax.set_yticks(np.arange(n_rows))
    ax.set_yticklabels(grid.period_labels, fontsize=7)
    ax.tick_params(axis="both", which="major", length=2, pad=1.5)
    ax.set_xlabel("sensor: clock position (12 = ahead, 3 = right) or roof, grouped by model", fontsize=8)
    ax.set_ylabel("period", fontsize=8)
    default_title = "Robust selection per period" if getattr(grid, "method", "") == "robust" else "Resilient selection per period"
    ax.set_title(title or default_title, fontsize=10, pad=14)
    handles: list[Any] = [Patch(color=colours["failed"], label="assumed to fail"), Patch(color=colours["active"], label="active")]
    col = {s: c for c, s in enumerate(grid.sensors)}
    xs = [col[s] for r in range(n_rows) for s in grid.worst(r)]
    ys = [r for r in range(n_rows) for _ in grid.worst(r)]
    if xs:
        from matplotlib.lines import Line2D

        ax.scatter(xs, ys, marker="x", s=22, color="k", linewidths=1.1, zorder=3)
        handles.append(Line2D([], [], ls="", marker="x", color="k", label="worst failure for the suite"))
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.005, 1.0), fontsize=8, frameon=False)
    return ax


if TYPE_CHECKING:  # plotting needs only the tradespace's result type
    from sensorsel.designs.tradespace import TradespaceResult

#: Colours and markers of the selectors in the tradespace plot (the paper's Fig. 4: uniform orange,
#: cost-benefit blue). Hollow markers of different shapes keep suites made by several rules visible.
SELECTOR_STYLES = {
    "uniform": ("tab:orange", "o", 60),
    "cost-benefit": ("tab:blue", "s", 34),
    "marginal": ("tab:green", "^", 30),
    "best-of": ("tab:purple", "D", 16),
}


def plot_tradespace(result: "TradespaceResult", ax: Axes | None = None, *, log_cost: bool = True,
                    fractions: Sequence[float] = (0.99, 0.95), title: str | None = None) -> Axes:
    """The cost-performance tradespace (the paper's Fig. 4).

    Every architecture is a hollow marker coloured by the selector that made it (one marker per
    selector when several made it); the Pareto front is a dashed red step line: from a front point
    the line stays flat until the next front point's cost, since between two front architectures a
    larger budget buys no better recorded architecture. The cheapest architectures reaching each of
    ``fractions`` of the best score are starred and labelled.

    Args:
        result: a :class:`sensorsel.designs.tradespace.TradespaceResult`.
        ax: axes to draw on; a new figure when None.
        log_cost: logarithmic cost axis (the costs span $449 to $200,000 in the paper's library).
        fractions: fractions of the best score whose cheapest architecture to mark.
        title: the axes' title (default: names the scenario and the counts).
    Returns:
        The axes drawn on.
    """
    from matplotlib.ticker import FuncFormatter

    ax = ax or new_axes((8.0, 5.5))
    archs = result.architectures
    if not archs:
        raise InputError("plot_tradespace: the tradespace has no architectures (every budget is below the cheapest sensor)")
    for name in result.selectors:
        pts = [(a.cost_usd, a.normalized) for a in archs if name in a.selectors]
        colour, marker, size = SELECTOR_STYLES.get(name, ("tab:gray", "x", 30))
        if pts:
            x, y = np.array(pts).T
            ax.scatter(x, y, s=size, marker=marker, facecolors="none", edgecolors=colour, linewidths=1.1,
                       label=f"made by {name} ({len(pts)})", zorder=3)
    front = result.front
    fx = np.array([a.cost_usd for a in front])
    fy = np.array([a.normalized for a in front])
    ax.step(fx, fy, where="post", ls="--", color="red", lw=1.4, label=f"Pareto front ({len(front)})", zorder=2)
    ax.scatter(fx, fy, s=5, color="red", zorder=4)
    if log_cost:
        ax.set_xscale("log")
    costs = np.array([a.cost_usd for a in archs])
    lo_x, hi_x = (np.log(costs.min()), np.log(costs.max())) if log_cost else (costs.min(), costs.max())
    for k, frac in enumerate(fractions):
        a = result.cheapest_reaching(frac)
        if a is None:
            continue
        first = k == 0
        ax.axhline(frac, color="0.6", lw=0.8, ls=":", zorder=1,
                   label=" and ".join(f"{f:.0%}" for f in fractions) + " of the best" if first else None)
        ax.scatter([a.cost_usd], [a.normalized], s=160, marker="*", color="gold", edgecolors="k", linewidths=0.7, zorder=5,
                   label="cheapest suite reaching it" if first else None)
        # the label goes below the point, towards the middle of the plot, so it stays inside the axes
        x = np.log(a.cost_usd) if log_cost else a.cost_usd
        right = x > (lo_x + hi_x) / 2
        ax.annotate(f"{frac:.0%} of best: ${a.cost_usd:,.0f}\n({a.n_sensors} sensors)", (a.cost_usd, a.normalized),
                    xytext=(-14 if right else 14, -30 - 30 * k), textcoords="offset points", fontsize=8.5,
                    ha="right" if right else "left", va="top", arrowprops=dict(arrowstyle="-", color="0.4", lw=0.7),
                    bbox=dict(boxstyle="round,pad=0.25", fc="white", ec="0.7", alpha=0.9), zorder=6)
    ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"${v / 1000:,.0f}k" if v >= 1000 else f"${v:,.0f}"))
    lo = min(a.normalized for a in archs)
    ax.set_ylim(max(0.0, lo - 0.05), 1.03)
    ax.set_xlabel("suite cost [$]" + (" (log scale)" if log_cost else ""))
    ax.set_ylabel("normalized performance  f(S) / max f")
    p = result.problem
    where = (f"scenario {p.scenario}: " if isinstance(p, ProblemInfo) else
             f"domain of {len(p.routes)} routes: " if isinstance(p, DomainInfo) else "")
    ax.set_title(title or f"{where}{len(archs)} architectures from {len(result.runs)} greedy runs "
                          f"({len(result.budgets_usd)} budgets)", fontsize=10)
    ax.grid(True, which="major", alpha=0.3)
    ax.grid(True, which="minor", alpha=0.1)
    ax.legend(loc="lower right", fontsize=8.5)
    return ax


def plot_domain_breakdown(design: "DomainDesign", ax: Axes | None = None, *, title: str | None = None) -> Axes:
    """The price of one suite for a whole domain, route by route.

    For each route (one row), the share of the route's best f_r(S)/f_r(all sensors) reached by the
    domain suite (filled dot) and by the suite the same rule picks for that route alone at the same
    budget (hollow dot), joined by a line: the gap is what the route gives up for the others. The
    worst route (lowest share of its own design) is labelled in red.

    Args:
        design: a :class:`sensorsel.designs.domain_design.DomainDesign`.
        ax: axes to draw on; a new figure when None.
    Returns:
        The axes drawn on.
    """
    routes = design.routes
    if any(r.condition for r in design.domain.routes):
        return _plot_condition_grid(design, ax, title=title)
    ax = ax if ax is not None else new_axes((7.0, 0.45 * len(routes) + 2.6))
    y = np.arange(len(routes))[::-1]
    domain_share = np.array([r.share_of_best for r in routes])
    own_share = np.array([r.own_score / r.best_score if r.best_score > 0 else 0.0 for r in routes])
    for yi, a, b in zip(y, domain_share, own_share):
        ax.plot([a, b], [yi, yi], color="0.7", lw=2, zorder=1)
    ax.scatter(own_share, y, s=60, facecolors="white", edgecolors="tab:blue", lw=1.5, zorder=2,
               label="each route's own design (same budget and rule)")
    ax.scatter(domain_share, y, s=60, color="tab:blue", zorder=3, label="the domain suite")
    labels = [f"{r.name} ({r.weight:.1%})" for r in routes]
    ax.set_yticks(y, labels)
    for tick, r in zip(ax.get_yticklabels(), routes):
        if r.name == design.worst_route:
            tick.set_color("tab:red")
    ax.set_xlabel("share of the route's best score, f_r(S) / f_r(all sensors)")
    ax.set_xlim(min(0.9, float(min(domain_share.min(), own_share.min())) - 0.02), 1.0)
    ax.grid(axis="x", alpha=0.3)
    ax.set_ylim(-2.2, len(routes) - 0.5)  # a band below the last route for the legend
    handles, labels = ax.get_legend_handles_labels()
    if design.worst_route:
        from matplotlib.patches import Patch

        handles.append(Patch(color="none"))
        labels.append("red name: the route that loses most to its own design")
    leg = ax.legend(handles, labels, loc="lower left", fontsize="small", ncol=1)
    if design.worst_route:
        leg.get_texts()[-1].set_color("tab:red")
    budget = design.greedy.budget_usd
    # "\\$" is a literal dollar: a bare $ starts matplotlib's mathtext
    ax.set_title(title or f"One suite for {len(routes)} routes at \\${budget:,.0f}: \\${design.greedy.cost_usd:,.0f}, "
                          f"{len(design.greedy.suite)} sensors (weights in brackets)", fontsize="medium")
    return ax


# ------------------------------------------------------------------------------ accuracy in metres


def plot_front_accuracy(acceptance: "FrontAcceptance", ax: Axes | None = None, *, log_cost: bool = True) -> Axes:
    """The Pareto front as cost [$] against the lateral 95 % error [m] (the worst route, at the
    specification's share of keyframes), each suite marked by whether it meets the specification,
    with the lateral requirement drawn as a line: which part of the front is acceptable."""
    from sensorsel.designs.requirements.spec import Specification

    ax = ax if ax is not None else new_axes((7.5, 5.0))
    pts = acceptance.points
    cost = np.array([p.cost_usd for p in pts])
    lat = np.array([p.lateral_95_m for p in pts])
    ax.plot(cost, lat, color="0.6", lw=1, zorder=1, label="Pareto front (cheapest first)")
    if acceptance.specifications:
        ok = np.array([bool(p.meets) for p in pts])
        ax.scatter(cost[ok], lat[ok], color="tab:green", s=40, zorder=3, label="meets the specification")
        ax.scatter(cost[~ok], lat[~ok], color="tab:red", marker="x", s=40, zorder=3, label="does not meet it")
        specs: list[Specification] = [s for _, s in acceptance.specifications]
        bounds = sorted({(s.lateral if not s.sigma else s.lateral * 1.959963984540054) for s in specs if s.lateral is not None})
        for b in bounds:
            ax.axhline(b, color="tab:blue", ls="--", lw=1.2, zorder=2)
        if bounds:
            ax.plot([], [], color="tab:blue", ls="--", label=f"lateral requirement ({specs[0].name})")
        best = acceptance.cheapest_meeting
        if best is not None:
            ax.annotate(f"cheapest meeting it: ${best.cost_usd:,.0f}", (best.cost_usd, best.lateral_95_m),
                        xytext=(10, 15), textcoords="offset points", fontsize=8, arrowprops=dict(arrowstyle="->", lw=0.8))
    else:
        ax.scatter(cost, lat, color="tab:blue", s=30, zorder=3, label="front suite")
    if log_cost:
        ax.set_xscale("log")
    ax.set_yscale("log")
    from matplotlib.ticker import FuncFormatter

    plain = FuncFormatter(lambda v, _: f"{v:g}")
    ax.yaxis.set_major_formatter(plain)
    ax.yaxis.set_minor_formatter(FuncFormatter(lambda v, _: f"{v:g}" if f"{v:.1g}"[0] in "25" else ""))
    ax.set_xlabel("suite cost [$]")
    ax.set_ylabel("lateral error, 95 % [m]")
    ax.set_title(f"Cost against lateral accuracy\n{acceptance.model_label}", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="upper right")
    return ax


def plot_accuracy_along_route(accuracies: "Sequence[tuple[str, RouteAccuracy]]", scenario: Scenario,
                              specification: "Specification | None" = None, ax: Axes | None = None,
                              component: str = "lateral") -> Axes:
    """A component's 95 % error (1.96σ, or 1σ if the specification is stated in σ) along the route
    [m or deg] against distance driven [m], one line per (label, accuracy), with the
    specification's bound drawn in."""
    from sensorsel.information.evaluators.accuracy import Z95

    ax = ax if ax is not None else new_axes((8.0, 4.0))
    dist = _route_distance_m(scenario)
    factor = 1.0 if specification is not None and specification.sigma else Z95
    for (label, acc), colour in zip(accuracies, ("tab:green", "tab:orange", "tab:purple", "tab:brown")):
        ax.plot(dist, factor * acc.sigmas(component), color=colour, lw=1.5, label=label)
    unit = "deg" if component == "heading" else "m"
    if specification is not None and getattr(specification, component) is not None:
        ax.axhline(getattr(specification, component), color="tab:red", ls="--", lw=1.2,
                   label=f"requirement ({specification.name}): {getattr(specification, component):g} {unit}")
    ax.set_xlabel("distance along the route [m]")
    ax.set_ylabel(f"{component} error, {'1σ' if factor == 1.0 else '95 %'} [{unit}]")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    return ax


def plot_route_margin(accuracy: "RouteAccuracy", scenario: Scenario, specification: "Specification",
                      ax: Axes | None = None) -> Axes:
    """The route coloured by its margin at each keyframe: the largest, over the specification's
    components, of error / bound (below 1: met; above 1: missed), with the landmarks in grey."""
    from matplotlib.collections import LineCollection
    from matplotlib.colors import TwoSlopeNorm

    ax = ax if ax is not None else new_axes((7.0, 6.0))
    ratio = np.zeros(accuracy.n_keyframes)
    for comp, bound, _ in specification.bounds():
        ratio = np.maximum(ratio, specification.factor * accuracy.sigmas(comp) / bound)
    xy = scenario.keyframes.poses[:, :2]
    if len(scenario.landmarks):
        ax.scatter(scenario.landmarks[:, 0], scenario.landmarks[:, 1], s=4, color="0.7", label="landmarks", zorder=1)
    segs = np.stack([xy[:-1], xy[1:]], axis=1)
    hi = max(2.0, float(ratio.max()))
    norm = TwoSlopeNorm(vmin=0.0, vcenter=1.0, vmax=hi)
    lc = LineCollection(list(segs), cmap="RdYlGn_r", norm=norm, linewidths=3, zorder=2)
    lc.set_array(np.maximum(ratio[:-1], ratio[1:]))
    ax.add_collection(lc)
    bad = ratio > 1.0
    if np.any(bad):
        ax.scatter(xy[bad, 0], xy[bad, 1], s=18, facecolors="none", edgecolors="black", zorder=3,
                   label=f"keyframes missing it ({int(bad.sum())})")
    cb = ax.figure.colorbar(lc, ax=ax, shrink=0.8)
    cb.set_label("error / requirement (worst component; > 1 misses)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.autoscale_view()
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.legend(fontsize=8, loc="best")
    return ax


def _plot_condition_grid(design: "DomainDesign", ax: Axes | None = None, *, title: str | None = None) -> Axes:
    """A domain with operating conditions: routes (rows) x conditions (columns), each cell the
    domain suite's share of that member's best f_r(S)/f_r(all sensors), with its share of the
    member's own design below it; the worst member (lowest share of its own design) framed in red."""
    info = {r.name: r for r in design.domain.routes}
    routes = list(dict.fromkeys(info[r.name].route or r.name for r in design.routes))
    conditions = list(dict.fromkeys(info[r.name].condition for r in design.routes))
    grid = np.full((len(routes), len(conditions)), np.nan)
    own = np.full_like(grid, np.nan)
    for r in design.routes:
        i, j = routes.index(info[r.name].route or r.name), conditions.index(info[r.name].condition)
        grid[i, j], own[i, j] = r.share_of_best, r.share_of_own
    ax = ax if ax is not None else new_axes((1.6 * len(conditions) + 3.0, 0.5 * len(routes) + 2.0))
    im = ax.imshow(grid, cmap="viridis", aspect="auto", vmin=float(np.nanmin(grid)), vmax=1.0)
    for i in range(len(routes)):
        for j in range(len(conditions)):
            if np.isfinite(grid[i, j]):
                ax.text(j, i, f"{grid[i, j]:.3f}\n({own[i, j]:.1%} of own)", ha="center", va="center", fontsize=7,
                        color="white" if grid[i, j] < 0.5 * (np.nanmin(grid) + 1.0) else "black")
    worst = info.get(design.worst_route)
    if worst is not None:
        i, j = routes.index(worst.route or worst.name), conditions.index(worst.condition)
        ax.add_patch(Rectangle((j - 0.5, i - 0.5), 1, 1, fill=False, edgecolor="tab:red", lw=2))
    weights = {c: sum(r.weight for r in design.routes if info[r.name].condition == c) for c in conditions}
    ax.set_xticks(range(len(conditions)), [f"{c}\n({weights[c]:.1%})" for c in conditions])
    ax.set_yticks(range(len(routes)), routes)
    ax.figure.colorbar(im, ax=ax, label="share of the member's best")
    budget = design.greedy.budget_usd
    ax.set_title(title or f"One suite for {len(routes)} routes x {len(conditions)} conditions at \\${budget:,.0f}: "
                          f"\\${design.greedy.cost_usd:,.0f} (red: worst member)", fontsize="medium")
    return ax
