"""Constraints besides the budget against brute-force enumeration.

Oracles: every suite of a small library (10 sensors, 1,024 suites) scored one by one with a fresh
reference evaluator, filtered by the request's limits written out by hand (resource totals, slot
counts, the number of sensors, required and excluded sensors); and every item set of a small
integer program. Checked, on seeded random requests (resource limits, mounting slots from a
library file that ``extends`` the stock one, ``max_sensors``, required, owned and excluded
sensors): every greedy suite (all four rules) is feasible and holds the required sensors; the
exact search equals the brute-force optimum; the certificate's bound is never below it; the milp
bound is exact (or, stopped early, never below) on random integer programs; the CLI refuses
infeasible requests in one line naming the constraint, and a result of other resources or slots.
"""

from __future__ import annotations

import functools
import itertools
import json
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from sensorsel.api import certify_result, run_optimal
from sensorsel.cli import cli
from sensorsel.designs.certify import Certificate, OptimumResult, certificate, optimal, packing_bound
from sensorsel.designs.selection import RULES, greedy
from sensorsel.errors import InputError
from sensorsel.information.evaluators import make_evaluator
from sensorsel.io import results
from sensorsel.model.constraints import Constraints, feasible_set
from sensorsel.model.library import load_library
from sensorsel.model.problem import build_problem
from sensorsel.model.scenario import ScenarioSpec, load_scenario

REPO = Path(__file__).resolve().parents[1]
STOCK = REPO / "configs" / "sensor_library.yaml"
REDUCED = REPO / "configs" / "reduced_library.yaml"
TOL = 1e-9
#: Ten sensors sharing places, so that the slots (one LiDAR on the roof; one radar and one camera
#: per clock position) bind: two LiDARs on the roof, two radars and two cameras at 12 o'clock.
IDS = ["LRL-roof", "MRL-roof", "LRR-12", "MRR-12", "WSC-12", "HD2K-12", "LRR-3", "WSC-3", "HD2K-6", "LSC-6"]
SLOTS = {"roof": {"lidar": 1}, "clock": {"radar": 1, "stereo": 1}}
RESOURCES = ("power_w", "mass_kg", "data_rate_mbps")


def _write_slotted(folder: Path) -> Path:
    path = folder / "car.yaml"
    path.write_text(yaml.safe_dump({"extends": str(STOCK), "slots": SLOTS}), encoding="utf-8")
    return path


@functools.cache
def slotted_library(folder: str):
    full = load_library(_write_slotted(Path(folder)))
    return full.subset([full.position(i) for i in IDS])


@pytest.fixture(scope="module")
def problem(tmp_path_factory):
    lib = slotted_library(str(tmp_path_factory.mktemp("lib")))
    return build_problem(lib, load_scenario(ScenarioSpec(fixture="tiny")))


@pytest.fixture(scope="module")
def scores(problem):
    """f of every suite, scored one by one by a fresh reference evaluator."""
    ev = make_evaluator(problem, "reference")
    n = problem.n_sensors
    return {s: (ev.score(s) if s else 0.0) for r in range(n + 1) for s in itertools.combinations(range(n), r)}


def allowed(lib, budget: float, c: Constraints, suite: tuple[int, ...]) -> bool:
    """The request written out by hand (independent of FeasibleSet's matrix)."""
    ids = {lib.ids[i] for i in suite}
    if not set(c.require) <= ids or ids & set(c.exclude):
        return False
    price = sum(lib[i].model.cost_usd for i in suite if not (c.owned and lib.ids[i] in c.require))
    if price > budget + 1e-6:
        return False
    for name, limit in c.limits:
        if sum(dict(lib[i].model.resources)[name] for i in suite) > limit * (1 + 1e-9) + 1e-9:
            return False
    if c.max_sensors is not None and len(suite) > c.max_sensors:
        return False
    if c.slots:
        for slot in lib.slots:
            if len(set(slot.members) & set(suite)) > slot.capacity:
                return False
    return True


def brute_optimum(lib, scores, budget: float, c: Constraints) -> float:
    return max(f for s, f in scores.items() if allowed(lib, budget, c, s))


