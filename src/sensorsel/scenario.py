"""Scenarios: a route (planar keyframe poses) and the landmarks standing along it.

Routes come from KITTI odometry ground truth (``poses/NN.txt`` + ``sequences/NN/times.txt``), from any
file in KITTI's pose format (a user's own drive), or from the bundled synthetic fixtures. Landmarks
come from a CSV file (x, y) or from a seeded generator (:class:`LandmarkModel`).

Frames: KITTI's camera frame has x right, y down, z forward; the ground plane is x-z. sensorsel's
planar frame is right-handed seen from above: X = z (forward at frame 0), Y = -x (left at frame 0),
heading counter-clockwise from X.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from ._resources import fixtures_dir
from .errors import InputError, ScenarioError
from .fileio import atomic_write_text

KITTI_ROOT_ENV = "SENSORSEL_KITTI_ROOT"
DEFAULT_FIXTURE = "suburb"


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
        landmark_source: "generated (seed N)" or the CSV path.
        route: the full-rate trajectory the keyframes were taken from (for drawing).
    """

    name: str
    keyframes: Trajectory
    landmarks: np.ndarray
    landmark_source: str = "<memory>"
    route: Trajectory | None = None

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
        bad = next(p for p in parts if not _is_float(p))
        raise ScenarioError(path, f"not a number: {bad!r}", lineno) from None
    if not all(math.isfinite(v) for v in values):
        raise ScenarioError(path, "NaN or infinite value", lineno)
    return values


def _is_float(s: str) -> bool:
    try:
        float(s)
        return True
    except ValueError:
        return False


def read_kitti_poses(path: str | Path) -> np.ndarray:
    """Read a KITTI pose file: one pose a line, 12 numbers, the row-major 3x4 matrix [R | t].

    Returns:
        (N, 3, 4) array.
    Raises:
        ScenarioError: missing file, empty file, a line without 12 finite numbers (names the line).
    """
    path = Path(path)
    rows = []
    for lineno, line in enumerate(_read_lines(path, "pose"), start=1):
        if not line.strip():
            continue
        rows.append(_parse_row(line, path, lineno, 12, "a row-major 3x4 pose matrix"))
    if not rows:
        raise ScenarioError(path, "pose file is empty: expected one line of 12 numbers per frame")
    return np.asarray(rows).reshape(-1, 3, 4)


def read_times(path: str | Path) -> np.ndarray:
    """Read a KITTI ``times.txt``: one timestamp [s] a line, strictly increasing."""
    path = Path(path)
    out = []
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
    if not (isinstance(rate_hz, (int, float)) and math.isfinite(rate_hz) and rate_hz > 0):
        raise InputError(f"keyframe rate must be a positive number of Hz, got {rate_hz!r}")
    step = 1.0 / rate_hz
    keep = [0]
    for i in range(1, len(times)):
        # the tolerance absorbs timestamp jitter (KITTI's 10 Hz is 0.1036 s +- a few ms)
        if times[i] - times[keep[-1]] >= step - 0.02 * step:
            keep.append(i)
    return np.asarray(keep, dtype=int)


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
        if not (math.isfinite(self.clearance_m) and self.clearance_m >= 0):
            raise InputError(f"landmark model: clearance_m must be >= 0, got {self.clearance_m!r}")


def generate_landmarks(route: Trajectory, model: LandmarkModel = LandmarkModel(), seed: int = 0) -> np.ndarray:
    """Synthetic landmarks along ``route`` (use the full-rate route, not keyframes).

    Returns:
        (M, 2) positions [m], deterministic for a given route, model and seed.
    """
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
    side = rng.choice([-1.0, 1.0], n)
    off = rng.uniform(*model.far_offset_m, n)
    out.append(p + (side * off)[:, None] * nrm)
    lm = np.concatenate(out)
    if model.clearance_m > 0 and len(lm):
        dist, _ = cKDTree(_densify(xy, 0.5)).query(lm)
        lm = lm[dist >= model.clearance_m]
    return lm


def _densify(xy: np.ndarray, step: float) -> np.ndarray:
    """Points along the polyline at most ``step`` apart (for distance-to-route queries)."""
    pts = [xy[:1]]
    for a, b in zip(xy[:-1], xy[1:]):
        n = max(1, int(math.ceil(np.hypot(*(b - a)) / step)))
        t = np.arange(1, n + 1)[:, None] / n
        pts.append(a + t * (b - a))
    return np.concatenate(pts)


