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
def test_relative_spread_is_the_root_trace_of_the_relative_error_and_bounds_both_line_of_sight_spreads(seed):
    pose, points, pred, meas = _slam_like(seed)
    b = Batch.of(pose[None, :], [Snapshot.of(pred, meas)])
    n = len(points)
    slot = np.arange(n)
    got = b.relative_spread(np.zeros(n, np.int64), slot)
    cov = np.asarray(pred.covariance)
    c, s = np.cos(pose[2]), np.sin(pose[2])
    rot = np.array([[c, -s], [s, c]])
    for k in range(n):
        # w = e_l − R(θ) e_xy, a linear map of the state's error
        m = np.zeros((2, cov.shape[0]))
        m[:, 3 + 2 * k : 5 + 2 * k] = np.eye(2)
        m[:, :2] = -rot
        cw = m @ cov @ m.T
        assert got[k] == pytest.approx(np.sqrt(np.trace(cw)), rel=1e-9)
        # far below the pose's spread plus the landmark's: their errors are correlated
        assert got[k] < 0.5 * (
            np.sqrt(cov[0, 0] + cov[1, 1]) + np.sqrt(np.trace(cov[3 + 2 * k : 5 + 2 * k, 3 + 2 * k : 5 + 2 * k]))
        )
        e = np.zeros((1, 5, 5))
        idx = [0, 1, 2, 3 + 2 * k, 4 + 2 * k]
        e[0] = cov[np.ix_(idx, idx)]
        sigma, rng = line_of_sight_spread(pose[None, :], points[k : k + 1], e, 3)
        assert np.all(sigma[0] <= got[k])
        assert rng[0] == pytest.approx(np.hypot(*(points[k] - pose[:2])))


def test_relative_spread_of_a_landmark_out_of_the_state_adds_its_prior():
    pose, points, pred, meas = _slam_like(0)
    b = Batch.of(pose[None, :], [Snapshot.of(pred, meas)])
    got = b.relative_spread(np.zeros(1, np.int64), np.array([-1]))
    cov = np.asarray(pred.covariance)
    assert got[0] == pytest.approx(np.sqrt(cov[0, 0] + cov[1, 1] + 2 * 100.0**2), rel=1e-9)


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
