"""simulate's measured 95 % lateral, longitudinal and heading errors against the predicted 1.96σ,
in the paper's SLAM graph and in a prior map (--map-sigma); the keyframe frame worked by hand; the
fast prediction against GTSAM's Marginals."""

from __future__ import annotations

import math

import gtsam
import numpy as np
import pytest
from click.testing import CliRunner
from gtsam.symbol_shorthand import L, X

from sensorsel.cli import cli
from sensorsel.errors import InputError
from sensorsel.information.evaluators import make_evaluator
from sensorsel.information.evaluators.accuracy import Z95, route_accuracy
from sensorsel.information.graph import pose2
from sensorsel.io import codec, results
from sensorsel.simulation import SimulationReport, SimulationResult, simulate
from sensorsel.simulation.consistency import body_frame_errors, predict
from sensorsel.simulation.noise import draw, make_payload, truth
from sensorsel.simulation.solve import Noise, build_graph

SUITE = "MRL-roof,HD2K-12"
COMPONENTS = ("lateral", "longitudinal", "heading")


@pytest.fixture(scope="module", params=[None, 0.05], ids=["slam", "map"])
def checked(request, tiny_problem):
    """200 runs of one suite on the tiny route, in the SLAM graph and in a map known to 5 cm."""
    return simulate(tiny_problem, SUITE, runs=200, seed=0, map_sigma_m=request.param)


def test_measured_95_percent_errors_are_the_predicted_ones(checked):
    """Oracle: the covariance of the graph at the truth. With 200 runs the 95th percentile of |error|
    per keyframe has a relative standard error of ~5 % (normal order statistic: sqrt(p (1 − p) / N)
    / (2 φ(1.96)) / 1.96 with p = 0.95); its median over the 10 keyframes lies within 10 % of the
    predicted median 1.96σ, the worst keyframe within 25 %, and the share of all 2,000 errors inside
    ±1.96σ_k within 2 points of 95 % (binomial sd 0.5 point; poses correlated along the route
    spread it more). Seed 0, not chosen."""
    acc = checked.accuracy
    assert acc is not None and acc.model == checked.model
    assert acc.model == ("slam" if checked.map_sigma_m is None else "map")
    for c in COMPONENTS:
        m, p = acc.spread("measured", c), acc.spread("predicted", c)
        assert m.median == pytest.approx(p.median, rel=0.10), c
        assert m.max == pytest.approx(p.max, rel=0.25), c
        assert abs(dict(acc.coverage)[c] - 0.95) < 0.02, c


def test_the_map_makes_the_lateral_error_smaller(tiny_problem, checked):
    """Both models, side by side: a map known to 5 cm bounds the lateral error well below SLAM's
    (the tiny route's SLAM σ grows from the first pose to ~0.08 m)."""
    other = simulate(tiny_problem, SUITE, runs=20, seed=0, map_sigma_m=None if checked.map_sigma_m else 0.05)
    slam, mapped = (checked, other) if checked.map_sigma_m is None else (other, checked)
    assert slam.accuracy and mapped.accuracy
    assert mapped.accuracy.spread("predicted", "lateral").max < 0.5 * slam.accuracy.spread("predicted", "lateral").max
    assert mapped.accuracy.spread("measured", "lateral").max < 0.5 * slam.accuracy.spread("measured", "lateral").max


def test_prediction_is_route_accuracy_of_the_same_suite_and_model(tiny_problem, checked):
    """The predicted 1.96σ are the accuracy commands print with --estimate smoother (fast engine;
    each run solves the whole route's batch, the smoother's estimate): equal in the map model;
    in SLAM to 1e-4 (the score's weak 100 m landmark prior, absent from the simulated graph)."""
    ev = make_evaluator(tiny_problem, "fast")
    acc = route_accuracy(
        ev, tiny_problem.library.parse_suite(SUITE), map_sigma_m=checked.map_sigma_m, estimate="smoother"
    )
    rel = 1e-12 if checked.map_sigma_m else 1e-4
    sim = checked.accuracy
    np.testing.assert_allclose(sim.predicted_lateral_95_m, Z95 * np.array(acc.lateral_sigma_m), rtol=rel)
    np.testing.assert_allclose(sim.predicted_longitudinal_95_m, Z95 * np.array(acc.longitudinal_sigma_m), rtol=rel)
    np.testing.assert_allclose(sim.predicted_heading_95_deg, Z95 * np.array(acc.heading_sigma_deg), rtol=rel)


