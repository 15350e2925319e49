"""Monte-Carlo SLAM validation (sensorsel.simulation): convergence, consistency, blind suites, determinism."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest
from click.testing import CliRunner
from scipy.stats import chi2

from sensorsel.cli import cli
from sensorsel.errors import InputError
from sensorsel.io import codec, results
from sensorsel.model.problem import build_problem
from sensorsel.model.scenario import Scenario
from sensorsel.simulation import Failure, SimulationReport, nees_bounds, parse_failures, simulate, without_timing


def _same(a, b) -> bool:
    return results.dumps(without_timing(a)) == results.dumps(without_timing(b))


# ------------------------------------------------------------------------- convergence to the truth


@pytest.mark.parametrize("solver", ["lm", "isam2"])
def test_noise_towards_zero_converges_to_the_truth(tiny_problem, solver):
    small = simulate(tiny_problem, "MRL-roof,WSC-12", runs=2, noise_scale=1e-4, solver=solver)
    smaller = simulate(tiny_problem, "MRL-roof,WSC-12", runs=2, noise_scale=1e-5, solver=solver)
    full = simulate(tiny_problem, "MRL-roof,WSC-12", runs=2, noise_scale=1.0, solver=solver)
    assert full.position_rmse_m > 1e-2  # the full noise gives centimetres of error
    for res in (small, smaller):  # errors shrink with the noise: about noise_scale times the full ones
        assert res.position_rmse_m < 10 * res.noise_scale * full.position_rmse_m
        assert res.heading_rmse_rad < 10 * res.noise_scale * full.heading_rmse_rad
        assert res.landmark_rmse_m is not None and res.landmark_rmse_m < 10 * res.noise_scale * full.landmark_rmse_m
    # The same random numbers are scaled (common random numbers), so near zero noise the estimator is
    # linear in it: ten times less noise, ten times smaller errors, for every keyframe.
    a = np.array([r.position_error_m for r in small.runs])
    b = np.array([r.position_error_m for r in smaller.runs])
    np.testing.assert_allclose(b * 10.0, a, rtol=1e-3, atol=1e-12)
    np.testing.assert_allclose(smaller.heading_rmse_rad * 10.0, small.heading_rmse_rad, rtol=1e-3)
    # SLAM beat the dead-reckoned start it was given
    assert small.position_rmse_m < small.initial_position_rmse_m


def test_lm_and_isam2_reach_the_same_estimate(tiny_problem):
    lm = simulate(tiny_problem, "LRL-roof,HD2K-12", runs=3, solver="lm")
    isam = simulate(tiny_problem, "LRL-roof,HD2K-12", runs=3, solver="isam2")
    for a, b in zip(lm.runs, isam.runs):
        np.testing.assert_allclose(np.array(a.poses), np.array(b.poses), atol=1e-4)
        np.testing.assert_allclose(np.array(a.landmarks), np.array(b.landmarks), atol=1e-4)
    assert isam.runs[0].iterations >= tiny_problem.scenario.n_poses  # one update per keyframe at least


# -------------------------------------------------------------------------------------- consistency


@pytest.mark.parametrize("suite", ["LRL-roof", "HD2K-12,LRR-6"])
def test_empirical_covariance_matches_the_prediction(tiny_problem, suite):
    """Average NEES over 150 runs inside its 95 % chi-square bounds.

    Seed 0, not chosen: over seeds 0..39 (100 runs each) the joint NEES fell inside its bounds 37 and
    38 times of 40 for these two suites, the per-pose average inside its correlated bounds 39 and 37
    times, as 95 % bounds should.
    """
    res = simulate(tiny_problem, suite, runs=150, seed=0)
    n, k = res.n_runs, res.problem.n_poses
    lo, hi = chi2.ppf([0.025, 0.975], 3 * n * k) / (n * k)
    assert res.nees_bounds == pytest.approx((lo, hi), rel=1e-12)
    assert lo <= res.nees_joint_mean <= hi and res.nees_joint_inside_bounds
    clo, chi = res.nees_bounds_correlated
    assert clo < lo and chi > hi  # poses along a route are correlated: the per-pose average spreads more
    assert clo <= res.nees_mean <= chi
    # RMS errors as predicted by the information matrix (20 % with 150 runs of 10 correlated poses)
    assert res.position_rmse_m == pytest.approx(res.predicted_position_rmse_m, rel=0.2)
    assert res.landmark_rmse_m == pytest.approx(res.predicted_landmark_rmse_m, rel=0.2)
    assert res.heading_rmse_rad == pytest.approx(res.predicted_heading_rmse_rad, rel=0.2)


def test_nees_bounds_without_correlation_are_the_textbook_ones():
    n, k = 7, 11
    assert nees_bounds(n, k, trace_sq=3.0 * k) == pytest.approx(nees_bounds(n, k), rel=1e-12)
    lo, hi = nees_bounds(n, k)
    assert (lo, hi) == pytest.approx(tuple(chi2.ppf([0.025, 0.975], 3 * n * k) / (n * k)), rel=1e-12)


def test_correlated_nees_bounds_cover_95_percent_of_gaussian_draws():
    """Oracle: numpy draws of correlated pose errors xi ~ N(0, P), the per-pose average NEES counted directly."""
    rng = np.random.default_rng(5)
    k, n_runs, trials = 6, 5, 20000
    a = rng.standard_normal((3 * k, 3 * k))
    # strongly correlated covariance: a random-walk-like chain plus a little independent noise
    walk = np.tril(np.ones((k, k)))
    p = np.kron(walk @ walk.T, np.eye(3)) + 0.1 * (a @ a.T) / (3 * k)
    blocks = [np.linalg.inv(p[3 * i : 3 * i + 3, 3 * i : 3 * i + 3]) for i in range(k)]
    A = np.zeros_like(p)
    for i, b in enumerate(blocks):
        A[3 * i : 3 * i + 3, 3 * i : 3 * i + 3] = b
    xi = rng.multivariate_normal(np.zeros(3 * k), p, size=(trials, n_runs))
    avg = np.einsum("tri,ij,trj->t", xi, A, xi) / (n_runs * k)
    ap = A @ p
    lo, hi = nees_bounds(n_runs, k, trace_sq=float(np.trace(ap @ ap)))
    inside = np.mean((avg >= lo) & (avg <= hi))
    assert 0.93 < inside < 0.97
    tlo, thi = nees_bounds(n_runs, k)  # the independent-terms bounds are too narrow here
    assert np.mean((avg >= tlo) & (avg <= thi)) < 0.85


# ------------------------------------------------------------------------------ blind and failed


@pytest.fixture(scope="module")
def blind_problem(library, tiny_problem):
    """The tiny route with its landmarks moved 100 km away: no sensor sees anything."""
    sc = tiny_problem.scenario
    return build_problem(library, Scenario("far", sc.keyframes, sc.landmarks + 1e5, "shifted"))


def test_a_suite_that_sees_nothing_gives_odometry_only_errors(blind_problem):
    res = simulate(blind_problem, "LRL-roof,WSC-12", runs=4)
    m = blind_problem.scenario.n_landmarks
    assert res.n_measurements == 0 and res.measured_landmarks == ()
    assert res.unmeasured_landmarks == tuple(range(m))
    assert res.landmark_rmse_m is None and res.predicted_landmark_rmse_m is None
    for v in (res.position_rmse_m, res.heading_rmse_rad, res.max_position_error_m, res.nees_mean, res.nees_joint_mean):
        assert math.isfinite(v) and v > 0
    # with odometry alone the MAP estimate is dead reckoning itself
    assert res.position_rmse_m == pytest.approx(res.initial_position_rmse_m, rel=1e-9)
    # odometry only: the predicted uncertainty grows along the route
    assert np.all(np.diff(res.predicted_position_sigma_m) > 0)
    assert all(r.landmarks == () for r in res.runs)


def test_whole_route_failure_equals_the_empty_suite(tiny_problem):
    failed = simulate(tiny_problem, "LRL-roof", failures=[Failure("LRL-roof")], runs=3)
    empty = simulate(tiny_problem, (), runs=3)
    lrl = tiny_problem.observations[tiny_problem.library.position("LRL-roof")]
    assert failed.n_measurements == 0 and failed.n_measurements_failed == len(lrl)
    assert failed.failures == (Failure("LRL-roof", 0, tiny_problem.scenario.n_poses),)
    # same seed: the same odometry noise, so the same odometry-only estimate
    assert [r.position_error_m for r in failed.runs] == [r.position_error_m for r in empty.runs]


def test_partial_failure_drops_exactly_its_measurements(tiny_problem):
    lib = tiny_problem.library
    full = simulate(tiny_problem, "LRL-roof,HD2K-12", runs=2)
    part = simulate(tiny_problem, "LRL-roof,HD2K-12", failures=[Failure("LRL-roof", 3, 7)], runs=2)
    lrl = tiny_problem.observations[lib.position("LRL-roof")]
    hd = tiny_problem.observations[lib.position("HD2K-12")]
    lost = (lrl.pose >= 3) & (lrl.pose < 7)
    assert part.n_measurements_failed == int(lost.sum())
    assert part.n_measurements == len(lrl) + len(hd) - int(lost.sum()) == full.n_measurements - int(lost.sum())
    still = set(lrl.landmark[~lost].tolist()) | set(hd.landmark.tolist())
    assert set(part.measured_landmarks) == still
    assert set(part.unmeasured_landmarks) == set(range(tiny_problem.scenario.n_landmarks)) - still
    # losing measurements can only raise the predicted uncertainty
    assert all(p >= f - 1e-12 for p, f in zip(part.predicted_position_sigma_m, full.predicted_position_sigma_m))


def test_parse_failures(tiny_problem):
    kf = tiny_problem.scenario.keyframes
    t = kf.times - kf.times[0]
    got = parse_failures("LRL-roof, WSC-12@2-5, HD2K-6@1s-4s", tiny_problem)
    expect = np.nonzero((t >= 1) & (t < 4))[0]
    assert got == (Failure("LRL-roof"), Failure("WSC-12", 2, 5), Failure("HD2K-6", int(expect[0]), int(expect[-1]) + 1))
    for bad, word in [
        ("NOPE-1", "NOPE-1"),
        ("LRL-roof@5", "LRL-roof@5"),
        ("LRL-roof@4-2", "4..1"),
        ("LRL-roof@0-99", "0..98"),
        ("LRL-roof@1.5-3", "integers"),
        ("LRL-roof@500s-600s", "no keyframe"),
    ]:
        with pytest.raises(InputError, match=word):
            parse_failures(bad, tiny_problem)


def test_bad_arguments_name_the_value(tiny_problem):
    with pytest.raises(InputError, match="'gauss'"):
        simulate(tiny_problem, "LRL-roof", solver="gauss")
    with pytest.raises(InputError, match="runs"):
        simulate(tiny_problem, "LRL-roof", runs=0)
    with pytest.raises(InputError, match="seed"):
        simulate(tiny_problem, "LRL-roof", seed=-1)
    with pytest.raises(InputError, match="noise scale"):
        simulate(tiny_problem, "LRL-roof", noise_scale=0.0)
    with pytest.raises(InputError, match="'WSC-12' is not in the suite"):
        simulate(tiny_problem, "LRL-roof", failures=[Failure("WSC-12")])


# ------------------------------------------------------------------------------------ determinism


def test_same_seed_same_numbers_and_json_round_trip(tiny_problem, tmp_path):
    a = simulate(tiny_problem, "MRL-roof,HD2K-12", runs=3, seed=7, failures=[Failure("MRL-roof", 2, 6)])
    b = simulate(tiny_problem, "MRL-roof,HD2K-12", runs=3, seed=7, failures=[Failure("MRL-roof", 2, 6)])
    c = simulate(tiny_problem, "MRL-roof,HD2K-12", runs=3, seed=8, failures=[Failure("MRL-roof", 2, 6)])
    assert _same(a, b)
    assert a.runs[0].position_error_m != c.runs[0].position_error_m
    path = results.save(SimulationReport((a,)), tmp_path / "sim.json")
    back = results.load(path, SimulationReport)
    assert results.dumps(back) == results.dumps(SimulationReport((a,)))


def test_runs_do_not_depend_on_how_many_there_are(tiny_problem):
    """Run r draws from (seed, r): the first runs of a longer simulation are the same runs."""
    short = simulate(tiny_problem, "LRL-roof", runs=2, seed=3)
    long = simulate(tiny_problem, "LRL-roof", runs=5, seed=3)
    assert short.runs == long.runs[:2]


def test_jobs_do_not_change_results(tiny_problem):
    one = simulate(tiny_problem, "LRL-roof,WSC-6", runs=4, jobs=1, seed=2)
    calls = []
    two = simulate(tiny_problem, "LRL-roof,WSC-6", runs=4, jobs=2, seed=2, progress=lambda d, t: calls.append((d, t)))
    assert _same(one, two)
    assert calls == [(1, 4), (2, 4), (3, 4), (4, 4)]  # progress(done, total), as everywhere
    assert two.timing is not None and two.timing.jobs == 2


# ------------------------------------------------------------------------------------------- plots


def test_plots_draw_each_design_on_one_error_scale(tiny_problem):
    from sensorsel.plotting import plot_error_along_route, plot_simulation, plot_simulation_comparison, typical_run

    a = simulate(tiny_problem, "LRL-roof,HD2K-12", runs=3, failures=[Failure("LRL-roof")], label="greedy")
    b = simulate(tiny_problem, "MRL-roof,HD2K-12", runs=3, failures=[Failure("MRL-roof", 2, 5)], label="resilient")
    sc = tiny_problem.scenario
    axes = plot_simulation_comparison([a, b], sc)
    assert len(axes) == 2
    norms = [[c.norm.vmax for c in ax.collections if c.get_array() is not None] for ax in axes]
    vmax = {v for n in norms for v in n}
    errs = [max(r.runs[typical_run(r)].position_error_m) for r in (a, b)]
    assert len(vmax) == 1 and vmax.pop() >= max(errs)  # one colour scale covering both
    assert "greedy" in axes[0].get_title() and "resilient" in axes[1].get_title()
    for res, ax in zip((a, b), axes):  # each panel shows its design's median run
        assert f"run {typical_run(res)} (median of 3)" in ax.get_title()
    same = plot_simulation_comparison([a, b], sc, runs=[0, 0])  # or the same draw for both
    assert all("run 0 (" in ax.get_title() for ax in same)
    ax = plot_simulation(a, sc, run=1)
    pos_coll = [c for c in ax.collections if c.get_label() == "estimated keyframes"][0]
    np.testing.assert_allclose(pos_coll.get_array(), a.runs[1].position_error_m)
    ax = plot_error_along_route([a, b], sc)
    assert len(ax.lines) == 2 * (3 + 2)  # every run, the RMS and the prediction, per design
    with pytest.raises(InputError, match="run 9"):
        plot_simulation(a, sc, run=9)


# --------------------------------------------------------------------------------------------- CLI


def _suite_file(problem, path, suite, failed=()):
    """A result file naming ``suite``: a score result, or with ``failed`` a resilient selection
    (computed on the problem, then given this suite and these assumed failures)."""
    from sensorsel.api import score_suite
    from sensorsel.designs.resilient import resilient_select
    from sensorsel.information.evaluators import make_evaluator

    if not failed:
        return results.save(score_suite(problem, suite, engine="reference"), path)
    r = resilient_select(make_evaluator(problem, None), 5000.0, 1, "uniform", info=problem.info)
    return results.save(dataclasses.replace(r, suite=tuple(suite.split(",")), failed=tuple(failed)), path)


def test_cli_reads_result_files_and_writes_everything(tmp_path, tiny_problem):
    greedy = _suite_file(tiny_problem, tmp_path / "greedy.json", "LRL-roof,HD2K-12")
    resilient = _suite_file(tiny_problem, tmp_path / "resilient.json", "LRL-roof,MRL-roof", ["LRL-roof"])
    out = tmp_path / "out"
    r = CliRunner().invoke(
        cli,
        [
            "simulate",
            "--fixture",
            "tiny",
            "--suite",
            str(greedy),
            "--compare",
            str(resilient),
            "--fail",
            "LRL-roof",
            "--runs",
            "2",
            "--jobs",
            "1",
            "--output-dir",
            str(out),
        ],
    )
    assert r.exit_code == 0, r.output
    assert "greedy" in r.output and "resilient" in r.output and "pos_rmse_m" in r.output
    assert "resilient assumes LRL-roof" not in r.output  # the failure it assumes is simulated: no hint
    for name in ("simulation.json", "trajectories.png", "error_along_route.png", "simulate.png"):
        assert (out / name).stat().st_size > 0
    rep = results.load(out / "simulation.json", SimulationReport)
    assert [s.label for s in rep.simulations] == ["greedy", "resilient"]
    assert all(s.failures[0].sensor == "LRL-roof" and len(s.runs) == 2 for s in rep.simulations)


def test_cli_labels_and_hint_for_an_assumed_failure(tmp_path, tiny_problem):
    resilient = _suite_file(tiny_problem, tmp_path / "resilient.json", "LRL-roof,MRL-roof", ["LRL-roof"])
    r = CliRunner().invoke(
        cli,
        [
            "simulate",
            "--fixture",
            "tiny",
            "--suite",
            "LRL-roof,WSC-12",
            "--label",
            "Greedy03",
            "--compare",
            str(resilient),
            "--runs",
            "1",
            "--jobs",
            "1",
            "--output-dir",
            str(tmp_path / "o"),
        ],
    )
    assert r.exit_code == 0, r.output
    assert "add --fail LRL-roof" in r.output
    rep = results.load(tmp_path / "o" / "simulation.json", SimulationReport)
    assert [s.label for s in rep.simulations] == ["Greedy03", "resilient"]
    assert all(s.failures == () for s in rep.simulations)


def test_cli_start_sigmas_set_the_first_pose_prior(tmp_path, tiny_problem):
    from sensorsel.model.problem import GraphSettings

    r = CliRunner().invoke(
        cli,
        [
            "simulate",
            "--fixture",
            "tiny",
            "--suite",
            "LRL-roof",
            "--start-sigmas",
            "1e-4,1e-4,1e-5",
            "--runs",
            "2",
            "--jobs",
            "1",
            "--output-dir",
            str(tmp_path),
        ],
    )
    assert r.exit_code == 0, r.output
    (sim,) = results.load(tmp_path / "simulation.json", SimulationReport).simulations
    assert sim.problem.settings.first_pose_sigmas == (1e-4, 1e-4, 1e-5)
    tight = simulate(
        build_problem(tiny_problem.library, tiny_problem.scenario, GraphSettings(first_pose_sigmas=(1e-4, 1e-4, 1e-5))),
        "LRL-roof",
        runs=2,
    )
    assert codec.dumps(without_timing(sim).runs) == codec.dumps(tight.runs)
    assert sim.predicted_position_rmse_m < simulate(tiny_problem, "LRL-roof", runs=1).predicted_position_rmse_m


@pytest.mark.parametrize(
    "args, word",
    [
        (["--suite", "LRL-roof,NOPE-3"], "NOPE-3"),
        (["--suite", "{tmp}/missing.json"], "missing.json"),
        (["--suite", "{tmp}/bad.json"], 'no "kind"'),
        (["--suite", "{tmp}/simulation.json"], "is a 'simulation' result, expected a 'greedy'"),
        (["--suite", "LRL-roof", "--fail", "WSC-12"], "WSC-12"),
        (["--suite", "LRL-roof", "--fail", "LRL-roof@x"], "LRL-roof@x"),
        (["--suite", "LRL-roof", "--runs", "0"], "--runs"),
        (["--suite", "LRL-roof", "--solver", "gauss"], "gauss"),
        (["--suite", "LRL-roof", "--compare-label", "x"], "--compare"),
        (["--suite", "LRL-roof", "--start-sigmas", "1,2"], "--start-sigmas"),
        (["--suite", "LRL-roof", "--start-sigmas", "1,0,1"], "'1,0,1'"),
    ],
)
def test_cli_bad_input_is_one_line_and_exit_2(tmp_path, args, word):
    (tmp_path / "bad.json").write_text(json.dumps({"picks": ["LRL-roof"]}))
    results.save(SimulationReport(()), tmp_path / "simulation.json")
    args = [a.replace("{tmp}", str(tmp_path)) for a in args]
    r = CliRunner().invoke(
        cli, ["simulate", "--fixture", "tiny", "--runs", "1", "--jobs", "1", "--output-dir", str(tmp_path / "o")] + args
    )
    assert r.exit_code == 2
    assert word in r.output
    assert "Traceback" not in r.output
