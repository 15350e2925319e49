"""The association risk of gated nearest neighbour (sensorsel.information.integrity.association)
against an independent Monte Carlo of the associator, the closed form on Poisson fields, and the
orderings it must keep: more noise, more landmarks or a looser prior never lower it."""

from __future__ import annotations

import math

import numpy as np
import pytest
from association_oracle import clopper_pearson, measure, monte_carlo

from sensorsel.information.filtering import KeyframeMeasurements, Prediction
from sensorsel.information.integrity.association import candidate_reach, gate_of, keyframe_risk, measurement_risks

POSE = np.array([1.0, -2.0, 0.3])


def _points(offsets: list[tuple[float, float]], rng_m: float = 20.0, bearing: float = 0.1) -> np.ndarray:
    """The measured landmark at (range, bearing) from POSE, the others at (dx, dy) [m] from it."""
    c, s = math.cos(POSE[2] + bearing), math.sin(POSE[2] + bearing)
    base = POSE[:2] + rng_m * np.array([c, s])
    return np.array([base] + [base + np.array(o) for o in offsets])


def _case(points, sb, sr, pose_sigma, lm_sigma, in_state, cross=0.0):
    n = len(points)
    state = np.arange(n) if in_state else np.zeros(0, np.int64)
    diag = [pose_sigma**2, pose_sigma**2, (pose_sigma / 20.0) ** 2] + ([lm_sigma**2] * (2 * n) if in_state else [])
    cov = np.diag(diag)
    if in_state and cross:
        cov[0, 3] = cov[3, 0] = cross * pose_sigma * lm_sigma
    pred = Prediction(keyframe=0, landmarks=state, covariance=cov, prior_sigma_m=lm_sigma)
    z = measure(POSE, points[0])
    meas = KeyframeMeasurements(
        0, np.array([0]), np.array([0]), np.array([z[0]]), np.array([z[1]]), np.array([sb]), np.array([sr])
    )
    return pred, meas


def _risk(points, pred, meas, gate_p=0.9999, model="map"):
    r = measurement_risks(
        POSE, points, pred, meas, np.arange(len(points)), gate=gate_of(gate_p), model=model, linear=True
    )
    assert r.linear[0] <= r.bound[0]  # the remainder only adds
    return float(r.estimate[0]), float(r.bound[0])


def _linear_and_robust(points, pred, meas):
    """The bound linearized at the truth, and the bound robust to the covariance (remainder whitened by R)."""
    kw = dict(gate=gate_of(0.9999), model="map")
    lin = measurement_risks(POSE, points, pred, meas, np.arange(len(points)), linear=True, **kw).linear[0]
    robust = measurement_risks(POSE, points, pred, meas, np.arange(len(points)), robust_to_covariance=True, **kw).bound[
        0
    ]
    return float(lin), float(robust)


# hand-placed cases: (offsets of the other landmarks [m], σ bearing, σ range, pose σ, landmark σ, in state, cross)
CASES = [
    ([(0.2, 0.0), (0.0, 0.6)], 0.01, 0.3, 0.2, 0.1, True, 0.3),
    ([(0.5, 0.0), (0.0, 1.5)], 0.01, 0.3, 0.2, 0.1, True, 0.3),
    ([(1.0, 0.0), (0.0, 3.0)], 0.01, 0.3, 0.2, 0.1, True, 0.3),
    ([(2.0, 0.0), (0.0, 6.0)], 0.01, 0.3, 0.2, 0.1, True, 0.3),
    ([(0.5, 0.0), (-0.3, 0.4)], 0.002, 0.1, 0.3, 0.05, False, 0.0),
    ([(1.0, 0.0), (-0.6, 0.8)], 0.002, 0.1, 0.3, 0.05, False, 0.0),
    ([(2.0, 0.0)], 0.002, 0.1, 0.3, 0.05, False, 0.0),
    ([(1.0, 0.0), (0.0, 1.0)], 0.002, 0.1, 0.1, 0.3, True, 0.0),
    ([(1.5, 0.5)], 0.005, 0.5, 0.05, 0.05, False, 0.0),
]


