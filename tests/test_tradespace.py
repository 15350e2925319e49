"""The cost-performance tradespace: the Pareto front against a brute-force dominance check, every
greedy step recorded, prefix sharing equal to independent runs, cheapest-reaching, determinism,
JSON/CSV output, the plot, and the ``sensorsel pareto`` command."""

from __future__ import annotations

import csv
import dataclasses
import io
import itertools
import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from sensorsel.cli import cli
from sensorsel.designs.selection import greedy
from sensorsel.designs.tradespace import (
    DEFAULT_RULES,
    TradespaceResult,
    csv_text,
    default_budgets,
    pareto_mask,
    parse_budgets,
    parse_rules,
    run_tradespace,
    tradespace,
    write_csv,
)
from sensorsel.errors import InputError
from sensorsel.information.evaluators import make_evaluator
from sensorsel.io import results
from sensorsel.io.resources import default_library_path
from sensorsel.model.problem import build_problem
from sensorsel.model.scenario import ScenarioSpec, load_scenario

MIXED = ("LRL-roof", "MRL-roof", "HD2K-12", "HD2K-6", "LSC-4", "WSC-12", "WSC-6", "LRR-6", "MRR-5", "LRR-12")
PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def tiny():
    return load_scenario(ScenarioSpec(fixture="tiny"))


@pytest.fixture(scope="module")
def mixed(library, tiny):
    return build_problem(library.subset([library.position(i) for i in MIXED]), tiny, spec=ScenarioSpec(fixture="tiny"))


@pytest.fixture(scope="module")
def ts(mixed):
    """The tradespace of the mixed library: default budgets, every rule."""
    return run_tradespace(mixed, rules=("uniform", "cost-benefit", "marginal", "best-of"), engine="reference")


def _brute_front(points):
    """Indices of points no other point dominates (cost no higher, score no lower, one strictly)."""
    keep = []
    for i, (ci, si) in enumerate(points):
        if not any((cj <= ci and sj >= si and (cj < ci or sj > si)) for j, (cj, sj) in enumerate(points) if j != i):
            keep.append(i)
    return keep


# --------------------------------------------------------------------------------- Pareto front


@pytest.mark.parametrize("seed", range(6))
def test_pareto_mask_is_the_non_dominated_set(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 60))
    # few distinct values: many equal costs, equal scores and exact duplicates
    costs = rng.integers(1, 8, n).astype(float) * 449.0
    scores = rng.integers(0, 6, n).astype(float) * 1.5
    mask = pareto_mask(costs, scores)
    assert sorted(np.flatnonzero(mask).tolist()) == _brute_front(list(zip(costs, scores)))


def test_pareto_mask_ties_and_errors():
    # equal cost and score: neither dominates, both on the front; equal cost, lower score: dominated
    assert pareto_mask([1, 1, 1, 2], [5, 5, 4, 5]).tolist() == [True, True, False, False]
    assert pareto_mask([], []).tolist() == []
    with pytest.raises(InputError):
        pareto_mask([1.0, math.nan], [1.0, 2.0])
    with pytest.raises(InputError):
        pareto_mask([1.0], [1.0, 2.0])


def test_front_is_exactly_the_non_dominated_architectures(ts):
    archs = ts.architectures
    assert len(archs) > 10
    points = [(a.cost_usd, a.score) for a in archs]
    assert [i for i, a in enumerate(archs) if a.on_front] == _brute_front(points)
    front = ts.front
    assert [a.cost_usd for a in front] == sorted(a.cost_usd for a in front)
    assert all(b.score > a.score for a, b in zip(front, front[1:]) if b.cost_usd > a.cost_usd)


