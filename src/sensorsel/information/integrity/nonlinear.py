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

The arithmetic over the points is single precision (:data:`QUADRATURE_DTYPE`; the pairs' maps and
S⁻¹ are computed in double, then rounded once): a count of points on either side of the gate and of
the right landmark's NIS only moves where a point lies within ~1e-6 (relative) of such a boundary,
which a count of 2^15 quasi-random points cannot resolve (its own error is 12 % at its stop), and
float32 halves the memory the quadrature streams through (a third of its time on KITTI 00 in SLAM).
Measured against double on KITTI 03 and 00, five suites, both models, with and without the lever:
every number of every record the same; ``tests/test_association_quadrature.py`` checks the counts
against a direct count in double precision on every point.

What it costs, and what shortens it (:func:`nonlinear_estimate`; each keeps the bound untouched and
the result byte-identical for any threads): the points are evaluated stage by stage over the pairs;
the bearing (an arctangent) only where the range innovation alone leaves the candidate inside the
gate (NIS_j ≥ ν_r² / S_rr), the right landmark's innovation only where the candidate is inside, the
state's factor without its zeros: the same wrong points as on every point. A pair needs no point
where its term of the bound, G_j(γ) ≥ P(NIS_j ≤ γ) ≥ p_j, is below the resolution; and a pair's
quadrature ends at the first stage where its estimate is resolved to :data:`KEYFRAME_SHARE` of its
keyframe's estimate (shared among the keyframe's bent pairs): it has no more to say about the
keyframe's estimate. ``tests/test_association_quadrature.py`` checks each against the whole
quadrature and a direct count on every point.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass, fields

import numpy as np
from scipy.special import ndtr, ndtri

from sensorsel.information.linearize import bearing_range_jacobians
from sensorsel.model.angles import wrap_angle

