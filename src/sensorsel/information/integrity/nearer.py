"""P(NIS_j < NIS_i) under the model linearized at the truth, with each NIS its own S: the CDF at 0 of
a quadratic form of a Gaussian vector, by the saddlepoint approximation.

Why: the two innovations ν_i (of the measured landmark) and ν_j = ν_i + D (of a candidate) are
jointly Gaussian, x = (ν_i, D) ~ N(m, Σ), m = (0, d), Σ = [[S_i, C_iD], [C_iDᵀ, C_D]]; the candidate
is nearer when

    Q = (ν_i + D)ᵀ S_j⁻¹ (ν_i + D) − ν_iᵀ S_i⁻¹ ν_i = xᵀ A x < 0,   A = [[S_j⁻¹ − S_i⁻¹, S_j⁻¹], [S_j⁻¹, S_j⁻¹]].

A common S̄ = (S_i + S_j)/2 for both NIS makes the boundary a plane; where S_i and S_j differ (a
stereo camera's bearing variance at a near and a far pole differs by 2× through the pose's position
error) that plane is off by factors of 2–3 at 10⁻⁴ (KITTI 03: 1.45·10⁻⁴ against 5.05·10⁻⁵ for a
Monte Carlo of the same linearized model). Here the form is whitened, x = m + L z, z ~ N(0, I₄),
L Lᵀ = Σ, and diagonalised, Lᵀ A L = U Λ Uᵀ, y = Uᵀ z:

    Q = Σ_k (λ_k y_k² + 2 b_k y_k) + c,   b = Uᵀ Lᵀ A m,   c = mᵀ A m,

whose cumulant generating function is K(t) = c t + Σ_k [−½ ln(1 − 2tλ_k) + 2t² b_k² / (1 − 2tλ_k)] on
1 − 2tλ_k > 0. The Lugannani–Rice saddlepoint approximation (Butler, *Saddlepoint Approximations
with Applications*, 2007, §1.2; Kuonen, Biometrika 86(4), 1999, for quadratic forms):
K'(ŝ) = 0, ŵ = sign(ŝ) √(−2K(ŝ)), û = ŝ √K''(ŝ),

    P(Q < 0) ≈ Φ(ŵ) + φ(ŵ) (1/ŵ − 1/û),

accurate in relative terms far into the tails, where Monte Carlo and the probability both are small;
near the mean (|ŵ| small, where it is 0/0) the normal approximation with the form's mean and variance.
Every operation is per pair (stacked LAPACK calls on each 4 × 4 matrix, elementwise arithmetic): a
pair's number is the same alone or in any batch.
"""

from __future__ import annotations

import numpy as np
from scipy.special import ndtr

__all__ = ["p_nearer_form"]

#: bisection steps for the saddlepoint (the bracket halves each step; K is stationary at ŝ, so an
#: error δ in ŝ moves K(ŝ), and the probability, by O(δ²): 2^−50 of the bracket is ample)
_BISECTIONS = 50
#: |ŵ| below which the normal approximation is used (Lugannani–Rice's 0/0 at the mean)
_NEAR_MEAN = 1e-3
#: a Cholesky pivot at most this share of its diagonal entry: Σ taken as singular there (:func:`_root`)
_PIVOT = 1e-10


def p_nearer_form(s_i: np.ndarray, s_j: np.ndarray, c_id: np.ndarray, c_d: np.ndarray, d: np.ndarray) -> np.ndarray:
    """(n,) P(NIS_j < NIS_i) of n pairs (module docstring): ``s_i``, ``s_j`` (n, 2, 2) the innovation
    covariances, ``c_id`` (n, 2, 2) Cov(ν_i, D), ``c_d`` (n, 2, 2) Cov(D), ``d`` (n, 2) E[D]
    (bearing [rad], range [m])."""
    n = len(d)
    if n == 0:
        return np.zeros(0)
    inv_i, inv_j = np.linalg.inv(s_i), np.linalg.inv(s_j)
    a = np.empty((n, 4, 4))
    a[:, :2, :2], a[:, :2, 2:], a[:, 2:, :2], a[:, 2:, 2:] = inv_j - inv_i, inv_j, inv_j, inv_j
    sigma = np.empty((n, 4, 4))
    sigma[:, :2, :2], sigma[:, :2, 2:] = s_i, c_id
    sigma[:, 2:, :2], sigma[:, 2:, 2:] = np.transpose(c_id, (0, 2, 1)), c_d
    sigma = 0.5 * (sigma + np.transpose(sigma, (0, 2, 1)))
    m = np.zeros((n, 4))
    m[:, 2:] = d
    ell = _root(sigma)
    ell_t = np.transpose(ell, (0, 2, 1))
    b_mat = ell_t @ a @ ell
    lam, u = np.linalg.eigh(0.5 * (b_mat + np.transpose(b_mat, (0, 2, 1))))
    am = np.einsum("nij,nj->ni", a, m)
    b = np.einsum("nji,nj->ni", u, np.einsum("nij,nj->ni", ell_t, am))
    c = np.einsum("ni,ni->n", m, am)
    s_hat = _saddlepoint(lam, b, c)
    k, k2 = _cgf(s_hat, lam, b, c, order=0), _cgf(s_hat, lam, b, c, order=2)
    w_hat = np.sign(s_hat) * np.sqrt(np.maximum(-2.0 * k, 0.0))
    u_hat = s_hat * np.sqrt(np.maximum(k2, 0.0))
    mean = c + lam.sum(axis=1)
    var = (2.0 * lam**2 + 4.0 * b**2).sum(axis=1)
    normal = ndtr(-mean / np.sqrt(np.maximum(var, 1e-300)))
    near = (np.abs(w_hat) < _NEAR_MEAN) | (np.abs(u_hat) < _NEAR_MEAN)
    safe_w = np.where(near, 1.0, w_hat)
    safe_u = np.where(near, 1.0, u_hat)
    lr = ndtr(safe_w) + np.exp(-0.5 * safe_w**2) / np.sqrt(2.0 * np.pi) * (1.0 / safe_w - 1.0 / safe_u)
    return np.clip(np.where(near, normal, lr), 0.0, 1.0)


