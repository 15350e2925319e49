"""Upper bounds on the candidates' gains from one base suite's covariance.

For a base suite S with information L_S and a candidate c adding Λ_c = Σ_m J_mᵀ R_m⁻¹ J_m (one term
per measurement m of c, J_m its 2 × 5 Jacobian on one pose k and one landmark j):

    gain(c | S) = log det(L_S + Λ_c) − log det L_S ≤ Σ_m [log det(L_S + J_mᵀ R_m⁻¹ J_m) − log det L_S]
                = Σ_m log det(I₂ + R_m^{-1/2} J_m Σ_(k,j) J_mᵀ R_m^{-1/2})  ≤  tr(L_S⁻¹ Λ_c),

the first step because X ↦ log det(L_S + Σ_{m∈X} A_m) is submodular for PSD terms A_m (the same
fact that makes f submodular), the second by the determinant lemma, the third because
log(1 + x) ≤ x on each eigenvalue. Either bound needs only the 5 × 5 joint covariance Σ_(k,j) of
each measured pair's pose and landmark. The per-measurement log det is far tighter when a
measurement alone is informative (a landmark the base hardly sees: its trace term is ~σ_prior²/σ²,
its log det term the log of that); measured on the suburb fixture's greedy run, candidates whose
bound reaches the step's best gain: 113 (trace) and 33 (per measurement) over 13 steps, against 150
for the stale gains alone. With P = Λ_pp − Σ_j W_j D_j⁻¹ W_jᵀ the pose Schur complement
(:mod:`.kernel`) and Σ_pp = P⁻¹:

    Σ_kj = −(Σ_pp W_j)_k D_j⁻¹,     Σ_jj = D_j⁻¹ + D_j⁻¹ W_jᵀ Σ_pp W_j D_j⁻¹,

where W_j (3K × 2) is landmark j's coupling to the keyframes that measure it in S. So each base
suite needs one dense P (assembled as the kernel does), its Cholesky and inverse (dpotri), and per
landmark group a small product of the covariance rows of the keyframes involved with W; every
candidate's bound is then a dot product over its measurements.

The bound is exact arithmetic's; computed, it and a computed gain each carry round-off (the gain
is a difference of two log dets ~1e4 nats apart by ~1e-12 relative). :func:`trace_bounds` returns
the trace; the lazy greedy adds a slack far above that round-off before it relies on it.

Cost: the dense inverse is ~2x a dense Cholesky, so a bound costs ~3-4 dense evaluations of the
base: it pays only when it spares more re-scored candidates than that (measured: docs/speed.md).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from sensorsel.information.evaluators.fast.kernel import Kernel
from sensorsel.information.evaluators.fast.plan import Planner
from sensorsel.information.evaluators.fast.state import BaseState, StateBuilder

#: rows per block when :func:`pose_covariance` mirrors the inverse's triangle
_SYM_BLOCK = 128
#: :func:`pair_quadratics` multiplies spans of covariance rows joining keyframes less than this many
#: apart (gaps of 1/4/8/16/32 keyframes: 112/87/83/79/80 ms for those products on KITTI 00 at 1 Hz)
_ROW_GAP = 16
_KEY_GAP = 4


def pose_covariance(kernel: Kernel, base: BaseState) -> np.ndarray:
    """Σ_pp = P⁻¹ (3K, 3K), symmetric, of the base suite (P its pose Schur complement)."""
    P = kernel.pose_matrix(base.wpl, base.d, base.a, base.layout)
    # the kernel's blocked Cholesky leaves the factor in P's row-major lower triangle, which
    # dpotri inverts in place (GIL released: see Blas.inverse_from_cholesky)
    kernel.blas.cholesky_logdet(P)
    kernel.blas.inverse_from_cholesky(P)
    # the lower triangle holds the inverse: copy it onto the upper one, a block column at a time (a
    # whole transposed add took ~12 ms on the 1,365² matrix of KITTI 00 at 1 Hz, this ~3 ms; the same numbers)
    cov = P
    n = len(cov)
    for i0 in range(0, n, _SYM_BLOCK):
        i1 = min(n, i0 + _SYM_BLOCK)
        cov[i0:i1, i1:] = cov[i1:, i0:i1].T
        blk = cov[i0:i1, i0:i1]
        iu = np.triu_indices(i1 - i0, 1)
        blk[iu] = blk.T[iu]
    return cov


def _runs(keyframes: np.ndarray, gap: int = 1) -> list[tuple[int, int]]:
    """[start, end) positions of the runs of the sorted ``keyframes`` whose neighbours are at most
    ``gap`` keyframes apart (1: runs of consecutive keyframes)."""
    starts = np.flatnonzero(np.r_[True, np.diff(keyframes) > gap])
    return list(zip(starts.tolist(), np.r_[starts[1:], len(keyframes)].tolist()))


def pair_quadratics(
    states: StateBuilder,
    planner: Planner,
    base: BaseState,
    cov: np.ndarray,
    pairs: np.ndarray,
    map_: Callable[..., Iterable[Any]] | None = None,
) -> np.ndarray:
    """(3, n) h_rᵀ Σ_(k,j) h_s of the rows (r, s) = (0, 0), (0, 1), (1, 1) (bearing 0, range 1) of each
    pair of ``pairs`` (n,) under the
    base suite's covariance (``cov`` = :func:`pose_covariance`): the trace bound per unit weight.
    ``map_``: runs the landmark groups' products (default: the builtin ``map``; an executor's ``map``
    runs them on its threads: numpy's gathers and products release the GIL)."""
    pk, pj = states.pair_pose[pairs], states.pair_landmark[pairs]
    n = len(pairs)
    d = base.d
    det = d[0] * d[2] - d[1] ** 2
    dinv = np.stack([d[2] / det, -d[1] / det, d[0] / det])  # (3, M): D⁻¹ entries 00, 01, 11
    G = np.zeros((n, 3, 2))  # (Σ_pp W_j)_k of each pair
    S = np.zeros((states.n_landmarks, 2, 2))  # W_jᵀ Σ_pp W_j of each landmark
    lay = base.layout
    grp_b = planner.group[lay.landmark]
    grp_n = planner.group[pj]
    ob = np.argsort(grp_b, kind="stable")
    on = np.argsort(grp_n, kind="stable")
    gb_sorted, gn_sorted = grp_b[ob], grp_n[on]
    # the base pairs in group order, once: each group's are then contiguous slices (pairs are
    # sorted by keyframe, so within a group too: the sort is stable)
    W = base.wpl.reshape(2, 3, -1).transpose(2, 1, 0)[ob]  # (Pa, 3, 2): W[a, c] of each active pair
    bk_all, bl_all = lay.pose[ob], lay.landmark[ob]
    groups = np.unique(grp_n)
    lo_b, hi_b = np.searchsorted(gb_sorted, groups), np.searchsorted(gb_sorted, groups, side="right")
    lo_n, hi_n = np.searchsorted(gn_sorted, groups), np.searchsorted(gn_sorted, groups, side="right")
    three = np.arange(3)

    def group(b0: int, b1: int, n0: int, n1: int) -> None:
        """G of the group's requested pairs and S of its landmarks (rows and landmarks of no other group)."""
        np_ = on[n0:n1]  # requested pairs of the group
        bk, bl = bk_all[b0:b1], bl_all[b0:b1]  # keyframe (non-decreasing) and landmark of the base pairs
        lms, bcol = np.unique(bl, return_inverse=True)
        first = np.r_[True, bk[1:] != bk[:-1]]
        keys = bk[first]
        # Wg: the group's W on the keyframes of its key spans (keys less than _ROW_GAP apart
        # joined, zero rows in between: fewer, larger products), 3 rows per keyframe, 2 columns
        # per landmark; each (keyframe, landmark) pair is active once, so written once
        key_spans = _runs(keys, _KEY_GAP)
        span_start = np.array([keys[k0] for k0, _ in key_spans])
        span_len = np.array([keys[k1 - 1] + 1 - keys[k0] for k0, k1 in key_spans])
        span_off = np.r_[0, np.cumsum(span_len)[:-1]]
        key_span = np.repeat(np.arange(len(key_spans)), [k1 - k0 for k0, k1 in key_spans])
        key_row = span_off[key_span] + keys - span_start[key_span]  # each key's keyframe row in Wg
        Wg4 = np.zeros((int(span_len.sum()), 3, len(lms), 2))
        Wg4[key_row[np.cumsum(first) - 1], :, bcol, :] = W[b0:b1] + 0.0
        Wg = Wg4.reshape(-1, 2 * len(lms))
        # rows: the keyframes of the requested pairs and of the base pairs (for W_jᵀ Σ W_j)
        rows_k = np.union1d(keys, pk[np_])
        # Z = Σ_pp[rows, keys] @ Wg (3 |rows|, 2 |lms|), by products on views of Σ_pp: one per (span of
        # rows, span of keys), spans joining keyframes less than _ROW_GAP apart (the extra rows of a
        # row span are dropped). Gathering Σ_pp[rows, keys] first was measured 218 against 176 ms
        # for the whole of this function (KITTI 00 at 1 Hz, synthetic map, median of 6)
        Z = np.empty((3 * len(rows_k), Wg.shape[1]))
        for a0, a1 in _runs(rows_k, _ROW_GAP):
            s0, s1 = int(rows_k[a0]), int(rows_k[a1 - 1]) + 1
            span = np.zeros((3 * (s1 - s0), Wg.shape[1]))
            for k0, ln, off in zip(span_start.tolist(), span_len.tolist(), span_off.tolist()):
                span += cov[3 * s0 : 3 * s1, 3 * k0 : 3 * (k0 + ln)] @ Wg[3 * off : 3 * (off + ln)]
            Z[3 * a0 : 3 * a1] = span[(3 * (rows_k[a0:a1] - s0)[:, None] + three).ravel()]
        # G of the requested pairs whose landmark the base measures
        jl = np.searchsorted(lms, pj[np_])
        has = (jl < len(lms)) & (lms[np.minimum(jl, len(lms) - 1)] == pj[np_])
        sel, jl = np_[has], jl[has]
        kr = np.searchsorted(rows_k, pk[sel])
        Z4 = Z.reshape(len(rows_k), 3, len(lms), 2)
        G[sel] = Z4[kr, :, jl, :]
        # W_jᵀ Σ W_j of the group's landmarks: the 2 x 2 diagonal blocks of Wgᵀ Z on the keys' rows
        # (one product; the per-pair einsum and add.at it replaced took ~25 of ~120 ms on KITTI 00)
        wk = Wg4[key_row].reshape(3 * len(keys), -1)
        zk = Z4[np.searchsorted(rows_k, keys)].reshape(wk.shape)
        own = np.arange(len(lms))
        S[lms] = (wk.T @ zk).reshape(len(lms), 2, len(lms), 2)[own, :, own, :]

    # a group with no landmark measured by the base has Σ_kj = 0, Σ_jj = D_j⁻¹: nothing to add
    todo = [
        (b0, b1, n0, n1)
        for b0, b1, n0, n1 in zip(lo_b.tolist(), hi_b.tolist(), lo_n.tolist(), hi_n.tolist())
        if b0 < b1
    ]
    # groups write disjoint rows of G and S, each in its own order: the same numbers on any threads
    for _ in (map_ or map)(lambda t: group(*t), todo):
        pass
    # landmark blocks per landmark, then per pair: Σ_jj = D⁻¹ + D⁻¹ S D⁻¹ (M, 2, 2)
    Dj = np.stack([np.stack([dinv[0], dinv[1]], -1), np.stack([dinv[1], dinv[2]], -1)], -2)
    Sjj = Dj + Dj @ S @ Dj
    sjj = [[np.take(Sjj[:, c, e], pj) for e in range(2)] for c in range(2)]
    e = [[np.take(Dj[:, c, e_], pj) for e_ in range(2)] for c in range(2)]
    # Σ_kj = −G D⁻¹ (3 x 2 per pair) and Σ_kk (3 x 3 per pair), one (n,) array per entry
    g = [[np.ascontiguousarray(G[:, a, c]) for c in range(2)] for a in range(3)]
    skj = [[-(g[a][0] * e[0][c] + g[a][1] * e[1][c]) for c in range(2)] for a in range(3)]
    skk = [[cov[3 * pk + a, 3 * pk + b] for b in range(3)] for a in range(3)]
    h = np.take(states.jacobian_rows, pairs, axis=2)  # (2, 5, n): row r, column (pose 3, landmark 2)
    # Σ h_r of each row r: pose part v (3) and landmark part u (2)
    sh = []
    for r in range(2):
        hp, hl = h[r, :3], h[r, 3:]
        v = [
            skk[a][0] * hp[0] + skk[a][1] * hp[1] + skk[a][2] * hp[2] + skj[a][0] * hl[0] + skj[a][1] * hl[1]
            for a in range(3)
        ]
        u = [
            skj[0][c] * hp[0] + skj[1][c] * hp[1] + skj[2][c] * hp[2] + sjj[c][0] * hl[0] + sjj[c][1] * hl[1]
            for c in range(2)
        ]
        sh.append(v + u)

    def quad(r: int, s_: int) -> np.ndarray:
        return sum(h[s_, x] * sh[r][x] for x in range(5))

    return np.stack([quad(0, 0), quad(0, 1), quad(1, 1)])


