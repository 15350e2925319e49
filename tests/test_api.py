"""The public API: every run function importable from ``sensorsel``, and the documented examples run."""

from __future__ import annotations

import doctest

import sensorsel
import sensorsel.api
import sensorsel.information.evaluators.domain


def test_every_run_function_is_importable_from_sensorsel():
    for name in (
        "score_suite",
        "run_greedy",
        "run_tradespace",
        "resilient_report",
        "certify_result",
        "run_optimal",
        "simulate",
        "design_domain",
        "score_domain_suite",
        "load_problem",
        "load_domain",
    ):
        assert callable(getattr(sensorsel, name)), name
    assert set(sensorsel.__all__) <= set(dir(sensorsel))


def test_the_documented_examples_run():
    for module in (sensorsel.api,):
        failed, attempted = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
        assert attempted > 0 and failed == 0, module.__name__


def test_a_given_evaluator_is_the_one_each_run_uses_and_a_resumable_greedy_refuses_one(tmp_path):
    """The CLI passes a cluster's evaluator to run_greedy, run_optimal and certify_result (evaluator=):
    the run must use it (here the reference engine, not the default fast one) and answer as a fresh
    evaluator of that engine does; a resumable greedy builds its own and refuses one."""
    import pytest

    from sensorsel import ScenarioSpec, load_problem
    from sensorsel.api import certify_result, run_greedy, run_optimal
    from sensorsel.information.evaluators import make_evaluator

    problem = load_problem(ScenarioSpec(fixture="tiny"))
    given = run_greedy(problem, 2000, evaluator=make_evaluator(problem, "reference"))
    fresh = run_greedy(problem, 2000, engine="reference")
    assert given.engine == "reference" != run_greedy(problem, 2000).engine
    assert (given.suite, given.score) == (fresh.suite, fresh.score)
    cert = certify_result(problem, given, evaluator=make_evaluator(problem, "reference"))
    assert cert.bound == certify_result(problem, fresh, engine="reference").bound
    opt = run_optimal(problem, 1500, max_nodes=50, evaluator=make_evaluator(problem, "reference"))
    assert opt.engine == "reference" and opt.suite == run_optimal(problem, 1500, max_nodes=50, engine="reference").suite
    with pytest.raises(ValueError, match="checkpoint"):
        run_greedy(
            problem, 2000, evaluator=make_evaluator(problem, "reference"), checkpoint=tmp_path / "greedy.checkpoint"
        )
    assert not (tmp_path / "greedy.checkpoint").exists()
