"""Recipes: what a worker rebuilds a problem or a domain from (a few kilobytes, never a matrix).

A linearized problem does not pickle, and need not: a Dask worker receives a :class:`TargetRecipe`
and builds the same problem, bit for bit, from its library, settings, route spec (or its own
scenario), condition and names.
"""

from __future__ import annotations

from dataclasses import dataclass

from sensorsel.model.conditions import Condition
from sensorsel.model.library import SensorLibrary
from sensorsel.model.osm.track import load_geo_scenario
from sensorsel.model.problem import Domain, DomainRoute, GraphSettings, Problem, Target, build_problem, check_reach
from sensorsel.model.scenario import Scenario, ScenarioSpec


@dataclass(frozen=True)
class RouteRecipe:
    """What a worker needs to rebuild one route's problem: a few kilobytes, never a matrix (a
    linearized GTSAM graph does not pickle, and need not).

    ``scenario`` is sent only when the problem was built from objects (no ``spec`` to load from);
    ``condition`` always (a problem put under one in Python has no spec to carry it: clear, else).
    """

    name: str
    library: SensorLibrary
    settings: GraphSettings
    spec: ScenarioSpec | None
    scenario: Scenario | None = None
    condition: Condition | None = None

    @classmethod
    def of(cls, name: str, problem: Problem) -> RouteRecipe:
        own = None if problem.spec is not None else problem.scenario
        return cls(name, problem.library, problem.settings, problem.spec, own, problem.condition)

    def build(self) -> Problem:
        if self.scenario is not None:
            sc = self.scenario
        else:
            assert self.spec is not None
            sc = load_geo_scenario(self.spec)
        problem = build_problem(self.library, sc, self.settings, spec=self.spec, condition=self.condition)
        check_reach(problem)
        return problem


@dataclass(frozen=True)
class TargetRecipe:
    """A problem or a domain, as a worker rebuilds it (routes as :class:`RouteRecipe`)."""

    routes: tuple[RouteRecipe, ...]
    weights: tuple[float, ...] | None  # None: one problem
    units: tuple[str, ...] = ()
    source: str = ""
    members: tuple[tuple[str, str], ...] = ()  # each member's (route, condition) names, as DomainRoute has them

    @classmethod
    def of(cls, target: Target) -> TargetRecipe:
        if isinstance(target, Domain):
            return cls(
                tuple(RouteRecipe.of(r.name, r.problem) for r in target.routes),
                tuple(r.weight for r in target.routes),
                tuple(r.unit for r in target.routes),
                target.source,
                tuple((r.route, r.condition) for r in target.routes),
            )
        return cls((RouteRecipe.of("", target),), None)

    def build(self) -> Target:
        if self.weights is None:
            return self.routes[0].build()
        names = self.members or (("", ""),) * len(self.routes)
        return Domain(
            tuple(
                DomainRoute(r.name, r.build(), w, u, *n)
                for r, w, u, n in zip(self.routes, self.weights, self.units, names)
            ),
            self.source,
        )


@dataclass(frozen=True)
class EvaluatorRecipe:
    """What a worker builds an evaluator from (a tradespace's rules, robust's methods): the target's recipe and
    the engine settings; the evaluator itself is made where the tasks run."""

    target: TargetRecipe
    engine: str | None
    jobs: int = 1
    aggregate: str = "normalised"

    def build(self) -> tuple[Target, EvaluatorRecipe]:
        """The target, built where the rules run, once for all of them (each rule's evaluator is its own)."""
        return self.target.build(), self
