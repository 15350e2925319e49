"""Operating conditions: the range models against numbers worked by hand, clear = none
bit for bit, scores monotone in severity, conditions in a domain, bad input."""

from __future__ import annotations

import math
import re
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from click.testing import CliRunner

from sensorsel.cli import cli
from sensorsel.designs.selection import greedy
from sensorsel.errors import InputError, ResultFileError
from sensorsel.information.evaluators import DomainEvaluator, make_evaluator
from sensorsel.io import results
from sensorsel.model.conditions import (
    Condition,
    ConditionPhysics,
    SensorEffect,
    fog_extinction_per_m,
    koschmieder_range_m,
    parse_condition,
    power_law_db_per_km,
    radar_extinction_per_m,
    range_under_extinction,
    sensor_effect,
)
from sensorsel.model.domain import DomainError, load_domain_file
from sensorsel.model.library import load_library
from sensorsel.model.problem import Domain, DomainRoute, check_result_problem, load_domain, load_problem, with_condition
from sensorsel.model.scenario import ScenarioSpec
from sensorsel.model.sensing import condition_effects, observe

REPO = Path(__file__).resolve().parents[1]
P = ConditionPhysics()


# ------------------------------------------------------------------------- the models, by hand


@pytest.mark.parametrize("mor, expected", [(1000, 134), (300, 85), (150, 60), (50, 31)])
def test_lidar_range_in_fog_is_lambert_w_of_hahner(mor, expected):
    # by hand: alpha = ln(20)/MOR; 200 m LiDAR solves R e^(alpha R) = 200. MOR 1000: alpha = 0.0029957,
    # alpha R0 = 0.599, W(0.599) = 0.4012 (0.4012 e^0.4012 = 0.599), R = 133.9 m; MOR 300: W(1.997) =
    # 0.8520, R = 85.3 m; MOR 150: W(3.994) = 1.2014, R = 60.2 m; MOR 50: W(11.98) = 1.8616, R = 31.1 m
    alpha = fog_extinction_per_m(mor)
    assert alpha == pytest.approx(math.log(20) / mor) and alpha == pytest.approx(3.0 / mor, rel=2e-3)
    r = range_under_extinction(200.0, alpha, 2)
    assert round(r) == expected
    assert r * math.exp(alpha * r) == pytest.approx(200.0, rel=1e-12)  # the defining equation, independently


@pytest.mark.parametrize("rain, expected", [(10, 177), (50, 146)])
def test_radar_range_in_rain_is_itu_p838_with_two_way_loss(rain, expected):
    # by hand: gamma = 1.13 R^0.72 dB/km: 5.93 at 10 mm/h, 18.89 at 50; two-way power 10^(-2 gamma r/1e4) / r^4
    # equals 1/200^4 at r = 177.2 m (10 mm/h: 10^(-2*5.93*177.2/1e4) = 0.6247 = (177.2/200)^4) and 145.7 m
    gamma = power_law_db_per_km(rain, 1.13, 0.72)
    assert gamma == pytest.approx({10: 5.93, 50: 18.89}[rain], abs=0.01)
    r = sensor_effect("radar", 200.0, Condition(rain_mm_h=rain), P).range_m
    assert round(r) == expected
    assert 10 ** (-2 * gamma * r / 1e4) / r**4 == pytest.approx(1 / 200.0**4, rel=1e-9)


def test_radar_in_fog_is_negligible_and_lidar_is_not():
    # ITU-R P.840: 3 (dB/km)/(g/m^3) x 0.5 g/m^3 at 50 m visibility = 1.5 dB/km: a 250 m radar keeps 240 m
    dense = Condition(fog_visibility_m=50)
    assert radar_extinction_per_m(dense, P) == pytest.approx(1.5 * math.log(10) / 1e4)
    radar = sensor_effect("radar", 250.0, dense, P).range_m
    lidar = sensor_effect("lidar", 120.0, dense, P).range_m
    assert 0.95 * 250 < radar < 250
    assert lidar < 0.3 * 120


