"""``require`` on a domain with each route's checks beside the route
(:mod:`sensorsel.designs.requirements.domain_checks`): the cheapest suite by enumeration, the same
bytes on one thread, two threads and worker processes, a lost worker's routes answering as before,
and nothing left where the routes live."""

from __future__ import annotations

import itertools
import os
import signal
from pathlib import Path

import pytest
from domains import four_routes, untimed
from test_require import SMALL

from sensorsel.designs.requirements import preset, require
from sensorsel.designs.requirements.domain_checks import DomainChecks, Here
from sensorsel.designs.requirements.spec import covariance_verdict
from sensorsel.information.evaluators import DomainEvaluator
from sensorsel.information.evaluators.fast import FastEvaluator
from sensorsel.information.evaluators.processes import ProcessDomainEvaluator
from sensorsel.information.filtering import forward_pass
from sensorsel.model.constraints import Constraints
from sensorsel.model.problem import load_domain


@pytest.fixture(scope="module")
def domain(tmp_path_factory):
    return load_domain(four_routes(tmp_path_factory.mktemp("four"), 1.0))


def _small(domain) -> Constraints:
    return Constraints(exclude=tuple(sorted(set(domain.library.ids) - set(SMALL))))


def _cheapest_by_enumeration(domain, spec, failures: int) -> float:
    """The cost of the cheapest suite of SMALL whose every suite after ``failures`` failures meets
    ``spec`` on every route by its own whole filter pass (suites in order of cost)."""
    lib = domain.library
    pos = [lib.position(i) for i in SMALL]
    price = {p: lib.sensors[p].cost_usd for p in pos}
    memo: dict[tuple[int, ...], bool] = {}

    def meets(s: tuple[int, ...]) -> bool:
        if s not in memo:
            memo[s] = all(
                covariance_verdict(forward_pass(r.problem, s, map_sigma_m=0.05).filtered, spec)[0]
                for r in domain.routes
            )
        return memo[s]

    suites = [tuple(sorted(c)) for k in range(len(pos) + 1) for c in itertools.combinations(pos, k)]
    for s in sorted(suites, key=lambda s: (sum(price[p] for p in s), s)):
        if len(s) > failures and all(
            meets(tuple(x for x in s if x not in f)) for f in itertools.combinations(s, failures)
        ):
            return float(sum(price[p] for p in s))
    raise AssertionError("no suite of SMALL meets the specification")


@pytest.mark.parametrize("failures", [0, 1])
def test_the_cheapest_suite_on_a_domain_is_the_enumerations_and_the_same_bytes_wherever_the_routes_live(
    domain, failures
):
    spec = preset("freeway")
    kw = {"map_sigma_m": 0.05, "constraints": _small(domain), "failures": failures}
    here = require(domain, spec, evaluator=DomainEvaluator(domain), **kw)
    assert here.status == "optimal"
    assert here.cost_usd == _cheapest_by_enumeration(domain, spec, failures)
    assert untimed(require(domain, spec, evaluator=DomainEvaluator(domain, jobs=2), **kw)) == untimed(here)
    assert untimed(require(domain, spec, jobs=1, **kw)) == untimed(here)
    for n in (1, 2):
        with ProcessDomainEvaluator(domain, processes=n) as ev:
            assert untimed(require(domain, spec, evaluator=ev, **kw)) == untimed(here)
            # nothing of the run is left beside the routes
            assert ev.apply_routes(_kept, {k: () for k in range(len(domain.routes))}) == dict.fromkeys(range(4), 0)


def _kept(engine) -> int:
    return len(engine.kept)


