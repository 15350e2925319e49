"""KITTI odometry: pose files (12 numbers a line, the 3x4 matrix [R | t] of camera 0), ``times.txt``,
the ``dataset/`` folder layout (``poses/NN.txt``, ``sequences/NN/times.txt``, ``landmarks/NN.csv``)."""

from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np

from sensorsel.errors import InputError, ScenarioError
from sensorsel.io.files import atomic_write_text
from sensorsel.model.scenario.base import (
    DEFAULT_FRAME_RATE_HZ,
    ROTATION_TOL,
    RouteFile,
    Trajectory,
    _check_coordinates,
    _parse_row,
    _read_lines,
    _refuse_rows,
)
from sensorsel.model.scenario.frames import find_frame

KITTI_ROOT_ENV = "SENSORSEL_KITTI_ROOT"


def read_kitti_poses(path: str | Path) -> np.ndarray:
    """Read a KITTI pose file: one pose a line, 12 numbers, the row-major 3x4 matrix [R | t].

    Returns:
        (N, 3, 4) array.
    Raises:
        ScenarioError: missing file, empty file, a line without 12 finite numbers (names the line).
    """
    path = Path(path)
    lines = _read_lines(path, "pose")
    linenos = [i for i, line in enumerate(lines, start=1) if line.strip()]
    if not linenos:
        raise ScenarioError(path, "pose file is empty: expected one line of 12 numbers per frame")
    # all numbers at once by numpy's parser when every line holds 12 finite numbers (30 -> 8 ms on
    # KITTI 00's 4,541 lines); otherwise line by line, for the message naming the first bad line
    poses = None
    try:
        flat = np.loadtxt(
            io.StringIO("\n".join(lines[i - 1] for i in linenos).replace(",", " ")), dtype=float, comments=None, ndmin=2
        )
    except ValueError:
        flat = None
    if flat is not None and flat.shape == (len(linenos), 12) and np.isfinite(flat).all():
        poses = flat.reshape(-1, 3, 4)
    if poses is None:
        rows = [_parse_row(lines[i - 1], path, i, 12, "a row-major 3x4 pose matrix") for i in linenos]
        poses = np.asarray(rows).reshape(-1, 3, 4)
    _check_rotations(poses[:, :, :3], path, linenos)
    _check_coordinates(poses[:, :, 3], path, linenos, "position")
    return poses


def _check_rotations(r: np.ndarray, path: Path, linenos: list[int]) -> None:
    """Every (3, 3) block is a rotation: |R R^T - I| and |det R - 1| within :data:`ROTATION_TOL`."""
    orth = np.abs(r @ r.transpose(0, 2, 1) - np.eye(3)).max(axis=(1, 2))
    det = np.linalg.det(r)
    bad = np.flatnonzero(~((orth <= ROTATION_TOL) & (np.abs(det - 1.0) <= ROTATION_TOL)))
    _refuse_rows(
        bad,
        path,
        linenos,
        lambda i: (
            f"the 3x3 block R of the pose is not a rotation (max |R R^T - I| = {orth[i]:.3g}, "
            f"det R = {det[i]:.6g}; allowed {ROTATION_TOL:g})"
        ),
    )


def read_times(path: str | Path) -> np.ndarray:
    """Read a KITTI ``times.txt``: one timestamp [s] a line, strictly increasing."""
    path = Path(path)
    out: list[float] = []
    for lineno, line in enumerate(_read_lines(path, "timestamp"), start=1):
        if not line.strip():
            continue
        (t,) = _parse_row(line, path, lineno, 1, "a timestamp in seconds")
        if out and t <= out[-1]:
            raise ScenarioError(path, f"timestamps must increase: {t} after {out[-1]}", lineno)
        out.append(t)
    if not out:
        raise ScenarioError(path, "timestamp file is empty")
    return np.asarray(out)


def planar_from_kitti(poses: np.ndarray) -> np.ndarray:
    """Planar (x, y, heading) of KITTI camera poses, shape (N, 3, 4) -> (N, 3).

    The car drives along the camera's z axis: heading is the direction of the camera's z axis
    projected on the ground plane.
    """
    t = poses[:, :, 3]
    fwd = poses[:, :, 2]  # camera z axis in frame-0 coordinates
    x = t[:, 2]
    y = -t[:, 0]
    heading = np.arctan2(-fwd[:, 0], fwd[:, 2])
    return np.column_stack([x, y, heading])


