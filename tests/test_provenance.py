"""Results describe the problem they were computed on; suites are accepted however they are given."""

from __future__ import annotations

import numpy as np
import pytest

from sensorsel import InputError, ScenarioSpec, load_problem, score_suite
from sensorsel.api import run_greedy


@pytest.fixture(scope="module")
def tiny():
    return load_problem(ScenarioSpec(fixture="tiny"))


def test_result_records_the_spec_the_problem_was_loaded_from(tiny):
    # the bug this guards: run functions defaulted spec=ScenarioSpec() and recorded "suburb"
    res = run_greedy(tiny, 5000, "uniform", engine="reference")
    assert res.problem is not None
    assert res.problem.scenario == "tiny"
    assert res.problem.spec is not None and res.problem.spec.fixture == "tiny"


def test_a_result_suite_scores_as_ids_positions_or_text(tiny):
    res = run_greedy(tiny, 5000, "uniform", engine="reference")
    assert res.suite
    lib = tiny.library
    positions = [lib.position(s) for s in res.suite]
    by_ids = score_suite(tiny, res.suite, engine="reference").score
    by_text = score_suite(tiny, ",".join(res.suite), engine="reference").score
    by_pos = score_suite(tiny, np.asarray(positions, dtype=np.int64), engine="reference").score
    assert by_ids == by_text == by_pos == pytest.approx(res.score, rel=1e-12)


@pytest.mark.parametrize(
    "bad, culprit",
    [
        (["LRL-roof", "NOPE-3"], "NOPE-3"),
        ("LRL-roof,,XYZ", "XYZ"),
        ([0, 999], "999"),
        ([-1], "-1"),
        ([True], "True"),
        ([1.5], "1.5"),
    ],
)
def test_unknown_or_malformed_suite_members_are_input_errors(tiny, bad, culprit):
    with pytest.raises(InputError, match=culprit.replace(".", r"\.")):
        score_suite(tiny, bad)


def test_problem_repr_is_short(tiny):
    text = repr(tiny)
    assert len(text) < 200 and "tiny" in text and "62 sensors" in text
    assert len(repr(tiny.library)) < 200
