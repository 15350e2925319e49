"""BLAS/LAPACK on sub-blocks of numpy arrays, through scipy's Cython BLAS/LAPACK function pointers,
and the BLAS thread count, through threadpoolctl.

numpy has no ``C -= A @ B.T`` on a strided view, nor an in-place Cholesky. scipy exports the BLAS
and LAPACK it links (``scipy.linalg.cython_blas`` / ``cython_lapack``) as C function pointers in
each module's ``__pyx_capi__`` (PyCapsules); :class:`Blas` casts them to ctypes functions with the
Fortran calling convention (every argument by pointer, column-major, 32-bit integers). This works
wherever scipy does, whatever BLAS scipy was built against. ctypes releases the GIL during each
call, so candidates scored on separate threads run in parallel.

Row-major vs column-major: a C-contiguous (m, n) block with leading dimension ``ld`` is, to
Fortran, the (n, m) block of its transpose with the same leading dimension; so the lower triangle
of a row-major matrix is the upper triangle of the column-major one, and ``C -= A Bᵀ`` on row-major
blocks is ``Cᵀ -= B Aᵀ`` on column-major ones.
"""

from __future__ import annotations

import ctypes
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np
from scipy.linalg import cython_blas, cython_lapack
from threadpoolctl import ThreadpoolController

_P = ctypes.c_void_p  # every Fortran argument: a pointer
_INT = ctypes.c_int  # scipy's Cython BLAS/LAPACK take ``int *`` (LP64)

#: columns per panel of :meth:`Blas.cholesky_logdet` (measured on KITTI 00's 1,365² pose matrix,
#: one thread: 64 → 18.9 ms, 128 → 20.3, 256 → 22.4, one dpotrf → 25.1)
CHOLESKY_BLOCK = 64

#: Fortran signatures: name -> (module, number of pointer arguments)
_SIGNATURES = {
    "dsyrk": (cython_blas, 10),
    "dgemm": (cython_blas, 13),
    "dpotrf": (cython_lapack, 5),
    "dtrsm": (cython_blas, 11),
    "dtrmm": (cython_blas, 11),
    "dtrtri": (cython_lapack, 6),
    "dpotri": (cython_lapack, 5),
}


def _function_pointer(module: Any, name: str, n_args: int) -> Any:
    """The C function ``name`` exported by a scipy Cython module, as a ctypes function of ``n_args`` pointers."""
    capsule = module.__pyx_capi__[name]
    # own prototypes of the C API functions (setting argtypes on ctypes.pythonapi's would change them for everyone)
    get_name = ctypes.PYFUNCTYPE(ctypes.c_char_p, ctypes.py_object)(("PyCapsule_GetName", ctypes.pythonapi))
    get_pointer = ctypes.PYFUNCTYPE(ctypes.c_void_p, ctypes.py_object, ctypes.c_char_p)(
        ("PyCapsule_GetPointer", ctypes.pythonapi)
    )
    signature = get_name(capsule)  # the capsule's name is the C signature, e.g. b"void (char *, int *, ...)"
    if not signature.startswith(b"void (") or signature.count(b"*") != n_args:
        raise ImportError(f"scipy's {name} has an unexpected signature: {signature!r}")
    address = get_pointer(capsule, signature)
    return ctypes.CFUNCTYPE(None, *([_P] * n_args))(address)


