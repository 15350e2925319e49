"""The route-order (frontal) path: log det of the full information matrix, poses and landmarks, by a
block Cholesky whose cost grows with the route, not with its cube.

Why. The pose Schur complement P couples every two keyframes that see a common landmark: a
keyframe is coupled to every keyframe within sensor range, so P has ~(keyframe rate x range)
non-zero blocks per row, and at a fixed route its dense factorization costs (3K)³/3, and even a
band one grows like K³. Eliminating in route order instead keeps the work per keyframe bounded:

Order. Keyframes in route order, cut into chunks of :data:`CHUNK_POSES` consecutive keyframes;
after each chunk, the landmarks whose last observation (by an active pair) falls in it. When chunk
t is eliminated, the only other variables it touches are the *open* landmarks (seen before or in
the chunk and again after it) and the next keyframe (odometry). The frontal matrix of chunk t is
``[chunk poses | alive landmarks | next pose]``, the alive landmarks (entered at or before t,
closing at or after t) sorted by (closing chunk, entering chunk, index): those closing at t come
first, so the eliminated variables (chunk poses and closing landmarks) are a leading block (one
dpotrf, one dtrsm, one dsyrk: :meth:`Blas.eliminate_leading`), and the Schur complement left on
(open landmarks, next pose) is carried into the next chunk's front. The carried landmarks keep
their relative order there (same sort key), so they move by a few block copies (one per run
between newly entering landmarks), triangle to same triangle; the next pose moves from last to
first (a transposed 3-row copy). Only the upper triangle of each row-major front (the lower one,
column-major, for LAPACK) is filled or read.
log det Λ = Σ over chunks of log det of the eliminated blocks (+ the prior-only landmarks'
2×2 log dets). The work per keyframe is ~3 (2F)² flops with F the open landmarks: it depends on
the landmarks within sensor range of a place, not on the keyframe rate or the route's length. A
route that comes back to a place keeps that place's landmarks open in between (F grows): the
kernel compares the predicted flops with the dense path's and takes the cheaper (see
:data:`sensorsel.evaluators.fast.kernel.FRONT_BELOW`).

A plan depends only on the active pairs (like a :class:`~.plan.Layout`): it is built once per base
suite and reused by every candidate that adds no pair. Memory: the plan's index arrays (linear in
the pairs) and two frontal buffers of the largest front (bounded by the landmarks in range, or by
all landmarks).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .blas import Blas

#: keyframes per chunk of the route-order elimination (measured: bench/scaling.py, docs/speed.md)
CHUNK_POSES = 32

#: (row, column) of the unique entries of a symmetric 3x3 in the lower triangle, in the order of
#: the pose-diagonal sums (SYM3 = (0,0), (0,1), (0,2), (1,1), (1,2), (2,2) as (i, j), i <= j)
_A_ROW = np.array([0, 1, 2, 1, 2, 2])
_A_COL = np.array([0, 0, 0, 1, 1, 2])


@dataclass(frozen=True, eq=False)
class Chunk:
    """One elimination step: where each input goes in its (m, m) row-major frontal matrix."""

    s: int  # first keyframe
    e: int  # one past the last keyframe
    m: int  # front size
    m1: int  # leading variables eliminated (chunk poses, closing landmarks)
    dims: np.ndarray  # C int (m1, m - m1, m)
    carry_pose: int  # row of the carried keyframe in the previous front's remaining block (-1: first chunk)
    segs: list[tuple[int, int, int]]  # carried landmark runs: (row in the previous remaining block, row here, length)
    base_idx: np.ndarray  # flat indices of the base graph's entries whose column is in the chunk
    base_val: np.ndarray  # their values
    a_idx: np.ndarray  # (6, e - s) flat indices of the pose-diagonal sums of the chunk's keyframes
    w_lo: int  # the chunk's pairs: [w_lo, w_hi) of the pairs sorted by keyframe
    w_hi: int
    w_idx: np.ndarray  # (6, w_hi - w_lo) flat indices of their W entries (entry c * 3 + a: landmark row c, pose column a)
    d_lm: np.ndarray  # landmarks entering the front at this chunk
    d_idx: np.ndarray  # (3, len(d_lm)) flat indices of their d00, d01, d11
    # (every flat index is of the upper triangle of the row-major front: entry (row r, column c) of
    # the matrix's lower triangle, r >= c, is stored at c * m + r)


@dataclass(frozen=True, eq=False)
class FrontPlan:
    """The route-order elimination of one pattern of active pairs."""

    chunks: list[Chunk]
    by_pose: np.ndarray  # (Pa,) active pairs (positions in the layout's order) sorted by keyframe
    unseen: np.ndarray  # landmarks no active pair measures (their information is their prior alone)
    flops: float  # predicted floating-point work of one evaluation
    max_front: int  # the largest front (variables)


def plan_front(pair_pose: np.ndarray, pair_landmark: np.ndarray, n_poses: int, n_landmarks: int,
               base_rc: tuple[np.ndarray, np.ndarray], base_values: np.ndarray, chunk_poses: int = CHUNK_POSES) -> FrontPlan | None:
    """The frontal plan of the active pairs (keyframe ``pair_pose``, landmark ``pair_landmark``, in the
    layout's order), or None when the base graph links keyframes more than one apart across a chunk
    boundary (loop closures in the base graph: not planned, the dense path takes it).

    ``base_rc``, ``base_values``: the lower triangle of the base graph's pose information (scalar rows).
    """
    K, M, c = n_poses, n_landmarks, max(1, int(chunk_poses))
    by_pose = np.argsort(pair_pose, kind="stable")
    ps_sorted = pair_pose[by_pose]
    first = np.full(M, K, dtype=np.int64)
    last = np.full(M, -1, dtype=np.int64)
    np.minimum.at(first, pair_landmark, pair_pose)
    np.maximum.at(last, pair_landmark, pair_pose)
    seen = last >= 0
    unseen = np.flatnonzero(~seen)
    n_chunks = -(-K // c)
    enter = np.where(seen, first // c, n_chunks)
    close = np.where(seen, last // c, -1)
    korder = np.flatnonzero(seen)
    korder = korder[np.lexsort((korder, enter[korder], close[korder]))]  # by (closing chunk, entering chunk, index)
    k_close, k_enter = close[korder], enter[korder]
    # the base graph by the keyframe of its column (the earlier keyframe of a lower entry)
    br, bc = base_rc
    col_pose, row_pose = bc // 3, br // 3
    border = np.argsort(col_pose, kind="stable")
    br, bc, bv, col_pose, row_pose = br[border], bc[border], base_values[border], col_pose[border], row_pose[border]
    pos_of = np.zeros(M, dtype=np.int64)
    chunks: list[Chunk] = []
    flops = 0.0
    max_front = 0
    prev_rest: np.ndarray | None = None  # landmarks carried out of the previous chunk, in order
    for t in range(n_chunks):
        s, e = t * c, min(K, (t + 1) * c)
        lo = int(np.searchsorted(k_close, t))
        alive = korder[lo:][k_enter[lo:] <= t]
        n_close = int(np.searchsorted(k_close[lo:], t + 1))  # alive landmarks closing at t: a prefix
        n_pose = 3 * (e - s)
        p_e = n_pose + 2 * len(alive)  # the next keyframe: last
        m = p_e + (3 if e < K else 0)
        m1 = n_pose + 2 * n_close
        if e == K and n_close != len(alive):
            raise AssertionError("landmarks open after the last keyframe")
        pos_of[alive] = n_pose + 2 * np.arange(len(alive))
        segs: list[tuple[int, int, int]] = []
        carry_pose = -1
        if prev_rest is not None:
            new = pos_of[prev_rest]
            if np.any(np.diff(new) <= 0):
                raise AssertionError("carried landmarks out of order")
            brk = np.flatnonzero(np.diff(new) != 2) + 1
            starts = np.r_[0, brk]
            ends = np.r_[brk, len(new)]
            segs = [(2 * int(a), int(new[a]), 2 * int(b - a)) for a, b in zip(starts, ends) if b > a]
            carry_pose = 2 * len(prev_rest)
        # base entries with their column in the chunk; rows in the chunk or on the next keyframe
        b_lo, b_hi = np.searchsorted(col_pose, [s, e])
        rp = row_pose[b_lo:b_hi]
        if np.any(rp > e) or (e == K and np.any(rp >= e)):
            return None
        rows = np.where(rp < e, br[b_lo:b_hi] - 3 * s, p_e + br[b_lo:b_hi] - 3 * e)
        base_idx = (bc[b_lo:b_hi] - 3 * s) * m + rows  # upper triangle: (column, row)
        k3 = 3 * np.arange(e - s)
        a_idx = (k3[None, :] + _A_COL[:, None]) * m + k3[None, :] + _A_ROW[:, None]
        w_lo, w_hi = np.searchsorted(ps_sorted, [s, e])
        pr = by_pose[w_lo:w_hi]
        lrow, pcol = pos_of[pair_landmark[pr]], 3 * (pair_pose[pr] - s)
        w_idx = np.stack([(pcol + aa) * m + lrow + cc for cc in range(2) for aa in range(3)])
        d_lm = alive[k_enter[lo:][k_enter[lo:] <= t] == t]
        dp = pos_of[d_lm]
        d_idx = np.stack([dp * m + dp, dp * m + dp + 1, (dp + 1) * m + dp + 1])
        dims = np.array([m1, m - m1, m], dtype=np.intc)
        chunks.append(Chunk(s, e, m, m1, dims, carry_pose, segs, base_idx, bv[b_lo:b_hi].copy(), a_idx, int(w_lo), int(w_hi),
                            w_idx, d_lm, d_idx))
        q = m - m1
        # potrf, trsm, syrk; the fill and the carried copies (~1 flop a byte), and ~60 us of calls a chunk
        flops += m1**3 / 3.0 + m1 * m1 * q + m1 * q * q + 2.0 * m * m + 1e6 + 2e4 * len(segs) ** 2
        max_front = max(max_front, m)
        prev_rest = alive[n_close:]
    return FrontPlan(chunks, by_pose, unseen, flops, max_front)


def front_logdet(plan: FrontPlan, wpl: np.ndarray, d: np.ndarray, a: np.ndarray, blas: Blas,
                 buffers: tuple[np.ndarray, np.ndarray]) -> float:
    """log det [nats] of the full information (poses and landmarks) by the plan's route-order
    elimination. ``wpl`` (6, Pa), ``d`` (3, M), ``a`` (6, K) as for the kernel (not written to);
    ``buffers``: two float64 scratch arrays of at least ``plan.max_front²`` entries."""
    du = d[:, plan.unseen]
    logdet = float(np.sum(np.log(du[0] * du[2] - du[1] * du[1])))
    w = wpl[:, plan.by_pose]
    prev: np.ndarray | None = None
    for i, ch in enumerate(plan.chunks):
        m = ch.m
        flat = buffers[i & 1][: m * m]
        flat.fill(0.0)
        g = flat.reshape(m, m)
        if prev is not None and ch.carry_pose >= 0:
            # the previous front's remaining block (upper triangle): carried landmarks, then the keyframe
            cp = ch.carry_pose
            g[0:3, 0:3] = prev[cp: cp + 3, cp: cp + 3]
            for j, (oi, ni, li) in enumerate(ch.segs):
                g[0:3, ni: ni + li] = prev[oi: oi + li, cp: cp + 3].T
                for oj, nj, lj in ch.segs[: j + 1]:
                    g[nj: nj + lj, ni: ni + li] = prev[oj: oj + lj, oi: oi + li]
        flat[ch.base_idx] += ch.base_val
        flat[ch.a_idx] += a[:, ch.s: ch.e]
        flat[ch.w_idx] += w[:, ch.w_lo: ch.w_hi]
        if len(ch.d_lm):
            flat[ch.d_idx] += d[:, ch.d_lm]
        logdet += blas.eliminate_leading(g, ch.m1, ch.dims)
        prev = g[ch.m1:, ch.m1:]
    return logdet
