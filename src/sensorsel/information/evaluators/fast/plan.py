"""The tiling plan of the Schur product: landmark groups in route order, keyframe runs, BLAS calls.

A plan depends only on which (keyframe, landmark) pairs are measured, not on their weights: a
base suite's plan is reused by every candidate that measures no pair the base does not.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from sensorsel.model.problem import Problem

#: landmarks per group (tile) of the Schur product
GROUP_SIZE = 16
#: runs of keyframes of a group's tile closer than this are joined (zero rows in between)
RUN_GAP = 6
#: :attr:`Layout.pattern` is a dense product below this many groups x K² multiply-adds, else a sparse one
_DENSE_PATTERN_FLOPS = 1e8


def route_order(problem: Problem, landmarks: np.ndarray) -> np.ndarray:
    """``landmarks`` (n,) indices sorted by the route frame nearest to each (ties: by index), (n,).

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
class Layout:
    """Where the Schur product of one pattern of active pairs goes: tiles, BLAS calls, sparsity.

    A tile is the dense (3 x keyframes) x (2 x landmarks) block of Y for one landmark group, rows
    restricted to the keyframes that see the group, stored row-major in one buffer. Each call
    accumulates one (run a, run b) block of tile @ tile.T into the lower triangle of the pose
    matrix, where a run is a range of consecutive keyframes of the tile (runs less than RUN_GAP
    keyframes apart joined). Offsets count float64 entries; the pose matrix is (3K, 3K) row-major.
    """

    act: np.ndarray  # (Pa,) active pair indices, sorted
    landmark: np.ndarray  # (Pa,) landmark of each active pair
    pose: np.ndarray  # (Pa,) keyframe of each active pair
    flat: np.ndarray  # (6 * Pa,) index into the tile buffer of each entry of Yᵀ, as (2, 3, Pa)
    size: int  # tile buffer length [entries]
    calls: list[tuple[int, int, int, int, int, int, int, bool]]  # (a_off, b_off, row, col, m, n, k, same):
    #   P[row: row + m, col: col + n] -= A[a_off] @ A[b_off].T; A (m x k) and B (n x k) row-major
    #   tiles of leading dimension k; ``same``: a_off == b_off, lower triangle only
    dims: np.ndarray  # (len(calls), 3) C int (m, n, k) of each call, for BLAS's by-pointer arguments
    group_pose: tuple[np.ndarray, np.ndarray]  # (group, keyframe) of every distinct pair: the pattern's source
    base_blocks: tuple[np.ndarray, np.ndarray]  # (row, column) pose blocks non-zero in the base graph
    n_poses: int
    grown_from: Layout | None = (
        None  # a layout of a subset of these pairs (a candidate's base): its pattern is a subset
    )

    def density_below(self, limit: float) -> bool:
        """Whether :attr:`density` < ``limit``, without building the pattern when a layout this one
        grew from is already at or above it (more pairs, more non-zero blocks: the same answer;
        building a pattern cost ~6 ms per candidate on KITTI 00 at 1 Hz)."""
        if self.grown_from is not None and not self.grown_from.density_below(limit):
            return False
        return self.density < limit

    @cached_property
    def pattern(self) -> np.ndarray:
        """(K, K) bool: pose blocks of the lower triangle that can be non-zero (keyframes that see a
        common group: a superset of the exact pattern whose extra entries are exact zeros). Built on
        demand (quadratic memory): only the sparse path needs it."""
        K = self.n_poses
        g, ps = self.group_pose
        n_groups = int(g.max()) + 1 if len(g) else 0
        if n_groups * K * K <= _DENSE_PATTERN_FLOPS:
            # keyframes sharing a group as a dense (groups, K) 0/1 product: exact small counts, one
            # BLAS call (the sparse product cost ~3 ms per candidate layout on KITTI 00 at 1 Hz, this ~0.5 ms)
            mf = np.zeros((n_groups, K), dtype=np.float32)
            mf[g, ps] = 1.0
            pat = (mf.T @ mf) > 0
        else:
            mf = sp.csr_matrix((np.ones(len(g), dtype=np.float32), (g, ps)), shape=(n_groups, K))
            pat = (mf.T @ mf).toarray() > 0
        pat[self.base_blocks] = True
        pat[np.arange(K), np.arange(K)] = True
        return np.tril(pat)

    @cached_property
    def density(self) -> float:
        """Fraction of non-zero pose blocks of the full matrix."""
        K = self.n_poses
        return (2 * int(np.count_nonzero(self.pattern)) - K) / float(K * K)


