"""Greedy selection under a budget: the budget is never exceeded, brute-force optima and the
(1 - 1/e) and (1 - 1/e)/2 guarantees on small libraries, lazy = plain, deterministic tie-breaks,
byte-identical and JSON round-tripping results, and the ``sensorsel greedy`` command."""

from __future__ import annotations

import dataclasses
import itertools
import json
import math
from pathlib import Path

import pytest
import yaml
from click.testing import CliRunner

from sensorsel.api import run_greedy
from sensorsel.cli import cli
from sensorsel.designs.certify import CertifiedGreedyResult
from sensorsel.designs.selection import RULES, GreedyResult, better_run, check_rule, greedy
from sensorsel.errors import InputError
from sensorsel.information.evaluators import make_evaluator
from sensorsel.io import results
from sensorsel.io.resources import default_library_path
from sensorsel.model.library import SensorLibrary
from sensorsel.model.problem import build_problem
from sensorsel.model.scenario import ScenarioSpec, load_scenario

# Ten sensors of every kind, one of which (LRR-12) sees nothing on the tiny route.
MIXED = ("LRL-roof", "MRL-roof", "HD2K-12", "HD2K-6", "LSC-4", "WSC-12", "WSC-6", "LRR-6", "MRR-5", "LRR-12")
BUDGETS = (0.0, 300.0, 449.0, 1000.0, 2500.0, 4500.0, 9000.0, 20000.0, 104500.0, 250000.0)


@pytest.fixture(scope="module")
def tiny():
    return load_scenario(ScenarioSpec(fixture="tiny"))


def sub_problem(library, scenario, ids):
    return build_problem(library.subset([library.position(i) for i in ids]), scenario)


@pytest.fixture(scope="module")
def mixed(library, tiny):
    return sub_problem(library, tiny, MIXED)


@pytest.fixture(scope="module")
def mixed_scores(mixed):
    """f(S) of all 2^10 suites of the mixed library (the brute-force oracle)."""
    ev = make_evaluator(mixed, "reference")
    n = mixed.n_sensors
    return {frozenset(c): ev.score(c) for r in range(n + 1) for c in itertools.combinations(range(n), r)}


def _positions(lib: SensorLibrary, ids) -> frozenset[int]:
    return frozenset(lib.position(i) for i in ids)


# ------------------------------------------------------------------------------- budget and steps


@pytest.mark.parametrize("rule", list(RULES))
def test_budget_never_exceeded_and_steps_are_consistent(mixed, mixed_scores, rule):
    lib = mixed.library
    ev = make_evaluator(mixed, "reference")
    for b in BUDGETS:
        res = greedy(ev, b, rule)
        assert res.cost_usd <= b
        assert res.cost_usd == pytest.approx(lib.cost(_positions(lib, res.suite)), abs=1e-9)
        prev_score, prev_suite = 0.0, ()
        for st in res.steps:
            pos = _positions(lib, st.suite)
            assert st.cost_usd <= b
            assert st.cost_usd == pytest.approx(lib.cost(pos), abs=1e-9)
            assert st.suite[:-1] == prev_suite and st.suite[-1] == st.pick  # one pick per step, in order
            assert st.score == pytest.approx(mixed_scores[pos], rel=1e-9, abs=1e-9)
            assert st.gain == pytest.approx(st.score - prev_score, rel=1e-9, abs=1e-9)
            assert st.gain > 0  # nothing uninformative is bought
            prev_score, prev_suite = st.score, st.suite
        assert res.suite == prev_suite and res.score == pytest.approx(prev_score)
        assert "LRR-12" not in res.suite  # it sees no landmark: never bought
        # stopping is justified: no unbought sensor both fits and adds information
        left = b - res.cost_usd
        cur = _positions(lib, res.suite)
        for i in set(range(len(lib))) - cur:
            if lib[i].cost_usd <= left:
                assert mixed_scores[cur | {i}] - mixed_scores[cur] <= 1e-9 * max(1.0, mixed_scores[cur])


