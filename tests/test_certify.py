"""The certificate and the exact search against brute-force enumeration.

Oracles: every suite of a small library scored one by one (<= 10 sensors: <= 1,024 suites), and
every item set of a small knapsack. Checked: the knapsack solvers (DP, branch and bound, node-limited
bound) equal or bound the brute-force maximum; the exact search finds the brute-force optimum; the
upper bound U(S) is never below the optimum, at any suite; the greedy certificate lies in [0, 100%]
and brackets the optimum; results are deterministic and round-trip through JSON; the CLI.
"""

from __future__ import annotations

import functools
import itertools
import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scenario_strategies import problems

from sensorsel.api import run_greedy
from sensorsel.cli import cli
from sensorsel.designs.certify import (
    Certificate,
    CertifiedGreedyResult,
    KnapsackSolution,
    OptimumResult,
    SuiteBound,
    certificate,
    certify_greedy,
    cost_units,
    format_certificate,
    knapsack,
    optimal,
    suite_bound,
)
from sensorsel.designs.selection import RULES, greedy
from sensorsel.errors import InputError
from sensorsel.information.evaluators import make_evaluator
from sensorsel.io import results
from sensorsel.model.library import load_library
from sensorsel.model.problem import build_problem
from sensorsel.model.scenario import ScenarioSpec, load_scenario

REPO = Path(__file__).resolve().parents[1]
LIBRARY = load_library()
TOL = 1e-9
HYPOTHESIS = settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def close_or_above(a: float, b: float) -> bool:
    """a >= b up to round-off."""
    return a >= b - TOL * max(1.0, abs(b))


# ------------------------------------------------------------------------------------ knapsack


def brute_knapsack(values, costs_int, capacity_int) -> float:
    best = 0.0
    for r in range(len(values) + 1):
        for t in itertools.combinations(range(len(values)), r):
            if sum(costs_int[i] for i in t) <= capacity_int:
                best = max(best, float(sum(values[i] for i in t)))
    return best


@st.composite
def knapsack_instances(draw):
    """(values, integer costs, integer capacity, unit [$]): costs in whole units of $1, $449 or 1 cent."""
    n = draw(st.integers(0, 9))
    values = draw(st.lists(st.floats(-5.0, 100.0, allow_nan=False), min_size=n, max_size=n))
    costs = draw(st.lists(st.integers(1, 40), min_size=n, max_size=n))
    capacity = draw(st.integers(0, max(1, sum(costs))))
    unit = draw(st.sampled_from([1.0, 449.0, 0.01]))
    return values, costs, capacity, unit


def _check_solution(sol: KnapsackSolution, values, costs, capacity) -> None:
    assert sum(costs[i] for i in sol.chosen) <= capacity
    assert sol.achieved == pytest.approx(sum(values[i] for i in sol.chosen), abs=1e-9)
    assert all(values[i] > 0 for i in sol.chosen)


@HYPOTHESIS
@given(knapsack_instances())
def test_knapsack_dp_equals_brute_force(inst):
    values, costs, capacity, unit = inst
    sol = knapsack(values, [c * unit for c in costs], capacity * unit)
    best = brute_knapsack(values, costs, capacity)
    assert sol.exact and sol.method in ("dp", "trivial")
    assert sol.value == pytest.approx(best, abs=1e-9)
    assert sol.achieved == pytest.approx(best, abs=1e-9)
    _check_solution(sol, values, costs, capacity)


@HYPOTHESIS
@given(knapsack_instances())
def test_knapsack_branch_and_bound_equals_brute_force(inst):
    values, costs, capacity, unit = inst
    sol = knapsack(values, [c * unit for c in costs], capacity * unit, max_cells=0)
    best = brute_knapsack(values, costs, capacity)
    assert sol.exact and sol.method in ("branch-and-bound", "trivial")
    assert sol.value == pytest.approx(best, abs=1e-9)
    _check_solution(sol, values, costs, capacity)


