"""The numeric kernel: log det of a suite's information from its sums, by a frontal block
Cholesky of the whole information matrix (:mod:`.front`), or by the Schur complement on the poses
and a dense Cholesky (LAPACK dpotrf) or a sparse LU (SuperLU) of it.

The kernel never writes to its inputs: the tiles, Y and the pose matrix are scratch buffers it
owns, one set per thread.
"""

from __future__ import annotations

import threading
import weakref
from collections import Counter

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from sensorsel.information.evaluators.fast.blas import Blas
from sensorsel.information.evaluators.fast.front import (
    CHUNK_POSES,
    FrontPlan,
    front_flops,
    front_logdet,
    front_pose_covariances,
    plan_front,
)
from sensorsel.information.evaluators.fast.plan import Layout

#: below this fraction of non-zero pose blocks the pose matrix is factored as a sparse matrix
SPARSE_BELOW = 0.11

#: the frontal path (:mod:`.front`) is taken when its predicted flops are below this fraction of the
#: dense pose Cholesky's (3K)³/3 (it also skips the dense path's Schur assembly; crossover measured
#: per evaluation on KITTI 00/02/08 at 1 Hz: equal time at ~1.0-1.2x the flops, see docs/speed.md)
FRONT_BELOW = 1.0
#: below this many keyframes the frontal path is not even predicted (unless forced by a ``front_below``
#: above :data:`FRONT_BELOW`): the dense Cholesky of a matrix under 300 x 300 takes ~0.1 ms, and the
#: prediction (four keyframe orders) cost more than that on KITTI 03, where dense always won
FRONT_FROM_KEYFRAMES = 100

#: the unique entries (row, column) of a symmetric 3x3, in the order of the pose-diagonal sums
SYM3 = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))  # unique entries of a symmetric 3x3


class _Scratch:
    """Reusable float64 buffers of one thread, handed out zeroed."""

    def __init__(self) -> None:
        self._arrays: dict[str, np.ndarray] = {}

    def array(self, name: str, size: int, *, zeroed: bool = True) -> np.ndarray:
        """A (size,) view of this thread's buffer ``name``, zero-filled unless ``zeroed`` is False."""
        a = self._arrays.get(name)
        if a is None or a.size < size:
            a = self._arrays[name] = np.zeros(max(size, 1))
            return a[:size]
        a = a[:size]
        if zeroed:
            a.fill(0.0)
        return a


