"""A domain's routes on this machine's cores: :class:`ProcessDomainEvaluator`.

    ev = ProcessDomainEvaluator(domain, processes=4)    # 4 worker processes, each owning routes
    design = design_domain(domain, 110_000, evaluator=ev)
    ev.close()                                          # or: with ProcessDomainEvaluator(...) as ev

Threads do not make a domain faster: a route's scores are many small numpy and GTSAM calls, each
holding the interpreter's lock (measured on 16 cores: the seven KITTI routes' greedy took 4.5 s on 1
thread, 4.6 s on 2, 5.3 s on 16). Processes do not share that lock. This evaluator is the Dask one
(:class:`~sensorsel.information.evaluators.distributed.DistributedDomainEvaluator`: routes owned by
workers, a round one message per worker, the client adding the routes' scores in route order) with
its messages carried by pipes to processes of this machine instead of Dask's scheduler: the same
numbers, to the bit, as the in-process :class:`DomainEvaluator` on any number of processes, and a
round costs a pipe's round trip (tens of microseconds), not an actor call through a scheduler.

Each worker process is forked from one server process that has imported the evaluators already
(``multiprocessing``'s forkserver), so a worker starts in milliseconds, not the second an interpreter
takes to import numpy and GTSAM, and forking never copies this process's threads. The workers build
their routes from the routes' recipes, all at once. A worker that dies has its routes rebuilt on
another (as on a cluster). The workers are stopped by :meth:`ProcessDomainEvaluator.close`, by
``with``, or when the evaluator is collected.
"""

from __future__ import annotations

import multiprocessing
import signal
import traceback
import weakref
from collections import OrderedDict
from collections.abc import Callable, Sequence
from multiprocessing.connection import Connection
from typing import Any, Self

import numpy as np
from threadpoolctl import ThreadpoolController

from sensorsel.errors import SensorselError
from sensorsel.information.evaluators.base import Suite
from sensorsel.information.evaluators.distributed import DistributedDomainEvaluator, WorkerRoutes
from sensorsel.model.problem import Domain, Target
from sensorsel.model.recipes import RouteRecipe

__all__ = [
    "AHEAD_FROM_KEYFRAMES",
    "PROCESSES_FROM_KEYFRAMES",
    "CovariancesAhead",
    "ProcessDomainEvaluator",
    "on_processes",
]

#: a domain's routes go to worker processes from this many keyframes in all (and 2 routes, 2 jobs):
#: below, starting and feeding processes costs more than they give (2 cores, build + greedy +
#: certificate + breakdown at $12,000 on one thread against 2 processes: the two fixture routes, 63
#: keyframes, 0.29-0.32 s against 0.40 s; ten generated routes, 100, 0.52-0.56 s against 0.51-0.53 s;
#: thirty, 300, 1.58-1.71 s against 1.27-1.38 s; the suite's accuracy and integrity on thirty, 0.39 s
#: either way once the processes' server runs)
PROCESSES_FROM_KEYFRAMES = 300


def on_processes(target: Target, jobs: int) -> bool:
    """Whether ``jobs`` pays for worker processes on ``target``'s routes (several of them, and
    :data:`PROCESSES_FROM_KEYFRAMES`): a choice of speed alone (the same bytes either way)."""
    keyframes = sum(r.problem.scenario.n_poses for r in target.routes)
    return jobs >= 2 and len(target.routes) >= 2 and keyframes >= PROCESSES_FROM_KEYFRAMES


#: the module the server process imports before it forks workers (what a worker runs)
_PRELOAD = __name__


class _WorkerError(Exception):
    """An exception raised by a worker's own code (not the loss of the worker): passed to the caller
    with the worker's traceback, never retried (the engines are deterministic: it would recur)."""


def _serve(conn: Connection) -> None:
    """A worker process: one :class:`WorkerRoutes`, answering (method, args) requests in order, BLAS
    held at one thread (as the in-process evaluator holds it around its routes' work): N processes
    each with a BLAS thread per core would take turns on the cores (measured on 16 cores: the seven
    KITTI routes' greedy on one thread took 5.83 s with 16 BLAS threads, 4.84 s with one)."""
    # Ctrl-C reaches the whole process group, as SIGTERM does from a batch system: the evaluator's
    # process handles both (its journal written, cli.options) and stops its workers (close: a request
    # to stop, then SIGKILL; or at exit: they are daemons, and a closed pipe ends them), so a worker
    # ignores them rather than die under the evaluator's last requests or print a traceback of its own
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    with ThreadpoolController().limit(limits=1, user_api="blas"):
        _answer(conn)


