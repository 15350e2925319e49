"""Consistency: the covariance the information matrix predicts, each run's errors and NEES, and bounds.

Each pose's error ``xi_k = truth_k.localCoordinates(estimate_k)`` (GTSAM's tangent space) is compared
with the covariance of the graph linearized at the **ground truth** (``gtsam.Marginals``): the
information matrix whose log det is the score, independent of the draw, computed once.
"""

from __future__ import annotations

from dataclasses import dataclass

import gtsam
import numpy as np
from gtsam.symbol_shorthand import L, X
from scipy.linalg import cho_factor, cho_solve

from ..graph import pose2
from ..sensing import wrap_angle
from .noise import Payload, truth
from .records import RunResult
from .solve import Noise, build_graph

NEES_CONFIDENCE = 0.95

COVARIANCE_NOTE = (
    "gtsam.Marginals of the simulated graph (same factors and noise, no landmark prior) linearized at the "
    "ground truth: the information matrix whose log det is the score, independent of the draw"
)


@dataclass(frozen=True, eq=False)
class Prediction:
    pose_cov: np.ndarray  # (3K, 3K) joint covariance of the poses, tangent space at the truth
    pose_info_chol: tuple  # scipy cho_factor of pose_cov
    pose_block_inv: np.ndarray  # (K, 3, 3) inverses of the per-pose blocks
    landmark_cov: np.ndarray  # (M, 2, 2), NaN for unmeasured landmarks

    def pose_blocks(self) -> np.ndarray:
        """(K, 3, 3) the per-pose diagonal blocks of the covariance."""
        return np.array([self.pose_cov[3 * k:3 * k + 3, 3 * k:3 * k + 3] for k in range(len(self.pose_block_inv))])


def predict(p: Payload) -> Prediction:
    """Covariance predicted by the information matrix of the graph linearized at the truth."""
    d = truth(p)
    graph = build_graph(p, Noise(p), d)
    values = gtsam.Values()
    n = len(p.poses)
    for k in range(n):
        values.insert(X(k), pose2(p.poses[k]))
    measured = np.unique(p.landmark[p.keep])
    for j in measured:
        values.insert(L(int(j)), gtsam.Point2(*map(float, p.landmarks[j])))
    marginals = gtsam.Marginals(graph, values)
    cov = marginals.jointMarginalCovariance(gtsam.KeyVector([X(k) for k in range(n)])).fullMatrix()
    cov = 0.5 * (cov + cov.T)
    blocks = np.array([np.linalg.inv(cov[3 * k:3 * k + 3, 3 * k:3 * k + 3]) for k in range(n)])
    lcov = np.full((len(p.landmarks), 2, 2), np.nan)
    for j in measured:
        lcov[j] = marginals.marginalCovariance(L(int(j)))
    return Prediction(cov, cho_factor(cov), blocks, lcov)


def rms(a: np.ndarray) -> float:
    """Root mean square of all entries."""
    return float(np.sqrt(np.mean(np.square(a))))


def run_errors(p: Payload, pred: Prediction, run: int, out: dict, measured: np.ndarray) -> RunResult:
    """Run ``run``'s errors against the truth and its NEES, from the numbers a solver returned."""
    est, true = out["poses"], p.poses
    pos_err = np.hypot(*(est[:, :2] - true[:, :2]).T)
    hdg_err = wrap_angle(est[:, 2] - true[:, 2])
    xi = np.array([pose2(t).localCoordinates(pose2(e)) for t, e in zip(true, est)])
    nees = np.einsum("ki,kij,kj->k", xi, pred.pose_block_inv, xi)
    flat = xi.reshape(-1)
    nees_joint = float(flat @ cho_solve(pred.pose_info_chol, flat)) / len(true)
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
    )


def nees_bounds(n_runs: int, n_poses: int, dof: int = 3, confidence: float = NEES_CONFIDENCE, *, trace_sq: float | None = None) -> tuple[float, float]:
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
        inv_blocks[3 * k:3 * k + 3, 3 * k:3 * k + 3] = pred.pose_block_inv[k]
    ap = inv_blocks @ pred.pose_cov
    return nees_bounds(n_runs, n_poses, trace_sq=float(np.sum(ap * ap.T)))
