"""The greedy's violation floor: a cheaper lower bound on the violation that caps the lazy bounds.

The floor must lie under every violation the route's checks return (the oracle), it must leave the
proved cheapest cost unchanged (brute force, here and in ``test_require_solver``), a greedy
completion capped by it must spare violations, and round-off in it must not change which of two
equally good candidates the greedy takes (the slack)."""

from __future__ import annotations

import numpy as np
import pytest
from oracles import cheapest_by_brute_force

from sensorsel.designs.requirements import oracle
from sensorsel.designs.requirements.domain_checks import DomainChecks, Here
from sensorsel.designs.requirements.oracle import Monotone, mask_of, suite_of
from sensorsel.designs.requirements.solver import _Search, cheapest_suite
from sensorsel.designs.requirements.spec import Specification
from sensorsel.information.evaluators.fast import FastEvaluator
from sensorsel.model.constraints import Constraints, feasible_set
from sensorsel.model.library import load_library

LIB = load_library()
SMALL = ("LRL-roof", "MRL-roof", "LRR-12", "LRR-6", "MRR-12", "WSC-12", "WSC-6", "HD2K-12", "HD2K-6", "HD2K-3")
POS = sorted(LIB.position(i) for i in SMALL)
OUT = Constraints(exclude=tuple(sorted(set(LIB.ids) - set(SMALL))))


def _coverage(weights: np.ndarray, threshold: float):
    """(meets, violation, floor): meets(S) when Σ_k min(1, Σ_s w) >= threshold (monotone);
    violation its shortfall, 0 where it meets; the floor the shortfall itself (exact but for the
    suites within 1e-12 of the threshold)."""

    def value(s: tuple[int, ...]) -> float:
        return float(np.minimum(1.0, weights[list(s)].sum(axis=0)).sum()) if s else 0.0

    def meets(s: tuple[int, ...]) -> bool:
        return value(s) >= threshold - 1e-12

    def floor(s: tuple[int, ...]) -> float:
        return max(0.0, threshold - value(s)) / threshold

    return meets, (lambda s: 0.0 if meets(s) else floor(s)), floor


def _search(feas, meets, violation, floor=None):
    return _Search(feas, 0, Monotone(len(LIB), meets, violation, floor=floor), None, None)


def test_a_capped_completion_spares_violations_and_learns_what_its_floors_refute():
    """From a two-sensor start, a completion capped by an exact floor asks fewer violations than one
    that is not; the suites the floor showed failing are known to fail (never asked again); a search
    that completes its plateaus so still proves brute force's cost."""
    rng = np.random.default_rng(3)
    weights = np.zeros((len(LIB), 6))
    weights[POS] = rng.uniform(0.0, 0.5, (len(POS), 6))
    feas = feasible_set(LIB, float("inf"), OUT)
    meets, violation, floor = _coverage(weights, 4.5)
    start = 1 << POS[2] | 1 << POS[5]
    asked: dict[bool, int] = {}
    refuted: set[tuple[int, ...]] = set()  # suites the floor showed failing

    def floor_seen(s):
        v = floor(s)
        if v > 1e-6:
            refuted.add(s)
        return v

    for capped in (False, True):
        n = [0]

        def counted(s, n=n):
            n[0] += 1
            return violation(s)

        search = _search(feas, meets, counted, floor_seen)
        got = search.greedy(start, capped=capped)
        assert got is not None and meets(suite_of(got))
        asked[capped] = n[0]
    assert asked[True] < asked[False] / 2, asked
    assert refuted and all(search.down.infer(mask_of(s)) is False for s in refuted)
    got = cheapest_suite(feas, meets, violation=violation, violation_floor=floor)
    assert got.status == "optimal" and got.cost == pytest.approx(cheapest_by_brute_force(feas, meets, 0, POS))