def test_full_library_budget_respected(tiny_problem):
    ev = make_evaluator(tiny_problem, "reference")
    for b in (449.0, 3000.0, 110000.0):
        res = greedy(ev, b, "uniform")
        assert 0 < res.cost_usd <= b
        assert res.cost_usd == pytest.approx(tiny_problem.library.cost(_positions(tiny_problem.library, res.suite)))


def test_budget_below_cheapest_sensor_gives_empty_suite(mixed):
    ev = make_evaluator(mixed, "reference")
    for rule in RULES:
        res = greedy(ev, 448.99, rule)
        assert res.suite == () and res.steps == () and res.cost_usd == 0.0 and res.score == 0.0
        assert "below the cheapest sensor" in res.stop_reason and "$449" in res.stop_reason


@pytest.mark.parametrize("bad", [-1.0, -0.01, math.nan, math.inf, "110000", None, True])
def test_bad_budget_is_an_input_error(mixed, bad):
    ev = make_evaluator(mixed, "reference")
    with pytest.raises(InputError, match="budget"):
        greedy(ev, bad)
    with pytest.raises(InputError, match="budget"):
        run_greedy(mixed, bad)


def test_unknown_rule(mixed):
    with pytest.raises(InputError, match="unknown rule 'greediest'.*uniform"):
        run_greedy(mixed, 1000.0, "greediest")
    with pytest.raises(InputError, match="unknown rule 'greediest'.*best-of"):
        greedy(make_evaluator(mixed, "reference"), 1000.0, "greediest")


# -------------------------------------------------------------------------- brute-force optimum


def _budgeted_opt(scores: dict, lib: SensorLibrary, budget: float) -> float:
    return max(f for s, f in scores.items() if lib.cost(s) <= budget)


def test_best_of_meets_half_one_minus_inv_e_of_the_budgeted_optimum(mixed, mixed_scores):
    lib = mixed.library
    ev = make_evaluator(mixed, "reference")
    bound = (1 - 1 / math.e) / 2
    for b in BUDGETS[2:]:
        opt = _budgeted_opt(mixed_scores, lib, b)
        runs = {o: greedy(ev, b, o) for o in RULES}
        for o, r in runs.items():
            assert r.score <= opt + 1e-9 * opt, o  # nothing beats the optimum
        assert runs["best-of"].score >= bound * opt
        # best-of keeps the better of uniform and marginal
        assert runs["best-of"].score == pytest.approx(max(runs["uniform"].score, runs["marginal"].score), rel=1e-12)
        assert runs["best-of"].winning_rule in ("uniform", "marginal")


def test_best_of_keeps_the_higher_score_even_when_dearer():
    def run(score, cost):
        return GreedyResult("uniform", 1e6, ("a",), cost, score, (), "", 0, "x", True, "uniform")

    cheap, dear = run(100.0, 10.0), run(200.0, 20.0)
    assert better_run([cheap, dear]) is dear and better_run([dear, cheap]) is dear
    tie_dear, tie_cheap = run(100.0, 20.0), run(100.0 * (1 + 1e-12), 10.0)
    assert better_run([tie_dear, tie_cheap]) is tie_cheap  # equal to round-off: the cheaper


@pytest.mark.parametrize("model,cost", [("HD2K", 449.0), ("LRR", 1493.0)])
def test_uniform_greedy_meets_one_minus_inv_e_under_a_cardinality_limit(library, tiny, model, cost):
    """Ten sensors of one model: a budget of k units is a cardinality limit k (Nemhauser et al. 1978)."""
    ids = [f"{model}-{c}" for c in range(1, 11)]
    prob = sub_problem(library, tiny, ids)
    ev = make_evaluator(prob, "reference")
    oracle = make_evaluator(prob, "reference")
    for k in range(1, 5):
        res = greedy(ev, k * cost, "uniform")
        assert len(res.suite) <= k
        opt = max(oracle.score(c) for c in itertools.combinations(range(10), k))
        assert res.score <= opt * (1 + 1e-9)
        assert res.score >= (1 - 1 / math.e) * opt
        if k == 1:  # one pick: greedy is exact
            assert res.score == pytest.approx(opt, rel=1e-12)


