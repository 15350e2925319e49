"""Route CSV files: planar ``t,x,y,heading``, positions only ``t,x,y`` and GPS-like ``Time,X,Y,Z`` logs."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from sensorsel.errors import ScenarioError
from sensorsel.io.files import atomic_write_text
from sensorsel.io.inputs import is_number_text
from sensorsel.model.scenario.base import (
    RouteFile,
    Trajectory,
    _checked_rows,
    _csv_fields,
    _data_lines,
    _parse_row,
    _read_lines,
)
from sensorsel.model.scenario.frames import HEADING_WINDOW_M, check_moves, find_frame
from sensorsel.model.scenario.positions import route_from_positions

PLANAR_CSV_COLUMNS = ("t", "x", "y", "heading")
# the names a column may go by (after lower case, a leading '#' and a unit such as '(s)' or '[m]' are dropped)
_ALIASES = {"t": ("t", "time", "timestamp", "stamp"), "x": ("x",), "y": ("y",), "z": ("z",), "heading": ("heading",)}


def _column(name: str) -> str:
    """A header field as a column name: ``#Time(s)`` -> ``time`` -> ``t``; ``X(m)`` -> ``x``."""
    n = re.sub(r"\(.*?\)|\[.*?\]", "", name).strip().lstrip("#").strip().lower()
    return next((k for k, names in _ALIASES.items() if n in names), n)


def _header(path: Path) -> tuple[int, list[str], list[tuple[int, str]]] | None:
    """(line, column names, data lines after it) of a route CSV: its first line that is not blank or
    a comment when it holds a field that is not a number; else a ``#`` comment line just before the
    first row naming t, x and y (GTSAM writes ``#time(s),x(m),y(m),z(m),...``); else None."""
    rows = _data_lines(path, "route CSV")
    if not rows:
        return None
    if not all(is_number_text(f) for f in rows[0][1].replace(",", " ").split()):
        return rows[0][0], [_column(f) for f in _csv_fields(rows[0][1])], rows[1:]
    first = rows[0][0]
    if first >= 2:
        prev = _read_lines(path, "route CSV")[first - 2].strip()
        if prev.startswith("#"):
            names = [_column(f) for f in _csv_fields(prev.lstrip("#"))]
            if all(c in names for c in ("t", "x", "y")):
                return first - 1, names, rows
    return None


def read_planar_csv(path: str | Path) -> Trajectory:
    """Read a route CSV (:func:`read_csv_route`): the planar route."""
    return read_csv_route(path).route


def read_csv_route(path: str | Path, *, up: str | None = None, window_m: float = HEADING_WINDOW_M) -> RouteFile:
    """Read a route CSV: a header naming the columns, then one point a row; ``#`` comments and blank
    lines are skipped; times strictly increasing; other columns are ignored.

    - ``t,x,y,heading`` (any order): a planar route: time [s], x [m], y [m], heading [rad]
      counter-clockwise from planar X.
    - ``t,x,y`` without heading: positions only, in the planar frame: the heading from the direction
      of travel (:func:`~sensorsel.model.scenario.positions.route_from_positions`).
    - ``t,x,y,z`` without heading (a GPS-like log, e.g. GTSAM's ``Time,X,Y,Z``): 3-D positions, their
      ground plane found (:func:`~sensorsel.model.scenario.frames.find_frame`: z up unless the positions
      say otherwise; ``up`` states it), then as ``t,x,y``.

    The time column may be named ``t``, ``time`` or ``timestamp``; a unit in brackets is dropped
    (``Time(s)``, ``x[m]``); a ``#`` comment right before the first row may be the header.

    Raises:
        ScenarioError: missing file, no header or a header without t, x and y, a row with another
            number of fields than the header or a bad number, no rows, times that do not increase, a
            car that never moves, positions that look like degrees.
    """
    path = Path(path)
    found = _header(path)
    if found is None:
        if not _data_lines(path, "route CSV"):
            raise ScenarioError(
                path, "route CSV is empty: expected a header t,x,y,heading (or t,x,y) and one pose a row"
            )
        raise ScenarioError(
            path,
            "route CSV has no header: lacks column(s) t, x, y: expected a header naming t,x,y "
            "(with heading in radians, or z, or neither)",
            _data_lines(path, "route CSV")[0][0],
        )
    hline, header, lines = found
    missing = [c for c in ("t", "x", "y") if c not in header]
    if missing:
        raise ScenarioError(
            path,
            f"route CSV header {','.join(header)!r} lacks column(s) {', '.join(missing)}: "
            "expected a header naming t,x,y (with heading in radians, or z, or neither)",
            hline,
        )
    wanted = [c for c in ("t", "x", "y", "heading", "z") if c in header]
    dup = sorted({c for c in header if header.count(c) > 1 and c in wanted})
    if dup:
        raise ScenarioError(path, f"route CSV header names column(s) {', '.join(dup)} twice", hline)
    if "heading" in wanted:
        wanted = [c for c in wanted if c != "z"]
    cols = [header.index(c) for c in wanted]
    rows, linenos = [], []
    for lineno, s in lines:
        fields = _csv_fields(s)
        if len(fields) != len(header):
            raise ScenarioError(
                path, f"expected {len(header)} comma-separated fields as in the header, found {len(fields)}", lineno
            )
        rows.append(_parse_row(" ".join(fields[c] for c in cols), path, lineno, len(cols), ",".join(wanted)))
        linenos.append(lineno)
    a = _checked_rows(rows, linenos, path, "route CSV has a header but no poses", 2)  # x and y (a heading or z follows)
    if "heading" in wanted:
        check_moves(a[:, 1:3], path)
        return RouteFile(Trajectory(a[:, 1:4], a[:, 0], np.arange(len(a)), str(path)), None, ())
    if "z" in wanted:
        frame, notes = find_frame(a[:, 1:4], None, path, convention="z-up", up=up)
        return route_from_positions(
            a[:, 0], frame.project(a[:, 1:4]), path, frame=frame, notes=tuple(notes), window_m=window_m
        )
    return route_from_positions(a[:, 0], a[:, 1:3], path, window_m=window_m)


def write_planar_csv(path: str | Path, planar: np.ndarray, times: np.ndarray) -> Path:
    """Write planar poses as a route CSV ``t,x,y,heading`` (full float precision; atomically)."""
    body = "".join(
        f"{t!r},{x!r},{y!r},{h!r}\n"
        for t, (x, y, h) in zip(np.asarray(times, dtype=float).tolist(), np.asarray(planar, dtype=float).tolist())
    )
    return atomic_write_text(path, "t,x,y,heading\n" + body)
