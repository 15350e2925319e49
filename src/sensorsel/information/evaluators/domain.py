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

Lazy greedy, member by member (:meth:`DomainEvaluator.scores_or_bounds`): a candidate's
gain is Σ_r c_r Δ_r(c | S) (c_r the route's factor in F), and each Δ_r is submodular on its own, so
the last exact Δ_r of an earlier step, or a route engine's bound, bounds it. A candidate that the
lazy greedy re-scores gets its routes' exact scores one route at a time, the route with the largest
bounded term per unit of work first, and is left with a (tighter) bound as soon as that bound shows
it cannot reach the best: only candidates that can still win get every route scored (a domain of
routes x conditions: the heavy clear and night members first, rain and fog only where they could
still matter). Same picks and scores to the bit; fewer route evaluations.

Members that see the suite as their route's clear member does (night before a camera is bought:
night changes the cameras alone) share the clear member's work: its f(S + {c}) is theirs for every
candidate they measure alike (copied, not evaluated: :meth:`DomainEvaluator._mirrors`), and its pose
covariance and pair quadratics make their gain bounds (:meth:`DomainEvaluator._member_gain_bounds`).
"""

from __future__ import annotations

import weakref
from collections.abc import Iterable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from threadpoolctl import ThreadpoolController

from sensorsel.errors import InputError
from sensorsel.information.evaluators import ahead as ahead_
from sensorsel.information.evaluators.base import Evaluator, ProblemEvaluator, Suite, as_suite
from sensorsel.information.evaluators.registry import check_engine, make_evaluator
from sensorsel.model.problem import Domain

#: how a domain combines its routes' scores (see the module's documentation)
AGGREGATES = ("normalised", "raw")


#: relative allowance for round-off on a route engine's bound on a gain (computed in exact arithmetic)
BOUND_SLACK = 1e-9

#: routes scored at once for a candidate re-scored alone (one each when two are): two routes keep
#: both cores of a 2-core machine busy, at the risk of one route scored that the bound did not
#: need. Fixed, not the thread count, so that the routes scored, and so every count of a result,
#: are the same for any ``jobs`` (as :data:`sensorsel.designs.selection.greedy.LAZY_BATCH`).
LONE_ROUTES = 2


@dataclass(eq=False)
class MemberBounds:
    """What :meth:`DomainEvaluator.scores_or_bounds` knows at one base suite S (R routes, n sensors).

    Attributes:
        suite: S.
        own: f_r(S) of each route [nats], shape (R,).
        stale: upper bounds on each route's gain Δ_r(c | S) [nats], shape (R, n) (inf: none yet).
        known: exact f_r(S + {c}) of the routes scored so far at S, by candidate, shape (R,) (nan: not yet).

    A member under a condition that changes no sensor of S has the information matrix of its route's
    clear member at S (same scenario, settings and, for those sensors, the very same measurements),
    and the condition only removes measurements of a candidate or shrinks their weights, so its gain
    is at most the clear member's: Δ_m(c | S) ≤ Δ_clear(c | S) (night, before a camera is bought).
    """

    suite: Suite
    own: np.ndarray
    stale: np.ndarray
    known: dict[int, np.ndarray] = field(default_factory=dict)
    #: (R,) bool: members whose condition leaves every sensor of S alone (their clear member bounds them)
    as_clear: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    #: f_r(S + {c}) [nats] scored ahead on an idle thread or worker, by (route, candidate), until asked
    #: (:mod:`.ahead`: read only where the one-thread run computes it)
    ahead: dict[tuple[int, int], float] = field(default_factory=dict)


def clear_partners(domain: Domain, n_sensors: int) -> tuple[np.ndarray, np.ndarray]:
    """For each member, its route's clear member (−1: none, or itself) and which sensors it measures
    exactly as the clear member does (the very same measurement arrays: a condition that leaves a
    sensor alone keeps them, :func:`sensorsel.model.sensing.apply_condition`), shapes (R,) and (R, n)."""
    R = len(domain.routes)
    clear: dict[str, int] = {}
    for k, r in enumerate(domain.routes):
        if r.problem.condition is None:
            clear.setdefault(r.route_name, k)
    partner, alike = np.full(R, -1), np.zeros((R, n_sensors), dtype=bool)
    for k, r in enumerate(domain.routes):
        p = clear.get(r.route_name, -1)
        if p < 0 or p == k:
            continue
        q = domain.routes[p].problem
        if r.problem.scenario is not q.scenario or r.problem.settings != q.settings:
            continue
        partner[k] = p
        alike[k] = [a is b for a, b in zip(r.problem.observations, q.observations)]
    return partner, alike


def planned_alike(domain: Domain, partner: np.ndarray) -> np.ndarray:
    """(R,) bool: members whose library measures the very landmarks their clear member's does
    (``partner`` from :func:`clear_partners`; False without one). An engine may plan its work by
    what the whole library measures (the fast engine groups the measured landmarks into tiles), so
    two members give the same bytes for a suite they measure alike only when that agrees too."""

    def seen(k: int) -> np.ndarray:
        obs = domain.routes[k].problem.observations
        return np.unique(np.concatenate([o.landmark for o in obs])) if obs else np.zeros(0, dtype=int)

    return np.array(
        [p >= 0 and np.array_equal(seen(k), seen(int(p))) for k, p in enumerate(partner.tolist())], dtype=bool
    )


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
    bounds_candidates = True
    scores_ahead = True  # lazy greedy passes its queue to scores_or_bounds (ahead=)
    #: route calls scored ahead, and those the lazy greedy then asked (:mod:`.ahead`; in no result)
    n_ahead = n_ahead_used = 0
    #: the fewest places (threads, workers) a round scores ahead on (:data:`.ahead.MIN_PLACES`)
    ahead_from: int = ahead_.MIN_PLACES
    _pool: ThreadPoolExecutor | None = None  # the members' threads, started on first use
    _blas: ThreadpoolController | None = None

    def __init__(
        self, domain: Domain, engine: str | None = None, *, jobs: int = 1, aggregate: str = "normalised"
    ) -> None:
        super().__init__(domain.library, jobs=jobs)
        self.domain = domain
        self.engine = check_engine(engine)
        self.aggregate = check_aggregate(aggregate)
        # the members' engines and normalisers f_r(L) on the threads (each from its own problem alone:
        # the same bytes on any number of threads), the largest routes first
        work = [float(r.problem.scenario.n_poses) for r in domain.routes]
        members = list(range(len(domain.routes)))
        self.routes: tuple[ProblemEvaluator, ...] = tuple(
            self._on_threads(
                lambda k: make_evaluator(domain.routes[k].problem, self.engine, jobs=jobs), members, work
            ).values()
        )
        everything = tuple(range(len(self.library)))
        best = self._on_threads(lambda k: self.routes[k].score(everything), members, work)
        self.set_normalisers([best[k] for k in members])

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
                raise InputError(
                    f"domain {domain.source}: route {r.name!r}: no sensor of the library measures any "
                    f"landmark ({r.problem.scenario.landmark_source}); its share of the best is undefined"
                )
        self.scale = self.weights / self.best if self.aggregate == "normalised" else self.weights.copy()
        # what lazy greedy's member-by-member scoring knows (here, as every evaluator of a domain sets its normalisers)
        self._lazy: MemberBounds | None = None
        self._clear, self._alike = clear_partners(domain, len(self.library))
        self._planned_alike = planned_alike(domain, self._clear)
        # a route's work per evaluation, relative: its keyframes K. Only orders the routes (never changes
        # a number): measured per candidate ~K^1.7 on the KITTI routes (03, 81 keyframes ~1 ms; 00, 455
        # ~20 ms), but the route-ordering by K scored fewer routes in all (seven routes x four conditions
        # at $110,000, one thread: 523 route evaluations, 12.6 s CPU; by K^2 599, 13.9 s; by K^3 745, 13.5 s;
        # by K^0.5 508, 13.3 s; with the routes alone K and K^2 both 4.2 s)
        self.work = np.array([float(r.problem.scenario.n_poses) for r in domain.routes])

    def __repr__(self) -> str:
        return f"DomainEvaluator({len(self.routes)} routes, engine {self.engine!r}, {self.aggregate})"

    def route_scores(self, suite: Iterable[int]) -> np.ndarray:
        """f_r(S) of each route [nats], shape (R,), the routes on :attr:`jobs` threads."""
        s = as_suite(suite)
        self._check_positions(s)
        got = self.map_routes(lambda k: float(self.routes[k].score(s)))
        return np.array([got[k] for k in range(len(self.routes))], dtype=float)

    def map_routes(self, one: Any, routes: Sequence[int] | None = None) -> dict[int, Any]:
        """``one(k)`` for each route k of ``routes`` (default: every route), by route in the order
        given, on :attr:`jobs` threads, the dearest routes started first (BLAS held at one thread
        meanwhile). ``one`` must use route k's engine alone (each engine is used by one thread at a
        time): then every answer is the bytes of a run on one thread."""
        return self._on_threads(one, list(range(len(self.routes))) if routes is None else [int(k) for k in routes])

    def apply_routes(self, fn: Any, args: dict[int, tuple[Any, ...]]) -> dict[int, Any]:
        """``fn(route's evaluator, *args[k])`` for each route k of ``args``, by route: a whole piece of
        work on one route (a route's own greedy), run where the route's evaluator lives. ``fn`` is a
        module-level function (it is pickled by name to reach a worker process) that uses route k's
        engine alone: the bytes of a run on one thread. Here, on :attr:`jobs` threads."""
        return self._on_threads(lambda k: fn(self.routes[k], *args[k]), [int(k) for k in args])

    @property
    def width(self) -> int:
        """How many routes' work runs at once (:meth:`apply_routes`): here, :attr:`jobs` threads."""
        return max(1, self.jobs)

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
        """Upper bounds on F(S + {c}) − F(S), shape (len(candidates),): each route's engine's bounds
        (or, where it gives none, the route's last exact gains from lazy greedy at a subset of S),
        combined (F is a combination of the routes' scores with non-negative factors); None when
        some route has neither (each engine judges the cost of its bounds on its own route)."""
        base, cand = as_suite(suite), [int(c) for c in candidates]
        self._check_positions(base + tuple(cand))
        st = self._lazy_at(base, score=False)
        # every member asked: asking only clear and night of the city's mix (lazy greedy's last gains
        # bounding rain and fog) scored 1.5-2.2x as many routes on the seven KITTI routes, and skipping
        # fog alone (0.5 % of driving) 6 % more, for more time than its bounds cost. Skipping the
        # members that see S as their clear member does (night before a camera is bought: the clear
        # member's bounds, handed over by _bound_alike, bound theirs) scored 596 route evaluations
        # against 518 (their cameras' bounds, the clear ones, are too loose) and took longer
        got = self._member_gain_bounds(base, cand, st)
        for k in range(
            len(self.routes)
        ):  # first: the clear members' bounds reach their alike members before these are read
            b = got.get(k)
            if (
                b is not None and st is not None
            ):  # kept for the member-by-member scoring, with an allowance for round-off
                allowed = np.asarray(b, dtype=float) * (1.0 + BOUND_SLACK) + BOUND_SLACK * max(1.0, abs(st.own[k]))
                st.stale[k, cand] = np.minimum(st.stale[k, cand], allowed)
                self._bound_alike(st, k, cand, np.asarray(b, dtype=float))
        per = []
        for k in range(len(self.routes)):
            b = got.get(k)
            if b is None:
                if st is None:
                    return None
                b = st.stale[k, cand]  # lazy greedy's last exact gains (inf where none yet: no bound)
            per.append(np.asarray(b, dtype=float))
        return self.combine(np.stack(per)) if per else None

    def score_bounds(self, suite: Iterable[int], candidates: Sequence[int]) -> tuple[float, np.ndarray] | None:
        """Upper bounds on F(S) and each F(S + {c}): the routes' cheap bounds combined, or None
        unless every route's engine gives them."""
        base, cand = as_suite(suite), [int(c) for c in candidates]
        self._check_positions(base + tuple(cand))
        got = self._ask_members("score_bounds", base, cand, range(len(self.routes)))
        st = self._lazy_at(base, score=False)
        if st is not None:
            for k in range(len(self.routes)):
                if (
                    got[k] is not None and cand
                ):  # f_r(S + {c}) <= bound: Δ_r <= bound − f_r(S) (round-off allowed by the engine)
                    st.stale[k, cand] = np.minimum(st.stale[k, cand], np.asarray(got[k][1], dtype=float) - st.own[k])
        return self.combined_score_bounds(got[k] for k in range(len(self.routes)))

    def combined_gain_bounds(self, per_route: Iterable[np.ndarray | None]) -> np.ndarray | None:
        """The routes' bounds on the gains (in route order) combined, or None at the first route
        without them (the routes after it are not asked, when ``per_route`` is lazy)."""
        got = []
        for bounds in per_route:
            if bounds is None:
                return None
            got.append(np.asarray(bounds, dtype=float))
        return self.combine(np.stack(got)) if got else None

    def combined_score_bounds(
        self, per_route: Iterable[tuple[float, np.ndarray] | None]
    ) -> tuple[float, np.ndarray] | None:
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

    def _ask_members(self, method: str, base: Suite, cand: list[int], members: Iterable[int]) -> dict[int, Any]:
        """Each member k's ``method(base, cand)`` (``gain_bounds``, ``score_bounds``), by member, the
        members on :attr:`jobs` threads (a cluster's evaluator asks them all at once). The fast
        engine computes one route's gain bounds on one thread; 28 members' took 7.0 of 18.3 s of the
        seven KITTI routes x four conditions on one thread, here they run two at a time."""
        return self._on_threads(lambda k: getattr(self.routes[k], method)(base, cand), list(members))

    def _member_gain_bounds(self, base: Suite, cand: list[int], st: MemberBounds | None) -> dict[int, Any]:
        """Each member's engine's ``gain_bounds(base, cand)``, by member, on :attr:`jobs` threads; a
        clear member and the members that see S as it does (:attr:`MemberBounds.as_clear`) as one task
        sharing the clear member's pose covariance Σ_pp and the quadratics of its measured pairs
        under it. Why that is valid: those members' information at S is the clear member's (the very
        same measurement arrays of every sensor of S, same scenario and settings:
        :func:`clear_partners`), so its Σ_pp is theirs, and a pair's quadratic depends only on Σ_pp,
        the base and the pair's geometry (a condition keeps a subset of the clear pairs: looked up
        by keyframe and landmark); each member's bounds are then made from its own measurements'
        weights (a night camera's, not the clear one's). The dense Cholesky and inverse behind Σ_pp
        and the pairs' products are nearly all of a bound's cost: night members pay almost nothing
        at the steps before a camera is bought.
        """
        # engines that offer their quadratics (the fast engine in-process; a cluster's proxies do not,
        # and its evaluator asks every actor at once through _ask_members)
        share = all(getattr(r, "bound_quadratics", None) is not None for r in self.routes) and st is not None
        if not share or st is None or not st.as_clear.any():
            return self._ask_members("gain_bounds", base, cand, range(len(self.routes)))
        groups: dict[int, list[int]] = {}
        for k in range(len(self.routes)):
            p = int(self._clear[k]) if st.as_clear[k] else k
            groups.setdefault(p, []).append(k)

        def one(p: int) -> dict[int, Any]:
            members = groups[p]
            if len(members) == 1:
                return {p: self.routes[p].gain_bounds(base, cand)}
            shared = getattr(self.routes[p], "bound_quadratics")(base, cand)
            if shared is None:  # the engine gives no bounds here (too few candidates for their cost)
                return {k: None for k in members}
            return {k: getattr(self.routes[k], "gain_bounds")(base, cand, shared=shared) for k in members}

        out: dict[int, Any] = {}
        work = {p: sum(self.work[k] for k in ks) for p, ks in groups.items()}
        for part in self._on_threads(one, list(groups), work).values():
            out.update(part)
        return out

    def _on_threads(self, one: Any, members: list[int], work: Any = None) -> dict[int, Any]:
        """``one(k)`` of each member, by member in the order of ``members``, on :attr:`jobs` threads
        (the engines release the GIL in their factorizations); each answer comes from its route's
        engine alone: the same bytes on any number of threads. ``work``: each member's relative cost
        (indexed by member; default :attr:`work`): the dearest are started first, so that a large
        route does not start last while the other thread idles (seven KITTI routes x four
        conditions: the members' gain bounds took 4.2 s in route order on 2 threads for 5.6 s CPU)."""
        if self._blas is None:
            self._blas = ThreadpoolController()
        # BLAS held at one thread by this (calling) thread around the routes' work, on one thread
        # too: a route's products are small and mid-sized, where BLAS's threads cost more than they
        # give (16 cores: the seven KITTI routes' greedy on one thread took 5.83 s with 16 BLAS
        # threads, 4.84 s with one), and the worker processes hold it at one, so every place runs
        # the same products on one BLAS thread. Each engine also holds it while it scores, but
        # BLAS's thread count is the process's, and an engine's hold taken and restored on a pool
        # thread while another route's is held on the other could leave BLAS on one thread for good
        # (measured: after a domain run numpy's products changed their last bits); nested under
        # this hold, theirs find one thread and put one back.
        with self._blas.limit(limits=1, user_api="blas"):
            if self.jobs < 2 or len(members) < 2:
                return {k: one(k) for k in members}
            cost = self.work if work is None else work
            started = sorted(members, key=lambda k: -float(cost[k]))  # stable: ties in the given order
            if self._pool is None:
                self._pool = ThreadPoolExecutor(max_workers=self.jobs, thread_name_prefix="sensorsel-domain")
                weakref.finalize(self, self._pool.shutdown, wait=False)
            got = dict(zip(started, self._pool.map(one, started)))
        return {k: got[k] for k in members}

    def _lazy_at(self, base: Suite, *, score: bool = True) -> MemberBounds | None:
        """The member-by-member state at ``base``: the last one's stale bounds carried on when its
        suite is a subset of ``base`` (each route's gains only shrink as the suite grows), else none.
        f_r(S) comes from the last state (the pick, scored on every route), is 0 for the empty suite,
        or is computed (only with ``score``; else None is returned)."""
        st = self._lazy
        if st is not None and st.suite == base:
            return st
        R, n = len(self.routes), len(self.library)
        if st is not None and set(st.suite) <= set(base):
            stale = st.stale
            grown = [c for c in base if c not in st.suite]
            full = st.known.get(grown[0]) if len(grown) == 1 else None  # the pick, scored on every route
            own = full if full is not None and not np.isnan(full).any() else None
        else:
            stale, own = np.full((R, n), np.inf), None
        if own is None and base and not score:
            return None
        if own is None:
            own = np.zeros(R) if not base else self.route_scores(base)  # f_r(empty) = 0 exactly
        as_clear = (self._clear >= 0) & self._alike[:, list(base)].all(axis=1)
        self._lazy = MemberBounds(base, np.array(own, dtype=float), stale, as_clear=as_clear)
        return self._lazy

    def _bound_alike(self, st: MemberBounds, k: int, cand: list[int], gains: np.ndarray) -> None:
        """Bounds ``gains`` [nats] on clear member k's Δ_k(c | S) (exact, or its engine's) bound
        the members that see S as it does (:class:`MemberBounds`), with an allowance for round-off."""
        allowed = gains * (1.0 + BOUND_SLACK) + BOUND_SLACK * max(1.0, abs(st.own[k]))
        for j in np.flatnonzero(st.as_clear & (self._clear == k)).tolist():
            st.stale[j, cand] = np.minimum(st.stale[j, cand], allowed)

    def scores_or_bounds(
        self, suite: Iterable[int], candidates: Sequence[int], needed: np.ndarray, *, ahead: Sequence[int] = ()
    ) -> tuple[np.ndarray, np.ndarray]:
        """For each candidate c, F(S + {c}) exactly, or an upper bound on it below ``needed`` (what
        it must reach to matter), scoring its routes one at a time (see the module's documentation).

        Args:
            needed: (len(candidates),) the F(S + {c}) each candidate must reach (−inf: score it exactly).
            ahead: the lazy queue's next candidates after these, likeliest first: their routes are
                scored ahead on the threads or workers a round leaves idle (:mod:`.ahead`; the same
                answers and counts, to the bit, with or without).

        Returns:
            (values, exact), shape (len(candidates),) each: F(S + {c}) where ``exact``, else a bound
            on it below ``needed``. At least one more route of each candidate is scored per call, so
            a caller asking again always gets closer to the exact value. Each candidate counts one
            evaluation in :attr:`n_evaluations`.
        """
        base, cand = as_suite(suite), [int(c) for c in candidates]
        self._check_positions(base + tuple(cand))
        self.n_evaluations += len(cand)
        st = self._lazy_at(base)
        assert st is not None
        R = len(self.routes)
        need = np.broadcast_to(np.asarray(needed, dtype=float), (len(cand),))
        out, exact = np.zeros(len(cand)), np.zeros(len(cand), dtype=bool)
        scored = np.zeros(len(cand), dtype=int)  # routes scored for each candidate in this call
        open_ = list(range(len(cand)))
        while open_:
            groups: dict[int, list[int]] = {}
            width = LONE_ROUTES if len(open_) == 1 else 1  # routes scored per candidate in this round
            for i in open_:
                c = cand[i]
                known = st.known.setdefault(c, np.full(R, np.nan))
                mirror = self._mirrors(st, c, known)
                todo = np.isnan(known)
                if not todo.any():
                    out[i], exact[i] = (
                        float(self.combine(known)),
                        True,
                    )  # the route order of scores_with: the same bytes
                    continue
                terms = np.where(todo, st.own + st.stale[:, c], known)
                bound = float(self.combine(terms))
                if scored[i] and bound < need[i]:
                    out[i] = bound  # cannot reach what it needs: a bound is all it gets
                    continue
                ask = todo & ~mirror  # a mirror's score comes with its clear member's
                if not np.isfinite(need[i]):  # to be scored exactly: every route at once
                    for m in np.flatnonzero(ask).tolist():
                        groups.setdefault(m, []).append(i)
                    continue
                # the routes whose unknown terms are largest per unit of work (infinite terms first, in
                # route order); a mirror's term counts with its clear member's, whose score gives both
                gap = np.where(todo, self.scale * st.stale[:, c], -np.inf)
                for j in np.flatnonzero(mirror).tolist():
                    gap[self._clear[j]] += gap[j]
                gap[mirror] = -np.inf
                prio = np.where(np.isinf(gap) & (gap > 0), np.inf, gap / self.work)
                for m in np.argsort(-prio, kind="stable")[: min(width, int(ask.sum()))].tolist():
                    groups.setdefault(m, []).append(i)
            open_ = sorted({i for idx in groups.values() for i in idx})
            groups = dict(sorted(groups.items()))  # routes asked in route order
            got = self._answer(
                st,
                base,
                {k: [cand[i] for i in idx] for k, idx in groups.items()},
                [cand[i] for i in open_] + [int(c) for c in ahead if int(c) not in cand],
            )
            for k, idx in groups.items():
                for i, v in zip(idx, np.asarray(got[k], dtype=float)):
                    c = cand[i]
                    st.known[c][k] = v
                    st.stale[k, c] = min(st.stale[k, c], v - st.own[k])
                    self._bound_alike(st, k, [c], np.array([v - st.own[k]]))
                    self._mirrors(st, c, st.known[c])
                    scored[i] += 1
        return out, exact

    def _mirrors(self, st: MemberBounds, c: int, known: np.ndarray) -> np.ndarray:
        """(R,) bool: the members that measure S + {c} exactly as their clear member does (S as it
        does, :attr:`MemberBounds.as_clear`, and c with the very same arrays), whose f_m(S + {c})
        [nats] is then their clear member's, copied into ``known`` (and their stale bound) where
        the clear member's is known.

        Why that is exact, to the bit: the member's engine and its clear member's are built from the
        same scenario, settings and, for every sensor of S + {c}, the very same measurement arrays,
        so they hold the same information matrix and compute its log det by the same deterministic
        steps (f_m(S) = f_clear(S) likewise, so the gains agree too), provided their engines planned
        alike (:func:`planned_alike`: the fast engine's landmark tiles come from every landmark the
        library measures; where night loses a landmark only a camera saw, no copies). Night changes the cameras
        alone: until a camera is bought, a night member's LiDAR and radar candidates need no
        evaluation of their own (a quarter of the city's driving, on the longest routes)."""
        mirror = st.as_clear & self._alike[:, c] & self._planned_alike
        for j in np.flatnonzero(mirror & np.isnan(known)).tolist():
            v = known[self._clear[j]]
            if not np.isnan(v):
                known[j] = v
                st.stale[j, c] = min(st.stale[j, c], v - st.own[j])
        return mirror

    def _answer(
        self, st: MemberBounds, base: Suite, groups: dict[int, list[int]], hopeful: list[int]
    ) -> dict[int, np.ndarray]:
        """f_k(S + {c}) for the candidates ``groups[k]`` of each member k: those scored ahead read
        back (and counted as evaluations now, where a one-thread run computes them), the others asked
        (:meth:`_ask_members_grouped`) with, on the places the round leaves idle, calls scored ahead
        for the ``hopeful`` candidates (the round's, then the lazy queue's; :mod:`.ahead`)."""
        out: dict[int, np.ndarray] = {}
        asked: dict[int, list[int]] = {}
        for k, cs in groups.items():
            out[k] = np.array([st.ahead.pop((k, c), np.nan) for c in cs], dtype=float)
            used = int(np.sum(~np.isnan(out[k])))
            self.routes[k].n_evaluations += used
            self.n_ahead_used += used
            if used < len(cs):
                asked[k] = [c for c, v in zip(cs, out[k].tolist()) if np.isnan(v)]
        if not asked:
            return out
        spec = self._plan_ahead(st, asked, hopeful)
        got = self._ask_members_grouped(base, asked, spec)
        for k, cs in asked.items():
            vals = iter(np.asarray(got[k], dtype=float)[: len(cs)].tolist())
            out[k] = np.array([v if not np.isnan(v) else next(vals) for v in out[k].tolist()], dtype=float)
        for k, cs in spec.items():
            mine = np.asarray(got[k], dtype=float)[len(asked.get(k, ())) :]  # after the round's own candidates
            st.ahead.update({(k, c): float(v) for c, v in zip(cs, mine.tolist())})
            self.n_ahead += len(cs)
        return out

    def _plan_ahead(self, st: MemberBounds, asked: dict[int, list[int]], hopeful: list[int]) -> dict[int, list[int]]:
        """{route: candidates} scored ahead in this round (:func:`.ahead.fill`), from the places
        (:meth:`_places`) and each hopeful candidate's next routes; nothing on one place."""
        cost = self.work**ahead_.COST_POWER
        places, home = self._places({k: float(cost[k]) * len(cs) for k, cs in asked.items()})
        if len(places) < max(2, self.ahead_from) or not hopeful:
            return {}
        lists = []
        for c in hopeful:
            mirror = st.as_clear & self._alike[:, c] & self._planned_alike
            routes = ahead_.next_routes(self.scale, self.work, st.stale[:, c], st.known.get(c), mirror, self._clear)
            lists.append([k for k in routes if (k, c) not in st.ahead and c not in asked.get(k, ())])
        return ahead_.fill(places, home, ahead_.breadth_first(lists, hopeful), cost)

    def _places(self, load: dict[int, float]) -> tuple[list[tuple[frozenset[int] | None, float]], dict[int, int]]:
        """Where a round's calls run: each of :attr:`jobs` threads (any route) with its predicted
        load, and each called route's thread, when the round's calls (``load``: each route's
        estimated cost) go dearest first to the least loaded thread."""
        if self.jobs < 2:
            return [], {}
        loads, home = ahead_.lpt(load, self.jobs)
        return [(None, x) for x in loads], home

    def _ask_members_grouped(
        self, base: Suite, groups: dict[int, list[int]], ahead: dict[int, list[int]] | None = None
    ) -> dict[int, np.ndarray]:
        """f_k(S + {c}) for the candidates ``groups[k]`` of each member k (one route call each), the
        routes on :attr:`jobs` threads (a lazy step asks for one or two candidates, often on
        different routes: one thread each); with ``ahead`` ({route: candidates}), those too, in the
        same route call after ``groups[k]``, not counted as evaluations (:meth:`_answer` counts
        them when used). An engine scores each candidate on its own against the base: the same
        bytes alone or in a batch."""
        spec = ahead or {}

        def one(k: int) -> np.ndarray:
            r, mine = self.routes[k], groups.get(k, [])
            n0 = r.n_evaluations  # this route's engine is used by this thread alone meanwhile
            out = np.asarray(r.scores_with(base, mine + spec.get(k, [])), dtype=float)
            r.n_evaluations = n0 + len(mine)
            return out

        calls = sorted(set(groups) | set(spec))
        work = {k: self.work[k] * (len(groups.get(k, [])) + len(spec.get(k, []))) for k in calls}
        return self._on_threads(one, calls, work)

    def scores_with(self, suite: Iterable[int], candidates: Sequence[int]) -> np.ndarray:
        """F(S + {c}) for each candidate c, shape (len(candidates),): each route's engine scores the
        candidates against the shared base suite, then the routes are combined."""
        base, cand = self._counted(suite, candidates)
        if not cand:
            return np.zeros(0)
        # the routes on the threads: a certificate's sweep or a plain greedy's step is every route
        # times every candidate, the widest work a domain has (each route's array from its own engine)
        got = self.map_routes(lambda k: np.asarray(self.routes[k].scores_with(base, cand), dtype=float))
        return self.combine(np.stack([got[k] for k in range(len(self.routes))]))
