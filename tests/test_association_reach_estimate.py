"""The association estimate where the associator's reach leaves the right landmark out.

The associator takes as candidates only landmarks within 1.25 r̂ + 5 m of the car, r̂ the *measured*
range. A stereo camera's range noise is metres at 20 m (σ_r = 4.65 m for LSC at 19.8 m on KITTI 03):
a measured range 8 m short of the truth puts the right landmark out of reach, and a landmark nearer
the car on the same bearing, inside the gate, is taken although the right one would have been
nearer in NIS. The estimate linearized at the truth has no reach and missed this (KITTI 03's
keyframe 39: 0.018 estimated, 0.057 observed for one LSC-9 measurement); it is now stratified on
the range noise, the tail where the reach can leave the landmark out taken by the quadrature.

Oracle: a Monte Carlo of gated nearest neighbour with the reach rule written here (the range-bearing
model, the map's and the pose's errors, the stereo noise), sharing no code with the engine.
"""

from __future__ import annotations

import numpy as np
import pytest
from association_cases import one_measurement
from association_oracle import clopper_pearson, jacobian, measure, retract

import sensorsel.information.integrity.association as association
from sensorsel.information.filtering import Prediction
from sensorsel.information.integrity.association import gate_of, measurement_risks

GATE = gate_of(0.9999)
POSE = np.array([0.0, 0.0, 0.0])
POSE_COV = np.diag([0.05**2, 0.05**2, 0.002**2])
MAP_SIGMA = 0.05
STEREO = (0.00286, 4.65)  # bearing [rad], range [m] std: a stereo camera at 20 m
#: the right pole 20 m ahead; another 11 m ahead, 10 of the camera's bearing σ aside: inside the gate
#: when the measured range is short, seldom nearer in NIS than the right pole while that one is in reach
POINTS = np.array([[20.0, 0.0], [11.0 * np.cos(10.0 * STEREO[0]), 11.0 * np.sin(10.0 * STEREO[0])]])


def _risks(points=POINTS, stereo=STEREO):
    meas = one_measurement(POSE, points[0], stereo)
    pred = Prediction(keyframe=1, landmarks=np.zeros(0, np.int64), covariance=POSE_COV, prior_sigma_m=MAP_SIGMA)
    return measurement_risks(POSE, points, pred, meas, np.array([0, 1]), gate=GATE, model="map")


def _monte_carlo(n: int, seed: int, points: np.ndarray = POINTS, stereo: tuple[float, float] = STEREO) -> int:
    """Draws (of ``n``) in which the associator takes landmark 1 for a measurement of landmark 0."""
    rng = np.random.default_rng(seed)
    e_pose = rng.standard_normal((n, 3)) @ np.linalg.cholesky(POSE_COV).T
    x_hat = retract(POSE, e_pose)
    z = measure(POSE, points[0]) + rng.standard_normal((n, 2)) * np.asarray(stereo)
    reach = 1.25 * z[:, 1] + 5.0  # the associator's, at the measured range
    nis, inside = [], []
    for j in range(2):
        joint = np.zeros((5, 5))
        joint[:3, :3], joint[3:, 3:] = POSE_COV, MAP_SIGMA**2 * np.eye(2)
        h = jacobian(POSE, points[j])
        s_inv = np.linalg.inv(np.diag(np.square(stereo)) + h @ joint @ h.T)  # S at the truth
        l_hat = points[j] + MAP_SIGMA * rng.standard_normal((n, 2))
        nu = z - measure(x_hat, l_hat)
        nu[:, 0] = (nu[:, 0] + np.pi) % (2 * np.pi) - np.pi
        nis.append(np.einsum("ni,ij,nj->n", nu, s_inv, nu))
        inside.append((nis[j] <= GATE) & (np.hypot(*(l_hat - x_hat[:, :2]).T) <= reach))
    wrong = inside[1] & (~inside[0] | (nis[1] < nis[0]))
    return int(wrong.sum())


def test_the_estimate_counts_the_right_landmark_out_of_reach():
    """The estimate is within 2x of the associator's Monte Carlo; the bound is not below its 99 %
    lower limit."""
    n = 200_000
    k = _monte_carlo(n, seed=5)
    lo, _ = clopper_pearson(k, n)
    r = _risks()
    assert k >= 1000, k  # resolved
    assert 0.5 <= r.estimate[0] / (k / n) <= 2.0, (r.estimate[0], k / n)
    assert r.bound[0] >= lo, (r.bound[0], lo)


def test_without_the_reach_stratum_the_estimate_misses_it(monkeypatch):
    """The guard: with no pair stratified (its threshold past 1), the linearized estimate is less
    than half of what the associator does (so the test above fails without it)."""
    monkeypatch.setattr(association, "REACH_SHARE", 2.0)
    n = 200_000
    k = _monte_carlo(n, seed=5)
    assert _risks().estimate[0] < 0.5 * k / n


@pytest.mark.parametrize("range_sigma", [0.03, 4.65])
def test_out_of_reach_worked_by_hand(range_sigma):
    """P(out of reach) to first order: r + w_a > 1.25 (r + v_r) + 5 ⇔ w_a − 1.25 v_r > 0.25 r + 5."""
    from scipy.special import ndtr

    got = association.out_of_reach_estimate(np.array([20.0]), np.array([0.07]), np.array([range_sigma]))[0]
    want = ndtr(-(0.25 * 20.0 + 5.0) / np.hypot(0.07, 1.25 * range_sigma))
    assert got == pytest.approx(want, rel=1e-12)
    assert (got > 0.01) == (range_sigma > 1.0)  # a LiDAR never; a stereo camera at 20 m, percent


#: a poor stereo camera (σ_r 8 m at 18 m) and a pole 37 m beyond the measured one, one bearing σ aside:
#: nearer in NIS whenever the range noise passes the midpoint (+18.5 m), but within the associator's
#: reach only past +22 m (1.25 r̂ + 5 ≥ 55 m). KITTI 03's keyframe 68 has such a pair (an LSC-12 pole at
#: 18 m, another 33 m beyond): the linearized estimate 6.0e-6, the associator 5.1e-7
FAR_STEREO = (0.00286, 8.0)
FAR_POINTS = np.array([[18.0, 0.0], [55.0 * np.cos(FAR_STEREO[0]), 55.0 * np.sin(FAR_STEREO[0])]])


def test_the_estimate_counts_a_farther_candidate_only_within_reach():
    """The estimate is within 2x of the associator's Monte Carlo where the candidate is farther than
    the reach at the true range; the bound is not below its 99 % lower limit."""
    n = 400_000
    k = _monte_carlo(n, 11, FAR_POINTS, FAR_STEREO)
    lo, _ = clopper_pearson(k, n)
    r = _risks(FAR_POINTS, FAR_STEREO)
    assert k >= 500, k  # resolved
    assert 0.5 <= r.estimate[0] / (k / n) <= 2.0, (r.estimate[0], k / n)
    assert r.bound[0] >= lo, (r.bound[0], lo)


def test_without_the_upper_stratum_the_estimate_overstates_it(monkeypatch):
    """The guard: with no farther candidate stratified (its upper tail taken as never binding), the
    linearized estimate is more than twice what the associator does."""
    monkeypatch.setattr(association, "reach_upper_tail", lambda r, s, rj, sj: np.ones(len(r)))
    n = 400_000
    k = _monte_carlo(n, 11, FAR_POINTS, FAR_STEREO)
    assert _risks(FAR_POINTS, FAR_STEREO).estimate[0] > 2.0 * k / n
