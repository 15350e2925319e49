"""The fast engine: the reference's log det of every suite, without rebuilding or relinearizing.

The numbers are the reference's (GTSAM: build, linearize at the truth, eliminate) to round-off:
measured ~1e-14 relative on the fixtures and KITTI 03/00, tested to 1e-9 on every evaluation.

Method
------
1. Linearize once. The linearization point is the truth, so a measurement's information never
   changes. :func:`sensorsel.graph.linearize_library` linearizes, with GTSAM, every distinct
   (keyframe, landmark) pair that some sensor measures (unit noise) and the base graph (first-pose
   prior, odometry, landmark priors). A suite's information is then
   ``Λ(S) = Λ₀ + Σ_pairs Σ_{r ∈ bearing, range} ω_r h_r h_rᵀ`` where ``h_r`` is the pair's Jacobian row
   and ``ω_r`` the sum of 1/σ_r² over the suite's sensors that measure the pair: a suite is a vector
   of pair weights, and adding a sensor adds its own weights.
2. Landmarks are conditionally independent given the poses. With ``D_j`` the 2×2 information of
   landmark j and ``W_j`` its coupling to the keyframes,
   ``log det Λ = Σ_j log det D_j + log det P``, ``P = Λ_pp − Σ_j W_j D_j⁻¹ W_jᵀ`` (3K × 3K).
3. P is dense on real routes. On KITTI 00 with the 120 m LiDAR in the suite each landmark is seen
   from ~75 keyframes over 2-3 passes of the loops, ~50% of P's 3×3 pose blocks are non-zero and a
   fill-reducing (minimum degree) order still leaves ~50% of a dense factorization's work. So P is
   factored by LAPACK's dense Cholesky (dpotrf at ~peak speed), unless fewer than
   :data:`SPARSE_BELOW` of its blocks are non-zero (e.g. one narrow radar or camera alone, the first
   greedy step), where SuperLU with a minimum-degree order is 2-3x faster (measured per sensor on 00).
4. Assembly. ``Σ_j W_j D_j⁻¹ W_jᵀ = Σ_j Y_j Y_jᵀ`` with ``Y_j = W_j L_j⁻ᵀ`` (``D_j = L_j L_jᵀ``).
   Landmarks are grouped in route order (:data:`GROUP_SIZE` per group: neighbours on the road are
   seen from the same keyframes on every pass). Each group's Y is a dense tile whose rows are the
   keyframes that see the group, as runs of consecutive keyframes; one BLAS syrk/gemm per pair of
   runs accumulates ``tile tileᵀ`` straight into P's lower triangle (CBLAS of numpy's OpenBLAS via
   ctypes with a leading dimension: no temporary and no second pass over memory; plain numpy when
   no OpenBLAS is found).
5. Incremental candidates. :meth:`FastEvaluator.scores_with` computes the base suite's pair
   weights, landmark and pose sums and the W of its measured pairs once; each candidate adds its
   own few thousand pairs to copies and reuses the base's tile layout unless it measures pairs the
   base does not (radars reaching beyond the LiDAR), which get a layout of their own.

Why not a low-rank update (determinant lemma) of the base: a candidate's update has rank 2 per
measurement (2,000-11,000 measurements per camera or radar on 00), and in the pose space it reaches
every keyframe: with the LiDAR in the suite, each later candidate changes 750-1,550 landmarks, seen
from all 455 keyframes. Every lemma form (pose space, landmark space, full space) is larger than
the 1,365 × 1,365 pose matrix itself, so factoring P is the cheapest exact step.

Parallelism: candidates are scored on ``jobs`` threads (from :data:`THREADS_FROM_KEYFRAMES` on:
smaller problems are quicker on one). numpy's array code and the ctypes BLAS
calls release the GIL; threads share the linearized problem without pickling (a linearized GTSAM
graph does not pickle) and without fork (forked workers after multithreaded BLAS were seen to
hang, see the shared GTSAM notes). OpenBLAS is held at one thread per caller while scoring: its
threaded Cholesky splits work by thread count (results could differ in the last bits) and its
spinning threads were measured 10-20x slower on the busy 2-core machine. Every candidate's number
comes from the same code on the same inputs, so results are identical whatever ``jobs`` is.
"""

