"""The GTSAM factor graph of a sensor suite, and the reference score read off R's diagonal.

This module (with :mod:`sensorsel.simulate`) is where gtsam is imported, and the only place factors are built. Following GTSAM's Python
examples: poses are ``X(k)`` (``Pose2``), landmarks ``L(j)`` (``Point2``), each measurement a
``BearingRangeFactor2D``; noise models that do not vary per measurement are built once.

The graph is linearized at the ground truth, so the information matrix is the Fisher information
of the suite and does not depend on any random draw. Elimination (COLAMD ordering, multifrontal
Cholesky: the fast path of the gtsam wheel, see shared notes) gives the Bayes tree of R, and
``logDeterminant()`` returns log|det R| = 1/2 log det L.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable, Sequence

import gtsam
import numpy as np
import scipy.sparse as sp
from gtsam.symbol_shorthand import L, X

from .problem import Problem


# ------------------------------------------------------------------ factor construction
#
# Every factor of the project is built by the functions below: the score's graph (GraphBuilder),
# the library linearization and the Monte-Carlo simulation (sensorsel.simulate) all call them.
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


def bearing_range_factor(k: int, j: int, bearing_rad: float, range_m: float, noise: gtsam.noiseModel.Base) -> gtsam.NonlinearFactor:
    """Landmark j measured from keyframe k at ``bearing_rad`` (in the keyframe's frame), ``range_m``."""
    return gtsam.BearingRangeFactor2D(X(int(k)), L(int(j)), gtsam.Rot2.fromAngle(float(bearing_rad)), float(range_m), noise)


def add_pose_chain(graph: gtsam.NonlinearFactorGraph, first: gtsam.Pose2, steps: Sequence[gtsam.Pose2],
                   prior_noise: gtsam.noiseModel.Base, odometry_noise: gtsam.noiseModel.Base) -> None:
    """Append the first-pose prior at ``first`` and odometry ``steps[k - 1]`` from keyframe k - 1 to k."""
    graph.add(first_pose_prior(first, prior_noise))
    for k, step in enumerate(steps, start=1):
        graph.add(odometry_factor(k, step, odometry_noise))


def add_bearing_range(graph: gtsam.NonlinearFactorGraph, pose: np.ndarray, landmark: np.ndarray, bearing_rad: np.ndarray,
                      range_m: np.ndarray, noise: gtsam.noiseModel.Base | Sequence[gtsam.noiseModel.Base]) -> None:
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
    for k, j, b, r, m in zip(keys_x, keys_l, np.asarray(bearing_rad, float).tolist(), np.asarray(range_m, float).tolist(), models):
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

    def base_graph(self) -> gtsam.NonlinearFactorGraph:
        """Prior on the first pose, odometry between keyframes, weak prior on every landmark."""
        g = gtsam.NonlinearFactorGraph()
        add_pose_chain(g, self._poses[0], truth_steps(self._poses), self._first_prior, self._odometry)
        for j, q in enumerate(self._points):
            g.add(landmark_prior(j, q, self._landmark_prior))
        return g

    def add_sensor(self, graph: gtsam.NonlinearFactorGraph, sensor: int) -> None:
        """Append one BearingRangeFactor2D per measurement of library sensor ``sensor``."""
        obs = self.problem.observations[sensor]
        if len(obs) == 0:
            return
        noise = [self._measurement(sb, sr) for sb, sr in zip(obs.sigma_bearing_rad.tolist(), obs.sigma_range_m.tolist())]
        add_bearing_range(graph, obs.pose, obs.landmark, obs.bearing_rad, obs.range_m, noise)

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
    """Linearize, at the truth, every measurement of the library and the base graph.

    The base graph (prior on the first pose, odometry, landmark priors: they put every variable in
    the graph, which fixes the column layout: L(0..M-1), 2 columns each, then X(0..K-1), 3 each) is
    linearized by GTSAM and read in one ``sparseJacobian_`` call (it drops entries with |value| <=
    1e-12: < 1e-24 relative to the O(1) entries of a row, far below the 1e-9 the engines agree to).
    Each distinct (keyframe, landmark) pair's unit-noise BearingRangeFactor2D Jacobian is computed in
    closed form (:func:`bearing_range_jacobians`, tested against GTSAM's linearization of those
    factors): building ~160k GTSAM factors from Python was most of this function's time on KITTI 00.
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
    base_rows = 3 * n_poses + 2 * n_landmarks  # prior 3 + odometry 3 each + landmark priors 2 each
    n_cols = 2 * n_landmarks + 3 * n_poses
    trip = graph.linearize(builder.values).sparseJacobian_() if graph.size() else np.zeros((3, 0))
    rows = trip[0].astype(np.int64) - 1
    cols = trip[1].astype(np.int64) - 1
    keep = cols < n_cols  # the last column is the right-hand side b (zero at the truth)
    base_pose, base_lm = _base_information(rows[keep], cols[keep], trip[2][keep], base_rows, n_landmarks, n_cols)
    jac = bearing_range_jacobians(sc.keyframes.poses[pair_pose], sc.landmarks[pair_landmark])

    sigmas = tuple(np.column_stack([o.sigma_bearing_rad, o.sigma_range_m]).astype(float) for o in obs)
    return LibraryLinearization(
        pair_pose=pair_pose, pair_landmark=pair_landmark, pair_jacobian=jac, sensor_pairs=sensor_pairs,
        sensor_sigmas=sigmas, base_pose_information=base_pose, base_landmark_information=base_lm,
    )


def bearing_range_jacobians(poses: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(n, 2, 5) Jacobians of [bearing [rad]; range [m]] of landmarks ``points`` (n, 2) [m] seen from
    keyframes ``poses`` (n, 3) (x [m], y [m], heading [rad]), with respect to [the pose's tangent
    (dx, dy [m] in the keyframe's frame, dθ [rad]), the landmark (dx, dy) [m]]: what GTSAM's
    ``BearingRangeFactor2D`` linearizes to at unit noise, in closed form (tested against it to
    1e-12). Why not GTSAM: building one factor per pair from Python took ~0.5 s of the ~0.75 s setup
    on KITTI 00 at 1 Hz (162k pairs), this ~25 ms.

    With p = R(θ)ᵀ (l − t) the landmark in the keyframe's frame and r = |p| (≥ the sensing model's
    minimum range, so never 0): ∂bearing/∂p = (−p_y, p_x) / r², ∂range/∂p = (p_x, p_y) / r;
    ∂p/∂(dx, dy) = −I and ∂p/∂dθ = (p_y, −p_x) (the pose perturbed in its own frame, as GTSAM's
    Pose2 retract); ∂p/∂l = R(θ)ᵀ. The range does not depend on the heading: its dθ entry is 0.
    """
    c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
    wx, wy = points[:, 0] - poses[:, 0], points[:, 1] - poses[:, 1]
    px, py = c * wx + s * wy, c * wy - s * wx
    r2 = px * px + py * py
    r = np.sqrt(r2)
    jac = np.zeros((len(poses), 2, 5))
    for row, (gx, gy) in enumerate(((-py / r2, px / r2), (px / r, py / r))):
        jac[:, row, 0], jac[:, row, 1] = -gx, -gy
        jac[:, row, 3], jac[:, row, 4] = gx * c - gy * s, gx * s + gy * c
    jac[:, 0, 2] = -1.0  # ∂bearing/∂dθ = (−p_y, p_x) · (p_y, −p_x) / r² = −1
    return jac


def _base_information(rows: np.ndarray, cols: np.ndarray, vals: np.ndarray, base_rows: int, n_landmarks: int,
                      n_cols: int) -> tuple[sp.csr_matrix, np.ndarray]:
    """The base graph's information from its Jacobian triplets: (pose part (3K, 3K) sparse, landmark
    part (M, 2, 2)); the base couples no pose with a landmark (checked)."""
    jb = sp.csr_matrix((vals, (rows, cols)), shape=(base_rows, n_cols))
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
    return info[ps, ps].tocsr(), base_lm