def _oracle_greedy(scores: dict, lib: SensorLibrary, budget: float, rule: str) -> tuple[list[str], float]:
    """Plain greedy written out again on the table of every suite's score: J of each rule as the
    docs define it, ties within a relative 1e-9 to the cheaper sensor, then the smaller id."""
    suite: frozenset[int] = frozenset()
    cost, f, picks = 0.0, 0.0, []
    while True:
        cands = []
        for i in range(len(lib)):
            c = float(lib.costs[i])
            if i in suite or c > budget - cost + 1e-9:
                continue
            f_new = scores[suite | {i}]
            if f_new - f <= 1e-9 * max(1.0, abs(f)):
                continue  # adds nothing: never bought
            j = {"uniform": f_new, "cost-benefit": f_new / (cost + c), "marginal": (f_new - f) / c}[rule]
            cands.append((j, c, lib[i].id, i, f_new))
        if not cands:
            return picks, f
        top = max(x[0] for x in cands)
        _, c, sid, i, f = min((x for x in cands if x[0] >= top - 1e-9 * max(1.0, abs(top))), key=lambda x: (x[1], x[2]))
        picks.append(sid)
        suite, cost = suite | {i}, cost + c


@pytest.mark.parametrize("lazy", [True, False])
def test_every_rule_picks_what_plain_greedy_on_the_brute_force_table_picks(mixed, mixed_scores, lazy):
    """The engine (lazy or not) against the oracle above; best-of against the better oracle run."""
    lib = mixed.library
    ev = make_evaluator(mixed, "reference")
    for b in BUDGETS:
        oracle = {r: _oracle_greedy(mixed_scores, lib, b, r) for r in ("uniform", "cost-benefit", "marginal")}
        for r, (picks, f) in oracle.items():
            res = greedy(ev, b, r, lazy=lazy)
            assert [st.pick for st in res.steps] == picks, (r, b)
            assert res.score == pytest.approx(f, rel=1e-9, abs=1e-9)
            assert (res.rule, res.winning_rule) == (r, r)
        best = greedy(ev, b, "best-of", lazy=lazy)
        (pu, fu), (pm, fm) = oracle["uniform"], oracle["marginal"]
        assert best.score == pytest.approx(max(fu, fm), rel=1e-9, abs=1e-9)
        if abs(fm - fu) > 1e-9 * max(1.0, fu, fm):  # not tied: the better run's picks
            assert [st.pick for st in best.steps] == (pm if fm > fu else pu)
        assert best.rule == "best-of" and best.winning_rule in ("uniform", "marginal")


def test_the_registry_holds_rules_and_strategies_checked_in_one_place():
    assert list(RULES) == ["uniform", "cost-benefit", "marginal", "best-of"]
    assert RULES["best-of"].component_rules == ("uniform", "marginal")
    assert all(RULES[r].component_rules == (r,) for r in ("uniform", "cost-benefit", "marginal"))
    for bad in ("greediest", "", None, 3):
        with pytest.raises(
            InputError, match=f"unknown rule {bad!r}; available: uniform, cost-benefit, marginal, best-of"
        ):
            check_rule(bad)
    with pytest.raises(TypeError):
        RULES["mine"] = RULES["uniform"]  # type: ignore[index]


# --------------------------------------------------------------------------------- lazy, ties


