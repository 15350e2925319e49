"""Robust selection: the answer against brute force, the upper bound, the exact search,
SATURATE's family machinery, determinism, and a case where Algorithm 2 loses to greedy.

Oracle: every suite of a small library (<= 12 sensors of Table I) scored once with the fast engine
(checked against the reference engine in test_fast.py); the robust optimum is then
max over affordable S of min over alpha-subsets F of f(S minus F), by enumeration of that table.
The methods under test read the *same* table (:class:`TableEvaluator`), so the comparisons are exact
up to the 1e-9 tie tolerance.
"""

from __future__ import annotations

import functools
import itertools
import json
import math

import numpy as np
import pytest
from oracles import every_suite_score

from sensorsel.designs.resilient import resilient_select, worst_case
from sensorsel.designs.robust import (
    EvaluatorFamily,
    FailureFamily,
    MemoEvaluator,
    knapsack_drop,
    robust_bound,
    robust_optimum,
    robust_select,
    saturate,
)
from sensorsel.designs.selection import greedy
from sensorsel.information.evaluators import Evaluator, as_suite, make_evaluator
from sensorsel.io import results
from sensorsel.model.library import load_library
from sensorsel.model.problem import build_problem
from sensorsel.model.scenario import ScenarioSpec, load_scenario

REL = 1e-9
LIBRARY = load_library()
SMALL = {
    # (fixture, sensors): 12 on the tiny fixture, 10 on suburb (its suites cost ~3 ms each)
    "tiny12": (
        "tiny",
        (
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
        ),
    ),
    "tiny-cheap10": (
        "tiny",
        ("MRR-12", "MRR-3", "LRR-9", "LRR-3", "WSC-6", "WSC-9", "HD2K-3", "HD2K-9", "LSC-6", "LSC-12"),
    ),
    "suburb10": (
        "suburb",
        ("LRL-roof", "MRL-roof", "LRR-12", "LRR-3", "LRR-6", "WSC-12", "WSC-3", "HD2K-12", "HD2K-6", "LSC-12"),
    ),
}
BUDGETS = {
    "tiny12": [3_000.0, 9_000.0, 110_000.0],
    "tiny-cheap10": [2_000.0, 6_000.0, 12_000.0],
    "suburb10": [5_000.0, 104_500.0, 110_000.0],
}
CASES = [(name, b, a) for name in SMALL for b in BUDGETS[name] for a in (1, 2)]


def tol(x: float) -> float:
    return REL * max(1.0, abs(x))


class TableEvaluator(Evaluator):
    """f(S) read from a table of every suite (the same numbers for the method and the oracle)."""

    name = "table"

    def __init__(self, problem, table: dict[tuple[int, ...], float]) -> None:
        super().__init__(problem.library)
        self.problem = problem
        self.table = table

    def score(self, suite):
        self.n_evaluations += 1
        return self.table[as_suite(suite)] - self.table[()]


@functools.cache
def small_problem(name: str):
    fixture, ids = SMALL[name]
    lib = LIBRARY.subset([LIBRARY.position(i) for i in ids])
    return build_problem(lib, load_scenario(ScenarioSpec(fixture=fixture)))


@functools.cache
def table(name: str) -> dict[tuple[int, ...], float]:
    """f of every suite, each scored once (as an extension of its prefix without its last sensor)."""
    return every_suite_score(make_evaluator(small_problem(name), "fast"))


def table_eval(name: str) -> TableEvaluator:
    return TableEvaluator(small_problem(name), table(name))


def brute_worst(tab, s: tuple[int, ...], alpha: int) -> float:
    k = min(alpha, len(s))
    return min(tab[tuple(i for i in s if i not in f)] for f in itertools.combinations(s, k)) if s else 0.0


@functools.cache
def brute_robust(name: str, budget: float, alpha: int) -> float:
    tab, lib = table(name), small_problem(name).library
    return max(brute_worst(tab, s, alpha) for s in tab if lib.cost(s) <= budget + 1e-9)


def positions(lib, ids) -> list[int]:
    return [lib.position(i) for i in ids]


# ------------------------------------------------------------------------------ knapsack with drops


@pytest.mark.parametrize("seed", range(40))
def test_knapsack_with_drops_equals_brute_force(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 9))
    v = np.round(rng.uniform(-1, 10, n), 3)
    c = rng.integers(0, 7, n).astype(float)
    cap = float(rng.integers(0, 20))
    for drop in range(0, 4):
        best = 0.0
        for r in range(n + 1):
            for t in itertools.combinations(range(n), r):
                if c[list(t)].sum() <= cap:
                    vals = sorted((v[i] for i in t), reverse=True)
                    best = max(best, sum(vals[drop:]))
        assert abs(knapsack_drop(v, c, cap, drop) - best) <= 1e-9 * max(1, best)


