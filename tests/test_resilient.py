"""Resilient selection (the paper's Algorithm 2 for alpha failures), worst-case evaluation, the
per-period selection, its grid, resume, and the ``sensorsel resilient`` command.

Oracles: plain greedy (alpha = 0), a brute-force loop over survivor sets scored with GTSAM directly,
singleton scores recomputed one by one, keyframe membership checked against the timestamps, and
the same period scored with all the route's landmarks (unseen landmarks add exactly 0).
"""

from __future__ import annotations

import json
import math
import warnings

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from sensorsel.cli import cli
from sensorsel.designs.options import RunOptions
from sensorsel.designs.resilient import (
    ACTIVE,
    FAILED,
    CacheWarning,
    PerPeriodResult,
    ResilientReport,
    SelectionGrid,
    check_period,
    compare,
    period_file,
    period_scenario,
    resilient_report,
    resilient_select,
    run_periods,
    split_periods,
    worst_case,
)
from sensorsel.designs.selection import greedy
from sensorsel.errors import InputError
from sensorsel.information.evaluators import make_evaluator
from sensorsel.information.graph import GraphBuilder
from sensorsel.io import results
from sensorsel.io.resources import default_library_path
from sensorsel.model.problem import build_problem
from sensorsel.model.scenario import Scenario, ScenarioSpec, Trajectory, load_scenario
from sensorsel.model.sensing import observe

REL = 1e-9
# A small library: both LiDARs, radars and cameras facing front, back and sides.
SMALL = (
    "LRL-roof",
    "MRL-roof",
    "LRR-12",
    "LRR-6",
    "MRR-3",
    "WSC-12",
    "WSC-6",
    "HD2K-12",
    "HD2K-3",
    "HD2K-6",
    "HD2K-9",
    "LSC-9",
)


@pytest.fixture(scope="module")
def small_lib(library):
    return library.subset([library.position(s) for s in SMALL])


@pytest.fixture(scope="module")
def tiny(small_lib):
    return build_problem(small_lib, load_scenario(ScenarioSpec(fixture="tiny")))


def strip_timings(obj):
    """A JSON value without its wall-time fields (the only fields allowed to differ between runs)."""
    if isinstance(obj, dict):
        return {k: strip_timings(v) for k, v in obj.items() if k != "seconds"}
    if isinstance(obj, list):
        return [strip_timings(v) for v in obj]
    return obj


def close(a: float, b: float) -> bool:
    return abs(a - b) <= REL * max(1.0, abs(a), abs(b))


# ---------------------------------------------------------------------------------- selection


@pytest.mark.parametrize("budget", [110_000.0, 9_000.0, 300.0])
def test_alpha_zero_is_plain_greedy(tiny, budget):
    r = resilient_select(make_evaluator(tiny, "reference"), budget, 0)
    g = greedy(make_evaluator(tiny, "reference"), budget)
    assert r.failed == () and r.failed_cost_usd == 0.0
    assert r.suite == g.suite == r.active
    assert r.score == g.score and r.cost_usd == g.cost_usd


def test_failing_set_is_the_largest_affordable_singletons(tiny, small_lib):
    ev = make_evaluator(tiny, "reference")
    single = {s: ev.score([small_lib.position(s)]) for s in small_lib.ids}  # one by one, not batched
    by_score = sorted(single, key=lambda s: -single[s])
    for alpha in (1, 2, 3):
        r = resilient_select(make_evaluator(tiny, "reference"), 110_000, alpha)
        assert r.failed == tuple(by_score[:alpha])
        assert all(close(v, single[s]) for s, v in zip(r.failed, r.failed_scores))
    # $50,000 cannot buy the long-range LiDAR: the best sensor that fits is designated instead
    r = resilient_select(make_evaluator(tiny, "reference"), 50_000, 1)
    affordable = [s for s in by_score if small_lib[small_lib.position(s)].cost_usd <= 50_000]
    assert "LRL-roof" not in r.failed and r.failed == (affordable[0],)