@HYPOTHESIS
@given(knapsack_instances())
def test_knapsack_stopped_at_its_node_limit_still_bounds_the_maximum(inst):
    values, costs, capacity, unit = inst
    sol = knapsack(values, [c * unit for c in costs], capacity * unit, max_cells=0, max_nodes=1)
    best = brute_knapsack(values, costs, capacity)
    assert close_or_above(sol.value, best)
    assert sol.achieved <= best + 1e-9
    _check_solution(sol, values, costs, capacity)
    if not sol.exact:
        assert sol.method == "branch-and-bound (node limit: bound)"


def test_cost_units_use_the_gcd_and_decimal_scales():
    u = cost_units([2000, 3000, 4500], 10_000)
    assert (u.costs.tolist(), u.capacity, u.unit_usd, u.exact) == ([4, 6, 9], 20, 500.0, True)
    u = cost_units([449.5, 1.25], 10.0)  # cents: 44950 and 125 cents, gcd 25 cents
    assert (u.costs.tolist(), u.capacity, u.unit_usd, u.exact) == ([1798, 5], 40, 0.25, True)
    u = cost_units(LIBRARY.costs, 110_000)  # Table I: 1,493 and 449 are coprime -> $1
    assert (u.unit_usd, u.capacity, u.exact) == (1.0, 110_000, True)
    assert u.costs.tolist() == [int(c) for c in LIBRARY.costs]
    u = cost_units([1 / 3, 2 / 3], 1.0)  # not decimal: rounded down, a relaxation
    assert (
        not u.exact
        and u.capacity * u.unit_usd <= 1.0
        and all(c * u.unit_usd <= x for c, x in zip(u.costs, [1 / 3, 2 / 3]))
    )


def test_knapsack_with_non_decimal_costs_is_still_an_upper_bound():
    values, costs = [3.0, 4.0, 5.0], [1 / 3, 1 / 3, 1 / 3 + 1e-9]
    sol = knapsack(values, costs, 2 / 3)
    assert not sol.exact and sol.value >= 9.0  # the true best is 4 + 5 = 9


def test_knapsack_input_checks():
    with pytest.raises(InputError, match="2 values but 1 costs"):
        knapsack([1.0, 2.0], [1.0], 3.0)
    with pytest.raises(InputError, match="capacity"):
        knapsack([1.0], [1.0], -1.0)
    with pytest.raises(InputError, match="values must be finite"):
        knapsack([math.nan], [1.0], 1.0)


# ------------------------------------------------------------------ small libraries, brute force

SMALL = {
    # <= 10 sensors each, of all types; the tiny fixture (10 keyframes, 37 landmarks)
    "mixed10": ["LRL-roof", "MRL-roof", "LRR-12", "LRR-3", "LRR-6", "WSC-12", "WSC-3", "HD2K-12", "HD2K-6", "LSC-12"],
    "cheap8": ["MRR-12", "MRR-3", "LRR-9", "WSC-6", "WSC-9", "HD2K-3", "HD2K-9", "LSC-6"],
    "lidars6": ["LRL-roof", "MRL-roof", "MRR-6", "LRR-12", "HD2K-4", "LSC-8"],
}
BUDGETS = {
    "mixed10": [0.0, 449.0, 3000.0, 6000.0, 12_000.0, 104_000.0, 110_000.0],
    "cheap8": [1500.0, 5000.0, 9000.0, 20_000.0],
    "lidars6": [4449.0, 100_000.0, 104_500.0],
}
CASES = [(name, b) for name in SMALL for b in BUDGETS[name]]


@functools.cache
def small_problem(name: str):
    lib = LIBRARY.subset([LIBRARY.position(i) for i in SMALL[name]])
    return build_problem(lib, load_scenario(ScenarioSpec(fixture="tiny")))