def random_requests(lib, n: int, seed: int) -> list[tuple[float, Constraints]]:
    """``n`` seeded random requests the library can meet (those it cannot are skipped here; the
    CLI tests cover them)."""
    rng = np.random.default_rng(seed)
    totals = {r: float(lib.resource(r).sum()) for r in RESOURCES}
    out: list[tuple[float, Constraints]] = []
    while len(out) < n:
        names = [r for r in RESOURCES if rng.random() < 0.5]
        limits = {r: round(float(rng.uniform(0.1, 0.6)) * totals[r], 2) for r in names}
        picks = rng.permutation(len(lib))
        require = [lib.ids[int(picks[0])]] if rng.random() < 0.5 else []
        exclude = [lib.ids[int(picks[1])]] if rng.random() < 0.4 else []
        c = Constraints.of(
            limits=limits,
            slots=bool(rng.random() < 0.7),
            require=require,
            owned=bool(require) and bool(rng.random() < 0.5),
            exclude=exclude,
            max_sensors=int(rng.integers(1, 6)) if rng.random() < 0.4 else None,
        )
        budget = float(rng.choice([3_000.0, 9_000.0, 20_000.0, 110_000.0]))
        try:
            feasible_set(lib, budget, c)
        except InputError:
            continue
        out.append((budget, c))
    return out


def test_feasible_set_matches_the_request_written_out(problem, scores):
    lib = problem.library
    for budget, c in random_requests(lib, 12, seed=3):
        feas = feasible_set(lib, budget, c)
        assert all(feas.fits(s) == allowed(lib, budget, c, s) for s in scores), c.describe()


def test_slots_from_the_extended_file_bind(problem):
    lib = problem.library
    feas = feasible_set(lib, 200_000.0, Constraints.of())
    two_lidars = lib.resolve_suite(["LRL-roof", "MRL-roof"])
    assert not feas.fits(two_lidars) and feasible_set(lib, 200_000.0, Constraints.of(slots=False)).fits(two_lidars)
    assert feas.fits(lib.resolve_suite(["LRL-roof", "LRR-12", "WSC-12"]))


@pytest.mark.parametrize("seed", [0, 1])
def test_random_requests_greedy_feasible_exact_equals_brute_force_bound_above(problem, scores, seed):
    lib = problem.library
    methods: set[str] = set()
    for budget, c in random_requests(lib, 4, seed=seed):
        feas = feasible_set(lib, budget, c)
        opt = brute_optimum(lib, scores, budget, c)
        for rule in RULES:
            g = greedy(make_evaluator(problem, "reference"), budget, rule, constraints=c)
            suite = lib.resolve_suite(g.suite)
            assert feas.fits(suite), (rule, c.describe(), g.suite, feas.violations(suite))
            assert set(c.require) <= set(g.suite)
            assert g.score <= opt + TOL * max(1.0, opt)
            cert = certificate(make_evaluator(problem, "reference"), g)
            assert cert.bound >= opt - TOL * max(1.0, opt), (rule, c.describe(), cert.bound, opt)
            methods.add(cert.knapsack_method)
        res = optimal(make_evaluator(problem, "reference"), budget, constraints=c)
        assert res.proved_optimal, c.describe()
        assert res.score == pytest.approx(opt, rel=TOL, abs=TOL)
        assert feas.fits(lib.resolve_suite(res.suite)) and set(c.require) <= set(res.suite)
        assert res.upper_bound >= opt - TOL * max(1.0, opt)
    assert any("milp" in m for m in methods), methods  # the integer program was exercised


def test_owned_required_sensor_without_rows_is_recorded_and_bounded(problem, scores):
    """Required and owned, no other limit: the budget is the only row, but the request is not the
    paper's (the owned LiDAR is free): the result must record it and the bound must cover suites
    whose prices sum above the budget."""
    lib = problem.library
    c = Constraints.of(slots=False, require=["LRL-roof"], owned=True)
    budget = 5_000.0
    opt = brute_optimum(lib, scores, budget, c)
    assert opt > brute_optimum(lib, scores, budget, Constraints.of(slots=False))  # owning it matters
    for rule in ("uniform", "best-of"):
        g = greedy(make_evaluator(problem, "reference"), budget, rule, constraints=c)
        assert g.constraints is not None and g.constraints.require == ("LRL-roof",) and g.constraints.owned
        assert "LRL-roof" in g.suite and g.cost_usd <= budget
        cert = certificate(make_evaluator(problem, "reference"), g)
        assert cert.constraints == g.constraints and cert.knapsack_method != "dp"
        assert cert.bound >= opt - TOL * max(1.0, opt)
    res = optimal(make_evaluator(problem, "reference"), budget, constraints=c)
    assert res.score == pytest.approx(opt, rel=TOL) and res.constraints is not None and "LRL-roof" in res.suite