@pytest.mark.parametrize("case", range(len(CASES)))
def test_against_monte_carlo(case):
    """The bound is never below the Monte Carlo's 99 % lower confidence limit; the estimate is within
    a factor of 2 of the Monte Carlo wherever it resolves the probability (≥ 50 wrong associations)."""
    offsets, sb, sr, ps, ls, in_state, cross = CASES[case]
    points = _points(offsets)
    pred, meas = _case(points, sb, sr, ps, ls, in_state, cross)
    est, bound = _risk(points, pred, meas)
    k, n = monte_carlo(
        POSE,
        points,
        pred.landmarks,
        pred.covariance,
        ls,
        0,
        (sb, sr),
        np.arange(len(points)),
        gate_of(0.9999),
        n=100_000,
        seed=case,
    )
    lo, hi = clopper_pearson(k, n)
    assert bound >= lo
    if k >= 50:
        assert 0.5 * k / n <= est <= 2.0 * k / n, (est, k / n)


def test_first_sighting_against_monte_carlo():
    """SLAM, a landmark not yet in the state: wrong when any state landmark gates; the bound holds and
    the estimate agrees with the Monte Carlo."""
    points = _points([(0.8, 0.0), (0.0, 1.2)])
    state = np.array([1, 2])
    cov = np.diag([0.04, 0.04, 1e-4, 0.01, 0.01, 0.01, 0.01])
    pred = Prediction(0, state, cov, 100.0)
    _, meas = _case(points, 0.01, 0.3, 0.2, 0.1, False)
    est, bound = _risk(points, pred, meas, model="slam")
    k, n = monte_carlo(
        POSE,
        points,
        state,
        cov,
        100.0,
        0,
        (0.01, 0.3),
        np.array([1, 2]),
        gate_of(0.9999),
        n=100_000,
        seed=7,
        right_is_candidate=False,
    )
    lo, _ = clopper_pearson(k, n)
    assert k >= 50 and bound >= lo and 0.5 * k / n <= est <= 2.0 * k / n


def test_two_landmarks_closer_than_the_noise_give_one_half():
    points = _points([(0.01, 0.0)])
    pred, meas = _case(points, 0.01, 0.5, 0.1, 0.1, True)
    est, bound = _risk(points, pred, meas)
    assert est == pytest.approx(0.5, abs=0.03)
    assert bound >= 0.5
    k, n = monte_carlo(
        POSE,
        points,
        pred.landmarks,
        pred.covariance,
        0.1,
        0,
        (0.01, 0.5),
        np.arange(2),
        gate_of(0.9999),
        n=40_000,
        seed=3,
    )
    assert k / n == pytest.approx(0.5, abs=0.02)


def test_far_landmarks_give_only_the_far_residual():
    """A landmark 60 m past the measured one (σ_r 0.1 m: λ ~ 10⁵): no estimate, and a bound that is
    positive (the landmark is not considered, and a bound of 0 would claim it can never be taken) but
    far below anything an hour's budget notices."""
    points = _points([(60.0, 0.0)])
    pred, meas = _case(points, 0.002, 0.1, 0.1, 0.05, False)
    est, bound = _risk(points, pred, meas)
    assert est == 0.0 and 0.0 < bound < 1e-22


BASE = ([(0.8, 0.0), (0.0, 1.2), (-0.5, -0.9)], 0.004, 0.2, 0.15, 0.1)


def _monotone_case(scale_noise=1.0, scale_pose=1.0, scale_landmark=1.0, extra=None, in_state=True):
    offsets, sb, sr, ps, ls = BASE
    points = _points(offsets + ([extra] if extra else []))
    pred, meas = _case(points, sb * scale_noise, sr * scale_noise, ps * scale_pose, ls * scale_landmark, in_state, 0.3)
    return _risk(points, pred, meas)


