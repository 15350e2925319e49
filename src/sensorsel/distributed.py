"""Past one machine: a domain's routes and a tradespace's runs on a Dask cluster (``sensorsel[dask]``).

    with DaskCluster(workers=2) as cluster:              # or DaskCluster(scheduler="tcp://10.0.0.5:8786")
        ev = DistributedDomainEvaluator(cluster.client, domain)
        design = design_domain(domain, 110_000, evaluator=ev)      # every selector works unchanged

**Domain evaluation.** Each route's evaluator is built once, on a worker, by a Dask *actor*
(:class:`RouteActor`) from the route's recipe: its scenario spec, the sensor library and the graph
settings (a few kilobytes; a linearized GTSAM graph does not pickle, and need not). A greedy step
sends the base suite and the candidates to every route's actor at once and gets back one array of
f_r(S + c) per route; the client combines them in route order with
:meth:`DomainEvaluator.combine`, so the numbers are the bytes of the in-process
:class:`~sensorsel.evaluators.DomainEvaluator` whatever the number of workers. The normalisers f_r(L)
are computed by the actors too.

**Faults.** An actor lives on one worker; when that worker dies, the call fails. The evaluator then
builds the route's actor again from its recipe on a live worker and repeats that route's call (the
engines are deterministic: the repeated call gives the same bytes), at most ``retries`` times.

**Study cells as tasks.** :func:`study_cells_on` runs each cell of a design study
(:mod:`sensorsel.study`) as a task, on a target built once per (library, landmark seed) by a task.

**Tradespace runs as tasks.** :func:`run_tradespace_on` runs each single rule's chain of budgets
(largest first, sharing prefixes exactly as in-process) as one Dask task; each task builds its
target on the worker from recipes and returns the runs, gathered in rule order.

Dask is imported only by this module, and only when a cluster is asked for: a run without one never
imports it.
"""

from __future__ import annotations

import pickle
import sys
import time
from dataclasses import dataclass
from typing import Any, Callable, Iterable, Sequence

import numpy as np

from .errors import SensorselError
from .evaluators import Evaluator, ProblemEvaluator, as_suite, make_evaluator
from .evaluators.domain import DomainEvaluator, check_aggregate
from .evaluators.registry import check_engine
from .library import SensorLibrary
from .problem import Domain, DomainRoute, Problem, Target, build_problem, check_reach
from .scenario import Scenario, ScenarioSpec, load_scenario

#: how `pip` installs what this module needs
EXTRA_HINT = 'pip install "sensorsel[dask]"'
#: seconds to wait for a scheduler to answer before giving up
DEFAULT_CONNECT_TIMEOUT_S = 5.0


class ClusterError(SensorselError):
    """The Dask extra is missing, or the scheduler does not answer, or a route cannot be rebuilt."""


def _import_distributed() -> Any:
    try:
        import distributed
    except ImportError as exc:
        raise ClusterError(f"--scheduler/--workers need Dask's distributed scheduler, which is not installed "
                           f"({exc}); install the extra: {EXTRA_HINT}") from None
    return distributed