from __future__ import annotations

import ctypes
import threading
import weakref
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Iterable, Iterator, Sequence

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.spatial import cKDTree

from .errors import InputError
from .objective import Evaluator, Suite, as_suite
from .problem import Problem

#: landmarks per group (tile) of the Schur product
GROUP_SIZE = 16
#: below this fraction of non-zero pose blocks the pose matrix is factored as a sparse matrix
SPARSE_BELOW = 0.11
#: runs of keyframes of a group's tile closer than this are joined (zero rows in between)
RUN_GAP = 6
#: candidates are scored on several threads only from this many keyframes on. Below it a candidate
#: costs ~2 ms, mostly interpreter work that holds the GIL, and two threads were measured slower
#: than one (KITTI 03, 81 keyframes: lazy greedy 0.39-0.48 s on 2 threads, 0.31-0.32 s on 1);
#: on KITTI 00 (455 keyframes) the dense factorizations release the GIL and 2 threads took 7.4 s
#: against 10.1 s on 1.
THREADS_FROM_KEYFRAMES = 200

_SYM3 = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))  # unique entries of a symmetric 3x3


class _Blas:
    """In-place dense kernels on sub-blocks of numpy arrays, through an OpenBLAS loaded by numpy.

    numpy has no ``C += A @ B.T`` on a view; calling the library's CBLAS directly with a leading
    dimension accumulates each group's Schur product straight into the pose matrix (no temporary,
    no second pass over memory), and LAPACK's dpotrf factors it in place. ctypes releases the GIL
    during each call, so candidates on separate threads run in parallel. ``available`` is False
    when no OpenBLAS with these symbols is loaded; the engine then uses numpy (same numbers to
    round-off).
    """

    ROW_MAJOR, NO_TRANS, TRANS, LOWER = 101, 111, 112, 122

    def __init__(self) -> None:
        self.available = False
        self._threads: list[tuple[object, object]] = []  # (get, set) number of threads of each OpenBLAS
        try:
            with open("/proc/self/maps") as fh:
                paths = sorted({line.split()[-1] for line in fh if "openblas" in line.rsplit("/", 1)[-1].lower()})
        except OSError:
            return
        for path in paths:
            try:
                lib = ctypes.CDLL(path)
            except OSError:
                continue
            for prefix, suffix in (("scipy_openblas", "64_"), ("scipy_openblas", ""), ("openblas", "64_"), ("openblas", "")):
                get = getattr(lib, f"{prefix}_get_num_threads{suffix}", None)
                put = getattr(lib, f"{prefix}_set_num_threads{suffix}", None)
                if get is not None and put is not None:
                    get.restype = ctypes.c_int
                    put.argtypes = [ctypes.c_int]
                    self._threads.append((get, put))
                    break
            if self.available:
                continue
            for prefix, cblas_suffix, f_suffix, int_t in (("scipy_", "64_", "_64_", ctypes.c_int64), ("", "64_", "_64_", ctypes.c_int64),
                                                          ("scipy_", "", "_", ctypes.c_int), ("", "", "_", ctypes.c_int)):
                gemm = getattr(lib, f"{prefix}cblas_dgemm{cblas_suffix}", None)
                syrk = getattr(lib, f"{prefix}cblas_dsyrk{cblas_suffix}", None)
                potrf = getattr(lib, f"{prefix}dpotrf{f_suffix}", None)
                if gemm is None or syrk is None or potrf is None:
                    continue
                i, d, p = ctypes.c_int, ctypes.c_double, ctypes.c_void_p
                gemm.argtypes = [i, i, i, int_t, int_t, int_t, d, p, int_t, p, int_t, d, p, int_t]
                gemm.restype = None
                syrk.argtypes = [i, i, i, int_t, int_t, d, p, int_t, d, p, int_t]
                syrk.restype = None
                potrf.argtypes = [ctypes.c_char_p, p, p, p, p, ctypes.c_size_t]
                potrf.restype = None
                self._gemm, self._syrk, self._potrf, self._int = gemm, syrk, potrf, int_t
                self.available = True
                break

    @contextmanager
    def single_thread(self) -> Iterator[None]:
        """Run the block with every loaded OpenBLAS on one thread per caller, then restore it.

        Why: (1) determinism: OpenBLAS's threaded Cholesky blocks the matrix by its thread count,
        so the last bits of a log det could depend on it; one BLAS thread per candidate keeps every
        number identical whatever ``jobs`` is. (2) speed: parallelism comes from scoring candidates
        on separate threads; on a busy 2-core machine OpenBLAS's own spinning threads were measured
        10-20x slower than one thread.
        """
        before = [get() for get, _ in self._threads]
        for _, put in self._threads:
            put(1)
        try:
            yield
        finally:
            for (_, put), n in zip(self._threads, before):
                put(n)

    def sub_aat(self, pc: int, ldc: int, pa: int, pb: int, m: int, n: int, k: int, same: bool) -> None:
        """C -= A @ B.T on raw row-major float64 blocks: C (m x n, leading dimension ldc) at address
        ``pc``, A (m x k) at ``pa``, B (n x k) at ``pb``; with ``same`` (A is B) only C's lower triangle."""
        if same:
            self._syrk(self.ROW_MAJOR, self.LOWER, self.NO_TRANS, m, k, -1.0, pa, k, 1.0, pc, ldc)
        else:
            self._gemm(self.ROW_MAJOR, self.NO_TRANS, self.TRANS, m, n, k, -1.0, pa, k, pb, k, 1.0, pc, ldc)

    def cholesky_logdet(self, p: np.ndarray) -> float:
        """log det of the symmetric positive definite ``p`` whose lower triangle is filled (destroys p) [nats]."""
        n = p.shape[0]
        nn, info = self._int(n), self._int(0)
        # row-major lower triangle = column-major upper triangle
        self._potrf(b"U", ctypes.addressof(nn), p.ctypes.data, ctypes.addressof(nn), ctypes.addressof(info), 1)
        if info.value != 0:
            raise np.linalg.LinAlgError(f"pose information matrix is not positive definite (dpotrf info {info.value})")
        return 2.0 * float(np.sum(np.log(np.diagonal(p))))


