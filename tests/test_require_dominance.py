"""Dominance among sensors in require's search, and filter passes stopped early: each against an
independent oracle (the filter's covariances themselves, brute force over every suite)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from oracles import cheapest_by_brute_force

from sensorsel.designs.requirements.dominance import dominance_order, information_dominance
from sensorsel.designs.requirements.solver import cheapest_suite
from sensorsel.designs.requirements.spec import Specification, covariance_verdict
from sensorsel.designs.requirements.truncated import bad_keyframes, meets_from_bad
from sensorsel.information.filtering import forward_pass
from sensorsel.model.constraints import Constraints, feasible_set
from sensorsel.model.library import load_library

LIB = load_library()


def test_a_dominated_sensor_swapped_for_its_dominator_never_loses_accuracy(suburb_problem):
    """The definition's promise, checked on the filter itself: for every pair (w, s) found on the
    bundled route, a suite holding w, with s in w's place, has covariances ⪯ at every keyframe."""
    pairs = information_dominance([suburb_problem])
    assert pairs, "the bundled library has dominated sensors (a stereo camera and the wide one at its position)"
    ids = LIB.ids
    # the narrow stereo camera at each clock position is dominated by the wide one there, not the reverse
    assert (LIB.position("LSC-3"), LIB.position("WSC-3")) in pairs
    assert (LIB.position("WSC-3"), LIB.position("LSC-3")) not in pairs
    rng = np.random.default_rng(3)
    for w, s in [pairs[i] for i in rng.choice(len(pairs), size=min(6, len(pairs)), replace=False)]:
        others = [i for i in rng.choice(len(ids), size=3, replace=False) if i not in (w, s)]
        weak = forward_pass(suburb_problem, sorted([w, *others]), map_sigma_m=0.05).filtered
        strong = forward_pass(suburb_problem, sorted([s, *others]), map_sigma_m=0.05).filtered
        lowest = min(np.linalg.eigvalsh(a - b).min() for a, b in zip(weak, strong))
        assert lowest >= -1e-12 * float(np.abs(weak).max()), (ids[w], ids[s], lowest)


def test_dominance_order_keeps_only_pairs_no_dearer_and_within_every_row():
    """The order rows need s no dearer than w in every row, w not required, neither excluded, and
    one direction of an equivalent pair."""
    a, b, c = (LIB.position(x) for x in ("LSC-3", "WSC-3", "HD2K-3"))
    feas = feasible_set(LIB, float("inf"), None)
    pairs = [(a, b), (b, c), (c, b)]  # pretend b ⪯ c and c ⪯ b as well
    got = dominance_order(feas, pairs)
    assert (a, b) not in got  # WSC is dearer than LSC: no order
    equal = np.array_equal(feas.A[:, b], feas.A[:, c])
    assert ((b, c) in got) == (not equal and bool(np.all(feas.A[:, c] <= feas.A[:, b])) or (equal and c < b))
    required = feasible_set(LIB, float("inf"), Constraints(require=("LSC-3",)))
    assert all(w != a for w, _ in dominance_order(required, [(a, c)]))


# --- the symmetric case, on a synthetic monotone predicate: many sensors of one price ------------

#: eight sensors of one model (one price) at clock positions, and two dearer ones
SYMMETRIC = tuple(f"HD2K-{k}" for k in range(1, 9))
POS = sorted(LIB.position(i) for i in SYMMETRIC + ("WSC-3", "LRR-6"))


def _coverage(weights: np.ndarray, threshold: float):
    def value(s: tuple[int, ...]) -> float:
        return float(np.minimum(1.0, weights[list(s)].sum(axis=0)).sum()) if s else 0.0

    return (lambda s: value(s) >= threshold - 1e-12), (lambda s: max(0.0, threshold - value(s)) / threshold)


def _brute(feas, meets, alpha: int) -> float | None:
    return cheapest_by_brute_force(feas, meets, alpha, POS)


