"""Bounds on the candidates' gains, and the lazy greedy that uses them.

Oracles: GTSAM's own dense Hessians of the suite's graph (the reference engine's graphs) for the
true gain, the trace tr(L_S⁻¹ Λ_c) and the per-measurement log det bound; the plain greedy
(every candidate scored at every step) and the lazy greedy without bounds for the picks.
"""

from __future__ import annotations

import gtsam
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from scenario_strategies import problems

from sensorsel.designs.selection.greedy import BOUND_FROM, Selector, greedy
from sensorsel.designs.selection.registry import RULES
from sensorsel.information.evaluators import FastEvaluator, ReferenceEvaluator
from sensorsel.information.evaluators.fast.evaluator import BOUND_SPARE
from sensorsel.information.graph import GraphBuilder
from sensorsel.model.constraints import Constraints
from sensorsel.model.library import load_library

LIBRARY = load_library()
HYPOTHESIS = settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])


class DenseOracle:
    """Gains and bounds from GTSAM's dense Hessians (variables in keyVector order, the same for
    every suite: the base graph holds every pose and landmark)."""

    def __init__(self, problem) -> None:
        self.builder = GraphBuilder(problem)
        keys = self.builder.base_graph().linearize(self.builder.values).keyVector()
        self.col, off = {}, 0
        for key in keys:
            self.col[key] = off
            off += 3 if chr(gtsam.Symbol(key).chr()) == "x" else 2

        self.base: tuple[tuple[int, ...], np.ndarray, float, np.ndarray] | None = (
            None  # the last suite's H, log det, H⁻¹
        )

    def hessian(self, suite) -> np.ndarray:
        return self.builder.graph(suite).linearize(self.builder.values).hessian()[0]

    def _suite(self, suite) -> tuple[np.ndarray, float, np.ndarray]:
        """(H, log det H, H⁻¹) of ``suite``, kept for the next candidate on the same suite."""
        if self.base is None or self.base[0] != tuple(suite):
            h0 = self.hessian(suite)
            self.base = (tuple(suite), h0, float(np.linalg.slogdet(h0)[1]), np.linalg.inv(h0))
        return self.base[1], self.base[2], self.base[3]

    def gain_and_bounds(self, suite, c) -> tuple[float, float, float]:
        """(true gain, Σ_m log det(I + J_m Σ J_mᵀ), tr(L_S⁻¹ Λ_c)) of candidate c on ``suite``."""
        h0, logdet0, cov = self._suite(suite)
        h1 = self.hessian(tuple(suite) + (c,))
        gain = np.linalg.slogdet(h1)[1] - logdet0
        trace = float(np.einsum("ij,ji->", cov, h1 - h0))  # tr(H⁻¹ (H_c − H))
        graph = gtsam.NonlinearFactorGraph()
        self.builder.add_sensor(graph, c)
        gauss = graph.linearize(self.builder.values)
        per = 0.0
        for i in range(gauss.size()):
            f = gauss.at(i)
            jac, _ = f.jacobian()  # whitened rows; columns in the factor's key order
            cols = np.concatenate(
                [self.col[k] + np.arange(3 if chr(gtsam.Symbol(k).chr()) == "x" else 2) for k in f.keys()]
            )
            per += np.linalg.slogdet(np.eye(jac.shape[0]) + jac @ cov[np.ix_(cols, cols)] @ jac.T)[1]
        return float(gain), float(per), trace


def fischer_oracle(oracle: DenseOracle, suite) -> tuple[float, float]:
    """(log det of GTSAM's dense Hessian with every pose–landmark coupling dropped (the pose block,
    and each landmark's 2 × 2 block, factored apart) minus the empty suite's log det [nats], the sum
    of the magnitudes of those three log dets: the scale of the engine's round-off allowance)."""
    h = oracle.hessian(suite)
    pose_cols = np.concatenate([oracle.col[k] + np.arange(3) for k in oracle.col if chr(gtsam.Symbol(k).chr()) == "x"])
    pose = float(np.linalg.slogdet(h[np.ix_(pose_cols, pose_cols)])[1])
    landmarks = float(
        sum(
            np.linalg.slogdet(h[c : c + 2, c : c + 2])[1]
            for k, c in oracle.col.items()
            if chr(gtsam.Symbol(k).chr()) == "l"
        )
    )
    empty = float(np.linalg.slogdet(oracle.hessian(()))[1])
    return pose + landmarks - empty, abs(pose) + abs(landmarks) + abs(empty)