class DaskCluster:
    """A Dask client for a run: to an existing scheduler, or to a LocalCluster of ``workers``
    processes that this object starts and stops (a context manager; ``close()`` is idempotent).

    Args:
        scheduler: address of a running scheduler (``tcp://10.0.0.5:8786``).
        workers: number of local worker processes (one thread each) to start instead.
        connect_timeout_s: how long a scheduler has to answer.
        echo: where to say what was started (the dashboard's address); default stderr.

    Raises:
        ClusterError: the extra is missing, both or neither of scheduler / workers, or no answer.
    """

    def __init__(self, scheduler: str | None = None, workers: int | None = None, *,
                 connect_timeout_s: float = DEFAULT_CONNECT_TIMEOUT_S, echo: Callable[[str], None] | None = None) -> None:
        if (scheduler is None) == (workers is None):
            raise ClusterError("give a scheduler address or a number of workers (one of them)")
        if workers is not None and workers < 1:
            raise ClusterError(f"--workers must be at least 1, got {workers}")
        self.scheduler, self.workers, self.connect_timeout_s = scheduler, workers, float(connect_timeout_s)
        self.echo = echo or (lambda line: print(line, file=sys.stderr))
        self.client: Any = None
        self._local: Any = None

    def __enter__(self) -> "DaskCluster":
        distributed = _import_distributed()
        if self.scheduler is not None:
            try:
                self.client = distributed.Client(self.scheduler, timeout=self.connect_timeout_s)  # actors find their client as the default one
            except (OSError, TimeoutError, ValueError) as exc:
                raise ClusterError(f"no Dask scheduler answered at {self.scheduler} within {self.connect_timeout_s:g} s "
                                   f"({type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''})") from None
            try:
                self.client.wait_for_workers(1, timeout=self.connect_timeout_s)
            except (OSError, TimeoutError) as exc:
                self.close()
                raise ClusterError(f"the Dask scheduler at {self.scheduler} has no worker after {self.connect_timeout_s:g} s "
                                   f"({type(exc).__name__})") from None
            self.echo(f"sensorsel: dask scheduler {self.scheduler}: {len(self.client.nthreads())} workers")
            return self
        import importlib.util
        import logging

        dashboard = "127.0.0.1:0" if importlib.util.find_spec("bokeh") is not None else None  # the dashboard needs bokeh
        self._local = distributed.LocalCluster(n_workers=self.workers, threads_per_worker=1, processes=True,
                                               host="127.0.0.1", scheduler_port=0, dashboard_address=dashboard,
                                               silence_logs=logging.ERROR,
                                               worker_dashboard_address=None)
        self.client = distributed.Client(self._local)  # actors find their client as the default one
        try:  # every worker registered before the first placement (the cluster starts them, they report later)
            self.client.wait_for_workers(self.workers, timeout=self.connect_timeout_s)
        except (OSError, TimeoutError) as exc:
            self.close()
            raise ClusterError(f"the local Dask cluster started fewer than {self.workers} workers within "
                               f"{self.connect_timeout_s:g} s ({type(exc).__name__})") from None
        where = self.client.dashboard_link if dashboard else "none (install bokeh for one)"
        self.echo(f"sensorsel: dask LocalCluster of {self.workers} worker processes at {self._local.scheduler_address}; "
                  f"dashboard {where}")
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def close(self) -> None:
        if self.client is not None:
            self.client.close()
            self.client = None
        if self._local is not None:
            self._local.close()
            self._local = None


# ------------------------------------------------------------------------------------ route recipes


@dataclass(frozen=True)
class RouteRecipe:
    """What a worker needs to rebuild one route's problem: a few kilobytes, never a matrix.

    ``scenario`` is sent only when the problem was built from objects (no ``spec`` to load from).
    """

    name: str
    library: SensorLibrary
    settings: Any
    spec: ScenarioSpec | None
    scenario: Scenario | None = None

    @classmethod
    def of(cls, name: str, problem: Problem) -> "RouteRecipe":
        return cls(name, problem.library, problem.settings, problem.spec, None if problem.spec is not None else problem.scenario)

    def build(self) -> Problem:
        if self.scenario is not None:
            sc = self.scenario
        else:
            assert self.spec is not None
            sc = load_scenario(self.spec)
        problem = build_problem(self.library, sc, self.settings, spec=self.spec)
        check_reach(problem)
        return problem


class RouteActor:
    """One route's evaluator, built once on a worker (a Dask actor) and kept there."""

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

    def busy(self) -> tuple[float, int, str]:
        """(seconds this actor spent scoring, calls it answered, its worker's address): the worker's
        share of a run's time; the rest of a step's wall time is the client, the network and Dask's
        actor machinery."""
        from distributed import get_worker

        return self.busy_s, self.calls, str(get_worker().address)

    def cost(self) -> tuple[float, int]:
        """(seconds to build this route on its worker, resident bytes that added there: its problem and
        its engine after scoring the whole library; a measure, not an accounting: the allocator keeps
        freed memory, and routes built later on the same worker reuse it)."""
        return self.built[0], self.built[1]