@pytest.mark.parametrize("in_state", [True, False])
def test_more_noise_more_landmarks_looser_prior_never_lower_the_risk(in_state):
    base_est, base_bound = _monotone_case(in_state=in_state)
    assert 1e-6 < base_est < 0.5
    for kw in (
        {"scale_noise": 1.5},
        {"scale_noise": 3.0},
        {"scale_pose": 1.5},
        {"scale_pose": 4.0},
        {"scale_landmark": 2.0},
        {"scale_landmark": 5.0},
        {"extra": (0.3, -1.5)},
        {"extra": (3.0, 3.0)},
    ):
        est, bound = _monotone_case(in_state=in_state, **kw)
        assert est >= base_est * (1 - 1e-9), kw
        assert bound >= base_bound * (1 - 1e-9), kw


def test_risk_never_falls_as_the_covariance_grows_random():
    """Random PSD additions to the predicted joint covariance (pose, landmarks, their correlations)
    never lower the linearized bound nor the bound robust to the covariance (theorems: what the
    search's floor rests on), the robust bound at the larger covariance is at least the bound at the
    smaller, and neither the bound nor the estimate falls (tested)."""
    rng = np.random.default_rng(11)
    offsets, sb, sr, ps, ls = BASE
    points = _points(offsets)
    pred, meas = _case(points, sb, sr, ps, ls, True, 0.3)
    est0, bound0 = _risk(points, pred, meas)
    lin0, robust0 = _linear_and_robust(points, pred, meas)
    assert 0.0 < lin0 < bound0 <= robust0 <= 1.0
    n = pred.covariance.shape[0]
    for _ in range(30):
        a = rng.standard_normal((n, 2)) * rng.uniform(0.01, 0.2)
        bigger = Prediction(0, pred.landmarks, pred.covariance + a @ a.T, pred.prior_sigma_m)
        est, bound = _risk(points, bigger, meas)
        lin, robust = _linear_and_robust(points, bigger, meas)
        assert lin >= lin0 * (1 - 1e-9) and robust >= robust0 * (1 - 1e-9)
        assert robust >= bound0
        assert bound >= bound0 * (1 - 1e-9)
        assert est >= est0 * (1 - 1e-6)


def test_poisson_field_closed_form():
    """Competing landmarks a Poisson field of density β in (bearing, range), pose known, no gate:
    P(correct) = 1/(1 + 2πβ√det S) (Mori et al.: the correct NIS is χ²₂, the ellipse NIS < u holds
    πu√det S of measurement space: the 2 is E[χ²₂]). The Monte Carlo of the associator agrees with
    it; the estimate, pairwise and independent, averages 1 − exp(−2πβ√det S), the bound above both."""
    rng = np.random.default_rng(5)
    sb, sr, ls = 0.01, 0.2, 0.01
    s_det = math.sqrt((sb**2 + (ls / 20.0) ** 2) * (sr**2 + ls**2))  # √det S in (rad, m) at 20 m
    x = 0.15
    beta = x / (2 * math.pi * s_det)
    half_b, half_r = 8 * sb, 8 * sr
    c0 = POSE[2] + 0.1
    ests, bounds, wrong, draws = [], [], 0, 0
    for f in range(300):
        k = rng.poisson(beta * 4 * half_b * half_r)
        b = c0 + rng.uniform(-half_b, half_b, k)
        r = 20.0 + rng.uniform(-half_r, half_r, k)
        others = np.column_stack([POSE[0] + r * np.cos(b), POSE[1] + r * np.sin(b)])
        points = np.vstack([_points([]), others])
        state = np.zeros(0, np.int64)
        cov = np.diag([1e-14, 1e-14, 1e-16])
        pred = Prediction(0, state, cov, ls)
        _, meas = _case(points, sb, sr, 0.0, ls, False)
        e, bd = _risk(points, pred, meas, gate_p=1 - 1e-12)
        ests.append(e)
        bounds.append(bd)
        if f < 60:
            w, n = monte_carlo(
                POSE, points, state, cov, ls, 0, (sb, sr), np.arange(len(points)), gate_of(1 - 1e-12), n=4000, seed=f
            )
            wrong, draws = wrong + w, draws + n
    exact = 1 - 1 / (1 + x)
    assert wrong / draws == pytest.approx(exact, rel=0.15)
    assert np.mean(ests) == pytest.approx(1 - math.exp(-x), rel=0.1)
    assert np.mean(bounds) >= exact


