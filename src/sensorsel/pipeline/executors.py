"""Executors: where a plan's tasks run. :class:`InProcess` here, one after another;
:class:`LocalProcesses` on worker processes of this machine; :class:`DaskExecutor` as Dask tasks on
a client's workers (``sensorsel[dask]``)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, Protocol

from sensorsel.errors import SensorselError
from sensorsel.pipeline.plan import Plan

#: how `pip` installs what the Dask executor needs
EXTRA_HINT = 'pip install "sensorsel[dask]"'

#: done(task index, result): called on the client as each task's result arrives
Done = Callable[[int, Any], None]


class ClusterError(SensorselError):
    """The Dask extra is missing, or the scheduler does not answer, or a task or a route cannot run there."""


def import_distributed() -> Any:
    """Dask's ``distributed`` module, or a :class:`ClusterError` saying how to install it."""
    try:
        import distributed
    except ImportError as exc:
        raise ClusterError(
            f"--scheduler/--workers need Dask's distributed scheduler, which is not installed "
            f"({exc}); install the extra: {EXTRA_HINT}"
        ) from None
    return distributed


class Executor(Protocol):
    """Runs some of a plan's tasks, calling ``done(i, result)`` for each as it finishes (any order)."""

    def run(self, plan: Plan[Any], todo: Sequence[int], done: Done) -> None: ...


class InProcess:
    """The tasks in this process, in task order. A state is built when its first task comes and
    dropped when a task of another state comes (plans list tasks in state order): one in memory."""

    def run(self, plan: Plan[Any], todo: Sequence[int], done: Done) -> None:
        held: dict[int, Any] = {}
        for i in todo:
            k = plan.state_index(i)
            if k not in held:
                held.clear()
                if plan.local is not None:
                    held[k] = plan.local[k]
                else:
                    held[k] = plan.build(plan.states[k]) if plan.build is not None else plan.states[k]
            done(i, plan.step(held[k], plan.tasks[i]))


class LocalProcesses:
    """The tasks on ``jobs`` worker processes of this machine. A job is one state's tasks, or part of
    them: a worker builds the state from its recipe (``plan.build``) once per job and runs the job's
    tasks on it, in task order (a job is one message out, its results one message back). A state
    with a recipe is one job (a domain's route: dear to build, few); a state that travels as it is
    (no ``build``: a simulation's draws on one payload) is cut into :data:`PARTS_PER_JOB` jobs per
    worker, so that every worker has work and the results (and the progress) come as they finish.
    Threads would not run these side by side (numpy and GTSAM's small calls hold the interpreter's
    lock). Workers are forked from a server process (``multiprocessing``'s forkserver; spawn where
    there is none), so a worker starts without importing numpy again; the steps are deterministic,
    so the bytes are those of an in-process run."""

    def __init__(self, jobs: int) -> None:
        self.jobs = int(jobs)

    def _jobs(self, plan: Plan[Any], todo: Sequence[int]) -> list[tuple[int, list[int]]]:
        """(state, its tasks) of each job, in task order."""
        by_state: dict[int, list[int]] = {}
        for i in todo:
            by_state.setdefault(plan.state_index(i), []).append(i)
        if plan.build is not None:
            return list(by_state.items())
        parts = -(-self.jobs * PARTS_PER_JOB // max(len(by_state), 1))
        out = []
        for k, ids in by_state.items():
            size = -(-len(ids) // parts)
            out += [(k, ids[a : a + size]) for a in range(0, len(ids), size)]
        return out

    def run(self, plan: Plan[Any], todo: Sequence[int], done: Done) -> None:
        jobs = self._jobs(plan, todo)
        if self.jobs < 2 or len(jobs) < 2:
            InProcess().run(plan, todo, done)
            return
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor, as_completed
        from concurrent.futures.process import BrokenProcessPool

        methods = multiprocessing.get_all_start_methods()
        ctx = multiprocessing.get_context("forkserver" if "forkserver" in methods else "spawn")
        if ctx.get_start_method() == "forkserver":
            # the server, when this starts it, imports the step's module once: each worker forked from
            # it starts with it imported (else each imports it again, ~0.8 s for the package's façade)
            ctx.set_forkserver_preload([plan.step.__module__])
        with ProcessPoolExecutor(
            max_workers=min(self.jobs, len(jobs)), mp_context=ctx, initializer=_ignore_interrupts
        ) as pool:
            futs = {
                pool.submit(_run_state, plan.build, plan.step, plan.states[k], [plan.tasks[i] for i in ids]): ids
                for k, ids in jobs
            }
            for fut in as_completed(futs):
                try:
                    got = fut.result()
                except BrokenProcessPool as exc:  # a worker was killed (out of memory, a signal)
                    raise ClusterError(f"a worker process running the {plan.name}s died ({exc})") from None
                for i, result in zip(futs[fut], got):
                    done(i, result)


#: jobs per worker process for a state that travels as it is (:class:`LocalProcesses`): results and
#: progress as they finish, and a slow part does not leave the other workers idle at the end
PARTS_PER_JOB = 4


def _ignore_interrupts() -> None:
    """A worker process ignores Ctrl-C (it reaches the whole process group): the process that started
    the pool stops it, and a worker would only print a traceback of its own."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _run_state(
    build: Callable[[Any], Any] | None, step: Callable[[Any, Any], Any], state: Any, tasks: list[Any]
) -> list[Any]:
    """A worker process's job: the state built (from its recipe) once, then each task on it."""
    held = build(state) if build is not None else state
    return [step(held, t) for t in tasks]


class DaskExecutor:
    """The tasks as Dask tasks on ``client``'s workers, results gathered on the client as they complete.

    Each state is sent once: scattered to every worker, or (with a recipe) built by one task whose
    result the state's tasks depend on (Dask moves it where they run). The tasks themselves are the
    plan's small messages. A task whose worker dies is rerun elsewhere by Dask (``retries`` for one
    that raised); the steps are deterministic, so the bytes are those of an in-process run.
    An interrupted run cancels what it submitted.
    """

    def __init__(self, client: Any, *, retries: int = 3) -> None:
        self.client, self.retries = client, int(retries)

    def run(self, plan: Plan[Any], todo: Sequence[int], done: Done) -> None:
        if not todo:
            return
        distributed = import_distributed()
        client = self.client
        states: dict[int, Any] = {}
        for k in sorted({plan.state_index(i) for i in todo}):
            if plan.build is not None:
                states[k] = client.submit(plan.build, plan.states[k], pure=False, retries=self.retries)
            else:
                # hash=False: a key of its own for each call. With the default content hash, a second
                # call on the same state scatters to the same key while the first call's release of it
                # may still be on its way to the scheduler, which then deletes it ("lost dependencies").
                states[k] = client.scatter(plan.states[k], broadcast=True, hash=False)
        futs = {
            client.submit(plan.step, states[plan.state_index(i)], plan.tasks[i], pure=False, retries=self.retries): i
            for i in todo
        }
        try:
            for fut in distributed.as_completed(list(futs)):
                done(futs[fut], result_of(fut, f"{plan.name} {futs[fut]}"))
        finally:
            client.cancel(list(futs) + list(states.values()))


def result_of(fut: Any, what: str) -> Any:
    """A Dask future's result; a failure other than the project's own errors as a :class:`ClusterError`."""
    try:
        return fut.result()
    except SensorselError:
        raise
    except Exception as exc:
        raise ClusterError(f"{what} failed on the cluster ({type(exc).__name__}: {exc})") from None