def _answer(conn: Connection) -> None:
    routes = WorkerRoutes()
    while True:
        try:
            request = conn.recv()
        except (EOFError, OSError):  # the evaluator went away
            return
        if request is None:
            return
        method, args = request
        try:
            reply: tuple[str, Any] = ("ok", getattr(routes, method)(*args))
        except SensorselError as exc:  # bad input found on the worker: the user's message, as in-process
            reply = ("error", exc)
        except Exception:  # a bug: its traceback, as text (the exception may not pickle)
            reply = ("bug", traceback.format_exc())
        conn.send(reply)


class _Reply:
    """A request's answer, read from the worker's pipe when asked for (requests answered in order)."""

    def __init__(self, worker: _Worker) -> None:
        self.worker = worker

    def result(self) -> Any:
        try:
            status, value = self.worker.conn.recv()
        except (EOFError, OSError) as exc:
            self.worker.dead = True
            raise ConnectionError(f"worker process {self.worker.name} was lost ({type(exc).__name__})") from None
        if status == "error":
            raise value
        if status == "bug":
            raise _WorkerError(f"worker process {self.worker.name} failed:\n{value}")
        return value


class _Worker:
    """One worker process and the pipe to it; its requests are answered in the order sent."""

    def __init__(self, ctx: Any, name: str) -> None:
        self.name, self.dead = name, False
        self.conn, theirs = ctx.Pipe()
        self.process = ctx.Process(target=_serve, args=(theirs,), name=f"sensorsel-{name}", daemon=True)
        self.process.start()
        theirs.close()

    def _send(self, method: str, *args: Any) -> _Reply:
        try:
            self.conn.send((method, args))
        except (OSError, ValueError) as exc:
            self.dead = True
            raise ConnectionError(f"worker process {self.name} was lost ({type(exc).__name__})") from None
        return _Reply(self)

    def build(self, recipes: dict[int, Any], engine: str, jobs: int = 1) -> _Reply:
        return self._send("build", recipes, engine, jobs)

    def call(self, calls: dict[int, tuple[str, tuple[Any, ...]]]) -> _Reply:
        return self._send("call", calls)

    def stop(self, now: bool = False) -> None:
        """Ask the worker to stop after the request in hand (killed if it has not within 5 s), or
        ``now``: killed at once."""
        if not now:
            try:
                self.conn.send(None)
            except (OSError, ValueError):
                pass
            self.process.join(timeout=5)
        if self.process.is_alive():
            self.process.kill()
        self.process.join()
        self.conn.close()


def _stop_all(workers: list[_Worker], now: bool = False) -> None:
    for w in workers:
        w.stop(now)
    workers.clear()


class _StopsWorkers:
    """Worker processes stopped by :meth:`close`, by ``with``, or when the owner is collected (its
    ``_finalizer``)."""

    _finalizer: weakref.finalize

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def close(self) -> None:
        """Stop the worker processes (nothing can be asked of them afterwards)."""
        self._finalizer()