def _rss() -> int:
    """Resident bytes of this process now (psutil, which Dask's distributed itself needs)."""
    import psutil  # type: ignore[import-untyped]

    return int(psutil.Process().memory_info().rss)


class _RemoteRoute(Evaluator):
    """A route's evaluator seen from the client: every call goes to its actor (for the per-route
    breakdown, which runs greedy on each route alone)."""

    name = "remote"

    def __init__(self, owner: "DistributedDomainEvaluator", k: int) -> None:
        super().__init__(owner.library, jobs=owner.jobs)
        self.owner, self.k = owner, k

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


def _route_cost(problem: Problem) -> int:
    """A route's expected cost on a worker: its measurements of the whole library."""
    return sum(len(o) for o in problem.observations) + 3 * problem.scenario.n_poses


class DistributedDomainEvaluator(DomainEvaluator):
    """:class:`DomainEvaluator`'s numbers, each route's evaluator living on a Dask worker.

    Args:
        client: a connected ``distributed.Client``.
        domain: the routes and their weights (each route is rebuilt on its worker from its recipe).
        engine, aggregate: as for :class:`DomainEvaluator`.
        jobs: threads each route's engine may use on its worker.
        retries: how many times a route whose worker died is rebuilt before giving up.

    Attributes:
        routes: one proxy evaluator per route (calls go to its actor).
        bytes_sent, bytes_received: pickled size of every call's arguments and results [bytes].
        n_rebuilt: routes rebuilt after losing their worker.
        step_bytes: (sent, received) of each domain ``scores_with`` call (a greedy step).
    """

    def __init__(self, client: Any, domain: Domain, engine: str | None = None, *, jobs: int = 1,
                 aggregate: str = "normalised", retries: int = 3) -> None:
        Evaluator.__init__(self, domain.library, jobs=jobs)
        self.domain = domain
        self.engine = check_engine(engine)
        self.aggregate = check_aggregate(aggregate)
        self.client, self.retries = client, int(retries)
        self.recipes = tuple(RouteRecipe.of(r.name, r.problem) for r in domain.routes)
        self.bytes_sent = self.bytes_received = self.n_rebuilt = 0
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
        """Start every route's actor, the most expensive routes first, each on the least loaded worker."""
        workers = self._workers()
        if not workers:
            raise ClusterError("the Dask cluster has no workers")
        load = {w: 0 for w in workers}
        order = sorted(range(len(problems)), key=lambda k: (-_route_cost(problems[k]), k))
        futures = {}
        for k in order:
            w = min(workers, key=lambda a: (load[a], a))
            load[w] += _route_cost(problems[k])
            futures[k] = self._submit(k, [w])
        for k, fut in futures.items():
            self._actors[k] = self._wait_actor(k, fut)

    def _submit(self, k: int, workers: list[str] | None) -> Any:
        recipe = self.recipes[k]
        self.bytes_sent += len(pickle.dumps(recipe))
        where: dict[str, Any] = {"workers": workers, "allow_other_workers": True} if workers else {}
        return self.client.submit(RouteActor, recipe, self.engine, self.jobs, actor=True, pure=False, **where)

    def _wait_actor(self, k: int, fut: Any) -> Any:
        try:
            return fut.result()
        except SensorselError:
            raise
        except Exception as exc:  # the worker died while building: once more anywhere
            self.n_rebuilt += 1
            try:
                return self._submit(k, None).result()
            except SensorselError:
                raise
            except Exception:
                raise ClusterError(f"route {self.recipes[k].name!r} could not be built on the cluster "
                                   f"({type(exc).__name__}: {exc})") from None

    def _call(self, calls: dict[int, tuple[str, tuple[Any, ...]]]) -> dict[int, Any]:
        """Send each route's call to its actor at once, then gather; a route whose actor was lost is
        rebuilt on a live worker and its call repeated (same recipe, same engine: same bytes)."""
        pending = dict(calls)
        out: dict[int, Any] = {}
        for attempt in range(self.retries + 1):
            futs = {}
            for k, (method, args) in pending.items():
                self.bytes_sent += len(pickle.dumps(args))
                try:
                    futs[k] = getattr(self._actors[k], method)(*args)
                except Exception as exc:  # the actor's worker is already known to be gone
                    futs[k] = exc
            failed: dict[int, Exception] = {}
            for k, fut in futs.items():
                if isinstance(fut, Exception):
                    failed[k] = fut
                    continue
                try:
                    res = fut.result()
                except SensorselError:
                    raise
                except Exception as exc:
                    failed[k] = exc
                    continue
                self.bytes_received += len(pickle.dumps(res))
                out[k] = res
            if not failed:
                return out
            if attempt == self.retries:
                k, err = next(iter(failed.items()))
                raise ClusterError(f"route {self.recipes[k].name!r}: its worker was lost {self.retries + 1} times "
                                   f"({type(err).__name__}: {err})")
            time.sleep(0.2 * (attempt + 1))  # let the scheduler notice the dead worker
            for k in failed:
                self.n_rebuilt += 1
                self._actors[k] = self._wait_actor(k, self._submit(k, None))
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
        base = as_suite(suite)
        cand = [int(c) for c in candidates]
        self._check_positions(base + tuple(cand))
        self.n_evaluations += len(cand)
        if not cand:
            return np.zeros(0)
        s0, r0 = self.bytes_sent, self.bytes_received
        got = self._call({k: ("scores_with", (base, cand)) for k in range(len(self.recipes))})
        self._count(len(cand))
        self.step_bytes.append((self.bytes_sent - s0, self.bytes_received - r0))
        per_route = np.stack([np.asarray(got[k], dtype=float) for k in range(len(self.recipes))])
        return self.combine(per_route)

    def gain_bounds(self, suite: Iterable[int], candidates: Sequence[int]) -> np.ndarray | None:
        """The routes' bounds on the gains, combined as in-process (every actor asked at once), or
        None unless every route's engine gives them."""
        base, cand = as_suite(suite), [int(c) for c in candidates]
        self._check_positions(base + tuple(cand))
        got = self._call({k: ("gain_bounds", (base, cand)) for k in range(len(self.recipes))})
        return self.combined_gain_bounds(got[k] for k in range(len(self.recipes)))

    def score_bounds(self, suite: Iterable[int], candidates: Sequence[int]) -> tuple[float, np.ndarray] | None:
        """The routes' cheap bounds on the scores, combined as in-process, or None unless every
        route's engine gives them."""
        base, cand = as_suite(suite), [int(c) for c in candidates]
        self._check_positions(base + tuple(cand))
        got = self._call({k: ("score_bounds", (base, cand)) for k in range(len(self.recipes))})
        return self.combined_score_bounds(got[k] for k in range(len(self.recipes)))

    def busy(self) -> dict[str, tuple[float, int, str]]:
        """Each route's (seconds its actor spent scoring, calls it answered, the worker holding it)."""
        got = self._call({k: ("busy", ()) for k in range(len(self.recipes))})
        return {self.recipes[k].name: (float(got[k][0]), int(got[k][1]), str(got[k][2])) for k in range(len(self.recipes))}

    def costs(self) -> dict[str, tuple[float, int]]:
        """Each route's (build seconds, resident bytes) on its worker (see :meth:`RouteActor.cost`)."""
        got = self._call({k: ("cost", ()) for k in range(len(self.recipes))})
        return {self.recipes[k].name: (float(got[k][0]), int(got[k][1])) for k in range(len(self.recipes))}


