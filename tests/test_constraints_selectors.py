"""The tradespace, robust selection and resilient (per-period) selection keep every
constraint (resource limits, mounting slots, most sensors, required / owned and excluded sensors).

Oracle: every suite of an 8-sensor library scored once with the fast engine (a table); the feasible
suites are those :meth:`FeasibleSet.fits` accepts, enumerated; the constrained robust optimum is the
max over them of the min over alpha-subsets, by enumeration of that table. The selectors read the
same table, so comparisons are exact up to the 1e-9 tie tolerance. Constraints are drawn from seeded
random generators, slots as random groups of sensors with capacity 1 or 2.
"""

from __future__ import annotations

import dataclasses
import functools
import itertools
import json
import warnings

import numpy as np
import pytest
import yaml
from click.testing import CliRunner
from oracles import every_suite_score

from sensorsel.cli import cli
from sensorsel.designs.resilient import CacheWarning, resilient_select, run_periods
from sensorsel.designs.robust import robust_bound, robust_optimum, robust_select
from sensorsel.designs.selection import RULES
from sensorsel.designs.tradespace import tradespace
from sensorsel.errors import InputError
from sensorsel.information.evaluators import Evaluator, as_suite, make_evaluator
from sensorsel.io import results
from sensorsel.io.resources import default_library_path
from sensorsel.model.constraints import Constraints, feasible_set
from sensorsel.model.library import Slot, load_library
from sensorsel.model.problem import build_problem
from sensorsel.model.scenario import ScenarioSpec, load_scenario

LIBRARY = load_library()
IDS = ("LRL-roof", "MRL-roof", "LRR-12", "LRR-6", "MRR-3", "WSC-12", "HD2K-3", "HD2K-9")
SEEDS = range(8)


def tol(x: float) -> float:
    return 1e-9 * max(1.0, abs(x))


@functools.cache
def problem():
    lib = LIBRARY.subset([LIBRARY.position(i) for i in IDS])
    return build_problem(lib, load_scenario(ScenarioSpec(fixture="tiny")))


@functools.cache
def table() -> dict[tuple[int, ...], float]:
    """f of every suite of the 8 sensors, each scored once."""
    return every_suite_score(make_evaluator(problem(), "fast"))


class TableEvaluator(Evaluator):
    """f(S) read from :func:`table`, on a library that may carry slots (slots never change a score)."""

    name = "table"

    def score(self, suite):
        self.n_evaluations += 1
        return table()[as_suite(suite)]


def random_case(seed: int) -> tuple[Evaluator, float, Constraints]:
    """A library with random slots, a budget and random constraints the library can meet."""
    rng = np.random.default_rng(seed)
    base = problem().library
    n = len(base)
    perm = rng.permutation(n)
    slots = []
    for k, size in enumerate(rng.integers(2, 4, size=2)):
        members = tuple(sorted(int(i) for i in perm[3 * k : 3 * k + int(size)]))
        slots.append(Slot(f"{k + 1}", "any", int(rng.integers(1, 3)), members))
    lib = dataclasses.replace(base, slots=tuple(slots))
    budget = float(rng.choice([6_000.0, 12_000.0, 110_000.0]))
    return TableEvaluator(lib), budget, draw_constraints(rng, lib, perm, budget)


def draw_constraints(
    rng: np.random.Generator,
    lib,
    perm: np.ndarray,
    budget: float,
    *,
    power_share: tuple[float, float] = (0.2, 0.7),
    p_mass: float = 0.4,
    p_pick: float = 0.5,
) -> Constraints:
    """Random constraints ``lib`` can meet: a power limit (a ``power_share`` of the library's, 70% of
    the time), a mass limit (``p_mass`` of the time), the last sensor of ``perm`` required and the one
    before excluded (``p_pick`` each), a largest number of sensors (half the time), owned (half the
    time there is a required sensor). A required sensor that breaks a drawn limit is drawn away."""
    limits = (
        {"power_w": round(float(rng.uniform(*power_share)) * float(lib.resource("power_w").sum()), 1)}
        if rng.random() < 0.7
        else {}
    )
    if p_mass and rng.random() < p_mass:
        limits["mass_kg"] = round(float(rng.uniform(0.3, 0.8)) * float(lib.resource("mass_kg").sum()), 2)
    require = [lib.ids[int(perm[-1])]] if rng.random() < p_pick else []
    exclude = [lib.ids[int(perm[-2])]] if rng.random() < p_pick else []
    max_sensors = int(rng.integers(2, 5)) if rng.random() < 0.5 else None
    c = Constraints.of(
        limits=limits,
        require=require,
        owned=bool(require) and rng.random() < 0.5,
        exclude=exclude,
        max_sensors=max_sensors,
    )
    try:
        feasible_set(lib, budget, c)
    except InputError:  # the required sensor breaks a drawn limit: draw it away
        c = dataclasses.replace(c, require=(), owned=False)
    return c