def test_camera_range_by_koschmieder_and_headlights():
    # C0 = 1 against eps = 0.05: d = ln(20)/alpha = the MOR itself; C0 = 0.5: ln(10)/ln(20) of it
    alpha = fog_extinction_per_m(30.0)
    assert koschmieder_range_m(alpha, 1.0, 0.05) == pytest.approx(30.0)
    assert koschmieder_range_m(alpha, 0.5, 0.05) == pytest.approx(30.0 * math.log(10) / math.log(20))
    assert sensor_effect("stereo", 50.0, Condition(fog_visibility_m=30), P).range_m == pytest.approx(30.0)
    night = sensor_effect("stereo", 50.0, Condition(night=True), P)
    assert night.range_m == P.night_camera_range_m and night.bearing_factor == P.night_camera_noise_factor
    assert night.range_factor == P.night_camera_noise_factor  # the disparity noise too, not only the bearing's
    for kind, reach in (("lidar", 120.0), ("radar", 250.0)):
        assert sensor_effect(kind, reach, Condition(night=True), P) == SensorEffect(reach, 1.0, 1.0)
    assert sensor_effect("lidar", 120.0, Condition(night=True), P).range_m == 120.0
    assert sensor_effect("radar", 250.0, Condition(night=True), P).range_m == 250.0


def test_the_library_file_cites_the_numbers_it_uses():
    lib = load_library()
    assert lib.physics == ConditionPhysics()  # the shipped file's numbers are the defaults
    text = (REPO / "configs" / "sensor_library.yaml").read_text()
    for cite in ("Hahner", "P.838-3", "P.840", "P.1814", "Koschmieder", "assumed"):
        assert cite in text


# ------------------------------------------------------------------------ clear = none, monotone


def test_neutral_condition_is_bit_identical_to_none(suburb_problem):
    spec = ScenarioSpec()
    plain = load_problem(spec)
    for neutral in (Condition(), parse_condition("clear"), Condition(rain_mm_h=0.0, snow_mm_h=0.0, name="dry")):
        other = load_problem(replace(spec, condition=neutral))
        assert other.condition is None and other.fingerprint == plain.fingerprint
        a, b = greedy(make_evaluator(plain), 110_000), greedy(make_evaluator(other), 110_000)
        assert results.dumps(replace(a, seconds=0)) == results.dumps(replace(b, seconds=0))
    assert with_condition(suburb_problem, Condition()) is suburb_problem


def test_derived_measurements_equal_observing_with_the_shrunk_ranges(suburb_problem):
    # the oracle: observe again with each model's range set to its range under the condition
    cond = Condition(night=True, rain_mm_h=20, fog_visibility_m=120)
    lib = suburb_problem.library
    derived = with_condition(suburb_problem, cond)
    effects = condition_effects(lib, cond)
    for s, e, o in zip(lib, effects, derived.observations):
        shrunk = replace(lib, sensors=(replace(s, model=replace(s.model, range_m=e.range_m)),))
        fresh = observe(shrunk, suburb_problem.scenario)[0]
        assert np.array_equal(o.pose, fresh.pose) and np.array_equal(o.landmark, fresh.landmark)
        assert np.allclose(o.sigma_bearing_rad, fresh.sigma_bearing_rad * e.bearing_factor, rtol=0, atol=0)
    assert sum(map(len, derived.observations)) < sum(map(len, suburb_problem.observations))


@pytest.mark.parametrize(
    "key, levels",
    [("rain_mm_h", [0, 2, 10, 50]), ("fog_visibility_m", [None, 2000, 300, 100, 40]), ("snow_mm_h", [0, 1, 5])],
)
def test_scores_are_monotone_in_severity(suburb_problem, key, levels):
    rng = np.random.default_rng(7)
    suites = [tuple(sorted(rng.choice(suburb_problem.n_sensors, size=k, replace=False))) for k in (1, 3, 6, 12)]
    suites.append(tuple(range(suburb_problem.n_sensors)))
    for night in (False, True):
        scores = []
        for v in levels:
            cond = Condition(night=night, **({key: v} if v is not None else {}))
            ev = make_evaluator(with_condition(suburb_problem, cond))
            scores.append([ev.score(s) for s in suites])
        s = np.array(scores)
        assert np.all(np.diff(s, axis=0) <= 1e-9 * np.abs(s[:-1]) + 1e-9), s
        assert s[-1, -1] < s[0, -1]  # the most severe level costs the whole library something


def test_night_costs_cameras_only(suburb_problem):
    night = make_evaluator(with_condition(suburb_problem, Condition(night=True)))
    clear = make_evaluator(suburb_problem)
    lidar_radar = suburb_problem.resolve_suite("LRL-roof,MRL-roof,LRR-12,MRR-3")
    cameras = suburb_problem.resolve_suite("HD2K-12,WSC-3")
    assert night.score(lidar_radar) == clear.score(lidar_radar)
    assert night.score(cameras) < clear.score(cameras)


def test_a_condition_is_not_applied_twice(suburb_problem):
    once = with_condition(suburb_problem, Condition(night=True))
    with pytest.raises(InputError, match="already under the condition"):
        with_condition(once, Condition(rain_mm_h=5))