class ProcessDomainEvaluator(_StopsWorkers, DistributedDomainEvaluator):
    """:class:`DomainEvaluator`'s numbers, the routes owned by ``processes`` worker processes of this
    machine (see the module's documentation).

    Args:
        domain: the routes and their weights (each route is rebuilt in its worker from its recipe).
        engine: as for :class:`DomainEvaluator`.
        processes: worker processes (at most one per route is used).
        aggregate: as for :class:`DomainEvaluator`.
        retries: how many times a route whose worker died is rebuilt before giving up.

    Raises:
        InputError: as :class:`DomainEvaluator` (from the workers, which build the routes).
    """

    def __init__(
        self,
        domain: Domain,
        engine: str | None = None,
        *,
        processes: int,
        aggregate: str = "normalised",
        retries: int = 3,
    ) -> None:
        ctx = multiprocessing.get_context("forkserver")
        ctx.set_forkserver_preload([_PRELOAD])
        self._ctx, self._started = ctx, 0
        self._processes: list[_Worker] = []
        self._finalizer = weakref.finalize(self, _stop_all, self._processes)
        for _ in range(max(1, min(int(processes), len(domain.routes)))):
            self._start()
        try:
            super().__init__(None, domain, engine, jobs=1, aggregate=aggregate, retries=retries)
        except BaseException:
            self.close()
            raise

    def __repr__(self) -> str:
        return (
            f"ProcessDomainEvaluator({len(self.recipes)} routes on {len(self._processes)} processes, "
            f"engine {self.engine!r}, {self.aggregate})"
        )

    def _start(self) -> _Worker:
        w = _Worker(self._ctx, f"p{self._started}")
        self._started += 1
        self._processes.append(w)
        return w

    def _workers(self) -> list[str]:
        return [w.name for w in self._processes if not w.dead and w.process.is_alive()]

    def _submit(self, routes: list[int], worker: str | None) -> tuple[Any, Any]:
        """The worker process named ``worker`` (else the first live one, else a new one) and the
        reply to its building ``routes``; a process holds every route it built."""
        live = [w for w in self._processes if not w.dead and w.process.is_alive()]
        chosen = next((w for w in live if w.name == worker), live[0] if live else None)
        if chosen is None:
            chosen = self._start()
        recipes = {k: self.recipes[k] for k in routes}
        self.n_messages += 1
        return chosen, chosen.build(recipes, self.engine, self.jobs)


#: one route gets worker processes computing its smoother's covariances ahead (``require``'s greedy,
#: :class:`CovariancesAhead`) from this many keyframes on: KITTI 00's 455 took ~57 ms a suite, the
#: README tour's 53 ~1.4 ms (there a process's start and its messages cost about what it would save)
AHEAD_FROM_KEYFRAMES = 300
#: the covariances computed ahead kept until asked for (the oldest dropped first)
AHEAD_KEEP = 64


