"""The robust commands end to end: ``sensorsel robust``, ``resilient --method robust`` (whole route and per period,
the worst failure set in the grid and its CSV), the worst route of a domain against brute force."""

from __future__ import annotations

import itertools
import json

import pytest
import yaml
from click.testing import CliRunner

from sensorsel.api import run_robust
from sensorsel.cli import cli
from sensorsel.cli.robust import method_words
from sensorsel.designs.resilient import ACTIVE, FAILED, ResilientReport, worst_case
from sensorsel.designs.robust import RobustResult, worst_route_select
from sensorsel.errors import InputError
from sensorsel.information.evaluators import DomainEvaluator, make_evaluator
from sensorsel.io import results
from sensorsel.io.resources import default_library_path
from sensorsel.model.problem import Domain, DomainRoute, build_problem
from sensorsel.model.scenario import ScenarioSpec, load_scenario

REL = 1e-9


def tol(x: float) -> float:
    return 1e-7 * max(1.0, abs(x))


def strip_timings(obj):
    if isinstance(obj, dict):
        return {k: strip_timings(v) for k, v in obj.items() if k != "seconds"}
    if isinstance(obj, list):
        return [strip_timings(v) for v in obj]
    return obj


def invoke(*args):
    return CliRunner().invoke(cli, [str(a) for a in args], catch_exceptions=False)


@pytest.fixture(scope="module")
def small_library_yaml(tmp_path_factory) -> str:
    """Table I with four clock positions: 2 LiDARs + 5 models x 4 = 22 sensors."""
    data = yaml.safe_load(default_library_path().read_text())
    data["clock_positions"] = [12, 3, 6, 9]
    path = tmp_path_factory.mktemp("lib") / "small.yaml"
    path.write_text(yaml.safe_dump(data))
    return str(path)


# ------------------------------------------------------------------------------------ sensorsel robust

ROBUST_ARGS = [
    "robust",
    "--fixture",
    "tiny",
    "--engine",
    "fast",
    "--jobs",
    "1",
    "--budget",
    "5,000",
    "--failures",
    "1",
    "-q",
]


def test_cli_robust_prints_the_three_designs_and_round_trips(small_library_yaml, tmp_path):
    out = tmp_path / "r.json"
    r = invoke(*ROBUST_ARGS, "--library", small_library_yaml, "-o", out)
    assert r.exit_code == 0, r.output
    res = results.load(out, RobustResult)
    assert results.dumps(results.load(results.save(res, tmp_path / "again.json"), "robust")) == results.dumps(res)
    summary = r.stdout.split("\ncandidates")[0]  # the three designs' table (the candidates' table follows)
    lines = {ln.split()[0]: ln for ln in summary.splitlines() if ln.startswith(("greedy ", "algorithm 2", "robust "))}
    assert set(lines) == {"greedy", "algorithm", "robust"}
    from sensorsel.cli.common import compact_suite

    # robust row: suite (ids grouped by model), cost, nominal, worst case, its failure set, the bound, the gap
    robust_row = lines["robust"]
    assert compact_suite(res.suite) in robust_row
    tail = robust_row.split(compact_suite(res.suite))[1].split()
    assert (
        tail[2] == f"{res.worst_score:,.2f}"
        and tail[3] == ",".join(res.failures)
        and tail[-1] == f"{res.gap_percent:.2f}%"
    )
    assert f"{res.greedy_worst_score:,.2f}" in lines["greedy"].split()
    # the user reads the methods' words, never their internal keys ("bound-leaf")
    assert f"chosen by {method_words(res.method)};" in r.stdout and "candidates" in r.stdout
    for c in res.candidates:
        assert any(ln.startswith(method_words(c.method) + "  ") for ln in r.stdout.splitlines())
        assert method_words(c.method) != c.method, f"{c.method} is printed under its internal key"
        assert c.method not in r.stdout.split("candidates")[1], f"{c.method} appears in the candidates table"
    # the guarantee, and the answer's worst case is exact
    assert res.worst_score >= res.greedy_worst_score - tol(res.greedy_worst_score)
    assert res.worst_score >= res.algorithm2_worst_score - tol(res.algorithm2_worst_score)
    assert res.worst_score <= res.bound + tol(res.bound)
    lib_problem = build_problem(results_library(small_library_yaml), load_scenario(ScenarioSpec(fixture="tiny")))
    ev = make_evaluator(lib_problem, "fast")
    w = worst_case(ev, lib_problem.library.resolve_suite(res.suite), 1)
    assert w.score == pytest.approx(res.worst_score, rel=1e-9) and w.failures == res.failures
    # --json prints the same result as the file holds (timings apart)
    r2 = invoke(*ROBUST_ARGS, "--library", small_library_yaml, "--json")
    assert r2.exit_code == 0
    assert strip_timings(json.loads(r2.stdout)) == strip_timings(json.loads(out.read_text()))
    assert json.loads(r2.stdout)["kind"] == "robust"


