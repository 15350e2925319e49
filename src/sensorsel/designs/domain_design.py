"""One suite for a whole operating domain, and what it costs each route.

A domain's greedy run (:func:`sensorsel.designs.greedy_run.greedy_design` with ``breakdown``) picks one
suite on the domain's score (:mod:`sensorsel.information.evaluators.domain`); :func:`route_breakdown` then,
route by route, compares the domain suite S with two references on that route alone:

    share of best   f_r(S) / f_r(L)      what S gets of everything the library could give there
    share of own    f_r(S) / f_r(G_r)    G_r: the suite the same rule picks for route r alone, at the
                                         same budget: the price, on r, of buying one suite for all

A share of own below 1 is what route r gives up for the others; above 1 is possible (greedy is not
optimal on r either). The route with the lowest share of own is named the worst route.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from sensorsel.designs.certify import CertifiedGreedyResult
from sensorsel.designs.selection import GreedyResult, greedy
from sensorsel.information.evaluators import DomainEvaluator, Evaluator
from sensorsel.io.progress import Progress
from sensorsel.io.results import result_kind
from sensorsel.model.constraints import recorded
from sensorsel.model.problem import DomainInfo


@dataclass(frozen=True)
class RouteShare:
    """How the domain suite does on one route.

    Attributes:
        name: the route.
        weight: its normalised weight w̄_r in the domain score (the weights sum to 1).
        score: f_r(S) of the domain suite [nats].
        best_score: f_r(L), the whole library [nats].
        share_of_best: score / best_score.
        own_suite: ids of the suite the same rule picks for this route alone, same budget.
        own_cost_usd: its cost [$].
        own_score: f_r(G_r) [nats].
        share_of_own: score / own_score (1 when both are 0).
    """

    name: str
    weight: float
    score: float
    best_score: float
    share_of_best: float
    own_suite: tuple[str, ...]
    own_cost_usd: float
    own_score: float
    share_of_own: float


@result_kind("domain-design")
@dataclass(frozen=True)
class DomainDesign:
    """A domain's suite and its per-route breakdown.

    Attributes:
        greedy: the greedy run on the domain score (its ``problem`` is the domain's
            :class:`~sensorsel.model.problem.DomainInfo`; its scores are domain scores), with its
            certificate when one was asked for.
        aggregate: "normalised" or "raw" (see :mod:`sensorsel.information.evaluators.domain`).
        routes: the breakdown, in the domain's route order.
        worst_route: the route with the lowest share of its own design.
        domain: what it was computed on.
        seconds: wall time of the whole design, breakdown included [s].
    """

    KIND: ClassVar[str] = "domain-design"

    greedy: CertifiedGreedyResult
    aggregate: str
    routes: tuple[RouteShare, ...]
    worst_route: str
    domain: DomainInfo
    seconds: float = 0.0


def own_design(route: Evaluator, budget_usd: float, rule: str, lazy: bool, constraints: Any) -> GreedyResult:
    """A route's own design: greedy on the route's evaluator alone with the domain design's rule,
    budget and recorded limits (run where the route's evaluator lives: :meth:`DomainEvaluator.apply_routes`)."""
    return greedy(route, budget_usd, rule, lazy=lazy, constraints=recorded(constraints))


def _share(evaluator: DomainEvaluator, k: int, own: GreedyResult, score: float) -> RouteShare:
    """Route ``k``'s :class:`RouteShare` from its own design and the domain suite's score there [nats]."""
    route = evaluator.domain.routes[k]
    f_s, f_own = float(score), float(own.score)
    return RouteShare(
        name=route.name,
        weight=float(evaluator.weights[k]),
        score=f_s,
        best_score=float(evaluator.best[k]),
        share_of_best=f_s / float(evaluator.best[k]),
        own_suite=own.suite,
        own_cost_usd=own.cost_usd,
        own_score=f_own,
        share_of_own=f_s / f_own if f_own > 0 else 1.0,
    )


def route_breakdown(
    evaluator: DomainEvaluator,
    result: GreedyResult,
    *,
    lazy: bool = True,
    progress: Progress | None = None,
    done: Sequence[RouteShare] = (),
    record: Callable[[tuple[RouteShare, ...]], None] | None = None,
) -> tuple[RouteShare, ...]:
    """Each route's share of its best and of its own design for the domain suite of ``result``
    (own designs: greedy with ``result``'s rule and budget on each route's own evaluator), in route
    order; ``progress(k, n)`` after route k.

    ``done``: the routes' shares already computed (a prefix, read back from a checkpoint), not
    recomputed. ``record``: called with the shares so far after each route; then the routes run in
    waves of the evaluator's :attr:`~DomainEvaluator.width` (an interruption keeps every finished
    wave), else all at once (the routes' own designs are independent: each runs where its route's
    evaluator lives, :meth:`~DomainEvaluator.apply_routes`)."""
    shares, n = list(done), len(evaluator.routes)
    if len(shares) >= n:
        return tuple(shares[:n])
    scores = evaluator.route_scores(evaluator.library.resolve_suite(result.suite))
    wave = evaluator.width if record is not None else n
    how = (result.budget_usd, result.rule, lazy, result.constraints)
    for start in range(len(shares), n, wave):
        todo = list(range(start, min(n, start + wave)))
        got = evaluator.apply_routes(own_design, {k: how for k in todo})
        for k in todo:
            shares.append(_share(evaluator, k, got[k], float(scores[k])))
            if record is not None:
                record(tuple(shares))
            if progress:
                progress(k + 1, n)
    return tuple(shares)


def worst_route(shares: Sequence[RouteShare]) -> str:
    """The route with the lowest share of its own design (the first of equals)."""
    return shares[int(np.argmin([s.share_of_own for s in shares]))].name


@dataclass(frozen=True)
class ConditionShare:
    """How the domain suite does in one operating condition, over the routes driven in it.

    Attributes:
        name: the condition ("clear", "night", ...).
        weight: its share of the domain's weight (the sum of its members' w̄_r).
        share_of_best: its members' shares of their best f_r(S)/f_r(L), averaged with their weights.
        share_of_own: its members' shares of their own designs, averaged likewise.
        worst_member: the member of this condition with the lowest share of its own design.
    """

    name: str
    weight: float
    share_of_best: float
    share_of_own: float
    worst_member: str


def by_condition(design: DomainDesign) -> tuple[ConditionShare, ...]:
    """The breakdown of a domain with conditions, condition by condition (in first-seen order);
    empty when the domain has none."""
    members = {r.name: r for r in design.domain.routes}
    groups: dict[str, list[RouteShare]] = {}
    for share in design.routes:
        info = members.get(share.name)
        if info is not None and info.condition:
            groups.setdefault(info.condition, []).append(share)
    out = []
    for name, shares in groups.items():
        w = np.array([s.weight for s in shares])
        total = float(w.sum())

        def avg(v: Sequence[float], w: np.ndarray = w, total: float = total) -> float:
            return float(np.dot(w, v) / total) if total > 0 else float(np.mean(v))

        out.append(
            ConditionShare(
                name,
                total,
                avg([s.share_of_best for s in shares]),
                avg([s.share_of_own for s in shares]),
                worst_route(shares),
            )
        )
    return tuple(out)
