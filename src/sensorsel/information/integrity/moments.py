"""The moments of the association risk's (measurement, candidate) pairs, for many keyframes at once.

A keyframe's risks need little of the filter's prediction: the pose's covariance, each state
landmark's 2 × 2 block, and the rows of the covariance of the pose and of the landmarks the keyframe
measures (their cross-covariances with every candidate). :class:`Snapshot` copies those while the
forward pass is at the keyframe (the pass updates its state in place afterwards), and
:class:`Batch` joins the snapshots of any number of keyframes, so that every pair of the route goes
through one vectorised computation (a few hundred numpy calls in all instead of a few hundred per
keyframe). Each pair's numbers are computed by the same operations on the same values as one
keyframe's alone: the batch changes how many pairs an array holds, not any pair's arithmetic.

Conventions of :mod:`~sensorsel.information.integrity.association` (its docstring has the formulas):
the pose's tangent (dx, dy in its own frame [m], dθ [rad]) first, then each landmark's (x, y) [m].
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from sensorsel.information.filtering import KeyframeMeasurements, Prediction
from sensorsel.information.linearize import bearing_range_jacobians
from sensorsel.model.angles import wrap_angle

__all__ = ["Batch", "Candidates", "Snapshot"]

_TWO = np.arange(2)
_THREE = np.arange(3)


@dataclass(frozen=True, eq=False)
class Snapshot:
    """What the risks of keyframe k's measurements read of the prediction before them, copied.

    Attributes:
        keyframe: k.
        meas: keyframe k's measurements (those whose risks the snapshot is for).
        held: (n,) the landmark indices in the state, in its order (the pass's: not sorted).
        pose_cov: (3, 3) the pose's covariance.
        rows: (3 + 2q, 3 + 2n) the covariance's rows of the pose, then of each of the q state
            landmarks the keyframe measures (two rows each, in slot order).
        slot: (m,) each measurement's landmark's slot in the state (−1: not in it).
        row: (m,) the row of ``rows`` of its landmark's x (−1: not in the state).
        blocks: (n, 2, 2) each state landmark's covariance block.
        lm_trace_max: the largest trace of ``blocks`` (0 with none) [m²].
        prior_sigma_m: the prior std of a landmark not in the state [m].
    """

    keyframe: int
    meas: KeyframeMeasurements
    held: np.ndarray
    pose_cov: np.ndarray
    rows: np.ndarray
    slot: np.ndarray
    row: np.ndarray
    blocks: np.ndarray
    lm_trace_max: float
    prior_sigma_m: float

    @classmethod
    def of(cls, prediction: Prediction, meas: KeyframeMeasurements) -> Snapshot:
        """The snapshot of ``prediction`` for ``meas`` (copies: valid after the prediction changes)."""
        cov = np.asarray(prediction.covariance, float)
        held = np.array(prediction.landmarks, np.int64)
        n = len(held)
        slot = prediction.slots_of(meas.landmark)  # the pass's own table: a gather
        inside = slot >= 0
        # the state landmarks measured, in slot order, and each measurement's rank among them (the
        # measured slots' sorted unique values: integers, however found)
        some = np.sort(slot[inside])
        measured = some[np.concatenate([[True], some[1:] != some[:-1]])] if len(some) else some
        row = np.full(len(slot), -1, np.int64)
        row[inside] = 3 + 2 * np.searchsorted(measured, slot[inside])
        idx = np.empty(3 + 2 * len(measured), np.int64)
        idx[:3] = _THREE
        idx[3::2] = 3 + 2 * measured
        idx[4::2] = 4 + 2 * measured
        # the landmarks' 2 × 2 diagonal blocks, copied from the diagonal and the two next to it
        blocks = np.empty((n, 2, 2))
        diag = cov.diagonal()
        blocks[:, 0, 0], blocks[:, 1, 1] = diag[3::2], diag[4::2]
        blocks[:, 0, 1], blocks[:, 1, 0] = cov.diagonal(1)[3::2], cov.diagonal(-1)[3::2]
        # the largest landmark trace, as the sum of the diagonal's pairs (the same sum as before)
        trace = float((diag[3::2] + diag[4::2]).max(initial=0.0))
        return cls(
            int(prediction.keyframe),
            meas,
            held,
            cov[:3, :3].copy(),
            cov[idx],  # rows gathered (take would first copy a strided view whole)
            slot,
            row,
            blocks,
            trace,
            float(prediction.prior_sigma_m),
        )


@dataclass(frozen=True, eq=False)
class Batch:
    """Many keyframes' snapshots and measurements joined (B keyframes, M measurements in all).

    Attributes:
        poses: (B, 3) the true poses (x [m], y [m], heading [rad]).
        pose_cov: (B, 3, 3); lm_trace_max: (B,) [m²]; prior_sigma_m: the landmarks' prior std [m].
        held, held_off: the state landmarks of every keyframe, joined, and where each one's start (B + 1,).
        blocks: (Σn, 2, 2) their covariance blocks, aligned with ``held``.
        rows, rows_off, width: every snapshot's ``rows`` flattened and joined, where each starts
            (B,), and each one's row length 3 + 2n (B,).
        meas: the measurements' fields joined (``landmark``, ``sensor``, ``bearing_rad``, ``range_m``,
            ``sigma_bearing_rad``, ``sigma_range_m``: (M,) each), their keyframe in the batch ``at``
            (M,), ``meas_off`` (B + 1,) where each keyframe's start; ``slot``, ``row`` (M,) as the
            snapshot's.
    """

    poses: np.ndarray
    pose_cov: np.ndarray
    lm_trace_max: np.ndarray
    prior_sigma_m: float
    held: np.ndarray
    held_off: np.ndarray
    blocks: np.ndarray
    rows: np.ndarray
    rows_off: np.ndarray
    width: np.ndarray
    meas: dict[str, np.ndarray]
    at: np.ndarray
    meas_off: np.ndarray
    slot: np.ndarray
    row: np.ndarray

    @classmethod
    def of(cls, poses: np.ndarray, snapshots: Sequence[Snapshot]) -> Batch:
        """The batch of ``snapshots`` (at least one) and their keyframes' true ``poses`` (B, 3)."""
        if not snapshots:
            raise ValueError("a batch needs at least one keyframe's snapshot")
        meas = [s.meas for s in snapshots]
        priors = {s.prior_sigma_m for s in snapshots}
        if len(priors) != 1:
            raise ValueError(f"a batch's snapshots share one landmark prior, got {sorted(priors)}")
        n_meas = np.array([len(m.landmark) for m in meas], np.int64)
        n_held = np.array([len(s.held) for s in snapshots], np.int64)
        sizes = np.array([s.rows.size for s in snapshots], np.int64)
        fields = ("landmark", "sensor", "bearing_rad", "range_m", "sigma_bearing_rad", "sigma_range_m")
        return cls(
            poses=np.asarray(poses, float),
            pose_cov=np.stack([s.pose_cov for s in snapshots]),
            lm_trace_max=np.array([s.lm_trace_max for s in snapshots]),
            prior_sigma_m=priors.pop(),
            held=np.concatenate([s.held for s in snapshots]),
            held_off=np.concatenate([[0], np.cumsum(n_held)]),
            blocks=np.concatenate([s.blocks for s in snapshots]),
            rows=np.concatenate([s.rows.ravel() for s in snapshots]),
            rows_off=np.concatenate([[0], np.cumsum(sizes)[:-1]]),
            width=3 + 2 * n_held,
            meas={f: np.concatenate([np.asarray(getattr(m, f)) for m in meas]) for f in fields},
            at=np.repeat(np.arange(len(meas)), n_meas),
            meas_off=np.concatenate([[0], np.cumsum(n_meas)]),
            slot=np.concatenate([s.slot for s in snapshots]),
            row=np.concatenate([s.row for s in snapshots]),
        )

    def part(self, lo: int, hi: int) -> Batch:
        """The batch of keyframes ``lo``..``hi`` − 1 of this one (views: nothing copied)."""
        h0, h1, m0, m1 = self.held_off[lo], self.held_off[hi], self.meas_off[lo], self.meas_off[hi]
        r0 = self.rows_off[lo]
        return Batch(
            poses=self.poses[lo:hi],
            pose_cov=self.pose_cov[lo:hi],
            lm_trace_max=self.lm_trace_max[lo:hi],
            prior_sigma_m=self.prior_sigma_m,
            held=self.held[h0:h1],
            held_off=self.held_off[lo : hi + 1] - h0,
            blocks=self.blocks[h0:h1],
            rows=self.rows[r0:],
            rows_off=self.rows_off[lo:hi] - r0,
            width=self.width[lo:hi],
            meas={f: v[m0:m1] for f, v in self.meas.items()},
            at=self.at[m0:m1] - lo,
            meas_off=self.meas_off[lo : hi + 1] - m0,
            slot=self.slot[m0:m1],
            row=self.row[m0:m1],
        )

    def slots(self, at: np.ndarray, landmarks: np.ndarray) -> np.ndarray:
        """(n,) the slot of each landmark in the state of keyframe ``at`` (n,) of the batch, or −1."""
        if self.held.size == 0:
            return np.full(len(landmarks), -1, np.int64)
        scale = int(max(self.held.max(initial=0), np.max(landmarks, initial=0))) + 1
        keys = np.repeat(np.arange(len(self.poses)), np.diff(self.held_off)) * scale + self.held
        # each state is in the pass's order (not sorted): the keys sorted once for the batch
        order = np.argsort(keys, kind="stable")
        query = at * scale + landmarks
        pos = order[np.minimum(np.searchsorted(keys[order], query), len(keys) - 1)]
        return np.where(keys[pos] == query, pos - self.held_off[at], -1).astype(np.int64)

    def pose_landmark(self, at: np.ndarray, slot: np.ndarray) -> np.ndarray:
        """(n, 3, 2) covariance between the pose and the landmark at ``slot`` of keyframe ``at``
        (0 when not in the state)."""
        out = np.zeros((len(slot), 3, 2))
        inside = slot >= 0
        a = at[inside]
        idx = (
            (self.rows_off[a] + 3 + 2 * slot[inside])[:, None, None]
            + np.arange(3)[None, :, None] * self.width[a][:, None, None]
            + _TWO[None, None, :]
        )
        out[inside] = self.rows[idx]
        return out

    def landmark_block(self, at: np.ndarray, slot: np.ndarray) -> np.ndarray:
        """(n, 2, 2) the covariance of the landmark at ``slot`` of keyframe ``at`` (its prior
        σ_p² I when not in the state)."""
        out = np.zeros((len(slot), 2, 2))
        inside = slot >= 0
        out[inside] = self.blocks[self.held_off[at[inside]] + slot[inside]]
        out[~inside] = self.prior_sigma_m**2 * np.eye(2)
        return out

    def cross_block(self, at: np.ndarray, row_i: np.ndarray, slot_i: np.ndarray, slot_j: np.ndarray) -> np.ndarray:
        """(n, 2, 2) the covariance between measured landmark i (its ``row_i``, ``slot_i``) and
        candidate j (``slot_j``, another landmark) at keyframe ``at``: the state's where both are in
        it, else 0 (a landmark out of the state carries its own prior error, independent of every
        other landmark's: the map's errors are drawn landmark by landmark)."""
        out = np.zeros((len(slot_i), 2, 2))
        both = (slot_i >= 0) & (slot_j >= 0)
        a = at[both]
        idx = (
            (self.rows_off[a] + row_i[both] * self.width[a] + 3 + 2 * slot_j[both])[:, None, None]
            + _TWO[None, :, None] * self.width[a][:, None, None]
            + _TWO[None, None, :]
        )
        out[both] = self.rows[idx]
        return out

    def line_of_sight_bounds(self, at: np.ndarray, slot: np.ndarray, points: np.ndarray) -> np.ndarray:
        """(n, 2) [m] upper bounds of (σ_a, σ_b), the std of the error w = e_l − R(θ) e_xy of the
        estimated position of the landmark at ``slot`` (−1: out of the state, its prior's) of keyframe
        ``at`` (n,), true position ``points`` (n, 2), along and across the line of sight from the
        keyframe's true pose (:func:`line_of_sight_spread`'s, from the same entries of the state:
        Cov(w) = E_ll + R E_pp Rᵀ − R E_pl − (R E_pl)ᵀ, 2 × 2, elementwise). Each variance adds 1e-12
        (tr E_ll + tr E_pp), a margin over the rounding of either computation (each below ~10 ulp of
        that sum: |R E_pl| entries are at most √(tr E_ll tr E_pp)), so that the bounds hold of the
        computed σ_a, σ_b. At most √tr Cov(w) each, and
        far below it across the line of sight where a stereo landmark's error runs along it."""
        inside = slot >= 0
        # the pose's part per keyframe (R E_pp Rᵀ, R's entries), gathered per candidate (the same bits)
        c, s = np.cos(self.poses[:, 2]), np.sin(self.poses[:, 2])
        p00, p01, p11 = self.pose_cov[:, 0, 0], self.pose_cov[:, 0, 1], self.pose_cov[:, 1, 1]
        q00 = (c * c * p00 - 2.0 * c * s * p01 + s * s * p11)[at]
        q11 = (s * s * p00 + 2.0 * c * s * p01 + c * c * p11)[at]
        q01 = (c * s * (p00 - p11) + (c * c - s * s) * p01)[at]
        t_pp, c, s = (p00 + p11)[at], c[at], s[at]
        every = bool(inside.all())  # SLAM's candidates: every one in the state, gathered as they are
        a, sl = (at, slot) if every else (at[inside], slot[inside])
        k, width = self.held_off[a] + sl, self.width[a]
        first = self.rows_off[a] + 3 + 2 * sl  # the pose's rows x, y at the landmark's columns

        def placed(x: np.ndarray, out_of_state: float) -> np.ndarray:
            """``x`` of the landmarks in the state, in place among all (``out_of_state`` elsewhere)."""
            if every:
                return x
            out = np.full(len(slot), out_of_state)
            out[inside] = x
            return out

        # out of the state: the prior's σ² I, no correlation with the pose (E_pl = 0)
        prior = self.prior_sigma_m**2
        l00, l11, l01 = (placed(self.blocks[k, i, j], v) for i, j, v in ((0, 0, prior), (1, 1, prior), (0, 1, 0.0)))
        xx, xy = placed(self.rows[first], 0.0), placed(self.rows[first + 1], 0.0)
        yx, yy = placed(self.rows[first + width], 0.0), placed(self.rows[first + width + 1], 0.0)
        w00 = l00 + q00 - 2.0 * (c * xx - s * yx)
        w11 = l11 + q11 - 2.0 * (s * xy + c * yy)
        w01 = l01 + q01 - (c * xy - s * yy) - (s * xx + c * yx)
        rel = points - self.poses[at, :2]
        rng = np.maximum(np.hypot(rel[:, 0], rel[:, 1]), 1e-9)
        ux, uy = rel[:, 0] / rng, rel[:, 1] / rng
        along = ux * ux * w00 + 2.0 * ux * uy * w01 + uy * uy * w11
        across = uy * uy * w00 - 2.0 * ux * uy * w01 + ux * ux * w11
        margin = 1e-12 * (l00 + l11 + t_pp)
        return np.sqrt(np.maximum(np.column_stack([along, across]), 0.0) + margin[:, None])

    def spreads(self, *, with_prior: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(B,) each of (sd_xy, sd_th, sd_lm): the predicted pose's position [m] and heading [rad]
        spreads and the largest landmark spread [m] (the prior's where larger, ``with_prior``)."""
        prior = 2.0 * self.prior_sigma_m**2 if with_prior else 0.0
        sd_lm = np.sqrt(np.maximum(self.lm_trace_max, prior))
        return np.sqrt(self.pose_cov[:, 0, 0] + self.pose_cov[:, 1, 1]), np.sqrt(self.pose_cov[:, 2, 2]), sd_lm


def noise_inverse(b: Batch, mi: np.ndarray) -> np.ndarray:
    """(n, 2, 2) R⁻¹ of each pair's measurement."""
    out = np.zeros((len(mi), 2, 2))
    out[:, 0, 0] = 1.0 / b.meas["sigma_bearing_rad"][mi] ** 2
    out[:, 1, 1] = 1.0 / b.meas["sigma_range_m"][mi] ** 2
    return out


@dataclass(frozen=True, eq=False)
class Pairs:
    """Per (measurement, candidate) pair: d (n, 2), S_i, S_j, C_D (n, 2, 2), Cov(ν_i, D) (n, 2, 2), λ (n,);
    the std (σ_a, σ_b) (n, 2) [m] of w along and across the line of sight and the true range (n,) [m]
    of the measured landmark i (the candidate's: :func:`candidate_moments`)."""

    d: np.ndarray
    s_i: np.ndarray
    s_j: np.ndarray
    c_d: np.ndarray
    c_id: np.ndarray
    lam: np.ndarray
    sigma_i: np.ndarray
    range_i: np.ndarray
    #: (n, 7, 7) the covariance of (pose error, l_i's error, l_j's error) (what the nonlinear
    #: estimate integrates over: nonlinear.py)
    joint: np.ndarray

    def select(self, mask: np.ndarray) -> Pairs:
        return Pairs(
            *(getattr(self, f)[mask] for f in ("d", "s_i", "s_j", "c_d", "c_id", "lam", "sigma_i", "range_i", "joint"))
        )


def pair_moments(
    b: Batch,
    points: np.ndarray,
    mi: np.ndarray,
    cj: np.ndarray,
    slot_j: np.ndarray,
    jac_j: np.ndarray,
    e_j: np.ndarray,
) -> Pairs:
    """The moments of each (measurement ``mi``, candidate ``cj``) pair; ``jac_j`` (n, 2, 5) and ``e_j``
    (n, 5, 5) candidate j's Jacobian and (pose, l_j) covariance block (:func:`candidate_moments`)."""
    at = b.at[mi]
    li, slot_i = b.meas["landmark"][mi], b.slot[mi]
    n = len(mi)
    # the 7 × 7 covariance of (δpose, δl_i, δl_j)
    e = np.zeros((n, 7, 7))
    e[:, :3, :3] = b.pose_cov[at]
    pi = b.pose_landmark(at, slot_i)
    e[:, :3, 3:5], e[:, :3, 5:7] = pi, e_j[:, :3, 3:]
    e[:, 3:5, :3], e[:, 5:7, :3] = np.transpose(pi, (0, 2, 1)), e_j[:, 3:, :3]
    e[:, 3:5, 3:5] = b.landmark_block(at, slot_i)
    e[:, 5:7, 5:7] = e_j[:, 3:, 3:]
    ij = b.cross_block(at, b.row[mi], slot_i, slot_j)
    e[:, 3:5, 5:7], e[:, 5:7, 3:5] = ij, np.transpose(ij, (0, 2, 1))
    poses = b.poses[at]
    jac_i = bearing_range_jacobians(poses, points[li])  # (n, 2, 5)
    bi = np.zeros((n, 2, 7))
    bi[:, :, :5] = jac_i
    c = np.zeros((n, 2, 7))
    c[:, :, :3], c[:, :, 5:7] = jac_j[:, :, :3], jac_j[:, :, 3:]
    r = np.zeros((n, 2, 2))
    r[:, 0, 0], r[:, 1, 1] = b.meas["sigma_bearing_rad"][mi] ** 2, b.meas["sigma_range_m"][mi] ** 2
    s_i = r + bi @ e @ np.transpose(bi, (0, 2, 1))
    s_j = r + c @ e @ np.transpose(c, (0, 2, 1))
    a = c - bi
    c_d = a @ e @ np.transpose(a, (0, 2, 1))
    c_id = bi @ e @ np.transpose(a, (0, 2, 1))
    d = innovation_means(b, points, mi, cj, at)
    lam = np.einsum("ni,ni->n", d, np.linalg.solve(s_j, d[:, :, None])[:, :, 0])
    sigma_i, range_i = line_of_sight_spread(poses, points[li], e, 3)
    return Pairs(d=d, s_i=s_i, s_j=s_j, c_d=c_d, c_id=c_id, lam=lam, sigma_i=sigma_i, range_i=range_i, joint=e)


@dataclass(frozen=True, eq=False)
class Candidates:
    """Candidate j's part of the moments, once per (keyframe, candidate) of a batch (u of them): what
    depends on the candidate alone, whatever measurement it is paired with.

    Attributes:
        jac: (u, 2, 5) the Jacobian H_j of its bearing and range in the (pose, l_j) errors.
        e: (u, 5, 5) the covariance of the (pose, l_j) errors.
        hph: (u, 2, 2) H_j E H_jᵀ (S_j without the measurement's noise).
        poses: (u, 3) the true pose of its keyframe; points: (u, 2) [m] its true position.
    """

    jac: np.ndarray
    e: np.ndarray
    hph: np.ndarray
    poses: np.ndarray
    points: np.ndarray

    @classmethod
    def of(cls, b: Batch, points: np.ndarray, uniq: np.ndarray, at: np.ndarray, slot: np.ndarray) -> Candidates:
        """The candidates ``uniq`` (u,) (landmark indices) of keyframes ``at`` (u,) of the batch, in
        its state at ``slot`` (u,) (−1: out of it)."""
        n = len(uniq)
        e = np.zeros((n, 5, 5))
        e[:, :3, :3] = b.pose_cov[at]
        pj = b.pose_landmark(at, slot)
        e[:, :3, 3:], e[:, 3:, :3] = pj, np.transpose(pj, (0, 2, 1))
        e[:, 3:, 3:] = b.landmark_block(at, slot)
        poses, pts = b.poses[at], points[uniq]
        jac = bearing_range_jacobians(poses, pts)  # (u, 2, 5)
        return cls(jac, e, jac @ e @ np.transpose(jac, (0, 2, 1)), poses, pts)

    def spread(self, sel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The spreads (σ_a, σ_b) (s, 2) [m] of the estimated relative position w_j along and across
        the line of sight (:func:`line_of_sight_spread`) and the true ranges (s,) [m] of the
        candidates ``sel`` (s,) (positions, repeats allowed: each row is computed on its own)."""
        return line_of_sight_spread(self.poses[sel], self.points[sel], self.e[sel], 3)


def candidate_moments(
    b: Batch, mi: np.ndarray, cand: Candidates, back: np.ndarray, d: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """What the far-pair filter needs of each pair (n of them), from the (pose, l_j) 5 × 5 block
    alone: S_j (n, 2, 2), λ (n,) and S_j⁻¹ (n, 2, 2) (the same as :func:`pair_moments`' for those
    pairs). Pair p is measurement ``mi[p]`` with candidate ``back[p]`` of ``cand``; ``d`` (n, 2) the
    pairs' innovation means. H_j P H_jᵀ is the candidate's (:class:`Candidates`), the
    measurement's noise added here."""
    s_j = cand.hph[back]
    s_j[:, 0, 0] += b.meas["sigma_bearing_rad"][mi] ** 2
    s_j[:, 1, 1] += b.meas["sigma_range_m"][mi] ** 2
    inv = inverse_2x2(s_j)
    lam = np.einsum("ni,nij,nj->n", d, inv, d)
    return s_j, lam, inv


def inverse_2x2(a: np.ndarray) -> np.ndarray:
    """(n, 2, 2) inverses of symmetric positive definite (n, 2, 2) matrices, in closed form."""
    det = a[:, 0, 0] * a[:, 1, 1] - a[:, 0, 1] * a[:, 1, 0]
    out = np.empty_like(a)
    out[:, 0, 0], out[:, 1, 1] = a[:, 1, 1] / det, a[:, 0, 0] / det
    out[:, 0, 1], out[:, 1, 0] = -a[:, 0, 1] / det, -a[:, 1, 0] / det
    return out


def line_of_sight_spread(
    poses: np.ndarray, points: np.ndarray, e: np.ndarray, col: int
) -> tuple[np.ndarray, np.ndarray]:
    """(σ_a, σ_b) (n, 2) [m] of w = e_l − R(θ) e_xy along and across the line of sight from ``poses``
    (n, 3) to ``points`` (n, 2), the landmark's error at columns ``col``, ``col + 1`` of the (n, q, q)
    covariance ``e`` (the pose's position error in its own frame at columns 0, 1); and the true
    ranges (n,) [m]."""
    c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
    rel = points - poses[:, :2]
    rng = np.maximum(np.hypot(rel[:, 0], rel[:, 1]), 1e-9)
    ux, uy = rel[:, 0] / rng, rel[:, 1] / rng
    # Cov(w) = E_ll + M E_pp Mᵀ − E_lp Mᵀ − M E_pl, M = R(θ) (2 × 2 blocks: cheap elementwise)
    rot = np.empty((len(c), 2, 2))
    rot[:, 0, 0], rot[:, 0, 1], rot[:, 1, 0], rot[:, 1, 1] = c, -s, s, c
    rot_t = np.transpose(rot, (0, 2, 1))
    e_lp = e[:, col : col + 2, :2] @ rot_t
    cw = e[:, col : col + 2, col : col + 2] + rot @ e[:, :2, :2] @ rot_t - e_lp - np.transpose(e_lp, (0, 2, 1))
    var_a = ux * ux * cw[:, 0, 0] + 2.0 * ux * uy * cw[:, 0, 1] + uy * uy * cw[:, 1, 1]
    var_b = uy * uy * cw[:, 0, 0] - 2.0 * ux * uy * cw[:, 0, 1] + ux * ux * cw[:, 1, 1]
    return np.sqrt(np.maximum(np.column_stack([var_a, var_b]), 0.0)), rng


def innovation_means(
    b: Batch, points: np.ndarray, mi: np.ndarray, cj: np.ndarray, at: np.ndarray, pick: np.ndarray | None = None
) -> np.ndarray:
    """(n, 2) d: the true measurement of each pair's measurement ``mi`` minus candidate ``cj``'s
    (bearing wrapped), seen from keyframe ``at`` of the batch (one per ``cj``). With ``pick``,
    ``cj`` are distinct (keyframe, candidate)s and pair p's is ``cj[pick[p]]`` (each predicted once)."""
    poses = b.poses[at]
    ci, si = np.cos(poses[:, 2]), np.sin(poses[:, 2])
    rel_j = points[cj] - poses[:, :2]
    bj = np.arctan2(ci * rel_j[:, 1] - si * rel_j[:, 0], ci * rel_j[:, 0] + si * rel_j[:, 1])
    rj = np.hypot(rel_j[:, 0], rel_j[:, 1])
    if pick is not None:
        bj, rj = bj[pick], rj[pick]
    db = wrap_angle(b.meas["bearing_rad"][mi] - bj)
    return np.column_stack([db, b.meas["range_m"][mi] - rj])