def _route_order(problem: Problem, landmarks: np.ndarray) -> np.ndarray:
    """``landmarks`` sorted by the route frame nearest to each (ties: by index).

    Landmarks near the same stretch of road are seen from the same keyframes, on every pass, so
    consecutive landmarks of this order share most of their keyframes: grouping them keeps the
    tiles of the Schur product nearly dense (measured on KITTI 00: ~25% fewer flops than a Z-order
    of the positions).
    """
    sc = problem.scenario
    route = (sc.route or sc.keyframes).poses[:, :2]
    _, frame = cKDTree(route).query(sc.landmarks[landmarks])
    return landmarks[np.lexsort((landmarks, frame))]


@dataclass(frozen=True, eq=False)
class _Layout:
    """Where the Schur product of one pattern of active pairs goes: tiles, BLAS calls, sparsity.

    A tile is the dense (3 x keyframes) x (2 x landmarks) block of Y for one landmark group, rows
    restricted to the keyframes that see the group. Each call accumulates one (run a, run b) block
    of tile @ tile.T into the lower triangle of the pose matrix, where a run is a range of
    consecutive keyframes of the tile (runs less than RUN_GAP keyframes apart joined).
    """

    act: np.ndarray  # (Pa,) active pair indices, sorted
    landmark: np.ndarray  # (Pa,) landmark of each active pair
    hpl: np.ndarray  # (12, Pa) hl_r (x) hp_r of each active pair, r = bearing (0:6), range (6:12)
    flat: np.ndarray  # (6 * Pa,) index into the tile buffer of each entry of Yᵀ, as (2, 3, Pa)
    size: int  # tile buffer length
    calls: list  # (a_off, b_off, c_off, m, n, k, same): P[c_off block m x n] -= A[a_off] @ A[b_off].T
    pattern: np.ndarray  # (K, K) bool: pose blocks of the lower triangle that can be non-zero
    density: float  # fraction of non-zero pose blocks of the full matrix


