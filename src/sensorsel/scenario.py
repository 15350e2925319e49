"""Scenarios: a route (planar keyframe poses) and the landmarks standing along it.

Routes come from KITTI odometry ground truth (``poses/NN.txt`` + ``sequences/NN/times.txt``), from a
route file in one of three formats (:data:`ROUTE_FORMATS`: KITTI poses, TUM trajectories, planar
CSV), or from the bundled synthetic fixtures. Landmarks come from a real map (a KITTI sequence's
``landmarks/NN.csv`` pole map, used by default when the KITTI folder has one), from a user's CSV
file, or from a seeded generator (:class:`LandmarkModel`). Every landmark set is checked the same
way (:class:`LandmarkReport`): exact duplicates are merged, landmarks standing on the road are
counted and, with a clearance, dropped; nothing is dropped without being counted, and
:func:`scenario_notes` says what was done in lines a command prints on stderr.

Frames: KITTI's camera frame has x right, y down, z forward; the ground plane is x-z. sensorsel's
planar frame is right-handed seen from above: X = z (forward at frame 0), Y = -x (left at frame 0),
heading counter-clockwise from X. A TUM trajectory is taken as z-up (ground plane x-y, the
convention of TUM's own ground-truth files and of ROS ``map``/``odom`` frames): planar X, Y = the
file's tx, ty, heading = the yaw of its quaternion (rotation about z); tz, roll and pitch are not
used. A planar CSV is already in the planar frame.
"""

from __future__ import annotations

import csv
import io
import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from ._resources import fixtures_dir
from .conditions import Condition
from .errors import InputError, ScenarioError
from .library import is_number_text
from .fileio import atomic_write_text

KITTI_ROOT_ENV = "SENSORSEL_KITTI_ROOT"
DEFAULT_FIXTURE = "suburb"
ROUTE_FORMATS = ("kitti", "tum", "csv")
DEFAULT_FRAME_RATE_HZ = 10.0  # assumed for a KITTI pose file without timestamps (KITTI's own rate)
ON_ROAD_M = 3.0  # landmarks closer than this to the route are counted as "on the road" (report only)
# Limits and checks (docs/scenarios.md, "Limits and checks"):
ROTATION_TOL = 1e-3  # max |R R^T - I| and |det R - 1| of a KITTI pose's rotation block (KITTI's own: < 3e-7)
QUATERNION_TOL = 1e-3  # max | |q| - 1 | of a TUM quaternion (a 4-decimal file is within 2e-4)
MAX_COORD_M = 1e8  # max |x|, |y| of a route position or landmark [m]: 2.5 times the Earth's circumference
MAX_LANDMARKS = 2_000_000  # most landmarks the generator makes (estimated from route length / spacing first)
SYNTHETIC = "synthetic"  # ScenarioSpec.landmarks: always generate
REAL = "real"  # ScenarioSpec.landmarks: the KITTI sequence's pole map, an error if there is none
# file stems that say nothing about the drive: such a route is named after its folder
_GENERIC_STEMS = {"poses", "pose", "groundtruth", "ground_truth", "gt", "trajectory", "traj", "route", "odometry", "data"}


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.ascontiguousarray(a, dtype=float)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class Trajectory:
    """Planar poses of the car along a route.

    Attributes:
        poses: (K, 3) array of x [m], y [m], heading [rad] in the planar frame.
        times: (K,) timestamps [s], strictly increasing.
        frames: (K,) index of each pose in the source file (0-based).
        source: where it came from (file path or description).
    """

    poses: np.ndarray
    times: np.ndarray
    frames: np.ndarray
    source: str = "<memory>"

    def __post_init__(self) -> None:
        object.__setattr__(self, "poses", _frozen(self.poses))
        object.__setattr__(self, "times", _frozen(self.times))
        object.__setattr__(self, "frames", np.asarray(self.frames, dtype=int))

    def __len__(self) -> int:
        return len(self.poses)

    @property
    def length_m(self) -> float:
        """Length of the polyline through the poses [m]."""
        return float(np.sum(np.hypot(*np.diff(self.poses[:, :2], axis=0).T)))

    @property
    def duration_s(self) -> float:
        return float(self.times[-1] - self.times[0]) if len(self.times) else 0.0

    def select(self, indices: np.ndarray) -> "Trajectory":
        """The sub-trajectory at these pose indices."""
        idx = np.asarray(indices, dtype=int)
        return Trajectory(self.poses[idx], self.times[idx], self.frames[idx], self.source)