def test_lazy_and_plain_greedy_pick_the_same_suites(library, tiny):
    ids = MIXED + ("HD2K-2", "HD2K-4", "HD2K-8", "HD2K-10", "LSC-8", "WSC-3", "MRR-7", "LRR-7", "LRR-9", "LSC-12")
    prob = sub_problem(library, tiny, ids)
    for rule in ("uniform", "marginal", "best-of"):
        for b in (1000.0, 5000.0, 12000.0, 110000.0):
            lazy_ev, plain_ev = (
                make_evaluator(prob),
                make_evaluator(prob),
            )  # the default engine: this tests the selector
            lazy = greedy(lazy_ev, b, rule, lazy=True)
            plain = greedy(plain_ev, b, rule, lazy=False)
            assert lazy.lazy and not plain.lazy
            assert [s.pick for s in lazy.steps] == [s.pick for s in plain.steps], (rule, b)
            assert lazy.score == pytest.approx(plain.score, rel=1e-12)
            assert lazy.n_evaluations <= plain.n_evaluations


def _twin(sensor, sensor_id, cost=None):
    model = sensor.model if cost is None else dataclasses.replace(sensor.model, cost_usd=cost)
    return dataclasses.replace(sensor, id=sensor_id, model=model)


def test_ties_break_cheaper_first_then_by_id(library, tiny):
    s = library[library.position("HD2K-12")]
    weak = library[library.position("LRR-6")]
    # identical sensors (same model, same mount) see the same landmarks with the same noise
    lib = SensorLibrary((weak, _twin(s, "CAM-b"), _twin(s, "CAM-a")))
    prob = build_problem(lib, tiny)
    ev = make_evaluator(prob, "reference")
    f = ev.scores_with((), [1, 2])
    assert f[0] == pytest.approx(f[1], rel=1e-12) and f[0] > ev.score([0])
    for rule in RULES:
        res = greedy(ev, 449.0, rule)
        assert res.suite == ("CAM-a",), rule  # equal cost: the smaller id, whatever the library order

    # same information, one twin cheaper: uniform (J = f) ties on f and takes the cheaper one,
    # even though its id sorts last and it comes last in the library
    lib2 = SensorLibrary((weak, _twin(s, "CAM-a"), _twin(s, "CAM-z", cost=400.0)))
    ev2 = make_evaluator(build_problem(lib2, tiny), "reference")
    for rule in RULES:
        res = greedy(ev2, 10000.0, rule)
        assert res.steps[0].pick == "CAM-z", rule


# ------------------------------------------------------------------------ determinism and JSON


def _without_timing(res):
    return results.dumps(dataclasses.replace(res, seconds=0.0))


def test_results_are_byte_identical_across_runs(mixed):
    for rule in RULES:
        a = run_greedy(mixed, 9000.0, rule, engine="reference")
        b = run_greedy(mixed, 9000.0, rule, engine="reference")
        assert _without_timing(a) == _without_timing(b)


def test_jobs_do_not_change_a_byte_of_the_result(suburb_problem):
    """--jobs 1 and --jobs 2: the same picks, scores and evaluation counts, with the fast engine's
    threads used whatever the route's size (the threaded path itself)."""
    from sensorsel.information.evaluators import FastEvaluator

    for rule in ("uniform", "best-of"):
        one = greedy(FastEvaluator(suburb_problem, jobs=1), 12_000.0, rule)
        two = greedy(FastEvaluator(suburb_problem, jobs=2, threads_from_keyframes=0), 12_000.0, rule)
        assert len(one.steps) >= 3
        assert _without_timing(one) == _without_timing(two)


def test_greedy_result_round_trips_through_json(mixed, tmp_path):
    res = run_greedy(mixed, 9000.0, "best-of", engine="reference")
    assert res.problem is not None and res.problem.scenario == "tiny" and res.steps
    path = results.save(res, tmp_path / "g.json")
    back = results.load(path, CertifiedGreedyResult)
    assert back == res
    plain = results.load(path, GreedyResult)  # any greedy result file reads as a GreedyResult
    assert plain.suite == res.suite and plain.winning_rule == res.winning_rule
    assert results.dumps(back) == results.dumps(res)


# ---------------------------------------------------------------------------------------- CLI