def pair_keys(states: StateBuilder, pairs: np.ndarray) -> np.ndarray:
    """(n,) int64 keyframe × M + landmark of each pair (M landmarks): a pair's name across engines."""
    return states.pair_pose[pairs].astype(np.int64) * states.n_landmarks + states.pair_landmark[pairs]


@dataclass(frozen=True)
class Quadratics:
    """:func:`pair_quadratics` of some pairs, by pair key (:func:`pair_keys`), sorted: ``keys`` (n,),
    ``q`` (3, n); ``covariance`` the base's Σ_pp (3K, 3K) they were made from."""

    keys: np.ndarray
    q: np.ndarray
    covariance: np.ndarray

    def lookup(self, states: StateBuilder, pairs: np.ndarray) -> np.ndarray | None:
        """(3, len(pairs)) the quadratics of ``pairs`` (of ``states``' engine), or None unless all are held."""
        want = pair_keys(states, pairs)
        at = np.minimum(np.searchsorted(self.keys, want), max(len(self.keys) - 1, 0))
        if len(self.keys) == 0 or not np.array_equal(self.keys[at], want):
            return None
        return self.q[:, at]


def quadratics(
    kernel: Kernel,
    states: StateBuilder,
    planner: Planner,
    base: BaseState,
    candidates: Sequence[int],
    covariance: np.ndarray,
) -> Quadratics:
    """The quadratics of every pair the ``candidates`` not in S measure, under the base's ``covariance``."""
    measured = np.zeros(len(states.pair_pose), dtype=bool)
    for c in candidates:
        if c not in base.suite:
            measured[states.sensor_pairs[c]] = True
    pairs = np.flatnonzero(measured)
    q = pair_quadratics(states, planner, base, covariance, pairs)
    keys = pair_keys(states, pairs)
    order = np.argsort(keys, kind="stable")
    return Quadratics(keys[order], q[:, order], covariance)