def all_scores(problem) -> dict[tuple[int, ...], float]:
    """f of every suite of the library, scored one by one (a fresh reference evaluator)."""
    ev = make_evaluator(problem, "reference")
    n = problem.n_sensors
    return {s: (ev.score(s) if s else 0.0) for r in range(n + 1) for s in itertools.combinations(range(n), r)}


@functools.cache
def small_scores(name: str) -> dict[tuple[int, ...], float]:
    return all_scores(small_problem(name))


def brute_optimum(problem, scores, budget, exclude=frozenset()) -> tuple[float, tuple[int, ...]]:
    lib = problem.library
    feasible = [(f, s) for s, f in scores.items() if lib.cost(s) <= budget + 1e-9 and not set(s) & exclude]
    return max(feasible, key=lambda fs: fs[0])


@pytest.mark.parametrize("name, budget", CASES)
def test_exact_search_equals_brute_force(name, budget):
    problem = small_problem(name)
    opt, _ = brute_optimum(problem, small_scores(name), budget)
    res = optimal(make_evaluator(problem, "reference"), budget)
    assert res.proved_optimal, res.stop_reason
    best_of = greedy(make_evaluator(problem, "reference"), budget, "best-of")  # the incumbent it started from
    assert (res.greedy_suite, res.greedy_score, res.greedy_rule) == (
        best_of.suite,
        best_of.score,
        f"best-of ({best_of.winning_rule})",
    )
    assert res.score == pytest.approx(opt, rel=TOL, abs=TOL)
    positions = problem.library.parse_suite(",".join(res.suite)) if res.suite else ()
    assert res.cost_usd == problem.library.cost(positions) <= budget
    assert small_scores(name)[positions] == pytest.approx(res.score, rel=TOL, abs=TOL)
    assert res.upper_bound == res.score and res.gap == 0.0
    assert res.greedy_score <= res.score + TOL * max(1.0, res.score)
    assert close_or_above(res.greedy_certificate_bound, opt)


@pytest.mark.parametrize("name, budget", [("mixed10", 6000.0), ("mixed10", 110_000.0), ("cheap8", 9000.0)])
def test_exact_search_with_lp_bounds_equals_brute_force(name, budget):
    """When the knapsack tables are too large, the nodes are bounded by the LP relaxation (looser, still valid)."""
    problem = small_problem(name)
    opt, _ = brute_optimum(problem, small_scores(name), budget)
    res = optimal(make_evaluator(problem, "reference"), budget, max_cells=0)
    assert res.proved_optimal and res.bound_method in ("fractional", "none")
    assert res.score == pytest.approx(opt, rel=TOL, abs=TOL)
    cert = certificate(
        make_evaluator(problem, "reference"),
        greedy(make_evaluator(problem, "reference"), budget, "marginal"),
        max_cells=0,
    )
    assert close_or_above(cert.bound, opt) and "dp" not in cert.knapsack_method.split("+")