__all__ = [
    "BENT_SHARE",
    "BentPairs",
    "KEYFRAME_SHARE",
    "QUADRATURE_DTYPE",
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
#: the quadrature's stages (log2 of the points used), the wrong points that end it (relative error ~12 %),
#: and the stage from which a pair with none ends (below 2^−13)
_STAGES = (9, 11, 13, SOBOL_LOG2)
_ENOUGH = 64
_QUIET_LOG2 = 13
#: a range-noise tail's stages (:func:`reach_tail_estimate`): its probability given the tail is a
#: share, not a rare event; a stage with no wrong point ends it
_TAIL_STAGES = (9, 11, 13)
#: a bent pair's quadrature ends once its uncertainty is at most this share of its keyframe's estimate,
#: divided among the keyframe's bent pairs (:func:`nonlinear_estimate`)
KEYFRAME_SHARE = 0.1
#: NIS_j ≥ ν_r² / S_rr: points with ν_r² > γ S_rr × this (a margin for rounding) are outside the gate
_RANGE_MARGIN = 1.001
#: the quadrature's pairs × points evaluated at once (memory: a few tens of such arrays)
_BLOCK = 2**16
#: the quadrature's arithmetic over its points (module docstring)
QUADRATURE_DTYPE = np.float32


#: Joe & Kuo's direction numbers (new-joe-kuo-6.21201, criterion D(6)) of dimensions 2 to 9: the degree
#: s of each primitive polynomial, its inner coefficients a (bits, the first the most significant) and
#: the initial m_1 .. m_s (dimension 1: every m_j = 1)
_JOE_KUO = (
    (1, 0, (1,)),
    (2, 1, (1, 3)),
    (3, 1, (1, 3, 1)),
    (3, 2, (1, 1, 1)),
    (4, 1, (1, 1, 3, 3)),
    (4, 4, (1, 3, 5, 13)),
    (5, 2, (1, 1, 5, 5, 17)),
    (5, 4, (1, 1, 5, 5, 5)),
)
_SOBOL_BITS = 30


@functools.lru_cache(maxsize=1)
def _normal_points() -> np.ndarray:
    """(9, 2^SOBOL_LOG2) the scrambled Sobol points mapped to standard normals, one row per
    dimension (contiguous rows: the quadrature combines them row by row; read-only), mapped in double
    and rounded to :data:`QUADRATURE_DTYPE`."""
    u = _scrambled_sobol(9, SOBOL_LOG2, _SOBOL_SEED)
    out = np.ascontiguousarray(ndtri(np.clip(u, 1e-12, 1.0 - 1e-12)).T, dtype=QUADRATURE_DTYPE)
    out.flags.writeable = False
    return out


def _scrambled_sobol(d: int, log2n: int, seed: int) -> np.ndarray:
    """(2^log2n, d) in [0, 1): the first 2^log2n points of the Sobol sequence in d ≤ 9 dimensions
    (Bratley & Fox's recurrence on Joe & Kuo's direction numbers, :data:`_SOBOL_BITS` bits), scrambled
    by Matoušek's linear matrix scramble and a digital shift drawn from ``numpy.random.default_rng(seed)``,
    in Gray-code order: bit for bit the points of ``scipy.stats.qmc.Sobol(d, scramble=True,
    seed=seed).random_base2(log2n)`` (``tests/test_association_quadrature.py``), without importing
    scipy.stats (a quarter of a second, more than a route's quadrature)."""
    bits, one = _SOBOL_BITS, np.uint64(1)
    m = np.ones((d, bits), np.uint64)
    for k, (deg, a, init) in enumerate(_JOE_KUO[: d - 1], start=1):
        m[k, :deg] = init
        for j in range(deg, bits):  # m_j = 2^s m_(j−s) ⊕ m_(j−s) ⊕ (⊕_q 2^q a_q m_(j−q))
            new = m[k, j - deg] ^ (m[k, j - deg] << np.uint64(deg))
            for q in range(1, deg):
                if (a >> (deg - 1 - q)) & 1:
                    new ^= m[k, j - q] << np.uint64(q)
            m[k, j] = new
    v = m << (np.uint64(bits - 1) - np.arange(bits, dtype=np.uint64))  # v_j = m_j / 2^j, in bits bits
    rng = np.random.default_rng(seed)
    shift = rng.integers(0, 2, size=(d, bits), dtype=np.uint32).astype(np.uint64) @ (
        one << np.arange(bits, dtype=np.uint64)
    )
    lower = np.tril(rng.integers(0, 2, size=(d, bits, bits), dtype=np.uint32)).astype(np.uint64)
    lower[:, np.arange(bits), np.arange(bits)] = 1
    rows = lower @ (one << np.arange(bits - 1, -1, -1, dtype=np.uint64))  # (d, bits): row p, its first entry on top
    scrambled = np.zeros_like(v)
    for p in range(bits):  # bit bits−1−p of the scrambled v: the parity of row p and v (GF(2))
        x: np.ndarray = np.bitwise_and(rows[:, p, None], v)
        parity = np.zeros_like(v)
        while x.any():
            parity ^= x & one
            x = np.right_shift(x, one)
        scrambled |= parity << np.uint64(bits - 1 - p)
    i = np.arange(2**log2n, dtype=np.uint64)
    gray = i ^ (i >> one)
    quasi = np.repeat(shift[:, None], len(i), axis=1)
    for k in range(log2n):
        quasi ^= np.where((gray >> np.uint64(k)) & one, scrambled[:, k, None], np.uint64(0))
    return (quasi * (1.0 / 2**bits)).T


def bent_pairs(rho_i: np.ndarray, rho_j: np.ndarray, lam: np.ndarray) -> np.ndarray:
    """(n,) bool: the pairs where the linearization at the truth fails; ``rho_i``, ``rho_j`` (n,) the
    whitened Taylor remainders at k = 2 of the measured landmark and the candidate, ``lam`` (n,) λ_j."""
    return np.maximum(rho_i, rho_j) > BENT_SHARE * np.sqrt(np.maximum(lam, 0.0))


def _cholesky(cov: np.ndarray) -> np.ndarray:
    """(..., q, q) a lower factor of each positive semi-definite matrix of ``cov`` (..., q, q) (a
    relative jitter where it is singular: a landmark tied to the pose)."""
    scale = np.maximum(np.max(np.diagonal(cov, axis1=-2, axis2=-1), axis=-1), 1e-300)[..., None, None]
    q = cov.shape[-1]
    return np.linalg.cholesky(0.5 * (cov + np.swapaxes(cov, -1, -2)) + 1e-12 * scale * np.eye(q))


@dataclass(frozen=True, eq=False)
class BentPairs:
    """The pairs the quadrature integrates (b of them).

    Attributes:
        poses: (b, 3) the truth at each pair's keyframe, x [m], y [m], heading [rad].
        point_i: (b, 2) [m] the measured landmark of each pair.
        point_j: (b, 2) [m] the candidate.
        z: (b, 2) the noise-free measurement (bearing [rad], range [m]).
        noise_sd: (b, 2) its noise std (bearing [rad], range [m]).
        joint: (b, 7, 7) the joint covariance of (pose error in its own frame, l_i's error, l_j's
            error) [m, m, rad, m, ...].
        right: (b,) bool: the measured landmark is a candidate (else a first sighting).
    """

    poses: np.ndarray
    point_i: np.ndarray
    point_j: np.ndarray
    z: np.ndarray
    noise_sd: np.ndarray
    joint: np.ndarray
    right: np.ndarray

    def select(self, mask: np.ndarray) -> BentPairs:
        """The pairs of ``mask`` (b,) bool."""
        return BentPairs(*(getattr(self, f.name)[mask] for f in fields(self)))


def nonlinear_pair_probabilities(pairs: BentPairs, gate: float, reach: tuple[float, float]) -> np.ndarray:
    """(b,) p_j of each of the ``pairs`` under the nonlinear model (module docstring), or NaN where no
    point of the quadrature errs (below its resolution): the whole staged quadrature of every pair, no
    pair resolved early (what :func:`nonlinear_estimate` shortens).

    The quadrature runs in stages, on the first 2^m points of the Sobol set for m in
    :data:`_STAGES` (each prefix is itself a balanced set): a pair stops at the first stage where it
    has :data:`_ENOUGH` wrong points (a relative error of ~1/√_ENOUGH) or none (below that stage's
    resolution, 2^−m, from 2^_QUIET_LOG2 points on), else goes on to the next; all of SOBOL_LOG2 at most.

    Args:
        pairs: the pairs.
        gate: γ.
        reach: (scale, margin [m]): the associator's candidates lie within scale × the measured range +
            margin of the estimated pose (``association.CANDIDATE_SCALE``, ``CANDIDATE_MARGIN_M``).
    """
    hits, done = _staged(pairs, gate, reach, None)
    return np.where(hits > 0, hits / np.maximum(done, 1), np.nan)


def _staged(
    pairs: BentPairs,
    gate: float,
    reach: tuple[float, float],
    resolved: Callable[[np.ndarray, np.ndarray], np.ndarray] | None,
    tail: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """(hits, points) (b,) int: each pair's wrong points and the points of the quadrature it used
    (:func:`nonlinear_pair_probabilities`' stages, the arguments its own), stage by stage over the
    pairs. ``resolved(hits, points)`` → (n,) bool, where given, also ends the pairs it marks, before
    the first stage (points 0) and after each: the pair's estimate is resolved enough. ``tail`` (b,):
    each pair given its range noise in that tail (:func:`reach_tail_estimate`; negative: the upper
    tail of probability −tail), in the stages
    :data:`_TAIL_STAGES`."""
    n = len(pairs.right)
    hits, done = np.zeros(n, np.int64), np.zeros(n, np.int64)
    active = np.ones(n, bool) if resolved is None else ~resolved(hits, done)
    quadrature = _Quadrature(pairs, tail)
    # a pair with no wrong point ends from stage 2^quiet on: a lower tail's at its first stage (its
    # share of a probability the linearized part carries), an upper tail's only at its last (the
    # candidate's whole estimate: none seen means below that stage's resolution, not 0)
    stages: tuple[int, ...] = _STAGES if tail is None else _TAIL_STAGES
    if tail is None:
        quiet = np.full(n, _QUIET_LOG2)
    else:
        quiet = np.where(tail < 0.0, _TAIL_STAGES[-1], _TAIL_STAGES[0])
    lo = 0  # every active pair has used the points before the stage's own
    for m in stages:
        at = np.flatnonzero(active)
        hits[at] += quadrature.wrong(at, lo, 2**m, gate, reach)
        done[at], lo = 2**m, 2**m
        active &= (hits < _ENOUGH) & ((hits > 0) | (m < quiet))
        if resolved is not None and active.any():
            active &= ~resolved(hits, done)
    return hits, done


class _Quadrature:
    """The pairs' quadrature: each pair's map of the state's errors to (dθ, w_i, w_j) and its
    innovations' S⁻¹, for every pair at once (LAPACK and matrix products per matrix: each pair's
    numbers as it alone would have them). ``tail`` (b,): the range noise drawn from each pair's lower
    tail of that probability, Φ⁻¹(tail · Φ(ξ)), or where negative its upper tail of probability −tail,
    −Φ⁻¹(−tail · Φ(ξ)) (:func:`reach_tail_estimate`)."""

    def __init__(self, pairs: BentPairs, tail: np.ndarray | None = None) -> None:
        self.tail = tail
        poses, cov, noise_sd = np.asarray(pairs.poses, float), pairs.joint, pairs.noise_sd
        n = len(poses)
        c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
        # the error of the estimated relative position of a landmark, w = e_l − R(θ) e_xy (world
        # frame), and the heading's error: a linear map of the 7 state errors
        to_w = np.zeros((n, 5, 7))
        to_w[:, 0, 2] = 1.0
        rot = np.stack([np.stack([c, -s], axis=-1), np.stack([s, c], axis=-1)], axis=-2)  # (n, 2, 2)
        for row, col in ((1, 3), (3, 5)):
            to_w[:, row, col] = to_w[:, row + 1, col + 1] = 1.0
            to_w[:, row : row + 2, :2] = -rot
        # (dθ, w_i, w_j) = A ξ[:7], A the state's factor mapped; the noise v = σ ⊙ ξ[7:]. The factor is
        # lower triangular: dθ (its row 2) reads ξ[:3] only, w_i (rows 3-4 and 0-1) ξ[:5] only
        self.a = to_w @ _cholesky(cov)
        r = np.zeros((n, 2, 2))
        r[:, 0, 0], r[:, 1, 1] = noise_sd[:, 0] ** 2, noise_sd[:, 1] ** 2
        jac_i = bearing_range_jacobians(poses, pairs.point_i)
        jac_j = bearing_range_jacobians(poses, pairs.point_j)
        sel_j = [0, 1, 2, 5, 6]
        s_j = r + jac_j @ cov[:, sel_j][:, :, sel_j] @ np.swapaxes(jac_j, 1, 2)
        self.s_inv_j = np.linalg.inv(s_j)
        self.s_inv_i = np.linalg.inv(r + jac_i @ cov[:, :5, :5] @ np.swapaxes(jac_i, 1, 2))
        # NIS_j ≥ ν_r² / S_rr (the least νᵀ S⁻¹ ν with that range component): a point whose range
        # innovation alone puts the candidate out of the gate (a relative margin for rounding) needs no
        # bearing; every other number is computed point by point as it would be on every point
        self.range_gate_m2 = s_j[:, 1, 1] * _RANGE_MARGIN
        self.poses, self.z, self.noise_sd = poses, np.asarray(pairs.z, float), noise_sd
        self.rel_i, self.rel_j = pairs.point_i - poses[:, :2], pairs.point_j - poses[:, :2]
        # computed in double, rounded once to the points' precision (module docstring)
        for name in ("a", "s_inv_j", "s_inv_i", "range_gate_m2", "poses", "z", "noise_sd", "rel_i", "rel_j"):
            setattr(self, name, np.asarray(getattr(self, name), QUADRATURE_DTYPE))
        self.right = np.asarray(pairs.right, bool)

    def wrong(self, at: np.ndarray, lo: int, hi: int, gate: float, reach: tuple[float, float]) -> np.ndarray:
        """(len(at),) the wrong points of each pair of ``at`` (indices) among the Sobol set's points
        ``lo`` to ``hi`` (the arguments :func:`nonlinear_pair_probabilities`' for these pairs): the
        pairs in blocks of at most :data:`_BLOCK` pair-points, each number element by element as the
        pair alone would have it (no sum across pairs or points but the counts)."""
        out = np.zeros(len(at), np.int64)
        step = max(1, _BLOCK // max(hi - lo, 1))
        for s in range(0, len(at), step):
            out[s : s + step] = self._wrong_block(at[s : s + step], lo, hi, gate, reach)
        return out

    def _wrong_block(self, at: np.ndarray, lo: int, hi: int, gate: float, reach: tuple[float, float]) -> np.ndarray:
        """:meth:`wrong` of one block of pairs: (P, N) arrays over its pairs and points, then the
        points that pass the range gate as flat arrays (pair ``k``, point ``n``)."""
        xi, a, z, sd = _normal_points()[:, lo:hi], self.a[at], self.z[at], self.noise_sd[at]
        rel_x, rel_y = _combine(a[:, 3:5], xi[:7], grid=True)
        rel_x += self.rel_j[at, 0, None]
        rel_y += self.rel_j[at, 1, None]
        # √(x² + y²), not hypot (libm's, several times the cost; no overflow at metres)
        dist_j = rel_x * rel_x
        dist_j += rel_y * rel_y
        np.sqrt(dist_j, out=dist_j)
        if self.tail is None:
            noise_r = xi[8]
        else:  # the stratum: the lower tail of probability t, or the upper one where t is negative
            t = self.tail[at, None]  # in double: a tail reaches 1e-250, below single precision's range
            noise_r = ndtri(np.abs(t) * ndtr(xi[8].astype(float))).astype(QUADRATURE_DTYPE)
            noise_r = np.where(t < 0.0, -noise_r, noise_r)
        z_r = z[:, 1, None] + noise_r * sd[:, 1, None]
        # a landmark is a candidate inside the gate and within the reach of the measured range
        reach_m = reach[0] * z_r + reach[1]
        nu_r = z_r - dist_j
        # the bearing where the range alone leaves the candidate in the gate (most points, so on the grid)
        near = (dist_j <= reach_m) & (nu_r * nu_r <= gate * self.range_gate_m2[at, None])
        heading = self.poses[at, 2, None] + _combine(a[:, 0:1, :3], xi[:3], grid=True)[0]
        z_b = z[:, 0, None] + xi[7] * sd[:, 0, None]
        s_j = [self.s_inv_j[at, r, c, None] for r, c in ((0, 0), (0, 1), (1, 1))]
        nis_j = _nis(z_b, rel_x, rel_y, heading, nu_r, *s_j)
        # the points inside the gate, as flat positions in the (P, N) grid (k pair, n point)
        flat = np.flatnonzero(near & (nis_j <= gate))
        k, n = np.divmod(flat, xi.shape[1])
        # a first sighting: any candidate inside the gate takes it
        first = ~self.right[at[k]]
        mine = np.flatnonzero(~first)
        k_i, n_i, f_i = k[mine], n[mine], flat[mine]
        di_x, di_y = _combine(a[:, 1:3, :5], xi[:5, n_i], at=k_i)
        di_x += self.rel_i[at[k_i], 0]
        di_y += self.rel_i[at[k_i], 1]
        dist_i = np.sqrt(di_x * di_x + di_y * di_y)
        s_i = [self.s_inv_i[at, r, c].take(k_i) for r, c in ((0, 0), (0, 1), (1, 1))]
        nis_i = _nis(z_b.take(f_i), di_x, di_y, heading.take(f_i), z_r.take(f_i) - dist_i, *s_i)
        wrong = (nis_j.take(f_i) < nis_i) | (nis_i > gate) | (dist_i > reach_m.take(f_i))
        return np.bincount(k[first], minlength=len(at)) + np.bincount(k_i[wrong], minlength=len(at))


def _combine(a: np.ndarray, xi: np.ndarray, grid: bool = False, at: np.ndarray | None = None) -> np.ndarray:
    """(r, M) A ξ for ``a`` (M, r, q) and points ``xi`` (q, M), one matrix per point; ``grid``: every
    matrix of ``a`` (P, r, q) on every point of ``xi`` (q, N), (r, P, N); ``at`` (M,): point m takes
    matrix ``at[m]`` of ``a`` (P, r, q). Product by product, summed in a fixed order (no BLAS: the
    same sums whatever the threads). The grid by ``np.einsum`` (no ``optimize``: numpy's own loops,
    which sum the products in the order of q, without fused multiply-adds; a third of the time of a
    pass per product over the grid, and the same numbers: ``tests/test_association_quadrature.py``
    checks it against the sums written out). Else a column of ``a`` that is zero throughout (the
    matrices used: the state's factor is lower triangular) is skipped: adding a zero leaves a sum as
    it was."""
    if grid:
        return np.einsum("prq,qn->rpn", a, xi)
    a = np.moveaxis(a, (-2, -1), (0, 1))  # (r, q, M or P)
    if at is not None:
        a = np.ascontiguousarray(a)  # rows of P coefficients, each gathered at the points' matrices
        used = np.zeros(a.shape[2], bool)
        used[at] = True
    shape = (a.shape[0], *xi.shape[1:])
    dtype = np.result_type(a, xi)
    out, term = np.zeros(shape, dtype), np.empty(shape[1:], dtype)
    for r in range(a.shape[0]):
        cols = [q for q in range(a.shape[1]) if (a[r, q] if at is None else a[r, q, used]).any()]
        for q in cols:
            coef = a[r, q] if at is None else a[r, q].take(at)
            np.multiply(coef, xi[q], out=out[r] if q == cols[0] else term)
            if q != cols[0]:
                out[r] += term
    return out


def _nis(
    z_b: np.ndarray,
    rel_x: np.ndarray,
    rel_y: np.ndarray,
    heading: np.ndarray,
    nu_r: np.ndarray,
    s_bb: np.ndarray,
    s_br: np.ndarray,
    s_rr: np.ndarray,
) -> np.ndarray:
    """(N,) νᵀ S⁻¹ ν of the measured bearings ``z_b`` (N,) [rad] against a landmark at the estimated
    relative position (``rel_x``, ``rel_y``) (N,) [m] (world frame) from a pose of estimated
    ``heading`` (N,) [rad], ν = (z_b − (atan2(rel) − heading), ``nu_r``), the bearing wrapped, ``nu_r``
    (N,) the range innovation [m] (the measured range less |rel|); ``s_bb``, ``s_br``, ``s_rr`` the
    entries (0, 0), (0, 1), (1, 1) of each point's S⁻¹ (broadcast against the points)."""
    nu_b = wrap_angle(z_b - np.arctan2(rel_y, rel_x) + heading)
    return s_bb * nu_b**2 + 2.0 * s_br * nu_b * nu_r + s_rr * nu_r**2


def nonlinear_estimate(
    p: np.ndarray,
    bent: np.ndarray,
    keyframe: np.ndarray,
    bound: np.ndarray,
    pairs: BentPairs,
    gate: float,
    reach: tuple[float, float],
) -> np.ndarray:
    """(n,) the pairs' estimates ``p`` (n,) with the bent ones (``bent`` (n,) bool) replaced by the
    quadrature's (module docstring), each pair's keyframe ``keyframe`` (n,) (any labels) and ``bound``
    (n,) its term G_j(γ) of the bound (P(NIS_j ≤ γ) ≤ G_j, so p_j ≤ G_j whatever the quadrature sees).
    ``pairs`` are the bent ones (b of them), as :func:`nonlinear_pair_probabilities` takes them, with
    its ``gate`` and ``reach``.

    A bent pair's quadrature ends early where its estimate is resolved (:func:`_resolution`): its
    uncertainty δ_j is at most the quadrature's resolution 2^−SOBOL_LOG2, or at most
    :data:`KEYFRAME_SHARE` × T_k / n_k (T_k its keyframe's estimate, n_k the keyframe's bent pairs).
    δ_j is, before any point, G_j (0 ≤ p_j ≤ G_j, proved); after h wrong points of N, √max(h, 1)/N
    (a standard error of h/N, the measure of the stages' own stop at 64 wrong points, 12 %; 1/N where none
    errs). Since ∂T_k/∂p_j ≤ 1, the pairs ended early move T_k by at most Σ δ_j ≤ KEYFRAME_SHARE × T_k
    (at a standard error each). Each pair's estimate: min(h/N, G_j) where the quadrature saw a wrong
    point; else min(linearized, G_j, 2^−SOBOL_LOG2) (a pair resolved before
    any point: min(linearized, G_j))."""
    if not bent.any():
        return p
    at = np.flatnonzero(bent)
    g = np.asarray(bound, float)[at]
    done = _resolution(p, bent, keyframe, g)
    hits, points = _staged(pairs, gate, reach, done)
    out = p.copy()
    # no point errs: the probability is below the quadrature's resolution, whatever the linearization says
    quiet = np.minimum(np.minimum(p[at], g), np.where(points > 0, 2.0**-SOBOL_LOG2, np.inf))
    out[at] = np.where(hits > 0, np.minimum(hits / np.maximum(points, 1), g), quiet)
    return out


def _resolution(
    p: np.ndarray,
    sel: np.ndarray,
    keyframe: np.ndarray,
    cap: np.ndarray,
    base: np.ndarray | float = 0.0,
    scale: np.ndarray | float = 1.0,
) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """:func:`_staged`'s ``resolved`` for the pairs of ``sel`` (n,) bool among the pairs' estimates
    ``p`` (n,) of keyframes ``keyframe`` (n,), each selected pair's estimate ``base`` + ``scale`` ×
    min(h/N, ``cap``) (b,) from its quadrature's h wrong points of N (:func:`nonlinear_estimate`:
    base 0, scale 1, cap G_j; :func:`reach_tail_estimate`: a stratum's share). T_k from the
    keyframe's other pairs' estimates and its selected pairs' values so far (a pair without a wrong
    point counts its base only: T_k is not overstated). A pair is resolved when its uncertainty,
    scale × (cap before any point, √max(h, 1)/N after), is at most the quadrature's resolution
    (scale × 2^−SOBOL_LOG2) or KEYFRAME_SHARE × T_k / n_k (n_k the keyframe's selected pairs). Each
    keyframe's pairs alone decide its numbers, in a fixed order: the same for a keyframe alone or in
    a batch."""
    kf = np.unique(keyframe, return_inverse=True)[1].ravel()
    n_kf = int(kf.max()) + 1
    log_other = np.bincount(kf, weights=np.log1p(-np.clip(np.where(sel, 0.0, p), 0.0, 1.0 - 1e-16)), minlength=n_kf)
    kb = kf[sel]
    share = KEYFRAME_SHARE / np.bincount(kb, minlength=n_kf)[kb]

    def resolved(hits: np.ndarray, points: np.ndarray) -> np.ndarray:
        per = np.maximum(points, 1)
        value = base + scale * np.where(hits > 0, np.minimum(hits / per, cap), 0.0)
        t_k = -np.expm1(
            log_other + np.bincount(kb, weights=np.log1p(-np.clip(value, 0.0, 1.0 - 1e-16)), minlength=n_kf)
        )
        spread = scale * np.where(points > 0, np.sqrt(np.maximum(hits, 1)) / per, cap)
        return spread <= np.maximum(scale * 2.0**-SOBOL_LOG2, share * t_k[kb])

    return resolved


def reach_tail_estimate(
    p: np.ndarray,
    reach_pairs: np.ndarray,
    keyframe: np.ndarray,
    tail: np.ndarray,
    upper: np.ndarray,
    pairs: BentPairs,
    gate: float,
    reach: tuple[float, float],
) -> np.ndarray:
    """(n,) the pairs' estimates ``p`` (n,) with those of ``reach_pairs`` (n,) bool stratified on the
    range noise, where the associator's reach, judged at the measured range, changes them (the
    linearized estimate has no reach): q_j the quadrature's probability with the range noise drawn
    from the stratum alone, a tail of probability t = ``tail`` (b,) (its points' noise Φ⁻¹(t Φ(ξ)),
    in the stages :data:`_TAIL_STAGES`, so a tail of 10⁻⁶ is resolved by a few hundred points: the
    plain quadrature would need millions), and

    - p_j = (1 − t) p_j + t q_j where the right landmark may fall out of reach in the lower tail (a
      stereo camera's range noise of metres shortens the measured range; the upper stratum keeps
      the linearized p_j: the reach leaves no right landmark out there);
    - p_j = t q_j for a farther candidate within reach only in the upper tail (``upper`` (b,), the
      noise −Φ⁻¹(t Φ(ξ))): below it the associator never takes it.

    A pair's quadrature ends early where its stratum is resolved against its keyframe's estimate
    (:func:`_resolution`, the pairs' keyframes ``keyframe`` (n,), as :func:`nonlinear_estimate`'s);
    one resolved before any point keeps its linearized p_j (a farther candidate: min(p_j, t)); a farther
    candidate's tail goes on to its last stage while no point errs, and one with none there takes
    min(p_j, t/N).
    ``pairs``: the b pairs of ``reach_pairs``, with ``gate`` and ``reach`` as
    :func:`nonlinear_pair_probabilities` takes them."""
    if not reach_pairs.any():
        return p
    at = np.flatnonzero(reach_pairs)
    lin = np.where(upper, np.minimum(p[at], tail), p[at])
    base = np.where(upper, 0.0, (1.0 - tail) * p[at])
    done = _resolution(p, reach_pairs, keyframe, np.ones(len(at)), base, tail)
    hits, points = _staged(pairs, gate, reach, done, np.where(upper, -tail, tail))
    out = p.copy()
    value = np.where(points > 0, base + tail * (hits / np.maximum(points, 1)), lin)
    # a farther candidate no point of its tail took: below the tail's resolution t / N
    quiet = upper & (points > 0) & (hits == 0)
    out[at] = np.where(quiet, np.minimum(p[at], tail / np.maximum(points, 1)), value)
    return out