@dataclass(frozen=True, eq=False)
class Scenario:
    """What the selection runs on: keyframe poses and landmark positions.

    Attributes:
        name: short label ("03", "suburb", a file name).
        keyframes: the keyframe trajectory (one Pose2 each in the factor graph).
        landmarks: (M, 2) landmark positions [m] in the planar frame.
        landmark_source: "generated (seed N)", "KITTI pole map <path>" or the CSV path.
        route: the full-rate trajectory the keyframes were taken from (for drawing).
        landmark_report: what was read, merged and dropped to get ``landmarks`` (None when the
            scenario was built from arrays).
        notes: what a user should be told about how the scenario was built (an assumed frame
            rate, the landmark counts): see :func:`scenario_notes`.
    """

    name: str
    keyframes: Trajectory
    landmarks: np.ndarray
    landmark_source: str = "<memory>"
    route: Trajectory | None = None
    landmark_report: "LandmarkReport | None" = None
    notes: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        lm = np.asarray(self.landmarks, dtype=float).reshape(-1, 2)
        object.__setattr__(self, "landmarks", _frozen(lm))

    @property
    def n_poses(self) -> int:
        return len(self.keyframes)

    @property
    def n_landmarks(self) -> int:
        return len(self.landmarks)


# --------------------------------------------------------------------------------------------- I/O