def _weight_dominance(weights: np.ndarray) -> list[tuple[int, int]]:
    """(w, s): s covers every 'keyframe' at least as much as w (so the coverage is no lower with s)."""
    return [(w, s) for w in POS for s in POS if w != s and np.all(weights[w] <= weights[s])]


@settings(max_examples=15, deadline=None)
@given(data=st.data())
def test_symmetric_library_cheapest_cost_equals_brute_force(data):
    """Sensors of one price, many of them identical (a clock position's copies) or dominated: the
    solver with the dominance swaps and order rows finds the brute-force cheapest cost, with 0 or 1
    failures and with limits."""
    rng = np.random.default_rng(data.draw(st.integers(0, 2**31)))
    weights = np.zeros((len(LIB), 5))
    kinds = rng.uniform(0.0, 0.6, (3, 5)) * (rng.uniform(size=(3, 5)) < 0.7)
    for k, i in enumerate(POS):
        weights[i] = kinds[k % 3] * (1.0 if rng.uniform() < 0.7 else rng.uniform(0.3, 1.0))  # copies, some weaker
    threshold = data.draw(st.floats(0.5, 4.0))
    alpha = data.draw(st.sampled_from([0, 0, 1]))
    exclude = tuple(sorted(set(LIB.ids) - {LIB.ids[i] for i in POS}))
    limit = data.draw(st.sampled_from(["none", "sensors", "require"]))
    c = Constraints(exclude=exclude)
    if limit == "sensors":
        c = Constraints(exclude=exclude, max_sensors=data.draw(st.integers(2, 6)))
    elif limit == "require":
        c = Constraints(exclude=exclude, require=(data.draw(st.sampled_from(SYMMETRIC)),))
    feas = feasible_set(LIB, float("inf"), c)
    meets, violation = _coverage(weights, threshold)
    pairs = _weight_dominance(weights)
    want = _brute(feas, meets, alpha)
    got = cheapest_suite(feas, meets, failures=alpha, violation=violation, dominance=pairs)
    if want is None:
        assert got.status == "infeasible"
        return
    assert got.status == "optimal", got
    assert got.cost == pytest.approx(want) and got.lower_bound <= want + 1e-6
    assert feas.fits(got.suite) and all(
        meets(tuple(sorted(set(got.suite) - set(f)))) for f in itertools.combinations(got.suite, alpha)
    )
    assert set(got.ordered) <= set(pairs)
    if any(feas.A[0, w] == feas.A[0, s] for w, s in got.ordered):
        assert not got.ties_exhaustive  # suites with w in place of s were not searched


def test_identical_sensors_take_fewer_checks_with_dominance():
    """Eight identical sensors of one price: the swaps and the order rows answer from what is known
    (the same cost, fewer calls of the predicate)."""
    weights = np.zeros((len(LIB), 4))
    for i in POS:
        weights[i] = [0.3, 0.3, 0.0, 0.2] if LIB.ids[i].startswith("HD2K") else [0.5, 0.5, 0.5, 0.5]
    meets, violation = _coverage(weights, 2.4)
    exclude = tuple(sorted(set(LIB.ids) - {LIB.ids[i] for i in POS}))
    feas = feasible_set(LIB, float("inf"), Constraints(exclude=exclude))
    plain = cheapest_suite(feas, meets, violation=violation)
    fast = cheapest_suite(feas, meets, violation=violation, dominance=_weight_dominance(weights))
    assert plain.status == fast.status == "optimal" and fast.cost == pytest.approx(plain.cost)
    assert fast.cost == pytest.approx(_brute(feas, meets, 0))
    assert fast.n_checks < plain.n_checks and fast.ordered