def _tie():
    """Two cameras of one price (a, b) and a radar (c): a suite meets when it holds c and a or b.
    From nothing, a and b remove the same violation per dollar: the greedy takes a (first in
    library order), then c."""
    a, b = sorted(LIB.position(i) for i in ("HD2K-12", "HD2K-6"))
    c = LIB.position("LRR-12")
    feas = feasible_set(LIB, float("inf"), OUT)
    assert feas.A[0, a] == feas.A[0, b] < feas.A[0, c]

    def meets(s):
        return c in s and (a in s or b in s)

    def violation(s):
        return 0.0 if meets(s) else 1.0 - 0.5 * (a in s or b in s) - 0.4 * (c in s)

    return feas, meets, violation, (a, b, c)


def test_a_floor_a_hair_above_the_violation_does_not_change_the_greedys_choice(monkeypatch):
    """The floor of suites holding a sits 1e-12 above their violation (round-off, computed another
    way): without the slack, a's cap falls under b's value and the greedy takes b instead."""
    feas, meets, violation, (a, b, c) = _tie()

    def floor(s):
        return violation(s) * (1 + 1e-12) if a in s else violation(s)

    want = 1 << a | 1 << c
    assert _search(feas, meets, violation).greedy(0) == want
    assert _search(feas, meets, violation, floor).greedy(0, capped=True) == want
    monkeypatch.setattr(oracle, "FLOOR_SLACK", 0.0)  # the guard removed: the other camera is taken
    assert _search(feas, meets, violation, floor).greedy(0, capped=True) == 1 << b | 1 << c


def test_a_completion_stops_once_its_failing_suite_costs_its_limit():
    """From nothing the greedy takes a (failing alone), then c. With a limit at a's price it stops
    after a: no suite, and none of its second step's violations asked; with a limit above a's price
    it goes on to the suite it finds without one. (Without the stop, the first search returns a
    and c.)"""
    feas, meets, violation, (a, b, c) = _tie()
    price = feas.A[0]
    asked: list[tuple[int, ...]] = []

    def counted(s):
        asked.append(s)
        return violation(s)

    assert _search(feas, meets, counted).greedy(0, limit=float(price[a])) is None
    assert not any(a in s and len(s) > 1 for s in asked)  # no candidate of the step after a
    assert _search(feas, meets, violation).greedy(0, limit=float(price[a] + price[c])) == 1 << a | 1 << c
    assert _search(feas, meets, violation).greedy(0) == 1 << a | 1 << c


def test_a_floor_needs_the_violation_it_bounds():
    feas, meets, violation, _ = _tie()
    with pytest.raises(ValueError, match="violation floor"):
        cheapest_suite(feas, meets, violation_floor=violation)


@pytest.mark.parametrize("estimate", ["filter", "smoother"])
def test_the_routes_floor_is_under_every_violation_they_return(tiny_problem, suburb_problem, estimate):
    """On two real routes, along a greedy-like chain of suites (each with its next one-sensor
    extensions): the floor is under the violation, asked before it and after it (then equal), and
    asking it computes nothing (the counts unchanged)."""
    spec = Specification(lateral=0.05, heading=0.2)
    checks = DomainChecks(
        Here([FastEvaluator(p) for p in (tiny_problem, suburb_problem)]),
        ["tiny", "suburb"],
        [spec, spec],
        0.05,
        estimate,
    )
    chain = [LIB.position(i) for i in ("HD2K-3", "WSC-6", "LRR-12", "HD2K-9", "WSC-12", "MRR-12", "LRL-roof")]
    suite: tuple[int, ...] = ()
    strictly = 0
    for k, p in enumerate(chain):
        suite = tuple(sorted((*suite, p)))
        for q in chain[k + 1 : k + 3] + [p]:
            grown = tuple(sorted({*suite, q}))
            counts = {n: checks.count(n) for n in ("n_checks", "n_refuted", "n_accepted")}
            before = checks.violation_floor(grown)
            assert {n: checks.count(n) for n in counts} == counts
            v = checks.violation(grown)
            assert before <= v + 1e-12 * (1 + v)
            assert checks.violation_floor(grown) == v  # known now: the value itself
            strictly += before < v
    assert strictly > 0, "the floor was never below a violation: nothing tested"