def feasible_suites(lib, budget: float, c: Constraints) -> list[tuple[int, ...]]:
    feas = feasible_set(lib, budget, c)
    return [s for s in table() if feas.fits(s)]


def brute_worst(s: tuple[int, ...], alpha: int) -> float:
    k = min(alpha, len(s))
    return min(table()[tuple(i for i in s if i not in f)] for f in itertools.combinations(s, k)) if s else 0.0


def assert_fits(lib, budget: float, c: Constraints, suite, what: str) -> None:
    feas = feasible_set(lib, budget, c)
    pos = lib.resolve_suite(suite) if suite and isinstance(next(iter(suite)), str) else list(suite)
    assert feas.fits(pos), f"{what}: {suite} breaks {feas.violations(pos)} under {c.describe()}"
    for r in c.require:
        assert lib.position(r) in pos, f"{what}: {suite} misses the required {r}"


def test_random_cases_are_constrained():
    """The generator draws real limits: in most cases some affordable suite is infeasible."""
    bites = 0
    for seed in SEEDS:
        ev, budget, c = random_case(seed)
        plain = [s for s in table() if ev.library.cost(s) <= budget]
        bites += len(feasible_suites(ev.library, budget, c)) < len(plain)
    assert bites >= len(SEEDS) - 1


# ------------------------------------------------------------------------------------------ tradespace


@pytest.mark.parametrize("seed", SEEDS)
def test_every_tradespace_suite_is_feasible_at_its_budget(seed):
    ev, budget, c = random_case(seed)
    lib = ev.library
    budgets = sorted({budget / 3, budget / 1.5, budget})
    budgets = [b for b in budgets if feasible_set(lib, budget, c).usage(feasible_set(lib, budget, c).required)[0] <= b]
    res = tradespace(ev, budgets, tuple(RULES), constraints=c)
    assert res.constraints is not None and res.constraints.limits == c.limits
    by_rule_budget = {(r.rule, r.budget_usd): r for r in res.runs}
    assert len(by_rule_budget) == len(RULES) * len(budgets)
    for r in res.runs:
        assert_fits(lib, r.budget_usd, c, r.suite, f"{r.rule} at ${r.budget_usd:,.0f}")
    for a in res.architectures:  # each is the suite of some run's step: it fits the largest budget
        assert_fits(lib, max(budgets), c, a.suite, "architecture")
    if c.limits:
        assert not res.share_prefix  # resource limits: the dollar-equivalent cost depends on the budget


@pytest.mark.parametrize("seed", SEEDS)
def test_prefix_sharing_under_capacity_rows_equals_independent_runs(seed):
    ev, budget, c = random_case(seed)
    c = dataclasses.replace(c, limits=())  # slots, most sensors, require / exclude: sharing stays on
    budgets = [
        b
        for b in (2_000.0, 5_000.0, 9_000.0, 110_000.0)
        if feasible_set(ev.library, b, c).usage(feasible_set(ev.library, b, c).required)[0] <= b
    ]
    shared = tradespace(ev, budgets, ("uniform", "cost-benefit", "marginal"), constraints=c)
    alone = tradespace(ev, budgets, ("uniform", "cost-benefit", "marginal"), constraints=c, share_prefix=False)
    assert shared.share_prefix and not alone.share_prefix
    assert [(r.rule, r.budget_usd, r.suite) for r in shared.runs] == [
        (r.rule, r.budget_usd, r.suite) for r in alone.runs
    ]
    assert [a.suite for a in shared.architectures] == [a.suite for a in alone.architectures]


# -------------------------------------------------------------------------------------------- robust


