"""The association bound's range term: a bound of P(NIS_j ≤ x) that needs no box, for a landmark
beside the car.

The Taylor-remainder bound works on a box of k σ of the estimate's error around each candidate; the
box must not reach the landmark (kσ_a < r_j). KITTI's pole maps hold poles 0.3–0.5 m from the
recorded path: with the prediction's 0.1 m only k ≤ 3 is left for them, so every measurement of that
keyframe carried at least 4Φ(−3) = 0.0054, and the lever (leave out measurements whose bound exceeds
10⁻³) left out every measurement of the keyframe (KITTI 00's keyframes 41, 137, 246 and 341: the
filter's σ jumped to one odometry step there). The range term (``_RangeSeparation``): NIS_j ≥ ν_r²/S_rr
and |r̂_j − r_j| ≤ ‖w_j‖, so NIS_j ≤ x only if |v_r| + ‖w_j‖ ≥ |r_i − r_j| − √(x S_rr).

Oracles: a Monte Carlo of the nonlinear NIS (the independent ``association_oracle``'s model: no code
shared with the engine), Clopper–Pearson limits, the box's premise worked by hand.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from association_cases import one_measurement
from association_oracle import clopper_pearson, jacobian, measure, retract
from scipy.special import ndtr

from sensorsel.information.filtering import KeyframeMeasurements, Prediction
from sensorsel.information.integrity.association import _RangeSeparation, gate_of, measurement_risks

GATE = gate_of(0.9999)
POSE = np.array([0.0, 0.0, 0.0])
#: the prediction at a KITTI 00 keyframe: 0.1 m and 0.01 rad (one odometry step on a tight filter)
POSE_COV = np.diag([0.1**2, 0.1**2, 0.01**2])
MAP_SIGMA = 0.05
LIDAR = (0.0035, 0.03)  # bearing [rad], range [m] std


def _meas(point: np.ndarray) -> KeyframeMeasurements:
    return one_measurement(POSE, point, LIDAR)


def _map_prediction() -> Prediction:
    return Prediction(keyframe=1, landmarks=np.zeros(0, np.int64), covariance=POSE_COV, prior_sigma_m=MAP_SIGMA)


def test_a_pole_beside_the_car_no_longer_floors_a_far_measurement():
    """A measurement of a pole 20 m out against a pole 0.41 m from the car: the box cannot go past
    k = 3 for the near pole (hand-worked premise below), so the box alone could not bound it under
    4Φ(−3) = 0.0054; the two are 19.6 m apart in range, and the bound is now below 10⁻⁹."""
    points = np.array([[20.0, 3.0], [0.4, 0.1]])
    near = float(np.hypot(*points[1]))
    sigma_a = math.sqrt(0.1**2 + MAP_SIGMA**2)  # along the line of sight: the pose's and the map's
    assert 4.0 * sigma_a >= near > 3.0 * sigma_a  # the premise: k = 4 reaches the pole, k = 3 does not
    r = measurement_risks(POSE, points, _map_prediction(), _meas(points[0]), np.array([0, 1]), gate=GATE, model="map")
    assert 4.0 * ndtr(-3.0) > 5e-3
    assert r.bound[0] < 1e-9, r.bound[0]


def _joint() -> np.ndarray:
    """(5, 5) the covariance of (pose error, the map landmark's error): independent."""
    joint = np.zeros((5, 5))
    joint[:3, :3] = POSE_COV
    joint[3:, 3:] = MAP_SIGMA**2 * np.eye(2)
    return joint


def _nis_below(points: np.ndarray, x: float, n: int, seed: int) -> int:
    """Draws (of ``n``) in which the nonlinear NIS of candidate 1 against a measurement of landmark 0
    is ≤ ``x``: pose error from POSE_COV, landmark 1 from the map's σ, the LiDAR's noise."""
    rng = np.random.default_rng(seed)
    h = jacobian(POSE, points[1])
    joint = _joint()
    s_inv = np.linalg.inv(np.diag(np.square(LIDAR)) + h @ joint @ h.T)
    e = rng.standard_normal((n, 5)) @ np.linalg.cholesky(joint).T
    z = measure(POSE, points[0]) + rng.standard_normal((n, 2)) * np.asarray(LIDAR)
    nu = z - measure(retract(POSE, e[:, :3]), points[1] + e[:, 3:])
    nu[:, 0] = (nu[:, 0] + np.pi) % (2 * np.pi) - np.pi
    return int((np.einsum("ni,ij,nj->n", nu, s_inv, nu) <= x).sum())


@pytest.mark.parametrize("far", [1.2, 1.3])
def test_the_range_term_is_not_below_the_nonlinear_monte_carlo(far):
    """Two poles on one line of sight, 0.45 m and ``far`` m from the car (the range alone separates
    them, the box cannot cover the near one): the range term bounds P(NIS_near ≤ γ) of the
    nonlinear model, resolved by Monte Carlo (≥ 100 hits), and is not the trivial 1."""
    points = np.array([[far, 0.0], [0.45, 0.0]])
    n = 200_000
    k = _nis_below(points, GATE, n, seed=3)
    lo, _ = clopper_pearson(k, n)
    h = jacobian(POSE, points[1])
    joint = _joint()
    s_rr = LIDAR[1] ** 2 + (h @ joint @ h.T)[1, 1]
    # w = e_l − R(θ) e_xy with θ = 0: its covariance is the map's plus the pose position's
    sigma_w = math.sqrt(2 * MAP_SIGMA**2 + 2 * 0.1**2)
    term = _RangeSeparation(np.array([far - 0.45]), np.array([s_rr]), np.array([LIDAR[1]]), np.array([sigma_w])).bound(
        np.array([GATE])
    )[0, 0]
    assert k >= 100, k  # resolved: not vacuous
    assert lo <= term < 1.0, (k / n, lo, term)


def test_the_range_term_is_at_least_the_linearized_one():
    """The search's floor sums the linearized bound F(γ; λ_j) and relies on it being at most the bound,
    term by term: with the range term added the linear bound stays below the bound, on random pairs
    of a keyframe's candidates around the car (some beside it)."""
    rng = np.random.default_rng(11)
    for _ in range(30):
        points = np.vstack([[15.0, 2.0], rng.uniform(-3.0, 3.0, (6, 2))])
        r = measurement_risks(
            POSE, points, _map_prediction(), _meas(points[0]), np.arange(7), gate=GATE, model="map", linear=True
        )
        assert r.linear[0] <= r.bound[0] + 1e-15


@pytest.mark.kitti
def test_the_lever_keeps_kitti00s_keyframe_beside_a_pole(kitti_root):
    """KITTI 00's keyframe 41 has a mapped pole 0.43 m from the path. With the lever at 10⁻³ the greedy
    suite used none of its 253 measurements (each bound ≥ 0.0054, from that pole) and its filtered σ
    was one odometry step (0.1 m); with the range term it uses most of them and its σ stays at its
    neighbours' (millimetres)."""
    from sensorsel import ScenarioSpec, load_problem
    from sensorsel.information.filtering import forward_pass
    from sensorsel.information.integrity.association import AssociationModel

    problem = load_problem(ScenarioSpec(seq="00", kitti_root=str(kitti_root), landmarks="real"))
    ids = [s.id for s in problem.library.sensors]
    suite = [ids.index(s) for s in ("LRL-roof", "MRL-roof", "LRR-12", "LRR-10", "LRR-6", "LRR-8")]
    points = np.asarray(problem.scenario.landmarks)[:, :2]
    pose = np.asarray(problem.scenario.keyframes.poses)[41]
    assert np.min(np.hypot(*(points - pose[:2]).T)) < 0.5  # the premise: a pole beside the car
    assoc = AssociationModel(problem, model="map")
    used: dict[int, tuple[int, int]] = {}

    def lever(prediction, meas):
        keep = assoc.risks(prediction, meas).bound <= 1e-3
        used[prediction.keyframe] = (int(keep.sum()), len(keep))
        return keep

    fp = forward_pass(problem, suite, map_sigma_m=0.05, use=lever, until=43)
    kept, made = used[41]
    assert made > 200 and kept > made // 2, (kept, made)
    sigma = np.sqrt(np.asarray(fp.filtered)[:, 0, 0])
    assert sigma[41] < 3 * max(sigma[40], sigma[42]) < 0.05, sigma[40:43]


def test_two_landmarks_of_the_map_are_independent(monkeypatch):
    """The pair's moments take two distinct landmarks out of the state (a map) as independent, as
    the simulator draws them: Cov(D) of a measurement of pole 0 against pole 1 is the dense
    (H_j − H_i) E (H_j − H_i)ᵀ with the two landmarks' blocks σ² I each and nothing between them.
    The estimate once held σ² I between them, and was 35 times high on the bundled route's first
    keyframe (the guide to the simulation)."""
    from sensorsel.information.integrity import association

    points = np.array([[20.0, 3.0], [21.0, 3.5]])
    seen = {}
    real = association._bounds

    def spy(pair, *args, **kwargs):
        seen["pair"] = pair
        return real(pair, *args, **kwargs)

    monkeypatch.setattr(association, "_bounds", spy)
    measurement_risks(POSE, points, _map_prediction(), _meas(points[0]), np.array([0, 1]), gate=GATE, model="map")
    e = np.zeros((7, 7))
    e[:3, :3] = POSE_COV
    e[3:5, 3:5] = e[5:7, 5:7] = MAP_SIGMA**2 * np.eye(2)
    h_i, h_j = jacobian(POSE, points[0]), jacobian(POSE, points[1])
    a = np.zeros((2, 7))
    a[:, :3], a[:, 5:7] = h_j[:, :3], h_j[:, 3:]
    a[:, :3] -= h_i[:, :3]
    a[:, 3:5] -= h_i[:, 3:]
    np.testing.assert_allclose(seen["pair"].c_d[0], a @ e @ a.T, rtol=1e-6, atol=1e-12)
