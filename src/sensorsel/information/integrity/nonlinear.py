"""The association estimate where the model linearized at the truth fails: a quadrature of the
nonlinear range-bearing model.

Why: the estimate of :mod:`~sensorsel.information.integrity.association` takes the innovations
linearized at the truth, ν_j ≈ d_ij + v − H_j e. In SLAM a landmark first seen by a stereo camera
enters the state with metres of spread at ~9 m; its predicted measurement then moves by a third of its
range and the linear model is wrong by orders of magnitude (KITTI 03's keyframe 3: λ = 208 linearized,
so ~1e-24, where the associator errs 0.4 % of the time). The module's Taylor remainder ρ_j(k) (the
largest whitened remainder of the polar coordinates over the box of k σ of the line-of-sight errors)
says where: a pair is **bent** when the remainder at k = 2 of the candidate or of the measured landmark
exceeds :data:`BENT_SHARE` × √λ_j (the remainder is then not small against the pair's separation).

What: for each bent pair, p_j = P(NIS_j < NIS_i, NIS_j ≤ γ) (the candidate nearer and inside the gate;
a first sighting: P(NIS_j ≤ γ)) by a deterministic quadrature over the joint Gaussian of (the pose's
error in its own frame (3), the measured landmark's error (2), the candidate's error (2), the
measurement noise (2)): a scrambled Sobol set of 2^:data:`SOBOL_LOG2` points with a fixed seed, mapped
through Φ⁻¹. The innovations are the associator's: ν = z − h(x̂, l̂), x̂ the truth retracted by the pose
error to first order (as the simulator's), the bearing wrapped, S at the truth (S = R + H E Hᵀ); a
landmark is a candidate only within CANDIDATE_SCALE r̂ + CANDIDATE_MARGIN_M of x̂, r̂ the measured range
(the associator's reach, the right landmark's too: a stereo camera's range noise can put it out). The
points are the same for every pair and every call and the sums are in a fixed order (no BLAS):
byte-identical results for any threads. The resolution is 2^−SOBOL_LOG2 (3e-5); where the quadrature
sees no wrong point, p_j is the linearized value capped at that resolution.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from scipy.special import ndtr, ndtri

from sensorsel.information.linearize import bearing_range_jacobians

__all__ = [
    "BENT_SHARE",
    "SOBOL_LOG2",
    "bent_pairs",
    "nonlinear_estimate",
    "nonlinear_pair_probabilities",
    "reach_tail_estimate",
]

#: a pair is bent when ρ(k = 2) of either landmark exceeds this share of √λ_j
BENT_SHARE = 0.1
#: the quadrature's size: 2^SOBOL_LOG2 points
SOBOL_LOG2 = 15
_SOBOL_SEED = 20261126
#: the quadrature's stages (log2 of the points used) and the wrong points that end it (relative error ~12 %)
_STAGES = (11, 13, SOBOL_LOG2)
#: a range-noise tail's stages: its probability given the tail is a share, not a rare event
_TAIL_STAGES = (9, 11, 13)
_ENOUGH = 64


@functools.lru_cache(maxsize=1)
def _normal_points() -> np.ndarray:
    """(9, 2^SOBOL_LOG2) the scrambled Sobol points mapped to standard normals, one row per
    dimension (contiguous rows: the quadrature combines them row by row; read-only)."""
    from scipy.stats import qmc  # scipy.stats is slow to import: only where a pair is bent

    u = qmc.Sobol(9, scramble=True, seed=_SOBOL_SEED).random_base2(SOBOL_LOG2)
    out = np.ascontiguousarray(ndtri(np.clip(u, 1e-12, 1.0 - 1e-12)).T)
    out.flags.writeable = False
    return out


def bent_pairs(rho_i: np.ndarray, rho_j: np.ndarray, lam: np.ndarray) -> np.ndarray:
    """(n,) bool: the pairs where the linearization at the truth fails; ``rho_i``, ``rho_j`` (n,) the
    whitened Taylor remainders at k = 2 of the measured landmark and the candidate, ``lam`` (n,) λ_j."""
    return np.maximum(rho_i, rho_j) > BENT_SHARE * np.sqrt(np.maximum(lam, 0.0))


def _cholesky(cov: np.ndarray) -> np.ndarray:
    """A lower factor of the positive semi-definite ``cov`` (a relative jitter where it is singular:
    a landmark tied to the pose)."""
    scale = max(float(np.max(np.diagonal(cov))), 1e-300)
    return np.linalg.cholesky(0.5 * (cov + cov.T) + 1e-12 * scale * np.eye(len(cov)))


def nonlinear_pair_probabilities(
    poses: np.ndarray,
    point_i: np.ndarray,
    point_j: np.ndarray,
    z: np.ndarray,
    noise_sd: np.ndarray,
    cov: np.ndarray,
    right: np.ndarray,
    gate: float,
    reach: tuple[float, float],
    tail: np.ndarray | None = None,
) -> np.ndarray:
    """(n,) p_j of each pair under the nonlinear model (module docstring), or NaN where no point of
    the quadrature errs (below its resolution). With ``tail`` (n,), the probability of each pair
    given that its range noise lies in its lower tail of that probability (where the reach leaves
    the measured landmark out): the range noise's points are drawn from that tail alone.

    The quadrature runs in stages, on the first 2^m points of the Sobol set for m in
    :data:`_STAGES` (each prefix is itself a balanced set): a pair stops at the first stage where it
    has :data:`_ENOUGH` wrong points (a relative error of ~1/√_ENOUGH) or none (below that stage's
    resolution, 2^−m, after the first two), else goes on to the next; all of SOBOL_LOG2 at most.

    Args:
        poses: (n, 3) the truth at each pair's keyframe, x [m], y [m], heading [rad].
        point_i: (n, 2) [m] the measured landmark of each pair.
        point_j: (n, 2) [m] the candidate.
        z: (n, 2) the noise-free measurement (bearing [rad], range [m]).
        noise_sd: (n, 2) its noise std (bearing [rad], range [m]).
        cov: (n, 7, 7) the joint covariance of (pose error in its own frame, l_i's error, l_j's error)
            [m, m, rad, m, ...].
        tail: (n,) in (0, 1]: condition on the range noise below its ``tail`` quantile (default: none).
        right: (n,) bool: the measured landmark is a candidate (else a first sighting).
        gate: γ.
        reach: (scale, margin [m]): the associator's candidates lie within scale × the measured range +
            margin of the estimated pose (``association.CANDIDATE_SCALE``, ``CANDIDATE_MARGIN_M``).
    """
    xi = _normal_points()
    n = len(point_i)
    out = np.full(n, np.nan)
    poses = np.asarray(poses, float)
    jac_i = bearing_range_jacobians(poses, point_i)
    jac_j = bearing_range_jacobians(poses, point_j)
    for p in range(n):
        pose = poses[p]
        c, s = math.cos(pose[2]), math.sin(pose[2])
        # the error of the estimated relative position of a landmark, w = e_l − R(θ) e_xy (world
        # frame), and the heading's error: a linear map of the 7 state errors
        to_w = np.zeros((5, 7))
        to_w[0, 2] = 1.0
        for row, col in ((1, 3), (3, 5)):
            to_w[row : row + 2, col : col + 2] = np.eye(2)
            to_w[row : row + 2, :2] = -np.array([[c, -s], [s, c]])
        # (dθ, w_i, w_j) = A ξ[:7], A the state's factor mapped; the noise v = σ ⊙ ξ[7:]
        a = to_w @ _cholesky(cov[p])
        r = np.diag(noise_sd[p] ** 2)
        sel_j = [0, 1, 2, 5, 6]
        s_inv_j = np.linalg.inv(r + jac_j[p] @ cov[p][np.ix_(sel_j, sel_j)] @ jac_j[p].T)
        s_inv_i = np.linalg.inv(r + jac_i[p] @ cov[p][:5, :5] @ jac_i[p].T)
        hits, done = 0, 0
        for m in _STAGES if tail is None else _TAIL_STAGES:
            block = xi[:, done : 2**m]
            d = _combine(a, block[:7])  # (5, N): dθ, w_i, w_j
            zs = z[p][:, None] + block[7:9] * noise_sd[p][:, None]
            if tail is not None:  # the range noise from its lower tail: Φ⁻¹(tail · Φ(ξ))
                zs[1] = z[p][1] + ndtri(tail[p] * ndtr(block[8])) * noise_sd[p][1]
            # a landmark is a candidate inside the gate and within the reach of the measured range
            reach_m = reach[0] * zs[1] + reach[1]
            nis_j, dist_j = _nis(zs, (point_j[p] - pose[:2])[:, None] + d[3:5], pose[2] + d[0], s_inv_j)
            wrong = (nis_j <= gate) & (dist_j <= reach_m)
            if right[p]:
                nis_i, dist_i = _nis(zs, (point_i[p] - pose[:2])[:, None] + d[1:3], pose[2] + d[0], s_inv_i)
                wrong &= (nis_j < nis_i) | (nis_i > gate) | (dist_i > reach_m)
            hits, done = hits + int(np.count_nonzero(wrong)), 2**m
            # a tail's first stage with no wrong point ends it (t · q < t 2^−9: a small share of the stratum)
            if hits >= _ENOUGH or (hits == 0 and (m >= _STAGES[1] or tail is not None)):
                break
        if hits:
            out[p] = hits / done
    return out


def _combine(a: np.ndarray, xi: np.ndarray) -> np.ndarray:
    """(r, N) A ξ for ``a`` (r, q) and points ``xi`` (q, N): scalar times row, summed in a fixed order
    (no BLAS: the same sums whatever the threads)."""
    out = np.empty((a.shape[0], xi.shape[1]))
    tmp = np.empty(xi.shape[1])
    for r in range(a.shape[0]):
        np.multiply(xi[0], a[r, 0], out=out[r])
        for k in range(1, a.shape[1]):
            np.multiply(xi[k], a[r, k], out=tmp)
            out[r] += tmp
    return out


def _nis(zs: np.ndarray, rel: np.ndarray, heading: np.ndarray, s_inv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(N,) νᵀ S⁻¹ ν of the measurements ``zs`` (2, N) against a landmark at the estimated relative
    position ``rel`` (2, N) [m] (world frame) from a pose of estimated ``heading`` (N,) [rad]:
    ν = z − (atan2(rel) − heading, |rel|), the bearing wrapped; ``s_inv`` (2, 2); and |rel| (N,) [m]."""
    dist = np.hypot(rel[0], rel[1])
    nu_b = (zs[0] - np.arctan2(rel[1], rel[0]) + heading + np.pi) % (2.0 * np.pi) - np.pi
    nu_r = zs[1] - dist
    return s_inv[0, 0] * nu_b**2 + 2.0 * s_inv[0, 1] * nu_b * nu_r + s_inv[1, 1] * nu_r**2, dist