@pytest.mark.parametrize("name, budget", CASES)
def test_greedy_certificate_brackets_the_brute_force_optimum(name, budget):
    problem = small_problem(name)
    opt, _ = brute_optimum(problem, small_scores(name), budget)
    ev = make_evaluator(problem, "reference")
    _ = ev.baseline_logdet  # computed once per evaluator; not part of any sweep below
    lib = problem.library
    for rule in sorted(RULES):
        res = greedy(ev, budget, rule)
        full = certificate(ev, res, prune=False)
        cert = certificate(ev, res)
        for c in (full, cert):
            assert 0.0 <= c.ratio <= 1.0 and 0.0 <= c.percent_of_best <= 100.0
            assert c.score == res.score <= opt + TOL * max(1.0, opt)
            assert close_or_above(c.bound, opt), (rule, c.bound, opt)
            assert len(c.step_bounds) == len(res.steps) + 1
            swept = [b for b in c.step_bounds if b is not None]
            assert all(close_or_above(b, opt) for b in swept)  # every intermediate bound is valid
            assert c.bound == max(min(swept), c.score)  # the certificate keeps the smallest
            assert c.step_bounds[c.bound_step] == min(swept)
            assert c.gap == pytest.approx(c.bound - c.score)
            assert c.ratio <= opt / c.bound + TOL if c.bound > 0 else c.ratio == 1.0
        # without pruning: every step swept, one sweep of the affordable sensors outside each suite
        assert None not in full.step_bounds
        affordable = {i for i in range(len(lib)) if lib.costs[i] <= budget}
        suites = [set()] + [set(lib.parse_suite(",".join(st_.suite))) for st_ in res.steps]
        assert full.n_evaluations == sum(len(affordable - s) for s in suites)
        # pruning skips only steps that could not lower the bound: the same certificate, for less
        assert cert.bound == pytest.approx(full.bound, rel=TOL, abs=TOL)
        assert cert.n_evaluations <= full.n_evaluations
        for k, b in enumerate(cert.step_bounds):
            assert b is None or b == full.step_bounds[k]
            if b is None:
                assert close_or_above(full.step_bounds[k], cert.bound)


def test_pruning_skips_sweeps_on_the_small_cases():
    """The skipped-step path of the certificate is exercised by the cases above (it skips about half
    of the steps there), so their equality with the unpruned certificate means something."""
    skipped = total = 0
    for name, budget in CASES:
        ev = make_evaluator(small_problem(name), "reference")
        for rule in ("uniform", "marginal"):
            steps = certificate(ev, greedy(ev, budget, rule)).step_bounds
            skipped += sum(b is None for b in steps)
            total += len(steps)
    assert total > 0 and skipped >= total // 4


@pytest.mark.parametrize("name", sorted(SMALL))
def test_bound_at_any_suite_is_never_below_the_optimum(name):
    problem = small_problem(name)
    scores = small_scores(name)
    ev = make_evaluator(problem, "reference")
    lib = problem.library
    rng = np.random.default_rng(7)
    suites = [s for s in scores if len(s) <= 1] + [
        tuple(sorted(rng.choice(len(lib), size=k, replace=False).tolist()))
        for k in (2, 3, 5, len(lib) - 1)
        for _ in range(3)
    ]
    for budget in BUDGETS[name]:
        opt, _ = brute_optimum(problem, scores, budget)
        for s in suites:  # even suites above the budget: the bound holds for any S
            b = suite_bound(ev, s, budget, score=scores[s])
            assert close_or_above(b.bound, opt), (s, budget, b.bound, opt)
            assert b.score == scores[s] and b.knapsack_exact
            # the knapsack's sensors are outside S and fit the budget
            ks = lib.parse_suite(",".join(b.knapsack_suite)) if b.knapsack_suite else ()
            assert not set(ks) & set(s) and lib.cost(ks) <= budget


def test_capacity_must_be_the_whole_budget_not_what_is_left():
    """With capacity B - Cost(S) the 'bound' at a greedy suite can fall below the optimum.

    At $104,000, marginal greedy buys cheap sensors first; the optimum is LRL-roof + MRL-roof ($104,000),
    which no longer fits beside them. The optimum need not contain S, so the sensors it adds to S may
    use the whole budget: certify uses capacity B, and its bound holds.
    """
    name, budget = "mixed10", 104_000.0
    problem = small_problem(name)
    opt, _ = brute_optimum(problem, small_scores(name), budget)
    ev = make_evaluator(problem, "reference")
    res = greedy(ev, budget, "marginal")
    lib = problem.library
    too_low = []
    for st_ in res.steps:
        s = lib.parse_suite(",".join(st_.suite))
        gains = np.maximum(ev.scores_with(s, [e for e in range(len(lib)) if e not in s]) - st_.score, 0.0)
        rest = [e for e in range(len(lib)) if e not in s]
        wrong = st_.score + knapsack(gains, lib.costs[rest], budget - st_.cost_usd).value
        too_low.append(wrong < opt - 1e-6)
        assert close_or_above(suite_bound(ev, s, budget, score=st_.score).bound, opt)
    assert any(too_low)