def test_resilient_suite_is_failing_set_plus_greedy_on_the_rest(tiny, small_lib):
    budget, alpha = 110_000.0, 2
    r = resilient_select(make_evaluator(tiny, "reference"), budget, alpha)
    failed = [small_lib.position(s) for s in r.failed]
    g = greedy(make_evaluator(tiny, "reference"), budget - small_lib.cost(failed), exclude=frozenset(failed))
    assert r.active == g.suite and r.suite == r.failed + r.active
    assert not set(r.failed) & set(r.active)
    assert r.cost_usd == small_lib.cost(failed) + g.cost_usd <= budget
    ev = make_evaluator(tiny, "reference")
    assert close(r.score, ev.score([small_lib.position(s) for s in r.suite]))
    assert close(r.active_score, ev.score([small_lib.position(s) for s in r.active]))


def test_fewer_failures_when_few_sensors_are_informative(small_lib):
    # a scenario whose only landmark is straight ahead, 200 m away: only the front radar sees it
    poses = np.column_stack([np.arange(3.0), np.zeros(3), np.zeros(3)])
    sc = Scenario("one", Trajectory(poses, np.arange(3.0), np.arange(3)), np.array([[200.0, 0.0]]))
    r = resilient_select(make_evaluator(build_problem(small_lib, sc), "reference"), 110_000, 2)
    assert r.failed == ("LRR-12",) and "only 1" in r.failure_note and r.active == ()


def test_bad_alpha_is_refused(tiny):
    ev = make_evaluator(tiny, "reference")
    for bad in (-1, 1.5, True, "1"):
        with pytest.raises(InputError, match="failures"):
            resilient_select(ev, 110_000, bad)
        with pytest.raises(InputError, match="failures"):
            worst_case(ev, [0, 1], bad)


# ---------------------------------------------------------------------------------- worst case


def brute_force_worst(problem, suite: list[int], alpha: int) -> float:
    """min f(T) over survivor sets T of size |S| - alpha, by a bitmask loop and GTSAM directly."""
    b = GraphBuilder(problem)
    base = b.logdet(())
    n, keep = len(suite), max(0, len(suite) - alpha)
    best = math.inf
    for mask in range(1 << n):
        if bin(mask).count("1") != keep:
            continue
        survivors = [suite[i] for i in range(n) if mask >> i & 1]
        best = min(best, b.logdet(survivors) - base)
    return best


@pytest.mark.parametrize("alpha", [0, 1, 2, 3, 5, 7])
def test_worst_case_equals_brute_force(tiny, small_lib, alpha):
    suite = [small_lib.position(s) for s in ("LRL-roof", "MRL-roof", "LRR-6", "WSC-12", "HD2K-3")]
    w = worst_case(make_evaluator(tiny, "reference"), suite, alpha)
    assert close(w.score, brute_force_worst(tiny, suite, alpha))
    k = min(alpha, len(suite))
    assert len(w.failures) == k and w.n_failure_sets == math.comb(len(suite), k)
    assert set(w.failures) | set(w.survivors) == set(w.suite) and not set(w.failures) & set(w.survivors)
    # the failure set it names attains the worst case
    ev = make_evaluator(tiny, "reference")
    assert close(w.score, ev.score([small_lib.position(s) for s in w.survivors]))
    assert close(w.nominal_score, ev.score(suite)) and w.score <= w.nominal_score + 1e-9


def test_worst_case_accepts_ids_and_refuses_huge_enumerations(tiny):
    ev = make_evaluator(tiny, "reference")
    assert worst_case(ev, "LRL-roof,HD2K-3", 1).suite == ("LRL-roof", "HD2K-3")
    with pytest.raises(InputError, match="evaluations"):
        worst_case(ev, list(range(12)), 6, max_failure_sets=100)


