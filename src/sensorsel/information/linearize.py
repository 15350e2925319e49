"""The library's linearization at the ground truth, in closed form (no gtsam): every measurement's
Jacobian and the base graph's information, what the fast engine starts from.

The Jacobians are GTSAM's own (``BearingRangeFactor2D``, ``PriorFactorPose2``,
``BetweenFactorPose2``, ``PriorFactorPoint2`` at the truth, where every error is 0), written out:
tests check them against GTSAM's linearization of the factors :mod:`sensorsel.information.graph` builds. Why
not GTSAM here: building ~160k factors from Python was most of the fast engine's setup on KITTI 00,
and without gtsam a command that only selects (greedy, pareto, ...) does not import it (~0.1 s).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from sensorsel.model.problem import Problem


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

    The base graph (prior on the first pose, odometry between consecutive keyframes, a prior on
    every landmark: they put every variable in the graph) by :func:`base_information`; each
    distinct (keyframe, landmark) pair's unit-noise BearingRangeFactor2D Jacobian by
    :func:`bearing_range_jacobians`. Both in closed form, tested against GTSAM's linearization.
    """
    sc = problem.scenario
    n_landmarks = sc.n_landmarks
    obs = problem.observations
    # distinct (pose, landmark) pairs over all sensors, and each measurement's pair
    keys = [np.asarray(o.pose, np.int64) * max(n_landmarks, 1) + np.asarray(o.landmark, np.int64) for o in obs]
    all_keys = np.concatenate(keys) if keys else np.zeros(0, np.int64)
    uniq, inverse = np.unique(all_keys, return_inverse=True)
    bounds = np.cumsum([0] + [len(k) for k in keys])
    sensor_pairs = tuple(inverse[bounds[i] : bounds[i + 1]].astype(np.int64) for i in range(len(keys)))
    pair_pose = (uniq // max(n_landmarks, 1)).astype(np.int64)
    pair_landmark = (uniq % max(n_landmarks, 1)).astype(np.int64)
    s = problem.settings
    base_pose, base_lm = base_information(
        sc.keyframes.poses,
        n_landmarks,
        np.asarray(s.first_pose_sigmas, float),
        np.asarray(s.odometry_sigmas, float),
        float(s.landmark_prior_sigma_m),
    )
    jac = bearing_range_jacobians(sc.keyframes.poses[pair_pose], sc.landmarks[pair_landmark])
    sigmas = tuple(np.column_stack([o.sigma_bearing_rad, o.sigma_range_m]).astype(float) for o in obs)
    return LibraryLinearization(
        pair_pose=pair_pose,
        pair_landmark=pair_landmark,
        pair_jacobian=jac,
        sensor_pairs=sensor_pairs,
        sensor_sigmas=sigmas,
        base_pose_information=base_pose,
        base_landmark_information=base_lm,
    )


def odometry_jacobians(poses: np.ndarray) -> np.ndarray:
    """(K - 1, 3, 3) Jacobian of the error of the odometry factor between keyframes k - 1 and k
    (``BetweenFactorPose2`` measuring the true relative pose) with respect to pose k - 1's tangent,
    at the truth, for ``poses`` (K, 3) (x [m], y [m], heading [rad]). With respect to pose k it is
    the identity.

    GTSAM's ``Pose2::between`` Jacobian (the error's chart adds the identity at 0): with R the
    relative heading and (dx, dy) = t_k − t_(k−1) in the world frame,
    [[−cos R, −sin R, −sin θ_k dx + cos θ_k dy], [sin R, −cos R, −cos θ_k dx − sin θ_k dy], [0, 0, −1]].
    """
    p1, p2 = poses[:-1], poses[1:]
    c1, s1, c2, s2 = np.cos(p1[:, 2]), np.sin(p1[:, 2]), np.cos(p2[:, 2]), np.sin(p2[:, 2])
    c, s = c1 * c2 + s1 * s2, c1 * s2 - s1 * c2  # cos and sin of the relative heading, as GTSAM forms them
    dx, dy = p2[:, 0] - p1[:, 0], p2[:, 1] - p1[:, 1]
    h = np.zeros((len(p1), 3, 3))
    h[:, 0, 0], h[:, 0, 1], h[:, 0, 2] = -c, -s, -s2 * dx + c2 * dy
    h[:, 1, 0], h[:, 1, 1], h[:, 1, 2] = s, -c, -c2 * dx - s2 * dy
    h[:, 2, 2] = -1.0
    return h


def base_information(
    poses: np.ndarray,
    n_landmarks: int,
    first_pose_sigmas: np.ndarray,
    odometry_sigmas: np.ndarray,
    landmark_prior_sigma_m: float,
) -> tuple[sp.csr_matrix, np.ndarray]:
    """The base graph's information at the truth: (pose part (3K, 3K) sparse, both triangles;
    landmark part (M, 2, 2)); the base couples no pose with a landmark.

    Args:
        poses: (K, 3) keyframes (x [m], y [m], heading [rad]).
        n_landmarks: M.
        first_pose_sigmas: (3,) prior std on the first pose's tangent (x, y [m], heading [rad]).
        odometry_sigmas: (3,) std of each odometry step (x, y [m], heading [rad]).
        landmark_prior_sigma_m: std of every landmark's weak prior [m].

    Pose k's prior or odometry term is Jᵀ Λ J with Λ the noise's information: the prior's J is
    the identity; odometry step k's is [H_k, I] on poses (k − 1, k), H_k of :func:`odometry_jacobians`.
    """
    n_poses = len(poses)
    n = 3 * n_poses
    lam = 1.0 / np.asarray(odometry_sigmas, float) ** 2  # (3,) diagonal of Λ
    rows, cols, vals = [], [], []
    blk_r, blk_c = np.meshgrid(np.arange(3), np.arange(3), indexing="ij")

    def add(block_rows: np.ndarray, block_cols: np.ndarray, blocks: np.ndarray) -> None:
        rows.append((3 * block_rows[:, None, None] + blk_r).ravel())
        cols.append((3 * block_cols[:, None, None] + blk_c).ravel())
        vals.append(blocks.ravel())

    if n_poses:
        add(
            np.zeros(1, np.int64), np.zeros(1, np.int64), np.diag(1.0 / np.asarray(first_pose_sigmas, float) ** 2)[None]
        )
    if n_poses > 1:
        h = odometry_jacobians(poses)
        k = np.arange(1, n_poses)
        lh = lam[None, :, None] * h  # Λ H (K - 1, 3, 3)
        add(k - 1, k - 1, np.einsum("kai,kaj->kij", h, lh))  # Hᵀ Λ H
        add(k - 1, k, np.transpose(lh, (0, 2, 1)))  # Hᵀ Λ
        add(k, k - 1, lh)  # Λ H
        add(k, k, np.broadcast_to(np.diag(lam), (n_poses - 1, 3, 3)))
    if rows:
        info = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n))
    else:
        info = sp.csr_matrix((n, n))
    info.sum_duplicates()
    info.eliminate_zeros()
    base_lm = np.zeros((n_landmarks, 2, 2))
    base_lm[:, 0, 0] = base_lm[:, 1, 1] = 1.0 / float(landmark_prior_sigma_m) ** 2
    return info, base_lm


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