@HYPOTHESIS
@given(problem=problems(LIBRARY, 3, 7), budget_units=st.integers(0, 60))
def test_exact_search_and_bounds_on_random_scenarios(problem, budget_units):
    budget = budget_units * 1000.0 + (100_000.0 if budget_units > 40 else 0.0)
    scores = all_scores(problem)
    opt, _ = brute_optimum(problem, scores, budget)
    ev = make_evaluator(problem, "reference")
    res = optimal(ev, budget)
    assert res.proved_optimal and res.score == pytest.approx(opt, rel=TOL, abs=TOL)
    cert = certificate(ev, greedy(ev, budget, "marginal"))
    assert 0.0 <= cert.ratio <= 1.0 and close_or_above(cert.bound, opt) and cert.score <= opt + TOL * max(1.0, opt)


def test_exact_search_respects_excluded_sensors():
    name, budget = "mixed10", 110_000.0
    problem = small_problem(name)
    lib = problem.library
    exclude = frozenset({lib.position("LRL-roof"), lib.position("WSC-3")})
    opt, _ = brute_optimum(problem, small_scores(name), budget, exclude)
    res = optimal(make_evaluator(problem, "reference"), budget, exclude=exclude)
    assert res.proved_optimal and res.score == pytest.approx(opt, rel=TOL)
    assert not {"LRL-roof", "WSC-3"} & set(res.suite)


@pytest.mark.parametrize("name, budget", [c for c in CASES if c[1] > 0])
def test_node_limit_gives_the_best_found_and_a_valid_gap(name, budget):
    problem = small_problem(name)
    opt, _ = brute_optimum(problem, small_scores(name), budget)
    full = optimal(make_evaluator(problem, "reference"), budget)
    res = optimal(make_evaluator(problem, "reference"), budget, max_nodes=1)
    assert res.n_nodes <= 1
    assert res.score <= opt + TOL * max(1.0, opt)
    assert close_or_above(res.upper_bound, opt)
    assert res.gap == pytest.approx(res.upper_bound - res.score)
    assert res.gap_percent == pytest.approx(100 * res.gap / res.upper_bound if res.upper_bound > 0 else 0.0)
    if full.n_nodes > 1:  # the limited run is the first node of the full one
        assert not res.proved_optimal and "node limit (1)" in res.stop_reason
    else:
        assert res.proved_optimal


def test_a_proof_that_needs_several_nodes_is_among_the_cases():
    """Keeps the node-limit test above honest: at least one case cannot be proved with one node."""
    assert any(optimal(make_evaluator(small_problem(n), "reference"), b).n_nodes > 1 for n, b in CASES[:7])


def test_budget_below_every_sensor():
    problem = small_problem("cheap8")
    ev = make_evaluator(problem, "reference")
    res = greedy(ev, 100.0, "uniform")
    cert = certificate(ev, res)
    assert (cert.score, cert.bound, cert.ratio, cert.bound_step) == (0.0, 0.0, 1.0, 0)
    opt = optimal(ev, 100.0)
    assert opt.proved_optimal and opt.suite == () and opt.score == 0.0


# --------------------------------------------------------------- determinism, JSON, input errors


def _without_seconds(text: str) -> dict:
    data = json.loads(text)
    data.pop("seconds")
    return data