# --------------------------------------------------------------------------- tradespace as tasks


@dataclass(frozen=True)
class TargetRecipe:
    """A problem or a domain, as workers rebuild it (routes as :class:`RouteRecipe`)."""

    routes: tuple[RouteRecipe, ...]
    weights: tuple[float, ...] | None  # None: one problem
    units: tuple[str, ...] = ()
    source: str = ""

    @classmethod
    def of(cls, target: Target) -> "TargetRecipe":
        if isinstance(target, Domain):
            return cls(tuple(RouteRecipe.of(r.name, r.problem) for r in target.routes),
                       tuple(r.weight for r in target.routes), tuple(r.unit for r in target.routes), target.source)
        return cls((RouteRecipe.of("", target),), None)

    def build(self) -> Target:
        if self.weights is None:
            return self.routes[0].build()
        return Domain(tuple(DomainRoute(r.name, r.build(), w, u) for r, w, u in zip(self.routes, self.weights, self.units)),
                      self.source)


def _rule_task(recipe: TargetRecipe, rule: str, budgets_desc: list[float], engine: str | None, jobs: int, lazy: bool,
               share_prefix: bool, aggregate: str, first: bool, constraints: Any = None) -> tuple[dict[float, Any], int]:
    """One single rule's runs at every budget, on a worker: (budget -> (result, shared), evaluations).

    In-process, one evaluator serves every rule and a problem's baseline log det is counted once, in
    the first rule's first run: the other rules' tasks compute it before counting (``first`` False)."""
    from .evaluators import evaluator_for
    from .tradespace import _rule_runs

    target = recipe.build()
    ev = evaluator_for(target, engine, jobs=jobs, aggregate=aggregate)
    if isinstance(ev, ProblemEvaluator) and not first:
        ev.baseline_logdet  # counted by the first rule's task only, as in-process
    n0 = ev.n_evaluations
    runs = _rule_runs(ev, rule, budgets_desc, lazy=lazy, share_prefix=share_prefix, tick=lambda: None, constraints=constraints)
    return runs, ev.n_evaluations - n0


