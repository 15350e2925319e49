"""The association bound covers the associator's reach: the right landmark can be out of it.

The associator takes as candidates only the landmarks within 1.25 r̂ + 5 m of the estimated pose,
r̂ the *measured* range. A stereo camera's range noise (metres) can make r̂ so short that the right
landmark is out of reach; a nearer landmark inside the gate is then taken, though the right one's
NIS is the smaller. The local nearest-neighbour form W ⊆ {NIS_i > t} ∪ ⋃_j {NIS_j ≤ t} does not
count that; the bound adds P(i out of reach) to G_i(t) (``association._out_of_reach``).

Oracles: the independent Monte Carlo of ``association_oracle`` (with the reach rule, written there
on its own), the simulator's associator (``simulate --associate``), Clopper–Pearson limits, the
closed form of the reach term against a Monte Carlo of the reach event itself.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from association_cases import one_measurement, simulated
from association_oracle import REACH_MARGIN_M, REACH_SCALE, clopper_pearson, monte_carlo
from scipy.special import ndtr

from sensorsel.information.filtering import KeyframeMeasurements, Prediction
from sensorsel.information.integrity import association
from sensorsel.information.integrity.association import _out_of_reach, gate_of, measurement_risks
from sensorsel.simulation import association as simulator

GATE = gate_of(0.9999)
POSE = np.array([0.0, 0.0, 0.0])
POSE_COV = np.diag([0.05**2, 0.05**2, 0.001**2])
MAP_SIGMA = 0.05
#: a stereo camera at 40 m: 1 px of bearing; 6 m of range (a ZED's 0.5 px of disparity gives 4.8 m there)
STEREO = (0.002, 6.0)
#: the right pole 40 m ahead, another 5 m ahead on the same bearing
POINTS = np.array([[40.0, 0.0], [5.0, 0.0]])
DRAWS = 100_000


def _meas(sigmas: tuple[float, float] = STEREO, point: np.ndarray | None = None) -> KeyframeMeasurements:
    """One measurement of landmark 0 at ``point`` (default POINTS[0]; truth: the noise-free bearing
    and range)."""
    return one_measurement(POSE, POINTS[0] if point is None else point, sigmas)


def _bound(sigmas: tuple[float, float] = STEREO) -> float:
    pred = Prediction(keyframe=1, landmarks=np.zeros(0, np.int64), covariance=POSE_COV, prior_sigma_m=MAP_SIGMA)
    r = measurement_risks(POSE, POINTS, pred, _meas(sigmas), np.array([0, 1]), gate=GATE, model="map")
    return float(r.bound[0])


def _no_reach_term(*args: np.ndarray) -> np.ndarray:
    return np.zeros(len(args[0]))


def test_the_oracle_states_the_associators_reach():
    """The oracle writes the reach on its own; it is the engine's and the simulator's."""
    assert (REACH_SCALE, REACH_MARGIN_M) == (association.CANDIDATE_SCALE, association.CANDIDATE_MARGIN_M)
    assert (REACH_SCALE, REACH_MARGIN_M) == (simulator.CANDIDATE_SCALE, simulator.CANDIDATE_MARGIN_M)


@pytest.mark.parametrize(
    ("sigma_a", "sigma_b", "sigma_r", "r", "slack"),
    [(0.1, 0.1, 6.0, 40.0, 1.2), (0.05, 0.3, 3.0, 20.0, 1.5), (3.0, 1.0, 2.0, 9.0, 6.0), (0.5, 4.0, 5.0, 20.0, 6.0)],
)
def test_the_reach_term_bounds_the_reach_event(sigma_a, sigma_b, sigma_r, r, slack):
    """P(|u + w| > 1.25 (r + v_r) + 5) by Monte Carlo of the event itself (w ~ N(0, diag(σ_a², σ_b²))
    along and across the line of sight, v_r ~ N(0, σ_r²)) is never above the term (σ_w = √(σ_a² +
    σ_b²), as the engine passes it). The term is at most ``slack`` × the Monte Carlo: nearly exact
    where the range noise dominates (a map's centimetres), looser where the spread is metres (the
    triangle inequality counts an error toward the car as one away from it)."""
    rng = np.random.default_rng(5)
    n = 400_000
    a = sigma_a * rng.standard_normal(n)
    b = sigma_b * rng.standard_normal(n)
    v = sigma_r * rng.standard_normal(n)
    out = np.hypot(r + a, b) > REACH_SCALE * (r + v) + REACH_MARGIN_M
    k = int(out.sum())
    lo, _ = clopper_pearson(k, n)
    term = float(_out_of_reach(np.array([r]), np.array([r]), np.array([math.hypot(sigma_a, sigma_b)]), [sigma_r])[0])
    assert k >= 100, k  # resolved
    assert lo <= term <= slack * k / n, (k / n, lo, term)


def test_the_reach_term_at_its_limits():
    """Worked by hand: no range noise leaves the Rayleigh tail e^(−D²/(2σ_w²)); no spread leaves the
    range noise's Φ(−D/(1.25 σ_r)); a landmark beyond the reach at the true range (D ≤ 0) gives 1;
    neither noise nor spread, with D > 0, gives 0."""
    r, dist = np.array([20.0, 20.0, 20.0, 20.0]), np.array([20.0, 20.0, 40.0, 20.0])
    got = _out_of_reach(r, dist, np.array([3.0, 0.0, 1.0, 0.0]), np.array([0.0, 4.0, 1.0, 0.0]))
    d = 0.25 * 20.0 + 5.0
    np.testing.assert_allclose(got[:2], [math.exp(-(d**2) / (2 * 9.0)), ndtr(-d / 5.0)], rtol=1e-12)
    assert got[2] == 1.0 and got[3] == 0.0


def _simulator_wrong() -> tuple[int, int]:
    """The simulator's associator on the case: (wrong draws, draws)."""
    cov = np.zeros((7, 7))
    cov[:3, :3] = POSE_COV
    cov[3:, 3:] = MAP_SIGMA**2 * np.eye(4)
    out = simulated(POSE, POINTS, _meas(), cov, draws=DRAWS, gate=GATE)
    return out.wrong_draws, out.draws


