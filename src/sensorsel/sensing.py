"""What each placed sensor sees along the route: its range-bearing measurements and their noise.

A sensor at the car's reference point, facing ``heading + mount_angle``, sees a landmark when the
landmark is within ``range_m`` and inside the cone of half-angle ``fov_rad / 2`` around its facing
(boundaries included). Measurements are noise-free (the truth) here; their noise std comes from the
sensor model, stereo range noise growing with the square of the distance.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .library import PlacedSensor, SensorLibrary
from .scenario import Scenario


def wrap_angle(a: np.ndarray) -> np.ndarray:
    """Wrap angles [rad] to [-pi, pi)."""
    return (np.asarray(a) + np.pi) % (2.0 * np.pi) - np.pi


@dataclass(frozen=True, eq=False)
class SensorObservations:
    """All measurements of one placed sensor along the route, as parallel arrays of length n.

    Attributes:
        sensor: position of the sensor in the library.
        pose: (n,) keyframe index of each measurement.
        landmark: (n,) landmark index.
        bearing_rad: (n,) true bearing relative to the car's heading [rad].
        range_m: (n,) true range [m].
        sigma_bearing_rad: (n,) bearing noise std [rad].
        sigma_range_m: (n,) range noise std [m].
    """

    sensor: int
    pose: np.ndarray
    landmark: np.ndarray
    bearing_rad: np.ndarray
    range_m: np.ndarray
    sigma_bearing_rad: np.ndarray
    sigma_range_m: np.ndarray

    def __len__(self) -> int:
        return len(self.pose)

    @property
    def landmarks_seen(self) -> np.ndarray:
        """Sorted unique landmark indices this sensor measures."""
        return np.unique(self.landmark)


def in_cone(sensor: PlacedSensor, bearing_rad: np.ndarray, range_m: np.ndarray) -> np.ndarray:
    """Boolean mask: which (car-relative bearing [rad], range [m]) pairs the sensor sees."""
    m = sensor.model
    ok = (range_m <= m.range_m) & (range_m > 1e-9)
    if m.fov_rad < 2.0 * np.pi:
        off = np.abs(wrap_angle(bearing_rad - sensor.mount_angle_rad))
        # a hair of tolerance so that a landmark exactly on the cone's edge counts as inside
        ok &= off <= 0.5 * m.fov_rad + 1e-12
    return ok


def relative_geometry(scenario: Scenario) -> tuple[np.ndarray, np.ndarray]:
    """Car-relative bearing [rad] and range [m] of every landmark from every keyframe, (K, M) each."""
    p = scenario.keyframes.poses
    d = scenario.landmarks[None, :, :] - p[:, None, :2]
    rng = np.hypot(d[..., 0], d[..., 1])
    brg = wrap_angle(np.arctan2(d[..., 1], d[..., 0]) - p[:, 2:3])
    return brg, rng


def observe(library: SensorLibrary, scenario: Scenario) -> tuple[SensorObservations, ...]:
    """The measurements of every sensor of the library along the scenario's keyframes.

    Returns:
        One :class:`SensorObservations` per library sensor, in library order. Measurements are
        sorted by (pose, landmark).
    """
    brg, rng = relative_geometry(scenario)
    out = []
    for i, sensor in enumerate(library):
        k, l = np.nonzero(in_cone(sensor, brg, rng))
        b, r = brg[k, l], rng[k, l]
        out.append(
            SensorObservations(
                sensor=i,
                pose=k,
                landmark=l,
                bearing_rad=b,
                range_m=r,
                sigma_bearing_rad=np.full(len(k), sensor.model.bearing_sigma()),
                sigma_range_m=sensor.model.range_sigma(r),
            )
        )
    return tuple(out)