def close(a: float, b: float, rel: float = 1e-9) -> bool:
    return abs(a - b) <= rel * max(1.0, abs(b))


def draw_suites(n_sensors: int, count: int, *, sizes: tuple[int, int], seed: int) -> list[tuple[int, ...]]:
    """``count`` random suites (sorted positions, no repeats) of sizes drawn from [sizes[0], sizes[1])."""
    rng = np.random.default_rng(seed)
    return [
        tuple(sorted(rng.choice(n_sensors, size=int(rng.integers(*sizes)), replace=False).tolist()))
        for _ in range(count)
    ]


def check_bounds(problem, suites) -> int:
    """Every candidate on every suite: the fast engine's bounds equal the dense oracle's, and
    gain ≤ per-measurement bound ≤ trace (to round-off). Returns how many were checked."""
    fe, oracle = FastEvaluator(problem), DenseOracle(problem)
    n = len(problem.library)
    checked = 0
    for suite in suites:
        cands = list(range(n))
        tight = fe.gain_bounds(suite, cands, force=True)
        trace = fe.gain_bounds(suite, cands, trace=True, force=True)
        gains = fe.scores_with(suite, cands) - fe.score(suite)
        f = fe.score(suite)
        tol = 1e-9 * max(1.0, abs(f))
        for c in cands:
            if c in suite:
                assert tight[c] == 0.0 and trace[c] == 0.0
                continue
            gain, per, tr = oracle.gain_and_bounds(suite, c)
            assert close(gains[c], gain, 1e-7) or abs(gains[c] - gain) <= tol, (suite, c, gains[c], gain)
            assert close(tight[c], per) or abs(tight[c] - per) <= tol, (suite, c, tight[c], per)
            assert close(trace[c], tr) or abs(trace[c] - tr) <= tol, (suite, c, trace[c], tr)
            # the order of the three, up to round-off of a gain (a difference of two log dets)
            assert gain <= per + tol and gains[c] <= tight[c] + tol, (suite, c, gain, per)
            assert per <= tr + tol, (suite, c, per, tr)
            checked += 1
    return checked


def test_bounds_match_the_dense_oracle_and_bound_the_gain_on_tiny(tiny_problem):
    suites = [(), (0,), (0, 25)] + draw_suites(len(tiny_problem.library), 3, sizes=(1, 8), seed=16)
    assert check_bounds(tiny_problem, suites) > 300


@HYPOTHESIS
@given(problem=problems(LIBRARY, 3, 6))
def test_bounds_bound_the_gain_on_random_small_problems(problem):
    n = len(problem.library)
    rng = np.random.default_rng(n)
    suites = [(), tuple(sorted(rng.choice(n, size=int(rng.integers(1, n)), replace=False).tolist()))]
    check_bounds(problem, suites)


def test_bound_is_tight_when_the_gains_are_small(suburb_problem):
    """With all but 8 sensors in the suite the gains are a few nats: the bound is never below the
    computed gain by more than its round-off, and within a few percent of it (log(1 + x) ≈ x)."""
    fe = FastEvaluator(suburb_problem)
    n = len(suburb_problem.library)
    out = np.random.default_rng(1).choice(n, size=8, replace=False).tolist()
    suite = tuple(sorted(set(range(n)) - set(out)))
    f = fe.score(suite)
    gains = fe.scores_with(suite, out) - f
    bounds = fe.gain_bounds(suite, out, force=True)
    assert np.all(bounds >= gains - 1e-12 * abs(f))  # round-off of a difference of two log dets ~1e4 nats
    small = gains < 2.0
    assert small.sum() >= 3 and np.all(gains > 0)
    assert np.all(bounds[small] <= 1.05 * gains[small])
    assert np.all(bounds <= 1.5 * gains)