class Kernel:
    """log det L [nats] of one problem's suites from their landmark, pose and coupling sums.

    Args:
        n_poses: K, the number of keyframes (the pose matrix is 3K x 3K).
        base_pose_information: (3K, 3K) sparse information of the base graph on the poses.
        blas: the BLAS/LAPACK access (function pointers, thread control).
        sparse_below: factor the pose matrix with SuperLU when fewer than this fraction of its
            pose blocks can be non-zero, else with dense Cholesky.
        inplace: accumulate the Schur product with in-place BLAS calls (True) or with numpy
            (``P[block] -= A @ B.T``, a temporary per call; a cross-check, same numbers to round-off).

    Attributes:
        counts: how many times each path was taken, by name: "syrk", "gemm" (in-place BLAS calls),
            "numpy" (numpy block products), "potrf" (dense Cholesky), "splu" (sparse LU), "front"
            (frontal elimination, :mod:`.front`).
    """

    def __init__(
        self,
        n_poses: int,
        base_pose_information: sp.spmatrix,
        blas: Blas,
        *,
        sparse_below: float = SPARSE_BELOW,
        front_below: float = FRONT_BELOW,
        chunk_poses: int = CHUNK_POSES,
        pose_orders: dict[str, np.ndarray] | None = None,
        inplace: bool = True,
    ) -> None:
        self.n = n = 3 * n_poses
        self.pose_orders = pose_orders or {"route": np.arange(n_poses)}
        self.n_poses = n_poses
        self.front_below = float(front_below)
        self.chunk_poses = int(chunk_poses)
        self._fronts: weakref.WeakKeyDictionary[Layout, FrontPlan] = weakref.WeakKeyDictionary()
        self._choices: weakref.WeakKeyDictionary[Layout, tuple[str, float]] = weakref.WeakKeyDictionary()
        self.blas = blas
        self.sparse_below = float(sparse_below)
        self.inplace = bool(inplace)
        low = sp.tril(base_pose_information).tocsr().tocoo()  # duplicates summed
        # lower triangle of the base on the poses, and of the pose-diagonal sums (6, K): (row, column)
        self._base_rc = (low.row.astype(np.int64), low.col.astype(np.int64))
        self.base_values = low.data.copy()
        k3 = 3 * np.arange(n_poses)
        self._diag_rc = (np.stack([k3 + j for i, j in SYM3]), np.stack([k3 + i for i, j in SYM3]))
        self.base_index = self._base_rc[0] * n + self._base_rc[1]
        self.diag_index = self._diag_rc[0] * n + self._diag_rc[1]
        self._ldc = np.array([n], dtype=np.intc)  # leading dimension of the pose matrix, for BLAS
        self._local = threading.local()
        self._lock = threading.Lock()
        self.counts: Counter[str] = Counter()

    def front_choice(self, layout: Layout, n_landmarks: int) -> tuple[str, float]:
        """(keyframe order, predicted flops) of the cheapest frontal plan of ``layout`` over
        :attr:`pose_orders` (from the alive intervals alone; cached per layout, depends on it alone)."""
        with self._lock:
            got = self._choices.get(layout)
        if got is None:
            got = min(
                (
                    (
                        front_flops(
                            layout.pose,
                            layout.landmark,
                            self.n_poses,
                            n_landmarks,
                            self._base_rc,
                            self.chunk_poses,
                            order,
                        ),
                        name,
                    )
                    for name, order in self.pose_orders.items()
                ),
                key=lambda x: (x[0], x[1]),
            )[::-1]
            with self._lock:
                self._choices[layout] = got
        return got

    def front_plan(self, layout: Layout, n_landmarks: int) -> FrontPlan:
        """The frontal plan of ``layout`` in its cheapest keyframe order, built once per layout."""
        with self._lock:
            plan = self._fronts.get(layout)
        if plan is None:
            name, _ = self.front_choice(layout, n_landmarks)
            plan = plan_front(
                layout.pose,
                layout.landmark,
                self.n_poses,
                n_landmarks,
                self._base_rc,
                self.base_values,
                self.chunk_poses,
                self.pose_orders[name],
                name,
            )
            with self._lock:
                self._fronts[layout] = plan
        return plan

    def uses_front(self, layout: Layout, n_landmarks: int) -> bool:
        """Whether ``layout`` is factored by the frontal path: predicted flops below ``front_below``
        times the dense Cholesky's."""
        if self.front_below <= 0 or (self.n_poses < FRONT_FROM_KEYFRAMES and self.front_below <= FRONT_BELOW):
            return False
        return self.front_choice(layout, n_landmarks)[1] < self.front_below * self.n**3 / 3.0

    def _scratch(self) -> _Scratch:
        """This thread's reusable buffers (the large arrays of one evaluation)."""
        sc = getattr(self._local, "scratch", None)
        if sc is None:
            sc = self._local.scratch = _Scratch()
        return sc

    def _count(self, **paths: int) -> None:
        with self._lock:
            self.counts.update(paths)

    def logdet(self, wpl: np.ndarray, d: np.ndarray, a: np.ndarray, layout: Layout) -> float:
        """log det L [nats]; no argument is written to.

        Args:
            wpl: (6, Pa) W of each active pair of ``layout``: entry c * 3 + a = W[a, c], W = Σ_r w_r hp_r hl_rᵀ
                (pose rows a, landmark columns c).
            d: (3, M) landmark information sums d00, d01, d11.
            a: (6, K) pose-diagonal information sums from measurements (unique entries of each 3x3).
            layout: the tiles and calls of the active pairs.
        """
        if self.uses_front(layout, d.shape[1]):
            plan = self.front_plan(layout, d.shape[1])
            self._count(front=1)
            return front_logdet(plan, wpl, d, a, self.blas, self._front_buffers(plan))
        scratch = self._scratch()
        n = self.n
        P = scratch.array("pose", n * n).reshape(n, n)
        logdet = self._schur(P, wpl, d, a, layout)
        if layout.density_below(self.sparse_below):
            self._count(splu=1)
            return logdet + self._sparse_logdet(P, layout.pattern)
        self._count(potrf=1)
        return logdet + self.blas.cholesky_logdet(P)

    def _front_buffers(self, plan: FrontPlan) -> tuple[np.ndarray, np.ndarray]:
        """The two scratch buffers of the frontal elimination, ``plan.max_front``² floats each (not zeroed)."""
        scratch = self._scratch()
        size = plan.max_front**2
        return scratch.array("front0", size, zeroed=False), scratch.array("front1", size, zeroed=False)

    def _schur(self, P: np.ndarray, wpl: np.ndarray, d: np.ndarray, a: np.ndarray, layout: Layout) -> float:
        """Fill the lower triangle of the zeroed (3K, 3K) ``P`` with the pose Schur complement
        (base + measurement diagonal - Σ_j W_j D_j⁻¹ W_jᵀ) and return Σ_j log det D_j [nats]
        (arguments as in :meth:`logdet`; none but ``P`` is written to)."""
        # landmark blocks: D_j = L_j L_j^T (2x2 Cholesky, vectorized)
        l11 = np.sqrt(d[0])
        l21 = d[1] / l11
        l22 = np.sqrt(d[2] - l21 * l21)
        logdet = 2.0 * float(np.sum(np.log(l11 * l22)))
        # Y_p = W_p L_j^{-T} (its (2, 3) rows are W's columns): with L^{-1} =
        # [[1/l11, 0], [-l21/(l11 l22), 1/l22]], Y[:, 0] = W[:, 0] / l11 and
        # Y[:, 1] = W[:, 1] / l22 - W[:, 0] l21 / (l11 l22)
        lm = layout.landmark
        scratch = self._scratch()
        w = wpl.reshape(2, 3, -1)
        y = scratch.array("y", wpl.size, zeroed=False).reshape(w.shape)
        np.multiply(w[1], np.take(1.0 / l22, lm), out=y[1])
        y[1] -= w[0] * np.take(l21 / (l11 * l22), lm)
        np.multiply(w[0], np.take(1.0 / l11, lm), out=y[0])
        buf = scratch.array("tiles", layout.size)
        buf[layout.flat] = y.ravel()
        # pose Schur complement (lower triangle): base + measurement diagonal - sum_j Y_j Y_j^T
        P.ravel()[self.base_index] = self.base_values
        P.ravel()[self.diag_index] += a
        self._subtract_products(P, buf, layout)
        return logdet

    def pose_matrix(self, wpl: np.ndarray, d: np.ndarray, a: np.ndarray, layout: Layout) -> np.ndarray:
        """The pose Schur complement P (3K, 3K) of a suite, lower triangle filled (upper: zeros), a
        new array (arguments as in :meth:`logdet`): what :mod:`.bound` inverts."""
        P = np.zeros((self.n, self.n))
        self._schur(P, wpl, d, a, layout)
        return P

    def pose_covariances(self, wpl: np.ndarray, d: np.ndarray, a: np.ndarray, layout: Layout) -> np.ndarray:
        """(K, 3, 3) diagonal blocks of P⁻¹ (the poses' marginal covariances; arguments as in
        :meth:`logdet`), on the path :meth:`logdet` takes: by selected inversion on the frontal
        elimination (:func:`.front.front_pose_covariances`, linear in the route), or
        :func:`pose_marginals` of the dense :meth:`pose_matrix`."""
        if self.uses_front(layout, d.shape[1]):
            plan = self.front_plan(layout, d.shape[1])
            self._count(front_covariance=1)
            kept: list[np.ndarray] = []  # the forward pass's eliminated rows, read back by the backward pass
            front_logdet(plan, wpl, d, a, self.blas, self._front_buffers(plan), keep=kept)
            return front_pose_covariances(plan, kept, self.n_poses)
        self._count(dense_covariance=1)
        return pose_marginals(self.pose_matrix(wpl, d, a, layout), self.blas)

    def _subtract_products(self, P: np.ndarray, buf: np.ndarray, layout: Layout) -> None:
        """P[block] -= A @ B.T for every call of ``layout`` (tiles in ``buf``), lower triangle of P."""
        if not self.inplace:
            for a_off, b_off, row, col, m, nn, k, _ in layout.calls:
                t = buf[a_off : a_off + m * k].reshape(m, k)
                u = buf[b_off : b_off + nn * k].reshape(nn, k)
                P[row : row + m, col : col + nn] -= t @ u.T
            self._count(numpy=len(layout.calls))
            return
        n = self.n
        syrk, gemm = self.blas.syrk_sub, self.blas.gemm_sub
        pa, pc, pd, pldc = buf.ctypes.data, P.ctypes.data, layout.dims.ctypes.data, self._ldc.ctypes.data
        n_same = 0
        for i, (a_off, b_off, row, col, _, _, _, same) in enumerate(layout.calls):
            p_m = pd + 12 * i  # dims[i] = (m, n, k), 4-byte C ints
            if same:
                syrk(pc + 8 * (row * n + col), pldc, pa + 8 * a_off, p_m, p_m + 8)
                n_same += 1
            else:
                gemm(pc + 8 * (row * n + col), pldc, pa + 8 * a_off, pa + 8 * b_off, p_m, p_m + 4, p_m + 8)
        self._count(syrk=n_same, gemm=len(layout.calls) - n_same)

    @staticmethod
    def _sparse_logdet(P: np.ndarray, pattern: np.ndarray) -> float:
        """log det [nats] of the (3K, 3K) matrix whose lower triangle is in ``P`` (not written to),
        non-zero only on the (K, K) ``pattern`` of pose blocks."""
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


