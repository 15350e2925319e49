"""The robust bound's knapsack with drops as an integer program over every limit, and the
worst route of a domain under constraints.

Oracles: brute force over every item set (the knapsack), and over every feasible suite of the
8-sensor table of :mod:`test_constraints_selectors` (the constrained robust optimum).
"""

from __future__ import annotations

import dataclasses
import functools
import itertools

import numpy as np
import pytest
from oracles import every_suite_score
from test_constraints_selectors import LIBRARY, brute_worst, draw_constraints, feasible_suites, random_case, tol

from sensorsel.api import run_robust
from sensorsel.designs.robust import knapsack_drop, robust_bound, worst_route_select
from sensorsel.designs.robust.bound import knapsack_drop_rows
from sensorsel.information.evaluators import make_evaluator
from sensorsel.model.constraints import feasible_set
from sensorsel.model.library import Slot
from sensorsel.model.problem import Domain, DomainRoute, build_problem
from sensorsel.model.scenario import ScenarioSpec, load_scenario


def brute_knapsack(values, usage, capacity, drop, forced) -> float:
    """max over item sets T ⊇ forced within every row of Σ_T values - the ``drop`` largest in T."""
    best = -np.inf
    n = len(values)
    for r in range(n + 1):
        for t in itertools.combinations(range(n), r):
            if not set(forced) <= set(t) or np.any(usage[:, list(t)].sum(axis=1) > capacity + 1e-9):
                continue
            chosen = sorted((values[i] for i in t), reverse=True)
            best = max(best, sum(chosen) - sum(chosen[:drop]))
    return best


def random_knapsack(rng):
    n, m = int(rng.integers(3, 9)), int(rng.integers(1, 4))
    values = np.round(rng.exponential(3.0, n), 3)
    values[rng.random(n) < 0.15] = 0.0
    usage = rng.integers(0, 5, (m, n)).astype(float)
    capacity = rng.integers(2, 12, m).astype(float)
    forced = [i for i in range(n) if rng.random() < 0.15]
    return values, usage, capacity, int(rng.integers(0, 4)), forced


def test_knapsack_drop_rows_equals_brute_force():
    rng = np.random.default_rng(15)
    infeasible = 0
    for _ in range(120):
        values, usage, capacity, drop, forced = random_knapsack(rng)
        got, proved = knapsack_drop_rows(values, usage, capacity, drop, forced=forced)
        want = brute_knapsack(values, usage, capacity, drop, forced)
        assert proved
        if want == -np.inf:
            infeasible += 1
            assert got == -np.inf
        else:
            # HiGHS closes the gap to an absolute 1e-6 at most; the answer is its dual bound (never below)
            assert want - 1e-9 <= got <= want + 1e-6, (values, usage, capacity, drop, forced, got, want)
    assert 0 < infeasible < 60  # the forced items sometimes break a row: both outcomes are exercised


def test_knapsack_drop_rows_on_the_budget_row_alone_equals_the_dynamic_program():
    rng = np.random.default_rng(3)
    for _ in range(40):
        n = int(rng.integers(4, 14))
        values = np.round(rng.exponential(3.0, n), 3)
        costs = rng.choice([500.0, 1493.0, 2000.0, 7000.0, 100_000.0], n)
        budget = float(rng.choice([5_000.0, 12_000.0, 110_000.0]))
        drop = int(rng.integers(0, 3))
        dp = knapsack_drop(values, costs, budget, drop)
        got, proved = knapsack_drop_rows(values, costs[None, :], [budget], drop)
        assert proved and dp - 1e-9 <= got <= dp + 1e-6


def test_knapsack_drop_rows_stopped_early_keeps_an_upper_bound():
    """A node limit of 1 on 40 items and 3 rows: HiGHS's dual bound, never below the maximum (here the
    maximum of the budget row alone with the same drops bounds it from above, the unlimited node run
    from below)."""
    rng = np.random.default_rng(7)
    n = 40
    values = np.round(rng.exponential(3.0, n), 3)
    usage = np.vstack([rng.integers(1, 9, n), rng.integers(0, 5, n), np.ones(n)]).astype(float)
    capacity = np.array([60.0, 25.0, 12.0])
    full, proved = knapsack_drop_rows(values, usage, capacity, 2)
    early, _ = knapsack_drop_rows(values, usage, capacity, 2, node_limit=1)
    assert proved
    assert early >= full - 1e-6
    assert early <= float(np.sort(values)[::-1][2:].sum()) + 1e-9


@pytest.mark.parametrize("seed", range(8))
@pytest.mark.parametrize("alpha", [1, 2])
def test_constrained_bound_is_valid_and_never_looser_than_the_budget_relaxation(seed, alpha):
    ev, budget, c = random_case(seed)
    opt = max(brute_worst(s, alpha) for s in feasible_suites(ev.library, budget, c))
    relaxed = robust_bound(ev, budget, alpha, constraints=c, relax_to_budget=True)
    both = robust_bound(ev, budget, alpha, constraints=c)
    tight = robust_bound(ev, budget, alpha, constraints=c, relax_to_budget=False)
    for b in (relaxed, both, tight):
        assert b.bound >= opt - tol(opt), (b.bound, opt, b.relaxation)
    assert both.bound <= relaxed.bound + tol(relaxed.bound)
    # without a case split every node is the root: fact (5)'s knapsacks are never above fact (4)'s
    root_tight = robust_bound(ev, budget, alpha, constraints=c, relax_to_budget=False, max_nodes=1)
    root_relaxed = robust_bound(ev, budget, alpha, constraints=c, relax_to_budget=True, max_nodes=1)
    assert opt - tol(opt) <= root_tight.bound <= root_relaxed.bound + tol(root_relaxed.bound)
    if c.limits or c.max_sensors or c.require:
        assert "integer programs" in (tight.relaxation + both.relaxation)