def _root(sigma: np.ndarray) -> np.ndarray:
    """(n, 4, 4) L with L Lᵀ = Σ for each positive semidefinite ``sigma`` (n, 4, 4): its Cholesky factor,
    written out entry by entry over the pairs (a stacked LAPACK call costs a microsecond a 4 × 4
    matrix, a third of this module's time); where a pivot is at most :data:`_PIVOT` of its diagonal
    entry (Σ singular or nearly: D is nearly fixed where the pose is known well), V √w from Σ's
    eigendecomposition instead, negative rounding clipped. Q's distribution, so the probability,
    is the same for any L with L Lᵀ = Σ (Lᵀ A L changes by an orthogonal similarity); each pair's
    factor is its own, the same alone or in a batch."""
    n = len(sigma)
    ell = np.zeros((n, 4, 4))
    good = np.ones(n, bool)
    for j in range(4):
        pivot = sigma[:, j, j] - (ell[:, j, :j] ** 2).sum(axis=1)
        good &= pivot > _PIVOT * sigma[:, j, j]
        ell[:, j, j] = np.sqrt(np.where(good, pivot, 1.0))
        for i in range(j + 1, 4):
            ell[:, i, j] = (sigma[:, i, j] - (ell[:, i, :j] * ell[:, j, :j]).sum(axis=1)) / ell[:, j, j]
    if not good.all():
        w, v = np.linalg.eigh(sigma[~good])
        ell[~good] = v * np.sqrt(np.maximum(w, 0.0))[:, None, :]
    return ell


def _cgf(t: np.ndarray, lam: np.ndarray, b: np.ndarray, c: np.ndarray, *, order: int) -> np.ndarray:
    """(n,) K(t), K'(t) or K''(t) (``order`` 0, 1, 2) of each pair's form at its ``t`` (n,)."""
    tt = t[:, None]
    one = 1.0 - 2.0 * tt * lam  # > 0 on the domain
    if order == 0:
        return c * t + (-0.5 * np.log(one) + 2.0 * tt**2 * b**2 / one).sum(axis=1)
    if order == 1:
        return c + (lam / one + 4.0 * tt * b**2 / one + 4.0 * tt**2 * b**2 * lam / one**2).sum(axis=1)
    square = 2.0 * lam**2 / one**2 + 4.0 * b**2 / one
    return (square + 16.0 * tt * b**2 * lam / one**2 + 16.0 * tt**2 * b**2 * lam**2 / one**3).sum(axis=1)


def _saddlepoint(lam: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """(n,) ŝ with K'(ŝ) = 0 (K' increases on the domain): bisection on a bracket inside the domain
    (1 − 2tλ_k > 0 for every k), widened outward where the domain is unbounded."""
    lam_max, lam_min = lam.max(axis=1), lam.min(axis=1)
    hi = np.where(lam_max > 0, 0.5 / np.where(lam_max > 0, lam_max, 1.0), np.inf)
    lo = np.where(lam_min < 0, 0.5 / np.where(lam_min < 0, lam_min, -1.0), -np.inf)
    # a finite bracket: from the domain's edges pulled in a hair, or doubling out where it is open
    hi = np.where(np.isfinite(hi), hi * (1.0 - 1e-12), 1.0)
    lo = np.where(np.isfinite(lo), lo * (1.0 - 1e-12), -1.0)
    slope = _Slope(lam, b, c)
    for _ in range(60):
        grow_hi = ~(lam_max > 0) & (slope(hi) < 0)
        grow_lo = ~(lam_min < 0) & (slope(lo) > 0)
        if not (grow_hi.any() or grow_lo.any()):
            break
        hi = np.where(grow_hi, 2.0 * hi, hi)
        lo = np.where(grow_lo, 2.0 * lo, lo)
    for _ in range(_BISECTIONS):
        mid = 0.5 * (lo + hi)
        up = slope(mid) > 0
        hi, lo = np.where(up, mid, hi), np.where(up, lo, mid)
    return 0.5 * (lo + hi)


class _Slope:
    """K'(t) of each pair's form at its ``t`` (n,): :func:`_cgf`'s ``order=1``, the same operations
    on the same values (each term's products in its order, the four terms summed from the first),
    on the eigenvalues and b² laid out (4, n) once for the bisection's fifty calls (rows contiguous,
    b² not recomputed)."""

    def __init__(self, lam: np.ndarray, b: np.ndarray, c: np.ndarray) -> None:
        self.lam, self.b2, self.c = np.ascontiguousarray(lam.T), np.ascontiguousarray((b**2).T), c

    def __call__(self, t: np.ndarray) -> np.ndarray:
        one = 1.0 - (2.0 * t) * self.lam
        terms = self.lam / one
        terms += (4.0 * t) * self.b2 / one
        terms += (4.0 * (t * t)) * self.b2 * self.lam / (one * one)
        return self.c + (((terms[0] + terms[1]) + terms[2]) + terms[3])