def results_library(path):
    from sensorsel.model.library import load_library

    return load_library(path)


def test_cli_robust_is_deterministic(small_library_yaml, tmp_path):
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    for out in (a, b):
        assert (
            invoke(
                *ROBUST_ARGS,
                "--library",
                small_library_yaml,
                "--methods",
                "saturate,local-search",
                "--no-skip",
                "-o",
                out,
            ).exit_code
            == 0
        )
    assert strip_timings(json.loads(a.read_text())) == strip_timings(json.loads(b.read_text()))


def test_aggregate_worst_is_refused_where_it_is_not_supported(small_library_yaml):
    r = invoke("greedy", "--fixture", "tiny", "--budget", "5000", "--aggregate", "worst")
    assert r.exit_code == 2 and "worst" in r.output
    r = invoke(*ROBUST_ARGS, "--library", small_library_yaml, "--aggregate", "worst")
    assert r.exit_code == 2 and "domain" in r.output and "Traceback" not in r.output
    problem = build_problem(results_library(small_library_yaml), load_scenario(ScenarioSpec(fixture="tiny")))
    with pytest.raises(InputError, match="domain"):
        run_robust(problem, 5000, 1, aggregate="worst")
    with pytest.raises(InputError, match="aggregate"):
        run_robust(problem, 5000, 1, aggregate="mean")


# ------------------------------------------------------------------------ resilient --method robust


def test_files_that_call_algorithm_2_paper_are_read_until_their_release(small_library_yaml, tmp_path):
    """Algorithm 2 has one name, "algorithm-2"; "paper", its name in files written before, is read as
    it (sensorsel.io.legacy, until the release it names): in result and period files (a resume
    reuses such periods, no warning). The command line takes only "algorithm-2"."""
    from sensorsel.io.legacy import REMOVED_IN

    assert REMOVED_IN == "0.2.0"  # the promise the docs make: change both together
    import warnings

    common = [
        "resilient",
        "--fixture",
        "tiny",
        "--library",
        small_library_yaml,
        "--engine",
        "fast",
        "--jobs",
        "1",
        "--budget",
        "5000",
        "--failures",
        "1",
        "--period",
        "3",
        "-q",
        "--json",
    ]
    out = tmp_path / "a2"
    first = invoke(*common, "--output-dir", out)
    assert first.exit_code == 0, first.output
    files = [out / "resilient.json", *sorted((out / "periods").glob("period-*.json"))]
    for f in files:  # as a run before the rename wrote them
        text = f.read_text()
        assert '"method": "algorithm-2"' in text
        f.write_text(text.replace('"method": "algorithm-2"', '"method": "paper"'))
    rep = results.load(out / "resilient.json", ResilientReport)
    assert rep.method == "algorithm-2" and rep.per_period is not None and rep.per_period.method == "algorithm-2"
    assert {p.method for p in rep.per_period.periods} == {"algorithm-2"} and rep.per_period.grid.method == "algorithm-2"
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a period file not reused would warn
        again = invoke(*common, "--method", "algorithm-2", "--output-dir", out, "--resume")
    assert again.exit_code == 0, again.output

    def untimed(text):
        def rec(o):
            if isinstance(o, dict):
                return {k: rec(v) for k, v in o.items() if k != "seconds"}
            return [rec(v) for v in o] if isinstance(o, list) else o

        return rec(json.loads(text))

    assert untimed(again.stdout) == untimed(first.stdout)


def test_algorithm_2_has_one_name_in_study_files_and_on_the_command_line(tmp_path):
    from sensorsel.designs.study import StudyError, load_study

    f = tmp_path / "paper.yaml"
    f.write_text("target: {fixture: tiny}\ngrid: {budgets: [5000], failures: [1]}\nmethod: paper\n")
    with pytest.raises(StudyError, match="method: expected one of algorithm-2, robust, got 'paper'"):
        load_study(f)
    r = invoke(
        "resilient", "--fixture", "tiny", "--budget", "5000", "--method", "paper", "--output-dir", tmp_path / "o"
    )
    assert r.exit_code == 2 and "'paper' is not one of" in r.output