def kitti_from_planar(planar: np.ndarray) -> np.ndarray:
    """Inverse of :func:`planar_from_kitti` for flat routes: (N, 3) -> (N, 3, 4) camera poses."""
    n = len(planar)
    out = np.zeros((n, 3, 4))
    c, s = np.cos(planar[:, 2]), np.sin(planar[:, 2])
    # Rotation about the camera's y axis (down) by -heading keeps x right, y down, z forward.
    out[:, 0, 0], out[:, 0, 2] = c, -s
    out[:, 1, 1] = 1.0
    out[:, 2, 0], out[:, 2, 2] = s, c
    out[:, 0, 3] = -planar[:, 1]
    out[:, 2, 3] = planar[:, 0]
    return out


def write_kitti_poses(path: str | Path, planar: np.ndarray) -> Path:
    """Write planar poses as a KITTI pose file (atomically)."""
    m = kitti_from_planar(np.asarray(planar, dtype=float)).reshape(-1, 12)
    return atomic_write_text(path, "".join(" ".join(f"{v:.9e}" for v in row) + "\n" for row in m))


def read_kitti_route(
    poses_path: str | Path,
    times_path: str | Path | None = None,
    *,
    frame_rate_hz: float = DEFAULT_FRAME_RATE_HZ,
    up: str | None = None,
    forward: str | None = None,
) -> RouteFile:
    """Read a route in KITTI's pose format, with its ``times.txt`` or a fixed frame rate, its ground
    plane and forward axis found (:func:`~sensorsel.model.scenario.frames.find_frame`; KITTI's own camera
    frame, y down and z forward, gives exactly :func:`planar_from_kitti`).

    Raises:
        ScenarioError: bad files, a pose file truncated relative to its timestamps, a route whose
            frame cannot be told (a car that never moves, ...).
    """
    poses_path = Path(poses_path)
    poses = read_kitti_poses(poses_path)
    if times_path is not None:
        times = read_times(times_path)
        if len(times) != len(poses):
            what = "truncated" if len(poses) < len(times) else "longer than its timestamps"
            raise ScenarioError(
                poses_path,
                f"pose file is {what}: {len(poses)} poses but {len(times)} timestamps in {times_path}",
                len(poses),
            )
    else:
        times = np.arange(len(poses)) / frame_rate_hz
    frame, notes = find_frame(poses[:, :, 3], poses[:, :, :3], poses_path, convention="camera", up=up, forward=forward)
    planar = frame.planar(poses[:, :, 3], poses[:, :, :3])
    return RouteFile(Trajectory(planar, times, np.arange(len(poses)), str(poses_path)), frame, tuple(notes))


def load_trajectory(
    poses_path: str | Path, times_path: str | Path | None = None, *, frame_rate_hz: float = DEFAULT_FRAME_RATE_HZ
) -> Trajectory:
    """The planar route of a KITTI pose file (:func:`read_kitti_route`)."""
    return read_kitti_route(poses_path, times_path, frame_rate_hz=frame_rate_hz).route


def resolve_kitti_root(explicit: str | Path | None) -> Path:
    """The KITTI ``dataset/`` folder: the explicit path, else ``$SENSORSEL_KITTI_ROOT``.

    Raises:
        InputError: neither is given (says how to point at one), or the folder has no ``poses/``.
    """
    root = explicit or os.environ.get(KITTI_ROOT_ENV)
    if not root:
        raise InputError(
            "no KITTI folder given: pass --kitti-root PATH or set "
            f"{KITTI_ROOT_ENV}=PATH, where PATH holds poses/NN.txt and sequences/NN/times.txt "
            "(KITTI odometry's dataset/ folder)"
        )
    root = Path(root)
    if not (root / "poses").is_dir():
        raise InputError(f"{root}: not a KITTI odometry dataset folder (expected {root / 'poses'}/NN.txt)")
    return root


def read_sequence(root: str | Path, seq: str) -> RouteFile:
    """Full-rate route of sequence ``seq`` under a KITTI-layout root, with its frame and notes."""
    root = Path(root)
    poses_path = root / "poses" / f"{seq}.txt"
    if not poses_path.is_file():
        have = sorted(p.stem for p in (root / "poses").glob("*.txt"))
        raise ScenarioError(poses_path, f"sequence {seq!r} not found; this folder has: {', '.join(have) or 'none'}")
    return read_kitti_route(poses_path, root / "sequences" / seq / "times.txt")


def load_sequence(root: str | Path, seq: str) -> Trajectory:
    """Full-rate trajectory of sequence ``seq`` under a KITTI-layout root."""
    return read_sequence(root, seq).route


def kitti_map_path(root: str | Path, seq: str) -> Path:
    """Where a KITTI folder keeps the pole map of sequence ``seq``: ``landmarks/NN.csv``."""
    return Path(root) / "landmarks" / f"{seq}.csv"