def test_a_dearer_dominator_is_not_ordered_and_the_answer_stays_cheapest():
    """A sensor dominated by a dearer one must stay free in the programs: the cheap one alone meets,
    its dearer dominator is not needed (the order rows would force it in if prices were ignored)."""
    cheap, dear = LIB.position("LSC-3"), LIB.position("WSC-3")
    weights = np.zeros((len(LIB), 3))
    weights[cheap], weights[dear] = [1.0, 1.0, 0.0], [1.0, 1.0, 1.0]
    meets, violation = _coverage(weights, 2.0)
    exclude = tuple(sorted(set(LIB.ids) - {"LSC-3", "WSC-3"}))
    feas = feasible_set(LIB, float("inf"), Constraints(exclude=exclude))
    got = cheapest_suite(feas, meets, violation=violation, dominance=[(cheap, dear)])
    assert got.suite == (cheap,) and got.status == "optimal" and not got.ordered


# --- passes stopped early -----------------------------------------------------------------------


def test_a_pass_stopped_early_gives_the_whole_pass_numbers(suburb_problem):
    suite = tuple(LIB.position(x) for x in ("LRR-7", "HD2K-1", "HD2K-5", "HD2K-8"))
    whole = forward_pass(suburb_problem, suite, map_sigma_m=0.05)
    part = forward_pass(suburb_problem, suite, map_sigma_m=0.05, until=17)
    np.testing.assert_array_equal(part.filtered, whole.filtered[:17])
    np.testing.assert_array_equal(part.predicted, whole.predicted[:17])


@pytest.mark.parametrize("at", [1.0, 0.9, 0.5])
def test_bad_keyframes_decide_as_covariance_verdict(at):
    """The per-keyframe rule agrees with the verdict on the whole array, at every share of keyframes."""
    rng = np.random.default_rng(11)
    spec = Specification(lateral=0.1, longitudinal=0.12, heading=0.2, at=at)
    for _ in range(200):
        K = int(rng.integers(1, 30))
        sig = rng.uniform(0.01, 0.08, (K, 3)) * np.where(rng.uniform(size=(K, 3)) < 0.15, 3.0, 1.0)
        sig[:, 2] = np.radians(sig[:, 2] * 3)
        cov = np.zeros((K, 3, 3))
        cov[:, [0, 1, 2], [0, 1, 2]] = sig**2
        assert meets_from_bad(bad_keyframes(cov, spec), K, spec) == covariance_verdict(cov, spec)[0]


def test_require_stops_passes_early_in_the_brute_forced_case(tiny_problem):
    """The case tests/test_require.py checks against enumeration with whole passes (ten sensors,
    prior map, lateral 0.06 m and heading 0.1 deg) refutes suites by a failing subset's early bad
    keyframes, and, with that off, takes passes stopped early: that brute-force test is the oracle
    of both."""
    from test_require import _small

    from sensorsel.designs.requirements.checks import RouteOracle
    from sensorsel.designs.requirements.design import require

    spec = Specification(lateral=0.06, heading=0.1)
    r = require(tiny_problem, spec, map_sigma_m=0.05, constraints=_small(tiny_problem.library))
    # with the refutation by a failing subset's early bad keyframes off, the passes stopped early
    # answer what it answered (the same suite, fewer suites refuted without a pass)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(RouteOracle, "refute_before_seen", False)
        mp.setattr(RouteOracle, "window_bounds", False)  # they would decide most of those suites first
        off = require(tiny_problem, spec, map_sigma_m=0.05, constraints=_small(tiny_problem.library))
    assert off.status == "optimal" and 0 < off.n_short < off.n_checks
    assert (r.status, r.suite, r.cost_usd) == (off.status, off.suite, off.cost_usd)
    assert r.n_refuted > off.n_refuted


