"""What the commands that take --scheduler/--workers share: the domain check and the evaluator."""

from __future__ import annotations

from typing import Any

import click

from sensorsel.api import DistributedDomainEvaluator, DomainEvaluator, Evaluator, evaluator_for
from sensorsel.model.problem import Domain, Target


def require_domain(cluster: Any, target: Target) -> None:
    """--scheduler/--workers spread a domain's routes: refused (usage error) on one route.

    Raises:
        click.UsageError: a cluster asked for on one route.
    """
    if cluster is not None and not isinstance(target, Domain):
        raise click.UsageError(
            "--scheduler/--workers spread a domain's routes over a cluster: they go with --domain FILE"
        )


def evaluator_on(cluster: Any, target: Target, engine: str | None, jobs: int, aggregate: str) -> Evaluator:
    """The target's evaluator: in this process, or with a started cluster each route of the domain on
    a worker (:func:`domain_evaluator_on`)."""
    if cluster is None:
        return evaluator_for(target, engine, jobs=jobs, aggregate=aggregate)
    assert isinstance(target, Domain)
    return domain_evaluator_on(cluster, target, engine, aggregate)


def domain_evaluator_on(cluster: Any, domain: Domain, engine: str | None, aggregate: str) -> DomainEvaluator:
    """A domain's evaluator with each route on a worker of a started cluster
    (:class:`sensorsel.information.evaluators.distributed.DistributedDomainEvaluator`; one thread per route there)."""
    return DistributedDomainEvaluator(cluster.client, domain, engine, aggregate=aggregate)