@dataclass(frozen=True)
class RuleRunsRecord:
    """A finished tradespace task, as written to ``OUTDIR/runs/rule-NAME.json`` (read back by ``--resume``).

    Attributes:
        fingerprint: digest of everything the runs depend on (target, library, settings, budgets,
            rule, engine, laziness, prefix sharing, aggregate, whether it counts the baseline).
        rule: the single rule.
        budgets_usd: the budgets, largest first.
        runs: the run at each budget (all its steps).
        shared: each run's picks taken from a larger budget's run.
        n_evaluations: suites the task scored.
    """

    fingerprint: str
    rule: str
    budgets_usd: tuple[float, ...]
    runs: tuple[Any, ...]
    shared: tuple[int, ...]
    n_evaluations: int


def _rule_fingerprint(target: Target, rule: str, desc: list[float], engine: str | None, lazy: bool, share_prefix: bool,
                      aggregate: str, first: bool, constraints: Any = None) -> str:
    from .constraints import feasible_set
    from .resilient.algorithm import constraints_key
    from .resilient.cache import _digest, fingerprint

    problems = [r.problem for r in target.routes] if isinstance(target, Domain) else [target]
    weights = [r.weight for r in target.routes] if isinstance(target, Domain) else [1.0]
    what = {"what": "tradespace-rule", "budgets": list(desc), "share_prefix": share_prefix, "aggregate": aggregate,
            "first": first, "weights": weights,
            **constraints_key(feasible_set(target.library, max(desc), constraints) if constraints is not None else None)}
    return _digest([fingerprint(p, 0.0, 0, rule, check_engine(engine), lazy, what) for p in problems])


def _rule_record_path(outdir: str, rule: str) -> Any:
    from pathlib import Path

    return Path(outdir) / "runs" / f"rule-{rule}.json"


def _load_rule_record(path: Any, fp: str) -> RuleRunsRecord | None:
    import warnings

    from .codec import from_jsonable, read_json
    from .resilient.cache import CacheWarning
    from .selection import GreedyResult

    if not path.is_file():
        return None
    try:
        data = read_json(path)
        rec = RuleRunsRecord(fingerprint=str(data["fingerprint"]), rule=str(data["rule"]),
                             budgets_usd=tuple(float(b) for b in data["budgets_usd"]),
                             runs=tuple(from_jsonable(GreedyResult, r) for r in data["runs"]),
                             shared=tuple(int(k) for k in data["shared"]), n_evaluations=int(data["n_evaluations"]))
    except (SensorselError, KeyError, TypeError, ValueError) as exc:
        warnings.warn(f"{path}: not reused, it cannot be read ({exc}); recomputing and overwriting it", CacheWarning, stacklevel=2)
        return None
    if rec.fingerprint != fp:
        warnings.warn(f"{path}: not reused, it was computed from other inputs; recomputing and overwriting it",
                      CacheWarning, stacklevel=2)
        return None
    return rec


