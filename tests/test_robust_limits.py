"""The methods' limits (saturate_levels, saturate_evaluations, local_rounds, local_evaluations,
bound_nodes) reach the methods whichever way a robust run is asked for: robust_select in this process,
run_robust as a plan, worst_route_select on a domain's worst route. Each limit is seen where it
acts: the bound's node count, and SATURATE's and local search's notes naming the limit reached."""

from __future__ import annotations

import pytest

from sensorsel.designs.robust import robust_select, run_robust, worst_route_select
from sensorsel.information.evaluators import make_evaluator
from sensorsel.model.problem import Domain, DomainRoute, build_problem
from sensorsel.model.scenario import ScenarioSpec, load_scenario

BUDGET, ALPHA = 8_000.0, 1
METHODS = ("saturate", "local-search")


def _notes(result) -> dict[str, str]:
    return {c.method: c.note for c in result.candidates if c.method in METHODS}


def test_robust_select_and_run_robust_take_the_limits(tiny_problem):
    ev = make_evaluator(tiny_problem, "fast")
    free = robust_select(ev, BUDGET, ALPHA, methods=METHODS, skip_when_proved=False)
    assert free.bound_detail.n_nodes > 1  # the default node limit splits this one
    assert not any("evaluation limit" in n for n in _notes(free).values())
    kw = dict(methods=METHODS, skip_when_proved=False, bound_nodes=1, saturate_evaluations=3, local_evaluations=3)
    for r in (robust_select(ev, BUDGET, ALPHA, **kw), run_robust(tiny_problem, BUDGET, ALPHA, engine="fast", **kw)):
        assert r.bound_detail.n_nodes == 1
        notes = _notes(r)
        assert "evaluation limit (3) reached" in notes["saturate"]
        assert "evaluation limit (3) reached" in notes["local-search"]


@pytest.fixture(scope="module")
def two_routes(library):
    specs = [ScenarioSpec(fixture="tiny"), ScenarioSpec(fixture="tiny", landmarks="synthetic", landmark_seed=3)]
    routes = tuple(
        DomainRoute(f"r{k}", build_problem(library, load_scenario(s), spec=s), 1.0) for k, s in enumerate(specs)
    )
    return Domain(routes, "test")


def test_the_worst_route_takes_the_limits(two_routes):
    kw = dict(methods=METHODS, skip_when_proved=False, engine="fast")
    free = worst_route_select(two_routes, BUDGET, ALPHA, **kw)
    capped = worst_route_select(two_routes, BUDGET, ALPHA, bound_nodes=1, local_evaluations=3, **kw)
    assert free.bound_detail.n_nodes > 2  # one bound per route, each split under the default limit
    assert capped.bound_detail.n_nodes == 2  # one node per route
    assert "evaluation limit (3) reached" in _notes(capped)["local-search"]
    assert "evaluation limit (3) reached" not in _notes(free)["local-search"]
