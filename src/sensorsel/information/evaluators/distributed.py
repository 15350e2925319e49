"""A domain's routes on a Dask cluster's workers: :class:`DistributedDomainEvaluator` (``sensorsel[dask]``).

    with DaskCluster(workers=2) as cluster:              # sensorsel.pipeline.cluster
        ev = DistributedDomainEvaluator(cluster.client, domain)
        design = design_domain(domain, 110_000, evaluator=ev)      # every selector works unchanged

**Domain evaluation.** Each route's evaluator is built once, on a worker, from the route's recipe:
its scenario spec, the sensor library and the graph settings (a few kilobytes; a linearized GTSAM
graph does not pickle, and need not). Each worker holds its routes in one Dask *actor*
(:class:`WorkerRoutes`, one :class:`RouteActor` state per route). A greedy round sends each worker
one message: the base suite and the candidates of each of its routes (with what it scores ahead
for the lazy queue, :mod:`.ahead`); it answers with one array of f_r(S + c) per route, all its
routes' calls together (messages per round: the workers, not the routes; bytes: suites and
numbers, never arrays of the route); the client combines them in route order with
:meth:`DomainEvaluator.combine`, so the numbers are the bytes of the in-process
:class:`~sensorsel.information.evaluators.DomainEvaluator` whatever the number of workers. The
normalisers f_r(L) are computed by the actors too.

**Faults.** An actor lives on one worker; when that worker dies, the call fails. The evaluator then
builds that worker's routes again from their recipes on a live worker and repeats their calls (the
engines are deterministic: the repeated calls give the same bytes), at most ``retries`` times.

It sits beside the evaluators it distributes, above the generic pipeline (plan, executors, store,
the cluster), which knows no sensor. Importing it imports no Dask: a client is handed in.
"""

from __future__ import annotations

import concurrent.futures
import os
import pickle
import time
import weakref
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np

from sensorsel.information.evaluators.base import Evaluator, ProblemEvaluator, as_suite
from sensorsel.information.evaluators.domain import DomainEvaluator, check_aggregate
from sensorsel.information.evaluators.registry import check_engine, make_evaluator
from sensorsel.model.problem import Domain, Problem
from sensorsel.model.recipes import RouteRecipe
from sensorsel.pipeline import ClusterError

__all__ = ["DistributedDomainEvaluator", "RouteActor", "RouteRecipe", "WorkerRoutes"]


# ------------------------------------------------------------------------------------ route recipes


class RouteActor:
    """One route's evaluator, built once on a worker and kept there (held by its worker's
    :class:`WorkerRoutes` actor)."""

    def __init__(self, recipe: RouteRecipe, engine: str, jobs: int = 1) -> None:
        m0, t0 = _rss(), time.perf_counter()
        self.recipe = recipe
        self.evaluator: ProblemEvaluator = make_evaluator(recipe.build(), engine, jobs=jobs)
        self.best = float(self.evaluator.score(tuple(range(len(recipe.library)))))  # f_r(L), the normaliser
        self.built = (time.perf_counter() - t0, _rss() - m0)  # building the problem, its engine and f_r(L) [s], [bytes]
        self.busy_s, self.calls = 0.0, 0  # time spent scoring in this actor's calls [s], and their number

    def score(self, suite: tuple[int, ...]) -> float:
        t0 = time.perf_counter()
        out = float(self.evaluator.score(suite))
        self.busy_s, self.calls = self.busy_s + time.perf_counter() - t0, self.calls + 1
        return out

    def normaliser(self) -> float:
        """f_r(L): the whole library's score on this route [nats] (computed when the actor was built)."""
        return self.best

    def scores_with(self, suite: tuple[int, ...], candidates: list[int]) -> np.ndarray:
        t0 = time.perf_counter()
        out = np.asarray(self.evaluator.scores_with(suite, candidates), dtype=float)
        self.busy_s, self.calls = self.busy_s + time.perf_counter() - t0, self.calls + 1
        return out

    def gain_bounds(self, suite: tuple[int, ...], candidates: list[int]) -> np.ndarray | None:
        """The route's engine's bounds on the gains (None where it has none or declines)."""
        return self.evaluator.gain_bounds(suite, candidates)

    def score_bounds(self, suite: tuple[int, ...], candidates: list[int]) -> tuple[float, np.ndarray] | None:
        """The route's engine's cheap bounds on the scores (None where it has none)."""
        return self.evaluator.score_bounds(suite, candidates)

    def pose_covariances(
        self, suite: tuple[int, ...], map_sigma_m: float | None, estimate: str = "smoother"
    ) -> np.ndarray:
        """The suite's (K, 3, 3) pose marginals on this route (``require``'s accuracy checks), of
        the filter's or the smoother's estimate."""
        t0 = time.perf_counter()
        out = self.evaluator.pose_covariances(suite, map_sigma_m=map_sigma_m, estimate=estimate)
        self.busy_s, self.calls = self.busy_s + time.perf_counter() - t0, self.calls + 1
        return out

    def apply(self, fn: Any, args: tuple[Any, ...]) -> Any:
        """``fn(this route's evaluator, *args)``: a whole piece of work on this route, done here."""
        t0 = time.perf_counter()
        out = fn(self.evaluator, *args)
        self.busy_s, self.calls = self.busy_s + time.perf_counter() - t0, self.calls + 1
        return out

    def busy(self) -> tuple[float, int, str]:
        """(seconds this actor spent scoring, calls it answered, its worker's address): the worker's
        share of a run's time; the rest of a step's wall time is the client, the network and Dask's
        actor machinery."""
        return self.busy_s, self.calls, _where()

    def cost(self) -> tuple[float, int]:
        """(seconds to build this route on its worker, resident bytes that added there: its problem and
        its engine after scoring the whole library; a measure, not an accounting: the allocator keeps
        freed memory, and routes built later on the same worker reuse it)."""
        return self.built[0], self.built[1]


