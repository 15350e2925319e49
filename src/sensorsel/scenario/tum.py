"""TUM trajectories: ``timestamp tx ty tz qx qy qz qw`` a line (as evo and most SLAM tools write)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..errors import ScenarioError
from ..fileio import atomic_write_text
from .base import QUATERNION_TOL, Trajectory, _check_coordinates, _data_lines, _increasing, _parse_row


def yaw_from_quaternion(qx: np.ndarray, qy: np.ndarray, qz: np.ndarray, qw: np.ndarray) -> np.ndarray:
    """Yaw [rad] (rotation about z, the heading of a z-up frame) of unit quaternions (x, y, z, w)."""
    return np.arctan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))


def read_tum_trajectory(path: str | Path) -> Trajectory:
    """Read a TUM trajectory: one pose a line, ``timestamp tx ty tz qx qy qz qw`` (spaces; ``#``
    comments and blank lines skipped), timestamps strictly increasing.

    Planar frame: the file's x-y plane is the ground (z up): planar (x, y) = (tx, ty), heading = the
    yaw of the quaternion. tz, roll and pitch are not used.

    Raises:
        ScenarioError: missing or empty file, a line without 8 finite numbers, a zero quaternion,
            timestamps that do not increase (each names the line).
    """
    return _read_tum(path)[0]


def _read_tum(path: str | Path) -> tuple[Trajectory, np.ndarray]:
    """The route of a TUM file and its tz column."""
    path = Path(path)
    rows, lines = [], []
    for lineno, s in _data_lines(path, "TUM trajectory"):
        row = _parse_row(s, path, lineno, 8, "timestamp tx ty tz qx qy qz qw")
        norm = math.hypot(*row[4:])
        if norm < 1e-9:
            raise ScenarioError(path, "quaternion qx qy qz qw is zero", lineno)
        if abs(norm - 1.0) > QUATERNION_TOL:
            raise ScenarioError(path, f"quaternion qx qy qz qw has norm {norm:.6g}, not 1 (allowed {QUATERNION_TOL:g}): not a rotation "
                                "(columns in another order or another unit?)", lineno)
        rows.append(row)
        lines.append(lineno)
    if not rows:
        raise ScenarioError(path, "TUM trajectory is empty: expected lines of 'timestamp tx ty tz qx qy qz qw'")
    a = np.asarray(rows)
    _increasing(a[:, 0].tolist(), path, lines)
    _check_coordinates(a[:, 1:3], path, lines, "position")
    q = a[:, 4:8] / np.linalg.norm(a[:, 4:8], axis=1)[:, None]
    heading = yaw_from_quaternion(q[:, 0], q[:, 1], q[:, 2], q[:, 3])
    return Trajectory(np.column_stack([a[:, 1], a[:, 2], heading]), a[:, 0], np.arange(len(a)), str(path)), a[:, 3]


def write_tum_trajectory(path: str | Path, planar: np.ndarray, times: np.ndarray) -> Path:
    """Write planar poses as a TUM trajectory (z = 0, quaternion of the heading about z; atomically)."""
    planar = np.asarray(planar, dtype=float)
    body = "".join(f"{t!r} {x!r} {y!r} 0 0 0 {math.sin(a / 2)!r} {math.cos(a / 2)!r}\n"
                   for t, (x, y, a) in zip(np.asarray(times, dtype=float).tolist(), planar.tolist()))
    return atomic_write_text(path, "# timestamp tx ty tz qx qy qz qw\n" + body)


