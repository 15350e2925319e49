"""The fast engine: the reference's numbers without rebuilding or relinearizing anything.

(docstring: method and measurements; written below once measured)
"""

from __future__ import annotations

import ctypes
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Iterable, Iterator, Sequence

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .errors import InputError
from .objective import Evaluator, Suite, as_suite
from .problem import Problem

#: landmarks per group of the Schur product (one GEMM per group), and the grid cell [m] used to
#: sort landmarks along a Z-order curve so that a group's landmarks are seen from the same keyframes
GROUP_SIZE = 32
CELL_M = 5.0
#: below this fraction of non-zero pose blocks the pose matrix is factored as a sparse matrix
SPARSE_BELOW = 0.06

_SYM3 = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))  # unique entries of a symmetric 3x3


def _openblas_thread_setters() -> list[tuple[object, object]]:
    """(get, set) of the number of threads of every OpenBLAS loaded in this process (Linux), else []."""
    found = []
    try:
        with open("/proc/self/maps") as fh:
            paths = sorted({line.split()[-1] for line in fh if "openblas" in line.rsplit("/", 1)[-1].lower()})
    except OSError:
        return found
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
                found.append((get, put))
                break
    return found


@contextmanager
def single_threaded_blas() -> Iterator[None]:
    """Run the block with OpenBLAS on one thread per caller, then restore its setting.

    Why: (1) determinism: OpenBLAS's threaded Cholesky blocks the matrix by its thread count, so
    the last bits of a log det could depend on it; one BLAS thread per candidate keeps every number
    identical whatever ``jobs`` is. (2) speed: parallelism comes from scoring candidates on separate
    threads (numpy's matmul and cholesky release the GIL); on a busy 2-core machine OpenBLAS's own
    spinning threads were measured 10-20x slower than one thread.
    """
    setters = _openblas_thread_setters()
    before = [get() for get, _ in setters]
    for _, put in setters:
        put(1)
    try:
        yield
    finally:
        for (_, put), n in zip(setters, before):
            put(n)


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
                return

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


def _zorder(xy: np.ndarray, cell: float) -> np.ndarray:
    """Order of 2-D points along a Z-order (Morton) curve of square cells of side ``cell``."""
    if len(xy) == 0:
        return np.zeros(0, dtype=np.int64)
    q = np.floor((xy - xy.min(axis=0)) / cell).astype(np.int64)
    code = np.zeros(len(xy), dtype=np.int64)
    for b in range(31):
        code |= ((q[:, 0] >> b) & 1) << (2 * b) | ((q[:, 1] >> b) & 1) << (2 * b + 1)
    return np.lexsort((np.arange(len(xy)), code))


@dataclass(frozen=True, eq=False)
class _Layout:
    """Where the Schur product of one pattern of active pairs goes: tiles, BLAS calls, sparsity.

    A tile is the dense (3 x keyframes) x (2 x landmarks) block of Y for one landmark group, rows
    restricted to the keyframes that see the group. Each call accumulates one (run a, run b) block
    of tile @ tile.T into the lower triangle of the pose matrix, where a run is a maximal range of
    consecutive keyframes of the tile.
    """

    act: np.ndarray  # (Pa,) active pair indices, sorted
    landmark: np.ndarray  # (Pa,) landmark of each active pair
    hpl: tuple[np.ndarray, np.ndarray]  # (Pa, 6) hp_r (x) hl_r of each active pair, r = bearing, range
    flat: np.ndarray  # (Pa * 6,) index into the tile buffer of each entry of Y (Pa, 3, 2)
    size: int  # tile buffer length
    calls: list  # (a_off, b_off, c_off, m, n, k, same): P[c_off block m x n] -= A[a_off] @ A[b_off].T
    pattern: np.ndarray  # (K, K) bool: pose blocks of the lower triangle that can be non-zero
    density: float  # fraction of non-zero pose blocks of the full matrix