def test_the_integer_programs_tighten_the_bound_on_some_random_case():
    """Not a theorem per case, but the point of the integer programs: on the seeded cases some root
    bound is strictly below the relaxation's."""
    tighter = 0
    for seed in range(8):
        ev, budget, c = random_case(seed)
        a = robust_bound(ev, budget, 1, constraints=c, relax_to_budget=False, max_nodes=1).bound
        b = robust_bound(ev, budget, 1, constraints=c, relax_to_budget=True, max_nodes=1).bound
        tighter += a < b - tol(b)
    assert tighter >= 2


# ------------------------------------------------------------------------- the worst route of a domain

WORST_IDS = ("LRL-roof", "MRL-roof", "LRR-12", "LRR-6", "WSC-9", "HD2K-4", "HD2K-10", "LSC-2")


@functools.cache
def two_route_problems():
    """The 8 sensors on two routes: the tiny fixture, and its track with synthetic landmarks."""
    lib = LIBRARY.subset([LIBRARY.position(i) for i in WORST_IDS])
    specs = (ScenarioSpec(fixture="tiny"), ScenarioSpec(fixture="tiny", landmarks="synthetic", landmark_seed=3))
    return tuple(build_problem(lib, load_scenario(s), spec=s) for s in specs)


@functools.cache
def route_tables() -> tuple[dict[tuple[int, ...], float], ...]:
    """f_r of every suite of the 8 sensors on each route (the fast engine, each suite scored once)."""
    return tuple(every_suite_score(make_evaluator(p, "fast")) for p in two_route_problems())


def worst_route_case(seed: int):
    """A 2-route domain on a library with random slots, a budget and random constraints it can meet."""
    rng = np.random.default_rng(100 + seed)
    base = two_route_problems()[0].library
    n = len(base)
    perm = rng.permutation(n)
    slots = tuple(
        Slot(f"{k + 1}", "any", int(rng.integers(1, 3)), tuple(sorted(int(i) for i in perm[3 * k : 3 * k + 3])))
        for k in range(2)
    )
    lib = dataclasses.replace(base, slots=slots)
    domain = Domain(
        tuple(
            DomainRoute(f"r{k}", dataclasses.replace(p, library=lib), 1.0) for k, p in enumerate(two_route_problems())
        ),
        "test",
    )
    budget = float(rng.choice([6_000.0, 12_000.0, 110_000.0]))
    c = draw_constraints(rng, lib, perm, budget, power_share=(0.25, 0.7), p_mass=0.0, p_pick=0.4)
    return domain, budget, c


def brute_h(s: tuple[int, ...], alpha: int) -> float:
    """h(S) = min over the routes and the alpha-sets F of f_r(S minus F) / f_r(L)."""
    tabs = route_tables()
    n = len(WORST_IDS)
    vals = []
    for tab in tabs:
        norm = tab[tuple(range(n))]
        k = min(alpha, len(s))
        vals.append(
            min(tab[tuple(i for i in s if i not in f)] for f in itertools.combinations(s, k)) / norm if s else 0.0
        )
    return min(vals)


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("alpha", [1, 2])
def test_worst_route_under_constraints_against_brute_force(seed, alpha):
    domain, budget, c = worst_route_case(seed)
    lib = domain.library
    feas = feasible_set(lib, budget, c)
    allowed = [s for s in route_tables()[0] if feas.fits(s)]
    opt = max(brute_h(s, alpha) for s in allowed)
    res = run_robust(domain, budget, alpha, engine="fast", aggregate="worst", constraints=c)
    assert res.aggregate == "worst"
    assert res.constraints is not None and res.constraints.limits == c.limits and res.constraints.require == c.require
    for cand in res.candidates:
        s = tuple(sorted(lib.resolve_suite(cand.suite)))
        assert feas.fits(s), f"{cand.method}: {cand.suite} breaks {feas.violations(s)} under {c.describe()}"
        assert abs(cand.worst_score - brute_h(s, alpha)) <= tol(1.0)
    s = tuple(sorted(lib.resolve_suite(res.suite)))
    assert feas.fits(s) and abs(res.worst_score - brute_h(s, alpha)) <= tol(1.0)
    assert res.worst_score <= opt + tol(1.0) and res.bound >= opt - tol(1.0), (res.worst_score, res.bound, opt)
    assert res.worst_score >= res.greedy_worst_score - tol(1.0) and res.worst_score >= res.algorithm2_worst_score - tol(
        1.0
    )
    if res.bound_detail.proved:
        assert abs(res.worst_score - opt) <= tol(1.0)


def test_worst_route_under_constraints_is_bound_by_them():
    """The generator's limits bite: on some case the unconstrained answer breaks them, and the
    constrained one never does."""
    broken = 0
    for seed in range(6):
        domain, budget, c = worst_route_case(seed)
        free = worst_route_select(domain, budget, 1, engine="fast")
        broken += not feasible_set(domain.library, budget, c).fits(domain.library.resolve_suite(free.suite))
    assert broken >= 2
