"""Planar route CSV: a header naming ``t,x,y,heading`` (any order), one pose a row."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import ScenarioError
from ..fileio import atomic_write_text
from .base import Trajectory, _check_coordinates, _csv_fields, _data_lines, _increasing, _parse_row

PLANAR_CSV_COLUMNS = ("t", "x", "y", "heading")



def read_planar_csv(path: str | Path) -> Trajectory:
    """Read a planar route CSV: a header naming the columns ``t,x,y,heading`` (any order; other
    columns are ignored), then one pose a row: time [s], x [m], y [m], heading [rad] counter-clockwise
    from planar X. ``#`` comments and blank lines are skipped; times strictly increasing.

    Raises:
        ScenarioError: missing file, no header or a header without those columns, a row with another
            number of fields than the header or a bad number, no rows, times that do not increase.
    """
    path = Path(path)
    lines = _data_lines(path, "route CSV")
    if not lines:
        raise ScenarioError(path, "route CSV is empty: expected a header t,x,y,heading and one pose a row")
    hline, header = lines[0][0], [f.lower() for f in _csv_fields(lines[0][1])]
    missing = [c for c in PLANAR_CSV_COLUMNS if c not in header]
    if missing:
        raise ScenarioError(path, f"route CSV header {','.join(header)!r} lacks column(s) {', '.join(missing)}: "
                            "expected a header naming t,x,y,heading (heading in radians)", hline)
    dup = sorted({c for c in header if header.count(c) > 1 and c in PLANAR_CSV_COLUMNS})
    if dup:
        raise ScenarioError(path, f"route CSV header names column(s) {', '.join(dup)} twice", hline)
    cols = [header.index(c) for c in PLANAR_CSV_COLUMNS]
    rows, linenos = [], []
    for lineno, s in lines[1:]:
        fields = _csv_fields(s)
        if len(fields) != len(header):
            raise ScenarioError(path, f"expected {len(header)} comma-separated fields as in the header, found {len(fields)}", lineno)
        rows.append(_parse_row(" ".join(fields[c] for c in cols), path, lineno, 4, "t,x,y,heading"))
        linenos.append(lineno)
    if not rows:
        raise ScenarioError(path, "route CSV has a header but no poses")
    a = np.asarray(rows)
    _increasing(a[:, 0].tolist(), path, linenos)
    _check_coordinates(a[:, 1:3], path, linenos, "position")
    return Trajectory(a[:, 1:4], a[:, 0], np.arange(len(a)), str(path))


def write_planar_csv(path: str | Path, planar: np.ndarray, times: np.ndarray) -> Path:
    """Write planar poses as a route CSV ``t,x,y,heading`` (full float precision; atomically)."""
    body = "".join(f"{t!r},{x!r},{y!r},{h!r}\n"
                   for t, (x, y, h) in zip(np.asarray(times, dtype=float).tolist(), np.asarray(planar, dtype=float).tolist()))
    return atomic_write_text(path, "t,x,y,heading\n" + body)