class Blas:
    """In-place dense kernels on raw float64 blocks, and the BLAS thread count while scoring.

    One per evaluator: the function pointers and the threadpoolctl controller are looked up once.
    Pointers to the constant arguments (``uplo``, ``trans``, alpha = -1, beta = 1) live in the
    instance, so a call builds no ctypes object beyond the integer addresses.
    """

    def __init__(self) -> None:
        self._syrk = _function_pointer(cython_blas, "dsyrk", _SIGNATURES["dsyrk"][1])
        self._gemm = _function_pointer(cython_blas, "dgemm", _SIGNATURES["dgemm"][1])
        self._potrf = _function_pointer(cython_lapack, "dpotrf", _SIGNATURES["dpotrf"][1])
        self._trsm = _function_pointer(cython_blas, "dtrsm", _SIGNATURES["dtrsm"][1])
        self._trmm = _function_pointer(cython_blas, "dtrmm", _SIGNATURES["dtrmm"][1])
        self._trtri = _function_pointer(cython_lapack, "dtrtri", _SIGNATURES["dtrtri"][1])
        self._potri = _function_pointer(cython_lapack, "dpotri", _SIGNATURES["dpotri"][1])
        self._chars = {
            c: ctypes.c_char(c) for c in (b"U", b"N", b"T", b"L", b"R")
        }  # kept alive: BLAS reads them by address
        self._char = {c: ctypes.addressof(v) for c, v in self._chars.items()}
        self._pu, self._pn, self._pt, self._pl = self._char[b"U"], self._char[b"N"], self._char[b"T"], self._char[b"L"]
        self._minus_one, self._one = ctypes.c_double(-1.0), ctypes.c_double(1.0)
        self.p_minus_one, self.p_one = ctypes.addressof(self._minus_one), ctypes.addressof(self._one)
        # created after scipy's BLAS is loaded (the import above), so that it sees it and numpy's
        self._controller = ThreadpoolController()

    @contextmanager
    def single_thread(self) -> Iterator[None]:
        """Run the block with every loaded BLAS on one thread per caller, then restore it.

        Why: (1) determinism: OpenBLAS's threaded Cholesky blocks the matrix by its thread count,
        so the last bits of a log det could depend on it; one BLAS thread per candidate keeps every
        number identical whatever ``jobs`` is. (2) speed: parallelism comes from scoring candidates
        on separate threads; on a busy 2-core machine OpenBLAS's own spinning threads were measured
        10-20x slower than one thread.
        """
        with self._controller.limit(limits=1, user_api="blas"):
            yield

    def syrk_sub(self, pc: int, p_ldc: int, pa: int, p_m: int, p_k: int) -> None:
        """C -= A Aᵀ, lower triangle of C only, on row-major float64 blocks (addresses).

        A is (m, k) with leading dimension k at ``pa``; C is (m, m) with leading dimension ldc at
        ``pc``. ``p_m``, ``p_k``, ``p_ldc`` are addresses of C ints holding m, k, ldc. Column-major:
        C's upper triangle -= Aᵀᵀ Aᵀ, i.e. dsyrk('U', 'T', n=m, k, -1, Aᵀ, lda=k, 1, Cᵀ, ldc).
        """
        self._syrk(self._pu, self._pt, p_m, p_k, self.p_minus_one, pa, p_k, self.p_one, pc, p_ldc)

    def gemm_sub(self, pc: int, p_ldc: int, pa: int, pb: int, p_m: int, p_n: int, p_k: int) -> None:
        """C -= A Bᵀ on row-major float64 blocks (addresses).

        A (m, k) at ``pa`` and B (n, k) at ``pb``, leading dimension k; C (m, n) with leading
        dimension ldc at ``pc``; ``p_m``, ``p_n``, ``p_k``, ``p_ldc`` are addresses of C ints.
        Column-major: Cᵀ (n, m) -= B Aᵀ = (Bᵀ)ᵀ Aᵀ, i.e. dgemm('T', 'N', n, m, k, -1, Bᵀ, k, Aᵀ, k, 1, Cᵀ, ldc).
        """
        self._gemm(self._pt, self._pn, p_n, p_m, p_k, self.p_minus_one, pb, p_k, pa, p_k, self.p_one, pc, p_ldc)

    def cholesky_logdet(self, p: np.ndarray, block: int = CHOLESKY_BLOCK) -> float:
        """log det [nats] of the symmetric positive definite (n, n) C-contiguous float64 ``p`` whose
        lower triangle is filled; ``p`` is overwritten by its Cholesky factor (pass a scratch array).

        Right-looking blocked Cholesky in ``block``-column panels (dpotrf on the diagonal block,
        the panel solved with it, dsyrk on the trailing matrix; 0: one dpotrf call). Why not dpotrf
        alone: on one thread OpenBLAS's dpotrf ran the 1,365² pose matrix of KITTI 00 at 1 Hz at
        ~23 GF/s, its dsyrk at ~54 GF/s; panels of 64 put nearly all the flops in dsyrk (25 → 19 ms
        measured, docs/speed.md). The panel is solved by inverting the small diagonal block
        (dtrtri) and multiplying by it (dtrmm, in place): dtrsm on these (64 x up to 1,300) panels
        ran at ~10 GF/s, a third of the whole factorization (28.8 → 22.6 ms, factors equal to
        3e-16). Same arithmetic on every run: the panels do not depend on threads."""
        if not (p.flags.c_contiguous and p.dtype == np.float64 and p.ndim == 2 and p.shape[0] == p.shape[1]):
            raise ValueError("cholesky_logdet needs a square C-contiguous float64 array")
        n = p.shape[0]
        step = n if block <= 0 else int(block)
        ld, info, m1, q = _INT(n), _INT(0), _INT(0), _INT(0)
        pld, pinfo, pm1, pq = (ctypes.addressof(x) for x in (ld, info, m1, q))
        inv = np.empty((min(step, n), min(step, n)))  # the diagonal block's inverse
        ld_inv = _INT(max(1, len(inv)))
        pinv, pld_inv = inv.ctypes.data, ctypes.addressof(ld_inv)
        # row-major lower triangle = column-major upper triangle: dpotrf('U'), then the panel to
        # the right of the diagonal block in column-major (rows below it in row-major) is solved,
        # U12 = U11⁻ᵀ A12, and A22 -= U12ᵀ U12 (upper triangle)
        base = p.ctypes.data
        for k in range(0, n, step):
            m1.value, q.value = min(step, n - k), max(0, n - k - step)
            p11 = base + 8 * (k * n + k)
            self._potrf(self._pu, pm1, p11, pld, pinfo)
            if info.value != 0:
                raise np.linalg.LinAlgError(
                    f"pose information matrix is not positive definite (dpotrf info {info.value + k})"
                )
            if q.value:
                # the block, row-major into the C-ordered (step, step) buffer: column-major, U11
                # with leading dimension step; dtrtri reads and writes its upper triangle only
                inv[: m1.value, : m1.value] = p[k : k + m1.value, k : k + m1.value]
                self._trtri(self._pu, self._pn, pm1, pinv, pld_inv, pinfo)
                if info.value != 0:
                    raise np.linalg.LinAlgError(f"pose information matrix is singular (dtrtri info {info.value + k})")
                p12 = p11 + 8 * m1.value * n
                self._trmm(self._pl, self._pu, self._pt, self._pn, pm1, pq, self.p_one, pinv, pld_inv, p12, pld)
                self._syrk(self._pu, self._pt, pq, pm1, self.p_minus_one, p12, pld, self.p_one, p12 + 8 * m1.value, pld)
        return 2.0 * float(np.sum(np.log(np.diagonal(p))))

    def inverse_from_cholesky(self, p: np.ndarray) -> None:
        """Overwrite the Cholesky factor that :meth:`cholesky_logdet` left in ``p``'s lower triangle
        (square C-contiguous float64) with the lower triangle of the inverse of the factored matrix
        (dpotri('U') on the column-major view; the upper triangle is not written).

        Why not scipy.linalg.lapack.dpotri: its wrapper holds the GIL for the whole call (measured:
        two threads inverting 1,365² matrices ran 1.06x as fast as one), so the members' gain bounds
        of a domain, scored two at a time, queued behind it; through the function pointer, ctypes
        releases the GIL.

        Raises:
            LinAlgError: a zero on the factor's diagonal.
        """
        if not (p.flags.c_contiguous and p.dtype == np.float64 and p.ndim == 2 and p.shape[0] == p.shape[1]):
            raise ValueError("inverse_from_cholesky needs a square C-contiguous float64 array")
        n, info = _INT(p.shape[0]), _INT(0)
        self._potri(self._pu, ctypes.addressof(n), p.ctypes.data, ctypes.addressof(n), ctypes.addressof(info))
        if info.value != 0:
            raise np.linalg.LinAlgError(f"pose information matrix is singular (dpotri info {info.value})")

    def eliminate_leading(self, g: np.ndarray, m1: int, dims: np.ndarray) -> float:
        """Eliminate the leading ``m1`` variables of the symmetric (m, m) row-major float64 block
        ``g`` (C-contiguous) whose UPPER triangle is filled: G11 = U11ᵀ U11, G12 <- U11⁻ᵀ G12 and
        G22 -= G12ᵀ G12 in place (upper triangle), which leaves the Schur complement of G11 in G22.
        Returns log det G11 [nats]. ``dims``: C int array (m1, m - m1, m), read by address.

        Column-major, g's upper triangle is the lower one: dpotrf('L') on G11, dtrsm('R', 'L', 'T')
        on the (m - m1, m1) block G21, dsyrk('L', 'N') on G22 (the right-side solve was measured 2-3x
        faster than the left-side one on these shapes, ~m1 = 50-300 by q = 400-1,000).
        """
        m = g.shape[0]
        q = m - m1
        pd = dims.ctypes.data  # m1, q, ld
        info = _INT(0)
        pg = g.ctypes.data
        self._potrf(self._pl, pd, pg, pd + 8, ctypes.addressof(info))
        if info.value != 0:
            raise np.linalg.LinAlgError(f"information matrix is not positive definite (dpotrf info {info.value})")
        if q:
            p21 = pg + 8 * m1
            self._trsm(self._char[b"R"], self._pl, self._pt, self._pn, pd + 4, pd, self.p_one, pg, pd + 8, p21, pd + 8)
            self._syrk(
                self._pl, self._pn, pd + 4, pd, self.p_minus_one, p21, pd + 8, self.p_one, p21 + 8 * m1 * m, pd + 8
            )
        return 2.0 * float(np.sum(np.log(g.ravel()[: m1 * (m + 1) : m + 1])))
