"""Plots. The only module that imports matplotlib; nothing here calls ``plt.show()``.

Every function takes ``ax=None`` (a new figure is made when omitted) and returns what it drew.
:func:`save_figure` writes PNG, SVG or PDF by the file's extension, atomically.
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import Iterable

import matplotlib

matplotlib.use("Agg")  # files only: no display on a server or in CI
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.axes import Axes  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.patches import Wedge  # noqa: E402

from .errors import InputError  # noqa: E402
from .fileio import atomic_write_bytes  # noqa: E402
from .library import SensorLibrary  # noqa: E402
from .scenario import Scenario  # noqa: E402

FORMATS = {".png": "png", ".svg": "svg", ".pdf": "pdf"}
TYPE_COLOURS = {"lidar": "tab:purple", "radar": "tab:orange", "stereo": "tab:cyan"}


def new_axes(figsize: tuple[float, float] = (7.0, 6.0)) -> Axes:
    fig = plt.figure(figsize=figsize, layout="constrained")
    return fig.add_subplot()


def save_figure(fig: Figure, path: str | Path, *, dpi: int = 150) -> Path:
    """Save ``fig`` as PNG/SVG/PDF (by extension) atomically, then close it.

    Raises:
        InputError: an extension other than .png, .svg, .pdf.
    """
    path = Path(path)
    fmt = FORMATS.get(path.suffix.lower())
    if fmt is None:
        raise InputError(f"{path}: unsupported plot format {path.suffix or '(none)'!r}; use .png, .svg or .pdf")
    buf = io.BytesIO()
    # fixed metadata so that the same plot gives the same bytes
    meta = {"Software": None} if fmt == "png" else ({"Date": None} if fmt == "svg" else {"CreationDate": None})
    fig.savefig(buf, format=fmt, dpi=dpi, metadata=meta)
    plt.close(fig)
    return atomic_write_bytes(path, buf.getvalue())


def plot_scene(
    scenario: Scenario,
    ax: Axes | None = None,
    *,
    library: SensorLibrary | None = None,
    suite: Iterable[int] = (),
    pose_index: int | None = None,
) -> Axes:
    """The route and landmarks (the paper's Fig. 2); with a suite, its sensing cones at one keyframe.

    Args:
        scenario: route and landmarks.
        ax: axes to draw on; a new figure when None.
        library, suite: sensors (library positions) whose cones to draw.
        pose_index: keyframe at which to draw the cones (default: the middle one).
    Returns:
        The axes drawn on.
    """
    ax = ax or new_axes()
    route = scenario.route or scenario.keyframes
    ax.plot(route.poses[:, 0], route.poses[:, 1], "-", color="tab:blue", lw=1.5, label=f"route ({route.length_m:.0f} m)")
    kf = scenario.keyframes.poses
    ax.plot(kf[:, 0], kf[:, 1], ".", color="tab:blue", ms=3, label=f"keyframes ({len(kf)})")
    ax.plot(kf[0, 0], kf[0, 1], "o", color="tab:green", ms=7, label="start")
    lm = scenario.landmarks
    ax.scatter(lm[:, 0], lm[:, 1], s=6, c="k", marker="^", label=f"landmarks ({len(lm)})", zorder=3)
    suite = list(suite)
    if suite:
        if library is None:
            raise InputError("plot_scene: a suite needs its library")
        k = len(kf) // 2 if pose_index is None else pose_index
        if not 0 <= k < len(kf):
            raise InputError(f"pose index {k} is outside the route (0..{len(kf) - 1})")
        x, y, th = kf[k]
        drawn: set[str] = set()
        for i in suite:
            s = library[i]
            centre = np.degrees(th + s.mount_angle_rad)
            half = np.degrees(s.model.fov_rad) / 2
            colour = TYPE_COLOURS.get(s.model.type, "tab:gray")
            label = s.model.name if s.model.name not in drawn else None
            drawn.add(s.model.name)
            ax.add_patch(Wedge((x, y), s.model.range_m, centre - half, centre + half, alpha=0.18, color=colour, label=label))
        ax.plot(x, y, "s", color="tab:red", ms=7, label=f"car at keyframe {k}")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(f"Scenario {scenario.name}: landmarks {scenario.landmark_source}")
    ax.legend(loc="best", fontsize=8)
    ax.grid(True, alpha=0.3)
    return ax