def rule_runs_on(client: Any, target: Target, *, engine: str | None = None, jobs: int = 1, aggregate: str = "normalised",
                 retries: int = 3, outdir: str | None = None, resume: bool = False,
                 constraints: Any = None) -> Callable[..., Any]:
    """A runner for :func:`sensorsel.tradespace.tradespace` (``rule_runs=``) that runs each single
    rule's chain of budgets as one Dask task (rerun elsewhere if its worker dies), gathered in rule
    order; ``tick`` is called as each rule's runs arrive (once per budget). With ``outdir``, each
    finished task is written to ``outdir/runs/rule-NAME.json`` by the client; ``resume`` reads back
    those whose inputs match instead of running them again."""
    distributed = _import_distributed()
    recipe = TargetRecipe.of(target)

    def run(singles: list[str], desc: list[float], lazy: bool, share_prefix: bool,
            tick: Callable[[], None]) -> tuple[dict[str, dict[float, Any]], int]:
        from .codec import save

        fps = {r: _rule_fingerprint(target, r, desc, engine, lazy, share_prefix, aggregate, r == singles[0], constraints)
               for r in singles}
        got: dict[str, tuple[dict[float, Any], int]] = {}
        if outdir is not None and resume:
            for r in singles:
                old = _load_rule_record(_rule_record_path(outdir, r), fps[r])
                if old is not None:
                    got[r] = ({b: (run_, k) for b, run_, k in zip(old.budgets_usd, old.runs, old.shared)}, old.n_evaluations)
                    for _ in desc:
                        tick()
        futs = {client.submit(_rule_task, recipe, r, desc, engine, jobs, lazy, share_prefix, aggregate, r == singles[0],
                              constraints, pure=False, retries=retries): r for r in singles if r not in got}
        for fut in distributed.as_completed(list(futs)):
            r = futs[fut]
            got[r] = _result(fut, f"tradespace rule {r!r}")
            if outdir is not None:
                runs = got[r][0]
                save(RuleRunsRecord(fps[r], r, tuple(runs), tuple(v[0] for v in runs.values()),
                                    tuple(v[1] for v in runs.values()), got[r][1]), _rule_record_path(outdir, r))
            for _ in desc:
                tick()
        return {r: got[r][0] for r in singles}, sum(got[r][1] for r in singles)

    return run


def run_tradespace_on(client: Any, target: Target, budgets: Iterable[float] | None = None,
                      rules: Iterable[str] | None = None, *, engine: str | None = None, jobs: int = 1, lazy: bool = True,
                      share_prefix: bool = True, aggregate: str = "normalised", progress: Callable[[int, int], None] | None = None,
                      outdir: str | None = None, resume: bool = False, constraints: Any = None) -> Any:
    """:func:`sensorsel.tradespace.run_tradespace` with each single rule's runs as a Dask task: the
    same result (timings aside) as in-process. ``outdir``/``resume``: see :func:`rule_runs_on`;
    ``constraints``: kept by every run (and part of each rule file's fingerprint)."""
    from .evaluators.registry import ENGINES
    from .selection import check_budget
    from .tradespace import DEFAULT_RULES, parse_rules, tradespace

    sel = parse_rules(DEFAULT_RULES if rules is None else rules, "rules")
    grid = None if budgets is None else tuple(check_budget(b) for b in budgets)
    check_aggregate(aggregate)
    name = DomainEvaluator.name if isinstance(target, Domain) else ENGINES[check_engine(engine)].name
    runner = rule_runs_on(client, target, engine=engine, jobs=jobs, aggregate=aggregate, outdir=outdir, resume=resume,
                          constraints=constraints)
    return tradespace(_NamedEvaluator(target.library, name), grid, sel, lazy=lazy, share_prefix=share_prefix,
                      progress=progress, info=target.info, rule_runs=runner, constraints=constraints)


