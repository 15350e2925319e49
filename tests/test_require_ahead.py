"""The smoother's marginals computed ahead on worker processes for one route
(:class:`~sensorsel.information.evaluators.processes.CovariancesAhead`, what ``require``'s greedy
is likely to ask next): the very bits this process computes, a suite computed here where no worker
holds it, a lost worker's suite computed here, and ``require``'s answer the same bytes with them as
without (real worker processes, stopped by the tests)."""

from __future__ import annotations

import os
import signal
import time

import numpy as np
import pytest
from domains import untimed

from sensorsel.designs.requirements import design, preset, require
from sensorsel.designs.requirements.domain_checks import DomainChecks, Here
from sensorsel.errors import InputError
from sensorsel.information.evaluators import processes
from sensorsel.information.evaluators.fast import FastEvaluator
from sensorsel.information.evaluators.processes import CovariancesAhead
from sensorsel.model.constraints import Constraints
from sensorsel.model.recipes import RouteRecipe

SIGMA = 0.05
#: suites of the bundled suburb route (library positions): a LiDAR, radars, cameras
SUITES = ((0,), (0, 5), (1, 7, 20), (2, 14, 30, 44), (1, 3, 9, 27, 50))


@pytest.fixture(scope="module")
def engine(suburb_problem):
    return FastEvaluator(suburb_problem)


@pytest.fixture
def ahead(suburb_problem):
    with CovariancesAhead(RouteRecipe.of("suburb", suburb_problem), "fast", 2, map_sigma_m=SIGMA) as a:
        yield a


def _here(engine):
    calls: list[tuple[int, ...]] = []

    def compute(s: tuple[int, ...]) -> np.ndarray:
        calls.append(s)
        return engine.pose_covariances(s, map_sigma_m=SIGMA, estimate="smoother")

    return compute, calls


def test_the_workers_covariances_are_the_bits_this_process_computes(ahead, engine):
    compute, calls = _here(engine)
    ahead.wait_built()
    mine = SUITES[4]
    for pair in (SUITES[:2], SUITES[2:4]):
        ahead.submit([mine, *pair])  # the first is asked first, here; two idle workers: one of the rest each
        for s in pair:
            got = ahead.take(s, compute)
            own = engine.pose_covariances(s, map_sigma_m=SIGMA, estimate="smoother")
            assert got.shape == own.shape == (engine.problem.scenario.n_poses, 3, 3)
            assert got.tobytes() == own.tobytes()
    assert calls == []  # every one came from a worker
    assert ahead.n_submitted == ahead.n_taken == 4


def test_the_suite_asked_first_is_computed_here_and_the_idle_workers_get_the_next(ahead, engine):
    compute, calls = _here(engine)
    ahead.take(SUITES[0], compute)  # nothing given out yet
    assert calls == [SUITES[0]]
    ahead.wait_built()
    ahead.submit([SUITES[4], SUITES[1], SUITES[2], SUITES[3]])  # SUITES[4] is this process's: 1 and 2 go out
    got = ahead.take(SUITES[4], compute)
    assert calls == [SUITES[0], SUITES[4]]  # here, not waited for from a worker
    assert got.tobytes() == engine.pose_covariances(SUITES[4], map_sigma_m=SIGMA, estimate="smoother").tobytes()
    ahead.take(SUITES[1], compute)
    ahead.take(SUITES[2], compute)
    assert calls == [SUITES[0], SUITES[4]] and ahead.n_taken == 2 and ahead.n_submitted >= 2
    ahead.take(SUITES[0], compute)  # computed before, but the covariances are not kept here
    assert calls == [SUITES[0], SUITES[4], SUITES[0]]


def test_a_lost_worker_is_dropped_and_its_suite_computed_here(suburb_problem, engine):
    compute, calls = _here(engine)
    with CovariancesAhead(RouteRecipe.of("suburb", suburb_problem), "fast", 1, map_sigma_m=SIGMA) as a:
        a.wait_built()
        assert a.workers == 1
        pid = a.pids[0]
        os.kill(pid, signal.SIGKILL)
        deadline = time.monotonic() + 30
        while _alive(pid) and time.monotonic() < deadline:
            time.sleep(0.01)
        a.submit([SUITES[4], SUITES[3]])  # SUITES[3] given to a dead worker (the pipe takes it) or dropped at once
        got = a.take(SUITES[3], compute)
        assert calls == [SUITES[3]] and a.workers == 0
        assert got.tobytes() == engine.pose_covariances(SUITES[3], map_sigma_m=SIGMA, estimate="smoother").tobytes()
        a.submit([SUITES[3], SUITES[4]])  # no worker left: nothing is given out, everything is computed here
        a.take(SUITES[4], compute)
        assert calls == [SUITES[3], SUITES[4]] and a.n_taken == 0


def test_a_worker_that_fails_is_dropped_and_the_suite_computed_here(ahead, engine):
    compute, calls = _here(engine)
    ahead.wait_built()
    bad = (0, 999)  # no such sensor: the worker's engine refuses it, and so does this process's
    ahead.submit([SUITES[4], bad, SUITES[1]])  # the first is this process's: one worker each for the others
    with pytest.raises(InputError, match="999"):
        ahead.take(bad, compute)
    assert calls == [bad] and ahead.workers == 1  # the other worker still serves
    ahead.take(SUITES[1], compute)
    assert calls == [bad] and ahead.n_taken == 1


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


def test_covariances_ahead_serve_one_route_of_this_process(ahead, suburb_problem, tiny_problem):
    engines = [FastEvaluator(suburb_problem), FastEvaluator(tiny_problem)]
    spec = preset("local-streets")
    with pytest.raises(ValueError, match="one route"):
        DomainChecks(Here(engines), ["a", "b"], [spec, spec], SIGMA, ahead=ahead)


def test_require_with_the_greedys_covariances_ahead_is_the_same_bytes(suburb_problem, monkeypatch):
    # the suburb route is below the keyframes from which require starts workers: lowered here
    monkeypatch.setattr(processes, "AHEAD_FROM_KEYFRAMES", 0)
    made: list[CovariancesAhead] = []
    start = design._covariances_ahead

    def kept(*args, **kw):
        got = start(*args, **kw)
        if got is not None:
            made.append(got)
        return got

    monkeypatch.setattr(design, "_covariances_ahead", kept)
    lib = suburb_problem.library
    small = ("LRL-roof", "MRL-roof", "LRR-12", "LRR-6", "MRR-12", "MRR-3", "WSC-12", "WSC-6", "HD2K-12", "HD2K-6")
    kw = dict(map_sigma_m=SIGMA, constraints=Constraints(exclude=tuple(sorted(set(lib.ids) - set(small)))))
    alone = require(suburb_problem, preset("local-streets"), jobs=1, **kw)
    assert made == []
    with_workers = require(suburb_problem, preset("local-streets"), jobs=2, **kw)
    assert len(made) == 1 and made[0].n_taken > 0  # the greedy's covariances did come from the worker
    assert made[0].workers == 0  # stopped with the run
    assert untimed(with_workers) == untimed(alone)
    assert alone.status == "optimal"
