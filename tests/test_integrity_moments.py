"""The association engine's small kernels (sensorsel.information.integrity.moments) against dense
numpy oracles: plain matrices, one keyframe at a time.

The far filters drop a pair only where a cheap bound shows the exact test would: the bounds must hold
of the numbers the exact test computes, on covariances where the pose's and the landmarks' errors
are strongly correlated (SLAM: metres each, decimetres relative)."""

from __future__ import annotations

import numpy as np
import pytest

from sensorsel.information.filtering import KeyframeMeasurements, Prediction
from sensorsel.information.integrity.moments import Batch, Snapshot, line_of_sight_spread


def _slam_like(seed: int, n_landmarks: int = 6):
    """A keyframe's pose, landmarks and a prediction whose errors share a common shift of metres
    (the pose and every landmark) over decimetres of their own."""
    rng = np.random.default_rng(seed)
    pose = np.array([rng.uniform(-50, 50), rng.uniform(-50, 50), rng.uniform(-np.pi, np.pi)])
    points = pose[:2] + rng.uniform(-40, 40, size=(n_landmarks, 2))
    q = 3 + 2 * n_landmarks
    shared = np.zeros((q, 3))  # a common translation (x, y) and rotation of the whole map
    c, s = np.cos(pose[2]), np.sin(pose[2])
    shared[:2, :2] = np.array([[c, s], [-s, c]])  # the pose's position error in its own frame
    shared[2, 2] = 1.0
    for k in range(n_landmarks):
        rel = points[k] - pose[:2]
        shared[3 + 2 * k : 5 + 2 * k, :2] = np.eye(2)
        shared[3 + 2 * k : 5 + 2 * k, 2] = [-rel[1], rel[0]]
    own = rng.normal(size=(q, q)) * 0.1
    cov = shared @ np.diag([4.0, 4.0, 1e-4]) @ shared.T + own @ own.T
    held = np.arange(n_landmarks, dtype=np.int64)
    pred = Prediction(keyframe=0, landmarks=held, covariance=cov, prior_sigma_m=100.0)
    meas = KeyframeMeasurements(
        0, held[:1], np.zeros(1, np.int64), np.zeros(1), np.ones(1), np.full(1, 0.01), np.full(1, 0.5)
    )
    return pose, points, pred, meas


@pytest.mark.parametrize("seed", range(8))
def test_line_of_sight_bounds_are_the_relative_errors_spreads_and_bound_the_exact_ones(seed):
    """Batch.line_of_sight_bounds against Cov(w), w = e_l − R(θ) e_xy, from the dense covariance (the
    oracle): along and across the line of sight to 1e-9, at least line_of_sight_spread's σ_a, σ_b
    computed from the same numbers (what the exact test reads: the far filter drops a pair only where
    it would), at most √tr Cov(w), and far below the pose's spread plus the landmark's where their
    errors are correlated."""
    pose, points, pred, meas = _slam_like(seed)
    b = Batch.of(pose[None, :], [Snapshot.of(pred, meas)])
    n = len(points)
    got = b.line_of_sight_bounds(np.zeros(n, np.int64), np.arange(n), points)
    cov = np.asarray(pred.covariance)
    c, s = np.cos(pose[2]), np.sin(pose[2])
    rot = np.array([[c, -s], [s, c]])
    for k in range(n):
        m = np.zeros((2, cov.shape[0]))
        m[:, 3 + 2 * k : 5 + 2 * k] = np.eye(2)
        m[:, :2] = -rot
        cw = m @ cov @ m.T
        rel = points[k] - pose[:2]
        u = rel / np.hypot(*rel)
        across = np.array([-u[1], u[0]])
        assert got[k, 0] == pytest.approx(np.sqrt(u @ cw @ u), rel=1e-9)
        assert got[k, 1] == pytest.approx(np.sqrt(across @ cw @ across), rel=1e-9)
        assert np.all(got[k] <= np.sqrt(np.trace(cw)) * (1 + 1e-9))
        assert np.sqrt(np.trace(cw)) < 0.5 * (
            np.sqrt(cov[0, 0] + cov[1, 1]) + np.sqrt(np.trace(cov[3 + 2 * k : 5 + 2 * k, 3 + 2 * k : 5 + 2 * k]))
        )
        e = np.zeros((1, 5, 5))
        idx = [0, 1, 2, 3 + 2 * k, 4 + 2 * k]
        e[0] = cov[np.ix_(idx, idx)]
        sigma, rng = line_of_sight_spread(pose[None, :], points[k : k + 1], e, 3)
        assert np.all(sigma[0] <= got[k])
        assert rng[0] == pytest.approx(np.hypot(*(points[k] - pose[:2])))


