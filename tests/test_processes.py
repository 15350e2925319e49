"""A domain's routes on worker processes of this machine (what ``--jobs N`` runs on a domain), and the
plan executor on worker processes: the bytes of one thread, one message per process and round, a lost
process rebuilt, a worker's own error raised once (not retried), the processes stopped.
"""

from __future__ import annotations

import os
import signal

import numpy as np
import pytest
from domains import four_routes, untimed

from sensorsel.api import design_domain, with_suite_quality
from sensorsel.errors import InputError, SensorselError
from sensorsel.information.evaluators import DomainEvaluator, evaluator_for
from sensorsel.information.evaluators.processes import (
    PROCESSES_FROM_KEYFRAMES,
    ProcessDomainEvaluator,
    _WorkerError,
    on_processes,
)
from sensorsel.model.problem import load_domain
from sensorsel.pipeline import ClusterError, InProcess, LocalProcesses, Plan, execute


@pytest.fixture(scope="module")
def domain(tmp_path_factory):
    return load_domain(four_routes(tmp_path_factory.mktemp("four"), 1.0))


@pytest.fixture(scope="module")
def dense(tmp_path_factory):
    """The same four routes at 10 keyframes a second: enough keyframes for worker processes."""
    return load_domain(four_routes(tmp_path_factory.mktemp("dense"), 10.0))


def test_greedy_on_processes_is_the_one_thread_bytes_and_jobs_choose_it(domain):
    here = design_domain(domain, 12_000, evaluator=DomainEvaluator(domain))
    for n in (1, 2, 3):
        with ProcessDomainEvaluator(domain, processes=n) as ev:
            assert len(ev._workers()) == n
            got = design_domain(domain, 12_000, evaluator=ev)
        assert untimed(got) == untimed(here)


def test_jobs_choose_processes_from_the_keyframes_of_the_domain(domain, dense):
    def keyframes(d):
        return sum(r.problem.scenario.n_poses for r in d.routes)

    assert keyframes(domain) < PROCESSES_FROM_KEYFRAMES <= keyframes(dense)  # 83 and 794
    assert type(evaluator_for(domain, jobs=2)) is DomainEvaluator  # too small to pay for processes
    assert type(evaluator_for(dense, jobs=1)) is DomainEvaluator
    ev = evaluator_for(dense, jobs=2)
    assert isinstance(ev, ProcessDomainEvaluator)
    ev.close()
    assert on_processes(dense, 2) and not on_processes(dense, 1) and not on_processes(domain, 2)


def test_a_round_is_one_message_per_process_and_scores_are_the_in_process_bytes(domain):
    here = DomainEvaluator(domain)
    with ProcessDomainEvaluator(domain, processes=2) as ev:
        base, n = (0,), len(domain.library)
        for cand in ([1, 2, 3], list(range(1, n))):
            m0, r0 = ev.n_messages, ev.n_rounds
            got = ev.scores_with(base, cand)
            assert ev.n_rounds - r0 == 1 and ev.n_messages - m0 == 2  # two processes, not four routes
            np.testing.assert_array_equal(got, here.scores_with(base, cand))
        np.testing.assert_array_equal(ev.best, here.best)


def test_a_killed_process_has_its_routes_rebuilt_with_the_same_bytes(domain):
    here = DomainEvaluator(domain).scores_with((0,), [1, 2])
    with ProcessDomainEvaluator(domain, processes=2) as ev:
        victim = ev._processes[0].process
        os.kill(victim.pid, signal.SIGKILL)
        victim.join(timeout=10)
        np.testing.assert_array_equal(ev.scores_with((0,), [1, 2]), here)
        assert ev.n_rebuilt >= 1
        assert len(ev._workers()) == 1  # the survivor now holds every route