def constructed_problem(library):
    """One sensor carries most of the information: a straight 45 m drive between 20 roadside
    landmarks 8 m to either side, which both LiDARs see, and 4 far landmarks 220-250 m straight
    ahead, which only the front long-range radar sees (beyond both LiDARs' range)."""
    lib = library.subset([library.position(s) for s in ("LRL-roof", "MRL-roof", "LRR-12", "LRR-6")])
    poses = np.column_stack([np.arange(10) * 5.0, np.zeros(10), np.zeros(10)])
    near = [(x, s * 8.0) for x in np.arange(0, 50, 5.0) for s in (1, -1)]
    far = [(220.0 + 10 * i, 0.5 * (-1) ** i) for i in range(4)]
    sc = Scenario("constructed", Trajectory(poses, np.arange(10.0), np.arange(10)), np.array(near + far))
    return build_problem(lib, sc)


def test_resilient_worst_case_beats_greedy_when_one_sensor_dominates(library):
    p = constructed_problem(library)
    ev = make_evaluator(p, "reference")
    f_lrl, f_all = ev.score([0]), ev.score(range(4))
    assert f_lrl > 0.75 * f_all  # the construction: the long-range LiDAR carries most of the information
    # $104,000 buys the long-range LiDAR plus either the mid-range LiDAR or a radar (not both)
    c = compare(p, 104_000, 1, options=RunOptions(engine="reference"))
    assert c.greedy.suite[0] == "LRL-roof" and "MRL-roof" not in c.greedy.suite  # given LRL, the radar adds more
    assert c.resilient.failed == ("LRL-roof",) and "MRL-roof" in c.resilient.active
    assert c.greedy_worst.failures == ("LRL-roof",) == c.resilient_worst.failures
    assert c.resilient_worst.score > c.greedy_worst.score + 100.0
    assert c.greedy.score >= c.resilient.score - 1e-9  # nominally greedy is at least as good


# ---------------------------------------------------------------------------------- periods


@pytest.mark.parametrize(
    "times, period",
    [
        (np.arange(10.0), 3.0),
        (np.arange(53.0), 7.0),
        (np.array([0.0, 10.0, 20.0, 30.0]), 10.0),  # each on a period boundary
        (np.array([0.04, 1.1, 2.07, 2.99, 3.0, 15.2, 15.9, 31.0]), 2.5),  # jitter and gaps
        (np.array([5.0]), 10.0),
    ],
)
def test_periods_cover_every_keyframe_exactly_once(times, period):
    spans = split_periods(times, period)
    got = np.concatenate([kf for *_, kf in spans])
    assert sorted(got.tolist()) == list(range(len(times)))  # every keyframe, none twice
    ks = [k for k, *_ in spans]
    assert ks == sorted(set(ks))
    for k, a, b, kf in spans:
        assert math.isclose(a, times[0] + k * period) and math.isclose(b - a, period)
        assert len(kf) > 0 and all(a - 1e-9 <= times[i] < b - 1e-9 for i in kf)
    if len(times) == 4 and np.array_equal(times, [0.0, 10.0, 20.0, 30.0]):
        assert [len(kf) for *_, kf in spans] == [1, 1, 1, 1]


@pytest.mark.parametrize("bad", [0, -3.0, math.nan, math.inf, "10"])
def test_bad_period_is_refused(bad):
    with pytest.raises(InputError, match="period"):
        check_period(bad)


def test_period_scenario_keeps_exactly_the_landmarks_seen(library):
    whole = build_problem(library, load_scenario(ScenarioSpec(fixture="suburb")))
    k, a, b, kf = split_periods(whole.scenario.keyframes.times, 10.0)[2]
    sc = period_scenario(whole, kf, a, b, "p")
    assert np.array_equal(sc.keyframes.poses, whole.scenario.keyframes.poses[kf])  # first one is the new start
    # oracle: observe from the period's keyframes with every landmark of the route
    full = Scenario("all", whole.scenario.keyframes.select(kf), whole.scenario.landmarks)
    seen = sorted({int(j) for o in observe(library, full) for j in o.landmark})
    assert np.array_equal(sc.landmarks, whole.scenario.landmarks[seen])
    assert 0 < sc.n_landmarks < whole.scenario.n_landmarks
    # dropping landmarks nobody sees changes no score
    small = library.subset([library.position(s) for s in ("MRL-roof", "WSC-12", "LRR-6")])
    ev_p, ev_f = (
        make_evaluator(build_problem(small, sc), "reference"),
        make_evaluator(build_problem(small, full), "reference"),
    )
    for suite in ([0], [1, 2], [0, 1, 2]):
        assert close(ev_p.score(suite), ev_f.score(suite))