def test_results_are_deterministic_and_round_trip(tmp_path):
    problem = small_problem("mixed10")
    info = problem.info
    runs = []
    for _ in range(2):
        ev = make_evaluator(problem, "reference")
        g = greedy(ev, 12_000.0, "best-of", info=info)
        runs.append((certificate(ev, g), optimal(ev, 12_000.0, info=info)))
    for a, b in zip(*runs):
        assert _without_seconds(results.dumps(a)) == _without_seconds(results.dumps(b))
    cert, opt = runs[0]
    for obj, cls in ((cert, Certificate), (opt, OptimumResult)):
        path = results.save(obj, tmp_path / f"{cls.__name__}.json")
        assert results.load(path, cls) == obj
    ev = make_evaluator(problem, "reference")
    sb = suite_bound(ev, (0, 3), 12_000.0)
    assert results.load(results.save(sb, tmp_path / "sb.json"), SuiteBound) == sb
    ks = knapsack([1.0, 2.0, 3.0], [1.0, 1.0, 2.0], 2.0)
    assert results.load(results.save(ks, tmp_path / "ks.json"), KnapsackSolution) == ks


def test_input_errors():
    problem = small_problem("cheap8")
    ev = make_evaluator(problem, "reference")
    with pytest.raises(InputError, match="budget"):
        optimal(ev, -5.0)
    with pytest.raises(InputError, match="max_nodes"):
        optimal(ev, 5000.0, max_nodes=0)
    other = small_problem("lidars6")
    foreign = greedy(make_evaluator(other, "reference"), 110_000.0, "uniform")
    assert "LRL-roof" in foreign.suite  # not in cheap8
    with pytest.raises(InputError, match="does not belong to this library"):
        certificate(ev, foreign)
    with pytest.raises(InputError, match="does not belong to this library"):
        optimal(ev, 110_000.0, incumbent=foreign)
    with pytest.raises(InputError, match="incumbent greedy run has budget"):
        optimal(ev, 9_000.0, incumbent=greedy(ev, 5_000.0, "uniform"))


def test_exact_search_starts_from_any_registered_rule():
    """Every rule of the registry gives the incumbent; a strategy is labelled with the run it kept."""
    name, budget = "cheap8", 9000.0
    problem = small_problem(name)
    opt, _ = brute_optimum(problem, small_scores(name), budget)
    for rule in RULES:
        ev = make_evaluator(problem, "reference")
        res = optimal(ev, budget, rule=rule)
        g = greedy(make_evaluator(problem, "reference"), budget, rule)
        assert res.proved_optimal and res.score == pytest.approx(opt, rel=TOL)
        assert res.greedy_rule == (rule if g.winning_rule == rule else f"{rule} ({g.winning_rule})")
        assert res.greedy_suite == g.suite and close_or_above(res.greedy_certificate_bound, opt)
    with pytest.raises(InputError, match="unknown rule 'nope'"):
        optimal(make_evaluator(problem, "reference"), budget, rule="nope")


def test_certificate_line():
    problem = small_problem("mixed10")
    ev = make_evaluator(problem, "reference")
    res = greedy(ev, 6000.0, "best-of")
    cert = certify_greedy(ev, res)
    line = format_certificate(cert)
    assert line.startswith("certificate: at least ") and "of the best possible suite under $6,000" in line
    shown = float(line.split("at least ")[1].split("%")[0])
    assert shown <= cert.percent_of_best and cert.percent_of_best - shown < 0.1 + 1e-9
    # never rounded up to 100
    almost = Certificate(**{**cert.__dict__, "ratio": 0.99996, "percent_of_best": 99.996})
    assert "at least 99.9%" in format_certificate(almost)


def test_run_greedy_carries_its_certificate_and_it_round_trips(tmp_path):
    """run_greedy(certify=True): the same certificate as certifying the run afterwards, above the
    brute-force optimum, saved and loaded with the greedy result."""
    problem = small_problem("mixed10")
    opt, _ = brute_optimum(problem, small_scores("mixed10"), 6000.0)
    res = run_greedy(problem, 6000.0, "best-of", engine="reference", certify=True)
    plain = run_greedy(problem, 6000.0, "best-of", engine="reference")
    assert plain.certificate is None and res.suite == plain.suite
    cert = res.certificate
    assert cert is not None
    again = certificate(make_evaluator(problem, "reference"), plain)
    assert (cert.score, cert.bound, cert.step_bounds) == (again.score, again.bound, again.step_bounds)
    assert close_or_above(cert.bound, opt) and cert.score == res.score
    loaded = results.load(results.save(res, tmp_path / "g.json"), CertifiedGreedyResult)
    assert loaded == res


