"""Coarse work, few messages: a domain on threads and on a real LocalCluster (127.0.0.1, stopped here).

A round of a domain's route calls is one message per worker (each worker's routes answered
together), whatever the number of routes or candidates; what a step sends and receives is suites
and numbers, the same bytes whatever the routes' keyframes; and the answer is the same bytes on 1
and 2 threads in-process and on 1 and 2 workers.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

distributed = pytest.importorskip("distributed")

from domains import four_routes, untimed  # noqa: E402

from sensorsel.api import design_domain  # noqa: E402
from sensorsel.information.evaluators import DomainEvaluator  # noqa: E402
from sensorsel.information.evaluators.distributed import DistributedDomainEvaluator  # noqa: E402
from sensorsel.io import results  # noqa: E402
from sensorsel.model.problem import load_domain  # noqa: E402
from sensorsel.pipeline.cluster import DaskCluster  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
FIXTURES = REPO / "configs" / "domain_fixtures.yaml"


@pytest.fixture(scope="module")
def cluster():
    with DaskCluster(workers=2, echo=lambda line: None) as c:
        yield c


def test_a_round_is_one_message_per_worker_whatever_the_routes_and_candidates(cluster, tmp_path):
    domain = load_domain(four_routes(tmp_path, 1.0))
    ev = DistributedDomainEvaluator(cluster.client, domain)
    here = DomainEvaluator(domain)
    holders = {id(a) for a in ev._actors}
    assert len(domain.routes) == 4 and len(holders) == 2  # four routes, owned by the two workers
    base, n = (0,), len(domain.library)
    for cand in ([1, 2, 3], list(range(1, n))):  # 3 candidates, then every other sensor
        m0, r0 = ev.n_messages, ev.n_rounds
        got = ev.scores_with(base, cand)
        assert ev.n_rounds - r0 == 1
        assert ev.n_messages - m0 == 2  # the workers: not the 4 routes, not routes x candidates
        np.testing.assert_array_equal(got, here.scores_with(base, cand))  # the in-process bytes
    # the lazy greedy's route-by-route rounds: a round asking three routes is still one message per worker
    m0 = ev.n_messages
    ev._ask_members_grouped(base, {0: [4], 1: [5], 2: [6]})
    assert ev.n_messages - m0 == len({id(ev._actors[k]) for k in (0, 1, 2)})


def test_bytes_of_a_step_do_not_grow_with_the_keyframes(cluster, tmp_path):
    sizes, poses = [], []
    for rate in (1.0, 3.0):
        domain = load_domain(four_routes(tmp_path, rate))
        poses.append(sum(r.problem.scenario.n_poses for r in domain.routes))
        ev = DistributedDomainEvaluator(cluster.client, domain)
        ev.scores_with((0, 1), list(range(2, len(domain.library))))
        sizes.append(ev.step_bytes[-1])
    assert poses[1] > 2 * poses[0]  # three times the keyframes
    assert sizes[0] == sizes[1]  # (sent, received): suites and one number per candidate and route
    assert sizes[0][0] < 1_000 and sizes[0][1] < 4 * 60 * 8 + 1_000


def test_domain_design_same_bytes_on_1_and_2_threads_and_1_and_2_workers(cluster):
    domain = load_domain(FIXTURES)
    runs = [design_domain(domain, 12_000, certify=True, jobs=jobs) for jobs in (1, 2)]
    with DaskCluster(workers=1, echo=lambda line: None) as one:
        runs.append(
            design_domain(domain, 12_000, certify=True, evaluator=DistributedDomainEvaluator(one.client, domain))
        )
    runs.append(
        design_domain(domain, 12_000, certify=True, evaluator=DistributedDomainEvaluator(cluster.client, domain))
    )
    first = untimed(runs[0])
    assert all(untimed(r) == first for r in runs[1:])


def test_a_checkpointed_domain_design_on_two_threads_records_the_one_thread_breakdown(tmp_path):
    # the breakdown's routes run in waves of the evaluator's threads, each recorded in route order
    domain = load_domain(FIXTURES)
    one = design_domain(domain, 12_000, certify=True, jobs=1)
    ck = tmp_path / "design.checkpoint"
    from sensorsel.designs.checkpoint import GreedyCheckpoint

    two = design_domain(domain, 12_000, checkpoint=ck, certify=True, jobs=2)
    assert untimed(two) == untimed(one)
    saved = results.load(ck, GreedyCheckpoint)
    assert saved.routes == one.routes  # every route's share, in route order


def _route_counts(ev):
    return [r.n_evaluations for r in ev.routes]


def test_scoring_ahead_on_idle_threads_and_workers_changes_no_byte_and_no_count(cluster, tmp_path):
    # the lazy greedy's rounds of one or two route calls leave threads (workers) idle: they score
    # the queue's next route calls ahead; what is used is read back where one thread computes it
    from sensorsel.designs.selection import greedy

    domain = load_domain(four_routes(tmp_path, 1.0))
    one = DomainEvaluator(domain, jobs=1)
    first = greedy(one, 12_000, lazy=True, info=domain.info)
    assert one.n_ahead == 0  # one thread: nothing is idle
    default = DomainEvaluator(domain, jobs=2)  # by default, too few places to score ahead on
    assert untimed(greedy(default, 12_000, lazy=True, info=domain.info)) == untimed(first) and default.n_ahead == 0
    for ev in (
        DomainEvaluator(domain, jobs=2),
        DomainEvaluator(domain, jobs=3),
        DistributedDomainEvaluator(cluster.client, domain),
    ):
        ev.ahead_from = 2  # score ahead on as few places as there are here
        got = greedy(ev, 12_000, lazy=True, info=domain.info)
        assert untimed(got) == untimed(first)  # picks, scores, every step's numbers and the count of evaluations
        if isinstance(
            ev, DistributedDomainEvaluator
        ):  # its proxies count the greedy's calls alone (not the normalisers)
            assert ev.n_ahead_used and [r.n_evaluations for r in ev.routes] == [n - 2 for n in _route_counts(one)]
        else:
            assert _route_counts(ev) == _route_counts(one)  # each route's evaluations too (robust reads them)
        assert ev.n_ahead > 0 and 0 < ev.n_ahead_used <= ev.n_ahead  # it did score ahead, and used some


def test_what_is_scored_ahead_is_the_route_engines_own_score_of_that_suite(tmp_path):
    # the oracle: a fresh engine of each route, scoring the suite alone
    from sensorsel.designs.selection import greedy
    from sensorsel.information.evaluators import make_evaluator

    seen: dict[tuple[tuple[int, ...], int, int], float] = {}

    class Watching(DomainEvaluator):
        def _answer(self, st, base, groups, hopeful):  # what is kept ahead after each round
            out = super()._answer(st, base, groups, hopeful)
            seen.update({(st.suite, k, c): v for (k, c), v in st.ahead.items()})
            return out

    domain = load_domain(four_routes(tmp_path, 1.0))
    ev = Watching(domain, jobs=2)
    ev.ahead_from = 2
    greedy(ev, 12_000, lazy=True, info=domain.info)
    assert seen
    fresh = {k: make_evaluator(domain.routes[k].problem, ev.engine) for k in {k for _, k, _ in seen}}
    for (suite, k, c), v in sorted(seen.items()):
        assert v == fresh[k].scores_with(suite, [c])[0]  # the bytes the round would get asking it
        assert v == pytest.approx(fresh[k].score(suite + (c,)), rel=1e-12)  # the suite scored whole
