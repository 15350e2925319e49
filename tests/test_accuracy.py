"""Accuracy in metres: pose marginals against GTSAM's ``Marginals``, the frame of Pose2's
tangent worked by hand, monotonicity in the suite, and the two kernel paths against each other."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sensorsel.errors import InputError
from sensorsel.information.evaluators import FastEvaluator, ReferenceEvaluator
from sensorsel.information.evaluators.accuracy import Z95, accuracy_from_covariances, route_accuracy
from sensorsel.model.problem import build_problem
from sensorsel.model.scenario import Scenario, Trajectory

SUITES = [(), (0,), (0, 5, 20), (2, 14, 30, 47, 61)]


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    """Largest difference relative to each keyframe's largest entry."""
    return float(np.max(np.abs(a - b) / np.abs(b).max(axis=(1, 2))[:, None, None]))


@pytest.mark.parametrize("fixture", ["tiny_problem", "suburb_problem"])
@pytest.mark.parametrize("map_sigma", [None, 0.05])
def test_pose_marginals_equal_gtsam_marginals(request, fixture, map_sigma):
    """Both engines, both kernel paths (frontal selected inversion, dense), both models: GTSAM's own
    Marginals of the same graph (landmark priors of the map's std in the map model)."""
    problem = request.getfixturevalue(fixture)
    ref = ReferenceEvaluator(problem)
    engines = [FastEvaluator(problem, front_below=0.0), FastEvaluator(problem, front_below=1e9)]
    for suite in SUITES + [tuple(range(len(problem.library)))]:
        want = ref.pose_covariances(suite, map_sigma_m=map_sigma)
        assert want.shape == (problem.scenario.n_poses, 3, 3)
        for ev in engines:
            assert _rel(ev.pose_covariances(suite, map_sigma_m=map_sigma), want) < 1e-8
    assert engines[0].kernel.counts["dense_covariance"] > 0 and engines[1].kernel.counts["front_covariance"] > 0


def _two_keyframes(library, heading: float, step_m: float):
    """A route of two keyframes ``step_m`` apart, both facing ``heading`` [rad], landmarks out of reach."""
    c, s = math.cos(heading), math.sin(heading)
    poses = np.array([[0.0, 0.0, heading], [step_m * c, step_m * s, heading]])
    traj = Trajectory(poses, np.array([0.0, 1.0]), np.array([0, 1]), "hand")
    far = np.array([[5000.0, 5000.0], [-5000.0, 5000.0]])
    return build_problem(library, Scenario("hand", traj, far, "hand", route=traj))


@pytest.mark.parametrize("heading", [0.0, 0.7, math.pi / 2, -2.5])
def test_frame_of_the_tangent_worked_by_hand(library, heading):
    """Odometry alone, two keyframes L apart facing the same way: in keyframe 1's own frame
    (x forward, y left) a heading error δθ₀ of keyframe 0 moves keyframe 1 sideways by L δθ₀, so
    σ²_lateral = σ²_y0 + L² σ²_θ0 + σ²_y,odo, σ²_longitudinal = σ²_x0 + σ²_x,odo,
    σ²_heading = σ²_θ0 + σ²_θ,odo, whatever the heading of the route (the body frame)."""
    step = 10.0
    problem = _two_keyframes(library, heading, step)
    s = problem.settings
    (px, py, pt), (ox, oy, ot) = s.first_pose_sigmas, s.odometry_sigmas
    for ev in (FastEvaluator(problem), ReferenceEvaluator(problem)):
        acc = route_accuracy(ev, ())
        assert acc.longitudinal_sigma_m[0] == pytest.approx(px, rel=1e-9)
        assert acc.lateral_sigma_m[0] == pytest.approx(py, rel=1e-9)
        assert acc.heading_sigma_deg[0] == pytest.approx(math.degrees(pt), rel=1e-9)
        assert acc.lateral_sigma_m[1] == pytest.approx(math.sqrt(py**2 + step**2 * pt**2 + oy**2), rel=1e-9)
        assert acc.longitudinal_sigma_m[1] == pytest.approx(math.sqrt(px**2 + ox**2), rel=1e-9)
        assert acc.heading_sigma_deg[1] == pytest.approx(math.degrees(math.sqrt(pt**2 + ot**2)), rel=1e-9)