@pytest.mark.parametrize("method", ["algorithm-2", "robust"])
def test_resilient_method_grid_and_csv_show_the_worst_failures(small_library_yaml, tmp_path, method):
    out = tmp_path / method
    r = invoke(
        "resilient",
        "--fixture",
        "tiny",
        "--library",
        small_library_yaml,
        "--engine",
        "fast",
        "--jobs",
        "1",
        "--budget",
        "5000",
        "--failures",
        "1",
        "--period",
        "3",
        "--method",
        method,
        "--output-dir",
        out,
        "-q",
    )
    assert r.exit_code == 0, r.output
    rep = results.load(out / "resilient.json", ResilientReport)
    assert rep.method == method and rep.per_period is not None and rep.per_period.method == method
    grid = rep.per_period.grid
    csv = (out / "grid.csv").read_text().splitlines()
    header = csv[0].split(",")
    assert header[-1] == "worst_failures" and header[3:-1] == list(grid.sensors)
    assert len(csv) == 1 + len(rep.per_period.periods) == 1 + 4
    for k, (line, p) in enumerate(zip(csv[1:], rep.per_period.periods)):
        cells = line.split(",")
        assert cells[-1] == "+".join(p.worst.failures) and p.worst.failures and grid.worst(k) == p.worst.failures
        assert set(p.worst.failures) <= set(p.worst.suite)
        if method == "robust":
            assert p.result is None and p.robust is not None and FAILED not in cells
            assert (
                {s for s, c in zip(grid.sensors, grid.cells[k]) if c == ACTIVE}
                == set(p.robust.suite)
                == set(p.worst.suite)
            )
            assert p.robust.worst_score == pytest.approx(p.worst.score, rel=1e-12)
            assert p.robust.worst_score >= max(p.robust.greedy_worst_score, p.robust.algorithm2_worst_score) - tol(
                p.worst.score
            )
        else:
            assert p.robust is None and grid.failed(k) == set(p.result.failed)
    if method == "robust":
        assert rep.robust is not None and rep.suite == rep.robust.suite and rep.failed == ()
        best_other = max(rep.comparison.greedy_worst.score, rep.comparison.resilient_worst.score)
        assert rep.robust.worst_score >= best_other - tol(best_other)
        assert any(ln.startswith("robust ") for ln in r.stdout.splitlines())
    else:
        assert rep.robust is None and rep.failed == rep.comparison.resilient.failed
    assert "worst failure for the suite" in r.stdout and (out / "grid.png").stat().st_size > 0
    back = results.load(results.save(rep, tmp_path / "again.json"), ResilientReport)
    assert results.dumps(back) == results.dumps(rep)


def test_resilient_robust_resume_does_not_reuse_paper_periods(small_library_yaml, tmp_path):
    args = [
        "resilient",
        "--fixture",
        "tiny",
        "--library",
        small_library_yaml,
        "--engine",
        "fast",
        "--jobs",
        "1",
        "--budget",
        "5000",
        "--failures",
        "1",
        "--period",
        "5",
        "--output-dir",
        tmp_path,
        "-q",
    ]
    assert invoke(*args).exit_code == 0
    r = invoke(*args, "--method", "robust", "--resume")
    assert r.exit_code == 0
    # each paper period file is named as not reused (the CLI prints sensorsel's warnings as one line)
    assert "sensorsel: warning:" in r.stderr and "period-0000.json" in r.stderr and "not reused" in r.stderr
    rep = results.load(tmp_path / "resilient.json", ResilientReport)
    assert all(p.method == "robust" for p in rep.per_period.periods)


# --------------------------------------------------------------------- the worst route of a domain

SMALL = ("LRL-roof", "MRL-roof", "LRR-12", "LRR-6", "WSC-9", "HD2K-4", "HD2K-10", "LSC-2")


