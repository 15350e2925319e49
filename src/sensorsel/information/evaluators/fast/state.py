"""The incremental state: a suite as pair weights and sums, built once per base suite and shared by
every candidate scored with it (each candidate adds its own few thousand pairs to copies)."""

from __future__ import annotations

import threading
from dataclasses import dataclass, field

import numpy as np

from sensorsel.information.evaluators.base import Suite
from sensorsel.information.evaluators.fast.kernel import SYM3
from sensorsel.information.evaluators.fast.plan import Layout, Planner
from sensorsel.information.linearize import LibraryLinearization


@dataclass(frozen=True, eq=False)
class BaseState:
    """A base suite's state, shared (read-only) by every candidate scored with it.

    P pairs, M landmarks, K keyframes, Pa active pairs (measured by the suite).
    """

    suite: Suite
    w: (
        np.ndarray
    )  # (2, P) information of each measurement row (bearing [1/rad²], range [1/m²]) of each pair (0: not measured)
    d: np.ndarray  # (3, M) landmark information d00, d01, d11
    a: np.ndarray  # (6, K) measurement information on the pose diagonal blocks (unique entries)
    layout: Layout
    wpl: np.ndarray  # (6, Pa) W_p = sum_r w_r hp_r hl_r^T of each active pair, entry c * 3 + a = W[a, c]


@dataclass(frozen=True, eq=False)
class KernelInput:
    """What the kernel needs for one suite (see :meth:`sensorsel.information.evaluators.fast.kernel.Kernel.logdet`)."""

    wpl: np.ndarray  # (6, Pa)
    d: np.ndarray  # (3, M)
    a: np.ndarray  # (6, K)
    layout: Layout


#: bytes of index arrays of the candidates' own layouts kept for the next base with the same pairs
#: (on KITTI 00 at 1 Hz a radar's layout is ~9 MB: ~14 of them)
GROWN_LAYOUT_BYTES = 128_000_000


def layout_bytes(layout: Layout) -> int:
    """The bytes of a layout's index arrays (what keeping it costs)."""
    return int(
        sum(x.nbytes for x in (layout.act, layout.landmark, layout.pose, layout.flat, layout.dims, *layout.group_pose))
    )


@dataclass(eq=False)
class _Layouts:
    """A base's layout, the pairs it measures and the layouts its candidates grew (by position)."""

    act: np.ndarray
    layout: Layout
    grown: dict[int, Layout] = field(default_factory=dict)
    nbytes: int = 0


@dataclass(frozen=True, eq=False)
class SensorSums:
    """One sensor's own information on the landmark and pose diagonal blocks (what it adds to any suite)."""

    landmarks: np.ndarray  # (m,) landmarks it measures, sorted
    d: np.ndarray  # (3, m) their information d00, d01, d11
    poses: np.ndarray  # (k,) keyframes it measures from, sorted
    a: np.ndarray  # (6, k) their pose-diagonal information (unique entries)


