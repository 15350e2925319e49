"""``sensorsel optimal`` resumed: the branch and bound's state is kept every N expanded
nodes, and a search interrupted after a checkpoint goes on from it to the uninterrupted run's answer
(counts included; the suites scored before the checkpoint are not scored again). A checkpoint of
another run (budget, rule, engine, limits, library, map, route) is never read back.

The oracle is the same search run through without a checkpoint (the search is deterministic)."""

from __future__ import annotations

import json

import pytest

from sensorsel.designs.certify import optimal
from sensorsel.designs.certify.resume import OptimalCheckpoint
from sensorsel.information.evaluators import evaluator_for
from sensorsel.io import results
from sensorsel.model.constraints import Constraints
from sensorsel.model.problem import build_problem
from sensorsel.model.scenario import ScenarioSpec, load_scenario
from sensorsel.pipeline.store import CacheWarning

BUDGET, NODES, EVERY = 6_000.0, 60, 15  # a search cut by its node limit, kept 4 times


@pytest.fixture(scope="module")
def problems(library):
    other = library.subset(list(range(len(library) - 1)))
    return {
        "base": build_problem(library, load_scenario(ScenarioSpec(fixture="tiny"))),
        "library": build_problem(other, load_scenario(ScenarioSpec(fixture="tiny"))),
        "map": build_problem(
            library, load_scenario(ScenarioSpec(fixture="tiny", landmarks="synthetic", landmark_seed=3))
        ),
        "route": build_problem(library, load_scenario(ScenarioSpec(fixture="tiny", keyframe_rate_hz=0.5))),
    }


def _answer(res, ignore=("seconds", "n_evaluations")) -> object:
    def rec(o: object) -> object:
        if isinstance(o, dict):
            return {k: rec(v) for k, v in o.items() if k not in ignore}
        return [rec(v) for v in o] if isinstance(o, list) else o

    return rec(json.loads(results.dumps(res)))


class Stop(Exception):
    pass


def _stop_after(n: int):
    def progress(done: int, total: int) -> None:
        if done > n:
            raise Stop  # as a kill would, between two nodes

    return progress


def test_an_interrupted_search_goes_on_from_its_last_checkpoint_to_the_same_answer(problems, tmp_path):
    p = problems["base"]
    whole = optimal(evaluator_for(p, "fast"), BUDGET, max_nodes=NODES, info=p.info)
    assert not whole.proved_optimal and whole.n_nodes == NODES  # the search is cut by the limit, not finished
    ck = tmp_path / "o.json.checkpoint"
    with pytest.raises(Stop):
        optimal(
            evaluator_for(p, "fast"),
            BUDGET,
            max_nodes=NODES,
            info=p.info,
            checkpoint=ck,
            checkpoint_every=EVERY,
            progress=_stop_after(2 * EVERY + 5),
        )
    kept = results.load(ck, OptimalCheckpoint)
    assert kept.nodes == 2 * EVERY and kept.heap  # the last checkpoint before the interruption
    ev = evaluator_for(p, "fast")
    again = optimal(ev, BUDGET, max_nodes=NODES, info=p.info, checkpoint=ck, checkpoint_every=EVERY, resume=True)
    assert _answer(again) == _answer(whole)
    assert abs(again.n_evaluations - whole.n_evaluations) <= 1  # the first nodes' suites counted, not rescored
    assert ev.n_evaluations < whole.n_evaluations - kept.n_evaluations / 2


def test_a_resume_with_more_nodes_goes_on_where_the_limit_stopped(problems, tmp_path):
    p = problems["base"]
    ck = tmp_path / "o.checkpoint"
    optimal(evaluator_for(p, "fast"), BUDGET, max_nodes=NODES // 2, info=p.info, checkpoint=ck, checkpoint_every=EVERY)
    more = optimal(
        evaluator_for(p, "fast"),
        BUDGET,
        max_nodes=NODES,
        info=p.info,
        checkpoint=ck,
        checkpoint_every=EVERY,
        resume=True,
    )
    assert _answer(more) == _answer(optimal(evaluator_for(p, "fast"), BUDGET, max_nodes=NODES, info=p.info))


CHANGES = {
    "budget": dict(budget=5_500.0),
    "rule": dict(rule="uniform"),
    "engine": dict(engine="reference"),
    "limits": dict(constraints=Constraints.of(limits={"power_w": 40.0})),
    "library": {},
    "map": {},
    "route": {},
}


@pytest.mark.parametrize("field", list(CHANGES))
def test_a_checkpoint_of_another_run_is_never_read_back(field, problems, tmp_path):
    base = dict(budget=BUDGET, rule="best-of", engine="fast", constraints=None)
    ck = tmp_path / "o.checkpoint"

    def run(target, budget, rule, engine, constraints, **kw):
        return optimal(
            evaluator_for(target, engine),
            budget,
            max_nodes=12,
            rule=rule,
            info=target.info,
            constraints=constraints,
            checkpoint=ck,
            checkpoint_every=5,
            **kw,
        )

    run(problems["base"], **base)
    assert results.load(ck, OptimalCheckpoint).nodes == 10
    changed = {**base, **CHANGES[field]}
    target = problems.get(field, problems["base"])
    with pytest.warns(CacheWarning, match="not reused"):
        got = run(target, **changed, resume=True)
    fresh = optimal(
        evaluator_for(target, changed["engine"]),
        changed["budget"],
        max_nodes=12,
        rule=changed["rule"],
        info=target.info,
        constraints=changed["constraints"],
    )
    assert _answer(got) == _answer(fresh)
