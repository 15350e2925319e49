"""What a stored result depends on: the one declaration every store's fingerprint is built from.

A result of a design run depends on its target and on the run's own inputs. The target is each
route by content (:class:`~sensorsel.model.problem.Fingerprint`: the library's sensors and costs,
the route and keyframe rate, the landmarks, the graph settings and the operating condition with
its physics) with, on a domain, the route's name, weight and unit. The run's inputs are whatever
else its answer reads (budget, failures, rule, engine, period, limits, specification, localization
model, ...), given by the store as keyword arguments.

Every store (the greedy checkpoint, the optimal search's checkpoint, the tradespace's rules, the
periods of a resilient run, the robust run's tasks, the study's cells and the ``require`` journal)
builds its fingerprint with :func:`result_fingerprint`, so a part of the target cannot be left out of
one store and not the others: a period, for one, is fingerprinted on its own scenario with the
whole route's library, settings and condition (:meth:`~sensorsel.model.problem.Problem.fingerprint_on`).
``tests/test_resume_inputs.py`` changes each input of each run alone and checks that no stored result
of the first run is read back.
"""

from __future__ import annotations

from typing import Any

from sensorsel.io.results import to_jsonable
from sensorsel.model.problem import DomainRoute, Fingerprint, RouteInfo, Target, TargetInfo
from sensorsel.pipeline.store import digest

#: the parts of a route a result depends on, besides its problem's content (the Fingerprint's parts)
ROUTE_PARTS = ("name", "weight", "unit")


def route_entry(name: str, weight: float, unit: str, fingerprint: Fingerprint | None) -> list[Any]:
    """One route as a result depends on it: ``[name, weight, unit, fingerprint as JSON]``."""
    return [name, weight, unit, to_jsonable(fingerprint)]


def route_inputs(target: Target | TargetInfo | Fingerprint | list[list[Any]] | None) -> list[list[Any]]:
    """Each route of ``target`` as ``[name, weight, unit, fingerprint]`` (one route: ``["", 1.0, "", fp]``).

    ``target``: a problem or domain, what a result records of one (:class:`ProblemInfo` or
    :class:`DomainInfo`), or a problem's :class:`Fingerprint` itself (a period's). A recorded problem
    without a fingerprint (a file written before fingerprints existed) gives None in its place:
    such a result is never taken for one of a known problem. A list: routes already given as
    :func:`route_entry` (read from files without building the problems, as a study does).
    """
    if isinstance(target, list):
        return target
    if target is None or isinstance(target, Fingerprint):
        return [route_entry("", 1.0, "", target)]
    # each route by its key (one route: named by nothing, so the same data under another name is the same)
    routes: tuple[DomainRoute | RouteInfo, ...] = target.routes
    return [route_entry(*key, r.problem.fingerprint) for key, r in zip(target.route_keys, routes)]


def result_fingerprint(
    store: str, format: int, target: Target | TargetInfo | Fingerprint | list[list[Any]] | None, **inputs: Any
) -> str:
    """sha256 of everything a stored result depends on: its ``store`` (which run's files) and ``format``, each
    route of ``target`` by content (:func:`route_inputs`) and the run's own ``inputs`` (JSON-able
    after :func:`~sensorsel.io.results.to_jsonable`; not file paths, not where or how fast it runs)."""
    return digest(
        {
            "format": format,
            "store": store,
            "routes": route_inputs(target),
            **{k: to_jsonable(v) for k, v in inputs.items()},
        }
    )
