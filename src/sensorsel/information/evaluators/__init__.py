"""Evaluators: log det engines behind one interface (:class:`Evaluator`), one registry (:data:`ENGINES`).

    reference   GTSAM graph built, linearized and eliminated per suite (the paper's method, the oracle)
    fast        the same numbers from pieces linearized once (see :mod:`sensorsel.information.evaluators.fast`)

Every engine gives the reference's numbers to round-off; they differ in speed only. An engine scores
one problem (:class:`ProblemEvaluator`); :class:`DomainEvaluator` combines one engine's evaluators of
many routes into the score of an operating domain. Selectors, certificates and robust designs see
only :class:`Evaluator`: ``library``, ``score(suite)``, ``scores_with(suite, candidates)``.
"""

from __future__ import annotations

from sensorsel.information.evaluators.base import Evaluator, ProblemEvaluator, Suite, as_suite
from sensorsel.information.evaluators.domain import AGGREGATES, DomainEvaluator, check_aggregate
from sensorsel.information.evaluators.fast import FastEvaluator
from sensorsel.information.evaluators.reference import ReferenceEvaluator
from sensorsel.information.evaluators.registry import DEFAULT_ENGINE, ENGINES, check_engine, make_evaluator, register
from sensorsel.model.problem import Domain, Target

__all__ = [
    "Evaluator",
    "ProblemEvaluator",
    "Suite",
    "as_suite",
    "ENGINES",
    "DEFAULT_ENGINE",
    "register",
    "make_evaluator",
    "check_engine",
    "ReferenceEvaluator",
    "FastEvaluator",
    "DomainEvaluator",
    "AGGREGATES",
    "check_aggregate",
    "evaluator_for",
    "evaluator_name",
]


def evaluator_name(target: Target, engine: str | None = None) -> str:
    """The name of :func:`evaluator_for`'s evaluator of ``target`` with ``engine``, without building it.

    Raises:
        InputError: an unknown engine."""
    return DomainEvaluator.name if isinstance(target, Domain) else check_engine(engine)


def evaluator_for(
    target: Target, engine: str | None = None, *, jobs: int = 1, aggregate: str = "normalised"
) -> Evaluator:
    """The evaluator of a problem (an engine of :data:`ENGINES`) or of a domain (a
    :class:`DomainEvaluator` over that engine's per-route evaluators, combined by ``aggregate``; with
    ``jobs`` of 2 or more on a domain large enough, the routes owned by that many worker processes:
    :class:`~sensorsel.information.evaluators.processes.ProcessDomainEvaluator`, the same numbers;
    :func:`~sensorsel.information.evaluators.processes.on_processes` decides)."""
    if isinstance(target, Domain):
        from sensorsel.information.evaluators.processes import ProcessDomainEvaluator, on_processes

        if on_processes(target, jobs):
            return ProcessDomainEvaluator(target, engine, processes=jobs, aggregate=aggregate)
        return DomainEvaluator(target, engine, jobs=jobs, aggregate=aggregate)
    check_aggregate(aggregate)  # one route: any aggregate picks the same suites, but a typo is still one
    return make_evaluator(target, engine, jobs=jobs)
