"""What the commands that take --scheduler/--workers share: the domain check and the evaluator."""

from __future__ import annotations

from typing import Any, cast

import click

from sensorsel.api import DistributedDomainEvaluator, DomainEvaluator, Evaluator, evaluator_for
from sensorsel.model.problem import Domain, Target


def require_domain(cluster: Any, target: Target) -> None:
    """--scheduler/--workers spread a domain's routes: refused (usage error) on one route.

    Raises:
        click.UsageError: a cluster asked for on one route.
    """
    if cluster is not None and target.kind != "domain":
        raise click.UsageError(
            "--scheduler/--workers spread a domain's routes over a cluster: they go with --domain FILE"
        )


def evaluator_on(cluster: Any, target: Target, engine: str | None, jobs: int, aggregate: str) -> Evaluator:
    """The target's evaluator: in this process, or with a started cluster each route of the domain on
    a worker (:func:`domain_evaluator_on`)."""
    ev = cluster_evaluator(cluster, target, engine, aggregate)
    return ev if ev is not None else evaluator_for(target, engine, jobs=jobs, aggregate=aggregate)


def cluster_evaluator(cluster: Any, target: Target, engine: str | None, aggregate: str) -> DomainEvaluator | None:
    """With a started cluster, the domain's evaluator with each route on a worker
    (:func:`domain_evaluator_on`); None without one (the run builds its evaluator in this process).

    Raises:
        click.UsageError: a cluster asked for on one route (:func:`require_domain`).
    """
    if cluster is None:
        return None
    require_domain(cluster, target)
    return domain_evaluator_on(cluster, cast(Domain, target), engine, aggregate)  # require_domain refused one route


def domain_evaluator_on(cluster: Any, domain: Domain, engine: str | None, aggregate: str) -> DomainEvaluator:
    """A domain's evaluator with each route on a worker of a started cluster
    (:class:`sensorsel.information.evaluators.distributed.DistributedDomainEvaluator`; one thread per route there)."""
    return DistributedDomainEvaluator(cluster.client, domain, engine, aggregate=aggregate)