@pytest.mark.parametrize("map_sigma", [None, 0.05])
def test_prediction_equals_gtsam_marginals(tiny_problem, map_sigma):
    """The closed-form dense prediction against GTSAM's Marginals of the same graph at the truth
    (landmark priors at the true positions in the map model), with a partial failure."""
    from sensorsel.simulation import Failure
    from sensorsel.simulation.failures import resolve_failures

    lib = tiny_problem.library
    suite = lib.parse_suite("LRL-roof,HD2K-12")
    fails = resolve_failures([Failure("LRL-roof", 2, 6)], tiny_problem, suite)
    p = make_payload(tiny_problem, suite, fails, 1.3, "lm", 0, map_sigma)
    pred = predict(p)
    d = truth(p)
    graph = build_graph(p, Noise(p), d)
    values = gtsam.Values()
    for k in range(len(p.poses)):
        values.insert(X(k), pose2(p.poses[k]))
    measured = p.measured_landmarks()
    for j in measured:
        values.insert(L(int(j)), gtsam.Point2(*p.landmarks[j]))
    m = gtsam.Marginals(graph, values)
    keys = gtsam.KeyVector([X(k) for k in range(len(p.poses))])
    np.testing.assert_allclose(pred.pose_cov, m.jointMarginalCovariance(keys).fullMatrix(), rtol=1e-8, atol=1e-14)
    for j in measured:
        np.testing.assert_allclose(pred.landmark_cov[j], m.marginalCovariance(L(int(j))), rtol=1e-8, atol=1e-14)
    assert np.all(np.isnan(pred.landmark_cov[np.setdiff1d(np.arange(len(p.landmarks)), measured)]))


def test_map_model_prior_sits_at_the_drawn_map_not_the_truth(tiny_problem):
    """Each run draws its own map from (seed, run, 2): off the truth by ~map_sigma, different per
    run, and the SLAM draws (odometry, measurements) are unchanged by it."""
    suite = tiny_problem.library.parse_suite(SUITE)
    slam = make_payload(tiny_problem, suite, (), 1.0, "lm", 4)
    mapped = make_payload(tiny_problem, suite, (), 1.0, "lm", 4, 0.5)
    a, b, c = draw(slam, 1), draw(mapped, 1), draw(mapped, 2)
    assert a.map_points is None and b.map_points is not None and c.map_points is not None
    np.testing.assert_array_equal(a.bearing_rad, b.bearing_rad)
    assert [q.x() for q in a.odometry] == [q.x() for q in b.odometry]
    err = b.map_points - mapped.landmarks
    assert 0.3 < float(np.std(err)) < 0.7  # std 0.5 m over the tiny map's landmarks
    assert not np.allclose(b.map_points, c.map_points)
    g = build_graph(mapped, Noise(mapped), b)
    priors = [g.at(i) for i in range(g.size()) if isinstance(g.at(i), gtsam.PriorFactorPoint2)]
    assert len(priors) == len(mapped.measured_landmarks())
    for f in priors:
        j = gtsam.Symbol(f.keys()[0]).index()
        np.testing.assert_array_equal(f.prior(), b.map_points[j])


# -------------------------------------------------------------------------------------- the frame


def test_body_frame_errors_worked_by_hand():
    """A route heading north (θ = 90°): forward is world +y, left is world −x. An estimate 0.3 m
    east and 0.2 m north of the truth is 0.2 m ahead (longitudinal) and 0.3 m to the right
    (lateral −0.3). Heading east (θ = 0) the same offset is 0.3 m ahead and 0.2 m to the left."""
    true = np.array([[10.0, 5.0, math.pi / 2], [10.0, 5.0, 0.0], [10.0, 5.0, math.pi]])
    est = true + np.array([[0.3, 0.2, 0.01], [0.3, 0.2, 0.0], [0.3, 0.2, 0.0]])
    lon, lat = body_frame_errors(true, est)
    np.testing.assert_allclose(lon, [0.2, 0.3, -0.3], atol=1e-12)
    np.testing.assert_allclose(lat, [-0.3, 0.2, -0.2], atol=1e-12)


def test_run_errors_are_world_offsets_in_each_keyframes_frame(tiny_problem, checked):
    """Every run's lateral and longitudinal errors are its estimate's offsets rotated into the true
    keyframe's frame (the tiny route's headings vary: checked per keyframe against the world offsets)."""
    true = np.asarray(tiny_problem.scenario.keyframes.poses, float)
    for r in checked.runs[:5]:
        est = np.array(r.poses)
        d = est[:, :2] - true[:, :2]
        fwd = np.column_stack([np.cos(true[:, 2]), np.sin(true[:, 2])])
        left = np.column_stack([-np.sin(true[:, 2]), np.cos(true[:, 2])])
        np.testing.assert_allclose(r.longitudinal_error_m, np.sum(d * fwd, axis=1), atol=1e-12)
        np.testing.assert_allclose(r.lateral_error_m, np.sum(d * left, axis=1), atol=1e-12)


# ----------------------------------------------------------------------------------- files and CLI


def test_older_simulation_files_still_load(checked):
    """Files written before the accuracy check: no model, map sigma, accuracy or body-frame errors."""
    data = codec.to_jsonable(checked)
    for key in ("model", "map_sigma_m", "accuracy"):
        data.pop(key)
    for run in data["runs"]:
        run.pop("lateral_error_m")
        run.pop("longitudinal_error_m")
    old = codec.from_jsonable(SimulationResult, data)
    assert old.model == "slam" and old.accuracy is None and old.runs[0].lateral_error_m == ()


