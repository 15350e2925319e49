"""The association bound against the associator where the linearization at the truth fails (SLAM).

In SLAM a landmark first seen by a stereo camera enters the filter's state with a spread of metres
along its line of sight (σ_range ≈ 1 m at 9 m, elongated further by the pose's heading), so at the next
keyframe its candidates' predicted positions can move by a third of their range. The integrity
engine takes ν_j = d_ij + H_j e (the model linearized at the truth); the associator the car runs, the
simulator and the independent Monte Carlo (``association_oracle``) take ν_j = z − h(x̂, l̂_j) with the
nonlinear range-bearing model. The case below is KITTI 03's keyframe 3 with the $2,391 freeway suite
(LRR-6, HD2K-6, LSC-12), SLAM model: the HD2K-6 measurement of pole 2 (8.7 m away, σ 2.9 m along its
line of sight) against pole 4 (8.9 m, σ 3.5 m), the pose and the two landmarks' predicted joint
covariance copied from the forward pass (pole 2 is landmark 0 here, pole 4 landmark 1).

The bound of the model linearized at the truth (``MeasurementRisk.linear``) misses it; the bound
with the Taylor remainder over a box of the landmarks' errors (``MeasurementRisk.bound``) holds.

Oracles: the independent Monte Carlo of the associator (no code shared with the engine or the
simulator), the simulator itself, Clopper–Pearson intervals.
"""

from __future__ import annotations

import numpy as np
from association_cases import one_measurement, simulated
from association_oracle import clopper_pearson, monte_carlo

from sensorsel.information.filtering import KeyframeMeasurements, Prediction
from sensorsel.information.integrity import nonlinear
from sensorsel.information.integrity.association import gate_of, measurement_risks

GATE = gate_of(0.9999)
POSE = np.array([27.08037, 0.4690774, 0.0281970857379124])
POINTS = np.array([[33.799, -5.11], [35.448, -2.499]])
#: the predicted joint covariance of (pose x, y, heading in its own frame; landmark 0; landmark 1)
COV = np.array(
    [
        [
            2.9054985953086143e-02,
            -2.1082607640611861e-03,
            -7.9722306354465986e-05,
            1.8645270441511565e-02,
            -2.0999018198607847e-03,
            1.8847305704045466e-02,
            -2.2335305387276663e-03,
        ],
        [
            -2.1082607640611857e-03,
            4.7179699414618484e-02,
            1.4756739873818220e-03,
            5.0872079643776089e-03,
            4.7016470516363894e-02,
            1.2324648133541834e-03,
            4.9452020904332122e-02,
        ],
        [
            -7.9722306354465986e-05,
            1.4756739873818220e-03,
            2.1691105951475079e-04,
            5.3119038568002455e-04,
            2.2582405411676817e-03,
            2.2591570428705105e-04,
            2.4510733320103947e-03,
        ],
        [
            1.8645270441511565e-02,
            5.0872079643776089e-03,
            5.3119038568002455e-04,
            8.6809075231790516e00,
            -3.0423184722408374e00,
            2.0049093206136882e-02,
            1.0059256388083960e-02,
        ],
        [
            -2.0999018198607847e-03,
            4.7016470516363894e-02,
            2.2582405411676817e-03,
            -3.0423184722408370e00,
            1.1398309520218814e00,
            3.2869569615368811e-03,
            6.5833217944232483e-02,
        ],
        [
            1.8847305704045466e-02,
            1.2324648133541834e-03,
            2.2591570428705105e-04,
            2.0049093206136882e-02,
            3.2869569615368802e-03,
            1.1935562033670074e01,
            -1.9480840227588205e00,
        ],
        [
            -2.2335305387276663e-03,
            4.9452020904332122e-02,
            2.4510733320103947e-03,
            1.0059256388083960e-02,
            6.5833217944232483e-02,
            -1.9480840227588208e00,
            3.9201805789573213e-01,
        ],
    ]
)
COV = 0.5 * (COV + COV.T)
#: HD2K-6 at 8.7 m: bearing [rad] and range [m] std
SIGMAS = (0.002857142857142857, 0.9079296870486997)
DRAWS = 200_000


def _meas() -> KeyframeMeasurements:
    return one_measurement(POSE, POINTS[0], SIGMAS, keyframe=3)