def test_grid_matches_the_period_results(tiny, small_lib, tmp_path):
    res = run_periods(tiny, 110_000, 1, period_s=3.0, engine="reference", outdir=tmp_path)
    g = res.grid
    assert g.sensors == small_lib.ids and len(g.cells) == len(res.periods) == 4
    for row, p in enumerate(res.periods):
        assert g.failed(row) == set(p.result.failed) and g.active(row) == set(p.result.active)
        assert g.period_labels[row] == p.period.label
        assert p.result.cost_usd <= 110_000 and p.worst.suite == tuple(
            s for s in small_lib.ids if s in set(p.result.suite)
        )
    assert sum(p.period.n_keyframes for p in res.periods) == tiny.scenario.n_poses
    # JSON and CSV round trips
    assert results.dumps(results.load(results.save(g, tmp_path / "g.json"), SelectionGrid)) == results.dumps(g)
    lines = g.to_csv().splitlines()
    assert lines[0].split(",")[3:] == [*small_lib.ids, "worst_failures"]
    for line, row, p in zip(lines[1:], g.cells, res.periods):
        assert tuple(line.split(",")[3:-1]) == row and line.split(",")[-1] == "+".join(p.worst.failures)
    assert {c for row in g.cells for c in row} <= {FAILED, ACTIVE, ""}
    back = results.load(results.save(res, tmp_path / "r.json"), PerPeriodResult)
    assert results.dumps(back) == results.dumps(res)


def test_grid_refuses_bad_cells():
    with pytest.raises(InputError, match="cell state"):
        SelectionGrid(("a",), ("M",), ("12",), ("0-10 s",), (0.0,), (10.0,), (("broken",),))
    with pytest.raises(InputError, match="cells"):
        SelectionGrid(("a", "b"), ("M", "M"), ("12", "1"), ("0-10 s",), (0.0,), (10.0,), (("failed",),))


# ---------------------------------------------------------------------------------- resume


class Stop(Exception):
    pass


def _report(problem, outdir, *, resume=False, budget=110_000, progress=None):
    return resilient_report(
        problem, budget, 1, period_s=3.0, engine="reference", outdir=outdir, resume=resume, progress=progress
    )


def _text(report) -> dict:
    return strip_timings(json.loads(results.dumps(report)))


def test_interrupted_run_resumes_to_the_same_result(tiny, tmp_path):
    full = _report(tiny, tmp_path / "full")
    n = len(full.per_period.periods)

    def stop_after_two(done, total):
        if done == 2:
            raise Stop

    out = tmp_path / "interrupted"
    with pytest.raises(Stop):
        _report(tiny, out, progress=stop_after_two)
    written = sorted(p.name for p in (out / "periods").iterdir())
    assert written == ["period-0000.json", "period-0001.json", "route.json"]  # whole files only, no temporaries
    stamps = {p.name: p.stat().st_mtime_ns for p in (out / "periods").iterdir()}
    resumed = _report(tiny, out, resume=True)
    assert _text(resumed) == _text(full)
    for name, t in stamps.items():  # reused, not recomputed
        assert (out / "periods" / name).stat().st_mtime_ns == t
    assert len(list((out / "periods").glob("period-*.json"))) == n
    # byte-identical apart from the timings: the saved reports too
    a = json.loads(results.save(full, tmp_path / "a.json").read_text())
    b = json.loads(results.save(resumed, tmp_path / "b.json").read_text())
    assert json.dumps(strip_timings(a)) == json.dumps(strip_timings(b))