# -------------------------------------------------------------------------------------- the CLI


def test_cli_greedy_prints_the_certificate_line_and_saves_it(tmp_path):
    lib_path = _small_library_yaml(tmp_path)
    base = [
        "greedy",
        "--fixture",
        "tiny",
        "--library",
        str(lib_path),
        "--budget",
        "5000",
        "--engine",
        "reference",
        "--jobs",
        "1",
        "--quiet",
    ]
    r = CliRunner().invoke(cli, base + ["-o", str(tmp_path / "g.json")])
    assert r.exit_code == 0, r.output
    res = results.load(tmp_path / "g.json", CertifiedGreedyResult)
    assert res.certificate is not None
    assert format_certificate(res.certificate) in r.output.splitlines()
    problem = build_problem(load_library(lib_path), load_scenario(ScenarioSpec(fixture="tiny")))
    opt, _ = brute_optimum(problem, all_scores(problem), 5000.0)
    assert close_or_above(res.certificate.bound, opt) and res.certificate.score == res.score <= opt + TOL * opt
    r = CliRunner().invoke(cli, base + ["--no-certificate", "--json"])
    assert r.exit_code == 0, r.output
    assert json.loads(r.output)["certificate"] is None and "certificate:" not in r.output


def _small_library_yaml(tmp_path: Path) -> Path:
    data = yaml.safe_load((REPO / "configs" / "sensor_library.yaml").read_text())
    data["clock_positions"] = [12, 6]
    data["models"] = [m for m in data["models"] if m["code"] in ("LRL", "MRL", "LRR", "HD2K")]
    path = tmp_path / "small.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path  # LRL-roof, LRR-12, LRR-6, MRL-roof, HD2K-12, HD2K-6


def test_cli_optimal_prints_the_proved_optimum_and_writes_json(tmp_path):
    lib_path = _small_library_yaml(tmp_path)
    out = tmp_path / "opt.json"
    r = CliRunner().invoke(
        cli,
        [
            "optimal",
            "--fixture",
            "tiny",
            "--library",
            str(lib_path),
            "--budget",
            "5000",
            "--engine",
            "reference",
            "--jobs",
            "1",
            "-q",
            "-o",
            str(out),
        ],
    )
    assert r.exit_code == 0, r.output
    assert "[proved optimal]" in r.output and "greedy     best-of" in r.output and "% of the optimum" in r.output
    res = results.load(out, OptimumResult)
    problem = build_problem(load_library(lib_path), load_scenario(ScenarioSpec(fixture="tiny")))
    opt, _ = brute_optimum(problem, all_scores(problem), 5000.0)
    assert res.proved_optimal and res.score == pytest.approx(opt, rel=TOL)
    assert f"f = {res.score:.3f} nats" in r.output
    assert res.problem is not None and res.problem.n_sensors == 6


def test_cli_optimal_node_limit_reports_the_gap(tmp_path):
    r = CliRunner().invoke(
        cli,
        [
            "optimal",
            "--fixture",
            "tiny",
            "--budget",
            "3000",
            "--max-nodes",
            "1",
            "--engine",
            "reference",
            "--jobs",
            "1",
            "--json",
        ],
    )
    assert r.exit_code == 0, r.output
    data = json.loads(r.output)
    assert data["n_nodes"] == 1 and not data["proved_optimal"] and data["upper_bound"] >= data["score"]
    r = CliRunner().invoke(
        cli,
        [
            "optimal",
            "--fixture",
            "tiny",
            "--budget",
            "3000",
            "--max-nodes",
            "1",
            "--engine",
            "reference",
            "--jobs",
            "1",
            "-q",
        ],
    )
    assert "[not proved: node limit (1) reached]" in r.output and "above the best found" in r.output