def test_a_result_of_one_condition_is_refused_on_another(tmp_path):
    spec = ScenarioSpec(fixture="tiny")
    clear, foggy = load_problem(spec), load_problem(replace(spec, condition=Condition(fog_visibility_m=100)))
    check_result_problem(foggy.info, foggy, "r.json")
    with pytest.raises(ResultFileError, match="another operating condition"):
        check_result_problem(foggy.info, clear, "r.json")
    with pytest.raises(ResultFileError, match="another operating condition"):
        check_result_problem(clear.info, foggy, "r.json")


# ------------------------------------------------------------------------------ in a domain


def _domain_file(tmp_path: Path, conditions: str, route_extra: str = "", name: str = "d.yaml") -> Path:
    p = tmp_path / name
    p.write_text(
        f"{conditions}\nroutes:\n  - name: suburb\n    fixture: suburb\n    weight: {{hours: 2}}\n{route_extra}"
        "  - name: tiny\n    fixture: tiny\n    weight: {hours: 1}\n"
    )
    return p


CITY = (
    "conditions:\n  - {name: night, night: true, share: 0.25}\n  - {name: rain, rain_mm_h: 5, share: 0.08}\n"
    "  - {name: fog, fog_visibility_m: 150, share: 0.005}"
)


def test_members_are_route_condition_pairs_weighted_by_share(tmp_path):
    path = _domain_file(tmp_path, CITY, "    conditions: {night: 0.5, fog: 0}\n")
    d = load_domain(path)
    got = {r.name: r.weight for r in d.routes}
    assert got == pytest.approx(
        {
            "suburb/clear": 2 * (1 - 0.58),
            "suburb/night": 1.0,
            "suburb/rain": 0.16,
            "tiny/clear": 0.665,
            "tiny/night": 0.25,
            "tiny/rain": 0.08,
            "tiny/fog": 0.005,
        }
    )
    assert d.condition_names == ("clear", "night", "rain", "fog")
    r = d.route("suburb/night")
    assert (r.route, r.condition, r.problem.condition.night) == ("suburb", "night", True)
    assert d.route("tiny/clear").problem.condition is None
    sub = d.in_conditions("clear,rain")
    assert [m.name for m in sub.routes] == ["suburb/clear", "suburb/rain", "tiny/clear", "tiny/rain"]
    with pytest.raises(InputError, match="unknown condition 'snow'"):
        d.in_conditions("clear,snow")
    # the members share the route's clear measurements: the clear member is the route's problem itself
    clear_obs, rain_obs = d.route("suburb/clear").problem.observations, d.route("suburb/rain").problem.observations
    for i in d.library.resolve_suite("HD2K-12,WSC-3"):  # 5 mm/h leaves the cameras' 20-50 m alone
        assert rain_obs[i] is clear_obs[i]


def test_one_route_in_one_condition_equals_the_plain_route(tmp_path):
    p = tmp_path / "one.yaml"
    p.write_text(
        "conditions:\n  - {name: storm, rain_mm_h: 30, night: true, share: 1}\n"
        "routes:\n  - {name: suburb, fixture: suburb, weight: 1}\n"
    )
    d = load_domain(p)
    assert [m.name for m in d.routes] == ["suburb/storm"]
    plain = load_problem(ScenarioSpec(condition=parse_condition("night,rain_mm_h=30")))
    a = greedy(DomainEvaluator(d), 20_000)
    b = greedy(make_evaluator(plain), 20_000)
    assert a.suite == b.suite
    ev = DomainEvaluator(d)
    assert ev.route_scores(d.resolve_suite(a.suite))[0] == make_evaluator(plain).score(plain.resolve_suite(b.suite))


def test_worst_member_names_route_and_condition(tmp_path):
    path = _domain_file(tmp_path, "conditions:\n  - {name: fog, fog_visibility_m: 40, share: 0.2}")
    r = _cli("robust", "--domain", path, "--budget", "3000", "--failures", "1", "--aggregate", "worst", "-q")
    assert r.returncode == 0, r.stderr
    worst = [line for line in r.stdout.splitlines() if "worst" in line.lower() and "/" in line]
    assert worst and any("/fog" in line or "/clear" in line for line in worst), r.stdout


# ------------------------------------------------------------------------------- bad input


def _cli(*args: object) -> SimpleNamespace:
    """The command in this process (returncode, stdout, stderr: as a subprocess gives them)."""
    r = CliRunner().invoke(cli, [str(a) for a in args])
    assert r.exception is None or isinstance(r.exception, SystemExit), r.exception
    return SimpleNamespace(returncode=r.exit_code, stdout=r.stdout, stderr=r.stderr)


