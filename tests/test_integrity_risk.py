"""Integrity risk, protection levels, the lever, the bounds a search uses, and the filter they
stand on (sensorsel.information.integrity, sensorsel.information.filtering)."""

from __future__ import annotations

import json
import math

import gtsam
import numpy as np
import pytest
from click.testing import CliRunner
from gtsam.symbol_shorthand import L, X
from scipy.stats import norm

from sensorsel.cli import cli
from sensorsel.errors import InputError
from sensorsel.information import graph as G
from sensorsel.information.filtering import forward_pass, keyframe_measurements
from sensorsel.information.integrity import IntegrityBounds, IntegritySpec, RouteIntegrity, route_integrity
from sensorsel.information.integrity.risk import keyframes_per_hour, protection_levels, tail_risk
from sensorsel.io import results

SUITE = "LRR-7,HD2K-4,HD2K-9,LSC-2"


def _gtsam_marginal(problem, suite, k, map_sigma, with_k=True):
    """GTSAM's marginal of X(k) on the graph of the priors, odometry up to k and the measurements of
    keyframes < k (<= k with ``with_k``): the filter's oracle."""
    b = G.GraphBuilder(problem)
    g = gtsam.NonlinearFactorGraph()
    poses = b._poses[: k + 1]
    G.add_pose_chain(
        g,
        poses[0],
        G.truth_steps(poses),
        G.diagonal(problem.settings.first_pose_sigmas),
        G.diagonal(problem.settings.odometry_sigmas),
    )
    vals = gtsam.Values()
    for i, q in enumerate(poses):
        vals.insert(X(i), q)
    seen = set()
    for obs in (problem.observations[s] for s in suite):
        for kk, j, br, r, sb, sr in zip(
            obs.pose, obs.landmark, obs.bearing_rad, obs.range_m, obs.sigma_bearing_rad, obs.sigma_range_m
        ):
            if kk < k or (with_k and kk == k):
                g.add(G.bearing_range_factor(int(kk), int(j), br, r, G.diagonal([sb, sr])))
                seen.add(int(j))
    sigma = problem.settings.landmark_prior_sigma_m if map_sigma is None else map_sigma
    for j in seen:
        g.add(G.landmark_prior(j, b._points[j], gtsam.noiseModel.Isotropic.Sigma(2, sigma)))
        vals.insert(L(j), b._points[j])
    return gtsam.Marginals(g, vals).marginalCovariance(X(k))


@pytest.mark.parametrize("map_sigma", [0.05, None])
def test_filter_stand_in_equals_gtsam(tiny_problem, map_sigma):
    suite = tiny_problem.library.resolve_suite(SUITE + ",MRL-roof")
    fp = forward_pass(tiny_problem, suite, map_sigma_m=map_sigma)
    for k in (0, 4, tiny_problem.scenario.n_poses - 1):
        want = _gtsam_marginal(tiny_problem, suite, k, map_sigma)
        np.testing.assert_allclose(fp.filtered[k], want, rtol=1e-7, atol=1e-14)
        want_pred = _gtsam_marginal(tiny_problem, suite, k, map_sigma, with_k=False)
        np.testing.assert_allclose(fp.predicted[k], want_pred, rtol=1e-7, atol=1e-14)
    assert fp.n_used.sum() == fp.n_measured.sum() == sum(len(tiny_problem.observations[s]) for s in suite)


def test_keyframe_measurements_group_and_order(tiny_problem):
    suite = tiny_problem.library.resolve_suite(SUITE)
    groups = keyframe_measurements(tiny_problem, suite)
    assert len(groups) == tiny_problem.scenario.n_poses
    assert sum(len(g.landmark) for g in groups) == sum(len(tiny_problem.observations[s]) for s in suite)
    for g in groups:
        key = list(zip(g.sensor.tolist(), g.landmark.tolist()))
        assert key == sorted(key)


def test_tail_and_protection_levels_by_hand():
    """σ = (0.1 m lon, 0.05 m lat, 0.2 deg): the tail is 2Φ(−2.9) + 2Φ(−5.8) + 2Φ(−2.5); the protection
    level at a 1e-6 allocation with 1e-7 of it taken by association is σ Φ⁻¹(1 − 0.9e-6 / 6)."""
    cov = np.diag([0.1**2, 0.05**2, math.radians(0.2) ** 2])[None]
    spec = IntegritySpec(alert_lateral_m=0.29, alert_longitudinal_m=0.29, alert_heading_deg=0.5)
    want = 2 * (norm.sf(2.9) + norm.sf(5.8) + norm.sf(2.5))
    assert tail_risk(cov, spec)[0] == pytest.approx(want, rel=1e-9)
    lat, lon = protection_levels(cov, np.array([1e-7]), 1e-6)
    z = norm.isf(0.9e-6 / 6)
    assert lat[0] == pytest.approx(0.05 * z, rel=1e-9) and lon[0] == pytest.approx(0.1 * z, rel=1e-9)
    lat, lon = protection_levels(cov, np.array([2e-6]), 1e-6)
    assert math.isinf(lat[0]) and math.isinf(lon[0])