@pytest.mark.parametrize(
    "args, message",
    [
        (["--budget", "-1"], "budget must be a finite, non-negative number"),
        (["--budget", "nan"], "budget must be a finite, non-negative number"),
        (["--budget", "100", "--max-nodes", "0"], "0 is not in the range x>=1"),
        (["--budget", "100", "--engine", "nope"], "Invalid value for '--engine'"),
    ],
)
def test_cli_optimal_bad_input_is_one_line(args, message):
    r = CliRunner().invoke(cli, ["optimal", "--fixture", "tiny", "-q"] + args)
    assert r.exit_code == 2
    assert message in r.output
    assert "Traceback" not in r.output


def test_reduced_library_is_one_model_per_type_of_table_i():
    reduced = load_library(REPO / "configs" / "reduced_library.yaml")
    assert len(reduced) == 25
    assert sorted({s.model.type for s in reduced}) == ["lidar", "radar", "stereo"]
    assert len({s.model.code for s in reduced}) == 3
    for s in reduced:  # same ids, paper indices, models and costs as the full library
        assert s == LIBRARY[LIBRARY.position(s.id)]


def test_cli_certify_runs_greedy_or_reads_its_result(tmp_path):
    lib_path = _small_library_yaml(tmp_path)
    base = ["--fixture", "tiny", "--library", str(lib_path), "--engine", "reference", "--jobs", "1"]
    r = CliRunner().invoke(
        cli, ["certify", *base, "--budget", "5000", "--rule", "marginal", "-q", "-o", str(tmp_path / "c.json")]
    )
    assert r.exit_code == 0, r.output
    cert = results.load(tmp_path / "c.json", Certificate)
    assert format_certificate(cert) in r.output
    problem = build_problem(load_library(lib_path), load_scenario(ScenarioSpec(fixture="tiny")))
    ev = make_evaluator(problem, "reference")
    expected = certificate(ev, greedy(ev, 5000.0, "marginal"))
    assert (cert.score, cert.bound, cert.step_bounds) == (expected.score, expected.bound, expected.step_bounds)
    # certify a saved greedy result: the same certificate
    r = CliRunner().invoke(
        cli, ["greedy", *base, "--budget", "5000", "--rule", "marginal", "--quiet", "-o", str(tmp_path / "g.json")]
    )
    assert r.exit_code == 0, r.output
    r = CliRunner().invoke(cli, ["certify", *base, "--suite", str(tmp_path / "g.json"), "--json"])
    assert r.exit_code == 0, r.output
    assert json.loads(r.output)["bound"] == expected.bound


@pytest.mark.parametrize(
    "extra, message",
    [
        ([], "give --suite FILE"),
        (["--budget", "100", "--suite", "x.json"], "not both"),
        (["--suite", "missing.json"], "missing.json: file not found"),
        (["--budget", "-3"], "budget must be a finite, non-negative number"),
    ],
)
def test_cli_certify_bad_input_is_one_line(extra, message):
    r = CliRunner().invoke(cli, ["certify", "--fixture", "tiny", "-q", "--engine", "reference"] + extra)
    assert r.exit_code == 2 and message in r.output and "Traceback" not in r.output


def test_cli_certify_refuses_a_result_of_another_scenario(tmp_path):
    problem = small_problem("cheap8")
    res = greedy(make_evaluator(problem, "reference"), 3000.0, "uniform", info=problem.info)
    path = results.save(res, tmp_path / "g.json")
    r = CliRunner().invoke(cli, ["certify", "--fixture", "suburb", "-q", "--suite", str(path)])
    assert (
        r.exit_code == 2 and "computed on another problem (another library" in r.output and "another route" in r.output
    )
