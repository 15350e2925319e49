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

from dataclasses import dataclass
from typing import Iterable

import gtsam
import numpy as np
import scipy.sparse as sp
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


@dataclass(frozen=True, eq=False)
class LibraryLinearization:
    """Every measurement a library can make, and the base graph, linearized once at the ground truth.

    Because the linearization point is the truth, the information of any suite is a sum of fixed
    pieces (Λ(S) = Λ₀ + Σ_{s∈S} Λ_s); this holds all of them. Many sensors measure the same
    (keyframe, landmark) pair with different noise, and the Jacobian of a range-bearing measurement
    does not depend on the noise, so each distinct pair is linearized once with unit noise and each
    sensor's measurement is whitened by its own noise (what GTSAM's Diagonal model does: rows
    scaled by 1/σ).

    Variables: pose k is the tangent of Pose2 at the truth (dx, dy [m] in the keyframe's frame,
    dθ [rad]); landmark j is (dx, dy) [m] in the world frame.

    Attributes:
        pair_pose: (P,) keyframe index of each distinct (keyframe, landmark) pair measured by some sensor.
        pair_landmark: (P,) landmark index of each pair, pairs sorted by (keyframe, landmark).
        pair_jacobian: (P, 2, 5) unit-noise Jacobian of [bearing [rad]; range [m]] w.r.t.
            [pose (3), landmark (2)] of each pair's BearingRangeFactor2D, as GTSAM linearizes it.
        sensor_pairs: per library sensor, (n_s,) pair index of each of its measurements (aligned
            with ``problem.observations[s]``).
        sensor_sigmas: per library sensor, (n_s, 2) noise std (bearing [rad], range [m]) of each measurement.
        base_pose_information: (3K, 3K) sparse information of the base graph on the poses
            (first-pose prior and odometry chain); row 3k + i is component i of pose k.
        base_landmark_information: (M, 2, 2) information of the landmark priors.
    """

    pair_pose: np.ndarray
    pair_landmark: np.ndarray
    pair_jacobian: np.ndarray
    sensor_pairs: tuple[np.ndarray, ...]
    sensor_sigmas: tuple[np.ndarray, ...]
    base_pose_information: sp.csr_matrix
    base_landmark_information: np.ndarray

    def whitened_blocks(self, sensor: int) -> tuple[np.ndarray, np.ndarray]:
        """Whitened Jacobian blocks of each measurement of library sensor ``sensor``.

        Returns:
            (A, B): A (n_s, 2, 3) w.r.t. the measuring pose, B (n_s, 2, 2) w.r.t. the landmark;
            rows (bearing, range) divided by their noise std, as in the sensor's own GTSAM factors.
        """
        jac = self.pair_jacobian[self.sensor_pairs[sensor]] / self.sensor_sigmas[sensor][:, :, None]
        return jac[:, :, :3], jac[:, :, 3:]