def test_resume_after_deleting_periods_and_after_changing_inputs(tiny, tmp_path):
    out = tmp_path / "run"
    full = _report(tiny, out)
    for k in (1, 3):
        period_file(out, k).unlink()
    assert _text(_report(tiny, out, resume=True)) == _text(full)
    # another budget: every stored file has the wrong fingerprint, is reported by name and recomputed
    with pytest.warns(CacheWarning) as caught:
        cheaper = _report(tiny, out, resume=True, budget=105_000)
    named = {str(w.message).split(":")[0] for w in caught}
    assert named == {str(out / "periods" / "route.json")} | {
        str(period_file(out, k)) for k in range(len(full.per_period.periods))
    }
    assert all("other inputs" in str(w.message) for w in caught)
    fresh = _report(tiny, tmp_path / "fresh", budget=105_000)
    assert _text(cheaper) == _text(fresh) and _text(cheaper) != _text(full)
    stored = results.load(results.save(cheaper, tmp_path / "c.json"), ResilientReport)
    assert stored.per_period.periods[0].result.budget_usd == 105_000
    # a damaged period file is reported and recomputed, not trusted; the matching ones are reused quietly
    period_file(out, 0).write_text("{ not json")
    with pytest.warns(CacheWarning) as caught:
        assert _text(_report(tiny, out, resume=True, budget=105_000)) == _text(fresh)
    assert [str(w.message).split(":")[0] for w in caught] == [str(period_file(out, 0))]
    assert "cannot be read" in str(caught[0].message)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert _text(_report(tiny, out, resume=True, budget=105_000)) == _text(fresh)


def test_damaged_route_cache_is_reported(tiny, tmp_path):
    cache = tmp_path / "route.json"
    first = compare(tiny, 110_000, 1, options=RunOptions(engine="reference"), cache=cache)
    cache.write_text(json.dumps({"alpha": 1}))  # JSON, but not a Comparison
    with pytest.warns(CacheWarning, match="route.json: not reused, it cannot be read as a Comparison"):
        again = compare(tiny, 110_000, 1, options=RunOptions(engine="reference"), cache=cache, resume=True)
    assert _text(again) == _text(first)
    assert results.load(cache, type(first)).fingerprint == first.fingerprint  # overwritten with a good file


# ---------------------------------------------------------------------------------- plot


def test_grid_plot(tiny, tmp_path):
    from sensorsel.plotting import plot_selection_grid, save_figure

    res = run_periods(tiny, 110_000, 1, period_s=3.0, engine="reference")
    ax = plot_selection_grid(res.grid, title="t")
    groups = [t.get_text() for t in ax.texts]
    assert groups == list(dict.fromkeys(res.grid.models))  # one label per model, in column order
    assert [t.get_text() for t in ax.get_xticklabels()] == list(res.grid.positions)
    assert [t.get_text() for t in ax.get_yticklabels()] == list(res.grid.period_labels)
    img = ax.images[0].get_array()
    for r, row in enumerate(res.grid.cells):
        for c, state in enumerate(row):
            red, green = img[r, c, 0] > 0.6 and img[r, c, 1] < 0.4, img[r, c, 1] > 0.5 and img[r, c, 0] < 0.4
            assert (state == FAILED) == red and (state == ACTIVE) == green
    path = save_figure(ax.figure, tmp_path / "grid.png")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


# ---------------------------------------------------------------------------------- CLI


def invoke(*args: str):
    return CliRunner().invoke(cli, list(args))


@pytest.fixture(scope="module")
def small_library_yaml(tmp_path_factory) -> str:
    """Table I with four clock positions: 2 LiDARs + 5 models x 4 = 22 sensors."""
    data = yaml.safe_load(default_library_path().read_text())
    data["clock_positions"] = [12, 3, 6, 9]
    path = tmp_path_factory.mktemp("lib") / "small.yaml"
    path.write_text(yaml.safe_dump(data))
    return str(path)