def _read_lines(path: Path, what: str) -> list[str]:
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ScenarioError(path, f"{what} file not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ScenarioError(path, f"cannot read {what} file: {exc}") from None
    return text.splitlines()


def _parse_row(line: str, path: Path, lineno: int, n: int, what: str) -> list[float]:
    parts = line.replace(",", " ").split()
    if len(parts) != n:
        raise ScenarioError(path, f"expected {n} numbers ({what}), found {len(parts)}", lineno)
    try:
        values = [float(p) for p in parts]
    except ValueError:
        bad = next(p for p in parts if not is_number_text(p))
        raise ScenarioError(path, f"not a number: {bad!r}", lineno) from None
    if not all(math.isfinite(v) for v in values):
        raise ScenarioError(path, "NaN or infinite value", lineno)
    return values


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
        flat = np.loadtxt(io.StringIO("\n".join(lines[i - 1] for i in linenos).replace(",", " ")), dtype=float,
                          comments=None, ndmin=2)
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
    if len(bad):
        i = int(bad[0])
        raise ScenarioError(path, f"the 3x3 block R of the pose is not a rotation (max |R R^T - I| = {orth[i]:.3g}, det R = {det[i]:.6g}; "
                            f"allowed {ROTATION_TOL:g}); {len(bad)} such line(s) in the file", linenos[i])


def _check_coordinates(xy: np.ndarray, path: Path, linenos: list[int], what: str) -> None:
    """No coordinate beyond :data:`MAX_COORD_M` (a value that is no place on a map)."""
    far = np.flatnonzero(np.abs(np.asarray(xy, dtype=float)).max(axis=1) > MAX_COORD_M)
    if len(far):
        i = int(far[0])
        raise ScenarioError(path, f"{what} {np.asarray(xy)[i].tolist()!r} is beyond the limit of {MAX_COORD_M:g} m from the origin "
                            f"(in metres? no map is that large); {len(far)} such line(s) in the file", linenos[i])


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


def select_keyframes(times: np.ndarray, rate_hz: float) -> np.ndarray:
    """Indices of keyframes: the first frame, then each first frame at least 1/rate_hz later."""
    if isinstance(rate_hz, bool) or not (isinstance(rate_hz, (int, float)) and math.isfinite(rate_hz) and rate_hz > 0):
        raise InputError(f"keyframe rate (--rate) must be a positive, finite number of Hz, got {rate_hz!r}")
    step = 1.0 / rate_hz
    keep = [0]
    for i in range(1, len(times)):
        # the tolerance absorbs timestamp jitter (KITTI's 10 Hz is 0.1036 s +- a few ms)
        if times[i] - times[keep[-1]] >= step - 0.02 * step:
            keep.append(i)
    return np.asarray(keep, dtype=int)


def route_rate_hz(route: Trajectory) -> float:
    """The route's own frame rate [Hz]: 1 / its median frame interval (inf for a single pose)."""
    if len(route.times) < 2:
        return math.inf
    return 1.0 / float(np.median(np.diff(route.times)))


def load_trajectory(poses_path: str | Path, times_path: str | Path | None = None, *, frame_rate_hz: float = 10.0) -> Trajectory:
    """Read a route in KITTI's pose format, with its ``times.txt`` or a fixed frame rate.

    Raises:
        ScenarioError: bad files, or a pose file truncated relative to its timestamps.
    """
    poses_path = Path(poses_path)
    poses = read_kitti_poses(poses_path)
    if times_path is not None:
        times = read_times(times_path)
        if len(times) != len(poses):
            what = "truncated" if len(poses) < len(times) else "longer than its timestamps"
            raise ScenarioError(poses_path, f"pose file is {what}: {len(poses)} poses but {len(times)} timestamps in {times_path}", len(poses))
    else:
        times = np.arange(len(poses)) / frame_rate_hz
    return Trajectory(planar_from_kitti(poses), times, np.arange(len(poses)), str(poses_path))


# ---------------------------------------------------------------------------------- route formats


def _data_lines(path: Path, what: str) -> list[tuple[int, str]]:
    """(line number, stripped text) of the non-blank lines not starting with ``#``."""
    out = []
    for lineno, line in enumerate(_read_lines(path, what), start=1):
        s = line.strip()
        if s and not s.startswith("#"):
            out.append((lineno, s))
    return out


def _increasing(times: list[float], path: Path, lines: list[int]) -> None:
    for i in range(1, len(times)):
        if times[i] <= times[i - 1]:
            raise ScenarioError(path, f"timestamps must increase: {times[i]} after {times[i - 1]}", lines[i])


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


PLANAR_CSV_COLUMNS = ("t", "x", "y", "heading")


def _csv_fields(line: str) -> list[str]:
    return [f.strip() for f in next(csv.reader([line]))]


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


def sniff_route_format(path: str | Path) -> str:
    """The format of a route file when none is given: ``csv`` for a ``.csv`` file; otherwise by the
    first line that is not blank or a ``#`` comment: a header (a field that is not a number) means
    ``csv``, 12 numbers ``kitti`` (a 3x4 pose matrix), 8 numbers ``tum``.

    Raises:
        ScenarioError: missing or empty file, or a first line that fits none of the formats.
    """
    path = Path(path)
    if path.suffix.lower() == ".csv":
        return "csv"
    lines = _data_lines(path, "route")
    if not lines:
        raise ScenarioError(path, "route file is empty")
    lineno, first = lines[0]
    parts = first.replace(",", " ").split()
    if not all(is_number_text(p) for p in parts):
        return "csv"
    by_count = {12: "kitti", 8: "tum"}
    if len(parts) not in by_count:
        raise ScenarioError(path, f"cannot tell the route format: {len(parts)} numbers on the first line "
                            "(KITTI poses have 12, TUM trajectories 8, a planar CSV has a header t,x,y,heading); "
                            "give the format (--route-format kitti|tum|csv)", lineno)
    return by_count[len(parts)]


def load_route_file(path: str | Path, fmt: str | None = None, times: str | Path | None = None,
                    *, frame_rate_hz: float = DEFAULT_FRAME_RATE_HZ) -> tuple[Trajectory, tuple[str, ...]]:
    """Read a route in ``fmt`` (``kitti``, ``tum``, ``csv``; None: :func:`sniff_route_format`).

    ``times`` goes with a KITTI pose file only (TUM and CSV routes carry their own timestamps); a
    KITTI pose file without it is taken at ``frame_rate_hz``, and the returned notes say so.

    Returns:
        (route, notes): notes are lines to tell the user (an assumed rate, a TUM file that does not
        look z-up).
    """
    path = Path(path)
    if fmt is None:
        fmt = sniff_route_format(path)
    if fmt not in ROUTE_FORMATS:
        raise InputError(f"unknown route format {fmt!r}; expected one of {', '.join(ROUTE_FORMATS)}")
    if times is not None and fmt != "kitti":
        raise InputError(f"timestamps {times} go with a KITTI pose file; a {fmt} route ({path}) carries its own")
    notes: list[str] = []
    if fmt == "kitti":
        route = load_trajectory(path, times, frame_rate_hz=frame_rate_hz)
        if times is None:
            notes.append(f"route {path} has no timestamps: assumed {frame_rate_hz:g} Hz (give its times file to use real ones)")
    elif fmt == "csv":
        route = read_planar_csv(path)
    else:
        route, z = _read_tum(path)
        extent = max(float(np.ptp(route.poses[:, 0])), float(np.ptp(route.poses[:, 1])))
        if np.ptp(z) > 1.0 and np.ptp(z) > 0.5 * extent:
            notes.append(f"route {path}: tz spans {np.ptp(z):.1f} m against {extent:.1f} m in x-y; sensorsel takes a TUM "
                         "file as z-up (ground plane x-y): a camera-frame (y-down) trajectory must be converted first")
    return route, tuple(notes)


def route_name(path: str | Path) -> str:
    """The name of a scenario read from a route file: the file's stem, or its folder's name when the
    stem says nothing about the drive (``poses``, ``groundtruth``, ``trajectory``, ...)."""
    path = Path(path)
    if path.stem.lower() in _GENERIC_STEMS and path.resolve().parent.name:
        return path.resolve().parent.name
    return path.stem


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


def load_sequence(root: str | Path, seq: str) -> Trajectory:
    """Full-rate trajectory of sequence ``seq`` under a KITTI-layout root."""
    root = Path(root)
    poses_path = root / "poses" / f"{seq}.txt"
    if not poses_path.is_file():
        have = sorted(p.stem for p in (root / "poses").glob("*.txt"))
        raise ScenarioError(poses_path, f"sequence {seq!r} not found; this folder has: {', '.join(have) or 'none'}")
    return load_trajectory(poses_path, root / "sequences" / seq / "times.txt")


# ------------------------------------------------------------------------------------- landmarks


@dataclass(frozen=True)
class LandmarkModel:
    """Seeded generator of synthetic point landmarks along a route.

    Near landmarks (poles, trees, façades) stand on both roadsides about every ``near_spacing_m``
    of route, ``near_offset_m`` to the side; far landmarks (buildings, hills) stand every
    ``far_spacing_m`` on a random side, ``far_offset_m`` away. Spacing and offsets are jittered
    uniformly. Landmarks closer than ``clearance_m`` to any point of the route (the road itself,
    e.g. on a loop) are dropped.
    """

    near_spacing_m: float = 5.0
    near_offset_m: tuple[float, float] = (4.0, 12.0)
    far_spacing_m: float = 25.0
    far_offset_m: tuple[float, float] = (25.0, 80.0)
    clearance_m: float = 3.0

    def __post_init__(self) -> None:
        for name in ("near_spacing_m", "far_spacing_m"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise InputError(f"landmark model: {name} must be positive, got {v!r}")
        for name in ("near_offset_m", "far_offset_m"):
            lo, hi = getattr(self, name)
            if not (0 <= lo <= hi and math.isfinite(hi)):
                raise InputError(f"landmark model: {name} must be 0 <= low <= high, got {(lo, hi)!r}")
            if hi > MAX_COORD_M:
                raise InputError(f"landmark model: {name} ({_OPTION[name]}) {hi:g} m is beyond the limit of {MAX_COORD_M:g} m")
        if not (math.isfinite(self.clearance_m) and self.clearance_m >= 0):
            raise InputError(f"landmark model: clearance_m must be >= 0, got {self.clearance_m!r}")


# the CLI option of each LandmarkModel field (`sensorsel landmarks`), named in its errors
_OPTION = {"near_spacing_m": "--near-spacing", "far_spacing_m": "--far-spacing", "near_offset_m": "--near-offset",
           "far_offset_m": "--far-offset", "clearance_m": "--clearance"}


def check_landmark_seed(seed: object) -> int:
    """The seed of the landmark generator: an integer >= 0 (``--landmark-seed``), else InputError."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError(f"landmark seed (--landmark-seed) must be an integer >= 0, got {seed!r}")
    return int(seed)


def estimate_landmark_count(length_m: float, model: LandmarkModel) -> int:
    """How many landmarks :func:`generate_landmarks` makes along a route of ``length_m`` before the
    clearance drops some: two roadsides of near ones, one row of far ones (an upper bound)."""
    return int(2 * (length_m // model.near_spacing_m) + length_m // model.far_spacing_m)


def generate_landmarks(route: Trajectory, model: LandmarkModel = LandmarkModel(), seed: int = 0) -> np.ndarray:
    """Synthetic landmarks along ``route`` (use the full-rate route, not keyframes).

    Returns:
        (M, 2) positions [m], deterministic for a given route, model and seed.
    Raises:
        InputError: a negative seed; spacings that would make more than :data:`MAX_LANDMARKS`
            landmarks along this route (estimated before anything is allocated).
    """
    seed = check_landmark_seed(seed)
    length = route.length_m
    n_est = estimate_landmark_count(length, model)
    if n_est > MAX_LANDMARKS:
        near, far = 2 * (length // model.near_spacing_m), length // model.far_spacing_m
        name = "near_spacing_m" if near >= far else "far_spacing_m"
        raise InputError(f"landmark model: {name} ({_OPTION[name]}) {getattr(model, name):g} m along the {length:,.0f} m route would "
                         f"generate about {n_est:,} landmarks, more than the limit of {MAX_LANDMARKS:,}: use a larger spacing")
    rng = np.random.default_rng(seed)
    xy = route.poses[:, :2]
    if len(xy) < 2:
        return np.zeros((0, 2))
    seg = np.diff(xy, axis=0)
    seglen = np.hypot(seg[:, 0], seg[:, 1])
    s_cum = np.concatenate([[0.0], np.cumsum(seglen)])
    total = s_cum[-1]
    if total <= 0:
        return np.zeros((0, 2))

    def along(s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        i = np.clip(np.searchsorted(s_cum, s, side="right") - 1, 0, len(seg) - 1)
        frac = (s - s_cum[i]) / np.where(seglen[i] > 0, seglen[i], 1.0)
        p = xy[i] + frac[:, None] * seg[i]
        d = seg[i] / np.where(seglen[i] > 0, seglen[i], 1.0)[:, None]
        return p, np.column_stack([-d[:, 1], d[:, 0]])  # point, left normal

    out = []
    for side in (+1.0, -1.0):
        n = int(total // model.near_spacing_m)
        s = (np.arange(n) + rng.uniform(0.0, 1.0, n)) * model.near_spacing_m
        p, nrm = along(s)
        off = rng.uniform(*model.near_offset_m, n)
        out.append(p + side * off[:, None] * nrm)
    n = int(total // model.far_spacing_m)
    s = (np.arange(n) + rng.uniform(0.0, 1.0, n)) * model.far_spacing_m
    p, nrm = along(s)
    far_side = rng.choice([-1.0, 1.0], n)
    off = rng.uniform(*model.far_offset_m, n)
    out.append(p + (far_side * off)[:, None] * nrm)
    lm = np.concatenate(out)
    if model.clearance_m > 0 and len(lm):
        dist, _ = cKDTree(_densify(xy, 0.5)).query(lm)
        lm = lm[dist >= model.clearance_m]
    return lm


def _densify(xy: np.ndarray, step: float) -> np.ndarray:
    """Points along the polyline at most ``step`` apart (for distance-to-route queries): its first
    point, then each segment's n = ceil(length / step) points a + (k / n)(b − a), k = 1..n."""
    if len(xy) < 2:
        return np.asarray(xy[:1], dtype=float)
    d = np.diff(xy, axis=0)
    n = np.maximum(1, np.ceil(np.hypot(d[:, 0], d[:, 1]) / step).astype(np.int64))
    seg = np.repeat(np.arange(len(d)), n)  # all segments at once (a loop over them took ~50 ms on 00)
    k = np.arange(len(seg)) - np.repeat(np.cumsum(n) - n, n) + 1
    t = (k / n[seg])[:, None]
    return np.concatenate([xy[:1], xy[:-1][seg] + t * d[seg]])


def read_landmarks_csv(path: str | Path) -> np.ndarray:
    """Read landmarks [m] from a CSV file, one landmark a row, as written (duplicates kept).

    Blank lines and ``#`` comments are skipped. The first other line is a header when any of its
    fields is not a number: it must name columns ``x`` and ``y`` (any case, any order), other columns
    (``z``, ``kind``, ``id``, ...) are ignored. Without a header, x and y are the first two columns
    and further columns are ignored. Every row has as many fields as the first (fields may be
    quoted, as CSV allows).

    Raises:
        ScenarioError: missing file, a header without x and y, a row with another number of fields
            or a bad x or y (names the line), no landmark.
    """
    path = Path(path)
    lines = _data_lines(path, "landmark")
    cols, n_fields, start = (0, 1), None, 0
    if lines:
        hline, first = lines[0]
        fields = _csv_fields(first)
        if not all(is_number_text(f) for f in fields):
            header = [f.lower() for f in fields]
            missing = [c for c in ("x", "y") if c not in header]
            if missing:
                raise ScenarioError(path, f"header {first!r} names no {' and no '.join(missing)} column: expected a header "
                                    "naming x and y (metres; other columns are ignored) or rows of numbers", hline)
            for c in ("x", "y"):
                if header.count(c) > 1:
                    raise ScenarioError(path, f"header {first!r} names column {c} twice", hline)
            cols, n_fields, start = (header.index("x"), header.index("y")), len(header), 1
    rows, linenos = [], []
    for lineno, s in lines[start:]:
        fields = _csv_fields(s)
        if n_fields is None:
            n_fields = len(fields)
            if n_fields < 2:
                raise ScenarioError(path, f"expected comma-separated x,y (metres), found {n_fields} fields", lineno)
        if len(fields) != n_fields:
            raise ScenarioError(path, f"expected {n_fields} comma-separated fields as in the {'header' if start else 'first row'}, "
                                f"found {len(fields)} fields", lineno)
        rows.append(_parse_row(f"{fields[cols[0]]} {fields[cols[1]]}", path, lineno, 2, "x,y"))
        linenos.append(lineno)
    if rows:
        _check_coordinates(np.asarray(rows), path, linenos, "landmark")
    if not rows:
        # an empty map would silently make every suite score 0
        raise ScenarioError(path, "landmark file has no landmarks: expected rows of x,y in metres")
    return np.asarray(rows, dtype=float).reshape(-1, 2)


@dataclass(frozen=True)
class LandmarkReport:
    """What was done to a landmark set before it became a scenario's landmarks.

    Attributes:
        source: where the landmarks came from (as :attr:`Scenario.landmark_source`).
        n_read: landmarks read (or generated), duplicates included.
        n_duplicates: rows that repeat an earlier row exactly (same x and y): always merged.
        on_road_m: the distance to the route polyline under which a landmark counts as on the road:
            the clearance when one is given, else :data:`ON_ROAD_M` (then only counted).
        n_on_road: distinct landmarks closer than ``on_road_m`` to the route.
        clearance_m: the clearance asked for (None: no landmark dropped for standing on the road).
        n_dropped: landmarks dropped for the clearance (``n_on_road`` when it is given, else 0).
        min_distance_m: smallest distance of a kept landmark to the route [m] (inf: none kept).
    """

    source: str
    n_read: int
    n_duplicates: int
    on_road_m: float
    n_on_road: int
    clearance_m: float | None
    n_dropped: int
    min_distance_m: float

    @property
    def n_kept(self) -> int:
        return self.n_read - self.n_duplicates - self.n_dropped

    def notes(self, always: bool = True) -> list[str]:
        """One line saying what was read, merged and dropped (``always=False``: only when something
        was merged, dropped or stands on the road)."""
        if not always and not (self.n_duplicates or self.n_on_road):
            return []
        parts = [f"{self.n_read} read"]
        if self.n_duplicates:
            parts.append(f"{self.n_duplicates} exact duplicate(s) merged")
        if self.clearance_m is not None:
            parts.append(f"{self.n_dropped} closer than the clearance {self.clearance_m:g} m to the route dropped")
        elif self.n_on_road:
            parts.append(f"{self.n_on_road} within {self.on_road_m:g} m of the route kept (a clearance drops them: --clearance {self.on_road_m:g})")
        return [f"landmarks: {self.source}: {', '.join(parts)}: {self.n_kept} used"]


def distance_to_route(points: np.ndarray, xy: np.ndarray, chunk: int = 256) -> np.ndarray:
    """Exact distance [m] of each point (M, 2) to the polyline through ``xy`` (K, 2).

    Only the segments that can be nearest are measured: a segment whose bounding circle (midpoint,
    half its length) lies farther than the point's nearest vertex (plus a margin far above
    round-off) cannot be. Each kept segment's distance is computed as for all of them, and a
    minimum is exact, so the result is the same to the bit (KITTI 00, 4,540 segments, 3,113 points: 615 -> 14 ms).
    """
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    xy = np.asarray(xy, dtype=float).reshape(-1, 2)
    if len(xy) == 1:
        return np.hypot(*(points - xy[0]).T)
    a, ab = xy[:-1], np.diff(xy, axis=0)
    ab2 = np.maximum(np.einsum("sk,sk->s", ab, ab), 1e-300)
    if not len(points):
        return np.zeros(0)
    upper, _ = cKDTree(xy).query(points)  # ≥ the distance to the polyline
    half = 0.5 * np.sqrt(ab2)
    reach = upper + float(half.max()) + 1e-6 * (1.0 + upper)
    lists = cKDTree(a + 0.5 * ab).query_ball_point(points, reach)
    n = np.fromiter((len(x) for x in lists), dtype=np.int64, count=len(lists))
    seg = np.fromiter((j for x in lists for j in x), dtype=np.int64, count=int(n.sum()))
    pt = np.repeat(np.arange(len(points)), n)
    # the same arithmetic per (point, segment) as over all segments, on the pairs kept
    p = points[pt] - a[seg]
    t = np.clip(np.einsum("nk,nk->n", p, ab[seg]) / ab2[seg], 0.0, 1.0)
    d = p - t[:, None] * ab[seg]
    d2 = np.einsum("nk,nk->n", d, d)
    start = np.concatenate([[0], np.cumsum(n)[:-1]])
    return np.sqrt(np.minimum.reduceat(d2, start))


def clean_landmarks(landmarks: np.ndarray, route: Trajectory, clearance_m: float | None = None,
                    source: str = "<memory>") -> tuple[np.ndarray, LandmarkReport]:
    """Merge exact duplicates (first occurrence kept, order kept), count the landmarks standing on
    the road (closer than ``clearance_m``, or :data:`ON_ROAD_M` when None, to the polyline of the
    full-rate ``route``) and drop them when ``clearance_m`` is given.

    Returns:
        (landmarks kept, the report of what was done).
    """
    if clearance_m is not None and not (isinstance(clearance_m, (int, float)) and math.isfinite(clearance_m) and clearance_m >= 0):
        raise InputError(f"clearance must be a number of metres >= 0, got {clearance_m!r}")
    lm = np.asarray(landmarks, dtype=float).reshape(-1, 2)
    n_read = len(lm)
    if n_read:
        _, first = np.unique(lm, axis=0, return_index=True)
        lm = lm[np.sort(first)]
    n_duplicates = n_read - len(lm)
    on_road_m = ON_ROAD_M if clearance_m is None else float(clearance_m)
    dist = distance_to_route(lm, route.poses[:, :2]) if len(lm) else np.zeros(0)
    near = dist < on_road_m
    dropped = int(near.sum()) if clearance_m is not None else 0
    if clearance_m is not None:
        lm, dist = lm[~near], dist[~near]
    report = LandmarkReport(source, n_read, n_duplicates, on_road_m, int(near.sum()), None if clearance_m is None else float(clearance_m), dropped,
                            float(dist.min()) if len(dist) else math.inf)
    return lm, report


def write_landmarks_csv(path: str | Path, landmarks: np.ndarray) -> Path:
    """Write landmarks as ``x,y`` CSV with a header (atomically)."""
    body = "".join(f"{x:.6f},{y:.6f}\n" for x, y in np.asarray(landmarks, dtype=float).reshape(-1, 2))
    return atomic_write_text(path, "x,y\n" + body)


# ------------------------------------------------------------------------------------- pipeline


@dataclass(frozen=True)
class ScenarioSpec:
    """Everything that defines a scenario, as a user states it (and as results record it).

    Exactly one route source is used: ``route`` (a route file in ``route_format``: ``kitti``,
    ``tum`` or ``csv``; None: sniffed, see :func:`sniff_route_format`), else ``poses`` (a KITTI pose
    file, the older spelling of ``route`` + ``route_format="kitti"``), else ``seq`` (under
    ``kitti_root`` / ``$SENSORSEL_KITTI_ROOT``), else the bundled fixture ``fixture``. ``times``
    goes with a KITTI pose file (without it: 10 Hz, and a note says so).

    ``landmarks``: None (default) uses the route's own map: a sequence's ``landmarks/NN.csv`` pole
    map when the KITTI folder has one, a fixture's bundled CSV, else generated; ``"real"`` requires
    the sequence's pole map; ``"synthetic"`` always generates (``landmark_model``, ``landmark_seed``);
    anything else is a landmark CSV file (:func:`read_landmarks_csv`).

    ``clearance_m``: drop landmarks closer than this to the route (None: count them, keep them).
    ``name``: the scenario's name (default: the sequence, the fixture, or the route file's name as
    :func:`route_name` gives it).
    ``condition``: the operating condition (night, rain, fog, snow; :mod:`sensorsel.conditions`)
    the route is driven in; None: clear. It does not change the scenario, only what each sensor
    sees on it (:func:`sensorsel.problem.build_problem` applies it).
    """

    seq: str | None = None
    kitti_root: str | None = None
    poses: str | None = None
    times: str | None = None
    fixture: str = DEFAULT_FIXTURE
    landmarks: str | None = None
    landmark_seed: int = 0
    keyframe_rate_hz: float = 1.0
    landmark_model: LandmarkModel = field(default_factory=LandmarkModel)
    route: str | None = None
    route_format: str | None = None
    clearance_m: float | None = None
    name: str | None = None
    condition: Condition | None = None


def fixture_names() -> list[str]:
    """Names of the bundled fixture scenarios."""
    return sorted(p.stem for p in (fixtures_dir() / "poses").glob("*.txt"))


@dataclass(frozen=True)
class _Route:
    route: Trajectory
    name: str
    own_landmarks: Path | None  # the route's own map (a pole map, a fixture's CSV), if it has one
    own_label: str  # how to name that map as a landmark source
    notes: tuple[str, ...]
    missing_map: str | None = None  # why a sequence has no own map (for the notes)


def kitti_map_path(root: str | Path, seq: str) -> Path:
    """Where a KITTI folder keeps the pole map of sequence ``seq``: ``landmarks/NN.csv``."""
    return Path(root) / "landmarks" / f"{seq}.csv"


def _load_route(spec: ScenarioSpec) -> _Route:
    if spec.route is not None and spec.poses is not None:
        raise InputError(f"give one route file: route {spec.route} or poses {spec.poses}, not both")
    if spec.route_format is not None and spec.route is None:
        raise InputError(f"a route format ({spec.route_format}) goes with a route file")
    if spec.times is not None and spec.route is None and spec.poses is None:
        raise InputError(f"timestamps {spec.times} go with a KITTI pose file (a sequence or fixture has its own times.txt)")
    if spec.route is not None or spec.poses is not None:
        path: str = spec.route if spec.route is not None else spec.poses  # type: ignore[assignment]  # one is set
        fmt = spec.route_format if spec.route is not None else "kitti"
        route, notes = load_route_file(path, fmt, spec.times)
        return _Route(route, route_name(path), None, "", notes)
    if spec.seq is not None:
        root = resolve_kitti_root(spec.kitti_root)
        lm = kitti_map_path(root, spec.seq)
        route = load_sequence(root, spec.seq)
        if lm.is_file():
            return _Route(route, spec.seq, lm, f"KITTI pole map {lm}", ())
        return _Route(route, spec.seq, None, "", (), f"no pole map {lm}")
    root = fixtures_dir()
    if spec.fixture not in fixture_names():
        raise InputError(f"unknown fixture {spec.fixture!r}; bundled fixtures: {', '.join(fixture_names())}")
    lm = root / "landmarks" / f"{spec.fixture}.csv"
    return _Route(load_sequence(root, spec.fixture), spec.fixture, lm, str(lm), ())


def load_route(spec: ScenarioSpec = ScenarioSpec()) -> tuple[Trajectory, str, Path | None]:
    """The full-rate route of ``spec``: (route, scenario name, the route's own landmark map or None:
    a sequence's pole map, a fixture's CSV)."""
    r = _load_route(spec)
    return r.route, _name(spec, r.name), r.own_landmarks


def _name(spec: ScenarioSpec, default: str) -> str:
    if spec.name is None:
        return default
    if not isinstance(spec.name, str) or not spec.name.strip() or any(c in spec.name for c in "\r\n\t"):
        raise InputError(f"scenario name must be a non-empty line of text, got {spec.name!r}")
    return spec.name.strip()


def route_landmarks(spec: ScenarioSpec = ScenarioSpec()) -> np.ndarray:
    """Synthetic landmarks along the route of ``spec`` from ``spec.landmark_model`` and
    ``spec.landmark_seed``, always generated (a fixture's bundled CSV, a sequence's pole map and
    ``spec.landmarks`` are not read): the file a user writes once and edits, or passes back with
    ``--landmarks``.

    Returns:
        (M, 2) positions [m] in the planar frame.
    """
    route, _, _ = load_route(spec)
    return generate_landmarks(route, spec.landmark_model, spec.landmark_seed)


def load_scenario(spec: ScenarioSpec = ScenarioSpec()) -> Scenario:
    """Build a scenario: read the route, take keyframes, read or generate landmarks, merge their
    exact duplicates and count (with ``spec.clearance_m``: drop) those standing on the road.

    What was assumed, merged or dropped is in the scenario's ``notes`` (:func:`scenario_notes`) and
    ``landmark_report``.
    """
    check_landmark_seed(spec.landmark_seed)
    r = _load_route(spec)
    route, name = r.route, _name(spec, r.name)
    keyframes = route.select(select_keyframes(route.times, spec.keyframe_rate_hz))
    if len(keyframes) < 2:
        raise InputError(f"route {route.source} gives {len(keyframes)} keyframe(s) at {spec.keyframe_rate_hz} Hz; need at least 2")
    notes = list(r.notes)
    own_rate = route_rate_hz(route)
    if spec.keyframe_rate_hz > own_rate:
        used = f"every frame ({len(route)})" if len(keyframes) == len(route) else f"{len(keyframes)} of {len(route)} frames"
        notes.append(f"keyframes: the rate {spec.keyframe_rate_hz:g} Hz is above the route's own {own_rate:.3g} Hz (median frame "
                     f"interval {1.0 / own_rate:.4g} s): used {used} as keyframes, at {(len(keyframes) - 1) / keyframes.duration_s:.3g} Hz "
                     "on average")
    choice = spec.landmarks
    if choice == REAL:
        if spec.seq is None or spec.route is not None or spec.poses is not None:
            raise InputError("landmarks 'real' means a KITTI sequence's pole map: it goes with a sequence (--seq NN)")
        if r.own_landmarks is None:
            raise InputError(f"landmarks 'real': {r.missing_map} (the KITTI folder has no landmarks/{spec.seq}.csv)")
    if choice == SYNTHETIC or (choice is None and r.own_landmarks is None):
        raw = generate_landmarks(route, spec.landmark_model, spec.landmark_seed)
        source = f"generated (seed {spec.landmark_seed})"
        if choice is None and r.missing_map:
            notes.append(f"landmarks: {r.missing_map}: generated synthetic landmarks (seed {spec.landmark_seed})")
        elif choice is None:
            notes.append(f"landmarks: the route has no map: generated synthetic landmarks (seed {spec.landmark_seed}; "
                         "give a landmark file for a real one)")
    elif choice is None or choice == REAL:
        assert r.own_landmarks is not None
        raw, source = read_landmarks_csv(r.own_landmarks), r.own_label
    else:
        raw, source = read_landmarks_csv(choice), str(choice)
    landmarks, report = clean_landmarks(raw, route, spec.clearance_m, source)
    notes.extend(report.notes(always=False))  # the source itself is on every result's scenario line
    if not len(landmarks):
        raise InputError(f"no landmark left of the {report.n_read} of {source} (clearance {spec.clearance_m} m): every suite would score 0")
    return Scenario(name, keyframes, landmarks, source, route, report, tuple(notes))


def scenario_notes(scenario: Scenario) -> list[str]:
    """Lines a command prints on stderr before its output: what was assumed in building the
    scenario (a frame rate, synthetic landmarks for want of a map) and what was done to its
    landmarks (read, duplicates merged, on the road kept or dropped). Empty for a scenario built
    from arrays."""
    return list(scenario.notes)
