"""Scenario types (:class:`Trajectory`, :class:`Scenario`), the limits every reader checks, and the
line-level parsing the route and landmark readers share (file, line and value in every error)."""

from __future__ import annotations

import csv
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sensorsel.errors import InputError, ScenarioError
from sensorsel.io.inputs import is_number_text
from sensorsel.model.scenario.frames import Frame

DEFAULT_FRAME_RATE_HZ = 10.0  # assumed for a KITTI pose file without timestamps (KITTI's own rate)
ON_ROAD_M = 3.0  # landmarks closer than this to the route are counted as "on the road" (report only)
# Limits and checks (docs/scenarios.md, "Limits and checks"):
ROTATION_TOL = 1e-3  # max |R R^T - I| and |det R - 1| of a KITTI pose's rotation block (KITTI's own: < 3e-7)
QUATERNION_TOL = 1e-3  # max | |q| - 1 | of a TUM quaternion (a 4-decimal file is within 2e-4)
MAX_COORD_M = 1e8  # max |x|, |y| of a route position or landmark [m]: 2.5 times the Earth's circumference
MAX_LANDMARKS = 2_000_000  # most landmarks the generator makes (estimated from route length / spacing first)


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

    def select(self, indices: np.ndarray) -> Trajectory:
        """The sub-trajectory at these pose indices."""
        idx = np.asarray(indices, dtype=int)
        return Trajectory(self.poses[idx], self.times[idx], self.frames[idx], self.source)


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
            parts.append(
                f"{self.n_on_road} within {self.on_road_m:g} m of the route kept (a clearance drops them: "
                f"--clearance {self.on_road_m:g})"
            )
        return [f"landmarks: {self.source}: {', '.join(parts)}: {self.n_kept} used"]


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
    landmark_report: LandmarkReport | None = None
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


def _refuse_rows(bad: np.ndarray, path: Path, linenos: list[int], why: Callable[[int], str]) -> None:
    """Refuse a file some of whose rows are wrong: ``bad``, the indices of those rows (into
    ``linenos``, their line numbers); a ScenarioError naming the first one's line, ``why(i)`` of it
    and how many such lines the file has. Nothing when ``bad`` is empty."""
    if len(bad):
        i = int(bad[0])
        raise ScenarioError(path, f"{why(i)}; {len(bad)} such line(s) in the file", linenos[i])


def _check_coordinates(xy: np.ndarray, path: Path, linenos: list[int], what: str) -> None:
    """No coordinate beyond :data:`MAX_COORD_M` (a value that is no place on a map)."""
    far = np.flatnonzero(np.abs(np.asarray(xy, dtype=float)).max(axis=1) > MAX_COORD_M)
    _refuse_rows(
        far,
        path,
        linenos,
        lambda i: (
            f"{what} {np.asarray(xy)[i].tolist()!r} is beyond the limit of {MAX_COORD_M:g} m from the origin "
            "(in metres? no map is that large)"
        ),
    )


def _checked_rows(rows: list[list[float]], linenos: list[int], path: Path, empty: str, n_position: int) -> np.ndarray:
    """The rows a route file's reader parsed (time first, then ``n_position`` position columns [m], on
    the lines ``linenos``) as an array (N, columns): refuses a file without rows (``empty``: the
    message), times that do not increase and positions beyond :data:`MAX_COORD_M`, each naming its line."""
    if not rows:
        raise ScenarioError(path, empty)
    a = np.asarray(rows)
    _increasing(a[:, 0].tolist(), path, linenos)
    _check_coordinates(a[:, 1 : 1 + n_position], path, linenos, "position")
    return a


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


def _csv_fields(line: str) -> list[str]:
    return [f.strip() for f in next(csv.reader([line]))]


@dataclass(frozen=True, eq=False)
class RouteFile:
    """A route as a reader returns it.

    Attributes:
        route: the planar trajectory.
        frame: the ground plane and forward axis found for a 3-D file (None: the file is planar, its
            x, y are the planar frame's).
        notes: lines to tell the user (a frame found other than the format's own, an assumed rate,
            headings taken from the direction of travel).
    """

    route: Trajectory
    frame: Frame | None
    notes: tuple[str, ...] = ()
