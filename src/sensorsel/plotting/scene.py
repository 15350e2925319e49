"""The scene: a route, its landmarks and a suite's sensing cones; a domain's city; the mounting."""

from __future__ import annotations

import textwrap
from collections.abc import Iterable, Sequence
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from matplotlib.patches import Wedge

from sensorsel.errors import InputError
from sensorsel.model.library import SensorLibrary
from sensorsel.model.scenario import Scenario
from sensorsel.plotting.figures import model_colours, new_axes, short_source

#: A cone shorter than this share of the route's extent is drawn again in a zoom at the car.
ZOOM_BELOW = 0.1


def _draw_cones(
    ax: Axes,
    library: SensorLibrary,
    suite: Sequence[int],
    pose: np.ndarray,
    colours: dict[str, str],
    ranges_m: Sequence[float] | None = None,
) -> None:
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
            ax.add_patch(
                Wedge(
                    (x, y),
                    m.range_m,
                    centre - half,
                    centre + half,
                    fill=False,
                    ls=":",
                    lw=0.8,
                    edgecolor=colours[m.code],
                    alpha=0.7,
                )
            )
        if m.fov_rad >= 2 * np.pi - 1e-9:  # all around: an outline, so that the cones inside it stay readable
            ax.add_patch(
                Wedge((x, y), reach, 0.0, 360.0, fill=False, edgecolor=colours[m.code], lw=1.6, ls="--", label=label)
            )
        else:
            ax.add_patch(
                Wedge(
                    (x, y),
                    reach,
                    centre - half,
                    centre + half,
                    alpha=0.35,
                    facecolor=colours[m.code],
                    edgecolor=colours[m.code],
                    lw=0.8,
                    label=label,
                )
            )


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
        a.plot(
            route.poses[:, 0],
            route.poses[:, 1],
            "-",
            color="tab:blue",
            lw=1.5,
            label=f"route ({route.length_m:,.0f} m)" if legend else None,
        )
        a.plot(kf[:, 0], kf[:, 1], ".", color="tab:blue", ms=3, label=f"keyframes ({len(kf)})" if legend else None)
        a.plot(kf[0, 0], kf[0, 1], "o", color="tab:green", ms=7, label="start" if legend else None)
        a.scatter(
            lm[:, 0], lm[:, 1], s=6, c="k", marker="^", label=f"landmarks ({len(lm)})" if legend else None, zorder=3
        )

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
            ax.indicate_inset(
                (x - zoom_half_m, y - zoom_half_m, 2 * zoom_half_m, 2 * zoom_half_m),
                inset_ax=zoom,
                edgecolor="tab:red",
                alpha=0.8,
            )
            if zoom.get_subplotspec() is not None:  # beside the route: a full-size panel with its own labels
                zoom.set_xlabel("x [m]")
                zoom.set_ylabel("y [m]")
                zoom.legend(
                    loc="upper center",
                    bbox_to_anchor=(0.5, -0.1),
                    fontsize=8,
                    title="sensing cones (dashed: all around)",
                    title_fontsize=8,
                )
            else:
                zoom.tick_params(labelsize=6)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    where = f" in {condition} (dotted: the clear range)" if condition else ""
    ax.set_title(
        textwrap.fill(f"{scenario.name}{where}: landmarks {short_source(scenario.landmark_source)}", 60), fontsize=10
    )
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
    markers = {
        "tree": ("o", "tab:green"),
        "street_lamp": ("^", "goldenrod"),
        "traffic_sign": ("s", "tab:red"),
        "traffic_signals": ("D", "tab:purple"),
        "utility_pole": ("v", "tab:brown"),
        "power_pole": ("v", "tab:gray"),
        "flagpole": ("P", "tab:cyan"),
        "stop": ("X", "darkred"),
        "give_way": ("x", "tab:pink"),
        "survey": ("*", "k"),
    }
    for c in sorted(by_class, key=lambda c: -len(by_class[c])):
        pts = np.array(list(by_class[c]), dtype=float).reshape(-1, 2)
        m, col = markers.get(c, ("^", "k"))
        ax.scatter(pts[:, 0], pts[:, 1], s=6, marker=m, color=col, label=f"{c} ({len(pts)})", zorder=3)
    km = sum(d.weight for d in loaded) if spec.weight_unit == "km" else None
    ax.set_title(
        f"{Path(domain_path).parent.name or domain_path}: {len(loaded)} routes"
        + (f", {km:.1f} km" if km is not None else "")
    )
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
        at = [
            i
            for i in chosen
            if (library[i].clock is None) == (place == "roof") and (place == "roof" or str(library[i].clock) == place)
        ]
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
            ax.text(
                tx, ty, " ".join(parts), ha="center", va="center", fontsize=5.5, color="tab:red" if full else "black"
            )
    ax.set_xlim(-1.5, 1.5)
    ax.set_ylim(-1.5, 1.5)
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])
    ax.set_title("slots used/capacity (L lidar, R radar, C camera; red: full)", fontsize=5.5)
    return ax