class WorkerRoutes:
    """The routes one worker owns (a Dask actor, one per worker): each route's :class:`RouteActor`
    state, built there from its recipe and kept. A round of a domain's calls is one message per
    worker (:meth:`call`: every call for its routes, answered together), not one per route: the
    client's cost per round grows with the workers, not the routes."""

    def __init__(self) -> None:
        self.routes: dict[int, RouteActor] = {}

    def build(self, recipes: dict[int, RouteRecipe], engine: str, jobs: int = 1) -> dict[int, float]:
        """Build each route (in the order given: the dearest first) and return its normaliser f_r(L)."""
        for k, recipe in recipes.items():
            self.routes[k] = RouteActor(recipe, engine, jobs)
        return {k: self.routes[k].best for k in recipes}

    def call(self, calls: dict[int, tuple[str, tuple[Any, ...]]]) -> dict[int, Any]:
        """Each route's ``method(*args)``, route by route in the order given, answered together."""
        return {k: getattr(self.routes[k], method)(*args) for k, (method, args) in calls.items()}


def _where() -> str:
    """This process's place: its Dask worker's address, else its process id (a local worker process)."""
    try:
        from distributed import get_worker

        return str(get_worker().address)
    except (ImportError, ValueError):
        return f"pid {os.getpid()}"


def _rss() -> int:
    """Resident bytes of this process now (psutil, which Dask's distributed itself needs)."""
    import psutil  # type: ignore[import-untyped]

    return int(psutil.Process().memory_info().rss)


class _RemoteRoute(Evaluator):
    """A route's evaluator seen from the client: every call goes to its actor (for the per-route
    breakdown, which runs greedy on each route alone)."""

    name = "remote"

    def __init__(self, owner: DistributedDomainEvaluator, k: int) -> None:
        super().__init__(owner.library, jobs=owner.jobs)
        # a proxy, not the evaluator: no cycle through its routes, so the evaluator (and a local
        # evaluator's worker processes) goes when its last user lets go, not at a later collection
        self.owner, self.k = weakref.proxy(owner), k

    def score(self, suite: Iterable[int]) -> float:
        s = as_suite(suite)
        self._check_positions(s)
        self.n_evaluations += 1
        return float(self.owner._call({self.k: ("score", (s,))})[self.k])

    def _ask(self, method: str, suite: Iterable[int], candidates: Sequence[int]) -> Any:
        """The actor's answer to ``method(suite, candidates)``, the positions checked here first."""
        base, cand = as_suite(suite), [int(c) for c in candidates]
        self._check_positions(base + tuple(cand))
        return self.owner._call({self.k: (method, (base, cand))})[self.k]

    def scores_with(self, suite: Iterable[int], candidates: Sequence[int]) -> np.ndarray:
        got = np.asarray(self._ask("scores_with", suite, candidates), dtype=float)
        self.n_evaluations += len(got)
        return got

    def gain_bounds(self, suite: Iterable[int], candidates: Sequence[int]) -> np.ndarray | None:
        return self._ask("gain_bounds", suite, candidates)

    def score_bounds(self, suite: Iterable[int], candidates: Sequence[int]) -> tuple[float, np.ndarray] | None:
        return self._ask("score_bounds", suite, candidates)

    def pose_covariances(
        self, suite: Iterable[int], *, map_sigma_m: float | None = None, estimate: str = "smoother"
    ) -> np.ndarray:
        """The route's pose marginals, computed by its actor (the same bytes as in-process)."""
        s = as_suite(suite)
        self._check_positions(s)
        return np.asarray(self.owner._call({self.k: ("pose_covariances", (s, map_sigma_m, estimate))})[self.k])