def test_route_integrity_adds_up(tiny_problem):
    suite = tiny_problem.library.resolve_suite(SUITE)
    spec = IntegritySpec(integrity_risk=1e-3)
    r = route_integrity(tiny_problem, suite, spec, map_sigma_m=0.05)
    fp = forward_pass(tiny_problem, suite, map_sigma_m=0.05)
    tail = tail_risk(fp.filtered, spec)
    np.testing.assert_allclose(r.integrity_risk, np.minimum(1, tail + np.asarray(r.p_wrong_association)), rtol=1e-12)
    n_h = keyframes_per_hour(tiny_problem)
    assert r.integrity_risk_per_hour == pytest.approx(n_h * np.mean(r.integrity_risk))
    assert all(b >= e - 1e-12 for b, e in zip(r.p_wrong_association, r.p_wrong_association_estimate))
    assert r.meets == (r.integrity_risk_per_hour <= 1e-3)
    back = results.from_jsonable(RouteIntegrity, results.to_jsonable(r))
    assert back == r


def test_the_lever_leaves_risky_measurements_out(tiny_problem):
    suite = tiny_problem.library.resolve_suite(SUITE)
    full = route_integrity(tiny_problem, suite, IntegritySpec(), map_sigma_m=0.05)
    lever = route_integrity(tiny_problem, suite, IntegritySpec(max_association_risk=1e-3), map_sigma_m=0.05)
    n_out = sum(x.count for x in lever.left_out)
    assert n_out > 0 and sum(lever.n_used) == sum(full.n_used) - n_out
    assert max(lever.p_wrong_association) < max(full.p_wrong_association)
    # each keyframe's union bound: only used measurements, each at most the threshold
    assert all(p <= 1e-3 * u + 1e-15 for p, u in zip(lever.p_wrong_association, lever.n_used))
    # information lost: the car's σ is never smaller with fewer measurements
    assert all(a >= b - 1e-15 for a, b in zip(lever.lateral_sigma_m, full.lateral_sigma_m))
    ids = {tiny_problem.library.sensors[s].id for s in suite}
    assert {x.sensor for x in lever.left_out} <= ids


def test_per_sensor_sums_add_up_to_the_keyframes(tiny_problem):
    """Each sensor's Σ bound is a bound on its expected wrong associations (never below Σ estimate);
    over the sensors it adds up to the keyframes' union bounds (min(1, Σ p) per keyframe): equal
    where no keyframe is capped at 1 (the lever keeps every sum small), never below it otherwise."""
    suite = tiny_problem.library.resolve_suite(SUITE)
    for threshold in (None, 1e-3):
        r = route_integrity(tiny_problem, suite, IntegritySpec(max_association_risk=threshold), map_sigma_m=0.05)
        assert r.by_sensor and all(x.expected_wrong <= x.expected_wrong_bound + 1e-12 for x in r.by_sensor)
        assert all(x.worst_bound <= x.expected_wrong_bound + 1e-15 for x in r.by_sensor)
        total = sum(x.expected_wrong_bound for x in r.by_sensor)
        if max(r.p_wrong_association) < 1.0:
            assert total == pytest.approx(sum(r.p_wrong_association), rel=1e-9)
        else:
            assert total > sum(r.p_wrong_association)


@pytest.mark.parametrize("threshold", [None, 2e-3])
def test_search_bounds_are_monotone_and_valid(tiny_problem, threshold):
    """(b) the tail relaxation never rises when a sensor is added and is at most the integrity risk;
    (c) the association floor never falls when a sensor is added and is at most the association part
    of the risk: on random nested suites of a small allowed library, with and without the lever."""
    lib = tiny_problem.library
    allowed = lib.resolve_suite("LRR-7,LRR-1,HD2K-4,HD2K-9,LSC-2,MRL-roof,WSC-12,HD2K-12")
    spec = IntegritySpec(max_association_risk=threshold)
    bounds = IntegrityBounds(tiny_problem, allowed, spec, map_sigma_m=0.05)
    rng = np.random.default_rng(2)
    n_h = keyframes_per_hour(tiny_problem)
    for _ in range(3):
        order = list(rng.permutation(allowed))
        prev_tail, prev_floor = math.inf, 0.0
        for i in range(1, len(order) + 1):
            suite = order[:i]
            tail, floor = bounds.tail_relaxation(suite), bounds.association_floor(suite)
            assert tail <= prev_tail * (1 + 1e-9) and floor >= prev_floor * (1 - 1e-12)
            r = bounds.check(suite)
            assoc = n_h * float(np.mean(np.minimum(1.0, r.p_wrong_association)))
            assert floor <= assoc * (1 + 1e-9) + 1e-300
            assert tail <= r.integrity_risk_per_hour * (1 + 1e-9)
            prev_tail, prev_floor = tail, floor
    assert prev_floor > 0