# --------------------------------------------------------------------------- Fischer's score bounds


def check_score_bounds(problem, suites) -> int:
    """On every suite and every candidate: the fast engine's score bounds equal the decoupled dense
    Hessian's log det (to the round-off allowance) and are never below the score; exact on ()."""
    fe, oracle = FastEvaluator(problem), DenseOracle(problem)
    n = len(problem.library)
    checked = 0
    for suite in suites:
        own, each = fe.score_bounds(suite, list(range(n)))
        f = fe.score(suite)
        scores = fe.scores_with(suite, list(range(n)))
        # the engine raises each bound by 1e-9 of its log dets' magnitudes (its round-off allowance)
        want, scale = fischer_oracle(oracle, suite)
        assert abs(own - want) <= 2e-9 * scale and own >= f, (suite, own, want, f)
        if not suite:
            assert abs(own - f) <= 2e-9 * scale  # nothing couples a pose with a landmark: Fischer is an equality
        for c in range(n):
            want, scale = fischer_oracle(oracle, tuple(sorted(set(suite) | {c})))
            assert abs(each[c] - want) <= 2e-9 * scale, (suite, c, each[c], want)
            assert each[c] >= scores[c], (suite, c, each[c], scores[c])
            checked += 1
    return checked


def test_score_bounds_are_the_decoupled_log_det_and_bound_the_score_on_tiny(tiny_problem):
    n = len(tiny_problem.library)
    suites = [(), (0,), (3, 17)] + draw_suites(n, 2, sizes=(2, 9), seed=5)
    assert check_score_bounds(tiny_problem, suites) == 5 * n


@HYPOTHESIS
@given(problem=problems(LIBRARY, 3, 6))
def test_score_bounds_bound_the_score_on_random_small_problems(problem):
    n = len(problem.library)
    rng = np.random.default_rng(n + 1)
    check_score_bounds(
        problem, [(), tuple(sorted(rng.choice(n, size=int(rng.integers(1, n)), replace=False).tolist()))]
    )


def test_score_bounds_spare_most_of_the_first_steps_evaluations(suburb_problem):
    """One pick (at most one sensor): the lazy greedy without bounds scores every sensor; with the
    score bounds it scores the sensors whose bound reaches the best one's score, and picks alike."""
    one = Constraints(max_sensors=1)
    n = len(suburb_problem.library)
    plain = Selector(FastEvaluator(suburb_problem), RULES["uniform"], lazy=True, bound_from=0, constraints=one).select(
        110_000.0
    )
    ev = FastEvaluator(suburb_problem)
    bounded = Selector(ev, RULES["uniform"], lazy=True, constraints=one).select(110_000.0)
    assert same_run(plain, bounded) and len(bounded.steps) == 1
    assert plain.n_evaluations >= n  # every sensor (and the empty suite, once)
    own, each = ev.score_bounds((), list(range(n)))
    reach = int(np.sum(each >= bounded.score))
    assert bounded.n_evaluations <= max(reach, 2) + 1 < n // 4  # batches of 2, and the empty suite once


def test_score_bounds_are_declined_for_a_wide_base_band(tiny_problem):
    """A base coupling keyframes far apart (a loop-closure prior, say) is no narrow band: no bound
    is offered (it would cost a dense factorization); the odometry chain's band is."""
    from sensorsel.information.evaluators.fast.fischer import MAX_HALF_BANDWIDTH, PoseBand

    K = 20
    near = np.array([MAX_HALF_BANDWIDTH]), np.array([0])
    far = np.array([MAX_HALF_BANDWIDTH + 1]), np.array([0])
    assert PoseBand(K, near, np.ones(1)).banded and not PoseBand(K, far, np.ones(1)).banded
    fe = FastEvaluator(tiny_problem)
    assert fe._pose_band.banded and fe.score_bounds((), [0]) is not None
    fe._pose_band = PoseBand(tiny_problem.scenario.n_poses, far, np.ones(1))
    assert fe.score_bounds((), [0]) is None