# ----------------------------------------------------------------------- the answer against brute force


@pytest.mark.parametrize("name, budget, alpha", CASES)
def test_robust_answer_lies_between_greedy_and_the_optimum(name, budget, alpha):
    tab, lib = table(name), small_problem(name).library
    r = robust_select(table_eval(name), budget, alpha)
    opt = brute_robust(name, budget, alpha)
    # greedy's and Algorithm 2's worst cases, recomputed independently
    g = greedy(table_eval(name), budget)
    a2 = resilient_select(table_eval(name), budget, alpha)
    g_w = brute_worst(tab, tuple(sorted(positions(lib, g.suite))), alpha)
    a2_w = brute_worst(tab, tuple(sorted(positions(lib, a2.suite))), alpha)
    assert abs(r.greedy_worst_score - g_w) <= tol(g_w) and abs(r.algorithm2_worst_score - a2_w) <= tol(a2_w)
    assert r.worst_score >= g_w - tol(g_w) and r.worst_score >= a2_w - tol(a2_w)
    assert r.worst_score <= opt + tol(opt)
    assert r.bound >= opt - tol(opt)
    assert 0.0 <= r.gap_percent <= 100.0
    # the answer is what it says it is
    s = tuple(sorted(positions(lib, r.suite)))
    assert lib.cost(s) <= budget + 1e-9 and r.cost_usd == lib.cost(s)
    assert abs(r.worst_score - brute_worst(tab, s, alpha)) <= tol(r.worst_score)
    assert abs(r.nominal_score - tab[s]) <= tol(r.nominal_score)
    for c in r.candidates:
        cs = tuple(sorted(positions(lib, c.suite)))
        assert lib.cost(cs) <= budget + 1e-9
        assert abs(c.worst_score - brute_worst(tab, cs, alpha)) <= tol(c.worst_score)
        assert c.worst_score <= r.worst_score + tol(r.worst_score)
    assert r.candidates[0].method == "greedy-uniform" and any(c.method == "algorithm-2" for c in r.candidates)
    if r.bound_detail.proved:
        assert abs(r.worst_score - opt) <= tol(opt)


@pytest.mark.parametrize("name, budget, alpha", CASES)
def test_every_method_and_the_bound_without_skipping(name, budget, alpha):
    opt = brute_robust(name, budget, alpha)
    r = robust_select(table_eval(name), budget, alpha, skip_when_proved=False)
    assert {c.method for c in r.candidates} >= {
        "greedy-uniform",
        "greedy-marginal",
        "algorithm-2",
        "oblivious-eta2",
        "local-search",
    }
    assert not r.skipped or r.skipped == ("saturate: no level between the best worst case and the bound",)
    assert r.worst_score <= opt + tol(opt) <= r.bound + 2 * tol(opt)
    # the bound with no case split (one node) is valid too, and never tighter than with the split
    b1 = robust_bound(table_eval(name), budget, alpha, max_nodes=1)
    assert b1.bound >= opt - tol(opt)


@pytest.mark.parametrize("name, budget, alpha", CASES)
def test_exact_search_equals_brute_force(name, budget, alpha):
    tab, lib = table(name), small_problem(name).library
    o = robust_optimum(table_eval(name), budget, alpha)
    opt = brute_robust(name, budget, alpha)
    assert o.proved_optimal and abs(o.worst_score - opt) <= tol(opt) and abs(o.upper_bound - o.worst_score) <= tol(opt)
    s = tuple(sorted(positions(lib, o.suite)))
    assert lib.cost(s) <= budget + 1e-9 and abs(brute_worst(tab, s, alpha) - opt) <= tol(opt)


def test_exact_search_node_limit_gives_a_valid_bracket():
    name, budget, alpha = "tiny-cheap10", 6_000.0, 2
    opt = brute_robust(name, budget, alpha)
    o = robust_optimum(table_eval(name), budget, alpha, max_nodes=2)
    assert o.worst_score <= opt + tol(opt) <= o.upper_bound + 2 * tol(opt)
    assert o.proved_optimal or "node limit" in o.stop_reason


# ------------------------------------------------------------------------------------- the families