def _route_cost(problem: Problem) -> int:
    """A route's expected cost on a worker: its measurements of the whole library."""
    return sum(len(o) for o in problem.observations) + 3 * problem.scenario.n_poses


class DistributedDomainEvaluator(DomainEvaluator):
    """:class:`DomainEvaluator`'s numbers, each route's evaluator living on a Dask worker.

    Args:
        client: a connected ``distributed.Client``.
        domain: the routes and their weights (each route is rebuilt on its worker from its recipe).
        engine: as for :class:`DomainEvaluator`.
        jobs: threads each route's engine may use on its worker.
        aggregate: as for :class:`DomainEvaluator`.
        retries: how many times a route whose worker died is rebuilt before giving up.

    Attributes:
        routes: one proxy evaluator per route (calls go to its actor).
        bytes_sent, bytes_received: pickled size of every call's arguments and results [bytes].
        n_rebuilt: routes rebuilt after losing their worker.
        step_bytes: (sent, received) of each domain ``scores_with`` call (a greedy step).
        n_messages: messages sent to the workers' actors, each one request and its answer: one per
            worker per round (its routes' calls together), one per worker's build.
        n_rounds: times the client sent calls and waited for all of their answers.
        wait_s: seconds the client spent waiting for answers [s].
    """

    #: what a lost worker raises: its actor cannot be reached (OSError: Dask's "Unable to contact
    #: Actor's worker", a closed comm; the worker processes' ConnectionError), its task was cancelled
    #: or killed. Only these are repaired (routes rebuilt, calls repeated); any other error is the
    #: routes' own (bad input, a bug), raised as it is: deterministic, it would recur on every try.
    _lost: tuple[type[Exception], ...] = (OSError, concurrent.futures.CancelledError)

    def __init__(
        self,
        client: Any,
        domain: Domain,
        engine: str | None = None,
        *,
        jobs: int = 1,
        aggregate: str = "normalised",
        retries: int = 3,
    ) -> None:
        Evaluator.__init__(self, domain.library, jobs=jobs)
        self.domain = domain
        self.engine = check_engine(engine)
        self.aggregate = check_aggregate(aggregate)
        self.client, self.retries = client, int(retries)
        if client is not None:  # Dask's own word for a worker that died under a task
            from distributed.scheduler import KilledWorker

            self._lost = (*self._lost, KilledWorker)
        self.recipes = tuple(RouteRecipe.of(r.name, r.problem) for r in domain.routes)
        self.bytes_sent = self.bytes_received = self.n_rebuilt = self.n_messages = self.n_rounds = 0
        self.wait_s = 0.0
        self.step_bytes: list[tuple[int, int]] = []
        self._actors: list[Any] = [None] * len(self.recipes)
        self._place([r.problem for r in domain.routes])
        self.routes = tuple(_RemoteRoute(self, k) for k in range(len(self.recipes)))  # type: ignore[assignment, misc]
        got = self._call({k: ("normaliser", ()) for k in range(len(self.recipes))})
        self.set_normalisers([float(got[k]) for k in range(len(self.recipes))])

    def __repr__(self) -> str:
        return f"DistributedDomainEvaluator({len(self.recipes)} routes, engine {self.engine!r}, {self.aggregate})"

    # -- placement and faults

    def _workers(self) -> list[str]:
        # asked of the scheduler each time: scheduler_info() may answer from the client's cached
        # identity, which can lack the per-worker entries (seen once in CI: "no workers" with two
        # workers registered)
        return sorted(self.client.nthreads())

    def _place(self, problems: list[Problem]) -> None:
        """Assign every route to a worker, the most expensive routes first, each to the least loaded
        worker (longest processing time first), then start one :class:`WorkerRoutes` actor per worker
        and build its routes there, the workers in parallel."""
        workers = self._workers()
        if not workers:
            raise ClusterError("the Dask cluster has no workers")
        load = {w: 0 for w in workers}
        owned: dict[str, list[int]] = {w: [] for w in workers}
        for k in sorted(range(len(problems)), key=lambda k: (-_route_cost(problems[k]), k)):
            w = min(workers, key=lambda a: (load[a], a))
            load[w] += _route_cost(problems[k])
            owned[w].append(k)
        self._build({w: ks for w, ks in owned.items() if ks})

    def _build(self, owned: dict[str | None, list[int]]) -> None:
        """Start a :class:`WorkerRoutes` actor on each worker of ``owned`` (None: any live worker)
        and build its routes there (in the order given), every worker at once; a worker that dies
        while building has its routes built once more anywhere."""
        where = {w: self._submit(ks, w) for w, ks in owned.items()}
        for w, (actor, fut) in where.items():
            try:
                fut.result()
            except self._lost as exc:  # the worker died while building: once more anywhere
                if w is None:
                    names = ", ".join(repr(self.recipes[k].name) for k in owned[w])
                    raise ClusterError(
                        f"route(s) {names} could not be built on the cluster ({type(exc).__name__}: {exc})"
                    ) from None
                self.n_rebuilt += len(owned[w])
                self._build({None: owned[w]})
                continue
            for k in owned[w]:
                self._actors[k] = actor

    def _submit(self, routes: list[int], worker: str | None) -> tuple[Any, Any]:
        """A new :class:`WorkerRoutes` actor (on ``worker``, else anywhere) and the future of its build."""
        recipes = {k: self.recipes[k] for k in routes}
        where: dict[str, Any] = {"workers": [worker], "allow_other_workers": True} if worker else {}
        try:
            actor = self.client.submit(WorkerRoutes, actor=True, pure=False, **where).result()
        except self._lost:  # the chosen worker is gone: anywhere
            actor = self.client.submit(WorkerRoutes, actor=True, pure=False).result()
        self.bytes_sent += len(pickle.dumps(recipes))
        self.n_messages += 1
        return actor, actor.build(recipes, self.engine, self.jobs)

    def _call(self, calls: dict[int, tuple[str, tuple[Any, ...]]]) -> dict[int, Any]:
        """Send the calls, one message per worker (each worker's routes' calls together), then
        gather; the routes of a worker that was lost are rebuilt on a live worker and their calls
        repeated (same recipe, same engine: same bytes)."""
        pending = dict(calls)
        out: dict[int, Any] = {}
        for attempt in range(self.retries + 1):
            groups: dict[int, tuple[Any, dict[int, tuple[str, tuple[Any, ...]]]]] = {}
            for k in sorted(pending):  # each worker's routes in route order
                actor = self._actors[k]
                groups.setdefault(id(actor), (actor, {}))[1][k] = pending[k]
            self.n_rounds += 1 if groups else 0
            futs: dict[int, Any] = {}
            for g, (actor, batch) in groups.items():
                self.bytes_sent += len(pickle.dumps(batch))
                self.n_messages += 1
                try:
                    futs[g] = actor.call(batch)
                except self._lost as exc:  # the actor's worker is already known to be gone
                    futs[g] = exc
            failed: dict[int, Exception] = {}
            t0 = time.perf_counter()
            for g, fut in futs.items():
                if not isinstance(fut, Exception):
                    try:
                        res = fut.result()
                    except self._lost as exc:
                        fut = exc
                    else:
                        self.bytes_received += len(pickle.dumps(res))
                        out.update(res)
                        continue
                for k in groups[g][1]:
                    failed[k] = fut
            self.wait_s += time.perf_counter() - t0
            if not failed:
                return out
            if attempt == self.retries:
                k, err = next(iter(failed.items()))
                raise ClusterError(
                    f"route {self.recipes[k].name!r}: its worker was lost {self.retries + 1} times "
                    f"({type(err).__name__}: {err})"
                )
            time.sleep(0.2 * (attempt + 1))  # let the scheduler notice the dead worker
            self.n_rebuilt += len(failed)
            self._build({None: sorted(failed)})
            pending = {k: pending[k] for k in failed}
        raise AssertionError("unreachable")

    # -- the Evaluator interface (same numbers as DomainEvaluator)

    def route_scores(self, suite: Iterable[int]) -> np.ndarray:
        s = as_suite(suite)
        self._check_positions(s)
        got = self._call({k: ("score", (s,)) for k in range(len(self.recipes))})
        self._count(1)
        return np.array([float(got[k]) for k in range(len(self.recipes))], dtype=float)

    def _count(self, n: int) -> None:
        """Count ``n`` evaluations on every route's proxy, as each route's own evaluator counts them
        in-process (robust selection over the worst route reads the routes' counts)."""
        for r in self.routes:
            r.n_evaluations += n

    def scores_with(self, suite: Iterable[int], candidates: Sequence[int]) -> np.ndarray:
        base, cand = self._counted(suite, candidates)
        if not cand:
            return np.zeros(0)
        s0, r0 = self.bytes_sent, self.bytes_received
        got = self._call({k: ("scores_with", (base, cand)) for k in range(len(self.recipes))})
        self._count(len(cand))
        self.step_bytes.append((self.bytes_sent - s0, self.bytes_received - r0))
        per_route = np.stack([np.asarray(got[k], dtype=float) for k in range(len(self.recipes))])
        return self.combine(per_route)

    def map_routes(self, one: Any, routes: Sequence[int] | None = None) -> dict[int, Any]:
        """``one(k)`` for each route, one route at a time from the client (each call still goes to
        the route's worker): the client's calls are not made for concurrent callers. Whole pieces of
        work on each route (a route's own greedy) go to the workers at once: :meth:`apply_routes`."""
        return {int(k): one(int(k)) for k in (range(len(self.recipes)) if routes is None else routes)}

    def apply_routes(self, fn: Any, args: dict[int, tuple[Any, ...]]) -> dict[int, Any]:
        """``fn(route's evaluator, *args[k])`` for each route k, on the workers that hold them, every
        worker asked at once (one message each): a route's own greedy runs beside its evaluator,
        not a message per step from here."""
        return self._call({int(k): ("apply", (fn, a)) for k, a in args.items()})

    @property
    def width(self) -> int:
        """How many routes' work runs at once: the workers holding routes."""
        return max(1, len({id(a) for a in self._actors}))

    def _ask_members(
        self, method: str, base: tuple[int, ...], cand: list[int], members: Iterable[int]
    ) -> dict[int, Any]:
        """Each member's ``method(base, cand)``, every actor asked at once (the bounds of
        :meth:`DomainEvaluator.gain_bounds` and :meth:`DomainEvaluator.score_bounds`: the same numbers)."""
        return self._call({k: (method, (base, cand)) for k in members})

    def _ask_members_grouped(
        self, base: tuple[int, ...], groups: dict[int, list[int]], ahead: dict[int, list[int]] | None = None
    ) -> dict[int, np.ndarray]:
        """Lazy greedy's route scores (:meth:`DomainEvaluator.scores_or_bounds`), every actor asked at
        once, each route's proxy counting its evaluations as its evaluator does in-process; with
        ``ahead`` ({route: candidates}), those scored ahead in the same call, after the round's
        own, not counted."""
        spec = ahead or {}
        calls = sorted(set(groups) | set(spec))
        got = self._call({k: ("scores_with", (base, groups.get(k, []) + spec.get(k, []))) for k in calls})
        for k, c in groups.items():
            self.routes[k].n_evaluations += len(c)
        return {k: np.asarray(got[k], dtype=float) for k in calls}

    def _places(self, load: dict[int, float]) -> tuple[list[tuple[frozenset[int] | None, float]], dict[int, int]]:
        """Each worker (its routes, the load of the round's calls on them), in a fixed order, and
        each called route's worker: a worker runs its routes' calls one after another, so what is
        scored ahead on a worker goes to its own routes
        (:mod:`sensorsel.information.evaluators.ahead`)."""
        owned: dict[int, list[int]] = {}
        for k, actor in enumerate(self._actors):
            owned.setdefault(id(actor), []).append(k)
        places = sorted(owned.values())
        home = {k: p for p, ks in enumerate(places) for k in ks if k in load}
        return [(frozenset(ks), sum(load.get(k, 0.0) for k in ks)) for ks in places], home

    def busy(self) -> dict[str, tuple[float, int, str]]:
        """Each route's (seconds its actor spent scoring, calls it answered, the worker holding it)."""
        got = self._call({k: ("busy", ()) for k in range(len(self.recipes))})
        return {
            self.recipes[k].name: (float(got[k][0]), int(got[k][1]), str(got[k][2])) for k in range(len(self.recipes))
        }

    def costs(self) -> dict[str, tuple[float, int]]:
        """Each route's (build seconds, resident bytes) on its worker (see :meth:`RouteActor.cost`)."""
        got = self._call({k: ("cost", ()) for k in range(len(self.recipes))})
        return {self.recipes[k].name: (float(got[k][0]), int(got[k][1])) for k in range(len(self.recipes))}
