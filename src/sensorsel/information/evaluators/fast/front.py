"""The frontal path: log det of the full information matrix, poses and landmarks, by a block
Cholesky whose cost grows with the route, not with its cube.

Why. The pose Schur complement P couples every two keyframes that see a common landmark: a
keyframe is coupled to every keyframe within sensor range, so P has ~(keyframe rate x range)
non-zero blocks per row, and at a fixed route its dense factorization costs (3K)³/3, and even a
band one grows like K³. Eliminating poses and landmarks together, along the route, keeps the work
per keyframe bounded.

Order. Keyframes in a keyframe order (:func:`keyframe_orders`: route order, x or y sweep, RCM of
nearby keyframes), cut into chunks of :data:`CHUNK_POSES`. Variables are the poses (3 scalars) and
the seen landmarks (2). A chunk *touches* its keyframes, the landmarks they see and the keyframes
the base graph links them to (odometry; each base entry belongs to the earlier chunk of its two
keyframes); a variable is alive from the first chunk that touches it to the last one, after which
nothing refers to it any more and it is eliminated. The frontal matrix of chunk t holds the alive
variables sorted by (closing chunk, entering chunk, id): those closing at t come first, so the
eliminated variables are a leading block (one dpotrf, one dtrsm, one dsyrk:
:meth:`Blas.eliminate_leading`), and the Schur complement left on the others is carried into the
next chunk's front. Carried variables keep their relative order there (same sort key), so they
move by a few block copies (one per run between newly entering variables), triangle to same
triangle. Only the upper triangle of each row-major front (the lower one, column-major, for
LAPACK) is filled or read.

log det Λ = Σ over chunks of log det of the eliminated blocks (+ the prior-only landmarks' 2×2 log
dets). The work per keyframe is ~3 (2F)² flops with F the open landmarks: it depends on the
landmarks within sensor range of a place, not on the keyframe rate or the route's length. A route
that comes back to a place keeps that place's landmarks open until the next pass (F grows): a
spatial order puts the passes side by side, and the kernel compares the predicted flops of each
order and of the dense path and takes the cheapest (see
:data:`sensorsel.information.evaluators.fast.kernel.FRONT_BELOW`).

A plan depends only on the active pairs (like a :class:`~.plan.Layout`): it is built once per
pattern of measured pairs and reused by every candidate that adds no pair. Memory: the plan's index arrays (linear in
the pairs) and two frontal buffers of the largest front (bounded by the landmarks in range, or by
all landmarks).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from sensorsel.information.evaluators.fast.blas import Blas

#: keyframes per chunk of the frontal elimination (measured per evaluation on 02 at 3 Hz, 03 at 8 Hz,
#: 00 at 1 Hz: 16 to 48 within ~10%, 64 up to 15% slower; docs/speed.md)
CHUNK_POSES = 32

#: (row, column) of the unique entries of a symmetric 3x3 in the lower triangle, in the order of
#: the pose-diagonal sums (SYM3 = (0,0), (0,1), (0,2), (1,1), (1,2), (2,2) as (i, j), i <= j)
_A_ROW = np.array([0, 1, 2, 1, 2, 2])
_A_COL = np.array([0, 0, 0, 1, 1, 2])


@dataclass(frozen=True, eq=False)
class Chunk:
    """One elimination step: where each input goes in its (m, m) row-major frontal matrix.

    Every flat index is of the upper triangle of the row-major front (the lower one, column-major,
    for LAPACK): an entry between front positions u and v is stored at min(u, v) * m + max(u, v).
    """

    poses: np.ndarray  # keyframes of the chunk
    m: int  # front size
    m1: int  # leading variables eliminated (those whose last chunk this is)
    dims: np.ndarray  # C int (m1, m - m1, m)
    segs: list[tuple[int, int, int]]  # carried runs: (row in the previous remaining block, row here, length)
    base_idx: np.ndarray  # flat indices of the base graph's entries assigned to the chunk
    base_val: np.ndarray  # their values
    a_idx: np.ndarray  # (6, len(poses)) flat indices of the pose-diagonal sums of the chunk's keyframes
    w_lo: int  # the chunk's pairs: [w_lo, w_hi) of the pairs sorted by chunk
    w_hi: int
    w_idx: (
        np.ndarray
    )  # (6, w_hi - w_lo) flat indices of their W entries (entry c * 3 + a: landmark row c, pose column a)
    d_lm: np.ndarray  # landmarks entering the front at this chunk
    d_idx: np.ndarray  # (3, len(d_lm)) flat indices of their d00, d01, d11


@dataclass(frozen=True, eq=False)
class FrontPlan:
    """The frontal elimination of one pattern of active pairs in one keyframe order."""

    chunks: list[Chunk]
    by_chunk: np.ndarray  # (Pa,) active pairs (positions in the layout's order) sorted by their keyframe's chunk
    unseen: np.ndarray  # landmarks no active pair measures (their information is their prior alone)
    flops: float  # predicted floating-point work of one evaluation
    max_front: int  # the largest front (variables)
    order_name: str  # which keyframe order


def keyframe_orders(xy: np.ndarray, radius_m: float = 100.0) -> dict[str, np.ndarray]:
    """Candidate keyframe orders for the frontal path, from the keyframes' positions ``xy`` (K, 2):
    route order; sweeps along x and along y; reverse Cuthill-McKee of the graph of keyframes
    closer than ``radius_m``. Where the route comes back to a place, a spatial order puts the
    passes side by side (their landmarks then stay open for a short while instead of the whole
    time in between). Measured on KITTI 02/08/00 at 1 Hz (LiDAR suite): no single order is best
    on every route, so each layout is planned in all of them and the cheapest is kept."""
    from scipy.sparse import coo_matrix, eye
    from scipy.sparse.csgraph import reverse_cuthill_mckee
    from scipy.spatial import cKDTree

    K = len(xy)
    orders = {
        "route": np.arange(K),
        "sweep-x": np.argsort(xy[:, 0], kind="stable"),
        "sweep-y": np.argsort(xy[:, 1], kind="stable"),
    }
    if K > 1:
        pr = cKDTree(xy).query_pairs(radius_m, output_type="ndarray")
        adj = coo_matrix((np.ones(len(pr)), (pr[:, 0], pr[:, 1])), shape=(K, K)).tocsr()
        orders["rcm"] = np.asarray(
            reverse_cuthill_mckee((adj + adj.T + eye(K, format="csr")).tocsr(), symmetric_mode=True)
        )
    return orders


def _intervals(
    pair_pose: np.ndarray,
    pair_landmark: np.ndarray,
    n_poses: int,
    n_landmarks: int,
    base_rc: tuple[np.ndarray, np.ndarray],
    chunk_poses: int,
    pose_order: np.ndarray | None,
) -> dict:
    """The chunks of every keyframe, pair and base entry, and every variable's alive interval."""
    K, M, c = n_poses, n_landmarks, max(1, int(chunk_poses))
    order = np.arange(K) if pose_order is None else np.asarray(pose_order)
    rank = np.empty(K, dtype=np.int64)
    rank[order] = np.arange(K)
    chunk_of = rank // c
    n_chunks = -(-K // c)
    pc = chunk_of[pair_pose]
    # base entries: each to the earlier chunk of its two keyframes
    br, bcol = base_rc
    b_chunk = np.minimum(chunk_of[br // 3], chunk_of[bcol // 3])
    # alive intervals [enter, close] of every variable: poses (ids 0..K-1) then landmarks (K + j)
    enter = np.full(K + M, n_chunks, dtype=np.int64)
    close = np.full(K + M, -1, dtype=np.int64)
    for v, t in ((np.arange(K), chunk_of), (br // 3, b_chunk), (bcol // 3, b_chunk), (K + pair_landmark, pc)):
        np.minimum.at(enter, v, t)
        np.maximum.at(close, v, t)
    size = np.where(np.arange(K + M) < K, 3, 2)
    return dict(
        K=K,
        M=M,
        c=c,
        order=order,
        chunk_of=chunk_of,
        n_chunks=n_chunks,
        pc=pc,
        b_chunk=b_chunk,
        enter=enter,
        close=close,
        size=size,
    )


def _flops(m: np.ndarray, m1: np.ndarray) -> float:
    """Predicted work of the chunks with fronts ``m`` and eliminated leading blocks ``m1``: potrf,
    trsm, syrk; the fill and the carried copies (~1 flop a byte), and ~50 us of calls a chunk."""
    q = m - m1
    return float(np.sum(m1**3 / 3.0 + m1 * m1 * q + m1 * q * q + 2.0 * m * m + 1e6))


def front_flops(
    pair_pose: np.ndarray,
    pair_landmark: np.ndarray,
    n_poses: int,
    n_landmarks: int,
    base_rc: tuple[np.ndarray, np.ndarray],
    chunk_poses: int = CHUNK_POSES,
    pose_order: np.ndarray | None = None,
) -> float:
    """The predicted flops of :func:`plan_front`'s plan, from the alive intervals alone (vectorized:
    ~1 ms where building the plan takes ~10-50; the kernel ranks orders and paths with it)."""
    iv = _intervals(pair_pose, pair_landmark, n_poses, n_landmarks, base_rc, chunk_poses, pose_order)
    live = iv["close"] >= 0
    enter, close, size, n = iv["enter"][live], iv["close"][live], iv["size"][live], iv["n_chunks"]
    diff = np.bincount(enter, size, n + 1) - np.bincount(close + 1, size, n + 1)
    m = np.cumsum(diff)[:n]
    m1 = np.bincount(close, size, n)
    return _flops(m.astype(float), m1.astype(float))


# Long on purpose (~60 lines): one pass over the chunks that fixes, in order, which variables each
# chunk eliminates and carries; the kernel replays it for every candidate.
def plan_front(
    pair_pose: np.ndarray,
    pair_landmark: np.ndarray,
    n_poses: int,
    n_landmarks: int,
    base_rc: tuple[np.ndarray, np.ndarray],
    base_values: np.ndarray,
    chunk_poses: int = CHUNK_POSES,
    pose_order: np.ndarray | None = None,
    order_name: str = "route",
) -> FrontPlan:
    """The frontal plan of the active pairs (keyframe ``pair_pose``, landmark ``pair_landmark``, in the
    layout's order) with keyframes taken ``chunk_poses`` at a time in ``pose_order`` (default: route order).

    Variables are the K poses (3 scalars, ids 0..K-1) and the seen landmarks (2 scalars, ids K + j).
    A chunk touches its keyframes, the landmarks they see and the keyframes the base graph links
    them to (its entries are assigned to the earlier chunk of their two keyframes); a variable is
    alive from the first chunk that touches it to the last, where it is eliminated.
    ``base_rc``, ``base_values``: the lower triangle of the base graph's pose information (scalar rows).
    """
    iv = _intervals(pair_pose, pair_landmark, n_poses, n_landmarks, base_rc, chunk_poses, pose_order)
    K, M, c, order, n_chunks = iv["K"], iv["M"], iv["c"], iv["order"], iv["n_chunks"]
    pc, b_chunk, enter, close = iv["pc"], iv["b_chunk"], iv["enter"], iv["close"]
    by_chunk = np.argsort(pc, kind="stable")
    pc_sorted = pc[by_chunk]
    br, bcol = base_rc
    border = np.argsort(b_chunk, kind="stable")
    br, bcol, bv, b_chunk = br[border], bcol[border], base_values[border], b_chunk[border]
    unseen = np.flatnonzero(close[K:] < 0)
    size = iv["size"]
    korder = np.flatnonzero(close >= 0)
    korder = korder[np.lexsort((korder, enter[korder], close[korder]))]  # by (closing chunk, entering chunk, id)
    k_close, k_enter, k_size = close[korder], enter[korder], size[korder]
    pos_of = np.zeros(K + M, dtype=np.int64)
    chunks: list[Chunk] = []
    ms: list[int] = []
    m1s: list[int] = []
    prev_rest: np.ndarray | None = None  # variables carried out of the previous chunk, in order
    for t in range(n_chunks):
        lo = int(np.searchsorted(k_close, t))
        sel = k_enter[lo:] <= t
        alive, asz = korder[lo:][sel], k_size[lo:][sel]
        n_close = int(np.searchsorted(k_close[lo:][sel], t + 1))  # alive variables closing at t: a prefix
        start = np.cumsum(asz) - asz
        pos_of[alive] = start
        m = int(asz.sum())
        m1 = int(asz[:n_close].sum())
        segs: list[tuple[int, int, int]] = []
        if prev_rest is not None and len(prev_rest):
            new = pos_of[prev_rest]
            sz = size[prev_rest]
            old = np.cumsum(sz) - sz
            if np.any(np.diff(new) <= 0):
                raise AssertionError("carried variables out of order")
            brk = np.flatnonzero(new[1:] != new[:-1] + sz[:-1]) + 1
            st, en = np.r_[0, brk], np.r_[brk, len(new)]
            segs = [(int(old[a]), int(new[a]), int(old[b - 1] + sz[b - 1] - old[a])) for a, b in zip(st, en)]
        poses = order[t * c : (t + 1) * c]
        b_lo, b_hi = np.searchsorted(b_chunk, [t, t + 1])
        u = pos_of[br[b_lo:b_hi] // 3] + br[b_lo:b_hi] % 3
        v = pos_of[bcol[b_lo:b_hi] // 3] + bcol[b_lo:b_hi] % 3
        base_idx = np.minimum(u, v) * m + np.maximum(u, v)
        pp = pos_of[poses]
        a_idx = (pp[None, :] + _A_COL[:, None]) * m + pp[None, :] + _A_ROW[:, None]  # (i, j), i <= j
        w_lo, w_hi = np.searchsorted(pc_sorted, [t, t + 1])
        pr = by_chunk[w_lo:w_hi]
        lpos, ppos = pos_of[K + pair_landmark[pr]], pos_of[pair_pose[pr]]
        w_idx = np.stack(
            [
                np.minimum(ppos + aa, lpos + cc) * m + np.maximum(ppos + aa, lpos + cc)
                for cc in range(2)
                for aa in range(3)
            ]
        )
        d_lm = alive[(k_enter[lo:][sel] == t) & (alive >= K)] - K
        dp = pos_of[K + d_lm]
        d_idx = np.stack([dp * m + dp, dp * m + dp + 1, (dp + 1) * m + dp + 1])
        dims = np.array([m1, m - m1, m], dtype=np.intc)
        chunks.append(
            Chunk(
                poses,
                m,
                m1,
                dims,
                segs,
                base_idx,
                bv[b_lo:b_hi].copy(),
                a_idx,
                int(w_lo),
                int(w_hi),
                w_idx,
                d_lm,
                d_idx,
            )
        )
        ms.append(m)
        m1s.append(m1)
        prev_rest = alive[n_close:]
    if prev_rest is not None and len(prev_rest):
        raise AssertionError("variables open after the last chunk")
    return FrontPlan(chunks, by_chunk, unseen, _flops(np.array(ms, float), np.array(m1s, float)), max(ms), order_name)


def front_logdet(
    plan: FrontPlan,
    wpl: np.ndarray,
    d: np.ndarray,
    a: np.ndarray,
    blas: Blas,
    buffers: tuple[np.ndarray, np.ndarray],
    keep: list[np.ndarray] | None = None,
) -> float:
    """log det [nats] of the full information (poses and landmarks) by the plan's frontal
    elimination. ``wpl`` (6, Pa), ``d`` (3, M), ``a`` (6, K) as for the kernel (not written to);
    ``buffers``: two float64 scratch arrays of at least ``plan.max_front²`` entries. ``keep``: if
    given, each chunk's eliminated rows after the elimination (a copy of the (m1, m) leading rows of
    its front: U11 in the upper triangle, U11⁻ᵀ G12 to its right) are appended to it, for
    :func:`front_pose_covariances`."""
    du = d[:, plan.unseen]
    logdet = float(np.sum(np.log(du[0] * du[2] - du[1] * du[1])))
    w = wpl[:, plan.by_chunk]
    prev: np.ndarray | None = None
    for i, ch in enumerate(plan.chunks):
        m = ch.m
        flat = buffers[i & 1][: m * m]
        flat.fill(0.0)
        g = flat.reshape(m, m)
        if prev is not None:
            # the previous front's remaining block (upper triangle), run by run
            for j, (oi, ni, li) in enumerate(ch.segs):
                for oj, nj, lj in ch.segs[: j + 1]:
                    g[nj : nj + lj, ni : ni + li] = prev[oj : oj + lj, oi : oi + li]
        flat[ch.base_idx] += ch.base_val
        flat[ch.a_idx] += a[:, ch.poses]
        flat[ch.w_idx] += w[:, ch.w_lo : ch.w_hi]
        if len(ch.d_lm):
            flat[ch.d_idx] += d[:, ch.d_lm]
        logdet += blas.eliminate_leading(g, ch.m1, ch.dims)
        if keep is not None:
            keep.append(g[: ch.m1].copy())
        prev = g[ch.m1 :, ch.m1 :]
    return logdet


def front_pose_covariances(plan: FrontPlan, kept: Sequence[np.ndarray], n_poses: int) -> np.ndarray:
    """The (K = ``n_poses``, 3, 3) marginal covariances of the poses by selected inversion on the
    frontal elimination: linear in the route, like the elimination itself.

    The forward pass is :func:`front_logdet` of ``plan`` run with ``keep=kept``: each chunk's
    eliminated rows, in chunk order, are what this backward pass reads. Going back from
    the last chunk, with E a chunk's eliminated variables, R the ones it carries on (all eliminated
    later, so their covariance Σ_RR over R is known by then), G11 = U11ᵀ U11 and X = G11⁻¹ G12 =
    U11⁻¹ (U11⁻ᵀ G12):

        Σ_ER = −X Σ_RR        Σ_EE = G11⁻¹ + X Σ_RR Xᵀ = U11⁻¹ U11⁻ᵀ − Σ_ER Xᵀ

    (the block inverse of [[G11, G12], [G21, Σ_RR⁻¹ + G21 G11⁻¹ G12]]). The chunk's front, so
    covered, holds the previous chunk's carried variables: their Σ_RR is read from it by the same
    runs that carried them forward. Each pose is eliminated in its own chunk: its block is read off
    Σ_EE. About twice the forward pass's flops (the products with Σ_RR are m1 q² each, like the
    forward Schur update), so ~3 evaluations in all.
    """
    from scipy.linalg import solve_triangular

    out = np.zeros((n_poses, 3, 3))
    s_rr = np.zeros((0, 0))
    for ch, top in zip(reversed(plan.chunks), reversed(kept)):
        m, m1 = ch.m, ch.m1
        u = top[:, :m1]  # U11 in its upper triangle (the solves read no other)
        x = solve_triangular(u, top[:, m1:], lower=False, check_finite=False)  # G11⁻¹ G12 (m1, q)
        u_inv = solve_triangular(u, np.eye(m1), lower=False, check_finite=False)
        s_er = -(x @ s_rr)
        s_ee = u_inv @ u_inv.T - s_er @ x.T
        pp = ch.a_idx[0] // m  # front positions of the chunk's keyframes (eliminated here, so < m1)
        idx = pp[:, None] + np.arange(3)[None, :]
        out[ch.poses] = s_ee[idx[:, :, None], idx[:, None, :]]
        if not ch.segs:
            s_rr = np.zeros((0, 0))
            continue
        # the previous chunk's Σ_RR: the rows and columns of the front's Σ its runs carried, copied
        # run by run from the quadrant each part of a run lies in (Σ_EE, Σ_ER, Σ_REᵀ, Σ_RR: the front's
        # whole Σ is not assembled)
        q_prev = sum(length for _, _, length in ch.segs)
        runs = _split_runs(ch.segs, m1)
        previous = np.empty((q_prev, q_prev))
        for oi, ni, li in runs:
            for oj, nj, lj in runs:
                if ni < m1:
                    src = s_ee[ni : ni + li, nj : nj + lj] if nj < m1 else s_er[ni : ni + li, nj - m1 : nj - m1 + lj]
                elif nj < m1:
                    src = s_er[nj : nj + lj, ni - m1 : ni - m1 + li].T
                else:
                    src = s_rr[ni - m1 : ni - m1 + li, nj - m1 : nj - m1 + lj]
                previous[oi : oi + li, oj : oj + lj] = src
        s_rr = previous
    return 0.5 * (out + out.transpose(0, 2, 1))


def _split_runs(segs: Sequence[tuple[int, int, int]], m1: int) -> list[tuple[int, int, int]]:
    """``segs`` ((old position, front position, length) runs) with each run that spans front position
    ``m1`` cut in two there: every part then lies in the eliminated variables or in the carried ones."""
    out = []
    for o, n, length in segs:
        if n < m1 < n + length:
            out += [(o, n, m1 - n), (o + m1 - n, m1, n + length - m1)]
        else:
            out.append((o, n, length))
    return out
