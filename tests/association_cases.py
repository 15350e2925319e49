"""Hand-placed association cases (tests only): one measurement of a landmark, and the simulator's
associator run on it. The association tests build their cases through these, so each states only
its geometry and noise."""

from __future__ import annotations

import numpy as np
from association_oracle import measure

from sensorsel.information.filtering import KeyframeMeasurements
from sensorsel.simulation.association import KeyframeCase, KeyframeOutcome, Task, associate_keyframe


def one_measurement(
    pose: np.ndarray, point: np.ndarray, sigmas: tuple[float, float], *, keyframe: int = 1
) -> KeyframeMeasurements:
    """Landmark 0 measured at ``point`` (x, y) [m] from ``pose`` (x, y [m], heading [rad]), the truth
    (its noise-free bearing and range), with the std ``sigmas`` (bearing [rad], range [m])."""
    z = measure(pose, point)
    return KeyframeMeasurements(
        keyframe=keyframe,
        sensor=np.array([0]),
        landmark=np.array([0]),
        bearing_rad=np.array([z[0]]),
        range_m=np.array([z[1]]),
        sigma_bearing_rad=np.array([sigmas[0]]),
        sigma_range_m=np.array([sigmas[1]]),
    )


def every_candidate(pose: np.ndarray, points: np.ndarray, meas: KeyframeMeasurements, cov: np.ndarray) -> KeyframeCase:
    """The simulator's case of ``meas`` (landmark 0 measured; every landmark of ``points`` (L, 2) a
    candidate, their errors and the pose's with the joint ``cov`` (3 + 2L, 3 + 2L))."""
    return KeyframeCase(
        keyframe=meas.keyframe,
        pose=pose,
        sensor=meas.sensor,
        landmark=meas.landmark,
        bearing_rad=meas.bearing_rad,
        range_m=meas.range_m,
        sigma_bearing_rad=meas.sigma_bearing_rad,
        sigma_range_m=meas.sigma_range_m,
        candidates=np.arange(len(points)),
        points=points,
        right=np.array([0]),
        covariance=cov,
    )


def simulated(
    pose: np.ndarray,
    points: np.ndarray,
    meas: KeyframeMeasurements,
    cov: np.ndarray,
    *,
    draws: int,
    gate: float,
    seed: int = 5,
) -> KeyframeOutcome:
    """The simulator's associator on :func:`every_candidate`'s case: ``draws`` draws."""
    case = every_candidate(pose, points, meas, cov)
    return associate_keyframe(case, Task(keyframe=meas.keyframe, draws=draws, seed=seed, gate=gate))