def test_cli_writes_the_comparison_grid_and_periods(small_library_yaml, tmp_path):
    out = tmp_path / "out"
    args = [
        "resilient",
        "--fixture",
        "tiny",
        "--library",
        small_library_yaml,
        "--engine",
        "reference",
        "--jobs",
        "1",
        "--budget",
        "110000",
        "--failures",
        "1",
        "--period",
        "3",
        "--output-dir",
        str(out),
    ]
    r = invoke(*args)
    assert r.exit_code == 0, (r.output, r.exception)
    data = json.loads((out / "resilient.json").read_text())
    rep = results.load(out / "resilient.json", ResilientReport)
    assert data["suite"] == list(rep.comparison.resilient.suite) and data["failed"] == ["LRL-roof"]
    assert set(data["failed"]) <= set(data["suite"])
    lines = r.stdout.splitlines()
    row = {ln.split()[0]: ln.split() for ln in lines if ln.startswith(("greedy ", "resilient "))}
    assert row["resilient"][1] == ",".join(rep.comparison.resilient.suite)
    assert row["resilient"][4] == f"{rep.comparison.resilient_worst.score:.2f}"
    assert row["greedy"][4] == f"{rep.comparison.greedy_worst.score:.2f}"
    assert (out / "grid.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    csv = (out / "grid.csv").read_text().splitlines()
    assert len(csv) == 1 + len(rep.per_period.periods) == 1 + len(list((out / "periods").glob("period-*.json")))
    assert r.stderr == ""  # no progress bar when not on a terminal
    # resume: same report apart from the timings; svg output
    r2 = invoke(*args, "--resume", "--plot-format", "svg")
    assert r2.exit_code == 0, r2.output
    assert strip_timings(json.loads((out / "resilient.json").read_text())) == strip_timings(data)
    assert (out / "grid.svg").read_text().lstrip().startswith("<?xml")


@pytest.mark.parametrize(
    "opts, needle",
    [
        (["--failures", "-1"], "-1"),
        (["--period", "0"], "period"),
        (["--period", "-5"], "-5"),
        (["--period", "nan"], "period"),
        (["--budget", "-10"], "budget"),
        (["--budget", "inf"], "budget"),
        (["--failures", "two"], "two"),
        (["--rule", "best"], "best"),
        (["--objective", "uniform"], "--objective"),
        (["--plot-format", "jpg"], "jpg"),
    ],
)
def test_cli_bad_input_exits_2(tmp_path, opts, needle):
    r = invoke("resilient", "--fixture", "tiny", "--engine", "reference", "--output-dir", str(tmp_path / "o"), *opts)
    assert r.exit_code == 2, r.output
    assert "Traceback" not in r.output and needle in r.output
    assert not (tmp_path / "o" / "resilient.json").exists()


def test_default_engine_gives_the_reference_selection(tiny):
    """Engines differ in speed, not in answers: the same suites, failures and grid as the reference."""
    fast = run_periods(tiny, 110_000, 1, period_s=3.0)  # the default engine
    ref = run_periods(tiny, 110_000, 1, period_s=3.0, engine="reference")
    assert fast.grid == ref.grid
    for a, b in zip(fast.periods, ref.periods):
        assert a.result.suite == b.result.suite and a.worst.failures == b.worst.failures
        assert close(a.result.score, b.result.score) and close(a.worst.score, b.worst.score)


def test_a_short_failing_set_says_what_it_had_to_fit(tiny_problem) -> None:  # type: ignore[no-untyped-def]
    """At the cheapest sensor's price one sensor fits as a failing sensor, whatever alpha asks: the note
    names the budget; under limits (here at most one sensor) it names the limits and the budget."""
    from sensorsel.designs.resilient import failing_set
    from sensorsel.information.evaluators import make_evaluator
    from sensorsel.model.constraints import Constraints

    ev = make_evaluator(tiny_problem, "reference")
    cheapest = float(tiny_problem.library.costs.min())
    picked, scores, note = failing_set(ev, cheapest, 2)
    assert len(picked) == len(scores) == 1
    assert note == f"only 1 informative sensor(s) fit the budget ${cheapest:,.0f} as failing sensors; 2 requested"
    whole = float(tiny_problem.library.costs.sum())
    picked, _, note = failing_set(ev, whole, 2, Constraints(max_sensors=1, slots=False))
    assert len(picked) == 1 and note.startswith("only 1 informative sensor(s) fit the limits (")
    assert note.endswith(f"; ${whole:,.0f}) as failing sensors; 2 requested")
