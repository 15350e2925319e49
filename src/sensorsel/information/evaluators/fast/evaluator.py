"""FastEvaluator: the fast engine's interface (method and reasons: :mod:`sensorsel.information.evaluators.fast`)."""

from __future__ import annotations

import weakref
from collections.abc import Iterable, Sequence
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from sensorsel.information.evaluators.base import ProblemEvaluator, Suite, as_suite
from sensorsel.information.evaluators.fast import bound
from sensorsel.information.evaluators.fast.blas import Blas
from sensorsel.information.evaluators.fast.fischer import PoseBand, landmark_logdets
from sensorsel.information.evaluators.fast.front import CHUNK_POSES, keyframe_orders
from sensorsel.information.evaluators.fast.kernel import FRONT_BELOW, SPARSE_BELOW, Kernel
from sensorsel.information.evaluators.fast.plan import Planner
from sensorsel.information.evaluators.fast.state import BaseState, StateBuilder
from sensorsel.model.problem import Problem

#: candidates are scored on several threads only from this many keyframes on. Below it a candidate
#: costs ~2 ms, mostly interpreter work that holds the GIL, and two threads were measured slower
#: than one (KITTI 03, 81 keyframes: lazy greedy 0.39-0.48 s on 2 threads, 0.31-0.32 s on 1);
#: on KITTI 00 (455 keyframes) the dense factorizations release the GIL and 2 threads took 7.4 s
#: against 10.1 s on 1.
THREADS_FROM_KEYFRAMES = 200

#: :meth:`FastEvaluator.gain_bounds` computes bounds only for at least this many times as many
#: candidates as the bounds are predicted to cost in evaluations of the base: (3K)³ flops for the
#: dense Cholesky and inverse against one evaluation's predicted flops (the dense Cholesky's
#: (3K)³/3, or the frontal path's). Measured (docs/speed.md): the bounds spare most of the
#: candidates the lazy greedy would re-score on KITTI 00 at 1 Hz (predicted cost 3.3 evaluations,
#: measured 6-7) and lose on 02 at 3 Hz (predicted 48, measured 26-36, where the frontal path makes
#: an evaluation cheap and the dense inverse dear). 3, not 2: once evaluations and base states got
#: cheaper, the bounds asked for 7 or 8 candidates on the synthetic 00 map spared 2 and 6 of them
#: at ~5 evaluations' cost each (whole selection, median of 4: 3.40 s at 2, 3.01 s at 3; the real
#: map asks the same 2 bounds either way)
BOUND_SPARE = 3.0

#: relative round-off allowance of :meth:`FastEvaluator.score_bounds` (of the magnitudes of the log
#: dets a bound is made of): far above what double precision loses over ~1e4 terms (~1e-13)
ROUND_OFF = 1e-9


