"""An independent Monte Carlo of gated nearest-neighbour association (tests only).

It shares no code with sensorsel.information.integrity: it draws the estimate's error from the
predicted joint covariance, perturbs the pose (in its own frame) and the landmarks, draws the
measurement noise, predicts every candidate's (bearing, range) with the nonlinear model, takes
S_j from a finite-difference Jacobian, and runs the gated nearest neighbour with the associator's
reach: a landmark is a candidate only within REACH_SCALE r̂ + REACH_MARGIN_M of the estimated pose,
r̂ the measured range (so a stereo camera's range noise can leave the right landmark out).
"""

from __future__ import annotations

import math

import numpy as np

#: the associator's reach, as stated in the guide (written here, not imported: the oracle shares no
#: code with the engine; a test checks they agree)
REACH_SCALE = 1.25
REACH_MARGIN_M = 5.0


def measure(pose: np.ndarray, point: np.ndarray) -> np.ndarray:
    """(..., 2) bearing [rad] and range [m] of ``point`` (..., 2) from ``pose`` (..., 3)."""
    dx, dy = point[..., 0] - pose[..., 0], point[..., 1] - pose[..., 1]
    c, s = np.cos(pose[..., 2]), np.sin(pose[..., 2])
    return np.stack([np.arctan2(c * dy - s * dx, c * dx + s * dy), np.hypot(dx, dy)], -1)


def retract(pose: np.ndarray, delta: np.ndarray) -> np.ndarray:
    """The pose perturbed by ``delta`` (dx, dy in its own frame, dθ), to first order."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return np.stack(
        [
            pose[0] + c * delta[..., 0] - s * delta[..., 1],
            pose[1] + s * delta[..., 0] + c * delta[..., 1],
            pose[2] + delta[..., 2],
        ],
        -1,
    )


def jacobian(pose: np.ndarray, point: np.ndarray, h: float = 1e-6) -> np.ndarray:
    """(2, 5) central finite differences of measure w.r.t. (pose tangent, landmark)."""
    out = np.zeros((2, 5))
    for k in range(5):
        d = np.zeros(5)
        d[k] = h
        a = measure(retract(pose, d[:3]), point + d[3:])
        b = measure(retract(pose, -d[:3]), point - d[3:])
        diff = a - b
        diff[0] = (diff[0] + np.pi) % (2 * np.pi) - np.pi
        out[:, k] = diff / (2 * h)
    return out


def joint_covariance(state: np.ndarray, cov: np.ndarray, prior_sigma: float, landmarks: list[int]) -> np.ndarray:
    """(3 + 2L, 3 + 2L) covariance of (pose, landmarks...) from a prediction's state (its landmarks in
    the pass's order, not sorted) and prior."""
    n = 3 + 2 * len(landmarks)
    out = np.zeros((n, n))
    idx = [list(range(3))] + [
        [3 + 2 * int(np.flatnonzero(state == j)[0]) + q for q in range(2)] if j in set(state.tolist()) else None
        for j in landmarks
    ]
    out[:3, :3] = cov[:3, :3]
    for a, ia in enumerate(idx[1:]):
        ra = slice(3 + 2 * a, 5 + 2 * a)
        if ia is None:
            out[ra, ra] = prior_sigma**2 * np.eye(2)
            continue
        out[ra, :3] = cov[np.ix_(ia, range(3))]
        out[:3, ra] = out[ra, :3].T
        for b, ib in enumerate(idx[1:]):
            if ib is not None:
                out[ra, 3 + 2 * b : 5 + 2 * b] = cov[np.ix_(ia, ib)]
    return out


def monte_carlo(
    pose,
    points,
    state,
    cov,
    prior_sigma,
    true_landmark,
    sigmas,
    candidates,
    gate,
    *,
    n,
    seed,
    right_is_candidate=True,
    reach=(REACH_SCALE, REACH_MARGIN_M),
):
    """Wrong associations of one measurement of ``true_landmark`` in ``n`` draws: returns (count, n).

    ``candidates`` (landmark indices) are what the associator matches against; the true landmark
    is one of them when ``right_is_candidate`` (map model, or a landmark already in the state).
    ``reach`` (scale, margin [m]): a landmark is a candidate only where its estimated position lies
    within scale × the measured range + margin of the estimated pose; None: every one is."""
    rng = np.random.default_rng(seed)
    cands = [int(j) for j in candidates if j != true_landmark]
    lms = ([true_landmark] if right_is_candidate else []) + cands
    full = joint_covariance(np.asarray(state, np.int64), cov, prior_sigma, lms)
    chol = np.linalg.cholesky(full + 1e-15 * np.eye(len(full)))
    r = np.diag(np.asarray(sigmas, float) ** 2)
    z_true = measure(pose, points[true_landmark])
    s_inv = []
    for a, j in enumerate(lms):
        h = jacobian(pose, points[j])
        sel = list(range(3)) + [3 + 2 * a, 4 + 2 * a]
        s_inv.append(np.linalg.inv(r + h @ full[np.ix_(sel, sel)] @ h.T))
    wrong = 0
    batch = 200_000
    for lo in range(0, n, batch):
        b = min(batch, n - lo)
        e = rng.standard_normal((b, len(full))) @ chol.T
        v = rng.standard_normal((b, 2)) * np.asarray(sigmas, float)
        z = z_true + v
        x_hat = retract(pose, e[:, :3])
        nis = np.empty((b, len(lms)))
        for a, j in enumerate(lms):
            nu = z - measure(x_hat, points[j] + e[:, 3 + 2 * a : 5 + 2 * a])
            nu[:, 0] = (nu[:, 0] + np.pi) % (2 * np.pi) - np.pi
            nis[:, a] = np.einsum("ni,ij,nj->n", nu, s_inv[a], nu)
            if reach is not None:  # out of reach: never taken
                l_hat = points[j] + e[:, 3 + 2 * a : 5 + 2 * a]
                far = np.hypot(*(l_hat - x_hat[:, :2]).T) > reach[0] * z[:, 1] + reach[1]
                nis[far, a] = np.inf
        gated = np.where(nis <= gate, nis, np.inf)
        best = np.argmin(gated, axis=1)
        any_in = np.isfinite(gated.min(axis=1))
        chosen_wrong = any_in & ((best != 0) if right_is_candidate else True)
        wrong += int(chosen_wrong.sum())
    return wrong, n


def clopper_pearson(k: int, n: int, level: float = 0.99) -> tuple[float, float]:
    """The exact two-sided binomial confidence interval at ``level``."""
    from scipy.stats import beta

    a = (1 - level) / 2
    lo = 0.0 if k == 0 else float(beta.ppf(a, k, n - k + 1))
    hi = 1.0 if k == n else float(beta.ppf(1 - a, k + 1, n - k))
    return lo, hi
