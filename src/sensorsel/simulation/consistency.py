"""Consistency: the covariance the information matrix predicts, each run's errors and NEES, and bounds.

Each pose's error ``xi_k = truth_k.localCoordinates(estimate_k)`` (GTSAM's tangent space) is compared
with the covariance of the graph linearized at the **ground truth** (closed form, equal to ``gtsam.Marginals``): the
information matrix whose log det is the score, independent of the draw, computed once.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import cho_factor, cho_solve

from sensorsel.information.graph import pose2
from sensorsel.information.linearize import base_information, bearing_range_jacobians
from sensorsel.model.angles import wrap_angle
from sensorsel.simulation.noise import Payload
from sensorsel.simulation.records import RunResult

NEES_CONFIDENCE = 0.95

COVARIANCE_NOTE = (
    "inverse information of the simulated graph (same factors and noise; no landmark prior in SLAM, the map's "
    "in the map model) linearized at the ground truth (equal to gtsam.Marginals there): the information matrix "
    "whose log det is the score, independent of the draw"
)


@dataclass(frozen=True, eq=False)
class Prediction:
    pose_cov: np.ndarray  # (3K, 3K) joint covariance of the poses, tangent space at the truth
    pose_info: np.ndarray  # (3K, 3K) its inverse: the pose information, landmarks eliminated
    pose_block_inv: np.ndarray  # (K, 3, 3) inverses of the per-pose blocks
    landmark_cov: np.ndarray  # (M, 2, 2), NaN for unmeasured landmarks

    def pose_blocks(self) -> np.ndarray:
        """(K, 3, 3) the per-pose diagonal blocks of the covariance."""
        return np.array([self.pose_cov[3 * k : 3 * k + 3, 3 * k : 3 * k + 3] for k in range(len(self.pose_block_inv))])


def predict(p: Payload) -> Prediction:
    """Covariance predicted by the information matrix of the simulated graph linearized at the truth.

    The same factors and noise as each run's graph (first-pose prior, odometry, the kept
    measurements; in the map model a prior of std ``map_sigma_m`` on every measured landmark),
    linearized in closed form (:func:`sensorsel.information.linearize.bearing_range_jacobians` and
    :func:`~sensorsel.information.linearize.base_information`, GTSAM's own Jacobians written out, tested against
    it) and inverted densely: the landmarks' 2×2 blocks are eliminated first (a landmark touches
    only poses), leaving the (3K, 3K) pose information S, whose Cholesky factor gives the joint pose
    covariance S⁻¹; a landmark's covariance is D_j⁻¹ + D_j⁻¹ C_jᵀ S⁻¹ C_j D_j⁻¹. Equal to
    ``gtsam.Marginals`` of the graph at the truth to round-off (tests), without its per-key
    recovery (KITTI 00, the $110,000 greedy suite: 283 s against 0.65 s). Memory: S, S⁻¹ and the
    coupling C are dense, (3K)² and 3K × 2M doubles (KITTI 00: 15 + 13 MB; a 5,000-keyframe route
    with 5,000 landmarks would need ~2 GB each: a sparse C was 2.5x slower on 00, so not used).
    """
    n_poses, n_lm = len(p.poses), len(p.landmarks)
    idx = np.nonzero(p.keep)[0]
    measured = p.measured_landmarks()
    base, _ = base_information(p.poses, n_lm, p.first_pose_sigmas, p.odometry_sigmas, 1.0)
    info = base.toarray()
    kk, jj = p.pose[idx], p.landmark[idx]
    jac = bearing_range_jacobians(p.poses[kk], p.landmarks[jj])
    jac /= np.column_stack([p.sigma_bearing_rad[idx], p.sigma_range_m[idx]])[:, :, None]
    a, b = jac[:, :, :3], jac[:, :, 3:]
    # measured landmark j is column block slot[j] of the coupling
    slot = np.full(n_lm, -1)
    slot[measured] = np.arange(len(measured))
    sj = slot[jj]
    pose_blocks = np.zeros((n_poses, 3, 3))
    np.add.at(pose_blocks, kk, np.einsum("nri,nrj->nij", a, a))
    for i in range(3):
        for j in range(3):
            info[3 * np.arange(n_poses) + i, 3 * np.arange(n_poses) + j] += pose_blocks[:, i, j]
    d = np.zeros((len(measured), 2, 2))
    np.add.at(d, sj, np.einsum("nri,nrj->nij", b, b))
    if p.map_sigma_m is not None:
        d[:, 0, 0] += 1.0 / p.map_sigma_m**2
        d[:, 1, 1] += 1.0 / p.map_sigma_m**2
    coupling = np.zeros((3 * n_poses, len(measured), 2))  # C: pose rows, landmark (slot, axis) columns
    ab = np.einsum("nri,nrj->nij", a, b)  # (n, 3, 2)
    for i in range(3):
        np.add.at(coupling, (3 * kk + i, sj), ab[:, i, :])
    d_inv = np.linalg.inv(d) if len(measured) else d
    w = np.einsum("pmi,mij->pmj", coupling, d_inv).reshape(3 * n_poses, -1)  # C D⁻¹
    schur = info - w @ coupling.reshape(3 * n_poses, -1).T
    schur = 0.5 * (schur + schur.T)
    chol = cho_factor(schur, lower=True)
    cov = cho_solve(chol, np.eye(3 * n_poses))
    cov = 0.5 * (cov + cov.T)
    blocks = np.array([np.linalg.inv(cov[3 * k : 3 * k + 3, 3 * k : 3 * k + 3]) for k in range(n_poses)])
    lcov = np.full((n_lm, 2, 2), np.nan)
    if len(measured):
        sw = (cov @ w).reshape(3 * n_poses, len(measured), 2)
        lcov[measured] = d_inv + np.einsum("pmi,pmj->mij", w.reshape(3 * n_poses, len(measured), 2), sw)
    return Prediction(cov, schur, blocks, lcov)


def rms(a: np.ndarray) -> float:
    """Root mean square of all entries."""
    return float(np.sqrt(np.mean(np.square(a))))


def run_errors(p: Payload, pred: Prediction, run: int, out: dict, measured: np.ndarray) -> RunResult:
    """Run ``run``'s errors against the truth and its NEES, from the numbers a solver returned."""
    est, true = out["poses"], p.poses
    pos_err = np.hypot(*(est[:, :2] - true[:, :2]).T)
    hdg_err = wrap_angle(est[:, 2] - true[:, 2])
    lon_err, lat_err = body_frame_errors(true, est)
    xi = np.array([pose2(t).localCoordinates(pose2(e)) for t, e in zip(true, est)])
    nees = np.einsum("ki,kij,kj->k", xi, pred.pose_block_inv, xi)
    flat = xi.reshape(-1)
    nees_joint = float(flat @ pred.pose_info @ flat) / len(true)
    lm_err = np.hypot(*(out["landmarks"][measured] - p.landmarks[measured]).T) if len(measured) else np.zeros(0)
    dr = out["dead_reckoning"]
    return RunResult(
        run=run,
        position_rmse_m=rms(pos_err),
        heading_rmse_rad=rms(hdg_err),
        landmark_rmse_m=rms(lm_err) if len(lm_err) else None,
        max_position_error_m=float(np.max(pos_err)),
        initial_position_rmse_m=rms(np.hypot(*(dr[:, :2] - true[:, :2]).T)),
        nees_mean=float(np.mean(nees)),
        nees_joint=nees_joint,
        iterations=int(out["iterations"]),
        final_error=float(out["final_error"]),
        position_error_m=tuple(float(v) for v in pos_err),
        heading_error_rad=tuple(float(v) for v in hdg_err),
        poses=tuple((float(a), float(b), float(c)) for a, b, c in est),
        landmarks=tuple((float(a), float(b)) for a, b in out["landmarks"][measured]),
        longitudinal_error_m=tuple(float(v) for v in lon_err),
        lateral_error_m=tuple(float(v) for v in lat_err),
    )


