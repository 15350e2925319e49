"""The greedy run, written once: greedy selection, its certificate, and a domain's per-route breakdown.

Every path that runs greedy as a design (``sensorsel greedy`` on a route or a domain, resumable or
not, in this process or on a cluster's evaluator; :func:`sensorsel.api.run_greedy` and
:func:`sensorsel.api.design_domain`) is :func:`greedy_design`, and on a domain with its breakdown
:func:`domain_design`:

    greedy          the suite (:func:`sensorsel.designs.selection.greedy`), pick by pick
    certificate     an upper bound on the best score within the budget (:mod:`sensorsel.designs.certify`)
    breakdown       each route's share of its best and of its own design (:mod:`.domain_design`)

each stage kept in one :class:`~sensorsel.designs.checkpoint.GreedyStore`: in memory, or a checkpoint
file rewritten after each pick and stage that a resumed run goes on from.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from sensorsel.designs.certify import CertifiedGreedyResult, certificate
from sensorsel.designs.checkpoint import GreedyInputs, GreedyStore
from sensorsel.designs.domain_design import DomainDesign, route_breakdown, worst_route
from sensorsel.designs.options import RunKeywords, RunOptions
from sensorsel.designs.parts import elapsed_s
from sensorsel.designs.selection import GreedyResult, check_budget, check_rule, greedy
from sensorsel.information.evaluators import DomainEvaluator, Evaluator
from sensorsel.io.progress import Progress
from sensorsel.model.constraints import feasible_set
from sensorsel.model.problem import Domain, Target

__all__ = ["GreedyKeywords", "GreedyRun", "domain_design", "greedy_design"]


@dataclass(frozen=True)
class GreedyRun:
    """A greedy design run's inputs besides its target.

    Attributes:
        budget_usd: the budget [$].
        rule: the greedy rule (:data:`sensorsel.designs.selection.RULES`).
        options: engine, jobs, aggregate, laziness, limits and the picks' progress (:class:`RunOptions`).
        certify: also compute the certificate (an upper bound on the best score within the budget)
            from the same evaluator.
        certify_progress: ``(done, total)`` after each certificate sweep.
        checkpoint: a file rewritten after each pick and stage (None: kept in memory only).
        resume: go on from what ``checkpoint`` holds when this very run wrote it
            (:mod:`sensorsel.designs.checkpoint`).
    """

    budget_usd: float
    rule: str = "uniform"
    options: RunOptions = field(default_factory=RunOptions)
    certify: bool = False
    certify_progress: Progress | None = None
    checkpoint: str | Path | None = None
    resume: bool = False

    @classmethod
    def of(cls, budget_usd: float, rule: str, **keywords: Any) -> GreedyRun:
        """The run of :class:`GreedyKeywords` (the run options and this run's own keywords)."""
        options, own = RunOptions.split(keywords)
        return cls(budget_usd, rule, options, **own)


class GreedyKeywords(RunKeywords, total=False):
    """:class:`GreedyRun` as the keywords of a public run function: the run options and its own."""

    certify: bool
    certify_progress: Progress | None
    checkpoint: str | Path | None
    resume: bool


def greedy_design(target: Target, run: GreedyRun, evaluator: Evaluator | None = None) -> CertifiedGreedyResult:
    """Greedy selection by ``run`` on ``target`` (a route, or a domain's combined score by its
    aggregate); with ``run.certify``, its certificate from the same evaluator.

    ``evaluator``: the target's evaluator already built (e.g. a domain's on a Dask cluster);
    the engine, jobs and aggregate of ``run.options`` are then its own. The limits besides the budget
    are kept by the suite.

    Raises:
        InputError: a bad budget, rule, engine or aggregate, constraints the library cannot meet
            (checked before any evaluator is built), or a route no sensor can measure.
    """
    store = _store(target, run)
    ev = evaluator if evaluator is not None else run.options.evaluator(target)
    return _certified(ev, store, run, target)[1]


def domain_design(
    domain: Domain, run: GreedyRun, evaluator: DomainEvaluator | None = None, progress: Progress | None = None
) -> DomainDesign:
    """:func:`greedy_design` on ``domain`` with its breakdown: each route's share of its best and of
    its own design (greedy by the same rule and budget on that route alone, keeping the same limits),
    reporting ``(done, total)`` to ``progress`` after each route; a :class:`DomainDesign`. The
    breakdown's finished routes are kept in the run's checkpoint too."""
    t0 = time.perf_counter()
    store = _store(domain, run)
    ev = evaluator if evaluator is not None else run.options.evaluator(domain)
    res, out = _certified(ev, store, run, domain)
    shares = route_breakdown(
        ev,
        res,
        lazy=run.options.lazy,
        progress=progress,
        done=store.ck.routes,
        record=store.record_routes if store.path is not None else None,
    )
    return DomainDesign(
        greedy=out,
        aggregate=ev.aggregate,
        routes=shares,
        worst_route=worst_route(shares),
        domain=ev.domain.info,
        seconds=elapsed_s(t0),
    )


def _store(target: Target, run: GreedyRun) -> GreedyStore:
    """The run's store, its budget, rule and limits checked first (before any evaluator is built)."""
    budget, rule, o = check_budget(run.budget_usd), check_rule(run.rule), run.options
    # the limits as the run records them (with the digest of the resources and slots they read)
    limits = feasible_set(target.library, budget, o.constraints).record if o.constraints is not None else None
    inputs = GreedyInputs(budget, rule, o.engine or "", o.aggregate, o.lazy, limits)
    return GreedyStore.open(run.checkpoint, run.resume, target, inputs)


def _certified(
    ev: Evaluator, store: GreedyStore, run: GreedyRun, target: Target
) -> tuple[GreedyResult, CertifiedGreedyResult]:
    """The greedy result (journaled in ``store``) and it with its certificate when asked for (the
    stored one when a resumed run finished it)."""
    o, ck = run.options, store.ck
    res = greedy(
        ev,
        ck.budget_usd,
        ck.rule,
        lazy=o.lazy,
        progress=o.progress,
        info=target.info,
        constraints=o.constraints,
        journal=store,
    )
    cert = store.ck.certificate
    if run.certify and cert is None:
        cert = certificate(ev, res, progress=run.certify_progress)
        store.update(certificate=cert)
    return res, CertifiedGreedyResult.of(res, cert if run.certify else None)