@pytest.fixture(scope="module")
def small_library(tmp_path_factory) -> Path:
    """The default library restricted to 4 models at 12 and 6 o'clock: 7 sensors, fast CLI runs."""
    data = yaml.safe_load(Path(default_library_path()).read_text())
    data["clock_positions"] = [12, 6]
    data["models"] = [m for m in data["models"] if m["code"] in ("MRL", "LRR", "HD2K", "WSC")]
    path = tmp_path_factory.mktemp("lib") / "small.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def _greedy(small_library, *args):
    return CliRunner().invoke(
        cli, ["greedy", "--fixture", "tiny", "--library", str(small_library), "--engine", "reference", *args]
    )


@pytest.mark.parametrize(
    "bad,msg", [("-5", "non-negative"), ("nan", "finite"), ("abc", "not a number"), ("1e400", "finite")]
)
def test_cli_bad_budget_exits_2(small_library, bad, msg):
    r = _greedy(small_library, f"--budget={bad}")
    assert r.exit_code == 2
    assert "--budget" in r.output and msg in r.output and bad in r.output
    assert "Traceback" not in r.output


def test_cli_budget_below_cheapest_sensor(small_library):
    # refused up front (one behaviour for "nothing fits" across the commands)
    r = _greedy(small_library, "--budget", "300")
    assert r.exit_code == 2 and r.stdout == ""
    assert "--budget $300 is below the cheapest sensor" in r.stderr and "$449" in r.stderr


def test_cli_greedy_table_and_json_output(small_library, tmp_path):
    out = tmp_path / "res" / "greedy.json"
    r = _greedy(small_library, "--budget", "$6,000", "--rule", "marginal", "-o", str(out))
    assert r.exit_code == 0, r.output
    res = results.load(out, GreedyResult)
    assert res.rule == "marginal" and res.budget_usd == 6000.0 and res.cost_usd <= 6000.0
    assert res.problem is not None and res.problem.scenario == "tiny" and res.problem.n_sensors == 7
    assert f"suite      {','.join(res.suite)}" in r.stdout
    assert f"${res.cost_usd:,.0f} of $6,000" in r.stdout
    for k, st in enumerate(res.steps, 1):  # one table row per pick, in order
        assert any(line.split()[:2] == [str(k), st.pick] for line in r.stdout.splitlines())
    j = _greedy(small_library, "--budget", "6000", "--rule", "marginal", "--json")
    assert j.exit_code == 0
    data = json.loads(j.stdout)
    assert data["suite"] == list(res.suite) and data["score"] == res.score
    assert len(data["steps"]) == len(res.steps)


def test_cli_jobs_1_and_2_write_the_same_bytes(tmp_path):
    """`sensorsel greedy --jobs 1` and `--jobs 2` (fast engine, certificate included): the same JSON
    apart from the wall times."""

    def run(jobs: str) -> dict:
        out = tmp_path / f"g{jobs}.json"
        r = CliRunner().invoke(cli, ["greedy", "--budget", "8000", "--jobs", jobs, "--quiet", "-o", str(out)])
        assert r.exit_code == 0, r.output
        data = json.loads(out.read_text())
        data.pop("seconds")
        data["certificate"].pop("seconds")
        return data

    one, two = run("1"), run("2")
    assert one["steps"] and one == two


def test_cli_rule_is_the_one_name_of_the_greedy_rule(small_library):
    new = _greedy(small_library, "--budget", "6000", "--rule", "marginal", "--json", "--no-certificate")
    assert new.exit_code == 0, new.output
    assert json.loads(new.stdout)["rule"] == "marginal"
    old = _greedy(small_library, "--budget", "6000", "--objective", "marginal", "--json", "--no-certificate")
    assert old.exit_code == 2 and "No such option '--objective'" in old.output
    bad = _greedy(small_library, "--budget", "6000", "--rule", "greediest")
    assert bad.exit_code == 2 and "unknown rule 'greediest'" in bad.output and "Traceback" not in bad.output
    help_text = CliRunner().invoke(cli, ["greedy", "--help"]).output
    assert "--rule" in help_text and "--objective" not in help_text and "best-of" in help_text