class _Scratch:
    """Reusable float64 buffers of one thread, handed out zeroed."""

    def __init__(self) -> None:
        self._arrays: dict[str, np.ndarray] = {}

    def array(self, name: str, size: int) -> np.ndarray:
        a = self._arrays.get(name)
        if a is None or a.size < size:
            a = self._arrays[name] = np.zeros(max(size, 1))
            return a[:size]
        a = a[:size]
        a.fill(0.0)
        return a


@dataclass(frozen=True, eq=False)
class _Base:
    """A base suite's state, shared by every candidate scored with it."""

    suite: Suite
    w: np.ndarray  # (2, P) information of each measurement row (bearing, range) of each pair (0: not measured)
    d: np.ndarray  # (M, 3) landmark information d00, d01, d11
    a: np.ndarray  # (K, 6) measurement information on the pose diagonal blocks (unique entries)
    layout: _Layout
    wpl: np.ndarray  # (6, Pa) W_p = sum_r w_r hp_r hl_r^T of each active pair, entry c * 3 + a = W[a, c]


class _Structure:
    """Everything that does not depend on the suite, computed once per problem."""

    def __init__(self, problem: Problem) -> None:
        from .graph import linearize_library  # gtsam lives in graph.py

        lin = linearize_library(problem)
        self.blas = _Blas()
        self.n_poses = K = problem.scenario.n_poses
        self.n_landmarks = M = problem.scenario.n_landmarks
        self.n = 3 * K
        self.pair_pose = lin.pair_pose
        self.pair_landmark = lin.pair_landmark
        jac = lin.pair_jacobian
        hp, hl = jac[:, :, :3], jac[:, :, 3:]
        # rank-one pieces of one measurement row r (0 bearing, 1 range) at unit information, stored
        # one component per contiguous row (vector operations run over pairs, not over 2x3 blocks)
        self.hll = np.stack([np.stack([hl[:, r, 0] ** 2, hl[:, r, 0] * hl[:, r, 1], hl[:, r, 1] ** 2]) for r in range(2)])  # (2, 3, P)
        self.hpp = np.stack([np.stack([hp[:, r, i] * hp[:, r, j] for i, j in _SYM3]) for r in range(2)])  # (2, 6, P)
        # W_p = sum_r w_r hp_r hl_r^T is kept transposed: entry c * 3 + a = W[a, c]; rows 0:6 bearing, 6:12 range
        self.hpl = np.ascontiguousarray((hl[:, :, :, None] * hp[:, :, None, :]).reshape(-1, 12).T)  # (12, P)
        self.sensor_pairs = lin.sensor_pairs
        self.sensor_w = tuple(np.ascontiguousarray((1.0 / s**2).T) for s in lin.sensor_sigmas)  # (2, n_s)
        low = sp.tril(lin.base_pose_information).tocoo()
        self.base_index = low.row.astype(np.int64) * self.n + low.col  # lower triangle of the base on the poses
        self.base_values = low.data.copy()
        self._local = threading.local()
        bl = lin.base_landmark_information
        self.base_ll = np.stack([bl[:, 0, 0], bl[:, 0, 1], bl[:, 1, 1]])  # (3, M)
        k3 = 3 * np.arange(K)
        self.diag_index = np.stack([(k3 + j) * self.n + k3 + i for i, j in _SYM3])  # (6, K) lower-triangle flat
        bp = np.eye(K, dtype=bool)
        coo = lin.base_pose_information.tocoo()
        bp[coo.row // 3, coo.col // 3] = True
        self.base_pattern = np.tril(bp)
        # landmark groups: seen landmarks in route order, GROUP_SIZE per group
        seen = np.zeros(M, dtype=bool)
        seen[self.pair_landmark] = True
        idx = np.flatnonzero(seen)
        order = _route_order(problem, idx)
        self.group = np.full(M, -1, dtype=np.int64)
        self.group[order] = np.arange(len(order)) // GROUP_SIZE
        self.n_groups = -(-len(order) // GROUP_SIZE)
        self.landmark_order = order  # seen landmarks sorted by group

    # ---- suite-dependent pieces -------------------------------------------------------------

    def base(self, suite: Suite) -> _Base:
        """State of a suite: pair weights, sums, layout and W of its active pairs."""
        w = np.zeros((2, len(self.pair_pose)))
        for s in suite:
            w[:, self.sensor_pairs[s]] += self.sensor_w[s]
        act = np.flatnonzero(w[0] + w[1] > 0)
        d = self.base_ll.copy()
        a = np.zeros((6, self.n_poses))
        self._accumulate(d, a, act, w[:, act])
        layout = self.layout(act)
        return _Base(suite, w, d, a, layout, self._wpl(w[:, act], layout.hpl))

    @staticmethod
    def _wpl(w: np.ndarray, hpl: np.ndarray) -> np.ndarray:
        """W of pairs with row weights ``w`` (2, n) and pieces ``hpl`` (12, n): (6, n)."""
        return w[0] * hpl[:6] + w[1] * hpl[6:]

    def _accumulate(self, d: np.ndarray, a: np.ndarray, pairs: np.ndarray, w: np.ndarray) -> None:
        """Add the landmark (d: 3, M) and pose-diagonal (a: 6, K) information of ``pairs`` with row weights ``w`` (2, n)."""
        lm, ps = self.pair_landmark[pairs], self.pair_pose[pairs]
        hll = np.take(self.hll, pairs, axis=2)
        hpp = np.take(self.hpp, pairs, axis=2)
        for i in range(3):
            d[i] += np.bincount(lm, w[0] * hll[0, i] + w[1] * hll[1, i], self.n_landmarks)
        for i in range(6):
            a[i] += np.bincount(ps, w[0] * hpp[0, i] + w[1] * hpp[1, i], self.n_poses)

    def layout(self, act: np.ndarray) -> _Layout:
        """Tiles and BLAS calls of the Schur product for the active pairs ``act`` (sorted pair indices)."""
        K, M, n = self.n_poses, self.n_landmarks, self.n
        lm, ps = self.pair_landmark[act], self.pair_pose[act]
        g = self.group[lm]
        # columns: the active landmarks of each group, 2 each, in group order
        lm_on = np.zeros(M, dtype=bool)
        lm_on[lm] = True
        on_sorted = lm_on[self.landmark_order]
        grp_sorted = self.group[self.landmark_order]
        ncols = 2 * np.bincount(grp_sorted[on_sorted], minlength=self.n_groups)
        first_rank = np.concatenate([[0], np.cumsum(ncols // 2)])[:-1]
        col_of = np.zeros(M, dtype=np.int64)
        col_of[self.landmark_order] = 2 * (np.cumsum(on_sorted) - 1 - first_rank[grp_sorted])
        # rows: runs of consecutive keyframes that see each group, 3 rows each; runs of a group
        # less than RUN_GAP keyframes apart are joined (zero rows in between: fewer, larger calls)
        mask = np.zeros((self.n_groups, K), dtype=bool)
        mask[g, ps] = True
        edge = np.diff(np.pad(mask, ((0, 0), (1, 1))).astype(np.int8), axis=1)
        rg, rs = np.nonzero(edge == 1)
        re = np.nonzero(edge == -1)[1]  # runs in (group, start) order, as the starts
        if len(rg) > 1:
            join = (rg[1:] == rg[:-1]) & (rs[1:] - re[:-1] <= RUN_GAP)
            rg, rs, re = rg[np.r_[True, ~join]], rs[np.r_[True, ~join]], re[np.r_[~join, True]]
        length = re - rs
        n_runs = np.bincount(rg, minlength=self.n_groups)
        first_run = np.concatenate([[0], np.cumsum(n_runs)])[:-1]
        cum = np.cumsum(length) - length
        row0 = cum - cum[first_run[rg]] if len(rg) else cum  # first keyframe row of each run in its tile
        nrows = 3 * np.bincount(rg, weights=length, minlength=self.n_groups).astype(np.int64)
        off = np.concatenate([[0], np.cumsum(nrows * ncols)])
        run = np.searchsorted(rg * K + rs, g * K + ps, side="right") - 1  # the run holding each pair's keyframe
        local = row0[run] + ps - rs[run]
        base = off[g] + 3 * local * ncols[g] + col_of[lm]
        nc = ncols[g]
        flat = np.concatenate([base + c + i * nc for c in range(2) for i in range(3)])
        # run pairs (a, b) of the same group with b <= a: the lower triangle
        cnt = np.arange(len(rg)) - first_run[rg] + 1
        ia = np.repeat(np.arange(len(rg)), cnt)
        ib = np.arange(len(ia)) - np.repeat(np.cumsum(cnt) - cnt, cnt) + first_run[rg[ia]]
        k = ncols[rg[ia]]
        a_off = off[rg[ia]] + 3 * row0[ia] * k
        b_off = off[rg[ia]] + 3 * row0[ib] * k
        c_off = 3 * rs[ia] * n + 3 * rs[ib]
        calls = list(zip(a_off.tolist(), b_off.tolist(), c_off.tolist(), (3 * length[ia]).tolist(), (3 * length[ib]).tolist(),
                         k.tolist(), (ia == ib).tolist()))
        # pose-block pattern of the lower triangle: keyframes that see a common group (a superset
        # of the exact pattern whose extra entries are exact zeros)
        mf = mask.astype(np.float32)
        pattern = np.tril(((mf.T @ mf) > 0) | self.base_pattern)
        density = (2 * int(np.count_nonzero(pattern)) - K) / float(K * K)
        return _Layout(act, lm, np.take(self.hpl, act, axis=1), flat, int(off[-1]), calls, pattern, density)

    def _scratch(self) -> "_Scratch":
        """This thread's reusable zeroed buffers (the large arrays of one evaluation)."""
        sc = getattr(self._local, "scratch", None)
        if sc is None:
            sc = self._local.scratch = _Scratch()
        return sc

    def logdet(self, wpl: np.ndarray, d: np.ndarray, a: np.ndarray, layout: _Layout) -> float:
        """log det L [nats] from W of the active pairs ``wpl`` (6, Pa; overwritten), landmark sums ``d``
        (3, M), pose-diagonal sums ``a`` (6, K)."""
        # landmark blocks: D_j = L_j L_j^T (2x2 Cholesky, vectorized)
        l11 = np.sqrt(d[0])
        l21 = d[1] / l11
        l22 = np.sqrt(d[2] - l21 * l21)
        logdet = 2.0 * float(np.sum(np.log(l11 * l22)))
        # Y_p = W_p L_j^{-T}, in place on wpl (its (2, 3) rows are W's columns): with L^{-1} =
        # [[1/l11, 0], [-l21/(l11 l22), 1/l22]], Y[:, 0] = W[:, 0] / l11 and
        # Y[:, 1] = W[:, 1] / l22 - W[:, 0] l21 / (l11 l22)
        lm = layout.landmark
        y = wpl.reshape(2, 3, -1)
        y[1] *= np.take(1.0 / l22, lm)
        y[1] -= y[0] * np.take(l21 / (l11 * l22), lm)
        y[0] *= np.take(1.0 / l11, lm)
        scratch = self._scratch()
        buf = scratch.array("tiles", layout.size)
        buf[layout.flat] = wpl.ravel()
        # pose Schur complement (lower triangle): base + measurement diagonal - sum_j Y_j Y_j^T
        P = scratch.array("pose", self.n * self.n).reshape(self.n, self.n)
        P.ravel()[self.base_index] = self.base_values
        P.ravel()[self.diag_index] += a
        blas = self.blas
        if blas.available:
            pa, pc = buf.ctypes.data, P.ctypes.data
            for a_off, b_off, c_off, m, n, k, same in layout.calls:
                blas.sub_aat(pc + 8 * c_off, self.n, pa + 8 * a_off, pa + 8 * b_off, m, n, k, same)
        else:
            for a_off, b_off, c_off, m, n, k, same in layout.calls:
                t = buf[a_off: a_off + m * k].reshape(m, k)
                u = buf[b_off: b_off + n * k].reshape(n, k)
                r0, c0 = divmod(c_off, self.n)
                P[r0: r0 + m, c0: c0 + n] -= t @ u.T
        if layout.density < SPARSE_BELOW:
            return logdet + self._sparse_logdet(P, layout.pattern)
        if blas.available:
            return logdet + blas.cholesky_logdet(P)
        return logdet + 2.0 * float(np.sum(np.log(np.diagonal(np.linalg.cholesky(P)))))

    def _sparse_logdet(self, P: np.ndarray, pattern: np.ndarray) -> float:
        """log det of the matrix whose lower triangle is in ``P``, non-zero only on ``pattern`` pose blocks."""
        kr, kc = np.nonzero(pattern)
        i = (3 * kr[:, None] + np.arange(3)[None, :]).repeat(3, axis=1).ravel()
        j = np.tile(3 * kc[:, None] + np.arange(3)[None, :], (1, 3)).ravel()
        low = i >= j
        i, j = i[low], j[low]
        v = P[i, j]
        off = i > j
        rows = np.concatenate([i, j[off]])
        cols = np.concatenate([j, i[off]])
        vals = np.concatenate([v, v[off]])
        S = sp.csc_matrix((vals, (rows, cols)), shape=P.shape)
        lu = spla.splu(S, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options=dict(SymmetricMode=True))
        u = lu.U.diagonal()
        if np.any(u <= 0):
            raise np.linalg.LinAlgError("pose information matrix is not positive definite")
        return float(np.sum(np.log(u)))

    def candidate(self, base: _Base, c: int) -> float:
        """log det L(base + {c}) [nats]."""
        if c in base.suite:
            return self.logdet(base.wpl.copy(), base.d, base.a, base.layout)
        pairs, wc = self.sensor_pairs[c], self.sensor_w[c]
        d, a = base.d.copy(), base.a.copy()
        self._accumulate(d, a, pairs, wc)
        layout = base.layout
        act = layout.act
        at = np.searchsorted(act, pairs)
        if len(pairs) and (at[-1] >= len(act) or np.any(act[np.minimum(at, len(act) - 1)] != pairs)):
            # the candidate measures pairs the base does not: a layout of its own
            w = base.w.copy()
            w[:, pairs] += wc
            layout = self.layout(np.flatnonzero(w[0] + w[1] > 0))
            wpl = self._wpl(w[:, layout.act], layout.hpl)
        else:
            wpl = base.wpl.copy()
            wpl[:, at] += self._wpl(wc, np.take(self.hpl, pairs, axis=1))
        return self.logdet(wpl, d, a, layout)


class FastEvaluator(Evaluator):
    """Exact log det from per-sensor linearized pieces computed once (see the module docstring)."""

    name = "fast"

    def __init__(self, problem: Problem, *, jobs: int = 1, threads_from_keyframes: int = THREADS_FROM_KEYFRAMES) -> None:
        """``threads_from_keyframes``: use the ``jobs`` threads only on routes with at least this many
        keyframes (speed only: the numbers are the same either way)."""
        super().__init__(problem, jobs=jobs)
        self._threads_from = int(threads_from_keyframes)
        self._s = _Structure(problem)
        self._base: _Base | None = None
        self._pool: ThreadPoolExecutor | None = None

    def _threads(self) -> ThreadPoolExecutor:
        """The evaluator's worker threads, started once (a pool per call cost more than a 03 candidate)."""
        if self._pool is None:
            self._pool = ThreadPoolExecutor(max_workers=self.jobs, thread_name_prefix="sensorsel-fast")
            weakref.finalize(self, self._pool.shutdown, wait=False)
        return self._pool

    def _base_for(self, suite: Suite) -> _Base:
        if self._base is None or self._base.suite != suite:
            self._base = self._s.base(suite)
        return self._base

    def _logdet(self, suite: Suite) -> float:
        with self._s.blas.single_thread():
            b = self._base_for(suite)
            return self._s.logdet(b.wpl.copy(), b.d, b.a, b.layout)

    def scores_with(self, suite: Iterable[int], candidates: Sequence[int]) -> np.ndarray:
        base = as_suite(suite)
        cands = [int(c) for c in candidates]
        for i in base + tuple(cands):
            if not 0 <= i < self.problem.n_sensors:
                raise InputError(f"sensor position {i} is outside the library (0..{self.problem.n_sensors - 1})")
        baseline = self.baseline_logdet
        with self._s.blas.single_thread():
            b = self._base_for(base)
            if self.jobs > 1 and len(cands) > 1 and self._s.n_poses >= self._threads_from:
                vals = list(self._threads().map(lambda c: self._s.candidate(b, c), cands))
            else:
                vals = [self._s.candidate(b, c) for c in cands]
        self.n_evaluations += len(cands)
        return np.array(vals, dtype=float) - baseline