def test_a_lost_worker_process_reopens_its_routes_checks_with_the_answers_so_far(domain):
    """A worker process killed between two questions: its routes are rebuilt on the other, without
    their checks; the next question opens them again from every answer found so far, and every
    answer stays each route's own (those of the checks held in this process)."""
    spec = preset("freeway")
    lib = domain.library
    suites = [
        tuple(sorted(lib.position(i) for i in ids))
        for ids in (
            ("HD2K-3",),
            ("LRR-6", "HD2K-3"),
            ("LRR-6", "HD2K-3", "HD2K-6"),
            ("MRL-roof",),
            ("LRL-roof", "WSC-12"),
        )
    ]
    names = [r.name for r in domain.routes]
    mine = DomainChecks(Here([FastEvaluator(r.problem) for r in domain.routes]), names, [spec] * 4, 0.05, "filter")
    with ProcessDomainEvaluator(domain, processes=2) as ev:
        theirs = DomainChecks(ev, names, [spec] * 4, 0.05, "filter")
        for k, s in enumerate(suites):
            if k == 2:
                victim = ev._processes[0].process
                os.kill(victim.pid, signal.SIGKILL)
                victim.join(timeout=10)
            assert theirs.meets(s) == mine.meets(s)
            assert theirs.violation(s) == mine.violation(s)
        assert ev.n_rebuilt >= 1
        assert theirs.answers() == mine.answers()
        theirs.close()


def test_ctrl_c_stops_require_on_worker_processes_at_once(tmp_path):
    """Ctrl-C (SIGINT to the process group) during ``require --domain --jobs 2`` on worker processes:
    exit 130 with one line, promptly, though a round of the routes' checks may be on its way."""
    import subprocess
    import sys
    import time

    dense = four_routes(tmp_path, 10.0)  # 794 keyframes: the routes go to worker processes
    cli = str(Path(sys.executable).parent / "sensorsel")
    args = [cli, "require", "--domain", str(dense), "--preset", "local-streets"]
    p = subprocess.Popen(
        [*args, "--jobs", "2", "-o", str(tmp_path / "r.json")],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        start_new_session=True,
        # as from a terminal: a test run started in the background (no job control) ignores SIGINT,
        # and its children would inherit that
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    time.sleep(8)  # the processes built, the search under way
    assert p.poll() is None, p.communicate()[1].decode()
    os.killpg(p.pid, signal.SIGINT)
    t0 = time.monotonic()
    _, err = p.communicate(timeout=60)
    assert p.returncode == 130, err.decode()
    assert err.decode().strip().splitlines()[-1] == "sensorsel: interrupted"
    assert time.monotonic() - t0 < 10
    assert (tmp_path / "r.json.checkpoint").is_file()  # what was learnt is kept for --resume


def test_a_domain_run_interrupted_on_processes_resumes_there_to_the_same_answer(domain, tmp_path):
    """The journal of a domain run on worker processes holds every route's answers; resumed on
    processes, each route's checks open with their own and the answer is the uninterrupted one's,
    with fewer computations."""
    from test_require import _Interrupt, _stop_after

    from sensorsel.io import results

    spec = preset("freeway")
    kw = {"map_sigma_m": 0.05, "constraints": _small(domain), "failures": 1}
    want = require(domain, spec, evaluator=DomainEvaluator(domain), **kw)
    ck = tmp_path / "r.json.checkpoint"
    with ProcessDomainEvaluator(domain, processes=2) as ev:
        with pytest.raises(_Interrupt):
            require(domain, spec, evaluator=ev, checkpoint=ck, progress=_stop_after(1), **kw)
    journal = results.load(ck, "requirement-journal")
    assert {r for r, *_ in journal.answers} == set(range(len(domain.routes)))  # every route's answers
    with ProcessDomainEvaluator(domain, processes=2) as ev:
        got = require(domain, spec, evaluator=ev, checkpoint=ck, resume=True, **kw)
    assert (got.status, got.suite, got.cost_usd, got.lower_bound_usd) == (
        want.status,
        want.suite,
        want.cost_usd,
        want.lower_bound_usd,
    )
    assert got.n_checks + got.n_refuted < want.n_checks + want.n_refuted
    assert got.n_resumed == len(journal.answers)