@pytest.mark.parametrize(
    "text, names",
    [
        ("rain_mm_h=-1", "rain_mm_h"),
        ("fog_visibility_m=0", "fog_visibility_m"),
        ("hail", "'hail'"),
        ("rain_mm_h=lots", "rain_mm_h"),
        ("night=1", "night"),
        ("rain_mm_h=2,rain_mm_h=3", "rain_mm_h"),
        ("snow_mm_h=nan", "snow_mm_h"),
        ("clear,night", "clear"),
    ],
)
def test_bad_condition_option_is_one_line_exit_2(text, names):
    r = _cli("score", "--fixture", "tiny", "--suite", "LRL-roof", "--condition", text)
    assert r.returncode == 2 and r.stdout == ""
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("sensorsel: error: --condition") and names in lines[0], r.stderr


@pytest.mark.parametrize(
    "conditions, key",
    [
        ("conditions:\n  - {name: rain, rain_mm_h: -2, share: 0.1}", "conditions[0].rain_mm_h"),
        ("conditions:\n  - {name: fog, fog_visibility_m: 0, share: 0.1}", "conditions[0].fog_visibility_m"),
        ("conditions:\n  - {name: fog, visibility: 100, share: 0.1}", "conditions[0].visibility"),
        ("conditions:\n  - {name: rain, rain_mm_h: heavy, share: 0.1}", "conditions[0].rain_mm_h"),
        (
            "conditions:\n  - {name: night, night: true, share: 0.7}\n  - {name: rain, rain_mm_h: 4, share: 0.4}",
            "conditions",
        ),
        ("conditions:\n  - {name: night, night: true, share: 1.5}", "conditions[0].share"),
        ("conditions:\n  - {name: clear, share: 0.5}", "conditions[0].name"),
        ("conditions:\n  - {name: rain, rain_mm_h: 4}", "conditions[0].share"),
        ("conditions:\n  - {name: night, night: yes please, share: 0.2}", "conditions[0].night"),
    ],
)
def test_bad_domain_conditions_name_the_key_and_line(tmp_path, conditions, key):
    path = _domain_file(tmp_path, conditions)
    with pytest.raises(DomainError) as e:
        load_domain_file(path)
    assert e.value.key == key and e.value.line is not None
    r = _cli("score", "--domain", path, "--suite", "LRL-roof")
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1 and key in r.stderr, r.stderr


@pytest.mark.parametrize(
    "extra, key",
    [
        ("    conditions: {snow: 0.1}\n", "routes[0].conditions.snow"),
        ("    conditions: {night: 0.9, rain: 0.2}\n", "routes[0].conditions"),
        ("    conditions: {night: many}\n", "routes[0].conditions.night"),
    ],
)
def test_bad_route_shares_name_the_key(tmp_path, extra, key):
    path = _domain_file(tmp_path, CITY, extra)
    with pytest.raises(DomainError) as e:
        load_domain_file(path)
    assert e.value.key == key


def test_condition_with_domain_is_a_usage_error(tmp_path):
    r = _cli("score", "--domain", _domain_file(tmp_path, CITY), "--suite", "LRL-roof", "--condition", "night")
    assert r.returncode == 2 and "--condition" in r.stderr


def test_bad_physics_in_the_library_names_the_key(tmp_path):
    lib = tmp_path / "lib.yaml"
    lib.write_text(f"extends: {REPO / 'configs' / 'sensor_library.yaml'}\nconditions:\n  night_camera_range_m: -3\n")
    r = _cli("score", "--fixture", "tiny", "--suite", "LRL-roof", "--library", lib, "--condition", "night")
    assert r.returncode == 2 and "conditions.night_camera_range_m" in r.stderr, r.stderr


def test_condition_members_on_dask_workers_equal_in_process(tmp_path):
    # the workers rebuild each member from its recipe (the spec carries the condition): same bytes
    pytest.importorskip("distributed")
    from sensorsel.api import design_domain
    from sensorsel.information.evaluators.distributed import DistributedDomainEvaluator
    from sensorsel.pipeline.cluster import DaskCluster

    p = tmp_path / "d.yaml"
    p.write_text(CITY + "\nroutes:\n  - {name: tiny, fixture: tiny, weight: 1}\n")
    d = load_domain(p)
    local = design_domain(d, 8_000)
    with DaskCluster(workers=2, echo=lambda line: None) as cluster:
        ev = DistributedDomainEvaluator(cluster.client, d)
        remote = design_domain(d, 8_000, evaluator=ev)
        assert np.array_equal(ev.best, DomainEvaluator(d).best)
    untimed = lambda r: re.sub(r'"seconds": [0-9.e-]+', "", results.dumps(r))  # noqa: E731
    assert untimed(remote) == untimed(local)


