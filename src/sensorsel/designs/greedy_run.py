"""The greedy run, written once: greedy selection, its certificate, and a domain's per-route breakdown.

Every path that runs greedy as a design (``sensorsel greedy`` on a route or a domain, resumable or
not, in this process or on a cluster's evaluator; :func:`sensorsel.api.run_greedy` and
:func:`sensorsel.api.design_domain`) is :func:`greedy_design`:

    greedy          the suite (:func:`sensorsel.designs.selection.greedy`), pick by pick
    certificate     an upper bound on the best score within the budget (:mod:`sensorsel.designs.certify`)
    breakdown       each route's share of its best and of its own design (:mod:`.domain_design`)

each stage kept in one :class:`~sensorsel.designs.checkpoint.GreedyStore`: in memory, or a checkpoint
file rewritten after each pick and stage that a resumed run goes on from.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Literal, overload

from sensorsel.designs.certify import CertifiedGreedyResult, certificate
from sensorsel.designs.checkpoint import GreedyInputs, GreedyStore
from sensorsel.designs.domain_design import DomainDesign, route_breakdown, worst_route
from sensorsel.designs.selection import check_budget, check_rule, greedy
from sensorsel.information.evaluators import DomainEvaluator, Evaluator, evaluator_for
from sensorsel.io.progress import Progress
from sensorsel.model.constraints import Constraints, feasible_set
from sensorsel.model.problem import Target

__all__ = ["greedy_design"]


@overload
def greedy_design(
    target: Target,
    budget_usd: float,
    rule: str = ...,
    *,
    engine: str | None = ...,
    jobs: int = ...,
    aggregate: str = ...,
    lazy: bool = ...,
    certify: bool = ...,
    breakdown: Literal[False] = ...,
    progress: Progress | None = ...,
    certify_progress: Progress | None = ...,
    breakdown_progress: Progress | None = ...,
    evaluator: Evaluator | None = ...,
    constraints: Constraints | None = ...,
    checkpoint: str | Path | None = ...,
    resume: bool = ...,
) -> CertifiedGreedyResult: ...


@overload
def greedy_design(
    target: Target,
    budget_usd: float,
    rule: str = ...,
    *,
    engine: str | None = ...,
    jobs: int = ...,
    aggregate: str = ...,
    lazy: bool = ...,
    certify: bool = ...,
    breakdown: Literal[True],
    progress: Progress | None = ...,
    certify_progress: Progress | None = ...,
    breakdown_progress: Progress | None = ...,
    evaluator: Evaluator | None = ...,
    constraints: Constraints | None = ...,
    checkpoint: str | Path | None = ...,
    resume: bool = ...,
) -> DomainDesign: ...


def greedy_design(
    target: Target,
    budget_usd: float,
    rule: str = "uniform",
    *,
    engine: str | None = None,
    jobs: int = 1,
    aggregate: str = "normalised",
    lazy: bool = True,
    certify: bool = False,
    breakdown: bool = False,
    progress: Progress | None = None,
    certify_progress: Progress | None = None,
    breakdown_progress: Progress | None = None,
    evaluator: Evaluator | None = None,
    constraints: Constraints | None = None,
    checkpoint: str | Path | None = None,
    resume: bool = False,
) -> CertifiedGreedyResult | DomainDesign:
    """Greedy selection within ``budget_usd`` [$] by ``rule`` on ``target`` (a route, or a domain's
    combined score by ``aggregate``); with ``certify``, its certificate from the same evaluator; with
    ``breakdown`` (a domain), its :class:`~sensorsel.designs.domain_design.DomainDesign` (each route's
    share of its best and of its own design), else the certified greedy result alone.

    ``evaluator``: the target's evaluator already built (e.g. a domain's on a Dask cluster);
    ``engine``, ``jobs`` and ``aggregate`` are then its own. ``constraints``: limits besides the
    budget (:mod:`sensorsel.model.constraints`), kept by the suite and by each route's own design.
    ``checkpoint``: a file rewritten after each pick and stage; with ``resume``, the run goes on from
    what it holds when this very run wrote it (:mod:`sensorsel.designs.checkpoint`). ``progress``,
    ``certify_progress``, ``breakdown_progress``: ``(done, total)`` after each pick, certificate
    sweep and route.

    Raises:
        InputError: a bad budget, rule, engine or aggregate, constraints the library cannot meet
            (checked before any evaluator is built), or a route no sensor can measure.
    """
    t0 = time.perf_counter()
    budget, rule = check_budget(budget_usd), check_rule(rule)
    # the limits as the run records them (with the digest of the resources and slots they read)
    limits = feasible_set(target.library, budget, constraints).record if constraints is not None else None
    store = GreedyStore.open(
        checkpoint, resume, target, GreedyInputs(budget, rule, engine or "", aggregate, lazy, limits)
    )
    ev = evaluator if evaluator is not None else evaluator_for(target, engine, jobs=jobs, aggregate=aggregate)
    res = greedy(
        ev, budget, rule, lazy=lazy, progress=progress, info=target.info, constraints=constraints, journal=store
    )
    cert = store.ck.certificate
    if certify and cert is None:
        cert = certificate(ev, res, progress=certify_progress)
        store.update(certificate=cert)
    out = CertifiedGreedyResult.of(res, cert if certify else None)
    if not breakdown:
        return out
    assert isinstance(ev, DomainEvaluator), "a breakdown is a domain's (give a Domain)"
    shares = route_breakdown(
        ev,
        res,
        lazy=lazy,
        progress=breakdown_progress,
        done=store.ck.routes,
        record=store.record_routes if store.path is not None else None,
    )
    return DomainDesign(
        greedy=out,
        aggregate=ev.aggregate,
        routes=shares,
        worst_route=worst_route(shares),
        domain=ev.domain.info,
        seconds=round(time.perf_counter() - t0, 6),
    )