def pose_marginals(P: np.ndarray, blas: Blas | None = None) -> np.ndarray:
    """The (K, 3, 3) diagonal blocks of the inverse of the (3K, 3K) symmetric positive definite
    matrix whose lower triangle is in ``P`` (C order; overwritten).

    Only the diagonal blocks are needed, so no inverse is formed: with P = Uᵀ U (Cholesky),
    P⁻¹ = U⁻¹ U⁻ᵀ and block k is Σ_j U⁻¹[3k:3k+3, j] U⁻¹[3k:3k+3, j]ᵀ, the Gram matrix of three
    rows of U⁻¹: a Cholesky (n³/3 flops) and a triangular inverse (n³/3) against dpotrf + dpotri's
    n³. A C-order lower triangle is, to LAPACK (column-major), the upper triangle of the same
    memory: both calls run on ``P.T`` without a copy. With ``blas``, the Cholesky is its blocked
    one (:meth:`Blas.cholesky_logdet`, the evaluations' own: ~25 % faster than one dpotrf); the
    strict upper triangle of ``P`` must then be zero (as :meth:`Kernel.pose_matrix` leaves it).
    """
    from scipy.linalg import lapack

    n = P.shape[0]
    if blas is not None:
        blas.cholesky_logdet(P)
        u = P.T
    else:
        u, info = lapack.dpotrf(P.T, lower=0, clean=1, overwrite_a=1)
        if info != 0:
            raise np.linalg.LinAlgError(f"pose information matrix is not positive definite (pivot {info})")
    uinv, info = lapack.dtrtri(u, lower=0, overwrite_c=1)
    if info != 0:
        raise np.linalg.LinAlgError(f"singular Cholesky factor (pivot {info})")
    rows = np.ascontiguousarray(uinv).reshape(n // 3, 3, n)  # rows 3k..3k+2 of U⁻¹
    cov = rows @ rows.transpose(0, 2, 1)
    return 0.5 * (cov + cov.transpose(0, 2, 1))