def test_failure_family_terms_are_the_members_grouped():
    name, alpha, c = "tiny12", 2, 1500.0
    tab, lib = table(name), small_problem(name).library
    fam = FailureFamily(table_eval(name), alpha)
    n = len(lib)
    for s in [(), (0,), (1, 4, 7), (0, 2, 5, 8, 9)]:
        w, v = fam.terms(s)
        brute = sum(min(tab[tuple(i for i in s if i not in f)], c) for f in itertools.combinations(range(n), alpha))
        assert w.sum() == math.comb(n, alpha) and abs(float(w @ np.minimum(v, c)) - brute) <= 1e-9 * brute
        cands = [e for e in range(n) if e not in s]
        w2, v2 = fam.terms_with(s, cands)
        w3, v3 = fam.terms_with(s, cands, cap=c)
        for k, e in enumerate(cands):
            se = tuple(sorted(s + (e,)))
            brute = sum(
                min(tab[tuple(i for i in se if i not in f)], c) for f in itertools.combinations(range(n), alpha)
            )
            assert abs(float(w2 @ np.minimum(v2[:, k], c)) - brute) <= 1e-9 * brute
            assert abs(float(w3 @ np.minimum(v3[:, k], c)) - brute) <= 1e-9 * brute
        assert fam.worst(s)[0] == pytest.approx(brute_worst(tab, s, alpha), rel=1e-12, abs=1e-12)


def test_saturate_covered_levels_are_reached_by_failures_and_by_routes():
    name, budget, alpha = "tiny12", 9_000.0, 1
    tab = table(name)
    opt = brute_robust(name, budget, alpha)
    levels, _ = saturate(FailureFamily(table_eval(name), alpha), budget, 0.0, opt * 1.2, levels=6)
    assert levels and any(ok for _, ok, _ in levels)
    for c, ok, s in levels:
        if ok:
            assert brute_worst(tab, s, alpha) >= c * (1 - 1e-9)
    # a family of two routes (the same library on two fixtures): min over routes of f_r(S)
    lib = small_problem(name).library
    other = build_problem(lib, load_scenario(ScenarioSpec(fixture="suburb")))
    members = [make_evaluator(small_problem(name), "fast"), make_evaluator(other, "fast")]
    fam = EvaluatorFamily(members, ["tiny", "suburb"])
    levels, _ = saturate(fam, budget, 0.0, 5_000.0, levels=5)
    for c, ok, s in levels:
        if ok:
            assert min(m.score(s) for m in members) >= c * (1 - 1e-9)
    assert any(ok for _, ok, _ in levels)


# --------------------------------------------------------------------- determinism and the real engine


def _strip(obj):
    if isinstance(obj, dict):
        return {k: _strip(v) for k, v in obj.items() if k != "seconds"}
    if isinstance(obj, list):
        return [_strip(v) for v in obj]
    return obj


def test_same_inputs_give_the_same_bytes_with_the_fast_engine(tmp_path):
    p = small_problem("tiny12")
    runs = [robust_select(make_evaluator(p, "fast"), 9_000.0, 2, skip_when_proved=False, info=p.info) for _ in range(2)]
    texts = [json.dumps(_strip(json.loads(results.dumps(r))), indent=1) for r in runs]
    assert texts[0] == texts[1]
    path = results.save(runs[0], tmp_path / "robust.json")
    assert results.load(path, type(runs[0])) == runs[0]
    opts = [robust_optimum(make_evaluator(p, "fast"), 9_000.0, 2) for _ in range(2)]
    assert _strip(results.to_jsonable(opts[0])) == _strip(results.to_jsonable(opts[1]))


def test_memo_scores_each_suite_once_and_agrees_with_the_engine():
    p = small_problem("tiny12")
    inner = make_evaluator(p, "fast")
    ev = MemoEvaluator(inner)
    a = ev.scores_with((0, 3), [1, 2, 5])
    n1 = ev.n_evaluations  # 3 suites (and the engine's baseline)
    b = ev.scores_with((0, 3), [2, 5, 6])
    assert ev.n_evaluations == n1 + 1 == inner.n_evaluations and a[1] == b[0] and a[2] == b[1]
    assert ev.score((0, 2, 3)) == a[1] and ev.n_evaluations == n1 + 1
    assert abs(ev.score((0, 3, 6)) - make_evaluator(p, "reference").score((0, 3, 6))) <= 1e-9 * 1e4


# --------------------------------------------------------------- Algorithm 2 strictly worse than greedy