class _NamedEvaluator(Evaluator):
    """The library and the engine's name, for a tradespace whose runs are made elsewhere."""

    def __init__(self, library: SensorLibrary, name: str) -> None:
        super().__init__(library)
        self.name = name  # type: ignore[misc]

    def score(self, suite: Iterable[int]) -> float:
        raise AssertionError("a tradespace run as tasks scores nothing on the client")


# ------------------------------------------------------------------------ resilient periods as tasks


def _period_task(problem: Problem, span: tuple[int, float, float, np.ndarray], budget: float, alpha: int, rule: str,
                 engine: str, jobs: int, lazy: bool, period: float, path: str | None, resume: bool,
                 constraints: Any = None) -> Any:
    """One period on a worker: :func:`sensorsel.resilient.periods._one_period` (which reuses a
    matching period file when resuming and writes the file it computes)."""
    from pathlib import Path

    from .resilient.periods import _one_period

    k, a, b, kf = span
    return _one_period(problem, k, a, b, kf, budget, alpha, rule, engine, jobs, lazy, period,
                       Path(path) if path is not None else None, resume, constraints=constraints)


def _compare_task(problem: Problem, budget: float, alpha: int, rule: str, engine: str | None, jobs: int, lazy: bool,
                  cache: str | None, resume: bool, constraints: Any = None) -> Any:
    from pathlib import Path

    from .resilient import compare

    return compare(problem, budget, alpha, rule, engine=engine, jobs=jobs, lazy=lazy,
                   cache=Path(cache) if cache is not None else None, resume=resume, constraints=constraints)


def resilient_report_on(client: Any, problem: Problem, budget_usd: float, alpha: int, *, period_s: float, rule: str = "uniform",
                        engine: str | None = None, jobs: int = 1, lazy: bool = True, outdir: str | None = None,
                        resume: bool = False, progress: Callable[[int, int], None] | None = None,
                        constraints: Any = None) -> Any:
    """:func:`sensorsel.resilient.resilient_report` on one route with the whole-route comparison and
    every period as Dask tasks (the problem is sent once to each worker; the period files are
    written by the workers, so ``outdir`` must be on a file system they share). ``--resume``: a
    period whose file matches is read back, not recomputed. Results gathered in period order."""
    from pathlib import Path

    from .resilient import check_alpha, check_period, check_rule, split_periods
    from .resilient.algorithm import engine_name
    from .resilient.periods import make_grid, period_file
    from .resilient.records import PerPeriodResult, ResilientReport
    from .selection import check_budget

    distributed = _import_distributed()
    t0 = time.perf_counter()
    budget, alpha, rule = check_budget(budget_usd), check_alpha(alpha), check_rule(rule)
    period = check_period(period_s)
    name = engine_name(engine)
    spans = split_periods(problem.scenario.keyframes.times, period)
    # hash=False: a key of its own for each call. With the default content hash, a second call on the
    # same problem scatters to the same key while the first call's release of it may still be on its
    # way to the scheduler, which then deletes the data under the new tasks ("lost dependencies").
    shared = client.scatter(problem, broadcast=True, hash=False)
    cache = str(Path(outdir) / "periods" / "route.json") if outdir is not None else None
    cmp_fut = client.submit(_compare_task, shared, budget, alpha, rule, engine, jobs, lazy, cache, resume, constraints,
                            pure=False)
    futs = {client.submit(_period_task, shared, span, budget, alpha, rule, name, jobs, lazy, period,
                          str(period_file(outdir, span[0])) if outdir is not None else None, resume, constraints,
                          pure=False): i
            for i, span in enumerate(spans)}
    got: dict[int, Any] = {}
    for fut in distributed.as_completed(list(futs)):
        got[futs[fut]] = _result(fut, f"period {spans[futs[fut]][0]}")
        if progress:
            progress(len(got), len(spans))
    cmp_ = _result(cmp_fut, "the whole-route comparison")
    out = [got[i] for i in range(len(spans))]
    if outdir is not None:  # as in-process: files of periods this run does not have would mislead
        keep = {period_file(outdir, k).name for k, *_ in spans}
        for f in sorted((Path(outdir) / "periods").glob("period-*.json")):
            if f.name not in keep:
                f.unlink()
    per = PerPeriodResult(period_s=period, alpha=alpha, budget_usd=budget, rule=rule, engine=name, periods=tuple(out),
                          grid=make_grid(problem.library, out), seconds=round(time.perf_counter() - t0, 6),
                          constraints=cmp_.constraints)
    return ResilientReport(suite=cmp_.resilient.suite, failed=cmp_.resilient.failed, alpha=alpha, budget_usd=budget,
                           rule=rule, engine=cmp_.engine, comparison=cmp_, per_period=per,
                           seconds=round(time.perf_counter() - t0, 6), constraints=cmp_.constraints)