def body_frame_errors(true: np.ndarray, est: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(longitudinal, lateral) position errors [m], each (K,), of estimated poses ``est`` (K, 3)
    against ``true`` (K, 3) (x [m], y [m], heading [rad]), in each true keyframe's own frame:
    R(θ_true)ᵀ (t_est − t_true), x forward (longitudinal), y to the left (lateral).

    The predicted covariance is in Pose2's tangent (Logmap of the relative pose), whose translation
    differs from this one by a factor 1 + O(heading error) (≈ 1e-3 here): the same to first order."""
    c, s = np.cos(true[:, 2]), np.sin(true[:, 2])
    dx, dy = est[:, 0] - true[:, 0], est[:, 1] - true[:, 1]
    return c * dx + s * dy, c * dy - s * dx


def nees_bounds(
    n_runs: int, n_poses: int, dof: int = 3, confidence: float = NEES_CONFIDENCE, *, trace_sq: float | None = None
) -> tuple[float, float]:
    """Two-sided bounds of an average NEES over ``n_runs`` runs of ``n_poses`` terms of ``dof`` each.

    Without ``trace_sq`` the terms are taken as independent: ``N K avg ~ chi2(dof N K)``. With it,
    the per-run sum ``q = sum_k xi_k' P_k^-1 xi_k = xi' A xi`` (A = blockdiag(P_k^-1)) of a Gaussian
    ``xi ~ N(0, P)`` has mean ``dof K`` and variance ``2 trace((A P)^2)`` = ``2 trace_sq``; the sum over
    runs is matched to a scaled chi-square ``c chi2(nu)`` with the same two moments (Welch-
    Satterthwaite). Independent poses give trace_sq = dof K, c = 1: the first case.
    """
    n = n_runs * n_poses
    mean = dof * n
    var = 2.0 * n_runs * (dof * n_poses if trace_sq is None else trace_sq)
    c, nu = var / (2.0 * mean), 2.0 * mean * mean / var
    from scipy.stats import chi2  # here, not at import: scipy.stats alone takes ~0.4 s to import

    lo, hi = c * chi2.ppf([(1 - confidence) / 2, (1 + confidence) / 2], nu) / n
    return float(lo), float(hi)


def correlated_nees_bounds(pred: Prediction, n_runs: int) -> tuple[float, float]:
    """Bounds of the average per-pose NEES that account for the correlation of the poses (trace((A P)^2))."""
    n_poses = len(pred.pose_block_inv)
    inv_blocks = np.zeros_like(pred.pose_cov)
    for k in range(n_poses):
        inv_blocks[3 * k : 3 * k + 3, 3 * k : 3 * k + 3] = pred.pose_block_inv[k]
    ap = inv_blocks @ pred.pose_cov
    return nees_bounds(n_runs, n_poses, trace_sq=float(np.sum(ap * ap.T)))