def test_budget_alone_keeps_the_knapsack_path(problem):
    """Constraints(slots=False) with nothing else is the paper's problem: the same bytes as no
    constraints at all (the published results' path), and nothing recorded."""
    ev = make_evaluator(problem, "reference")
    for budget in (3_000.0, 104_000.0):
        g = greedy(ev, budget, "uniform")
        g2 = greedy(ev, budget, "uniform", constraints=Constraints.of(slots=False))
        assert g2.constraints is None and g.suite == g2.suite
        a, b = certificate(ev, g), certificate(ev, g2)
        assert "milp" not in a.knapsack_method and a.constraints is None
        assert (a.bound, a.step_bounds, a.knapsack_method) == (b.bound, b.step_bounds, b.knapsack_method)
        o1 = optimal(ev, budget, max_nodes=50)
        o2 = optimal(ev, budget, max_nodes=50, constraints=Constraints.of(slots=False))

        def strip(r):
            return {k: v for k, v in json.loads(results.dumps(r)).items() if k not in ("seconds", "n_evaluations")}

        assert strip(o1) == strip(o2) and o1.constraints is None and "milp" not in o1.bound_method


def test_constrained_results_round_trip(problem, tmp_path):
    c = Constraints.of(limits={"power_w": 40.0}, max_sensors=3, require=["WSC-3"])
    res = run_optimal(problem, 20_000.0, engine="reference", constraints=c)
    assert (
        res.constraints is not None
        and res.constraints.limits == (("power_w", 40.0),)
        and res.constraints.library_digest
    )
    assert "milp" in res.bound_method or res.n_nodes == 0
    back = results.load(results.save(res, tmp_path / "opt.json"), OptimumResult)
    assert back == res
    g = greedy(make_evaluator(problem, "reference"), 20_000.0, "marginal", constraints=c, info=problem.info)
    cert = certify_result(problem, g, engine="reference")
    assert results.load(results.save(cert, tmp_path / "cert.json"), Certificate) == cert
    assert cert.bound >= res.score - TOL * max(1.0, res.score)


def test_certify_result_refuses_other_slots(problem):
    """The result's constraints were checked against the slotted library: a library with the same
    sensors but no slots is refused (force: certified anyway, over its own, larger, feasible set)."""
    g = greedy(
        make_evaluator(problem, "reference"), 9_000.0, "uniform", constraints=Constraints.of(), info=problem.info
    )
    assert g.constraints is not None
    stock = load_library()
    bare = build_problem(stock.subset([stock.position(i) for i in IDS]), load_scenario(ScenarioSpec(fixture="tiny")))
    with pytest.raises(InputError, match="other resources or mounting slots"):
        certify_result(bare, g, engine="reference")
    assert certify_result(bare, g, engine="reference", force=True).bound >= g.score


# ------------------------------------------------------------------------- the milp bound


def brute_packing(v, A, cap) -> float:
    best = 0.0
    n = len(v)
    for r in range(n + 1):
        for t in itertools.combinations(range(n), r):
            if np.all(A[:, list(t)].sum(axis=1) <= cap + 1e-9):
                best = max(best, float(sum(v[i] for i in t)))
    return best


def test_packing_bound_equals_brute_force_on_random_integer_programs(capfd):
    rng = np.random.default_rng(7)
    for _ in range(60):
        n, m = int(rng.integers(0, 9)), int(rng.integers(1, 4))
        v = rng.normal(3.0, 3.0, n)
        A = rng.integers(0, 6, (m, n)).astype(float) * rng.choice([1.0, 0.37, 1000.0])
        cap = rng.integers(0, 14, m).astype(float) * (A.max() / 5 if A.size and A.max() > 0 else 1.0)
        best = brute_packing(v, A, cap)
        sol = packing_bound(v, A, cap)
        assert sol.exact and sol.value == pytest.approx(best, rel=1e-9, abs=1e-6)
        assert sol.value >= best - 1e-9 * max(1.0, best)
        t = list(sol.chosen)
        assert np.all(A[:, t].sum(axis=1) <= cap * (1 + 1e-9) + 1e-9) and sol.achieved == pytest.approx(
            sum(v[t]), abs=1e-9
        )
    assert "Highs" not in capfd.readouterr().out  # HiGHS's stray debug line never reaches stdout


def test_packing_bound_stopped_early_stays_above_the_optimum():
    rng = np.random.default_rng(11)
    methods = set()
    for _ in range(4):
        v = rng.uniform(1.0, 10.0, 30)
        A = rng.uniform(0.0, 10.0, (3, 30))
        cap = np.full(3, 40.0)
        exact = packing_bound(v, A, cap)
        early = packing_bound(v, A, cap, max_nodes=1)
        methods.add(early.method)
        assert exact.exact and early.value >= exact.value - 1e-9 * exact.value
        assert early.achieved <= exact.value + 1e-9 * exact.value
        assert early.exact == (early.method in ("milp", "trivial"))
    assert methods - {"milp"}, "no instance stopped at the node limit: the early path is untested"


# --------------------------------------------------------------------------------- the CLI