class Planner:
    """Plans the tiles of any set of active pairs of one problem (fixed: pairs, groups, base pattern).

    Args:
        problem: the scenario (route, landmarks) whose pairs are planned.
        pair_pose, pair_landmark: (P,) keyframe and landmark of each distinct measured pair.
        base_blocks: (row, column) of the pose blocks non-zero in the base graph (any triangle).
    """

    def __init__(
        self,
        problem: Problem,
        pair_pose: np.ndarray,
        pair_landmark: np.ndarray,
        base_blocks: tuple[np.ndarray, np.ndarray],
    ) -> None:
        self.n_poses = K = problem.scenario.n_poses
        self.n_landmarks = M = problem.scenario.n_landmarks
        self.pair_pose, self.pair_landmark = pair_pose, pair_landmark
        br, bc = (np.asarray(x, dtype=np.int64) for x in base_blocks)
        self.base_blocks = (np.maximum(br, bc), np.minimum(br, bc))  # lower triangle
        # landmark groups: seen landmarks in route order, GROUP_SIZE per group
        seen = np.zeros(M, dtype=bool)
        seen[pair_landmark] = True
        order = route_order(problem, np.flatnonzero(seen))
        self.group = np.full(M, -1, dtype=np.int64)
        self.group[order] = np.arange(len(order)) // GROUP_SIZE
        self.n_groups = -(-len(order) // GROUP_SIZE)
        self.landmark_order = order  # seen landmarks sorted by group
        self.n = 3 * K

    def layout(self, act: np.ndarray, grown_from: Layout | None = None) -> Layout:
        """Tiles and BLAS calls of the Schur product for the active pairs ``act`` (sorted pair indices);
        ``grown_from``: a layout of a subset of ``act`` (see :meth:`Layout.density_below`).

        Long (~60 lines) on purpose: one vectorized pass from pairs to tiles, runs and calls, each
        step reading the previous one's arrays; split, the pieces would only pass a dozen arrays on.
        """
        K, M = self.n_poses, self.n_landmarks
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
        # less than RUN_GAP keyframes apart are joined (zero rows in between: fewer, larger calls).
        # From the sorted distinct (group, keyframe) pairs: linear in the pairs, not groups x keyframes.
        seen = np.zeros(
            self.n_groups * K, dtype=bool
        )  # sorted distinct keys by a mask: np.unique hashed and sorted (~3 ms on 00)
        seen[g * K + ps] = True
        key = np.flatnonzero(seen)
        gk, pk = key // K, key % K
        start = np.r_[True, (gk[1:] != gk[:-1]) | (pk[1:] - pk[:-1] - 1 > RUN_GAP)] if len(key) else np.zeros(0, bool)
        first = np.flatnonzero(start)
        last = np.r_[first[1:] - 1, len(key) - 1] if len(key) else first
        rg, rs, re = gk[first], pk[first], pk[last] + 1
        length = re - rs
        n_runs = np.bincount(rg, minlength=self.n_groups)
        first_run = np.concatenate([[0], np.cumsum(n_runs)])[:-1]
        cum = np.cumsum(length) - length
        row0 = cum - cum[first_run[rg]] if len(rg) else cum  # first keyframe row of each run in its tile
        nrows = 3 * np.bincount(rg, weights=length, minlength=self.n_groups).astype(np.int64)
        off = np.concatenate([[0], np.cumsum(nrows * ncols)])
        # the run holding each pair's keyframe: runs number the sorted keys, found by a table over the
        # (group, keyframe) cells (a searchsorted of every pair took ~6 ms a layout on KITTI 00)
        run = (np.cumsum(start) - 1)[(np.cumsum(seen) - 1)[g * K + ps]]
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
        row, col = 3 * rs[ia], 3 * rs[ib]
        m_rows, n_rows = 3 * length[ia], 3 * length[ib]
        calls = list(
            zip(
                a_off.tolist(),
                b_off.tolist(),
                row.tolist(),
                col.tolist(),
                m_rows.tolist(),
                n_rows.tolist(),
                k.tolist(),
                (ia == ib).tolist(),
            )
        )
        dims = np.ascontiguousarray(np.column_stack([m_rows, n_rows, k]), dtype=np.intc).reshape(-1, 3)
        return Layout(act, lm, ps, flat, int(off[-1]), calls, dims, (gk, pk), self.base_blocks, K, grown_from)
