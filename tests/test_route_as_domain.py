"""A route is a domain of one route: ``target.routes`` reads alike on a problem and on a domain, and
what a design computes per route on a problem is what it computes on the domain holding that route
alone, and what the route's own engine gives (the oracle: the engine called directly)."""

from __future__ import annotations

import numpy as np

from sensorsel.api import suite_accuracy, suite_integrity
from sensorsel.designs.requirements.front import front_acceptance
from sensorsel.information.evaluators import make_evaluator
from sensorsel.information.evaluators.accuracy import route_accuracy
from sensorsel.model.problem import Domain, DomainRoute

SUITE = ("MRL-roof", "HD2K-10", "HD2K-4")


def test_a_problem_reads_as_its_one_route(tiny_problem):
    (member,) = tiny_problem.routes
    assert member.problem is tiny_problem
    assert (member.name, member.weight) == (tiny_problem.scenario.name, 1.0)


def test_per_route_accuracy_on_a_route_is_the_one_route_domains_and_the_engines(tiny_problem):
    one = Domain((DomainRoute(tiny_problem.scenario.name, tiny_problem, 1.0),), "one route")
    got = suite_accuracy(tiny_problem, SUITE)
    assert len(got) == 1 and got == suite_accuracy(one, SUITE)
    positions = tiny_problem.library.resolve_suite(SUITE)
    direct = route_accuracy(
        make_evaluator(tiny_problem), positions, route=tiny_problem.scenario.name, estimate="filter"
    )
    assert got[0].route == tiny_problem.scenario.name
    np.testing.assert_array_equal(got[0].lateral_sigma_m, direct.lateral_sigma_m)
    assert [r.route for r in suite_integrity(tiny_problem, SUITE)] == [tiny_problem.scenario.name]


def test_a_front_is_judged_on_a_routes_one_member(tiny_problem):
    cost = float(tiny_problem.library.cost(tiny_problem.library.resolve_suite(SUITE)))
    got = front_acceptance(tiny_problem, [(SUITE, cost, 1.0)], None, map_sigma_m=None)
    (point,) = got.points
    assert [a.route for a in point.accuracy] == [tiny_problem.scenario.name]