# --------------------------------------------------------------------------------- the lazy greedy


def same_run(a, b) -> bool:
    """Bit-identical picks and step scores (the evaluation counts may differ: bookkeeping)."""
    return (
        a.suite == b.suite
        and a.score == b.score
        and a.cost_usd == b.cost_usd
        and a.stop_reason == b.stop_reason
        and [(s.pick, s.score, s.gain, s.rule_value) for s in a.steps]
        == [(s.pick, s.score, s.gain, s.rule_value) for s in b.steps]
    )


def runs(problem, budget, rule, constraints=None, jobs=1):
    """(plain, lazy without bounds, lazy with bounds as shipped, lazy with bounds at every step where
    more than one candidate would be re-scored)."""
    out = []
    for lazy, bound_from, spare in ((False, 0, 0.0), (True, 0, 0.0), (True, BOUND_FROM, BOUND_SPARE), (True, 1, 0.0)):
        ev = FastEvaluator(problem, jobs=jobs, bound_spare=spare)
        out.append(
            (
                Selector(ev, RULES[rule], lazy=lazy, bound_from=bound_from, constraints=constraints).select(budget),
                ev.n_bounds,
            )
        )
    return out


@pytest.mark.parametrize("rule", ["uniform", "marginal"])
@pytest.mark.parametrize("budget", [20_000.0, 110_000.0])
def test_bounded_lazy_picks_what_plain_and_lazy_greedy_pick_on_suburb(suburb_problem, rule, budget):
    (plain, _), (lazy, nb0), (bounded, nb), (eager, nb1) = runs(suburb_problem, budget, rule)
    assert nb0 == 0 and nb > 0 and nb1 >= nb
    assert same_run(plain, lazy) and same_run(lazy, bounded) and same_run(lazy, eager)
    assert bounded.n_evaluations < lazy.n_evaluations <= plain.n_evaluations
    assert len(bounded.steps) >= 3


def test_bounded_lazy_picks_the_same_with_constraints_and_threads(tiny_problem):
    c = Constraints(max_sensors=4)
    (plain, _), (lazy, _), (bounded, _), (eager, _) = runs(tiny_problem, 60_000.0, "uniform", constraints=c, jobs=2)
    assert len(plain.suite) == 4
    assert same_run(plain, lazy) and same_run(lazy, bounded) and same_run(lazy, eager)


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(problem=problems(LIBRARY, 3, 6))
def test_bounded_lazy_picks_the_same_on_random_small_problems(problem):
    costs = np.asarray(problem.library.costs, dtype=float)
    for budget in (float(costs.min()), float(np.sort(costs)[:3].sum()), float(costs.sum())):
        for rule in ("uniform", "marginal"):
            (plain, _), (lazy, _), (bounded, _), (eager, _) = runs(problem, budget, rule)
            assert same_run(plain, lazy) and same_run(lazy, bounded) and same_run(lazy, eager), (budget, rule)


def test_bounds_are_declined_when_predicted_dearer_than_the_candidates(tiny_problem):
    fe = FastEvaluator(tiny_problem)
    cost = fe.bound_cost((0,))
    assert cost >= 3.0  # Cholesky and inverse, (3K)³ flops, against a dense Cholesky's (3K)³/3
    few = list(range(1, int(np.ceil(BOUND_SPARE * cost))))
    assert fe.gain_bounds((0,), few) is None and fe.n_bounds == 0
    assert fe.gain_bounds((0,), few + [len(few) + 1]) is not None and fe.n_bounds == 1
    assert fe.gain_bounds((0,), few[:1], force=True) is not None and fe.n_bounds == 2


def test_engines_without_bounds_say_so(tiny_problem):
    assert ReferenceEvaluator(tiny_problem).gain_bounds((), [0, 1]) is None
    small = tiny_problem  # the reference engine's lazy greedy runs without bounds
    a = greedy(ReferenceEvaluator(small), 20_000.0, "uniform")
    b = greedy(FastEvaluator(small), 20_000.0, "uniform")
    assert a.suite == b.suite
