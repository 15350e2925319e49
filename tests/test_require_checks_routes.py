"""A domain's checks skip the routes a subset already meets: the answers (meets, violation) are
those of computing every route afresh, for either estimate, with fewer computations."""

from __future__ import annotations

import pytest

from sensorsel.designs.requirements.domain_checks import DomainChecks, Here
from sensorsel.designs.requirements.spec import Specification
from sensorsel.information.evaluators.fast import FastEvaluator
from sensorsel.model.library import load_library

LIB = load_library()
#: the greedy's path: each suite is the last plus one sensor, with every one-sensor extension asked
CHAIN = ("HD2K-3", "WSC-6", "LRR-12", "HD2K-9", "WSC-12", "MRR-12", "HD2K-6", "LRL-roof")


@pytest.mark.parametrize("estimate", ["filter", "smoother"])
def test_routes_met_by_a_subset_answer_as_if_computed(tiny_problem, suburb_problem, estimate):
    spec = Specification(lateral=0.05, heading=0.2)  # met on one route before the other
    problems = (tiny_problem, suburb_problem)
    shared = DomainChecks(Here([FastEvaluator(p) for p in problems]), ["tiny", "suburb"], [spec, spec], 0.05, estimate)

    def afresh(suite: tuple[int, ...]) -> tuple[bool, float]:
        # a new oracle knows nothing: it computes every route (the answer before the skip)
        o = DomainChecks(Here([FastEvaluator(p) for p in problems]), ["tiny", "suburb"], [spec, spec], 0.05, estimate)
        return o.meets(suite), o.violation(suite)

    positions = [LIB.position(i) for i in CHAIN]
    suite: tuple[int, ...] = ()
    asked = 0
    verdicts = set()
    for k, p in enumerate(positions):
        suite = tuple(sorted((*suite, p)))
        for q in positions[k + 1 : k + 4]:  # the candidates the greedy tries from this suite
            grown = tuple(sorted((*suite, q)))
            assert shared.violation(grown) == afresh(grown)[1]
            asked += 1
        meets, violation = afresh(suite)
        assert shared.violation(suite) == violation
        assert shared.meets(suite) == meets
        verdicts.add((meets, violation > 0))
        asked += 1
    assert verdicts == {(False, True), (True, False)}, "the chain never crosses the specification"
    # routes met by a subset were answered without their marginals
    assert shared.count("n_met_below") > 0
    assert shared.count("n_checks") < 2 * asked