def nonlinear_estimate(
    p: np.ndarray,
    bent: np.ndarray,
    poses: np.ndarray,
    point_i: np.ndarray,
    point_j: np.ndarray,
    z: np.ndarray,
    noise_sd: np.ndarray,
    joint: np.ndarray,
    right: np.ndarray,
    gate: float,
    reach: tuple[float, float],
) -> np.ndarray:
    """(n,) the pairs' estimates ``p`` (n,) with the bent ones (``bent`` (n,) bool) replaced by the
    quadrature's where it resolves them (module docstring). The rest describe the bent pairs only
    (b of them), as :func:`nonlinear_pair_probabilities` takes them: ``poses`` (b, 3), ``point_i``,
    ``point_j`` (b, 2) [m], ``z``, ``noise_sd`` (b, 2), ``joint`` (b, 7, 7), ``right`` (b,)."""
    if not bent.any():
        return p
    at = np.flatnonzero(bent)
    q = nonlinear_pair_probabilities(poses, point_i, point_j, z, noise_sd, joint, right, gate, reach)
    out = p.copy()
    # no point errs: the probability is below the quadrature's resolution, whatever the linearization says
    out[at] = np.where(np.isnan(q), np.minimum(p[at], 2.0**-SOBOL_LOG2), q)
    return out