@pytest.fixture(scope="module")
def three_routes(library):
    lib = library.subset([library.position(i) for i in SMALL])
    specs = [
        ScenarioSpec(fixture="tiny"),
        ScenarioSpec(fixture="tiny", landmarks="synthetic", landmark_seed=3),
        ScenarioSpec(fixture="tiny", landmarks="synthetic", landmark_seed=7),
    ]
    return Domain(
        tuple(
            DomainRoute(f"r{k}", build_problem(lib, load_scenario(s), spec=s), w)
            for k, (s, w) in enumerate(zip(specs, (3.0, 1.0, 0.5)))
        ),
        "test",
    )


def brute_worst_route(domain, budget, alpha):
    """Every affordable suite's h(S) = min over routes and alpha-sets of f_r(S minus F) / f_r(L)."""
    lib = domain.library
    evs = [make_evaluator(r.problem, "fast") for r in domain.routes]
    everything = tuple(range(len(lib)))
    best = [e.score(everything) for e in evs]
    table = {}
    for k in range(len(lib) + 1):
        for s in itertools.combinations(range(len(lib)), k):
            if lib.cost(s) <= budget + 1e-9:
                vals = []
                for e, b in zip(evs, best):
                    sets = itertools.combinations(s, min(alpha, len(s)))
                    vals.append(
                        min((e.score(tuple(i for i in s if i not in f)) if len(f) < len(s) else 0.0) / b for f in sets)
                    )
                table[s] = min(vals)
    return table


@pytest.mark.parametrize("budget, alpha", [(3000.0, 0), (6000.0, 1), (110_000.0, 1), (12_000.0, 2)])
def test_worst_route_against_brute_force(three_routes, budget, alpha):
    table = brute_worst_route(three_routes, budget, alpha)
    opt = max(table.values())
    lib = three_routes.library
    res = worst_route_select(three_routes, budget, alpha, engine="fast")
    s = tuple(sorted(lib.resolve_suite(res.suite)))
    assert res.aggregate == "worst" and res.cost_usd <= budget + 1e-9
    assert res.worst_score == pytest.approx(table[s], rel=1e-9, abs=1e-12)
    assert res.worst_score <= opt + tol(opt) and res.bound >= opt - tol(opt)
    for c in res.candidates:
        assert c.worst_score == pytest.approx(table[tuple(sorted(lib.resolve_suite(c.suite)))], rel=1e-9, abs=1e-12)
    assert res.worst_score >= res.greedy_worst_score - tol(opt) and res.worst_score >= res.algorithm2_worst_score - tol(
        opt
    )
    # the breakdown names the worst route, with each route's exact shares
    assert [m.name for m in res.members] == ["r0", "r1", "r2"]
    worst = min(res.members, key=lambda m: m.worst_share)
    assert res.worst_member == worst.name and worst.worst_share == pytest.approx(res.worst_score, rel=1e-12)
    # greedy on the average is a candidate
    dev = DomainEvaluator(three_routes, "fast")
    from sensorsel.designs.selection import greedy

    g = greedy(dev, budget, "uniform")
    assert set(res.candidates[0].suite) == set(g.suite)
    # with these routes the answer is the brute-force optimum (each case checked once by hand)
    assert res.worst_score == pytest.approx(opt, rel=1e-9, abs=1e-12)


def test_worst_route_is_deterministic_and_round_trips(three_routes, tmp_path):
    a = worst_route_select(three_routes, 6000.0, 1, engine="fast")
    b = run_robust(three_routes, 6000.0, 1, engine="fast", aggregate="worst")
    assert strip_timings(json.loads(results.dumps(a))) == strip_timings(json.loads(results.dumps(b)))
    back = results.load(results.save(a, tmp_path / "w.json"), RobustResult)
    assert results.dumps(back) == results.dumps(a)


def test_cli_robust_worst_route_on_the_fixture_domain(small_library_yaml, tmp_path):
    from pathlib import Path

    domain = Path(__file__).resolve().parents[1] / "configs" / "domain_fixtures.yaml"
    out = tmp_path / "w.json"
    r = invoke(
        "robust",
        "--domain",
        domain,
        "--library",
        small_library_yaml,
        "--aggregate",
        "worst",
        "--budget",
        "5000",
        "--failures",
        "1",
        "--jobs",
        "1",
        "-q",
        "-o",
        out,
    )
    assert r.exit_code == 0, r.output
    res = results.load(out, RobustResult)
    assert res.aggregate == "worst" and res.worst_member in ("suburb", "tiny")
    assert f"per route (worst: {res.worst_member})" in r.stdout
    assert res.worst_score >= max(res.greedy_worst_score, res.algorithm2_worst_score) - 1e-12