def test_the_bounds_hold_where_the_relative_error_vanishes():
    """The margin: a landmark whose error is the pose's exactly (Cov(w) = 0 but for rounding), where
    the two computations of a variance of ~0 round apart: the bounds stay at least the exact test's
    spreads (the guard: without the margin a bound rounds below them)."""
    rng_ = np.random.default_rng(3)
    pose = np.array([10.0, -4.0, 0.7])
    points = pose[:2] + rng_.uniform(-30, 30, size=(40, 2))
    c, s = np.cos(pose[2]), np.sin(pose[2])
    q = 3 + 2 * len(points)
    shared = np.zeros((q, 3))  # every landmark moves with the pose: w = 0
    shared[:2, :2] = np.array([[c, s], [-s, c]])
    shared[2, 2] = 1.0
    for k, p in enumerate(points):
        shared[3 + 2 * k : 5 + 2 * k, :2] = np.eye(2)
        shared[3 + 2 * k : 5 + 2 * k, 2] = [-(p - pose[:2])[1], (p - pose[:2])[0]]
    cov = shared @ np.diag([9.0, 9.0, 1e-4]) @ shared.T
    held = np.arange(len(points), dtype=np.int64)
    pred = Prediction(keyframe=0, landmarks=held, covariance=cov, prior_sigma_m=100.0)
    meas = KeyframeMeasurements(
        0, held[:1], np.zeros(1, np.int64), np.zeros(1), np.ones(1), np.full(1, 0.01), np.full(1, 0.5)
    )
    b = Batch.of(pose[None, :], [Snapshot.of(pred, meas)])
    got = b.line_of_sight_bounds(np.zeros(len(points), np.int64), held, points)
    for k in range(len(points)):
        idx = [0, 1, 2, 3 + 2 * k, 4 + 2 * k]
        sigma, _ = line_of_sight_spread(pose[None, :], points[k : k + 1], cov[np.ix_(idx, idx)][None], 3)
        assert np.all(sigma[0] <= got[k])


def test_line_of_sight_bounds_of_a_landmark_out_of_the_state_add_its_prior():
    pose, points, pred, meas = _slam_like(0)
    b = Batch.of(pose[None, :], [Snapshot.of(pred, meas)])
    got = b.line_of_sight_bounds(np.zeros(1, np.int64), np.array([-1]), points[:1])
    cov = np.asarray(pred.covariance)
    rel = points[0] - pose[:2]
    u = rel / np.hypot(*rel)
    c, s = np.cos(pose[2]), np.sin(pose[2])
    rot = np.array([[c, -s], [s, c]])
    pp = rot @ cov[:2, :2] @ rot.T + 100.0**2 * np.eye(2)  # no correlation with a prior's error
    assert got[0, 0] == pytest.approx(np.sqrt(u @ pp @ u), rel=1e-9)
    assert got[0, 1] == pytest.approx(np.sqrt(np.array([-u[1], u[0]]) @ pp @ np.array([-u[1], u[0]])), rel=1e-9)


@pytest.mark.parametrize("seed", range(6))
def test_snapshot_copies_the_rows_blocks_and_slots_a_dense_reading_gives(seed):
    """Each field of :meth:`Snapshot.of` against the prediction read directly: the state landmarks'
    2 × 2 diagonal blocks (an unsymmetric matrix: the upper and lower neighbours of the diagonal are
    told apart), the rows of the pose and of each measured state landmark in slot order (a landmark
    measured twice once, one out of the state left out), each measurement's slot and row."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(0, 9))
    held = np.sort(rng.choice(40, size=n, replace=False)).astype(np.int64)
    cov = rng.normal(size=(3 + 2 * n, 3 + 2 * n))
    outside = np.setdiff1d(np.arange(40), held)[:2]
    landmark = np.concatenate([rng.choice(held, size=min(n, 4)), outside, held[:1]]).astype(np.int64)
    m = len(landmark)
    meas = KeyframeMeasurements(
        7, np.zeros(m, np.int64), landmark, np.zeros(m), np.ones(m), np.full(m, 0.01), np.full(m, 0.5)
    )
    pred = Prediction(keyframe=7, landmarks=held, covariance=cov, prior_sigma_m=3.0)
    snap = Snapshot.of(pred, meas)
    position = {int(h): s for s, h in enumerate(held)}
    slot = np.array([position.get(int(x), -1) for x in landmark], np.int64)
    measured = sorted({int(s) for s in slot if s >= 0})
    rank = {s: r for r, s in enumerate(measured)}
    assert snap.slot.tolist() == slot.tolist()
    assert snap.row.tolist() == [3 + 2 * rank[int(s)] if s >= 0 else -1 for s in slot]
    rows = [0, 1, 2] + [3 + 2 * s + a for s in measured for a in (0, 1)]
    assert np.array_equal(snap.rows, cov[rows, :])
    assert np.array_equal(snap.pose_cov, cov[:3, :3]) and snap.pose_cov is not cov
    blocks = np.array([cov[3 + 2 * k : 5 + 2 * k, 3 + 2 * k : 5 + 2 * k] for k in range(n)]).reshape(n, 2, 2)
    assert np.array_equal(snap.blocks, blocks)
    assert snap.lm_trace_max == max(
        (cov[3 + 2 * k, 3 + 2 * k] + cov[4 + 2 * k, 4 + 2 * k] for k in range(n)), default=0.0
    )
    assert snap.held.tolist() == held.tolist() and snap.held is not held
    cov[:] = 0.0  # copies: the snapshot outlives the prediction's state
    assert np.array_equal(snap.blocks, blocks)