def linearize_library(problem: Problem) -> LibraryLinearization:
    """Linearize, with GTSAM and at the truth, every measurement of the library and the base graph.

    One graph holds the base factors (prior on the first pose, odometry, landmark priors: they put
    every variable in the graph, which fixes the column layout below) and one unit-noise
    BearingRangeFactor2D per distinct (keyframe, landmark) pair. It is linearized once and read
    in one call with ``sparseJacobian_`` (per-factor reads from Python would dominate on KITTI 00,
    ~160k pairs). Columns follow the sorted keys: L(0..M-1) (2 each), then X(0..K-1) (3 each).
    ``sparseJacobian_`` drops entries with |value| <= 1e-12; such an entry changes the information
    by < 1e-24 relative to the O(1) entries of its row, far below the 1e-9 the engines agree to.
    """
    sc = problem.scenario
    n_poses, n_landmarks = sc.n_poses, sc.n_landmarks
    obs = problem.observations
    # distinct (pose, landmark) pairs over all sensors, and each measurement's pair
    keys = [np.asarray(o.pose, np.int64) * max(n_landmarks, 1) + np.asarray(o.landmark, np.int64) for o in obs]
    all_keys = np.concatenate(keys) if keys else np.zeros(0, np.int64)
    uniq, inverse = np.unique(all_keys, return_inverse=True)
    bounds = np.cumsum([0] + [len(k) for k in keys])
    sensor_pairs = tuple(inverse[bounds[i]:bounds[i + 1]].astype(np.int64) for i in range(len(keys)))
    pair_pose = (uniq // max(n_landmarks, 1)).astype(np.int64)
    pair_landmark = (uniq % max(n_landmarks, 1)).astype(np.int64)

    builder = GraphBuilder(problem)
    graph = builder.base_graph()
    n_base = graph.size()
    base_rows = 3 * n_poses + 2 * n_landmarks  # prior 3 + odometry 3 each + landmark priors 2 each
    unit = gtsam.noiseModel.Unit.Create(2)
    poses, points = sc.keyframes.poses, sc.landmarks
    d = points[pair_landmark] - poses[pair_pose, :2]
    bearing = np.arctan2(d[:, 1], d[:, 0]) - poses[pair_pose, 2]
    rng = np.hypot(d[:, 0], d[:, 1])
    # symbol keys computed as integers (X(k) == x_key + k), the loop does nothing but construct
    x_key, l_key = X(0), L(0)
    factor, rot, add = gtsam.BearingRangeFactor2D, gtsam.Rot2.fromAngle, graph.add
    for k, j, b, r in zip((pair_pose + x_key).tolist(), (pair_landmark + l_key).tolist(), bearing.tolist(), rng.tolist()):
        add(factor(k, j, rot(b), r, unit))
    n_cols = 2 * n_landmarks + 3 * n_poses
    if graph.size() == 0:
        trip = np.zeros((3, 0))
    else:
        trip = graph.linearize(builder.values).sparseJacobian_()
    rows = trip[0].astype(np.int64) - 1
    cols = trip[1].astype(np.int64) - 1
    vals = trip[2]
    keep = cols < n_cols  # the last column is the right-hand side b (zero at the truth)
    rows, cols, vals = rows[keep], cols[keep], vals[keep]
    assert graph.size() - n_base == len(uniq)

    # base graph: pose part and landmark part (the base couples no pose with a landmark)
    is_base = rows < base_rows
    jb = sp.csr_matrix((vals[is_base], (rows[is_base], cols[is_base])), shape=(base_rows, n_cols))
    info = (jb.T @ jb).tocsr()
    lm = slice(0, 2 * n_landmarks)
    ps = slice(2 * n_landmarks, n_cols)
    if info[lm, ps].count_nonzero():
        raise AssertionError("base graph couples poses and landmarks: unexpected column layout")
    two = 2 * np.arange(n_landmarks)
    base_lm = np.zeros((n_landmarks, 2, 2))
    for a in range(2):
        for c in range(2):
            base_lm[:, a, c] = np.asarray(info[two + a, two + c]).ravel()

    # pair rows: 2 per pair; columns mapped to [pose (3), landmark (2)] within the pair
    r, c, v = rows[~is_base] - base_rows, cols[~is_base], vals[~is_base]
    pair = r // 2
    local = np.where(c >= 2 * n_landmarks, c - 2 * n_landmarks - 3 * pair_pose[pair], 3 + c - 2 * pair_landmark[pair])
    ok = np.where(c >= 2 * n_landmarks, (local >= 0) & (local < 3), (local >= 3) & (local < 5))
    if not ok.all():
        raise AssertionError("sparseJacobian_ column layout is not L(0..M-1), X(0..K-1) as assumed")
    jac = np.zeros((len(uniq), 2, 5))
    jac[pair, r % 2, local] = v

    sigmas = tuple(np.column_stack([o.sigma_bearing_rad, o.sigma_range_m]).astype(float) for o in obs)
    return LibraryLinearization(
        pair_pose=pair_pose, pair_landmark=pair_landmark, pair_jacobian=jac, sensor_pairs=sensor_pairs,
        sensor_sigmas=sigmas, base_pose_information=info[ps, ps].tocsr(), base_landmark_information=base_lm,
    )