class CovariancesAhead(_StopsWorkers):
    """One route's pose covariances computed ahead of being asked for, on worker processes of this
    machine that each hold a copy of the route (built from its recipe, as the domain's workers
    build theirs): while this process computes what a search asks now, the workers compute what it
    will likely ask next (``require``'s greedy: the next candidates of its lazy queue).

        ahead = CovariancesAhead(RouteRecipe.of(name, problem), "fast", 1, map_sigma_m=0.2)
        ahead.submit([s1, s2, s3])          # s1 asked now; s2, s3 likely next: to the idle workers
        cov = ahead.take(s1, compute)       # s1 is not given out: compute(s1), here
        cov = ahead.take(s2, compute)       # s2's (K, 3, 3) covariances from its worker
        ahead.close()

    Why nothing changes but the time: a worker's engine is built from the same recipe and computes
    with BLAS on one thread, as this process's engine does (``single_thread``), so its covariances
    are the bits this process would compute (a test compares them); which suites go ahead, and when,
    changes only who computes them. A worker takes one suite at a time (never a queue: a suite asked
    for is done, or being computed, which :meth:`take` waits for, or not given out). A worker that
    fails or dies is dropped, and what it held is computed here. The first suite of a
    :meth:`submit` that no worker holds is the one asked now: it stays here (given out, this process
    would wait for it idle). On KITTI 00 (455 keyframes, local streets) the greedy's 301 smoother
    marginals took 14.2 s in one process; with one worker, this process computed 147 of them and
    waited 1.5 s in all for the worker's (docs/guide-requirements.md).

    Args:
        recipe: the route's recipe (:meth:`~sensorsel.model.recipes.RouteRecipe.of` its problem).
        engine: the engine's registered name (the one this process uses on the route).
        processes: worker processes (>= 1).
        map_sigma_m, estimate: as :meth:`~sensorsel.information.evaluators.base.ProblemEvaluator.pose_covariances`.
    """

    def __init__(
        self,
        recipe: RouteRecipe,
        engine: str,
        processes: int,
        *,
        map_sigma_m: float | None,
        estimate: str = "smoother",
    ) -> None:
        ctx = multiprocessing.get_context("forkserver")
        ctx.set_forkserver_preload([_PRELOAD])
        self._how = (map_sigma_m, estimate)
        self._workers = [_Worker(ctx, f"ahead{i}") for i in range(max(1, int(processes)))]
        # stopped at once: what they compute is of no use to anyone else
        self._finalizer = weakref.finalize(self, _stop_all, self._workers, True)
        #: per worker, what its pipe will answer next: None (its build) or a suite; at most one suite
        self._pending: dict[str, list[Suite | None]] = {}
        for w in self._workers:
            w.build({0: recipe}, engine, 1)
            self._pending[w.name] = [None]
        self._done: OrderedDict[Suite, np.ndarray] = OrderedDict()
        self._next: list[Suite] = []  # the latest suites likely asked next
        self.n_submitted = 0  # suites given to a worker
        self.n_taken = 0  # suites asked for that were computed ahead (the others ahead were work lost)

    def wait_built(self) -> None:
        """Wait until every worker has built its route (a search never waits for it: until then its
        suites are computed here)."""
        for w in list(self._workers):
            while None in self._pending.get(w.name, []):
                self._receive(w)

    @property
    def workers(self) -> int:
        """The worker processes still serving (a failed or lost one is dropped; none once closed)."""
        return len(self._workers)

    @property
    def pids(self) -> list[int]:
        """The worker processes' ids, in order."""
        return [int(w.process.pid or 0) for w in self._workers]

    def submit(self, suites: Sequence[Suite]) -> None:
        """The suites likely asked next, in order (the latest list replaces the one before). The
        first that no worker holds is this process's: it is asked first, and computed here (a
        worker given it would make this process wait for what it could compute itself); the next
        ones that no worker holds go to the idle workers, one each."""
        self._next = list(suites)
        self._collect()
        self._fill(self._unclaimed(None))

    def take(self, suite: Suite, compute: Callable[[Suite], np.ndarray]) -> np.ndarray:
        """``suite``'s (K, 3, 3) covariances: done ahead, or waited for while a worker computes them,
        or ``compute(suite)`` here where no worker holds it (the idle workers are first given the
        next suites of the latest :meth:`submit`). This process never computes ahead itself: it
        computes only what it is asked."""
        self._collect()
        got = self._done.pop(suite, None)
        if got is None:
            w = next((w for w in self._workers if suite in self._pending[w.name]), None)
            while w is not None and suite in self._pending[w.name]:
                self._receive(w)
            got = self._done.pop(suite, None)
        if got is None:
            self._fill(suite)
            return compute(suite)
        self.n_taken += 1
        return got

    def _unclaimed(self, mine: Suite | None) -> Suite | None:
        """The first suite of the latest :meth:`submit` that is not ``mine`` (this process's to
        compute) and that no one has done or computes."""
        busy = {s for q in self._pending.values() for s in q if s is not None}
        return next((s for s in self._next if s != mine and s not in self._done and s not in busy), None)

    def _fill(self, mine: Suite | None) -> None:
        """Give the idle workers the next suites of the latest :meth:`submit` but ``mine``, one each."""
        for w in [w for w in self._workers if not self._pending[w.name]]:
            s = self._unclaimed(mine)
            if s is None:
                return
            if self._send(w, s):
                self.n_submitted += 1

    def _trim(self) -> None:
        while len(self._done) > AHEAD_KEEP:
            self._done.popitem(last=False)

    def _send(self, w: _Worker, suite: Suite) -> bool:
        try:
            w.call({0: ("pose_covariances", (suite, *self._how))})
        except ConnectionError:
            self._drop(w)
            return False
        self._pending[w.name].append(suite)
        return True

    def _collect(self) -> None:
        """Read every reply already in a pipe (never waiting)."""
        for w in list(self._workers):
            while self._pending.get(w.name) and _ready(w):
                self._receive(w)

    def _receive(self, w: _Worker) -> None:
        """Read ``w``'s next reply (waiting for it); a failed or lost worker is dropped."""
        what = self._pending[w.name][0]
        try:
            value = _Reply(w).result()
        except Exception:  # a worker's failure only loses what it computed ahead
            self._drop(w)
            return
        self._pending[w.name].pop(0)
        if what is not None:
            self._done[what] = value[0]
            self._trim()

    def _drop(self, w: _Worker) -> None:
        self._workers.remove(w)
        self._pending[w.name] = []
        w.stop(now=True)


def _ready(w: _Worker) -> bool:
    try:
        return bool(w.conn.poll())
    except (OSError, ValueError):
        return True  # read it: the reading finds the worker lost