def test_a_problem_put_under_a_condition_in_python_keeps_it_on_dask_workers(tiny_problem):
    # no spec carries the condition here (built from objects): the recipe must, or the workers
    # rebuild and score the clear problem (a silently wrong answer: the night member scored clear)
    pytest.importorskip("distributed")
    from sensorsel.api import design_domain
    from sensorsel.designs.tradespace import run_tradespace
    from sensorsel.information.evaluators.distributed import DistributedDomainEvaluator
    from sensorsel.model.recipes import TargetRecipe
    from sensorsel.pipeline.cluster import DaskCluster

    night = with_condition(tiny_problem, Condition(night=True, fog_visibility_m=150))
    assert night.spec is None and tiny_problem.spec is None
    d = Domain(
        (
            DomainRoute("tiny/clear", tiny_problem, 3.0, "km", "tiny", "clear"),
            DomainRoute("tiny/night", night, 1.0, "km", "tiny", "night"),
        ),
        "python",
    )
    rebuilt = TargetRecipe.of(d).build()
    assert isinstance(rebuilt, Domain) and [(r.route, r.condition) for r in rebuilt.routes] == [
        ("tiny", "clear"),
        ("tiny", "night"),
    ]
    best = DomainEvaluator(d).best
    assert best[1] < best[0]  # the condition costs the whole library information: clear and night differ
    untimed = lambda r: re.sub(r'"seconds": [0-9.e-]+', "", results.dumps(r))  # noqa: E731
    with DaskCluster(workers=2, echo=lambda line: None) as cluster:
        ev = DistributedDomainEvaluator(cluster.client, d)
        assert np.array_equal(ev.best, best)
        remote = design_domain(d, 8_000, evaluator=ev)
        spread = run_tradespace(
            night, [4_000, 8_000], ["uniform"], executor=cluster.executor
        )  # TargetRecipe of a Problem
    assert untimed(remote) == untimed(design_domain(d, 8_000))
    assert untimed(spread) == untimed(run_tradespace(night, [4_000, 8_000], ["uniform"]))


def test_breakdown_by_condition_and_its_grid_plot(tmp_path):
    from sensorsel.api import by_condition, design_domain
    from sensorsel.plotting import plot_domain_breakdown

    d = load_domain(_domain_file(tmp_path, CITY))
    design = design_domain(d, 8_000)
    got = {c.name: c for c in by_condition(design)}
    assert list(got) == ["clear", "night", "rain", "fog"]
    assert sum(c.weight for c in got.values()) == pytest.approx(1.0)
    members = [(r, m) for r, m in zip(design.routes, d.routes) if m.condition == "night"]  # independently, by hand
    w = sum(r.weight for r, _ in members)
    assert got["night"].share_of_best == pytest.approx(sum(r.weight * r.share_of_best for r, _ in members) / w)
    assert got["night"].worst_member in {m.name for _, m in members}
    ax = plot_domain_breakdown(design)
    assert [t.get_text() for t in ax.get_yticklabels()] == ["suburb", "tiny"]
    assert len(ax.get_xticklabels()) == 4
    import matplotlib.pyplot as plt

    plt.close(ax.figure)


def test_night_inflates_the_stereo_cameras_range_noise_as_their_disparity_noise(tiny_problem):
    """At night a stereo camera's disparity noise σ_d, not only its pixel noise, grows by the night
    factor: its range noise is factor · z² σ_d / (f b) (the paper's eq. 5, computed here from the
    library's numbers) at every measurement it still makes, and its bearing noise factor · σ_px / f."""
    lib, phys = tiny_problem.library, tiny_problem.library.physics
    night = with_condition(tiny_problem, Condition(night=True))
    k = phys.night_camera_noise_factor
    assert k > 1
    checked = 0
    for s, o in zip(lib, night.observations):
        m = s.model
        if m.type != "stereo" or not len(o):
            continue
        assert np.max(o.range_m) <= phys.night_camera_range_m
        np.testing.assert_allclose(
            o.sigma_range_m, k * o.range_m**2 * m.sigma_disparity_px / (m.focal_px * m.baseline_m), rtol=1e-12
        )
        np.testing.assert_allclose(o.sigma_bearing_rad, k * m.sigma_pixel_px / m.focal_px, rtol=1e-12)
        checked += len(o)
    assert checked > 100