@dataclass(frozen=True, eq=False)
class _Base:
    """A base suite's state, shared by every candidate scored with it."""

    suite: Suite
    w: np.ndarray  # (P, 2) information of each measurement row of each pair (0: not measured)
    d: np.ndarray  # (M, 3) landmark information d00, d01, d11
    a: np.ndarray  # (K, 6) measurement information on the pose diagonal blocks (unique entries)
    layout: _Layout
    wpl: np.ndarray  # (Pa, 6) W_p = sum_r w_r hp_r hl_r^T of each active pair


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
        # rank-one pieces of one measurement row r (0 bearing, 1 range) at unit information
        self.hll = tuple(np.ascontiguousarray(np.stack([hl[:, r, 0] ** 2, hl[:, r, 0] * hl[:, r, 1], hl[:, r, 1] ** 2], 1)) for r in range(2))
        self.hpl = tuple(np.ascontiguousarray((hp[:, r, :, None] * hl[:, r, None, :]).reshape(-1, 6)) for r in range(2))
        self.hpp = tuple(np.ascontiguousarray(np.stack([hp[:, r, i] * hp[:, r, j] for i, j in _SYM3], 1)) for r in range(2))
        self.sensor_pairs = lin.sensor_pairs
        self.sensor_w = tuple(np.ascontiguousarray(1.0 / s**2) for s in lin.sensor_sigmas)  # (n_s, 2)
        self.base_pp = np.ascontiguousarray(lin.base_pose_information.toarray())
        bl = lin.base_landmark_information
        self.base_ll = np.stack([bl[:, 0, 0], bl[:, 0, 1], bl[:, 1, 1]], 1)
        k3 = 3 * np.arange(K)
        self.diag_index = np.stack([(k3 + j) * self.n + k3 + i for i, j in _SYM3], 1)  # (K, 6) lower-triangle flat
        bp = np.abs(lin.base_pose_information.toarray().reshape(K, 3, K, 3)).sum(axis=(1, 3)) > 0
        self.base_pattern = np.tril(bp | np.eye(K, dtype=bool))
        # landmark groups: seen landmarks in Z-order of position, GROUP_SIZE per group
        seen = np.zeros(M, dtype=bool)
        seen[self.pair_landmark] = True
        idx = np.flatnonzero(seen)
        order = idx[_zorder(problem.scenario.landmarks[idx], CELL_M)]
        self.group = np.full(M, -1, dtype=np.int64)
        self.group[order] = np.arange(len(order)) // GROUP_SIZE
        self.n_groups = -(-len(order) // GROUP_SIZE)
        self.landmark_order = order  # seen landmarks sorted by group

    # ---- suite-dependent pieces -------------------------------------------------------------

    def base(self, suite: Suite) -> _Base:
        """State of a suite: pair weights, sums, layout and W of its active pairs."""
        w = np.zeros((len(self.pair_pose), 2))
        for s in suite:
            w[self.sensor_pairs[s]] += self.sensor_w[s]
        act = np.flatnonzero(w[:, 0] + w[:, 1] > 0)
        d = self.base_ll.copy()
        a = np.zeros((self.n_poses, 6))
        self._accumulate(d, a, act, w[act])
        layout = self.layout(act)
        wa = w[act]
        wpl = wa[:, 0:1] * layout.hpl[0] + wa[:, 1:2] * layout.hpl[1]
        return _Base(suite, w, d, a, layout, wpl)

    def _accumulate(self, d: np.ndarray, a: np.ndarray, pairs: np.ndarray, w: np.ndarray) -> None:
        """Add the landmark and pose-diagonal information of ``pairs`` with row weights ``w`` (n, 2)."""
        lm, ps = self.pair_landmark[pairs], self.pair_pose[pairs]
        for i in range(3):
            d[:, i] += np.bincount(lm, w[:, 0] * self.hll[0][pairs, i] + w[:, 1] * self.hll[1][pairs, i], self.n_landmarks)
        for i in range(6):
            a[:, i] += np.bincount(ps, w[:, 0] * self.hpp[0][pairs, i] + w[:, 1] * self.hpp[1][pairs, i], self.n_poses)

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
        # rows: the keyframes that see each group, 3 each, in keyframe order
        mask = np.zeros((self.n_groups, K), dtype=bool)
        mask[g, ps] = True
        pos = np.cumsum(mask, axis=1) - 1
        nrows = 3 * mask.sum(axis=1)
        off = np.concatenate([[0], np.cumsum(nrows * ncols)])
        base = off[g] + 3 * pos[g, ps] * ncols[g] + col_of[lm]
        flat = (base[:, None, None] + np.arange(3)[None, :, None] * ncols[g][:, None, None] + np.arange(2)[None, None, :]).ravel()
        # runs of consecutive keyframes in each group's rows
        edge = np.diff(np.pad(mask, ((0, 0), (1, 1))).astype(np.int8), axis=1)
        rg, rs = np.nonzero(edge == 1)
        _, re = np.nonzero(edge == -1)  # same (group, order) as the starts
        n_runs = np.bincount(rg, minlength=self.n_groups)
        first_run = np.concatenate([[0], np.cumsum(n_runs)])[:-1]
        # run pairs (a, b) of the same group with b <= a: the lower triangle
        cnt = np.arange(len(rg)) - first_run[rg] + 1
        ia = np.repeat(np.arange(len(rg)), cnt)
        ib = np.arange(len(ia)) - np.repeat(np.cumsum(cnt) - cnt, cnt) + first_run[rg[ia]]
        gg = rg[ia]
        k = ncols[gg]
        a_off = off[gg] + 3 * pos[gg, rs[ia]] * k
        b_off = off[gg] + 3 * pos[gg, rs[ib]] * k
        c_off = 3 * rs[ia] * n + 3 * rs[ib]
        m_, n_ = 3 * (re[ia] - rs[ia]), 3 * (re[ib] - rs[ib])
        calls = list(zip(a_off.tolist(), b_off.tolist(), c_off.tolist(), m_.tolist(), n_.tolist(), k.tolist(), (ia == ib).tolist()))
        # pose-block pattern of the lower triangle
        pattern = self.base_pattern.copy()
        for i, j in zip(ia.tolist(), ib.tolist()):
            pattern[rs[i]: re[i], rs[j]: re[j]] = True
        pattern = np.tril(pattern)
        density = (2 * int(pattern.sum()) - K) / float(K * K)
        hpl = (np.ascontiguousarray(self.hpl[0][act]), np.ascontiguousarray(self.hpl[1][act]))
        return _Layout(act, lm, hpl, flat, int(off[-1]), calls, pattern, density)

    def logdet(self, wpl: np.ndarray, d: np.ndarray, a: np.ndarray, layout: _Layout) -> float:
        """log det L [nats] from W of the active pairs ``wpl`` (Pa, 6), landmark sums ``d``, pose sums ``a``."""
        # landmark blocks: D_j = L_j L_j^T (2x2 Cholesky, vectorized)
        l11 = np.sqrt(d[:, 0])
        l21 = d[:, 1] / l11
        l22 = np.sqrt(d[:, 2] - l21 * l21)
        logdet = 2.0 * float(np.sum(np.log(l11 * l22)))
        # Y_p = W_p L_j^{-T} (3x2 per active pair)
        lm = layout.landmark
        w3 = wpl.reshape(-1, 3, 2)
        y = np.empty_like(w3)
        y[:, :, 0] = w3[:, :, 0] / l11[lm, None]
        y[:, :, 1] = (w3[:, :, 1] - l21[lm, None] * y[:, :, 0]) / l22[lm, None]
        buf = np.zeros(layout.size)
        buf[layout.flat] = y.ravel()
        # pose Schur complement (lower triangle): base + measurement diagonal - sum_j Y_j Y_j^T
        P = self.base_pp.copy()
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
            return self.logdet(base.wpl, base.d, base.a, base.layout)
        pairs, wc = self.sensor_pairs[c], self.sensor_w[c]
        d, a = base.d.copy(), base.a.copy()
        self._accumulate(d, a, pairs, wc)
        layout = base.layout
        act = layout.act
        at = np.searchsorted(act, pairs)
        if len(pairs) and (at[-1] >= len(act) or np.any(act[np.minimum(at, len(act) - 1)] != pairs)):
            # the candidate measures pairs the base does not: a layout of its own
            w = base.w.copy()
            w[pairs] += wc
            layout = self.layout(np.flatnonzero(w[:, 0] + w[:, 1] > 0))
            wa = w[layout.act]
            wpl = wa[:, 0:1] * layout.hpl[0] + wa[:, 1:2] * layout.hpl[1]
        else:
            wpl = base.wpl.copy()
            wpl[at] += wc[:, 0:1] * self.hpl[0][pairs] + wc[:, 1:2] * self.hpl[1][pairs]
        return self.logdet(wpl, d, a, layout)


class FastEvaluator(Evaluator):
    """Exact log det from per-sensor linearized pieces computed once (see the module docstring)."""

    name = "fast"

    def __init__(self, problem: Problem, *, jobs: int = 1) -> None:
        super().__init__(problem, jobs=jobs)
        self._s = _Structure(problem)
        self._base: _Base | None = None

    def _base_for(self, suite: Suite) -> _Base:
        if self._base is None or self._base.suite != suite:
            self._base = self._s.base(suite)
        return self._base

    def _logdet(self, suite: Suite) -> float:
        with single_threaded_blas():
            b = self._base_for(suite)
            return self._s.logdet(b.wpl, b.d, b.a, b.layout)

    def scores_with(self, suite: Iterable[int], candidates: Sequence[int]) -> np.ndarray:
        base = as_suite(suite)
        cands = [int(c) for c in candidates]
        for i in base + tuple(cands):
            if not 0 <= i < self.problem.n_sensors:
                raise InputError(f"sensor position {i} is outside the library (0..{self.problem.n_sensors - 1})")
        baseline = self.baseline_logdet
        with single_threaded_blas():
            b = self._base_for(base)
            if self.jobs > 1 and len(cands) > 1:
                with ThreadPoolExecutor(max_workers=min(self.jobs, len(cands))) as pool:
                    vals = list(pool.map(lambda c: self._s.candidate(b, c), cands))
            else:
                vals = [self._s.candidate(b, c) for c in cands]
        self.n_evaluations += len(cands)
        return np.array(vals, dtype=float) - baseline