def read_landmarks_csv(path: str | Path) -> np.ndarray:
    """Read landmarks from a CSV of ``x,y`` rows [m] (an optional header line ``x,y``; blank lines and
    ``#`` comments are skipped).

    Raises:
        ScenarioError: missing file, a row without two finite numbers (names the line), no landmark.
    """
    path = Path(path)
    rows = []
    header_allowed = True  # the header may follow leading comments, but not a data row
    for lineno, line in enumerate(_read_lines(path, "landmark"), start=1):
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        if header_allowed and s.replace(" ", "").lower() == "x,y":
            header_allowed = False
            continue
        header_allowed = False
        parts = [p.strip() for p in s.split(",")]
        if len(parts) != 2:
            raise ScenarioError(path, f"expected 2 comma-separated numbers (x,y), found {len(parts)} fields", lineno)
        rows.append(_parse_row(" ".join(parts), path, lineno, 2, "x,y"))
    if not rows:
        # an empty map would silently make every suite score 0
        raise ScenarioError(path, "landmark file has no landmarks: expected rows of x,y in metres")
    return np.asarray(rows, dtype=float).reshape(-1, 2)


def write_landmarks_csv(path: str | Path, landmarks: np.ndarray) -> Path:
    """Write landmarks as ``x,y`` CSV with a header (atomically)."""
    body = "".join(f"{x:.6f},{y:.6f}\n" for x, y in np.asarray(landmarks, dtype=float).reshape(-1, 2))
    return atomic_write_text(path, "x,y\n" + body)


# ------------------------------------------------------------------------------------- pipeline


@dataclass(frozen=True)
class ScenarioSpec:
    """Everything that defines a scenario, as a user states it (and as results record it).

    Exactly one route source is used: ``poses`` (a KITTI-format file), else ``seq`` (under
    ``kitti_root`` / ``$SENSORSEL_KITTI_ROOT``), else the bundled fixture ``fixture``.
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


def fixture_names() -> list[str]:
    """Names of the bundled fixture scenarios."""
    return sorted(p.stem for p in (fixtures_dir() / "poses").glob("*.txt"))


def load_route(spec: ScenarioSpec = ScenarioSpec()) -> tuple[Trajectory, str, Path | None]:
    """The full-rate route of ``spec``: (route, scenario name, the fixture's landmark CSV or None)."""
    if spec.poses is not None:
        return load_trajectory(spec.poses, spec.times), Path(spec.poses).stem, None
    if spec.seq is not None:
        return load_sequence(resolve_kitti_root(spec.kitti_root), spec.seq), spec.seq, None
    root = fixtures_dir()
    if spec.fixture not in fixture_names():
        raise InputError(f"unknown fixture {spec.fixture!r}; bundled fixtures: {', '.join(fixture_names())}")
    return load_sequence(root, spec.fixture), spec.fixture, root / "landmarks" / f"{spec.fixture}.csv"


def route_landmarks(spec: ScenarioSpec = ScenarioSpec()) -> np.ndarray:
    """Synthetic landmarks along the route of ``spec`` from ``spec.landmark_model`` and
    ``spec.landmark_seed``, always generated (a fixture's bundled CSV and ``spec.landmarks`` are not
    read): the file a user writes once and edits, or passes back with ``--landmarks``.

    Returns:
        (M, 2) positions [m] in the planar frame.
    """
    route, _, _ = load_route(spec)
    return generate_landmarks(route, spec.landmark_model, spec.landmark_seed)


def load_scenario(spec: ScenarioSpec = ScenarioSpec()) -> Scenario:
    """Build a scenario: read the route, take keyframes, read or generate landmarks."""
    route, name, default_landmarks = load_route(spec)
    keyframes = route.select(select_keyframes(route.times, spec.keyframe_rate_hz))
    if len(keyframes) < 2:
        raise InputError(f"route {route.source} gives {len(keyframes)} keyframe(s) at {spec.keyframe_rate_hz} Hz; need at least 2")
    lm_path = spec.landmarks or (str(default_landmarks) if default_landmarks else None)
    if lm_path is not None:
        landmarks = read_landmarks_csv(lm_path)
        source = str(lm_path)
    else:
        landmarks = generate_landmarks(route, spec.landmark_model, spec.landmark_seed)
        source = f"generated (seed {spec.landmark_seed})"
    return Scenario(name, keyframes, landmarks, source, route)
