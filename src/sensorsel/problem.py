"""The selection problem: a sensor library, a scenario, the graph's fixed noise, and what each sensor sees.

Built once per (library, scenario) and shared by every evaluator and selector.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from .errors import InputError
from .library import SensorLibrary
from .scenario import Scenario
from .sensing import SensorObservations, observe


@dataclass(frozen=True)
class GraphSettings:
    """The parts of the SLAM factor graph that do not depend on the sensor suite.

    Attributes:
        odometry_sigmas: std of each odometry step between keyframes (x [m], y [m], heading [rad]),
            in the frame of the earlier pose. Default 0.1 m, 0.1 m, 0.01 rad per 1 s keyframe step:
            wheel odometry of about 1% of a ~10 m step and half a degree of heading, a typical
            production car's wheel-speed + yaw-rate odometry (the paper does not state its choice).
        first_pose_sigmas: std of the prior on the first keyframe (anchors the gauge freedom).
        landmark_prior_sigma_m: std of the weak prior on every landmark [m]. It keeps the
            information matrix positive definite; its contribution cancels in the score
            f(S) = log det L(S) - log det L(empty), so an unseen landmark adds exactly 0.
    """

    odometry_sigmas: tuple[float, float, float] = (0.1, 0.1, 0.01)
    first_pose_sigmas: tuple[float, float, float] = (0.01, 0.01, 0.001)
    landmark_prior_sigma_m: float = 100.0

    def __post_init__(self) -> None:
        for name in ("odometry_sigmas", "first_pose_sigmas"):
            v = getattr(self, name)
            if len(v) != 3 or not all(isinstance(s, (int, float)) and math.isfinite(s) and s > 0 for s in v):
                raise InputError(f"graph settings: {name} must be three positive numbers, got {v!r}")
        s = self.landmark_prior_sigma_m
        if not (isinstance(s, (int, float)) and math.isfinite(s) and s > 0):
            raise InputError(f"graph settings: landmark_prior_sigma_m must be positive, got {s!r}")


@dataclass(frozen=True, eq=False)
class Problem:
    """A library on a scenario: the input of every evaluator.

    Attributes:
        library: the placed sensors (positions 0..n-1 are the sensors' handles everywhere).
        scenario: keyframes and landmarks.
        settings: odometry and prior noise.
        observations: what each sensor sees, one entry per library sensor.
    """

    library: SensorLibrary
    scenario: Scenario
    settings: GraphSettings = field(default_factory=GraphSettings)
    observations: tuple[SensorObservations, ...] = ()

    @property
    def n_sensors(self) -> int:
        return len(self.library)


def build_problem(library: SensorLibrary, scenario: Scenario, settings: GraphSettings = GraphSettings()) -> Problem:
    """Compute what every sensor of ``library`` sees along ``scenario`` and bundle it."""
    return Problem(library, scenario, settings, observe(library, scenario))