def _library_lacking_power(folder: Path) -> Path:
    doc = yaml.safe_load(REDUCED.read_text(encoding="utf-8"))
    for m in doc["models"]:
        if m["code"] == "LRR":
            del m["resources"]["power_w"]
    path = folder / "no_radar_power.yaml"
    path.write_text(yaml.safe_dump(doc), encoding="utf-8")
    return path


@pytest.mark.parametrize("command", ["optimal", "certify", "greedy"])
@pytest.mark.parametrize(
    "extra, named",
    [
        (["--include", "LRL-roof", "--limit", "power_w=10"], "power_w"),  # required sensors over a limit
        (["--include", "LRL-roof,LRR-12", "--max-sensors", "1"], "--max-sensors"),
        (["--limit", "thrust_n=3"], "thrust_n"),  # unknown resource
        (["--include", "XYZ-99"], "XYZ-99"),  # unknown id
        (["--exclude", "NOPE-1"], "NOPE-1"),
        (["--include", "LRR-12", "--exclude", "LRR-12,WSC-3"], "LRR-12"),  # required and excluded
        (["--limit", "power_w=abc"], "power_w"),
        ("lacking", "LRR"),  # a model without the resource
    ],
)
def test_cli_infeasible_requests_fail_in_one_line(tmp_path, command, extra, named):
    lib = REDUCED
    if extra == "lacking":
        lib, extra = _library_lacking_power(tmp_path), ["--limit", "power_w=100"]
    r = CliRunner().invoke(
        cli,
        [command, "--fixture", "tiny", "--library", str(lib), "--budget", "110000", "-q", "--engine", "reference"]
        + extra,
    )
    assert r.exit_code == 2, r.output
    assert "Traceback" not in r.output and r.stdout == ""
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("sensorsel: error:") and named in lines[0], r.stderr


def test_cli_require_suites_hold_the_required_sensors():
    base = [
        "--fixture",
        "tiny",
        "--library",
        str(REDUCED),
        "--budget",
        "9000",
        "-q",
        "--engine",
        "reference",
        "--include",
        "LRR-6,WSC-9",
        "--json",
    ]
    r = CliRunner().invoke(cli, ["optimal", "--max-nodes", "15", "--limit", "power_w=30"] + base)
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout)
    assert {"LRR-6", "WSC-9"} <= set(out["suite"]) and {"LRR-6", "WSC-9"} <= set(out["greedy_suite"])
    assert out["constraints"]["require"] == ["LRR-6", "WSC-9"]
    r = CliRunner().invoke(cli, ["certify", "--rule", "uniform", "--owned"] + base)
    assert r.exit_code == 0, r.output
    cert = json.loads(r.stdout)
    assert {"LRR-6", "WSC-9"} <= set(cert["suite"]) and cert["constraints"]["owned"] is True


def test_cli_optimal_prints_the_usage_table():
    r = CliRunner().invoke(
        cli,
        [
            "optimal",
            "--fixture",
            "tiny",
            "--library",
            str(REDUCED),
            "--budget",
            "9000",
            "-q",
            "--max-nodes",
            "5",
            "--limit",
            "power_w=20",
            "--max-sensors",
            "3",
        ],
    )
    assert r.exit_code == 0, r.output
    assert "limits     power_w <= 20 W" in r.stdout and "power_w" in r.stdout.split("limits")[1]


def test_cli_certify_result_of_other_slots_is_refused_naming_the_file(tmp_path):
    car = tmp_path / "car.yaml"
    car.write_text(yaml.safe_dump({"extends": str(REDUCED), "slots": SLOTS}), encoding="utf-8")
    base = ["--fixture", "tiny", "-q", "--engine", "reference"]
    out = tmp_path / "g.json"
    r = CliRunner().invoke(
        cli, ["greedy", "--library", str(car), "--budget", "9000", "--no-certificate", "-o", str(out)] + base
    )
    assert r.exit_code == 0, r.output
    r = CliRunner().invoke(cli, ["certify", "--library", str(REDUCED), "--suite", str(out)] + base)
    assert r.exit_code == 2 and str(out) in r.stderr and "mounting slots" in r.stderr and "Traceback" not in r.output
    assert len(r.stderr.strip().splitlines()) == 1
    r = CliRunner().invoke(cli, ["certify", "--library", str(REDUCED), "--suite", str(out), "--force"] + base)
    assert r.exit_code == 0 and "warning" in r.stderr and str(out) in r.stderr
    r = CliRunner().invoke(cli, ["certify", "--library", str(car), "--suite", str(out)] + base)
    assert r.exit_code == 0 and "and its limits" in r.stdout
    r = CliRunner().invoke(cli, ["certify", "--library", str(car), "--suite", str(out), "--limit", "power_w=5"] + base)
    assert r.exit_code == 2 and "only with --budget" in r.stderr