def gain_bounds(
    kernel: Kernel,
    states: StateBuilder,
    planner: Planner,
    base: BaseState,
    candidates: Sequence[int],
    *,
    trace: bool = False,
    map_: Callable[..., Iterable[Any]] | None = None,
    covariance: np.ndarray | None = None,
    shared: Quadratics | None = None,
) -> np.ndarray:
    """Upper bounds [nats] on each candidate's gain log det L(S + {c}) − log det L(S), shape
    (len(candidates),); 0 for a candidate already in S.

    ``trace`` False (default): Σ_m log det(I₂ + R_m^{-1/2} J_m Σ_(k,j) J_mᵀ R_m^{-1/2}) over the
    candidate's measurements m (submodularity of log det over its PSD terms, then the determinant
    lemma per measurement); True: tr(L_S⁻¹ Λ_c), which is larger (log(1 + x) ≤ x per eigenvalue).
    ``map_``: as in :func:`pair_quadratics` (the same numbers either way). ``covariance``: the base's
    Σ_pp (3K, 3K) when the caller has it (:func:`pose_covariance` of the same pose matrix), else computed.
    ``shared``: the pairs' quadratics of an engine with the same base information at S
    (:func:`quadratics`), looked up by (keyframe, landmark) for every pair the candidates measure
    (each pair's quadratic depends only on the base's covariance and the pair's geometry); ignored,
    and computed here, unless it holds them all.
    """
    cands = [int(c) for c in candidates]
    new = [c for c in cands if c not in base.suite]
    out = np.zeros(len(cands))
    if not new:
        return out
    measured = np.zeros(len(states.pair_pose), dtype=bool)  # the candidates' distinct pairs, sorted
    for c in new:  # (np.unique of their concatenation took ~25 ms on KITTI 00 at 1 Hz, this ~2)
        measured[states.sensor_pairs[c]] = True
    pairs = np.flatnonzero(measured)
    q = shared.lookup(states, pairs) if shared is not None else None
    if q is None:
        if covariance is None and shared is not None:
            covariance = shared.covariance
        cov = pose_covariance(kernel, base) if covariance is None else covariance
        q = pair_quadratics(states, planner, base, cov, pairs, map_)
    for i, c in enumerate(cands):
        if c in base.suite:
            continue
        at = np.searchsorted(pairs, states.sensor_pairs[c])
        w0, w1 = states.sensor_w[c]
        a, e = w0 * q[0, at], w1 * q[2, at]
        if trace:
            out[i] = float(np.sum(a) + np.sum(e))
        else:
            x2 = w0 * w1 * q[1, at] ** 2
            out[i] = float(np.sum(np.log1p(a + e + (a * e - x2))))  # log det [[1 + a, x], [x, 1 + e]]
    return out
