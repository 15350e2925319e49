"""The association bound past the far limit (sensorsel.information.integrity.association): a landmark
the engine does not keep as a candidate (its pair dropped by the far filters, or the landmark beyond
the widened reach) can still be taken by the associator with a tiny but positive probability, and the
bound must not be 0 there.

The cases put the car's estimate and the map exactly right (zero covariance), so the innovation of
a candidate j is z − h(x, l_j) = d + v with v ~ N(0, R) the measurement noise alone: NIS_j is exactly
non-central χ²₂ with λ = dᵀR⁻¹d, and NIS_i is χ²₂ with the same whitened noise. With j on the
measured landmark's bearing and √λ > 2√γ, NIS_j ≤ γ forces NIS_i > γ ≥ NIS_j, and the draws inside
the gate put both landmarks within the associator's reach (checked below from the geometry), so
P(wrong) = P(NIS_j ≤ γ) exactly: computed here by a numerical integral over the gate's disc in log
space and, independently, by importance sampling centred on the disc.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from association_oracle import REACH_MARGIN_M, REACH_SCALE, measure
from scipy.integrate import quad
from scipy.special import i0e, ndtr

from sensorsel.information.filtering import KeyframeMeasurements, Prediction
from sensorsel.information.integrity.association import candidate_reach, gate_of, measurement_risks

POSE = np.array([3.0, 1.0, 0.2])
GATE = gate_of(0.9999)
SIGMA_BEARING = 0.002  # [rad]


def _case(range_i: float, range_j: float, sigma_r: float, covariance_scale: float = 0.0):
    """The measured landmark ``range_i`` [m] ahead on bearing 0.1 rad and one other ``range_j`` [m]
    out on the same bearing; the pose and the map known exactly (``covariance_scale`` 0) or with
    that std [m] (the heading's a 20th of it [rad])."""
    c, s = math.cos(POSE[2] + 0.1), math.sin(POSE[2] + 0.1)
    points = np.array([POSE[:2] + r * np.array([c, s]) for r in (range_i, range_j)])
    sd = covariance_scale
    pred = Prediction(
        keyframe=0,
        landmarks=np.zeros(0, np.int64),
        covariance=np.diag([sd**2, sd**2, (sd / 20) ** 2]),
        prior_sigma_m=sd,
    )
    z = measure(POSE, points[0])
    meas = KeyframeMeasurements(
        0,
        np.array([0]),
        np.array([0]),
        np.array([z[0]]),
        np.array([z[1]]),
        np.array([SIGMA_BEARING]),
        np.array([sigma_r]),
    )
    return points, pred, meas


def _bound(points, pred, meas, **kw):
    r = measurement_risks(POSE, points, pred, meas, np.arange(len(points)), gate=GATE, model="map", **kw)
    return r


def _log_disc_probability(lam: float, radius: float) -> float:
    """ln P(‖x‖ ≤ radius) for x ~ N(μ, I₂), ‖μ‖² = ``lam``: the integral over the disc in polar
    coordinates about its centre, ∫₀^radius ρ e^(−(λ + ρ²)/2) I₀(√λ ρ) dρ, in log space
    (I₀(y) = i0e(y) eʸ)."""
    root = math.sqrt(lam)

    def log_f(rho: float) -> float:
        return math.log(rho) - 0.5 * (lam + rho**2) + math.log(i0e(root * rho)) + root * rho

    peak = log_f(radius)  # the integrand grows toward the edge nearest the origin's side
    value, err = quad(lambda r: math.exp(log_f(r) - peak) if r > 0 else 0.0, 0.0, radius, epsabs=0, epsrel=1e-10)
    assert err < 1e-6 * value
    return math.log(value) + peak


def _importance_sampled(lam: float, radius: float, n: int = 200_000, seed: int = 0) -> tuple[float, float]:
    """P(‖x − μ‖ ≤ radius) for x ~ N(0, I₂), ‖μ‖² = ``lam``, by draws from N(μ, I₂) weighted by the
    likelihood ratio exp(λ/2 − μ·x): (estimate, its standard error)."""
    rng = np.random.default_rng(seed)
    mu = np.array([0.0, math.sqrt(lam)])
    x = rng.standard_normal((n, 2)) + mu
    w = np.where(np.hypot(*(x - mu).T) <= radius, np.exp(0.5 * lam - x @ mu), 0.0)
    return float(w.mean()), float(w.std() / math.sqrt(n))


# (range of the measured landmark, of the other one [m], σ_range [m], where the engine leaves it)
CASES = {
    "dropped-by-the-far-filter": (20.0, 21.5, 0.1),  # within 1.25 r + 5 m, λ = 225
    "beyond-the-widened-reach": (20.0, 35.0, 1.0),  # past r + (√γ + F) √(s_bb + s_rr): λ = 225
}


@pytest.mark.parametrize("name", CASES)
def test_the_bound_covers_a_landmark_past_the_far_limit(name):
    range_i, range_j, sigma_r = CASES[name]
    points, pred, meas = _case(range_i, range_j, sigma_r)
    r = _bound(points, pred, meas, linear=True)
    assert r.n_candidates[0] == 0  # the engine keeps no candidate: the far limit is what is tested
    reach = float(candidate_reach(pred, meas, GATE)[0])
    assert (range_j > reach) == (name == "beyond-the-widened-reach")
    # the truth: λ from the geometry (same bearing: only the range differs), P(NIS_j ≤ γ) exactly
    lam = ((range_j - range_i) / sigma_r) ** 2
    root_g = math.sqrt(GATE)
    assert math.sqrt(lam) > 2 * root_g  # inside the gate, NIS_j < NIS_i (module docstring)
    # inside the gate the range noise is at least (range_j − range_i) − √γ σ_r: both landmarks in reach
    shortest = range_i + (range_j - range_i) - root_g * sigma_r
    assert REACH_SCALE * shortest + REACH_MARGIN_M > range_j > range_i
    log_truth = _log_disc_probability(lam, root_g)
    sampled, se = _importance_sampled(lam, root_g)
    assert abs(sampled - math.exp(log_truth)) < 5 * se  # the two oracles agree
    truth = math.exp(log_truth)
    assert truth == pytest.approx(2.47e-27, rel=0.01)  # the guide's figure: positive, and tiny
    assert r.bound[0] >= truth > 0.0  # the bound covers it (it was 0 when the far limit added nothing)
    # the one landmark not kept adds the guide's 4Φ(−10) + Φ(−10) (3.8e-23), nothing more: usable
    assert r.bound[0] == pytest.approx(5.0 * ndtr(-10.0), rel=1e-12)
    assert r.linear[0] <= r.bound[0]


def test_the_robust_bound_never_falls_as_a_pair_crosses_the_far_limit():
    """As the estimate's covariance grows, λ falls and the pair moves from dropped to kept: the bound
    robust to the covariance (what the search reads) must not fall at the crossing (each kept pair's
    term is floored at what it added when dropped)."""
    scales = np.geomspace(0.01, 0.3, 60)
    bounds, kept = [], []
    for sd in scales:
        points, pred, meas = _case(20.0, 21.55, 0.1, covariance_scale=float(sd))
        r = _bound(points, pred, meas, robust_to_covariance=True)
        bounds.append(float(r.bound[0]))
        kept.append(int(r.n_candidates[0]))
    assert kept[0] == 0 and kept[-1] == 1  # the scan crosses the far limit
    assert np.all(np.diff(bounds) >= 0.0), bounds
