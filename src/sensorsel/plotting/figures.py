"""Figures: new axes, the file backend, atomic saving, and the colours every plot shares."""

from __future__ import annotations

import io
from pathlib import Path

import matplotlib
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure, SubFigure

from sensorsel.errors import InputError
from sensorsel.io.files import atomic_write_bytes
from sensorsel.model.library import SensorLibrary
from sensorsel.model.scenario import Scenario

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
MODEL_COLOURS = {
    "LRL": "tab:purple",
    "MRL": "tab:pink",
    "LRR": "tab:orange",
    "MRR": "tab:brown",
    "WSC": "tab:cyan",
    "HD2K": "tab:olive",
    "LSC": "tab:gray",
}
EXTRA_MODEL_COLOURS = ("gold", "teal", "navy", "lime", "maroon", "magenta", "salmon", "indigo")


def model_colours(library: SensorLibrary) -> dict[str, str]:
    """A colour per model code of ``library`` (:data:`MODEL_COLOURS`, then the extra colours in library order)."""
    out: dict[str, str] = {}
    extra = iter(EXTRA_MODEL_COLOURS)
    for s in library:
        code = s.model.code
        if code not in out:
            out[code] = MODEL_COLOURS.get(code) or next(extra, "0.5")
    return out


def short_source(source: str) -> str:
    """The landmark source with its folders dropped ("KITTI pole map .../landmarks/03.csv" -> "... 03.csv"):
    a title names the map, the result file keeps the whole path."""
    return " ".join(Path(w).name if ("/" in w or "\\" in w) else w for w in source.split())


def route_distance_m(scenario: Scenario) -> np.ndarray:
    """Distance along the route at each keyframe [m], shape (K,)."""
    xy = scenario.keyframes.poses[:, :2]
    return np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])