def test_keyframe_risk():
    est, bound = keyframe_risk(np.array([0.1, 0.2]), np.array([0.3, 0.9]))
    assert est == pytest.approx(1 - 0.9 * 0.8)
    assert bound == 1.0
    assert keyframe_risk(np.zeros(0), np.zeros(0)) == (0.0, 0.0)


def test_a_far_landmark_within_a_stereo_cameras_range_noise_counts():
    """A stereo camera's range noise (metres at 16 m) carries the measured range past the stated
    reach 1.25 r + 5 m at the true range: a landmark 12 m behind the measured one, on its bearing,
    is then inside the gate and nearer for many draws. The bound must still be above the Monte
    Carlo's 99 % lower limit (with the reach at the true range alone it was 0), and the estimate
    within 2x of it."""
    rng_m, sr = 16.0, 3.0
    c, s = math.cos(POSE[2] + 0.1), math.sin(POSE[2] + 0.1)
    points = _points([(12.0 * c, 12.0 * s)], rng_m=rng_m)
    assert np.hypot(*(points[1] - POSE[:2])) > 1.25 * rng_m + 5.0  # beyond the stated reach
    pred, meas = _case(points, 0.002, sr, 0.1, 0.05, True)
    est, bound = _risk(points, pred, meas)
    k, n = monte_carlo(
        POSE,
        points,
        pred.landmarks,
        pred.covariance,
        0.05,
        0,
        (0.002, sr),
        np.arange(2),
        gate_of(0.9999),
        n=100_000,
        seed=7,
    )
    lo, _ = clopper_pearson(k, n)
    assert k >= 50 and bound >= lo, (bound, k / n)
    assert 0.5 * k / n <= est <= 2.0 * k / n, (est, k / n)


def test_slam_reach_does_not_grow_with_the_prior_of_landmarks_out_of_the_state():
    """In SLAM the candidates are the state's landmarks: a measurement's reach comes from its own
    noise and the state's spreads, not from the weak prior (100 m) of the landmarks out of it (with
    it, every landmark of a route was a candidate of every measurement: the same risks, many times
    slower). In the map model the prior is the map's std and counts."""
    points = _points([(1.0, 0.0)])
    for prior in (0.05, 100.0):
        pred, meas = _case(points, 0.002, 0.1, 0.1, 0.05, True)
        pred = Prediction(keyframe=0, landmarks=pred.landmarks, covariance=pred.covariance, prior_sigma_m=prior)
        slam = candidate_reach(pred, meas, gate_of(0.9999), model="slam")
        assert slam[0] < 100.0, slam
    assert candidate_reach(pred, meas, gate_of(0.9999), model="map")[0] > 1000.0


def test_a_measurement_certain_to_be_misassociated_makes_its_keyframe_certain_without_a_warning():
    # 1 - (1 - 0.5)(1 - 1) = 1 by hand; log1p(-1) is -inf, which numpy warns about unless told
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert keyframe_risk(np.array([0.5, 1.0]), np.array([0.5, 1.0])) == (1.0, 1.0)
        assert keyframe_risk(np.array([0.5, 0.5]), np.array([0.5, 0.5])) == (0.75, 1.0)