def reach_tail_estimate(
    p: np.ndarray,
    reach_pairs: np.ndarray,
    tail: np.ndarray,
    poses: np.ndarray,
    point_i: np.ndarray,
    point_j: np.ndarray,
    z: np.ndarray,
    noise_sd: np.ndarray,
    joint: np.ndarray,
    gate: float,
    reach: tuple[float, float],
) -> np.ndarray:
    """(n,) the pairs' estimates ``p`` (n,) with those of ``reach_pairs`` (n,) bool stratified on the
    range noise: where the measured landmark may fall out of the associator's reach (a stereo
    camera's range noise of metres shortens the measured range; the linearized estimate has no
    reach), p_j = (1 − t) p_j + t q_j, t = ``tail`` (b,) the probability of the range noise's lower
    tail that holds every such draw, and q_j the quadrature's probability given that tail (its
    points' range noise drawn from it alone, in the stages :data:`_TAIL_STAGES`, so a tail of
    10⁻³ is resolved by a few hundred points: the plain quadrature would need millions). The
    upper stratum keeps the linearized p_j (the reach leaves no right landmark out there). The
    rest as :func:`nonlinear_estimate`, for the b pairs of ``reach_pairs`` (the measured landmark
    a candidate)."""
    if not reach_pairs.any():
        return p
    at = np.flatnonzero(reach_pairs)
    right = np.ones(len(at), bool)
    q = nonlinear_pair_probabilities(poses, point_i, point_j, z, noise_sd, joint, right, gate, reach, tail)
    out = p.copy()
    out[at] = (1.0 - tail) * p[at] + tail * np.nan_to_num(q, nan=0.0)
    return out