class StateBuilder:
    """The per-pair pieces of a linearized library, and the suite states built from them.

    Every measurement row r (0 bearing, 1 range) of a pair contributes ``ω_r h_r h_rᵀ`` at weight
    ω_r = Σ 1/σ_r² over the suite's sensors measuring the pair; its rank-one pieces at unit weight are
    stored one component per contiguous row (vector operations run over pairs, not over 2x3 blocks).
    """

    def __init__(self, lin: LibraryLinearization, planner: Planner) -> None:
        self.planner = planner
        self.n_poses, self.n_landmarks = planner.n_poses, planner.n_landmarks
        self.pair_pose, self.pair_landmark = lin.pair_pose, lin.pair_landmark
        # the Jacobians' entries as contiguous rows, so that the products below run over contiguous
        # arrays (on the (P, 2, 5) array's strided columns they took ~90 of ~100 ms on KITTI 00)
        jr = self.jacobian_rows = np.ascontiguousarray(lin.pair_jacobian.transpose(1, 2, 0))  # (2, 5, P): row r, column
        hp, hl = jr[:, :3], jr[:, 3:]  # (2, 3, P) pose and (2, 2, P) landmark columns
        self.hll = np.stack([hl[:, 0] ** 2, hl[:, 0] * hl[:, 1], hl[:, 1] ** 2], axis=1)  # (2, 3, P)
        self.hpp = np.stack([hp[:, i] * hp[:, j] for i, j in SYM3], axis=1)  # (2, 6, P)
        # W_p = sum_r w_r hp_r hl_r^T is kept transposed: entry c * 3 + a = W[a, c]; rows 0:6 bearing, 6:12 range
        self.hpl = (hl[:, :, None, :] * hp[:, None, :, :]).reshape(12, -1)  # (12, P): row r * 6 + c * 3 + a
        self.sensor_pairs = lin.sensor_pairs
        self.sensor_w = tuple(np.ascontiguousarray((1.0 / s**2).T) for s in lin.sensor_sigmas)  # (2, n_s)
        bl = lin.base_landmark_information
        self.base_ll = np.stack([bl[:, 0, 0], bl[:, 0, 1], bl[:, 1, 1]])  # (3, M)
        self._sensor_sums: dict[int, SensorSums] = {}
        self._reuse: _Layouts | None = None  # the last base's layouts, kept while bases measure the same pairs
        self._lock = threading.Lock()

    def _base_layout(self, act: np.ndarray) -> Layout:
        """The layout of a base measuring the pairs ``act``: the last base's own (and the layouts its
        candidates grew) when it measured the same pairs (a greedy step that bought a sensor adding
        no pair: a camera inside the LiDAR's range), else a new one. Same pairs, same layout: the
        same numbers, without planning it and its candidates' again (~15 ms a layout on KITTI 00)."""
        with self._lock:
            last = self._reuse
            if last is not None and np.array_equal(last.act, act):
                return last.layout
        layout = self.planner.layout(act)
        with self._lock:
            self._reuse = _Layouts(act, layout)
        return layout

    def _grown_layout(self, base: BaseState, c: int, act: np.ndarray) -> Layout:
        """The layout of ``base.suite + {c}`` measuring the pairs ``act`` (a superset of the base's),
        kept for the next bases with the same pairs while :data:`GROWN_LAYOUT_BYTES` allow."""
        with self._lock:
            last = self._reuse
            keep = last if last is not None and last.layout is base.layout else None
            got = keep.grown.get(c) if keep is not None else None
        if got is not None:
            return got
        layout = self.planner.layout(act, grown_from=base.layout)
        with self._lock:
            if keep is not None and keep.nbytes + layout_bytes(layout) <= GROWN_LAYOUT_BYTES:
                keep.grown[c] = layout
                keep.nbytes += layout_bytes(layout)
        return layout

    def base(self, suite: Suite) -> BaseState:
        """State of a canonical suite: pair weights, sums, layout and W of its active pairs."""
        d = self.base_ll.copy()
        a = np.zeros((6, self.n_poses))
        for s in suite:  # the sums as those of the sensors' own, in suite order (~1 ms; over the pairs ~15 on KITTI 00)
            own = self.sensor_sums(s)
            d[:, own.landmarks] += own.d
            a[:, own.poses] += own.a
        # each pair's weights, summed over the suite's sensors in suite order
        w = np.zeros((2, len(self.pair_pose)))
        if suite:
            pairs = np.concatenate([self.sensor_pairs[s] for s in suite])
            for r in range(2):
                w[r] = np.bincount(pairs, np.concatenate([self.sensor_w[s][r] for s in suite]), len(self.pair_pose))
        act = np.flatnonzero(w[0] + w[1] > 0)
        layout = self._base_layout(act)
        return BaseState(suite, w, d, a, layout, self._pairs_wpl(act, np.take(w, act, axis=1)))

    def sensor_sums(self, c: int) -> SensorSums:
        """Sensor ``c``'s own landmark and pose-diagonal information (computed once, then kept)."""
        got = self._sensor_sums.get(c)
        if got is None:
            pairs, w = self.sensor_pairs[c], self.sensor_w[c]
            d, a = np.zeros((3, self.n_landmarks)), np.zeros((6, self.n_poses))
            self._accumulate(d, a, pairs, w)
            # the landmarks and keyframes it measures, by masks (np.unique sorted them: ~2x as long)
            lm = np.flatnonzero(np.bincount(self.pair_landmark[pairs], minlength=self.n_landmarks))
            ps = np.flatnonzero(np.bincount(self.pair_pose[pairs], minlength=self.n_poses))
            got = self._sensor_sums[c] = SensorSums(lm, d[:, lm], ps, a[:, ps])
        return got

    def candidate(self, base: BaseState, c: int) -> KernelInput:
        """The kernel's input for ``base.suite + {c}``; ``base`` is not written to."""
        if c in base.suite:
            return KernelInput(base.wpl, base.d, base.a, base.layout)
        pairs, wc = self.sensor_pairs[c], self.sensor_w[c]
        # c's own sums, kept per sensor: the base's plus them are the bits accumulating c's pairs
        # onto copies of the base's gave (each is a bincount from zero, added once)
        own = self.sensor_sums(c)
        d, a = base.d.copy(), base.a.copy()
        d[:, own.landmarks] += own.d
        a[:, own.poses] += own.a
        piece = self._pairs_wpl(pairs, wc)  # c's W on its pairs
        layout = base.layout
        act = layout.act
        at = np.searchsorted(act, pairs)
        if len(pairs) and (at[-1] >= len(act) or np.any(act[np.minimum(at, len(act) - 1)] != pairs)):
            # the candidate measures pairs the base does not: a layout of its own, and the base's W
            # moved to their places in it (recomputing W of every pair took ~10 ms on KITTI 00)
            measured = np.zeros(len(self.pair_pose), dtype=bool)
            measured[act] = True
            measured[pairs] = True
            rank = np.cumsum(measured) - 1  # each measured pair's place among them (searchsorted took ~3x as long)
            layout = self._grown_layout(base, c, np.flatnonzero(measured))
            wpl = np.zeros((6, len(layout.act)))
            wpl[:, rank[act]] = base.wpl
            wpl[:, rank[pairs]] += piece
        else:
            wpl = base.wpl.copy()
            wpl[:, at] += piece
        return KernelInput(wpl, d, a, layout)

    def _pairs_wpl(self, pairs: np.ndarray, w: np.ndarray) -> np.ndarray:
        """W of ``pairs`` (n,) with row weights ``w`` (2, n): (6, n), W_p = Σ_r w_r hp_r hl_rᵀ, a row
        at a time (a (12, n) gather of the pieces first took ~2x as long on a base of KITTI 00)."""
        out = np.empty((6, len(pairs)))
        for i in range(6):
            np.multiply(w[0], np.take(self.hpl[i], pairs), out=out[i])
            out[i] += w[1] * np.take(self.hpl[6 + i], pairs)
        return out

    def _accumulate(self, d: np.ndarray, a: np.ndarray, pairs: np.ndarray, w: np.ndarray) -> None:
        """Add, in place, the landmark (d: 3, M) and pose-diagonal (a: 6, K) information of
        ``pairs`` (n,) with row weights ``w`` (2, n)."""
        lm, ps = self.pair_landmark[pairs], self.pair_pose[pairs]
        hll = np.take(self.hll, pairs, axis=2)
        hpp = np.take(self.hpp, pairs, axis=2)
        for i in range(3):
            d[i] += np.bincount(lm, w[0] * hll[0, i] + w[1] * hll[1, i], self.n_landmarks)
        for i in range(6):
            a[i] += np.bincount(ps, w[0] * hpp[0, i] + w[1] * hpp[1, i], self.n_poses)
