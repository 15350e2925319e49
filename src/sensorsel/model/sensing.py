"""What each placed sensor sees along the route: its range-bearing measurements and their noise.

A sensor at the car's reference point, facing ``heading + mount_angle``, sees a landmark when the
landmark is at least :data:`MIN_RANGE_M` and at most ``range_m`` away and inside the cone of
half-angle ``fov_rad / 2`` around its facing (boundaries included). Measurements are noise-free (the
truth) here; their noise std comes from the
sensor model, stereo range noise growing with the square of the distance.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from sensorsel.model.angles import wrap_angle
from sensorsel.model.conditions import Condition, SensorEffect, sensor_effect
from sensorsel.model.library import PlacedSensor, SensorLibrary
from sensorsel.model.scenario import Scenario

#: Nearest landmark a sensor measures [m]. A landmark nearer than this to the car's reference point
#: would stand inside the car, and every sensor of Table I has a minimum range of its own (LiDARs and
#: radars ~0.5-1 m, the stereo cameras' nearest depth 0.3-1.5 m). Without it a pole of a real map lying
#: on the route (KITTI's maps have them 0.1 m from a keyframe on 00, 02, 06, 08 and 10) gives a bearing
#: information ~1/r^2 times that of a pole 1 m away: an artifact of the map, scored as information.
MIN_RANGE_M = 1.0

BYTES_PER_MEASUREMENT = 48  # the six 8-byte arrays of SensorObservations
_CHUNK_PAIRS = 1 << 21  # (keyframe, landmark) pairs whose geometry observe() holds at once


@dataclass(frozen=True, eq=False)
class Measurements:
    """Range-bearing measurements of landmarks from keyframes, as parallel arrays of length n: what a
    sensor's observations and the Monte-Carlo solver's combined pairs
    (:class:`sensorsel.simulation.solve.Pairs`) are made of.

    Attributes:
        pose: (n,) keyframe index of each measurement.
        landmark: (n,) landmark index.
        bearing_rad: (n,) bearing relative to the car's heading [rad].
        range_m: (n,) range [m].
        sigma_bearing_rad: (n,) bearing noise std [rad].
        sigma_range_m: (n,) range noise std [m].
    """

    pose: np.ndarray
    landmark: np.ndarray
    bearing_rad: np.ndarray
    range_m: np.ndarray
    sigma_bearing_rad: np.ndarray
    sigma_range_m: np.ndarray

    def __len__(self) -> int:
        return len(self.pose)


@dataclass(frozen=True, eq=False)
class SensorObservations(Measurements):
    """All measurements of one placed sensor along the route (:class:`Measurements`: the true bearings
    and ranges, their noise std).

    Attributes:
        sensor: position of the sensor in the library.
    """

    sensor: int

    @property
    def landmarks_seen(self) -> np.ndarray:
        """Sorted unique landmark indices this sensor measures."""
        return np.unique(self.landmark)


def off_axis(wrapped_bearing_rad: np.ndarray, mount_angle_rad: float) -> np.ndarray:
    """|angle| [rad] in [0, pi] between bearings already wrapped to [-pi, pi) and a sensor's axis.

    The same angle as ``|wrap_angle(bearing - mount)|``, from a subtraction, an absolute value and
    a minimum: :func:`observe` runs it once per sensor over the pairs in range, and the remainder
    in :func:`wrap_angle` made that ~0.15 s of loading KITTI 00 (62 sensors)."""
    axis = float(wrap_angle(np.asarray(mount_angle_rad)))
    d = np.abs(np.asarray(wrapped_bearing_rad) - axis)  # in [0, 2 pi]
    return np.minimum(d, 2.0 * np.pi - d)


def in_cone(sensor: PlacedSensor, bearing_rad: np.ndarray, range_m: np.ndarray) -> np.ndarray:
    """Boolean mask: which (car-relative bearing [rad], range [m]) pairs the sensor sees."""
    m = sensor.model
    ok = (range_m <= m.range_m) & (range_m >= MIN_RANGE_M)
    if m.fov_rad < 2.0 * np.pi:
        off = off_axis(wrap_angle(bearing_rad), sensor.mount_angle_rad)
        # a hair of tolerance so that a landmark exactly on the cone's edge counts as inside
        ok &= off <= 0.5 * m.fov_rad + 1e-12
    return ok


def relative_geometry(scenario: Scenario, rows: slice = slice(None)) -> tuple[np.ndarray, np.ndarray]:
    """Car-relative bearing [rad] and range [m] of every landmark from every keyframe (of ``rows``),
    (K, M) each."""
    p = scenario.keyframes.poses[rows]
    d = scenario.landmarks[None, :, :] - p[:, None, :2]
    rng = np.hypot(d[..., 0], d[..., 1])
    brg = wrap_angle(np.arctan2(d[..., 1], d[..., 0]) - p[:, 2:3])
    return brg, rng


def estimate_measurements(library: SensorLibrary, scenario: Scenario, fov_share: bool = False) -> int:
    """The measurements :func:`observe` would return, computed without the dense geometry: for each
    sensor, the (keyframe, landmark) pairs within its range (an upper bound), times the share of
    the circle its field of view covers with ``fov_share`` (an estimate)."""
    if not scenario.n_landmarks or not len(library):
        return 0
    tree = cKDTree(scenario.landmarks)
    xy = scenario.keyframes.poses[:, :2]
    per_range: dict[float, int] = {}
    total = 0.0
    for sensor in library:
        r = float(sensor.model.range_m)
        if r not in per_range:
            per_range[r] = int(np.sum(tree.query_ball_point(xy, r, return_length=True)))
        total += per_range[r] * (min(1.0, sensor.model.fov_rad / (2.0 * np.pi)) if fov_share else 1.0)
    return int(math.ceil(total))


def observe(library: SensorLibrary, scenario: Scenario) -> tuple[SensorObservations, ...]:
    """The measurements of every sensor of the library along the scenario's keyframes.

    The geometry is computed a block of keyframes at a time (at most about two million
    keyframe-landmark pairs), so memory grows with the measurements, not with keyframes x landmarks.

    Returns:
        One :class:`SensorObservations` per library sensor, in library order. Measurements are
        sorted by (pose, landmark).
    """
    n_k, n_m = scenario.n_poses, scenario.n_landmarks
    step = max(1, _CHUNK_PAIRS // max(1, n_m))
    parts: list[list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]] = [[] for _ in library]
    for start in range(0, n_k, step):
        brg, rng = relative_geometry(scenario, slice(start, start + step))
        brg_flat, rng_flat = brg.ravel(), rng.ravel()
        # the pairs within each distinct range, found once: the cone test (what :func:`in_cone`
        # computes, on these pairs alone) then runs over a few percent of the keyframes x landmarks
        near: dict[float, np.ndarray] = {}
        for i, sensor in enumerate(library):
            m = sensor.model
            reach = float(m.range_m)
            if reach not in near:
                near[reach] = np.flatnonzero((rng_flat <= m.range_m) & (rng_flat >= MIN_RANGE_M))
            at = near[reach]
            if m.fov_rad < 2.0 * np.pi:
                off = off_axis(brg_flat[at], sensor.mount_angle_rad)  # brg_flat is wrapped
                at = at[off <= 0.5 * m.fov_rad + 1e-12]
            k, j = np.divmod(at, n_m)
            parts[i].append((k + start, j, brg_flat[at], rng_flat[at]))
    out = []
    for i, sensor in enumerate(library):
        if parts[i]:
            k, j, b, r = (np.concatenate(a) for a in zip(*parts[i]))
        else:
            k = j = np.zeros(0, dtype=np.intp)
            b = r = np.zeros(0)
        out.append(
            SensorObservations(
                sensor=i,
                pose=k,
                landmark=j,
                bearing_rad=b,
                range_m=r,
                sigma_bearing_rad=np.full(len(k), sensor.model.bearing_sigma()),
                sigma_range_m=sensor.model.range_sigma(r),
            )
        )
    return tuple(out)


def condition_effects(library: SensorLibrary, condition: Condition | None) -> tuple[SensorEffect, ...]:
    """What ``condition`` does to each sensor of the library (its range [m] and noise multipliers),
    in library order, by the library's condition physics (:mod:`sensorsel.model.conditions`)."""
    return tuple(sensor_effect(s.model.type, float(s.model.range_m), condition, library.physics) for s in library)