@pytest.mark.parametrize("seed", SEEDS)
def test_robust_candidates_are_feasible_and_the_bound_holds(seed):
    ev, budget, c = random_case(seed)
    lib = ev.library
    res = robust_select(ev, budget, 1, rules=tuple(RULES), skip_when_proved=False, constraints=c)
    for cand in res.candidates:
        assert_fits(lib, budget, c, cand.suite, cand.method)
    assert_fits(lib, budget, c, res.suite, "answer")
    opt = max(brute_worst(s, 1) for s in feasible_suites(lib, budget, c))
    assert res.worst_score <= opt + tol(opt)
    assert res.bound >= opt - tol(opt), (res.bound, opt, res.bound_detail.relaxation)
    assert res.worst_score >= res.greedy_worst_score - tol(res.greedy_worst_score)
    direct = robust_bound(ev, budget, 1, constraints=c)
    assert direct.bound >= opt - tol(opt)
    if not res.bound_detail.relaxation:
        assert res.constraints is None or c.is_default


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("alpha", [1, 2])
def test_exact_robust_search_equals_brute_force_under_constraints(seed, alpha):
    ev, budget, c = random_case(seed)
    lib = ev.library
    opt = robust_optimum(ev, budget, alpha, constraints=c)
    assert opt.proved_optimal
    feas = feasible_suites(lib, budget, c)
    best = max(brute_worst(s, alpha) for s in feas)
    assert abs(opt.worst_score - best) <= tol(best)
    assert_fits(lib, budget, c, opt.suite, "exact optimum")


def test_owned_sensors_do_not_count_against_the_budget_and_the_bound_stays_valid():
    """With --owned the LiDAR costs nothing: suites above the budget in price are feasible, and the
    budget-only relaxation must widen its budget by the owned price (else it would be below them)."""
    lib = problem().library
    ev = TableEvaluator(lib)
    c = Constraints.of(require=["LRL-roof"], owned=True)
    budget = 3_000.0
    feas = feasible_suites(lib, budget, c)
    assert any(lib.cost(s) > budget for s in feas)
    best = max(brute_worst(s, 1) for s in feas)
    res = robust_select(ev, budget, 1, skip_when_proved=False, constraints=c)
    assert res.bound >= best - tol(best)
    assert "owned" in res.bound_detail.relaxation
    assert abs(robust_optimum(ev, budget, 1, constraints=c).worst_score - best) <= tol(best)
    for cand in res.candidates:
        assert_fits(lib, budget, c, cand.suite, cand.method)


def test_robust_result_records_the_constraints_and_round_trips():
    ev, budget, c = random_case(1)
    res = robust_select(ev, budget, 1, constraints=c)
    assert res.constraints is not None and res.constraints.library_digest
    assert results.from_jsonable(type(res), json.loads(results.dumps(res))) == res


# ---------------------------------------------------------------------------------------- resilient


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("alpha", [1, 2])
def test_algorithm_2_failing_and_active_set_fit_together(seed, alpha):
    ev, budget, c = random_case(seed)
    lib = ev.library
    r = resilient_select(ev, budget, alpha, constraints=c)
    assert_fits(lib, budget, c, r.suite, "Algorithm 2")
    assert set(r.failed) | set(r.active) == set(r.suite) and not set(r.failed) & set(r.active)
    assert not set(r.suite) & set(c.exclude)


def test_per_period_suites_are_feasible_and_the_fingerprint_holds_the_constraints(tmp_path):
    lib = dataclasses.replace(problem().library, slots=(Slot("roof", "lidar", 1, (0, 1)),))
    p = build_problem(lib, load_scenario(ScenarioSpec(fixture="tiny")))
    c = Constraints.of(limits={"power_w": 40.0}, require=["LRR-12"])
    budget = 9_000.0
    per = run_periods(p, budget, 1, period_s=3.0, engine="fast", outdir=tmp_path, constraints=c)
    assert per.constraints is not None and len(per.periods) >= 2
    for period in per.periods:
        assert_fits(lib, budget, c, period.suite, period.period.label)
    # a resume under other limits never reuses these files
    c2 = Constraints.of(limits={"power_w": 30.0}, require=["LRR-12"])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        per2 = run_periods(p, budget, 1, period_s=3.0, engine="fast", outdir=tmp_path, resume=True, constraints=c2)
    assert sum(issubclass(w.category, CacheWarning) for w in caught) == len(per.periods)
    for period in per2.periods:
        assert_fits(lib, budget, c2, period.suite, period.period.label)
    # and the same limits are reused without a word
    with warnings.catch_warnings():
        warnings.simplefilter("error", CacheWarning)
        run_periods(p, budget, 1, period_s=3.0, engine="fast", outdir=tmp_path, resume=True, constraints=c2)