class FastEvaluator(ProblemEvaluator):
    """Exact log det from per-sensor linearized pieces computed once (see :mod:`sensorsel.information.evaluators.fast`).

    Attributes:
        kernel: the numeric kernel (its ``counts`` tell which paths were taken).
    """

    name = "fast"

    def __init__(
        self,
        problem: Problem,
        *,
        jobs: int = 1,
        threads_from_keyframes: int = THREADS_FROM_KEYFRAMES,
        sparse_below: float = SPARSE_BELOW,
        front_below: float = FRONT_BELOW,
        chunk_poses: int = CHUNK_POSES,
        inplace_blas: bool = True,
        bound_spare: float = BOUND_SPARE,
    ) -> None:
        """``threads_from_keyframes``: use the ``jobs`` threads only on routes with at least this many
        keyframes. ``sparse_below``, ``front_below``, ``chunk_poses``, ``inplace_blas``: the kernel's choice
        of paths (see
        :class:`~sensorsel.information.evaluators.fast.kernel.Kernel`); ``bound_spare``: when :meth:`gain_bounds`
        computes bounds (:data:`BOUND_SPARE`; 0: always). All change speed, not the numbers."""
        super().__init__(problem, jobs=jobs)
        from sensorsel.information.linearize import linearize_library

        lin = linearize_library(problem)
        K = problem.scenario.n_poses
        coo = lin.base_pose_information.tocoo()
        planner = Planner(problem, lin.pair_pose, lin.pair_landmark, (coo.row // 3, coo.col // 3))
        self._states = StateBuilder(lin, planner)
        self._planner = planner
        self.kernel = Kernel(
            K,
            lin.base_pose_information,
            Blas(),
            sparse_below=sparse_below,
            front_below=front_below,
            chunk_poses=chunk_poses,
            pose_orders=keyframe_orders(problem.scenario.keyframes.poses[:, :2]),
            inplace=inplace_blas,
        )
        self._pose_band = PoseBand(K, self.kernel._base_rc, self.kernel.base_values)
        self._threads_from = int(threads_from_keyframes)
        self._bound_spare = float(bound_spare)
        self._base: BaseState | None = None
        self.n_bounds = 0  # base suites whose covariance :meth:`gain_bounds` computed
        self._pool: ThreadPoolExecutor | None = None

    def _threads(self) -> ThreadPoolExecutor:
        """The evaluator's worker threads, started once (a pool per call cost more than a 03 candidate)."""
        if self._pool is None:
            self._pool = ThreadPoolExecutor(max_workers=self.jobs, thread_name_prefix="sensorsel-fast")
            weakref.finalize(self, self._pool.shutdown, wait=False)
        return self._pool

    def _base_for(self, suite: Suite) -> BaseState:
        """The state of ``suite``, kept for the next call (greedy scores many candidates on one base)."""
        if self._base is None or self._base.suite != suite:
            self._base = self._states.base(suite)
        return self._base

    def _request(self, suite: Iterable[int], candidates: Sequence[int]) -> tuple[Suite, list[int]]:
        """The canonical base suite and the candidates' positions, all checked against the library."""
        base = as_suite(suite)
        cands = [int(c) for c in candidates]
        self._check_positions(base + tuple(cands))
        return base, cands

    def _candidate_logdet(self, base: BaseState, c: int) -> float:
        """log det L(base + {c}) [nats]."""
        x = self._states.candidate(base, c)
        return self.kernel.logdet(x.wpl, x.d, x.a, x.layout)

    def _logdet(self, suite: Suite) -> float:
        with self.kernel.blas.single_thread():
            b = self._base_for(suite)
            return self.kernel.logdet(b.wpl, b.d, b.a, b.layout)

    def _pose_covariances(self, suite: Suite, map_sigma_m: float | None) -> np.ndarray:
        """The suite's pose marginals from its state: the pose Schur complement, factored and
        inverted on its diagonal blocks (:func:`.kernel.pose_marginals`: about two dense Cholesky
        factorizations of the pose matrix). With ``map_sigma_m`` each landmark's weak prior is
        replaced by an isotropic prior of that std (the state's landmark sums hold the prior: it
        is swapped, the measurements kept)."""
        with self.kernel.blas.single_thread():
            b = self._base_for(suite)
            return self.kernel.pose_covariances(b.wpl, self._landmark_sums(b, map_sigma_m), b.a, b.layout)

    def pose_covariance_floor(self, suite: Iterable[int], *, map_sigma_m: float | None = None) -> np.ndarray:
        """(K, 3, 3) inverses of the diagonal blocks P_kk of the pose Schur complement: a lower bound
        on the marginal covariances (for a positive definite P, (P⁻¹)_kk ⪰ (P_kk)⁻¹: the other poses'
        uncertainty only adds to pose k's). P_kk = Λ_kk − Σ_j W_kj D_j⁻¹ W_kjᵀ over the pairs pose k
        measures: linear in the pairs, no factorization (~1/20 of :meth:`pose_covariances` on KITTI
        00). What ``require`` uses to refute a suite before computing its marginals."""
        s = as_suite(suite)
        self._check_positions(s)
        with self.kernel.blas.single_thread():
            b = self._base_for(s)
            return np.linalg.inv(self._pose_diagonal_blocks(b, self._landmark_sums(b, map_sigma_m)))

    def _landmark_sums(self, b: BaseState, map_sigma_m: float | None) -> np.ndarray:
        """The state's (3, M) landmark information sums, with each landmark's weak prior replaced by
        an isotropic prior of std ``map_sigma_m`` [m] when one is given (a new array then)."""
        if map_sigma_m is None:
            return b.d
        d = b.d - self._states.base_ll
        d[0] += 1.0 / map_sigma_m**2
        d[2] += 1.0 / map_sigma_m**2
        return d

    def _pose_diagonal_blocks(self, b: BaseState, d: np.ndarray) -> np.ndarray:
        """(K, 3, 3) diagonal blocks of the pose Schur complement of state ``b`` with landmark sums ``d``."""
        K = self.problem.scenario.n_poses
        blocks = np.zeros((K, 3, 3))
        k = self.kernel
        # the base graph's diagonal blocks (its lower triangle; both triangles of a diagonal block)
        r, c = k._base_rc
        on = (r // 3) == (c // 3)
        np.add.at(blocks, (r[on] // 3, r[on] % 3, c[on] % 3), k.base_values[on])
        off = on & (r != c)
        np.add.at(blocks, (r[off] // 3, c[off] % 3, r[off] % 3), k.base_values[off])
        for e, (i, j) in enumerate(((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))):
            blocks[:, i, j] += b.a[e]
            if i != j:
                blocks[:, j, i] += b.a[e]
        lm, pose = b.layout.landmark, b.layout.pose
        det = d[0] * d[2] - d[1] * d[1]
        i00, i01, i11 = (d[2] / det)[lm], (-d[1] / det)[lm], (d[0] / det)[lm]
        w0, w1 = b.wpl[0:3], b.wpl[3:6]  # W's columns (landmark x, y), rows the pose's 3 components
        for i in range(3):
            for j in range(3):
                q = i00 * w0[i] * w0[j] + i01 * (w0[i] * w1[j] + w1[i] * w0[j]) + i11 * w1[i] * w1[j]
                blocks[:, i, j] -= np.bincount(pose, q, K)
        return blocks

    def scores_with(self, suite: Iterable[int], candidates: Sequence[int]) -> np.ndarray:
        """f(S + {c}) for each candidate c [nats], shape (len(candidates),); the base's state is
        computed once and shared (on ``jobs`` threads from ``threads_from_keyframes`` keyframes on)."""
        base, cands = self._request(suite, candidates)
        baseline = self.baseline_logdet
        with self.kernel.blas.single_thread():
            b = self._base_for(base)
            if self.jobs > 1 and len(cands) > 1 and self.problem.scenario.n_poses >= self._threads_from:
                vals = list(self._threads().map(lambda c: self._candidate_logdet(b, c), cands))
            else:
                vals = [self._candidate_logdet(b, c) for c in cands]
        self.n_evaluations += len(cands)
        return np.array(vals, dtype=float) - baseline

    def gain_bounds(
        self,
        suite: Iterable[int],
        candidates: Sequence[int],
        *,
        trace: bool = False,
        force: bool = False,
        covariance: np.ndarray | None = None,
        shared: bound.Quadratics | None = None,
    ) -> np.ndarray | None:
        """Upper bounds [nats] on each candidate's gain f(S + {c}) − f(S), shape (len(candidates),)
        (exact arithmetic; :func:`.bound.gain_bounds`: per measurement log det, or with ``trace``
        tr(L_S⁻¹ Λ_c)); not counted in :attr:`n_evaluations`.

        They cost one dense Cholesky and inverse of the base's pose matrix: None (unless ``force``)
        when there are fewer than ``bound_spare`` (:data:`BOUND_SPARE`) times as many candidates as that is predicted
        to cost in evaluations (:meth:`bound_cost`). The choice depends on the suite's pattern
        alone, so a run's evaluations are the same on every machine.

        ``covariance``: the base's pose covariance Σ_pp (3K, 3K) from :meth:`bound_covariance` of an
        engine with the same pose information matrix at S (a domain member and its clear member
        when S holds no sensor the condition changes), instead of computing it again; ``shared``:
        such an engine's pair quadratics (:meth:`bound_quadratics`), used where they hold every pair
        the candidates measure here."""
        base, cands = self._request(suite, candidates)
        with self.kernel.blas.single_thread():
            b = self._base_for(base)
            if not force and len(cands) < self._bound_spare * self._bound_cost(b):
                return None
            # on one thread: the landmark groups' products are small, and on 2 threads they ran
            # slower (KITTI 00 at 1 Hz, synthetic map: whole selection 3.57 against 3.16 s, min of 4)
            out = bound.gain_bounds(
                self.kernel, self._states, self._planner, b, cands, trace=trace, covariance=covariance, shared=shared
            )
        self.n_bounds += 1
        return out

    def bound_quadratics(self, suite: Iterable[int], candidates: Sequence[int]) -> bound.Quadratics | None:
        """The pair quadratics of :meth:`gain_bounds` for ``candidates`` at ``suite`` (from one pose
        covariance), for engines with the same base information at S; None when it would give no bounds."""
        base, cands = self._request(suite, candidates)
        cov = self.bound_covariance(base, len(cands))
        if cov is None:
            return None
        with self.kernel.blas.single_thread():
            return bound.quadratics(self.kernel, self._states, self._planner, self._base_for(base), cands, cov)

    def bound_covariance(self, suite: Iterable[int], n_candidates: int) -> np.ndarray | None:
        """The pose covariance Σ_pp (3K, 3K) [m², rad²] of ``suite`` that :meth:`gain_bounds` would
        compute for ``n_candidates`` candidates, or None when it would give no bounds (the same choice)."""
        base = as_suite(suite)
        self._check_positions(base)
        with self.kernel.blas.single_thread():
            b = self._base_for(base)
            if n_candidates < self._bound_spare * self._bound_cost(b):
                return None
            return bound.pose_covariance(self.kernel, b)

    def score_bounds(self, suite: Iterable[int], candidates: Sequence[int]) -> tuple[float, np.ndarray] | None:
        """Upper bounds [nats] on f(S) and on each f(S + {c}), shape (len(candidates),), from
        Fischer's inequality (:mod:`.fischer`: log det L ≤ log det A + Σ_j log det D_j, poses and
        landmarks decoupled); ~0.2 ms per candidate on KITTI 00 at 1 Hz. None when the base graph's pose
        information is not a narrow band.

        Round-off is allowed for here: each bound is raised by :data:`ROUND_OFF` times the sum of
        the magnitudes of the log dets it is made of (they are ~1e4 nats on KITTI 00, so a bound on
        the empty suite's score, exactly 0, was computed as -2e-9: that is far below the
        allowance, ~5e-5 nats there, and above the 1e-9 tie tolerance a caller adds to a score of 0)."""
        if not self._pose_band.banded:
            return None
        base, cands = self._request(suite, candidates)
        baseline = self.baseline_logdet
        with self.kernel.blas.single_thread():
            b = self._base_for(base)
            per_landmark = landmark_logdets(b.d)
            landmarks = float(np.sum(per_landmark))
            pose = self._pose_band.logdet(b.a)
            own = pose + landmarks - baseline + ROUND_OFF * (abs(pose) + abs(landmarks) + abs(baseline))
            out = np.empty(len(cands))
            for i, c in enumerate(cands):
                if c in b.suite:
                    out[i] = own
                    continue
                # only the landmarks and keyframes c measures change
                x = self._states.sensor_sums(c)
                lm_c = landmarks + float(
                    np.sum(landmark_logdets(b.d[:, x.landmarks] + x.d) - per_landmark[x.landmarks])
                )
                pose_c = self._pose_band.logdet(b.a, (x.poses, x.a))
                out[i] = pose_c + lm_c - baseline + ROUND_OFF * (abs(pose_c) + abs(lm_c) + abs(baseline))
        return own, out

    def bound_cost(self, suite: Iterable[int]) -> float:
        """Predicted cost of :meth:`gain_bounds` on ``suite``, in evaluations of the suite: (3K)³
        flops (dense Cholesky and inverse) over one evaluation's predicted flops (≥ 3)."""
        with self.kernel.blas.single_thread():
            return self._bound_cost(self._base_for(as_suite(suite)))

    def _bound_cost(self, b: BaseState) -> float:
        k = self.kernel
        m = b.d.shape[1]
        per_eval = k.front_choice(b.layout, m)[1] if k.uses_front(b.layout, m) else k.n**3 / 3.0
        return float(k.n) ** 3 / max(per_eval, 1.0)
