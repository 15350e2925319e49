"""Positions-only routes: (t, x, y) becomes a route, its heading from the direction of travel.

The entry point for every reader whose file has no orientation (a CSV ``t,x,y``, a GPS log
``Time,X,Y,Z`` once projected, a GPX track once in metres): :func:`route_from_positions`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sensorsel.errors import ScenarioError
from sensorsel.model.scenario.base import MAX_COORD_M, RouteFile, Trajectory
from sensorsel.model.scenario.frames import HEADING_WINDOW_M, Frame, check_moves, headings_from_travel


def route_from_positions(
    t: np.ndarray,
    xy: np.ndarray,
    source: str | Path,
    *,
    frame: Frame | None = None,
    notes: tuple[str, ...] = (),
    window_m: float = HEADING_WINDOW_M,
) -> RouteFile:
    """A planar route from positions only.

    Args:
        t: (N,) times [s], strictly increasing.
        xy: (N, 2) planar positions [m] (x east / forward at the start, y north / left: right-handed
            seen from above).
        source: the file (named in errors and notes).
        frame: the frame the positions were projected by, if they were 3-D (kept for projecting a
            3-D landmark map the same way); None: already planar.
        notes: notes of the reader so far (kept first).
        window_m: the heading's smoothing window [m] (:func:`~sensorsel.model.scenario.frames.headings_from_travel`).
    Returns:
        the route (heading [rad] from the direction of travel), its frame, and the notes (headings
        taken from travel; reversals).
    Raises:
        ScenarioError: times that do not increase, non-finite or absurd coordinates, a car that
            never moves, positions that look like degrees (each naming ``source``).
    """
    t = np.asarray(t, dtype=float).reshape(-1)
    xy = np.asarray(xy, dtype=float).reshape(-1, 2)
    if len(t) != len(xy) or not len(t):
        raise ScenarioError(source, f"{len(t)} times for {len(xy)} positions: expected one time per position")
    if not (np.isfinite(t).all() and np.isfinite(xy).all()):
        raise ScenarioError(source, "NaN or infinite time or position")
    bad = np.flatnonzero(np.diff(t) <= 0)
    if len(bad):
        i = int(bad[0]) + 1
        raise ScenarioError(source, f"timestamps must increase: {t[i]!r} after {t[i - 1]!r} (point {i + 1})")
    if np.abs(xy).max() > MAX_COORD_M:
        raise ScenarioError(
            source,
            f"a position is beyond the limit of {MAX_COORD_M:g} m from the origin (in metres? no map is that large)",
        )
    check_moves(xy, source)
    heading, turn_notes = headings_from_travel(t, xy, window_m=window_m)
    said = [
        f"route {source}: no heading in the file: heading from the direction of travel (smoothed over {window_m:g} m; "
        "a stop keeps the last heading)"
    ]
    said += [f"route {source}: {n}" for n in turn_notes]
    route = Trajectory(np.column_stack([xy, heading]), t, np.arange(len(t)), str(source))
    return RouteFile(route, frame, tuple(notes) + tuple(said))