# ---------------------------------------------------------------------------------------------- CLI


@pytest.fixture(scope="module")
def slotted_library_yaml(tmp_path_factory) -> str:
    """Table I at four clock positions with one radar and one camera per position (extends the stock file)."""
    d = tmp_path_factory.mktemp("lib")
    stock = yaml.safe_load(default_library_path().read_text())
    stock["clock_positions"] = [12, 3, 6, 9]
    (d / "small.yaml").write_text(yaml.safe_dump(stock))
    (d / "car.yaml").write_text("extends: small.yaml\nslots:\n  roof: {lidar: 1}\n  clock: {radar: 1, stereo: 1}\n")
    return str(d / "car.yaml")


def invoke(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


COMMON = ["--fixture", "tiny", "--engine", "fast", "--jobs", "1", "-q"]


def _check_json_suites(lib_path: str, budget: float, c: Constraints, suites) -> None:
    from sensorsel.model.library import load_library as load

    lib = load(lib_path)
    for s in suites:
        assert_fits(lib, budget, c, s, "CLI suite")


def test_cli_pareto_robust_resilient_keep_a_power_limit(slotted_library_yaml, tmp_path):
    c = Constraints.of(limits={"power_w": 30.0})
    out = tmp_path / "p"
    r = invoke(
        "pareto",
        *COMMON,
        "--library",
        slotted_library_yaml,
        "--budgets",
        "5000,20000",
        "--rules",
        "uniform,marginal",
        "--limit",
        "power_w=30",
        "--output-dir",
        out,
    )
    assert r.exit_code == 0, r.output
    from sensorsel.designs.tradespace import TradespaceResult

    ts = results.load(out / "tradespace.json", TradespaceResult)
    assert ts.constraints is not None and ts.constraints.limits == (("power_w", 30.0),)
    _check_json_suites(slotted_library_yaml, 20_000.0, c, [a.suite for a in ts.architectures])

    out = tmp_path / "r.json"
    r = invoke(
        "robust",
        *COMMON,
        "--library",
        slotted_library_yaml,
        "--budget",
        "6000",
        "--failures",
        "1",
        "--methods",
        "none",
        "--limit",
        "power_w=30",
        "-o",
        out,
    )
    assert r.exit_code == 0, r.output
    assert "power_w" in r.output  # the resource-use table of the answer
    from sensorsel.designs.robust import RobustResult

    rr = results.load(out, RobustResult)
    _check_json_suites(slotted_library_yaml, 6_000.0, c, [cand.suite for cand in rr.candidates])

    r = invoke(
        "resilient",
        *COMMON,
        "--library",
        slotted_library_yaml,
        "--budget",
        "6000",
        "--failures",
        "1",
        "--period",
        "5",
        "--limit",
        "power_w=30",
        "--output-dir",
        tmp_path / "res",
    )
    assert r.exit_code == 0, r.output
    from sensorsel.designs.resilient import ResilientReport

    rep = results.load(tmp_path / "res" / "resilient.json", ResilientReport)
    assert rep.constraints is not None
    suites = [rep.suite, rep.comparison.greedy.suite] + [p.suite for p in rep.per_period.periods]
    _check_json_suites(slotted_library_yaml, 6_000.0, c, suites)


@pytest.mark.parametrize(
    "cmd",
    [
        ["pareto", "--budgets", "5000,20000", "--output-dir", "{tmp}/x"],
        ["robust", "--budget", "6000", "--failures", "1", "-o", "{tmp}/x.json"],
        ["resilient", "--budget", "6000", "--failures", "1", "--output-dir", "{tmp}/x"],
    ],
)
def test_cli_refuses_an_infeasible_request_naming_the_constraint(slotted_library_yaml, tmp_path, cmd):
    r = invoke(
        *(a.replace("{tmp}", str(tmp_path)) for a in cmd),
        *COMMON,
        "--library",
        slotted_library_yaml,
        "--include",
        "LRL-roof",
        "--owned",
        "--limit",
        "power_w=30",
    )
    assert r.exit_code == 2
    lines = [ln for ln in r.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and "power_w" in lines[0] and "--include" in lines[0], r.output