def _simulated(pose: np.ndarray, points: np.ndarray, meas: KeyframeMeasurements, cov: np.ndarray):
    """The simulator's associator on ``meas`` (landmark 0 measured, landmarks 0 and 1 candidates and
    in the state with ``cov``): DRAWS draws, seed 5."""
    return simulated(pose, points, meas, cov, draws=DRAWS, gate=GATE)


def _observed() -> tuple[int, int]:
    return monte_carlo(POSE, POINTS, np.array([0, 1]), COV, 100.0, 0, SIGMAS, [0, 1], GATE, n=DRAWS, seed=7)


def test_the_simulator_sees_what_the_independent_monte_carlo_sees():
    """Both run the stated (nonlinear) associator: both see pole 4 taken for pole 2 about 0.4 % of the time."""
    k, n = _observed()
    meas = _meas()
    out = _simulated(POSE, POINTS, meas, COV)
    assert k >= 200 and out.wrong_draws >= 200  # resolved by both: not vacuous
    lo1, hi1 = clopper_pearson(out.wrong_draws, out.draws)
    lo2, hi2 = clopper_pearson(k, n)
    assert lo1 <= hi2 and lo2 <= hi1  # the two 99 % intervals overlap


def test_the_bound_is_not_below_the_associator_where_landmarks_are_fresh():
    """The bound covers the Taylor remainder of the range-bearing model over a box of the landmarks'
    line-of-sight errors: it holds where the model linearized at the truth does not (its bound here
    is ≈ 1e-24, λ = 208, while the associator errs 0.4 % of the time)."""
    k, n = _observed()
    lo, _ = clopper_pearson(k, n)
    pred = Prediction(keyframe=3, landmarks=np.array([0, 1]), covariance=COV, prior_sigma_m=100.0)
    r = measurement_risks(POSE, POINTS, pred, _meas(), np.array([0, 1]), gate=GATE, model="slam", linear=True)
    assert k >= 200  # resolved: not vacuous
    assert r.linear[0] < 1e-12 < lo  # the linearized model's bound is below: the case is a real one
    assert r.bound[0] >= lo, (r.bound[0], k / n, lo)
    assert r.bound[0] < 1.0  # and not the trivial bound


def test_the_estimate_follows_the_nonlinear_model_where_the_linearization_fails():
    """Where the remainder is not small against the separation (here λ = 208 linearized, the
    candidate's box at 2σ reaching most of its range) the estimate is the quadrature of the nonlinear
    model: within 2x of what the independent Monte Carlo of the associator observes (0.4 %), where
    the pairwise estimate linearized at the truth gives ~1e-24."""
    k, n = _observed()
    pred = Prediction(keyframe=3, landmarks=np.array([0, 1]), covariance=COV, prior_sigma_m=100.0)
    r = measurement_risks(POSE, POINTS, pred, _meas(), np.array([0, 1]), gate=GATE, model="slam", linear=True)
    assert k >= 200  # resolved: not vacuous
    assert r.linear[0] < 1e-12  # the linearized model misses it (the case is a real one)
    assert 0.5 <= r.estimate[0] / (k / n) <= 2.0, (r.estimate[0], k / n)


def test_the_nonlinear_quadrature_is_the_associator_on_a_first_sighting():
    """A first sighting of pole 2 (not in the state) against pole 4 (in it, metres of spread): the
    quadrature's P(NIS_4 ≤ γ) against the independent Monte Carlo (the measured landmark not a candidate)."""
    state = np.array([1])
    cov = COV[np.ix_([0, 1, 2, 5, 6], [0, 1, 2, 5, 6])]
    k, n = monte_carlo(
        POSE, POINTS, state, cov, 100.0, 0, SIGMAS, [1], GATE, n=DRAWS, seed=11, right_is_candidate=False
    )
    pred = Prediction(keyframe=3, landmarks=state, covariance=cov, prior_sigma_m=100.0)
    r = measurement_risks(POSE, POINTS, pred, _meas(), np.array([1]), gate=GATE, model="slam")
    assert k >= 200
    assert 0.5 <= r.estimate[0] / (k / n) <= 2.0, (r.estimate[0], k / n)


