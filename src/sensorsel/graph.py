"""The GTSAM factor graph of a sensor suite, and the reference score read off R's diagonal.

This module (with :mod:`sensorsel.simulate`) is where gtsam is imported. Following GTSAM's Python
examples: poses are ``X(k)`` (``Pose2``), landmarks ``L(j)`` (``Point2``), each measurement a
``BearingRangeFactor2D``; noise models that do not vary per measurement are built once.

The graph is linearized at the ground truth, so the information matrix is the Fisher information
of the suite and does not depend on any random draw. Elimination (COLAMD ordering, multifrontal
Cholesky: the fast path of the gtsam wheel, see shared notes) gives the Bayes tree of R, and
``logDeterminant()`` returns log|det R| = 1/2 log det L.
"""

from __future__ import annotations

from typing import Iterable

import gtsam
import numpy as np
from gtsam.symbol_shorthand import L, X

from .problem import Problem


class GraphBuilder:
    """Builds the factor graph of any suite of a problem; fixed noise models are made once."""

    def __init__(self, problem: Problem) -> None:
        self.problem = problem
        s = problem.settings
        self._first_prior = gtsam.noiseModel.Diagonal.Sigmas(np.asarray(s.first_pose_sigmas, float))
        self._odometry = gtsam.noiseModel.Diagonal.Sigmas(np.asarray(s.odometry_sigmas, float))
        self._landmark_prior = gtsam.noiseModel.Isotropic.Sigma(2, s.landmark_prior_sigma_m)
        poses = problem.scenario.keyframes.poses
        self._poses = [gtsam.Pose2(float(x), float(y), float(t)) for x, y, t in poses]
        self._points = [gtsam.Point2(float(x), float(y)) for x, y in problem.scenario.landmarks]
        values = gtsam.Values()
        for k, p in enumerate(self._poses):
            values.insert(X(k), p)
        for j, q in enumerate(self._points):
            values.insert(L(j), q)
        self.values = values

    def base_graph(self) -> gtsam.NonlinearFactorGraph:
        """Prior on the first pose, odometry between keyframes, weak prior on every landmark."""
        g = gtsam.NonlinearFactorGraph()
        g.add(gtsam.PriorFactorPose2(X(0), self._poses[0], self._first_prior))
        for k in range(1, len(self._poses)):
            g.add(gtsam.BetweenFactorPose2(X(k - 1), X(k), self._poses[k - 1].between(self._poses[k]), self._odometry))
        for j, q in enumerate(self._points):
            g.add(gtsam.PriorFactorPoint2(L(j), q, self._landmark_prior))
        return g

    def add_sensor(self, graph: gtsam.NonlinearFactorGraph, sensor: int) -> None:
        """Append one BearingRangeFactor2D per measurement of library sensor ``sensor``."""
        obs = self.problem.observations[sensor]
        if len(obs) == 0:
            return
        constant = np.ptp(obs.sigma_range_m) == 0.0
        shared = gtsam.noiseModel.Diagonal.Sigmas(np.array([obs.sigma_bearing_rad[0], obs.sigma_range_m[0]])) if constant else None
        for k, j, b, r, sb, sr in zip(obs.pose, obs.landmark, obs.bearing_rad, obs.range_m, obs.sigma_bearing_rad, obs.sigma_range_m):
            noise = shared or gtsam.noiseModel.Diagonal.Sigmas(np.array([sb, sr]))
            graph.add(gtsam.BearingRangeFactor2D(X(int(k)), L(int(j)), gtsam.Rot2.fromAngle(float(b)), float(r), noise))

    def graph(self, suite: Iterable[int]) -> gtsam.NonlinearFactorGraph:
        """The full nonlinear factor graph of a suite (library positions)."""
        g = self.base_graph()
        for i in sorted(set(suite)):
            self.add_sensor(g, i)
        return g

    def logdet(self, suite: Iterable[int]) -> float:
        """log det of the information matrix of ``suite`` [nats]: build, linearize, eliminate, 2 log|det R|."""
        lin = self.graph(suite).linearize(self.values)
        return 2.0 * lin.eliminateMultifrontal().logDeterminant()