def test_a_pole_out_of_reach_is_counted_by_the_bound(monkeypatch):
    """A stereo measurement of a pole 40 m ahead (σ_r 6 m) with another pole 5 m ahead on its bearing:
    when the measured range falls under 28 m (v_r below −2 σ_r: 1.25 r̂ + 5 < 40 m) the right pole is out of reach
    and the near one, inside the gate, is taken. The associator (the oracle with the reach rule and
    the simulator, which agree) errs more often than the bound without the reach term allows; with
    it the bound is above Monte Carlo's 99 % lower limit. Without the reach the oracle errs far less
    (the near pole's NIS is the larger)."""
    k, n = monte_carlo(
        POSE, POINTS, np.zeros(0, np.int64), POSE_COV, MAP_SIGMA, 0, STEREO, [0, 1], GATE, n=DRAWS, seed=3
    )
    k_sim, n_sim = _simulator_wrong()
    lo, hi = clopper_pearson(k, n)
    lo_sim, hi_sim = clopper_pearson(k_sim, n_sim)
    assert lo <= hi_sim and lo_sim <= hi, (k, k_sim)  # the two associators agree
    k_far, _ = monte_carlo(
        POSE, POINTS, np.zeros(0, np.int64), POSE_COV, MAP_SIGMA, 0, STEREO, [0, 1], GATE, n=DRAWS, seed=3, reach=None
    )
    assert k >= 1000 and k_far < k / 2, (k, k_far)  # resolved, and the reach is what errs
    bound = _bound()
    assert max(lo, lo_sim) <= bound < 1.0, (k / n, k_sim / n_sim, bound)
    with monkeypatch.context() as patched:  # the bound without the reach term: below what the associator does
        patched.setattr(association, "_out_of_reach", _no_reach_term)
        without = _bound()
    assert without < min(lo, lo_sim), (without, k / n, k_sim / n_sim)


def test_the_estimate_sees_the_reach_too():
    """On the case above the estimate counts the right pole out of reach as well (the linearized
    estimate, which takes it within reach, is stratified on the range noise: the guide's "the
    estimate"): within 2x of what the associator does."""
    pred = Prediction(keyframe=1, landmarks=np.zeros(0, np.int64), covariance=POSE_COV, prior_sigma_m=MAP_SIGMA)
    r = measurement_risks(POSE, POINTS, pred, _meas(), np.array([0, 1]), gate=GATE, model="map")
    k, n = monte_carlo(
        POSE, POINTS, np.zeros(0, np.int64), POSE_COV, MAP_SIGMA, 0, STEREO, [0, 1], GATE, n=DRAWS, seed=3
    )
    assert k >= 1000 and 0.5 <= r.estimate[0] / (k / n) <= 2.0, (r.estimate[0], k / n)


def test_the_reach_term_leaves_a_lidar_measurement_unchanged(monkeypatch):
    """Centimetres of range noise: the right pole is never out of reach (the term underflows to 0),
    and the bound is the same number with and without it."""
    lidar = (0.0035, 0.03)
    points_near = np.array([[40.0, 0.0], [39.5, 0.4]])
    pred = Prediction(keyframe=1, landmarks=np.zeros(0, np.int64), covariance=POSE_COV, prior_sigma_m=MAP_SIGMA)

    def bound() -> float:
        return float(
            measurement_risks(POSE, points_near, pred, _meas(lidar), np.array([0, 1]), gate=GATE, model="map").bound[0]
        )

    with_term = bound()
    with monkeypatch.context() as patched:
        patched.setattr(association, "_out_of_reach", _no_reach_term)
        assert bound() == with_term
    assert 0.0 < with_term < 1.0


@pytest.mark.parametrize(("far", "near", "sigma_r"), [(40.0, 5.0, 6.0), (20.0, 8.0, 3.5)])
def test_the_bound_holds_in_slam_with_metres_of_spread(far, near, sigma_r):
    """SLAM: the measured pole in the state with 2 m of spread a side (a fresh stereo landmark), the
    near one with 0.55 m: its estimate, not only the measured range, can carry it out of reach. The
    bound is not below the oracle's 99 % lower limit (resolved)."""
    points = np.array([[far, 0.0], [near, 0.0]])
    cov = np.diag([0.05**2, 0.05**2, 0.001**2, 4.0, 4.0, 0.3, 0.3])
    sigmas = (0.002, sigma_r)
    meas = _meas(sigmas, points[0])
    pred = Prediction(keyframe=1, landmarks=np.array([0, 1]), covariance=cov, prior_sigma_m=100.0)
    bound = float(measurement_risks(POSE, points, pred, meas, np.array([0, 1]), gate=GATE, model="slam").bound[0])
    k, n = monte_carlo(POSE, points, np.array([0, 1]), cov, 100.0, 0, sigmas, [0, 1], GATE, n=DRAWS, seed=3)
    lo, _ = clopper_pearson(k, n)
    assert k >= 1000, k
    assert lo <= bound < 1.0, (k / n, bound)