def test_a_domain_asks_every_route_every_question(tiny_problem, suburb_problem):
    """A suite that fails one route is still asked of the other (each route learns from every
    suite), and every answer is 'meets on every route' as each route's own whole-pass verdict says."""
    from sensorsel.designs.requirements.domain_checks import DomainChecks, Here
    from sensorsel.information.evaluators.fast import FastEvaluator

    spec = Specification(lateral=0.2, heading=0.5)
    evs = [FastEvaluator(tiny_problem), FastEvaluator(suburb_problem)]
    oracle = DomainChecks(Here(evs), ["tiny", "suburb"], [spec, spec], 0.05, "filter")
    suites = [
        (LIB.position("LRL-roof"),),
        (LIB.position("HD2K-3"),),
        tuple(sorted((LIB.position("WSC-3"), LIB.position("HD2K-6")))),
        tuple(LIB.position(x) for x in ("LRR-7", "HD2K-1", "HD2K-5", "HD2K-8")),
        tuple(sorted((LIB.position("LRR-12"), LIB.position("WSC-6")))),
    ]
    split, asked = False, [0, 0]
    for s in suites:
        truth = [
            covariance_verdict(forward_pass(p, s, map_sigma_m=0.05).filtered, spec)[0]
            for p in (tiny_problem, suburb_problem)
        ]
        assert oracle.meets(s) == all(truth)
        split = split or truth[0] != truth[1]
        # each route's own oracle, where it lives, was asked this suite too, and answers as its pass
        for i, (ev, t) in enumerate(zip(evs, truth)):
            (route,) = ev.kept.values()
            assert route.n_asked == asked[i] + 1 and route.meets(s) == t
            asked[i] = route.n_asked
    assert split, "no suite met one route and failed the other: the case shows nothing"
    oracle.close()
    assert all(not ev.kept for ev in evs)


def test_a_failing_subsets_bad_keyframes_before_the_added_sensor_measures_refute_the_suite(suburb_problem):
    """A suite S of the README tour's growth meets local streets but at keyframe 1 (heading, as the
    car drives; its smoother meets it everywhere); MRR-6 measures nothing before keyframe 16.
    S + MRR-6's own whole pass equals S's before 16 (the property the refutation rests on: to
    rounding, as its state also holds landmarks S dropped), and fails: the oracle refutes it from S's
    answer without a pass (with the refutation off, it computes one)."""
    from sensorsel.designs.requirements.checks import RouteOracle
    from sensorsel.information.evaluators.fast import FastEvaluator

    p = suburb_problem
    spec = Specification(lateral=0.1, longitudinal=0.1, heading=0.17)
    ids = ("LRR-5", "HD2K-12", "HD2K-1", "HD2K-2", "HD2K-3", "HD2K-4", "HD2K-5", "HD2K-6", "LSC-11")
    s = tuple(sorted(LIB.position(x) for x in ids))
    added = LIB.position("MRR-6")
    t = tuple(sorted((*s, added)))
    first = int(np.min(p.observations[added].pose))
    assert first == 16
    alone, both = forward_pass(p, s, map_sigma_m=0.05).filtered, forward_pass(p, t, map_sigma_m=0.05).filtered
    scale = np.abs(alone[:first]).max(axis=(1, 2))[:, None, None]  # each keyframe's largest entry
    assert np.all(np.abs(both[:first] - alone[:first]) <= 1e-12 * scale)
    assert not np.allclose(alone[first], both[first], rtol=1e-6, atol=0)
    assert not covariance_verdict(both, spec)[0]
    assert [b.tolist() for b in bad_keyframes(alone, spec)] == [[], [], [1]]

    def oracle() -> RouteOracle:
        o = RouteOracle(FastEvaluator(p), p, "suburb", spec, 0.05, "filter")
        assert not o.meets(s)  # by its pass: its bad keyframes kept
        return o

    on = oracle()
    checks = on.n_checks
    assert checks > 0 and not on.meets(t)
    assert (on.n_checks, on.n_before_seen) == (checks, 1)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(RouteOracle, "refute_before_seen", False)
        mp.setattr(RouteOracle, "window_bounds", False)  # they would refute it without a pass too
        off = oracle()
        checks = off.n_checks
        assert not off.meets(t)
        assert off.n_checks > checks and off.n_before_seen == 0