def test_summaries_and_line():
    cov = np.zeros((5, 3, 3))
    lat = np.array([0.1, 0.3, 0.2, 0.5, 0.4])
    cov[:, 0, 0], cov[:, 1, 1], cov[:, 2, 2] = 0.01, lat**2, math.radians(0.1) ** 2
    acc = accuracy_from_covariances(cov, map_sigma_m=0.05, route="r")
    assert acc.model == "map" and acc.lateral.max == pytest.approx(0.5) and acc.lateral.worst_keyframe == 3
    assert acc.lateral.median == pytest.approx(0.3)
    assert acc.lateral.p95 == pytest.approx(np.percentile(lat, 95))
    assert acc.heading_sigma_deg[0] == pytest.approx(0.1)
    line = acc.line()
    assert "prior map (landmarks known to 0.05 m)" in line and f"{Z95 * 0.5:.3f}" in line
    assert accuracy_from_covariances(cov, map_sigma_m=None).model == "slam"


@pytest.mark.parametrize("bad", [0.0, -0.1, math.nan, math.inf])
def test_map_sigma_must_be_positive(tiny_problem, bad):
    with pytest.raises(InputError, match="map sigma"):
        FastEvaluator(tiny_problem).pose_covariances((0,), map_sigma_m=bad)


@settings(max_examples=25, deadline=None)
@given(data=st.data())
def test_adding_a_sensor_never_raises_a_sigma(tiny_problem, data):
    """Monotonicity, which require's exact search relies on: every σ of every keyframe falls (or
    stays) when a sensor is added, in both models."""
    n = len(tiny_problem.library)
    ev = _tiny_fast(tiny_problem)
    suite = tuple(sorted(data.draw(st.sets(st.integers(0, n - 1), max_size=6))))
    extra = data.draw(st.integers(0, n - 1))
    ms = data.draw(st.sampled_from([None, 0.05, 1.0]))
    a = route_accuracy(ev, suite, map_sigma_m=ms)
    b = route_accuracy(ev, suite + (extra,), map_sigma_m=ms)
    for comp in ("lateral", "longitudinal", "heading"):
        assert np.all(b.sigmas(comp) <= a.sigmas(comp) * (1 + 1e-9) + 1e-15)


_FAST: dict[int, FastEvaluator] = {}


def _tiny_fast(problem) -> FastEvaluator:
    ev = _FAST.get(id(problem))
    if ev is None:
        ev = _FAST[id(problem)] = FastEvaluator(problem)
    return ev


def test_map_model_is_tighter_than_slam(suburb_problem):
    """Known landmarks (5 cm) only add information: every σ is below the SLAM graph's."""
    ev = FastEvaluator(suburb_problem)
    slam, mapped = route_accuracy(ev, (0,)), route_accuracy(ev, (0,), map_sigma_m=0.05)
    assert np.all(mapped.sigmas("lateral") < slam.sigmas("lateral"))
    assert mapped.lateral.max < 0.1 < slam.lateral.max


@settings(max_examples=20, deadline=None)
@given(data=st.data())
def test_covariance_floor_is_below_the_marginals(suburb_problem, data):
    """The cheap floor require refutes suites with: every keyframe's (P_kk)⁻¹ is below its marginal
    covariance in the PSD order (so every σ is below the true one), in both models."""
    n = len(suburb_problem.library)
    ev = _tiny_fast(suburb_problem)
    suite = tuple(sorted(data.draw(st.sets(st.integers(0, n - 1), min_size=0, max_size=8))))
    ms = data.draw(st.sampled_from([None, 0.05]))
    floor, cov = ev.pose_covariance_floor(suite, map_sigma_m=ms), ev.pose_covariances(suite, map_sigma_m=ms)
    gap = np.linalg.eigvalsh(cov - floor)
    assert np.all(gap >= -1e-9 * np.abs(cov).max(axis=(1, 2))[:, None])
