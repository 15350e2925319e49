"""The solver's time limit holds inside every step (the greedy upper bound, the growth of failing
sets, the parts checked after failures), measured on an injected clock that advances one unit per
reading: the limit then falls after a known number of readings, with no timing in the test."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from sensorsel.designs.requirements.solver import cheapest_suite, meets_after_failures
from sensorsel.model.constraints import Constraints, feasible_set
from sensorsel.model.library import load_library

LIB = load_library()
SMALL = ("LRL-roof", "MRL-roof", "LRR-12", "LRR-6", "LRR-3", "MRR-12", "WSC-12", "WSC-6", "HD2K-12", "HD2K-6")
POS = sorted(LIB.position(i) for i in SMALL)


class _Ticks:
    """A clock that advances 1 s per reading."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        self.now += 1.0
        return self.now


def _case(seed: int):
    rng = np.random.default_rng(seed)
    weights = np.zeros((len(LIB), 8))
    weights[POS] = rng.uniform(0.0, 0.5, (len(POS), 8))
    calls: list[tuple[int, ...]] = []

    def value(s: tuple[int, ...]) -> float:
        return float(np.minimum(1.0, weights[list(s)].sum(axis=0)).sum()) if s else 0.0

    def meets(s: tuple[int, ...]) -> bool:
        calls.append(s)
        return value(s) >= 6.0

    def violation(s: tuple[int, ...]) -> float:
        calls.append(s)
        return max(0.0, 6.0 - value(s))

    feas = feasible_set(LIB, float("inf"), Constraints(exclude=tuple(sorted(set(LIB.ids) - set(SMALL)))))
    return feas, meets, violation, calls, value


def _brute(feas, value, alpha: int) -> float:
    best = float("inf")
    for k in range(alpha + 1, len(POS) + 1):
        for combo in itertools.combinations(POS, k):
            if all(value(tuple(sorted(set(combo) - set(f)))) >= 6.0 for f in itertools.combinations(combo, alpha)):
                best = min(best, float(feas.A[0, list(combo)].sum()))
    return best


@pytest.mark.parametrize("alpha", [0, 1])
def test_the_greedy_stops_at_the_time_limit(alpha):
    feas, meets, violation, calls, _ = _case(3)
    full = cheapest_suite(feas, meets, failures=alpha, violation=violation, clock=_Ticks())
    # the greedy alone asks many suites: a limit of 5 readings falls inside it
    assert full.status == "optimal" and full.n_checks > 15
    calls.clear()
    cut = cheapest_suite(feas, meets, failures=alpha, violation=violation, time_limit=5, clock=_Ticks())
    assert cut.status == "gap" and not cut.proved
    assert "time limit (5 s)" in cut.stop
    # start, then one reading before each call: the sixth reading is past the limit
    assert cut.n_checks == len(calls) <= 5
    assert cut.iterations == 0 and cut.lower_bound <= full.cost


@pytest.mark.parametrize("alpha, floor", [(0, False), (1, False), (0, True)])
def test_every_limit_gives_valid_bounds_and_a_suite_that_meets(alpha, floor):
    """Wherever the limit falls (greedy, growth, more cuts, ties), both bounds stay true and the
    suite reported meets the requirement after the failures; with a violation floor too (the capped
    completions, which may stop early, read the same clock)."""
    feas, meets, violation, calls, value = _case(11)
    # the floor: the violation itself, not counted (a floor is not a check)
    kw = {"violation": violation, "violation_floor": (lambda s: max(0.0, 6.0 - value(s))) if floor else None}
    best = _brute(feas, value, alpha)
    full = cheapest_suite(feas, meets, failures=alpha, clock=_Ticks(), **kw)
    assert full.status == "optimal" and full.cost == pytest.approx(best)
    seen = set()
    for limit in range(1, full.n_checks + 2 * full.iterations + 8, 3):
        calls.clear()
        got = cheapest_suite(feas, meets, failures=alpha, time_limit=limit, clock=_Ticks(), **kw)
        assert got.n_checks == len(calls) <= limit
        assert got.lower_bound <= best + 1e-6
        if got.status == "gap":
            assert "time limit" in got.stop
        else:
            assert got.status == "optimal" and got.cost == pytest.approx(best)
        if got.suite is not None:
            assert got.cost >= best - 1e-6
            assert meets_after_failures(lambda s: value(s) >= 6.0, [got.suite], failures=alpha) == (True,)
        seen.add(got.status)
    assert seen == {"gap", "optimal"}


def test_a_requirement_that_is_not_monotone_stops_at_the_limit_too():
    """The full check and both relaxations read the clock as well (no greedy here: the growth of
    failing sets, the shrinking of the anti-monotone ones and the no-goods)."""
    feas, _, _, calls, value = _case(5)

    def down(s: tuple[int, ...]) -> bool:
        calls.append(s)
        return value(s) >= 6.0

    def up(s: tuple[int, ...]) -> bool:  # at most five sensors: anti-monotone
        calls.append(s)
        return len(s) <= 5

    def full(s: tuple[int, ...]) -> bool:
        calls.append(s)
        return value(s) >= 6.0 and len(s) <= 5 and len(s) != 4  # no structure: four sensors never do

    kw = dict(monotone=False, necessary_monotone=down, necessary_antimonotone=up)
    whole = cheapest_suite(feas, full, clock=_Ticks(), **kw)
    assert whole.status == "optimal" and whole.n_checks > 10
    for limit in range(1, whole.n_checks + 2 * whole.iterations + 8, 2):
        calls.clear()
        got = cheapest_suite(feas, full, time_limit=limit, clock=_Ticks(), **kw)
        assert got.n_checks == len(calls) <= limit
        assert got.lower_bound <= whole.cost + 1e-6
        assert got.status == "optimal" or "time limit" in got.stop
        if got.suite is not None:
            assert full(got.suite) and got.cost >= whole.cost - 1e-6