def apply_condition(
    library: SensorLibrary, observations: tuple[SensorObservations, ...], condition: Condition | None
) -> tuple[SensorObservations, ...]:
    """The measurements under ``condition``, derived from the clear ones (``observations``, what
    :func:`observe` returns for ``library``) without observing again: each sensor keeps the
    measurements within its range under the condition, in the same order, with its noise std
    multiplied by the condition's factors. A sensor the condition leaves alone keeps its very
    arrays (so a neutral condition returns ``observations`` unchanged, bit for bit).

    Because a condition only shrinks ranges and inflates noise, each sensor's measurements are a
    subset of its clear ones, each at most as informative: no suite gains information."""
    if condition is None or condition.neutral:
        return observations
    out = []
    for o, s, e in zip(observations, library, condition_effects(library, condition)):
        if e.neutral_for(float(s.model.range_m)):
            out.append(o)
            continue
        keep = o.range_m <= e.range_m
        out.append(
            SensorObservations(
                sensor=o.sensor,
                pose=o.pose[keep],
                landmark=o.landmark[keep],
                bearing_rad=o.bearing_rad[keep],
                range_m=o.range_m[keep],
                sigma_bearing_rad=o.sigma_bearing_rad[keep] * e.bearing_factor,
                sigma_range_m=o.sigma_range_m[keep] * e.range_factor,
            )
        )
    return tuple(out)
