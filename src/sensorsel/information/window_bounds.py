"""The filter's covariance at a keyframe bounded from below and from above by a short window of the
route before it: a few small solves instead of a forward pass over the route.

The filter's covariance at keyframe k (:mod:`~sensorsel.information.filtering`) is the marginal of
pose k in the graph G_k of the priors, the odometry up to k and the suite's measurements of
keyframes ≤ k, linearized at the truth. Take the window of poses lo..k, lo = max(0, k − w), and the
landmarks the suite measures from them (V: the window's variables).

**The floor.** Condition G_k on every pose before lo (take them as known, at the truth). A
conditional covariance is ⪯ the marginal one (knowing more never adds uncertainty), so pose k's
block of Cov(V | poses < lo) is ⪯ the filter's: each σ from it is a lower bound. Given those poses,
the landmarks not in V are independent of pose k and drop out; what is left is V's information
in G_k restricted to V: the odometry factor from pose lo − 1 becomes a prior N(0, Σ_odo) on pose lo
(its Jacobian on pose lo is the identity), each landmark of V keeps the information of its
measurements from the poses before lo (BᵀB of their whitened Jacobians [A | B]) beside its prior,
and the window's own factors stay as they are.

**The ceiling.** Keep only the window's factors: the odometry between poses lo..k, the suite's
measurements from them and the landmarks' priors (the first pose's prior too when lo = 0). That is a
subgraph of G_k: fewer factors, less information, so pose k's marginal in it is ⪰ the filter's and
each σ from it is an upper bound. With nothing before lo, pose lo is anchored by the landmarks'
priors alone: in the map model (landmarks known to ``map_sigma_m``) it is a proper Gaussian as soon
as the window sees enough of them; where it is not (its information singular), the ceiling is
infinite (no bound).

**The ceiling with the earlier visits.** After a loop the filter still knows the window's landmarks
from when the car first passed them, which the window's ceiling has lost: on a drive of KITTI 00's
ground truth a six-sensor suite's ceiling of 48 keyframes was 1.057 of the heading limit at
keyframe 221 where its pass was 0.935. Any set of poses with the factors among them is a subgraph
of G_k as well: the window's poses plus the keyframes before lo that measure a landmark the window
measures, with the suite's measurements from all of them (of any landmark: those anchor the earlier
poses), the odometry between two of them that follow one another, and the priors. Its pose k
marginal is again ⪰ the filter's, and ⪯ the window's ceiling (a larger subgraph); at that keyframe
0.937 of the limit, against the pass's 0.935.

Both are the marginal of pose k in a system of 3(k − lo + 1) + 2|V| unknowns: the landmarks (2 × 2
blocks each) are eliminated first, then the pose block (at most 3(w + 1) square) is factored. Each
measurement's whitened terms (AᵀA, AᵀB, BᵀB) are summed into the system where its keyframe and
landmark are (the sums the filter forms per pair, in another order: equal to round-off); they are
computed once per sensor of the route (:class:`WindowBounds` keeps them), so that the suites of a
failing set's growth, which differ by a sensor, cost only their windows' solves. With
lo = 0 (k ≤ w) the floor and the ceiling are both G_k itself: the filter's covariance, computed
another way (equal to round-off). In the map model at the README tour's sizes, w = 16 put the
floor's σ within 10 % below the filter's and the ceiling's within 5 % above at most keyframes.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass

import numpy as np
from scipy.linalg.lapack import dpotrf, dtrtri

from sensorsel.information.filtering import WINDOW_KEYFRAMES, blas_controller, check_map_sigma
from sensorsel.information.linearize import bearing_range_jacobians, odometry_jacobians
from sensorsel.model.problem import Problem

__all__ = ["WINDOW", "WindowBounds", "pass_flops"]

#: the window's length in keyframes before the one bounded (w): the longer, the tighter both bounds
#: and the dearer each solve (the pose block is 3(w + 1) square)
WINDOW = 16


#: a suite's or a sensor's measurement terms: keyframe (m,), landmark (m,), AᵀA (m, 3, 3), AᵀB (m, 3, 2),
#: BᵀB (m, 2, 2)
_Terms = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]

#: a sensor's terms when it measures nothing (what a suite's are concatenated to: typed if it is empty)
_NO_TERMS: _Terms = (
    np.zeros(0, np.int64),
    np.zeros(0, np.int64),
    np.zeros((0, 3, 3)),
    np.zeros((0, 3, 2)),
    np.zeros((0, 2, 2)),
)


@dataclass(frozen=True)
class _WindowSystem:
    """The system of a keyframe's ceiling: the pose block (3n, 3n), the first pose's prior (None past
    the route's start), the landmarks measured (L,), their blocks (L, 2, 2) and their coupling to the
    poses (L, 2, 3n)."""

    pose: np.ndarray
    first: np.ndarray | None
    lms: np.ndarray
    blocks: np.ndarray
    coupling: np.ndarray


class WindowBounds:
    """The floors and ceilings of the filter's covariance on one route, in one localization model
    (module docstring), with each sensor's measurement terms computed once.

    Args:
        problem: the route.
        map_sigma_m: the map model's landmark std [m], or None for SLAM (the problem's weak landmark
            prior: the ceilings are then mostly infinite).
        window: w, the keyframes of the window before the one bounded.
    """

    def __init__(self, problem: Problem, map_sigma_m: float | None, window: int = WINDOW) -> None:
        check_map_sigma(map_sigma_m)
        s = problem.settings
        self.problem, self.window = problem, int(window)
        prior_sigma = float(s.landmark_prior_sigma_m if map_sigma_m is None else map_sigma_m)
        self._landmark_prior = np.eye(2) / prior_sigma**2
        poses = np.asarray(problem.scenario.keyframes.poses, float)
        odo = odometry_jacobians(poses) if len(poses) > 1 else np.zeros((0, 3, 3))
        self._odo_info = np.diag(1.0 / np.asarray(s.odometry_sigmas, float) ** 2)
        self._first_info = np.diag(1.0 / np.asarray(s.first_pose_sigmas, float) ** 2)
        # the odometry's blocks of each step j − 1 -> j (row j − 1): HᵀΩH on pose j − 1, HᵀΩ off the
        # diagonal, Ω on pose j (Ω the step's information, H its Jacobian on pose j − 1)
        self._ht_o = np.transpose(odo, (0, 2, 1)) @ self._odo_info
        self._ht_o_h = self._ht_o @ odo
        self._slot = np.full(max(problem.scenario.n_landmarks, 1), -1, np.int64)
        self._seen = np.zeros(len(self._slot), bool)
        self._terms: dict[int, tuple[_Terms, np.ndarray]] = {}
        self._bands: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
        #: the last suite's terms gathered: (suite, (K + 1,) the keyframes gathered, terms), kept as its
        #: chunks and windows are asked one after another
        self._last: tuple[tuple[int, ...], np.ndarray, _Terms] | None = None

    def _sensor_terms(self, i: int) -> tuple[_Terms, np.ndarray]:
        """Sensor ``i``'s measurements, sorted by keyframe (stable): (keyframe (m,), landmark (m,), AᵀA
        (m, 3, 3), AᵀB (m, 3, 2), BᵀB (m, 2, 2)) of each one's whitened Jacobian [A | B]; and where each
        keyframe's begin among them ((K + 1,): keyframes 0..K)."""
        got = self._terms.get(i)
        if got is None:
            o = self.problem.observations[i]
            order = np.argsort(np.asarray(o.pose, np.int64), kind="stable")
            keyframe, landmark = np.asarray(o.pose, np.int64)[order], np.asarray(o.landmark, np.int64)[order]
            jac = bearing_range_jacobians(
                np.asarray(self.problem.scenario.keyframes.poses, float)[keyframe],
                np.asarray(self.problem.scenario.landmarks, float)[landmark],
            )
            sigmas = np.column_stack([np.asarray(o.sigma_bearing_rad, float), np.asarray(o.sigma_range_m, float)])
            jac = jac * (1.0 / sigmas[order])[:, :, None]
            A, B = jac[:, :, :3], jac[:, :, 3:]
            At = np.transpose(A, (0, 2, 1))
            terms = (keyframe, landmark, At @ A, At @ B, np.transpose(B, (0, 2, 1)) @ B)
            starts = np.searchsorted(keyframe, np.arange(self.problem.scenario.n_poses + 1))
            got = self._terms[i] = (terms, starts)
        return got

    def __call__(
        self,
        suite: Iterable[int],
        keyframes: Iterable[int],
        window: int | None = None,
        floors_wanted: Callable[[np.ndarray], np.ndarray] | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """(n, 3, 3) floors and (n, 3, 3) ceilings of the filter's pose covariance (Pose2 tangent: dx,
        dy in the keyframe's frame [m], dθ [rad]) of ``suite`` (library positions) at each of
        ``keyframes`` (n,), from ``window`` keyframes before each (default: the object's). A ceiling
        whose system is singular is +inf.

        ``floors_wanted``: given the ceilings, which keyframes' floors to solve for ((n,) bool); the
        others' floors are 0, the trivial floor. A caller that judges a keyframe by its ceiling first
        (within a limit there, the floor is too) spares the floors' solves there: each system is
        assembled once and its ceiling solved, then the floors where wanted (the same operations as
        without: the same bytes). The systems are held until the callback has answered: ask a chunk
        of keyframes at a time (a window's system on a long route is up to a few MB)."""
        ks = np.asarray(list(keyframes), np.int64)
        w = self.window if window is None else int(window)
        key = _suite_key(suite)
        # the systems read the suite's measurements of their windows alone (a floor's before its window
        # are read sensor by sensor, for its landmarks only: :meth:`_floor`)
        terms = self._gathered(key, _runs(ks, w))
        starts = _starts(terms, ks)
        floors, ceilings = np.zeros((len(ks), 3, 3)), np.zeros((len(ks), 3, 3))
        # one BLAS thread: small products, where threads only cost (as in the filter's pass)
        with blas_controller().limit(limits=1, user_api="blas"):
            systems = []
            for out, k in enumerate(ks.tolist()):
                system = self._system(k, w, *terms, starts)
                ceilings[out] = _last_marginal(system.pose, system.first, system.blocks, system.coupling)
                if floors_wanted is None:
                    floors[out] = self._floor_of(system, key, k, w, ceilings[out])
                else:
                    systems.append(system)
            if floors_wanted is not None:
                for out in np.flatnonzero(np.asarray(floors_wanted(ceilings), bool)).tolist():
                    floors[out] = self._floor_of(systems[out], key, int(ks[out]), w, ceilings[out])
        return floors, ceilings

    def ceilings_with_visits(
        self, suite: Iterable[int], keyframes: Iterable[int], window: int | None = None
    ) -> np.ndarray:
        """(n, 3, 3) ceilings of ``suite``'s filter covariance at each of ``keyframes`` (n,) from the window
        of ``window`` keyframes before each and the route's earlier visits to its landmarks (module
        docstring): the keyframes before the window that measure a landmark the window measures join
        the subgraph, with their own measurements (of any landmark) and the odometry between those of
        them that follow one another. +inf where the system is singular."""
        ks, terms, starts, w = self._asked(suite, keyframes, window)
        keyframe, landmark = terms[0], terms[1]
        out = np.zeros((len(ks), 3, 3))
        with blas_controller().limit(limits=1, user_api="blas"):
            for i, k in enumerate(ks.tolist()):
                lo = max(0, k - w)
                before, inside = int(starts[lo]), int(starts[k + 1])
                seen = np.zeros(len(self._slot), bool)
                seen[landmark[before:inside]] = True
                visits = np.unique(keyframe[:before][seen[landmark[:before]]])
                poses = np.concatenate([visits, np.arange(lo, k + 1)])
                # the measurements from those keyframes (sorted by keyframe, as the terms are)
                chosen = np.zeros(k + 1, bool)
                chosen[poses] = True
                rows = np.flatnonzero(chosen[keyframe[:inside]])
                out[i] = self._ceiling_on(poses, rows, *terms)
        return out

    def _asked(
        self, suite: Iterable[int], keyframes: Iterable[int], window: int | None
    ) -> tuple[np.ndarray, _Terms, np.ndarray, int]:
        """The keyframes asked (n,), the suite's terms, where each keyframe's terms begin (up to the last
        asked) and the window's length (the object's where ``window`` is None)."""
        ks = np.asarray(list(keyframes), np.int64)
        terms = self._gathered(_suite_key(suite), ((0, int(ks.max(initial=-1)) + 1),))
        return ks, terms, _starts(terms, ks), self.window if window is None else int(window)

    def _gathered(self, key: tuple[int, ...], runs: tuple[tuple[int, int], ...]) -> _Terms:
        """The measurement terms of the suite ``key`` (sorted distinct library positions) from the
        keyframes of ``runs`` ((first, stop) each, stop excluded; sorted and apart), as
        :meth:`_sensor_terms`' five arrays, sorted by keyframe (stable: a keyframe's in the suite's
        sensor order): the same terms in the same order as the route's, cut to those keyframes, so the
        same sums. Each sensor's slices are read off where its keyframes begin (not its whole route
        filtered: the windows are a small share of a long route); the last suite's kept, as its chunks
        and windows are asked one after another (asked again outside them, the keyframes from the
        first asked or kept on, to the last kept or, beyond it, to the route's end: its next chunks are
        there)."""
        n = self.problem.scenario.n_poses
        runs = runs or ((0, 0),)  # no keyframe asked: none gathered
        last = self._last
        if last is not None and last[0] == key:
            covered = last[1]
            if all(covered[a:b].all() for a, b in runs):
                return last[2]
            kept = np.flatnonzero(covered)
            if len(kept):
                stop = max(b for _, b in runs)
                runs = ((min(runs[0][0], int(kept[0])), n if stop > kept[-1] + 1 else int(kept[-1]) + 1),)
        covered = np.zeros(n + 1, bool)
        for a, b in runs:
            covered[a:b] = True
        parts = []
        for i in key:
            terms, starts = self._sensor_terms(i)
            if len(runs) == 1:
                lo, hi = int(starts[runs[0][0]]), int(starts[runs[0][1]])
                parts.append(tuple(t[lo:hi] for t in terms))
            else:
                rows = np.concatenate([np.arange(starts[a], starts[b]) for a, b in runs])
                parts.append(tuple(t[rows] for t in terms))
        merged = _merged(parts)  # type: ignore[arg-type]
        self._last = (key, covered, merged)
        return merged

    def _system(
        self,
        k: int,
        window: int,
        keyframe: np.ndarray,
        landmark: np.ndarray,
        AA: np.ndarray,
        AB: np.ndarray,
        BB: np.ndarray,
        starts: np.ndarray,
    ) -> _WindowSystem:
        """The ceiling's system at keyframe ``k`` from the ``window`` keyframes before it, from the suite's
        measurement terms sorted by keyframe (``starts``: where each keyframe's begin)."""
        lo = max(0, k - window)
        win = slice(int(starts[lo]), int(starts[k + 1]))
        rel = keyframe[win] - lo
        pose = self._pose_block(np.arange(lo, k + 1), rel, AA[win])
        # the landmarks the window measures: their blocks (the prior and the window's measurements) and
        # their coupling W to the poses
        lms, which, W = self._coupling(landmark[win], rel, AB[win], k - lo + 1)
        blocks = _sums(which, BB[win], len(lms)) + self._landmark_prior
        return _WindowSystem(pose, self._first_info if lo == 0 else None, lms, blocks, W)

    def _floor_of(
        self, system: _WindowSystem, key: tuple[int, ...], k: int, window: int, ceiling: np.ndarray
    ) -> np.ndarray:
        """The floor at keyframe ``k`` of ``system`` (its ceiling's, from :meth:`_system`) for the suite
        ``key``, the last gathered (:meth:`_gathered`). Where the window reaches the route's start
        nothing lies before it: the floor's system is the ceiling's, and so is its answer (the same
        bytes), not solved again."""
        if k <= window:
            return ceiling
        return self._floor(system, key, k - window)

    def _floor(self, system: _WindowSystem, key: tuple[int, ...], lo: int) -> np.ndarray:
        """The floor of ``system``'s keyframe (from :meth:`_system`, its window beginning at keyframe
        ``lo``) for the suite ``key``, the last gathered: its landmarks' blocks with the suite's
        measurements of them before the window too, and the odometry from the pose before it as a
        prior.

        Those measurements are the gathered terms' before the window where they hold every keyframe
        before it; else they are taken from each sensor's own (a few of a long route's, not the route
        merged up to the window) and put in the suite's order (by keyframe, a keyframe's in the suite's
        sensor order): the order the merged terms hold them in, so the same sums either way."""
        assert self._last is not None and self._last[0] == key
        covered, terms = self._last[1], self._last[2]
        if covered[:lo].all():
            start = int(np.searchsorted(terms[0], lo))
            landmark, BB = terms[1][:start], terms[4][:start]
        else:  # each sensor's measurements of the window's landmarks before it, merged as a suite's
            parts = []
            for i in key:
                sensor, at = self._sensor_terms(i)
                before = int(at[lo])
                sel = np.flatnonzero(self._slots(system.lms, sensor[1][:before]) >= 0)
                parts.append(tuple(t[sel] for t in sensor))
            _, landmark, _, _, BB = _merged(parts)  # type: ignore[arg-type]
        which = self._slots(system.lms, landmark)
        kept = which >= 0
        which, BB = which[kept], BB[kept]
        blocks = system.blocks + _sums(which, BB, len(system.lms))
        first = self._odo_info if system.first is None else system.first
        return _last_marginal(system.pose, first, blocks, system.coupling)

    def _ceiling_on(
        self,
        poses: np.ndarray,
        rows: np.ndarray,
        keyframe: np.ndarray,
        landmark: np.ndarray,
        AA: np.ndarray,
        AB: np.ndarray,
        BB: np.ndarray,
    ) -> np.ndarray:
        """The ceiling at the last of ``poses`` (sorted keyframes) from the subgraph of those poses: the
        odometry between those that follow one another, the suite's measurements ``rows`` (of the
        terms sorted by keyframe: those from these poses) and their landmarks' priors (the first
        pose's prior too where it is keyframe 0)."""
        index = np.full(int(poses[-1]) + 1, -1, np.int64)
        index[poses] = np.arange(len(poses))
        rel = index[keyframe[rows]]
        pose = self._pose_block(poses, rel, AA[rows])
        lms, which, W = self._coupling(landmark[rows], rel, AB[rows], len(poses))
        blocks = _sums(which, BB[rows], len(lms)) + self._landmark_prior
        return _last_marginal(pose, self._first_info if poses[0] == 0 else None, blocks, W)

    def _pose_block(self, poses: np.ndarray, rel: np.ndarray, AA: np.ndarray) -> np.ndarray:
        """(3n, 3n) the information on ``poses`` (n sorted keyframes) of their measurements' AᵀA (``rel``:
        each one's index in ``poses``) and of the odometry between those that follow one another."""
        n_p = len(poses)
        # sums by np.bincount over flat indices: an order of magnitude below np.add.at's
        diagonal = _sums(rel, AA, n_p)
        if n_p and int(poses[-1]) - int(poses[0]) == n_p - 1:  # consecutive (a window): a band
            steps = poses[:-1]
            diagonal[:-1] += self._ht_o_h[steps]
            diagonal[1:] += self._odo_info
            on, above, below = self._band(n_p)
            flat = np.zeros(9 * n_p * n_p)
            flat[on] = diagonal.reshape(-1)
            flat[above] = self._ht_o[steps].reshape(-1)
            flat[below] = np.transpose(self._ht_o[steps], (0, 2, 1)).reshape(-1)
            return flat.reshape(3 * n_p, 3 * n_p)
        step = np.flatnonzero(poses[1:] == poses[:-1] + 1)  # poses[t] -> poses[t + 1]: an odometry step
        diagonal[step] += self._ht_o_h[poses[step]]
        diagonal[step + 1] += self._odo_info
        blocks4 = np.zeros((n_p, 3, n_p, 3))
        at = np.arange(n_p)
        blocks4[at, :, at, :] = diagonal
        blocks4[step, :, step + 1, :] = self._ht_o[poses[step]]
        blocks4[step + 1, :, step, :] = np.transpose(self._ht_o[poses[step]], (0, 2, 1))
        return blocks4.reshape(3 * n_p, 3 * n_p)

    def _band(self, n_p: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Where the (3n, 3n) information of ``n_p`` consecutive poses, flattened, holds each pose's 3 x 3
        block (n, 3, 3), the odometry's block above it (pose t's row, pose t + 1's column; (n - 1, 3, 3))
        and below it (their transposes' places), each in C order: flat indices, kept per size."""
        got = self._bands.get(n_p)
        if got is None:
            width = 3 * n_p
            t = np.arange(n_p)[:, None, None]
            r, c = np.arange(3)[None, :, None], np.arange(3)[None, None, :]
            on = ((3 * t + r) * width + 3 * t + c).reshape(-1)
            t = t[:-1]
            above = ((3 * t + r) * width + 3 * (t + 1) + c).reshape(-1)
            below = ((3 * (t + 1) + r) * width + 3 * t + c).reshape(-1)
            got = self._bands[n_p] = (on, above, below)
        return got

    def _slots(self, lms: np.ndarray, landmark: np.ndarray) -> np.ndarray:
        """Each of ``landmark``'s index in ``lms`` (sorted distinct landmarks), -1 where it is not one."""
        slot = self._slot
        slot[lms] = np.arange(len(lms))
        out = slot[landmark]
        slot[lms] = -1
        return out

    def _coupling(
        self, landmark: np.ndarray, rel: np.ndarray, AB: np.ndarray, n_p: int
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The landmarks measured (sorted, L), each measurement's index among them, and W (L, 2, 3 n_p):
        W_lᵀ, landmark l's coupling to the poses, its rows at pose j the sum of its AᵀB there."""
        seen = self._seen
        seen[landmark] = True
        lms = np.flatnonzero(seen)  # np.unique's answer (sorted, distinct) without its sort
        seen[lms] = False
        which = self._slots(lms, landmark)
        L = len(lms)
        sums = _sums(which * n_p + rel, AB, L * n_p).reshape(L, n_p, 3, 2)
        return lms, which, np.transpose(sums, (0, 3, 1, 2)).reshape(L, 2, 3 * n_p)


def _suite_key(suite: Iterable[int]) -> tuple[int, ...]:
    """A suite's sorted distinct library positions."""
    return tuple(sorted(set(int(i) for i in suite)))


def _merged(parts: list[_Terms]) -> _Terms:
    """``parts`` (each sensor's terms, in the suite's sensor order) concatenated and sorted by keyframe
    (stable: a keyframe's in the parts' order, each part's in its own)."""
    keyframe, landmark, AA, AB, BB = (np.concatenate([p[f] for p in [_NO_TERMS, *parts]]) for f in range(5))
    order = np.argsort(keyframe, kind="stable")
    return keyframe[order], landmark[order], AA[order], AB[order], BB[order]


def _runs(ks: np.ndarray, window: int) -> tuple[tuple[int, int], ...]:
    """The keyframes of the windows of ``window`` keyframes before each of ``ks`` (and it), as sorted
    runs (first, stop) apart from one another."""
    runs: list[tuple[int, int]] = []
    for k in sorted(set(ks.tolist())):
        lo = max(0, k - window)
        if runs and lo <= runs[-1][1]:
            runs[-1] = (runs[-1][0], k + 1)
        else:
            runs.append((lo, k + 1))
    return tuple(runs)


def _starts(terms: _Terms, ks: np.ndarray) -> np.ndarray:
    """Where each keyframe's terms begin in ``terms`` (sorted by keyframe), for keyframes 0 .. max(ks) + 1."""
    return np.searchsorted(terms[0], np.arange(int(ks.max(initial=0)) + 2))


def _last_marginal(pose: np.ndarray, prior: np.ndarray | None, blocks: np.ndarray, W: np.ndarray) -> np.ndarray:
    """The 3 x 3 marginal covariance of the last pose of the system with pose block ``pose`` (3n, 3n),
    ``prior`` (3 x 3, or None) added on the first pose, and landmarks of blocks ``blocks`` (L, 2, 2)
    coupled by ``W`` (L, 2, 3n); +inf where the system is singular."""
    info = pose.copy()
    if prior is not None:
        info[:3, :3] += prior
    if len(blocks):
        # the landmarks eliminated: info − Σ_l W_l D_l⁻¹ W_lᵀ = info − Yᵀ Y, Y_l = G_l⁻¹ W_lᵀ
        # with G_l Gₗᵀ = D_l (2 x 2 Cholesky factors, in closed form)
        g11 = np.sqrt(blocks[:, 0, 0])
        g21 = blocks[:, 1, 0] / g11
        g22 = np.sqrt(blocks[:, 1, 1] - g21 * g21)
        y0 = W[:, 0] / g11[:, None]
        y1 = (W[:, 1] - g21[:, None] * y0) / g22[:, None]
        Y = np.concatenate([y0, y1])
        info -= Y.T @ Y
    factor, bad = dpotrf(info, lower=1, clean=1)
    if bad:
        return np.full((3, 3), np.inf)  # only a ceiling's can be singular (a floor's holds a prior)
    # the last pose's marginal is the last 3 x 3 block of info⁻¹ = F⁻ᵀ F⁻¹ (F lower triangular, so
    # F⁻¹'s last three columns are 0 but in its last block row): yᵀ y, y the inverse of F's last
    # diagonal block
    y, _ = dtrtri(np.ascontiguousarray(factor[-3:, -3:]), lower=1)
    return y.T @ y


def _sums(index: np.ndarray, values: np.ndarray, n: int) -> np.ndarray:
    """(n, *values.shape[1:]) the sums of ``values`` (m, ...) by ``index`` (m,) in 0..n − 1."""
    tail = values.shape[1:]
    size = math.prod(tail)
    flat = (np.asarray(index, np.int64)[:, None] * size + np.arange(size)).ravel()
    sums = np.bincount(flat, values.reshape(-1), minlength=n * size)
    return sums.astype(float, copy=False).reshape((n, *tail))  # (an empty bincount is of integers)


def pass_flops(problem: Problem, suite: Iterable[int]) -> float:
    """A model of the flops a keyframe of ``suite``'s filter pass costs on ``problem`` (its windows of
    :data:`~sensorsel.information.filtering.WINDOW_KEYFRAMES`, g), from which landmarks it measures
    when, without a pass: at keyframe k, (3 + 2a)² r for the update (a: the landmarks whose
    measurements are at most g keyframes apart around k, the state a window works on; r: the
    measurement rows), and (2d)² 2a / g for the closes (d: the landmarks held meanwhile, measured
    before and again later: a window's dormant ones). What it is for: telling a pass of a few
    landmarks in view (cameras: ~0.1-0.7 ms a keyframe) from one that holds hundreds (a roof LiDAR or
    radars on a user's drive with a loop: 4-40 ms). Measured against the passes (KITTI 00's ground truth
    with 1,614 generated landmarks, its pole map, the README's route; 12 suites each): a pass took
    0.1 ms plus 1-4e-10 s per modelled flop a keyframe, a factor of 3 either way (two suites whose
    models differ by less than that can come in either order; the two kinds above do not)."""
    K = problem.scenario.n_poses
    sensors = sorted(set(int(i) for i in suite))
    if not K or not sensors:
        return 0.0
    pose = np.concatenate([np.asarray(problem.observations[i].pose, np.int64) for i in sensors])
    landmark = np.concatenate([np.asarray(problem.observations[i].landmark, np.int64) for i in sensors])
    if not len(pose):
        return 0.0
    rows = 2.0 * np.bincount(pose, minlength=K)
    order = np.lexsort((pose, landmark))
    pose, landmark = pose[order], landmark[order]
    same = landmark[1:] == landmark[:-1]

    def spans(starts: np.ndarray) -> np.ndarray:
        # (K,) how many runs cover k: a run is a landmark's measurements from a start up to the last
        # one before the next start (their keyframes, inclusive)
        ends = np.ones(len(pose), bool)
        ends[:-1] = starts[1:]
        count = np.zeros(K + 1)
        np.add.at(count, pose[starts], 1.0)
        np.add.at(count, pose[ends] + 1, -1.0)
        return np.cumsum(count)[:K]

    first = np.ones(len(pose), bool)
    first[1:] = ~same
    run = first.copy()
    run[1:] |= np.diff(pose) > WINDOW_KEYFRAMES
    active, held = spans(run), spans(first)
    update = (3 + 2 * active) ** 2 * rows
    close = (2 * (held - active)) ** 2 * (2 * active) / WINDOW_KEYFRAMES
    return float((update + close).sum() / K)