def test_the_estimate_is_unchanged_where_the_linearization_holds(monkeypatch):
    """A prior map (5 cm) and a pose known to decimetres, poles 1.5 m apart at 20 m: the remainder is
    small against the separation, no pair is bent, and the estimate is the linearized one to 1e-12
    (the same as with the nonlinear quadrature switched off); that estimate agrees with the
    independent Monte Carlo within 2x, so keeping it there is right."""
    pose = np.array([0.0, 0.0, 0.1])
    points = np.array([[20.0, 2.0], [20.3, 3.47], [35.0, -4.0]])
    cov = np.diag([0.04, 0.02, 1e-4])
    sigmas = (0.02, 0.3)
    meas = one_measurement(pose, points[0], sigmas, keyframe=0)
    pred = Prediction(keyframe=0, landmarks=np.zeros(0, np.int64), covariance=cov, prior_sigma_m=0.05)
    cands = np.array([0, 1, 2])
    got = measurement_risks(pose, points, pred, meas, cands, gate=GATE, model="map").estimate[0]
    monkeypatch.setattr(nonlinear, "BENT_SHARE", np.inf)  # the quadrature off: the linearized estimate
    lin = measurement_risks(pose, points, pred, meas, cands, gate=GATE, model="map").estimate[0]
    assert abs(got - lin) <= 1e-12
    k, n = monte_carlo(pose, points, np.zeros(0, np.int64), cov, 0.05, 0, sigmas, [0, 1, 2], GATE, n=DRAWS, seed=3)
    assert k >= 200  # resolved: not vacuous
    assert 0.5 <= got / (k / n) <= 2.0, (got, k / n)


def test_the_nonlinear_estimate_is_the_same_whatever_the_threads():
    """Byte-identical for one thread and several (the quadrature's sums avoid BLAS)."""
    from threadpoolctl import threadpool_limits

    pred = Prediction(keyframe=3, landmarks=np.array([0, 1]), covariance=COV, prior_sigma_m=100.0)
    runs = []
    for threads in (1, 4):
        with threadpool_limits(threads):
            r = measurement_risks(POSE, POINTS, pred, _meas(), np.array([0, 1]), gate=GATE, model="slam")
        runs.append(r.estimate.tobytes())
    assert runs[0] == runs[1]


def test_the_nonlinear_estimate_keeps_the_associators_reach():
    """The associator's candidates lie within 1.25 r̂ + 5 m of the estimated pose, r̂ the *measured*
    range: a stereo camera's range noise (3.5 m at 19 m) can put the right landmark out of reach, and
    a nearer fresh neighbour then wins though its NIS is the larger. The estimate follows the
    simulator and the independent oracle (both run that associator, and agree); the oracle without
    the reach sees a quarter of it."""
    pose = np.array([0.0, 0.0, 0.0])
    points = np.array([[19.0, 0.0], [11.0, 2.3]])
    cov = np.diag([0.02, 0.02, 1e-4, 4.0, 1.0, 0.3, 0.3])
    sigmas = (0.003, 3.5)
    meas = one_measurement(pose, points[0], sigmas, keyframe=0)
    pred = Prediction(keyframe=0, landmarks=np.array([0, 1]), covariance=cov, prior_sigma_m=100.0)
    r = measurement_risks(pose, points, pred, meas, np.array([0, 1]), gate=GATE, model="slam")
    out = _simulated(pose, points, meas, cov)
    observed = out.wrong_draws / out.draws
    k, n = monte_carlo(pose, points, np.array([0, 1]), cov, 100.0, 0, sigmas, [0, 1], GATE, n=DRAWS, seed=7)
    lo, hi = clopper_pearson(k, n)
    lo_sim, hi_sim = clopper_pearson(out.wrong_draws, out.draws)
    assert lo <= hi_sim and lo_sim <= hi, (k, out.wrong_draws)  # the two associators agree
    k_far, _ = monte_carlo(
        pose, points, np.array([0, 1]), cov, 100.0, 0, sigmas, [0, 1], GATE, n=DRAWS, seed=7, reach=None
    )
    assert out.wrong_draws >= 200 and k_far / n < observed / 2  # resolved, and the reach matters here
    assert 0.5 <= r.estimate[0] / observed <= 2.0, (r.estimate[0], observed)