def test_slam_floor_is_zero(tiny_problem):
    b = IntegrityBounds(tiny_problem, tiny_problem.library.resolve_suite(SUITE), IntegritySpec(), map_sigma_m=None)
    assert b.association_floor(tiny_problem.library.resolve_suite(SUITE)) == 0.0


def test_integrity_line_and_json_of_score():
    runner = CliRunner()
    res = runner.invoke(
        cli, ["score", "--fixture", "tiny", "--suite", SUITE, "--map-sigma", "0.05", "--max-association-risk", "0.001"]
    )
    assert res.exit_code == 0, res.output
    line = [ln for ln in res.output.splitlines() if ln.startswith("integrity")]
    assert len(line) == 1 and "/h FAILS 1e-08/h (assoc. " in line[0] and "left out 21/111" in line[0]
    assert len(line[0]) <= 130  # one readable line; the detail is in the JSON
    res = runner.invoke(cli, ["score", "--fixture", "tiny", "--suite", SUITE, "--json"])
    assert res.exit_code == 0
    data = json.loads(res.output)
    itg = data["integrity"][0]
    for key in (
        "p_wrong_association",
        "integrity_risk",
        "protection_level_lateral_m",
        "protection_level_longitudinal_m",
    ):
        assert len(itg[key]) == 10
    assert isinstance(itg["integrity_risk_per_hour"], float)


@pytest.mark.parametrize(
    "args, option",
    [
        (["--integrity-risk", "0"], "--integrity-risk"),
        (["--integrity-risk", "1"], "--integrity-risk"),
        (["--integrity-risk", "-1e-8"], "--integrity-risk"),
        (["--alert-lateral", "0"], "--alert-lateral"),
        (["--alert-longitudinal", "-0.2"], "--alert-longitudinal"),
        (["--alert-heading", "0"], "--alert-heading"),
        (["--gate-probability", "1"], "--gate-probability"),
        (["--gate-probability", "0"], "--gate-probability"),
        (["--max-association-risk", "1.5"], "--max-association-risk"),
        (["--alert-lateral", "nan"], "--alert-lateral"),
    ],
)
def test_bad_integrity_options(args, option):
    res = CliRunner().invoke(cli, ["score", "--fixture", "tiny", "--suite", SUITE] + args)
    assert res.exit_code == 2
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert lines == [lines[-1]] and lines[-1].startswith(f"sensorsel: error: {option} ")


def test_selecting_commands_print_and_record_integrity(tmp_path):
    runner = CliRunner()
    out = tmp_path / "greedy.json"
    res = runner.invoke(
        cli,
        [
            "greedy",
            "--fixture",
            "tiny",
            "--budget",
            "5000",
            "--map-sigma",
            "0.05",
            "-q",
            "--alert-lateral",
            "0.5",
            "-o",
            str(out),
        ],
    )
    assert res.exit_code == 0, res.output
    assert sum(ln.startswith("integrity") for ln in res.output.splitlines()) == 1
    loaded = results.load(out)
    assert len(loaded.integrity) == 1 and loaded.integrity[0].spec.alert_lateral_m == 0.5
    assert loaded.integrity[0].model == "map"


def test_same_inputs_same_bytes(tiny_problem):
    suite = tiny_problem.library.resolve_suite(SUITE)
    spec = IntegritySpec(max_association_risk=1e-3)
    a = results.dumps(route_integrity(tiny_problem, suite, spec, map_sigma_m=0.05))
    b = results.dumps(route_integrity(tiny_problem, suite, spec, map_sigma_m=0.05))
    assert a == b


def test_suite_quality_runs_the_filter_once_and_answers_as_the_two_calls(tiny_problem):
    """with_suite_quality takes the accuracy from the integrity's forward pass (without the lever):
    the same records as suite_accuracy and suite_integrity called apart, in both models."""
    from dataclasses import dataclass

    from sensorsel import api

    @dataclass(frozen=True)
    class Chosen:
        suite: tuple[str, ...]
        accuracy: tuple = ()
        integrity: tuple = ()

    suite = tuple(SUITE.split(","))
    for ms in (0.05, None):
        got = api.with_suite_quality(Chosen(suite), tiny_problem, map_sigma_m=ms)
        acc = api.suite_accuracy(tiny_problem, suite, map_sigma_m=ms)
        itg = api.suite_integrity(tiny_problem, suite, map_sigma_m=ms)
        assert got.accuracy == acc  # exactly equal (dataclass equality on every float tuple)
        assert [results.dumps(a) for a in got.integrity] == [results.dumps(a) for a in itg]
    spec = IntegritySpec(max_association_risk=1e-3)  # the lever: what is used differs, two passes
    got = api.with_suite_quality(Chosen(suite), tiny_problem, map_sigma_m=0.05, integrity=spec)
    assert got.accuracy == api.suite_accuracy(tiny_problem, suite, map_sigma_m=0.05)
    with pytest.raises(InputError, match="map sigma"):
        api.with_suite_quality(Chosen(suite), tiny_problem, map_sigma_m=-1.0)