def test_cli_map_sigma_prints_predicted_vs_measured(tmp_path):
    r = CliRunner().invoke(
        cli,
        [
            "simulate",
            "--fixture",
            "tiny",
            "--suite",
            SUITE,
            "--runs",
            "3",
            "--jobs",
            "1",
            "--map-sigma",
            "0.05",
            "--output-dir",
            str(tmp_path),
        ],
    )
    assert r.exit_code == 0, r.output
    assert "predicted vs measured 95 % errors" in r.output and "landmarks known to 0.05 m" in r.output
    for c in COMPONENTS:
        assert c in r.output
    (sim,) = results.load(tmp_path / "simulation.json", SimulationReport).simulations
    assert sim.model == "map" and sim.map_sigma_m == 0.05 and sim.accuracy is not None
    assert len(sim.accuracy.measured_lateral_95_m) == sim.problem.n_poses


@pytest.mark.parametrize("value", ["-0.1", "0", "nan", "inf"])
def test_cli_bad_map_sigma_is_one_line(tmp_path, value):
    r = CliRunner().invoke(
        cli,
        [
            "simulate",
            "--fixture",
            "tiny",
            "--suite",
            SUITE,
            "--runs",
            "1",
            "--jobs",
            "1",
            "--map-sigma",
            value,
            "--output-dir",
            str(tmp_path),
        ],
    )
    assert r.exit_code == 2 and "--map-sigma" in r.output and "Traceback" not in r.output


def test_api_bad_map_sigma(tiny_problem):
    with pytest.raises(InputError, match="map sigma"):
        simulate(tiny_problem, SUITE, runs=1, map_sigma_m=-1.0)


# ------------------------------------------------------------------------- one factor per pair


def _values(p, poses, points):
    values = gtsam.Values()
    for k, q in enumerate(poses):
        values.insert(X(k), pose2(q))
    for j in p.measured_landmarks():
        values.insert(L(int(j)), gtsam.Point2(*points[j]))
    return values


def _every_measurement_graph(p, d):
    """The graph with one factor per measurement (how it was built before pairs were combined)."""
    from sensorsel.information.graph import add_bearing_range, add_pose_chain

    noise = Noise(p)
    g = gtsam.NonlinearFactorGraph()
    add_pose_chain(g, d.prior, d.odometry, noise.prior, noise.odometry)
    o = p.order()
    add_bearing_range(g, p.pose[o], p.landmark[o], d.bearing_rad[o], d.range_m[o], [noise.measurement(i) for i in o])
    return g


def test_pairs_keep_the_error_of_every_measurement(tiny_problem):
    """Combining a pair's measurements by their information changes the graph's error only by the
    constant it reports, at any values (so the same minimiser and information); checked with one
    pair's bearings placed either side of ±π, where a mean without wrapping would point backwards."""
    import dataclasses

    from sensorsel.simulation.solve import pairs

    suite = tiny_problem.library.parse_suite("LRL-roof,MRL-roof,HD2K-12,WSC-12")
    p = make_payload(tiny_problem, suite, (), 1.0, "lm", 3)
    d = draw(p, 0)
    q = pairs(p, d)
    assert len(q.pose) < int(p.keep.sum())  # the tiny route has pairs measured by several sensors
    o = p.order()
    key = p.pose[o] * len(p.landmarks) + p.landmark[o]
    shared = np.unique(key)[np.unique(key, return_counts=True)[1] > 1][0]  # a pair several sensors measure
    dup = o[key == shared]
    bearing = d.bearing_rad.copy()
    bearing[dup[0]], bearing[dup[1]] = math.pi - 0.001, -math.pi + 0.002
    d = dataclasses.replace(d, bearing_rad=bearing)
    q = pairs(p, d)
    merged, every = build_graph(p, Noise(p), d, q), _every_measurement_graph(p, d)
    rng = np.random.default_rng(1)
    for scale in (0.0, 0.05, 1.0):
        poses = p.poses + scale * rng.standard_normal(p.poses.shape)
        values = _values(p, poses, p.landmarks + scale * rng.standard_normal(p.landmarks.shape))
        assert merged.error(values) + q.constant == pytest.approx(every.error(values), rel=1e-10)


def test_map_model_is_byte_identical_whatever_the_workers(tiny_problem):
    """Same seed, same bytes, on 1 or 2 worker processes (the map draw travels as (seed, run, 2))."""
    from sensorsel.simulation import without_timing

    one = simulate(tiny_problem, SUITE, runs=4, seed=9, jobs=1, map_sigma_m=0.1)
    two = simulate(tiny_problem, SUITE, runs=4, seed=9, jobs=2, map_sigma_m=0.1)
    assert results.dumps(SimulationReport((without_timing(one),))) == results.dumps(
        SimulationReport((without_timing(two),))
    )
    other = simulate(tiny_problem, SUITE, runs=4, seed=10, jobs=1, map_sigma_m=0.1)
    assert other.runs[0].lateral_error_m != one.runs[0].lateral_error_m
