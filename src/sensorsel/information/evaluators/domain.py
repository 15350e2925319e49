"""The score of an operating domain: one suite for every route a fleet drives.

A domain (:class:`~sensorsel.model.problem.Domain`) is routes r = 1..R with weights w_r (the share of the
fleet's driving each stands for, in kilometres or hours), all with one sensor library. Its score is

    normalised (default):  F(S) = sum_r  w̄_r f_r(S) / f_r(L)     a share of the best, in [0, 1]
    raw:                   F(S) = sum_r  w̄_r f_r(S)              [nats]

with w̄_r = w_r / sum_q w_q the normalised weights and L the whole library: f_r(L) is the most any
suite can get on route r, so a long route does not drown a short one. Each term is a non-negative
multiple of a monotone submodular function, so F is monotone submodular: greedy and its lazy
evaluation, the certificate's knapsack bound and the exact search keep their guarantees unchanged.
With one route, F is f scaled by a positive constant (normalised) or f itself (raw), so every
selector picks exactly what it picks on the route alone.

Each route keeps its own engine (built once); a candidate's domain score is the weighted sum of its
routes' scores, added in route order (one fixed order: the same bytes however many threads).
"""

from __future__ import annotations

from typing import Iterable, Sequence

import numpy as np

from sensorsel.errors import InputError
from sensorsel.information.evaluators.base import Evaluator, ProblemEvaluator, as_suite
from sensorsel.information.evaluators.registry import check_engine, make_evaluator
from sensorsel.model.problem import Domain

#: how a domain combines its routes' scores (see the module's documentation)
AGGREGATES = ("normalised", "raw")


def check_aggregate(aggregate: str) -> str:
    """``aggregate`` if it is one of :data:`AGGREGATES` (else an InputError naming the choices)."""
    if aggregate not in AGGREGATES:
        raise InputError(f"unknown aggregate {aggregate!r}; available: {', '.join(AGGREGATES)}")
    return aggregate


class DomainEvaluator(Evaluator):
    """F(S) of a domain from one engine's evaluator per route.

    Args:
        domain: the routes and their weights.
        engine: the per-route engine (default: the fastest registered).
        jobs: threads each route's engine may use.
        aggregate: "normalised" (default) or "raw" (see the module's documentation).

    Attributes:
        routes: the per-route evaluators, in the domain's order.
        weights: w̄_r, shape (R,), summing to 1.
        best: f_r(L), the whole library's score on each route [nats], shape (R,).
        scale: the factor of each route's score in F, shape (R,).

    Raises:
        InputError: an unknown engine or aggregate, or a route on which no sensor of the library
            measures anything (f_r(L) = 0: its share of the best is undefined).
    """

    name = "domain"

    def __init__(self, domain: Domain, engine: str | None = None, *, jobs: int = 1, aggregate: str = "normalised") -> None:
        super().__init__(domain.library, jobs=jobs)
        self.domain = domain
        self.engine = check_engine(engine)
        self.aggregate = check_aggregate(aggregate)
        self.routes: tuple[ProblemEvaluator, ...] = tuple(make_evaluator(r.problem, self.engine, jobs=jobs) for r in domain.routes)
        everything = tuple(range(len(self.library)))
        self.set_normalisers([ev.score(everything) for ev in self.routes])

    def set_normalisers(self, best: Sequence[float]) -> None:
        """Weights, normalisers f_r(L) and each route's factor in F, from f_r(L) of every route
        (however they were computed: here, or on a cluster's workers).

        Raises:
            InputError: a route with f_r(L) = 0 (no sensor measures anything there).
        """
        domain = self.domain
        w = np.array([r.weight for r in domain.routes], dtype=float)
        self.weights = w / w.sum()
        self.best = np.array(best, dtype=float)
        for r, f_all in zip(domain.routes, self.best):
            if not f_all > 0:
                raise InputError(f"domain {domain.source}: route {r.name!r}: no sensor of the library measures any "
                                 f"landmark ({r.problem.scenario.landmark_source}); its share of the best is undefined")
        self.scale = self.weights / self.best if self.aggregate == "normalised" else self.weights.copy()

    def __repr__(self) -> str:
        return f"DomainEvaluator({len(self.routes)} routes, engine {self.engine!r}, {self.aggregate})"

    def route_scores(self, suite: Iterable[int]) -> np.ndarray:
        """f_r(S) of each route [nats], shape (R,)."""
        s = as_suite(suite)
        self._check_positions(s)
        return np.array([ev.score(s) for ev in self.routes], dtype=float)

    def combine(self, route_scores: np.ndarray) -> np.ndarray:
        """F from per-route scores of shape (R,) or (R, n), summed in route order."""
        out = np.zeros(np.shape(route_scores)[1:], dtype=float)
        for k in range(len(self.routes)):  # a fixed order of additions: the same bytes every run
            out = out + self.scale[k] * route_scores[k]
        return out

    def score(self, suite: Iterable[int]) -> float:
        """F(S): the domain's score of the suite (a share of the best when normalised, else nats)."""
        self.n_evaluations += 1
        return float(self.combine(self.route_scores(suite)))

    def gain_bounds(self, suite: Iterable[int], candidates: Sequence[int]) -> np.ndarray | None:
        """Upper bounds on F(S + {c}) − F(S), shape (len(candidates),): the routes' bounds combined
        (F is a combination of the routes' scores with non-negative factors), or None unless every
        route's engine gives them (each judges their cost on its own route)."""
        return self.combined_gain_bounds(ev.gain_bounds(suite, candidates) for ev in self.routes)

    def score_bounds(self, suite: Iterable[int], candidates: Sequence[int]) -> tuple[float, np.ndarray] | None:
        """Upper bounds on F(S) and each F(S + {c}): the routes' cheap bounds combined, or None
        unless every route's engine gives them."""
        return self.combined_score_bounds(ev.score_bounds(suite, candidates) for ev in self.routes)

    def combined_gain_bounds(self, per_route: Iterable[np.ndarray | None]) -> np.ndarray | None:
        """The routes' bounds on the gains (in route order) combined, or None at the first route
        without them (the routes after it are not asked, when ``per_route`` is lazy)."""
        got = []
        for bounds in per_route:
            if bounds is None:
                return None
            got.append(np.asarray(bounds, dtype=float))
        return self.combine(np.stack(got)) if got else None

    def combined_score_bounds(self, per_route: Iterable[tuple[float, np.ndarray] | None]) -> tuple[float, np.ndarray] | None:
        """The routes' (bound on f(S), bounds on each f(S + {c})) combined, as :meth:`combined_gain_bounds`."""
        own, got = [], []
        for bounds in per_route:
            if bounds is None:
                return None
            own.append(float(bounds[0]))
            got.append(np.asarray(bounds[1], dtype=float))
        if not got:
            return None
        return float(self.combine(np.array(own))), self.combine(np.stack(got))

    def scores_with(self, suite: Iterable[int], candidates: Sequence[int]) -> np.ndarray:
        """F(S + {c}) for each candidate c, shape (len(candidates),): each route's engine scores the
        candidates against the shared base suite, then the routes are combined."""
        base = as_suite(suite)
        cand = [int(c) for c in candidates]
        self._check_positions(base + tuple(cand))
        self.n_evaluations += len(cand)
        if not cand:
            return np.zeros(0)
        per_route = np.stack([ev.scores_with(base, cand) for ev in self.routes])
        return self.combine(per_route)
