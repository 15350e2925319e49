"""TUM trajectories: ``timestamp tx ty tz qx qy qz qw`` a line (as evo and most SLAM tools write)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from sensorsel.errors import ScenarioError
from sensorsel.io.files import atomic_write_text
from sensorsel.model.scenario.base import (
    QUATERNION_TOL,
    RouteFile,
    Trajectory,
    _checked_rows,
    _data_lines,
    _parse_row,
)
from sensorsel.model.scenario.frames import find_frame


def yaw_from_quaternion(qx: np.ndarray, qy: np.ndarray, qz: np.ndarray, qw: np.ndarray) -> np.ndarray:
    """Yaw [rad] (rotation about z, the heading of a z-up frame) of unit quaternions (x, y, z, w)."""
    return np.arctan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))


def rotations_from_quaternions(q: np.ndarray) -> np.ndarray:
    """Rotation matrices (N, 3, 3) of unit quaternions (N, 4) as (x, y, z, w); R[1, 0] and R[0, 0]
    are the very expressions of :func:`yaw_from_quaternion` (a z-up file gives the same heading)."""
    x, y, z, w = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    r = np.empty((len(q), 3, 3))
    r[:, 0, 0] = 1.0 - 2.0 * (y * y + z * z)
    r[:, 0, 1] = 2.0 * (x * y - w * z)
    r[:, 0, 2] = 2.0 * (x * z + w * y)
    r[:, 1, 0] = 2.0 * (w * z + x * y)
    r[:, 1, 1] = 1.0 - 2.0 * (x * x + z * z)
    r[:, 1, 2] = 2.0 * (y * z - w * x)
    r[:, 2, 0] = 2.0 * (x * z - w * y)
    r[:, 2, 1] = 2.0 * (y * z + w * x)
    r[:, 2, 2] = 1.0 - 2.0 * (x * x + y * y)
    return r


def read_tum_trajectory(path: str | Path) -> Trajectory:
    """Read a TUM trajectory: one pose a line, ``timestamp tx ty tz qx qy qz qw`` (spaces; ``#``
    comments and blank lines skipped), timestamps strictly increasing.

    The ground plane and the forward axis are found from the poses (:func:`read_tum_route`): a
    z-up file (TUM's own ground truth, ROS ``map`` frames) gives planar (x, y) = (tx, ty) and heading
    = the yaw of the quaternion; a camera-frame file (as evo writes KITTI poses) the same numbers
    as the KITTI file.

    Raises:
        ScenarioError: missing or empty file, a line without 8 finite numbers, a zero quaternion,
            timestamps that do not increase (each names the line); a route whose frame cannot be told.
    """
    return read_tum_route(path).route


def read_tum_route(path: str | Path, *, up: str | None = None, forward: str | None = None) -> RouteFile:
    """The route of a TUM file with its frame (:func:`~sensorsel.model.scenario.frames.find_frame`, the
    format's own convention z up, x forward) and notes."""
    path = Path(path)
    rows, lines = [], []
    for lineno, s in _data_lines(path, "TUM trajectory"):
        row = _parse_row(s, path, lineno, 8, "timestamp tx ty tz qx qy qz qw")
        norm = math.hypot(*row[4:])
        if norm < 1e-9:
            raise ScenarioError(path, "quaternion qx qy qz qw is zero", lineno)
        if abs(norm - 1.0) > QUATERNION_TOL:
            raise ScenarioError(
                path,
                f"quaternion qx qy qz qw has norm {norm:.6g}, not 1 (allowed {QUATERNION_TOL:g}): not a rotation "
                "(columns in another order or another unit?)",
                lineno,
            )
        rows.append(row)
        lines.append(lineno)
    a = _checked_rows(
        rows, lines, path, "TUM trajectory is empty: expected lines of 'timestamp tx ty tz qx qy qz qw'", 3
    )
    q = a[:, 4:8] / np.linalg.norm(a[:, 4:8], axis=1)[:, None]
    rot = rotations_from_quaternions(q)
    frame, notes = find_frame(a[:, 1:4], rot, path, convention="z-up", up=up, forward=forward)
    route = Trajectory(frame.planar(a[:, 1:4], rot), a[:, 0], np.arange(len(a)), str(path))
    return RouteFile(route, frame, tuple(notes))


def write_tum_trajectory(path: str | Path, planar: np.ndarray, times: np.ndarray) -> Path:
    """Write planar poses as a TUM trajectory (z = 0, quaternion of the heading about z; atomically)."""
    planar = np.asarray(planar, dtype=float)
    body = "".join(
        f"{t!r} {x!r} {y!r} 0 0 0 {math.sin(a / 2)!r} {math.cos(a / 2)!r}\n"
        for t, (x, y, a) in zip(np.asarray(times, dtype=float).tolist(), planar.tolist())
    )
    return atomic_write_text(path, "# timestamp tx ty tz qx qy qz qw\n" + body)