class CoverageEvaluator(Evaluator):
    """Weighted coverage (monotone submodular): each sensor covers items; f = total weight covered."""

    name = "coverage"

    def __init__(self, lib, covers: list[dict[str, float]]) -> None:
        super().__init__(lib)
        self.covers = covers

    def score(self, suite):
        self.n_evaluations += 1
        seen: dict[str, float] = {}
        for i in as_suite(suite):
            seen.update(self.covers[i])
        return float(sum(seen.values()))


def test_algorithm_2_can_lose_to_greedy_and_the_robust_answer_beats_both():
    # five $449 sensors, budget for three, alpha = 1:
    #   a covers A (10) and W (1)   -> the best singleton, Algorithm 2's failing sensor
    #   d covers A (10)             -> best once a is ignored, useless next to a
    #   x covers X (6), y covers Y (6), z covers Z (2)
    # greedy {a, x, y}: worst f({x, y}) = 12.   Algorithm 2 {a, d, x}: worst f({a, d}) = 11.
    lib = LIBRARY.subset([LIBRARY.position(i) for i in ("HD2K-12", "HD2K-3", "HD2K-6", "HD2K-9", "LSC-12")])
    a, d, x, y, z = range(5)
    covers = [{"A": 10.0, "W": 1.0}, {"A": 10.0}, {"X": 6.0}, {"Y": 6.0}, {"Z": 2.0}]
    budget = 3 * 449.0
    ev = CoverageEvaluator(lib, covers)
    g = greedy(ev, budget)
    a2 = resilient_select(ev, budget, 1)
    g_w = worst_case(ev, positions(lib, g.suite), 1).score
    a2_w = worst_case(ev, positions(lib, a2.suite), 1).score
    assert sorted(positions(lib, g.suite)) == [a, x, y] and g_w == 12.0
    assert sorted(positions(lib, a2.suite)) == [a, d, x] and a2_w == 11.0
    r = robust_select(CoverageEvaluator(lib, covers), budget, 1, skip_when_proved=False)
    assert r.worst_score >= max(g_w, a2_w) and r.algorithm2_worst_score == 11.0 and r.greedy_worst_score == 12.0
    best = max(
        min(CoverageEvaluator(lib, covers).score([i for i in s if i != f]) for f in s)
        for s in itertools.combinations(range(5), 3)
    )
    assert r.worst_score == best and r.bound >= best
    o = robust_optimum(CoverageEvaluator(lib, covers), budget, 1)
    assert o.proved_optimal and o.worst_score == best


def test_bad_inputs_are_refused():
    from sensorsel.errors import InputError

    ev = table_eval("tiny12")
    with pytest.raises(InputError, match="failures"):
        robust_select(ev, 1_000.0, -1)
    with pytest.raises(InputError, match="unknown rule .nope."):
        robust_select(ev, 1_000.0, 1, rules=("nope",))
    with pytest.raises(InputError, match="robust method"):
        robust_select(ev, 1_000.0, 1, methods=("nope",))
    with pytest.raises(InputError, match="budget"):
        robust_optimum(ev, -5.0, 1)
    with pytest.raises(InputError, match="failures"):
        robust_bound(ev, 1_000.0, 1.5)


def test_the_memo_passes_its_engines_bounds_on_so_robust_runs_score_fewer_suites(suburb_problem):
    """The memo forwards the engine's bounds (they cost no evaluation); a greedy run through it picks
    what the bare engine picks, bit for bit, scoring no more suites than the bare engine's run
    without bounds (bound_from=0)."""
    from sensorsel.designs.robust.memo import MemoEvaluator
    from sensorsel.designs.selection.greedy import Selector
    from sensorsel.designs.selection.registry import RULES
    from sensorsel.information.evaluators import FastEvaluator

    n = len(suburb_problem.library)
    inner = FastEvaluator(suburb_problem)
    memo = MemoEvaluator(inner)
    own, each = memo.score_bounds((0,), list(range(n)))
    want_own, want_each = FastEvaluator(suburb_problem).score_bounds((0,), list(range(n)))
    assert own == want_own and each.tobytes() == want_each.tobytes()
    assert memo.gain_bounds((0,), list(range(1, n))).tobytes() == inner.gain_bounds((0,), list(range(1, n))).tobytes()
    through = Selector(MemoEvaluator(FastEvaluator(suburb_problem)), RULES["uniform"]).select(60_000.0)
    bare = Selector(FastEvaluator(suburb_problem), RULES["uniform"], bound_from=0).select(60_000.0)
    assert through.suite == bare.suite and [s.score for s in through.steps] == [s.score for s in bare.steps]
    assert through.n_evaluations < bare.n_evaluations