def test_architectures_are_unique_scored_and_normalized(ts, mixed):
    lib = mixed.library
    oracle = make_evaluator(mixed, "reference")
    keys = [frozenset(a.suite) for a in ts.architectures]
    assert len(keys) == len(set(keys))
    assert ts.best_score == max(a.score for a in ts.architectures)
    for a in ts.architectures:
        pos = [lib.position(i) for i in a.suite]
        assert list(a.suite) == [lib[i].id for i in sorted(pos)]  # library order
        assert a.cost_usd == pytest.approx(lib.cost(pos))
        assert a.cost_usd <= max(ts.budgets_usd)
        assert a.score == pytest.approx(oracle.score(pos), rel=1e-9)
        assert a.normalized == pytest.approx(a.score / ts.best_score, rel=1e-12)
        assert a.rules and set(a.rules) <= set(ts.rules)
    assert max(a.normalized for a in ts.architectures) == 1.0
    order = [(a.cost_usd, -a.score, a.suite) for a in ts.architectures]
    assert order == sorted(order)


def test_every_step_of_every_independent_run_is_recorded(ts, mixed):
    """Independent greedy runs (no prefix sharing) at each budget: each intermediate suite is an
    architecture of the tradespace, labelled with the rule that made it."""
    by_suite = {frozenset(a.suite): a for a in ts.architectures}
    ev = make_evaluator(mixed, "reference")
    made = set()
    for rule in ts.rules:
        for b in ts.budgets_usd:
            res = greedy(ev, b, rule)
            run = next(r for r in ts.runs if r.rule == rule and r.budget_usd == b)
            assert run.suite == res.suite and run.n_steps == len(res.steps) and run.stop_reason == res.stop_reason
            for st in res.steps:
                a = by_suite[frozenset(st.suite)]
                assert rule in a.rules
                assert a.score == pytest.approx(st.score, rel=1e-12)
                made.add(frozenset(st.suite))
    assert made == set(by_suite)  # and nothing else


def test_prefix_sharing_equals_independent_runs_with_fewer_evaluations(mixed):
    shared = tradespace(make_evaluator(mixed, "reference"), share_prefix=True)
    fresh = tradespace(make_evaluator(mixed, "reference"), share_prefix=False)
    assert shared.architectures == fresh.architectures

    def strip(runs):
        return [dataclasses.replace(r, n_evaluations=0, shared_steps=0) for r in runs]

    assert strip(shared.runs) == strip(fresh.runs)
    assert all(r.shared_steps == 0 for r in fresh.runs)
    assert any(r.shared_steps > 0 for r in shared.runs)
    assert shared.n_evaluations < fresh.n_evaluations


def test_best_of_architectures_come_from_its_uniform_or_marginal_runs(ts):
    for a in ts.architectures:
        if "best-of" in a.rules:
            assert "uniform" in a.rules or "marginal" in a.rules
    for r in ts.runs:
        if r.rule == "best-of":
            twins = {x.rule: x for x in ts.runs if x.budget_usd == r.budget_usd and x.rule in ("uniform", "marginal")}
            assert r.score == max(twins["uniform"].score, twins["marginal"].score)
            assert r.suite == twins[r.winning_rule].suite


def test_runs_against_the_brute_force_optimum_of_each_budget(ts, mixed):
    """Oracle: the best suite of each budget among all 2^10 suites, scored one by one. No run and no
    architecture within the budget beats it; best-of keeps (1 - 1/e)/2 of it (Leskovec et al. 2007)."""
    ev = make_evaluator(mixed, "reference")
    n = mixed.n_sensors
    table = [
        (mixed.library.cost(c), ev.score(c) if c else 0.0)
        for r in range(n + 1)
        for c in itertools.combinations(range(n), r)
    ]
    for b in ts.budgets_usd:
        opt = max(f for c, f in table if c <= b)
        runs = [r for r in ts.runs if r.budget_usd == b]
        assert len(runs) == len(ts.rules)
        for r in runs:
            assert r.cost_usd <= b and r.score <= opt + 1e-9 * max(1.0, opt)
            if r.rule == "best-of":
                assert r.score >= (1 - 1 / math.e) / 2 * opt
        assert all(a.score <= opt + 1e-9 * max(1.0, opt) for a in ts.architectures if a.cost_usd <= b)