def test_a_workers_own_error_is_raised_once_not_retried_as_a_lost_process(domain):
    with ProcessDomainEvaluator(domain, processes=2) as ev:
        with pytest.raises(_WorkerError, match="AttributeError"):
            ev._call({0: ("no_such_method", ())})
        assert ev.n_rebuilt == 0
        # the user's error found on a worker is the user's error, as in this process
        with pytest.raises(SensorselError):
            ev._call({1: ("score", ((999,),))})
        assert ev.n_rebuilt == 0


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_ctrl_c_or_sigterm_to_the_process_group_leaves_the_workers_to_the_evaluator(domain, sig):
    """A terminal's Ctrl-C and a batch system's SIGTERM reach every process of the group: the workers
    ignore both, so the evaluator's process (which handles both as an interrupt) still has them for
    its last requests, and stops them itself."""
    here = DomainEvaluator(domain).scores_with((0,), [1, 2])
    with ProcessDomainEvaluator(domain, processes=2) as ev:
        for w in ev._processes:
            os.kill(w.process.pid, sig)
        np.testing.assert_array_equal(ev.scores_with((0,), [1, 2]), here)
        assert ev.n_rebuilt == 0 and all(w.process.is_alive() for w in ev._processes)


def test_close_stops_every_process(domain):
    ev = ProcessDomainEvaluator(domain, processes=2)
    procs = [w.process for w in ev._processes]
    assert all(p.is_alive() for p in procs)
    ev.close()
    assert not any(p.is_alive() for p in procs)


def _square_plus(state: int, task: int) -> int:
    if task < 0:
        raise InputError(f"task {task}: negative")
    return state * state + task


def test_the_plan_executor_on_processes_gives_the_in_process_results_in_task_order():
    plan = Plan("number", _square_plus, [1, 2, 3, 4, 5], states=[10, 20, 30], state_of=[0, 0, 1, 2, 2])
    want = execute(plan, InProcess())
    assert execute(plan, LocalProcesses(2)) == want == [101, 102, 403, 904, 905]
    bad = Plan("number", _square_plus, [1, -1], states=[1, 2], state_of=[0, 1])
    with pytest.raises(InputError, match="task -1: negative"):
        execute(bad, LocalProcesses(2))


def _where(state: int, task: int) -> tuple[int, int, int]:
    return state, task, os.getpid()


def test_one_state_that_travels_as_it_is_is_cut_into_parts_across_the_processes():
    """A plan of one state and no recipe (a simulation's draws on one payload) runs on every worker
    process, in parts, each task on its own state, the results in task order."""
    from sensorsel.pipeline.executors import PARTS_PER_JOB

    n = 3 * 2 * PARTS_PER_JOB
    got = execute(Plan("draw", _where, list(range(n)), states=[7]), LocalProcesses(2))
    assert [(s, t) for s, t, _ in got] == [(7, t) for t in range(n)]
    assert len({pid for _, _, pid in got}) == 2 and os.getpid() not in {pid for _, _, pid in got}
    # a state with a recipe (dear to build) stays one job: built once (one job runs here, no process)
    built = execute(Plan("draw", _where, list(range(n)), states=[7], build=int), LocalProcesses(2))
    assert len({pid for _, _, pid in built}) == 1


def _die(state: int, task: int) -> int:
    os._exit(3)  # a worker killed mid-task (out of memory, a signal)


def test_a_plan_worker_that_dies_is_one_error_naming_the_tasks():
    plan = Plan("number", _die, [1, 2], states=[1, 2], state_of=[0, 1])
    with pytest.raises(ClusterError, match="a worker process running the numbers died"):
        execute(plan, LocalProcesses(2))


def test_suite_quality_on_processes_is_the_in_process_bytes(domain, dense):
    res = design_domain(domain, 12_000, evaluator=DomainEvaluator(domain)).greedy  # a suite to judge
    one = with_suite_quality(res, dense, jobs=1)
    two = with_suite_quality(res, dense, jobs=2)
    assert untimed(two) == untimed(one)
    assert len(one.accuracy) == len(dense.routes) and len(one.integrity) == len(dense.routes)
    assert one.accuracy[0].n_keyframes == dense.routes[0].problem.scenario.n_poses
