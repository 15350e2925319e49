"""The acceptable region of the Pareto front: which suites of a cost–performance front meet a
specification in metres (the paper's open question: "which regions of the Pareto front are
acceptable").

Each front suite's accuracy is computed on every route (:func:`sensorsel.api`-level evaluators, one
per route, built once); a suite is acceptable when every route meets its specification. Because
meeting is monotone in the suite but the front's suites are not nested, acceptability along the
front need not be monotone in cost: each point is judged on its own.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from sensorsel.designs.requirements.spec import Specification, at_rank, verdict
from sensorsel.information.evaluators import as_suite, make_evaluator
from sensorsel.information.evaluators.accuracy import Z95, RouteAccuracy, estimate_label, model_label, route_accuracy
from sensorsel.io.results import result_kind
from sensorsel.model.problem import Target, TargetInfo

__all__ = ["FrontPoint", "FrontAcceptance", "front_acceptance"]


@dataclass(frozen=True)
class FrontPoint:
    """One suite of the front with its accuracy.

    Attributes:
        suite: sensor ids.
        cost_usd: its cost [$].
        score: its score (nats, or a domain's share).
        lateral_95_m: the largest, over the routes, of the lateral 95 % error (1.96σ) at the
            specification's share of keyframes (every keyframe without a specification) [m].
        accuracy: its accuracy on each route.
        meets: whether it meets the specification on every route (None without one).
        violation: how far it misses (0 when it meets; None without a specification).
    """

    suite: tuple[str, ...]
    cost_usd: float
    score: float
    lateral_95_m: float
    accuracy: tuple[RouteAccuracy, ...]
    meets: bool | None
    violation: float | None


@result_kind("front-acceptance")
@dataclass(frozen=True)
class FrontAcceptance:
    """A front's suites against a specification.

    Attributes:
        model, map_sigma_m: the localization model (:mod:`sensorsel.information.evaluators.accuracy`).
        specifications: (route, its specification) pairs, or () without one.
        points: the front's suites, cheapest first.
        problem: what it was computed on.
        estimate: "filter" (as the car drives) or "smoother" (the whole route); files written
            before estimates existed hold the smoother's, and load so.
    """

    model: str
    map_sigma_m: float | None
    specifications: tuple[tuple[str, Specification], ...]
    points: tuple[FrontPoint, ...]
    problem: TargetInfo | None = None
    estimate: str = "smoother"

    @property
    def model_label(self) -> str:
        return f"{model_label(self.model, self.map_sigma_m)}, {estimate_label(self.estimate)}"

    @property
    def cheapest_meeting(self) -> FrontPoint | None:
        """The cheapest front suite that meets the specification, if any."""
        return next((p for p in self.points if p.meets), None)


def front_acceptance(
    target: Target,
    front: Sequence[tuple[Sequence[str], float, float]],
    specifications: Sequence[Specification] | None,
    *,
    map_sigma_m: float | None,
    engine: str | None = None,
    estimate: str = "filter",
) -> FrontAcceptance:
    """Each front suite ``(ids, cost, score)``'s accuracy on every route of ``target`` and whether
    it meets ``specifications`` (one per route in the domain's order, or None: accuracy only);
    ``estimate``: the filter's (as the car drives) or the smoother's (each accuracy records it)."""
    routes = [(r.name, r.problem) for r in target.routes]
    evaluators = [make_evaluator(p, engine) for _, p in routes]
    lib = target.library
    points = []
    for ids, cost, score in front:
        positions = as_suite(lib.resolve_suite(list(ids)))
        accs = tuple(
            route_accuracy(ev, positions, map_sigma_m=map_sigma_m, route=name, estimate=estimate)
            for ev, (name, _) in zip(evaluators, routes)
        )
        if specifications is None:
            lat = max(Z95 * a.lateral.max for a in accs)
            points.append(FrontPoint(tuple(ids), float(cost), float(score), lat, accs, None, None))
            continue
        verdicts = [verdict(a, s) for a, s in zip(accs, specifications)]
        lat = max(Z95 * at_rank(a.sigmas("lateral"), s.at) for a, s in zip(accs, specifications))
        points.append(
            FrontPoint(
                tuple(ids),
                float(cost),
                float(score),
                lat,
                accs,
                all(v.meets for v in verdicts),
                max(v.violation for v in verdicts),
            )
        )
    specs = tuple(zip([n for n, _ in routes], specifications)) if specifications is not None else ()
    return FrontAcceptance(
        "slam" if map_sigma_m is None else "map",
        map_sigma_m,
        specs,
        tuple(sorted(points, key=lambda p: (p.cost_usd, -p.score))),
        target.info,
        estimate,
    )