def test_cheapest_reaching(ts):
    for frac in (0.5, 0.9, 0.95, 0.99, 1.0):
        a = ts.cheapest_reaching(frac)
        ok = [x for x in ts.architectures if x.score >= frac * ts.best_score]
        assert a is not None and a.cost_usd == min(x.cost_usd for x in ok)
        assert a.score == max(x.score for x in ok if x.cost_usd == a.cost_usd)
        assert a.on_front
    assert ts.best is not None and ts.best.score == ts.best_score
    for bad in (0.0, -0.1, 1.01, math.nan, "0.99"):
        with pytest.raises(InputError, match="fraction"):
            ts.cheapest_reaching(bad)


# -------------------------------------------------------------------------------------- budgets


def test_default_budgets_log_spaced_from_cheapest_to_total(library):
    b = default_budgets(library)
    assert len(b) == 14 and list(b) == sorted(set(b))
    assert b[0] == library.costs.min() == 449.0
    assert b[-1] == pytest.approx(library.costs.sum()) and b[-1] == pytest.approx(202532.0)
    ratios = np.diff(np.log(b))
    assert np.allclose(ratios, ratios.mean(), rtol=0.01)
    assert default_budgets(library, 1) == (b[-1],)
    with pytest.raises(InputError):
        default_budgets(library, 0)


def test_parse_budgets_and_rules():
    assert parse_budgets("110000, 449,$27_000,449") == (449.0, 27000.0, 110000.0)
    for bad, msg in (
        ("abc", "'abc' is not a number"),
        ("1,,2", "empty item"),
        ("-5", "'-5'"),
        ("nan", "'nan'"),
        ("", "expected"),
    ):
        with pytest.raises(InputError, match=msg):
            parse_budgets(bad)
    assert parse_rules("marginal, uniform,marginal") == ("marginal", "uniform")
    with pytest.raises(InputError, match="--rules: unknown rule 'greedy'; available: uniform"):
        parse_rules("uniform,greedy")


def test_budgets_below_cheapest_give_an_empty_tradespace(mixed):
    res = tradespace(make_evaluator(mixed, "reference"), [100.0, 300.0])
    assert res.architectures == () and res.best_score == 0.0 and res.cheapest_reaching(0.99) is None
    assert all(r.suite == () and "below the cheapest" in r.stop_reason for r in res.runs)


def test_progress_counts_every_run(mixed):
    calls = []
    res = tradespace(
        make_evaluator(mixed, "reference"),
        [449.0, 5000.0, 20000.0],
        ("uniform", "best-of"),
        progress=lambda d, t: calls.append((d, t)),
    )
    # best-of needs marginal runs too: 2 rules x 3 budgets
    assert calls == [(k, 6) for k in range(1, 7)]
    assert len(res.runs) == 6


# ------------------------------------------------------------------------ determinism and output


def _without_timing(res: TradespaceResult) -> str:
    return results.dumps(dataclasses.replace(res, seconds=0.0))


def test_byte_identical_across_runs_and_json_round_trip(mixed, ts, tmp_path):
    again = run_tradespace(mixed, rules=ts.rules, engine="reference")
    assert _without_timing(again) == _without_timing(ts)
    assert csv_text(again) == csv_text(ts)
    back = results.load(results.save(ts, tmp_path / "t.json"), TradespaceResult)
    assert back == ts
    assert back.front == ts.front and back.cheapest_reaching(0.95) == ts.cheapest_reaching(0.95)


def test_csv_lists_every_architecture(ts, tmp_path):
    path = write_csv(ts, tmp_path / "out" / "architectures.csv")
    rows = list(csv.DictReader(io.StringIO(path.read_text())))
    assert len(rows) == len(ts.architectures)
    assert list(rows[0]) == ["cost_usd", "score", "normalized_score", "on_front", "n_sensors", "rules", "suite"]
    for row, a in zip(rows, ts.architectures):
        assert float(row["cost_usd"]) == a.cost_usd and float(row["score"]) == a.score
        assert float(row["normalized_score"]) == a.normalized
        assert row["on_front"] == ("1" if a.on_front else "0")
        assert row["suite"].split(",") == list(a.suite) and row["rules"].split("+") == list(a.rules)