def _result(fut: Any, what: str) -> Any:
    try:
        return fut.result()
    except SensorselError:
        raise
    except Exception as exc:
        raise ClusterError(f"{what} failed on the cluster ({type(exc).__name__}: {exc})") from None


# ------------------------------------------------------------------------------ study cells as tasks


def _build_target(recipe: Any) -> Target:
    """A study's target (a route or a domain), built on a worker once for all its cells."""
    built: Target = recipe.build()
    return built


def _cell_task(target: Target, cell: Any, study: Any) -> tuple[Any, Any]:
    """One study cell on a worker: (its row, what its target is)."""
    from .study import run_cell

    return run_cell(target, cell, study, jobs=1), target.info


def study_cells_on(client: Any, *, retries: int = 3) -> Callable[..., None]:
    """A runner for :func:`sensorsel.study.run_study` (``runner=``) that runs each cell as one Dask
    task. Each target (one per library and landmark seed of the grid) is built once, by a task of its
    own, and handed to its cells' tasks (Dask moves it between workers if it must); Dask reruns a
    task whose worker died (``retries`` for a task that raised). ``done(row, info)`` is called on the
    client as each cell completes: the rows are gathered there, in cell order, by ``run_study``."""
    distributed = _import_distributed()

    def run(study: Any, cells: Sequence[Any], done: Callable[[Any, Any], None]) -> None:
        built = {t: client.submit(_build_target, study.targets[t], pure=False, retries=retries)
                 for t in sorted({c.target for c in cells})}
        futs = {client.submit(_cell_task, built[c.target], c, study, pure=False, retries=retries): c for c in cells}
        try:
            for fut in distributed.as_completed(list(futs)):
                row, info = _result(fut, f"study cell {futs[fut].index}")
                done(row, info)
        finally:
            client.cancel(list(futs) + list(built.values()))  # an interrupted study leaves nothing running

    return run


# --------------------------------------------------------------------- simulation runs as tasks


def _simulation_run(payload: Any, run: int) -> dict:
    """One Monte-Carlo run on a worker (draws from (seed, run): the same numbers wherever it runs)."""
    from .simulate.solve import solve_run

    return solve_run(payload, run)


def simulation_runs_on(client: Any, *, retries: int = 3) -> Callable[..., list[dict]]:
    """A ``run_map`` for :func:`sensorsel.simulate.simulate`: the payload (the suite's measurements and
    noise, numbers only) is sent once to every worker, each run is one task, the runs' raw outputs
    are gathered in run order (``progress`` ticks as each completes). Run r draws from streams
    seeded by (seed, r) wherever it runs, so the result is the in-process one, timings aside."""
    distributed = _import_distributed()

    def run_map(payload: Any, runs: int, progress: Callable[[int, int], None] | None) -> list[dict]:
        shared = client.scatter(payload, broadcast=True, hash=False)  # hash=False: see resilient_report_on
        futs = {client.submit(_simulation_run, shared, r, pure=False, retries=retries): r for r in range(runs)}
        got: dict[int, dict] = {}
        try:
            for fut in distributed.as_completed(list(futs)):
                got[futs[fut]] = _result(fut, f"simulation run {futs[fut]}")
                if progress:
                    progress(len(got), runs)
        finally:
            client.cancel(list(futs) + [shared])
        return [got[r] for r in range(runs)]

    return run_map
