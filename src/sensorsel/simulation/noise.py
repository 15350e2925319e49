"""What a run measures, as numbers (the payload sent to workers), and its noisy draw.

Noise is drawn in each factor's own error coordinates, so the factors' noise models are exactly right:
first-pose prior ``truth_0.retract(sigma * z)``, odometry ``truth_{k-1}.between(truth_k).retract(sigma * z)``,
bearing and range truth + sigma * z. Run ``r`` of seed ``s`` draws odometry from
``SeedSequence([s, r, 0])``, the measurements of library sensor ``i`` from ``SeedSequence([s, r, 1, i])``
and, in the map model, the prior map's landmark errors from ``SeedSequence([s, r, 2])`` (a stream of
its own: the odometry and measurement draws are those of the SLAM model).
"""

from __future__ import annotations

from dataclasses import dataclass

import gtsam
import numpy as np

from sensorsel.information.graph import pose2, truth_steps
from sensorsel.model.problem import Problem
from sensorsel.simulation.records import Failure


@dataclass(frozen=True, eq=False)
class Payload:
    """Everything a worker needs, as numbers only (pickled once per worker process).

    Measurements are grouped by sensor (``sensor_slices``) in sorted library order, each group in the
    problem's (pose, landmark) order; ``keep`` masks out those lost to failures.
    """

    poses: np.ndarray  # (K, 3) truth
    landmarks: np.ndarray  # (M, 2) truth
    first_pose_sigmas: np.ndarray  # (3,) scaled
    odometry_sigmas: np.ndarray  # (3,) scaled
    sensors: tuple[int, ...]
    sensor_slices: tuple[tuple[int, int], ...]
    pose: np.ndarray  # (n,) int
    landmark: np.ndarray  # (n,) int
    bearing_rad: np.ndarray  # (n,) truth
    range_m: np.ndarray  # (n,) truth
    sigma_bearing_rad: np.ndarray  # (n,) scaled
    sigma_range_m: np.ndarray  # (n,) scaled
    keep: np.ndarray  # (n,) bool
    solver: str
    seed: int
    map_sigma_m: float | None = None  # the map model: landmarks known to this std [m]; None: SLAM

    def measured_landmarks(self) -> np.ndarray:
        """Sorted indices of the landmarks some kept measurement sees (the estimated ones)."""
        return np.unique(self.landmark[self.keep]).astype(int)

    def order(self) -> np.ndarray:
        """Kept measurements in keyframe order (ties: sensor order), the order a car receives them."""
        idx = np.nonzero(self.keep)[0]
        return idx[np.argsort(self.pose[idx], kind="stable")]


def make_payload(
    problem: Problem,
    suite: tuple[int, ...],
    failures: tuple[Failure, ...],
    noise_scale: float,
    solver: str,
    seed: int,
    map_sigma_m: float | None = None,
) -> Payload:
    """The measurements of ``suite`` (sorted library positions) with sigmas scaled by ``noise_scale``
    (the map's ``map_sigma_m`` [m] is not scaled: it is the map's accuracy, not a sensor's)."""
    s = problem.settings
    parts: dict[str, list[np.ndarray]] = {k: [] for k in ("pose", "landmark", "bearing", "range", "sb", "sr", "keep")}
    slices, at = [], 0
    lib = problem.library
    for i in suite:
        o = problem.observations[i]
        keep = np.ones(len(o), dtype=bool)
        for f in failures:
            if lib[i].id == f.sensor:
                keep &= ~((o.pose >= f.start) & (o.pose < f.stop))
        for key, arr in zip(
            parts,
            (
                o.pose,
                o.landmark,
                o.bearing_rad,
                o.range_m,
                o.sigma_bearing_rad * noise_scale,
                o.sigma_range_m * noise_scale,
                keep,
            ),
        ):
            parts[key].append(np.asarray(arr))
        slices.append((at, at + len(o)))
        at += len(o)

    def cat(key: str, dtype: type) -> np.ndarray:
        return np.concatenate(parts[key]).astype(dtype) if parts[key] else np.zeros(0, dtype)

    return Payload(
        poses=np.array(problem.scenario.keyframes.poses, dtype=float),
        landmarks=np.array(problem.scenario.landmarks, dtype=float),
        first_pose_sigmas=np.asarray(s.first_pose_sigmas, float) * noise_scale,
        odometry_sigmas=np.asarray(s.odometry_sigmas, float) * noise_scale,
        sensors=suite,
        sensor_slices=tuple(slices),
        pose=cat("pose", int),
        landmark=cat("landmark", int),
        bearing_rad=cat("bearing", float),
        range_m=cat("range", float),
        sigma_bearing_rad=cat("sb", float),
        sigma_range_m=cat("sr", float),
        keep=cat("keep", bool),
        solver=solver,
        seed=seed,
        map_sigma_m=map_sigma_m,
    )


@dataclass(frozen=True, eq=False)
class Draw:
    """The values of one run's factors (or the truth's).

    Attributes:
        prior: the first-pose prior's pose.
        odometry: (K - 1) relative poses; ``odometry[k - 1]`` goes from keyframe k - 1 to k.
        bearing_rad, range_m: (n,) every measurement of the payload, failed or not.
        map_points: (M, 2) the prior map's landmark positions [m] (map model), None in SLAM.
    """

    prior: gtsam.Pose2
    odometry: list[gtsam.Pose2]
    bearing_rad: np.ndarray
    range_m: np.ndarray
    map_points: np.ndarray | None = None

    def dead_reckoning(self) -> list[gtsam.Pose2]:
        """The prior's pose composed with the odometry: the poses a car knows before any landmark."""
        dead = [self.prior]
        for step in self.odometry:
            dead.append(dead[-1].compose(step))
        return dead


def draw(p: Payload, run: int) -> Draw:
    """Run ``run``'s noisy first-pose prior, odometry, bearings and ranges (seeded by (seed, run))."""
    z = np.random.default_rng(np.random.SeedSequence([p.seed, run, 0])).standard_normal((len(p.poses), 3))
    truth = [pose2(q) for q in p.poses]
    prior = truth[0].retract(p.first_pose_sigmas * z[0])
    odometry = [step.retract(p.odometry_sigmas * z[k]) for k, step in enumerate(truth_steps(truth), start=1)]
    bearing = p.bearing_rad.copy()
    rng_m = p.range_m.copy()
    for sensor, (a, b) in zip(p.sensors, p.sensor_slices):
        # every measurement of the sensor is drawn, failed or not, so a failure does not shift the others' noise
        w = np.random.default_rng(np.random.SeedSequence([p.seed, run, 1, sensor])).standard_normal((b - a, 2))
        bearing[a:b] += p.sigma_bearing_rad[a:b] * w[:, 0]
        rng_m[a:b] += p.sigma_range_m[a:b] * w[:, 1]
    map_points = None
    if p.map_sigma_m is not None:
        # the prior map of this run: every landmark off by an isotropic error of std map_sigma_m
        e = np.random.default_rng(np.random.SeedSequence([p.seed, run, 2])).standard_normal(p.landmarks.shape)
        map_points = p.landmarks + p.map_sigma_m * e
    return Draw(prior, odometry, bearing, rng_m, map_points)


def truth(p: Payload) -> Draw:
    """The noiseless values: what the factors would hold with perfect sensors (and a perfect map)."""
    poses = [pose2(q) for q in p.poses]
    return Draw(poses[0], truth_steps(poses), p.bearing_rad, p.range_m, None if p.map_sigma_m is None else p.landmarks)
