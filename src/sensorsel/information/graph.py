"""The GTSAM factor graph of a sensor suite, and the reference score read off R's diagonal.

This module (with :mod:`sensorsel.simulation`) is where gtsam is imported, and the only place factors are built
(:mod:`sensorsel.information.linearize` writes their Jacobians at the truth out in closed form, for the
fast engine). Following GTSAM's Python
examples: poses are ``X(k)`` (``Pose2``), landmarks ``L(j)`` (``Point2``), each measurement a
``BearingRangeFactor2D``; noise models that do not vary per measurement are built once.

The graph is linearized at the ground truth, so the information matrix is the Fisher information
of the suite and does not depend on any random draw. Elimination (COLAMD ordering, multifrontal
Cholesky: the fast path of the gtsam wheel, see shared notes) gives the Bayes tree of R, and
``logDeterminant()`` returns log|det R| = 1/2 log det L.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import gtsam
import numpy as np
from gtsam.symbol_shorthand import L, X

from sensorsel.model.problem import Problem

# ------------------------------------------------------------------ factor construction
#
# Every factor of the project is built by the functions below: the score's graph (GraphBuilder),
# the library linearization and the Monte-Carlo simulation (sensorsel.simulation) all call them.
# Keys follow GTSAM's examples: X(k) is keyframe k (Pose2), L(j) landmark j (Point2); because a
# symbol is its character in the top byte plus its index, X(k) == X(0) + k, which the bulk
# measurement loop uses to stay cheap on ~160k factors.


def diagonal(sigmas: Sequence[float] | np.ndarray) -> gtsam.noiseModel.Base:
    """A diagonal Gaussian noise model with these standard deviations."""
    return gtsam.noiseModel.Diagonal.Sigmas(np.asarray(sigmas, dtype=float))


def pose2(pose: Sequence[float] | np.ndarray) -> gtsam.Pose2:
    """``Pose2`` of (x [m], y [m], heading [rad])."""
    x, y, t = pose
    return gtsam.Pose2(float(x), float(y), float(t))


class MeasurementNoise:
    """Diagonal (bearing [rad], range [m]) noise models, one per distinct pair of sigmas (built once)."""

    def __init__(self) -> None:
        self._cache: dict[tuple[float, float], gtsam.noiseModel.Base] = {}

    def __call__(self, sigma_bearing_rad: float, sigma_range_m: float) -> gtsam.noiseModel.Base:
        key = (float(sigma_bearing_rad), float(sigma_range_m))
        model = self._cache.get(key)
        if model is None:
            model = self._cache[key] = diagonal(key)
        return model


def first_pose_prior(pose: gtsam.Pose2, noise: gtsam.noiseModel.Base) -> gtsam.NonlinearFactor:
    """The prior anchoring keyframe 0 at ``pose``."""
    return gtsam.PriorFactorPose2(X(0), pose, noise)


def odometry_factor(k: int, step: gtsam.Pose2, noise: gtsam.noiseModel.Base) -> gtsam.NonlinearFactor:
    """Odometry from keyframe k - 1 to keyframe k: the relative pose ``step`` (in the frame of k - 1)."""
    return gtsam.BetweenFactorPose2(X(k - 1), X(k), step, noise)


def landmark_prior(j: int, point: np.ndarray, noise: gtsam.noiseModel.Base) -> gtsam.NonlinearFactor:
    """A prior on landmark j at ``point`` (a ``Point2``: (x, y) [m])."""
    return gtsam.PriorFactorPoint2(L(j), point, noise)


def bearing_range_factor(
    k: int, j: int, bearing_rad: float, range_m: float, noise: gtsam.noiseModel.Base
) -> gtsam.NonlinearFactor:
    """Landmark j measured from keyframe k at ``bearing_rad`` (in the keyframe's frame), ``range_m``."""
    return gtsam.BearingRangeFactor2D(
        X(int(k)), L(int(j)), gtsam.Rot2.fromAngle(float(bearing_rad)), float(range_m), noise
    )


def add_pose_chain(
    graph: gtsam.NonlinearFactorGraph,
    first: gtsam.Pose2,
    steps: Sequence[gtsam.Pose2],
    prior_noise: gtsam.noiseModel.Base,
    odometry_noise: gtsam.noiseModel.Base,
) -> None:
    """Append the first-pose prior at ``first`` and odometry ``steps[k - 1]`` from keyframe k - 1 to k."""
    graph.add(first_pose_prior(first, prior_noise))
    for k, step in enumerate(steps, start=1):
        graph.add(odometry_factor(k, step, odometry_noise))


def add_bearing_range(
    graph: gtsam.NonlinearFactorGraph,
    pose: np.ndarray,
    landmark: np.ndarray,
    bearing_rad: np.ndarray,
    range_m: np.ndarray,
    noise: gtsam.noiseModel.Base | Sequence[gtsam.noiseModel.Base],
) -> None:
    """Append one ``BearingRangeFactor2D`` per measurement, in the given order (what
    :func:`bearing_range_factor` builds; keys computed as integers, the loop only constructs).

    Args:
        pose, landmark: (n,) keyframe and landmark index of each measurement.
        bearing_rad, range_m: (n,) the measured values.
        noise: one model for all, or one per measurement.
    """
    n = len(pose)
    models = [noise] * n if isinstance(noise, gtsam.noiseModel.Base) else noise
    x_key, l_key = X(0), L(0)
    factor, rot, add = gtsam.BearingRangeFactor2D, gtsam.Rot2.fromAngle, graph.add
    keys_x = (np.asarray(pose, np.int64) + x_key).tolist()
    keys_l = (np.asarray(landmark, np.int64) + l_key).tolist()
    for k, j, b, r, m in zip(
        keys_x, keys_l, np.asarray(bearing_rad, float).tolist(), np.asarray(range_m, float).tolist(), models
    ):
        add(factor(k, j, rot(b), r, m))


def truth_steps(poses: Sequence[gtsam.Pose2]) -> list[gtsam.Pose2]:
    """The exact odometry of a route: ``poses[k - 1].between(poses[k])`` for k = 1 .. K - 1."""
    return [poses[k - 1].between(poses[k]) for k in range(1, len(poses))]


# ------------------------------------------------------------------------ the score's graph


class GraphBuilder:
    """Builds the factor graph of any suite of a problem; fixed noise models are made once."""

    def __init__(self, problem: Problem) -> None:
        self.problem = problem
        s = problem.settings
        self._first_prior = diagonal(s.first_pose_sigmas)
        self._odometry = diagonal(s.odometry_sigmas)
        self._landmark_prior = gtsam.noiseModel.Isotropic.Sigma(2, s.landmark_prior_sigma_m)
        self._measurement = MeasurementNoise()
        self._poses = [pose2(q) for q in problem.scenario.keyframes.poses]
        self._points = [gtsam.Point2(float(x), float(y)) for x, y in problem.scenario.landmarks]
        values = gtsam.Values()
        for k, p in enumerate(self._poses):
            values.insert(X(k), p)
        for j, q in enumerate(self._points):
            values.insert(L(j), q)
        self.values = values

    def base_graph(self, *, landmark_sigma_m: float | None = None) -> gtsam.NonlinearFactorGraph:
        """Prior on the first pose, odometry between keyframes, weak prior on every landmark (or,
        with ``landmark_sigma_m``, a prior of that std [m]: a map known to that accuracy)."""
        g = gtsam.NonlinearFactorGraph()
        add_pose_chain(g, self._poses[0], truth_steps(self._poses), self._first_prior, self._odometry)
        prior = (
            self._landmark_prior
            if landmark_sigma_m is None
            else gtsam.noiseModel.Isotropic.Sigma(2, float(landmark_sigma_m))
        )
        for j, q in enumerate(self._points):
            g.add(landmark_prior(j, q, prior))
        return g

    def add_sensor(self, graph: gtsam.NonlinearFactorGraph, sensor: int) -> None:
        """Append one BearingRangeFactor2D per measurement of library sensor ``sensor``."""
        obs = self.problem.observations[sensor]
        if len(obs) == 0:
            return
        noise = [
            self._measurement(sb, sr) for sb, sr in zip(obs.sigma_bearing_rad.tolist(), obs.sigma_range_m.tolist())
        ]
        add_bearing_range(graph, obs.pose, obs.landmark, obs.bearing_rad, obs.range_m, noise)

    def graph(self, suite: Iterable[int], *, landmark_sigma_m: float | None = None) -> gtsam.NonlinearFactorGraph:
        """The full nonlinear factor graph of a suite (library positions); ``landmark_sigma_m`` as in
        :meth:`base_graph`."""
        g = self.base_graph(landmark_sigma_m=landmark_sigma_m)
        for i in sorted(set(suite)):
            self.add_sensor(g, i)
        return g

    def logdet(self, suite: Iterable[int]) -> float:
        """log det of the information matrix of ``suite`` [nats]: build, linearize, eliminate, 2 log|det R|."""
        lin = self.graph(suite).linearize(self.values)
        return 2.0 * lin.eliminateMultifrontal().logDeterminant()

    def pose_covariances(self, suite: Iterable[int], *, map_sigma_m: float | None = None) -> np.ndarray:
        """(K, 3, 3) marginal covariance of every keyframe's pose by GTSAM's ``Marginals`` (at the
        truth; Pose2's tangent: x forward, y left [m] in the keyframe's frame, θ [rad]).
        ``map_sigma_m``: landmarks known to that std [m] (a prior map), or None (the SLAM graph)."""
        marginals = gtsam.Marginals(self.graph(suite, landmark_sigma_m=map_sigma_m), self.values)
        return np.array([marginals.marginalCovariance(X(k)) for k in range(len(self._poses))])