def test_plot_draws_every_architecture_and_the_front(ts, tmp_path):
    from sensorsel.plotting import plot_tradespace, save_figure

    ax = plot_tradespace(ts)
    # the markers' legend entries read "made by RULE (N)"
    drawn = {
        c.get_label().split(" (")[0].removeprefix("made by "): len(c.get_offsets())
        for c in ax.collections
        if not c.get_label().startswith("_")
    }
    for name in ts.rules:
        assert drawn[name] == sum(name in a.rules for a in ts.architectures)
    line = next(ln for ln in ax.get_lines() if ln.get_label().startswith("Pareto front"))
    assert line.get_linestyle() == "--"
    xs = line.get_xdata()
    assert sorted(set(np.asarray(xs, float))) == sorted({a.cost_usd for a in ts.front})
    assert ax.get_xscale() == "log"
    for ext, magic in ((".png", PNG), (".svg", b"<?xml"), (".pdf", b"%PDF")):
        path = save_figure(plot_tradespace(ts).figure, tmp_path / f"p{ext}")
        assert path.read_bytes().startswith(magic)
    with pytest.raises(InputError, match="no architectures"):
        plot_tradespace(dataclasses.replace(ts, architectures=()))


# ---------------------------------------------------------------------------------------- CLI


@pytest.fixture(scope="module")
def small_library(tmp_path_factory) -> Path:
    data = yaml.safe_load(Path(default_library_path()).read_text())
    data["clock_positions"] = [12, 6]
    data["models"] = [m for m in data["models"] if m["code"] in ("MRL", "LRR", "HD2K", "WSC")]
    path = tmp_path_factory.mktemp("lib") / "small.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def _pareto(small_library, *args):
    return CliRunner().invoke(
        cli, ["pareto", "--fixture", "tiny", "--library", str(small_library), "--engine", "reference", *args]
    )


def test_cli_pareto_writes_plot_csv_and_json(small_library, tmp_path):
    out = tmp_path / "ts"
    r = _pareto(small_library, "--output-dir", str(out))
    assert r.exit_code == 0, r.output
    # runs/: each rule's runs as they finish, which --resume reads back (tests/test_pipeline.py)
    assert sorted(p.name for p in out.iterdir()) == [
        "accuracy.json",
        "architectures.csv",
        "pareto-accuracy.png",
        "pareto.png",
        "runs",
        "tradespace.json",
    ]
    assert (out / "pareto.png").read_bytes().startswith(PNG)
    res = results.load(out / "tradespace.json", TradespaceResult)
    assert res.rules == DEFAULT_RULES and len(res.budgets_usd) == 14
    rows = list(csv.DictReader(io.StringIO((out / "architectures.csv").read_text())))
    assert len(rows) == len(res.architectures)
    assert f"found      {len(res.architectures)} architectures, {len(res.front)} on the Pareto front" in r.stdout
    for frac in (0.99, 0.95):
        a = res.cheapest_reaching(frac)
        assert f"cheapest reaching {frac:.0%} of the best: ${a.cost_usd:,.0f}" in r.stdout
        assert ",".join(a.suite) in r.stdout


def test_cli_pareto_options(small_library, tmp_path):
    out = tmp_path / "svg"
    r = _pareto(
        small_library, "--output-dir", str(out), "--budgets", "2000,6000", "--rules", "marginal", "--plot-format", "svg"
    )
    assert r.exit_code == 0, r.output
    assert (out / "pareto.svg").read_bytes().startswith(b"<?xml")
    res = results.load(out / "tradespace.json", TradespaceResult)
    assert res.budgets_usd == (2000.0, 6000.0) and res.rules == ("marginal",)
    old = _pareto(
        small_library, "--output-dir", str(tmp_path / "old"), "--budgets", "2000,6000", "--selectors", "marginal"
    )
    assert old.exit_code == 2 and "No such option '--selectors'" in old.stderr  # one name: --rules
    for args, msg in (
        (["--budgets", "1000,abc"], "'abc' is not a number"),
        (["--rules", "uniform,best"], "unknown rule 'best'"),
    ):
        bad = _pareto(small_library, "--output-dir", str(tmp_path / "bad"), *args)
        assert bad.exit_code == 2 and msg in bad.stderr and "Traceback" not in bad.output
        assert not (tmp_path / "bad").exists()
