"""The run options every design run shares, declared once (``designs.options.RunOptions``) and taken by
the public run functions as keywords (``RunKeywords``): each keyword a run takes is a field of what it
builds, and a keyword is sent to the part of the run it names."""

from __future__ import annotations

from dataclasses import fields

import pytest

from sensorsel.designs.greedy_run import GreedyKeywords, GreedyRun
from sensorsel.designs.options import RunKeywords, RunOptions
from sensorsel.designs.resilient import ResilientKeywords, ResilientRun


def _names(cls) -> set[str]:  # type: ignore[no-untyped-def]
    return {f.name for f in fields(cls)}


def test_the_keywords_are_the_fields() -> None:
    """Every field of a run is a keyword of the functions that build it (the budget and the greedy
    rule are their positional arguments), and nothing else is."""
    assert set(RunKeywords.__annotations__) == _names(RunOptions)
    greedy_own = _names(GreedyRun) - {"options", "budget_usd", "rule"}
    assert set(GreedyKeywords.__annotations__) == _names(RunOptions) | greedy_own
    assert set(ResilientKeywords.__annotations__) == _names(RunOptions) | (_names(ResilientRun) - {"options"})


def test_split_sends_each_keyword_to_its_part() -> None:
    run = GreedyRun.of(9_000, "marginal", engine="reference", lazy=False, certify=True, resume=True)
    assert run.options == RunOptions(engine="reference", lazy=False)
    assert (run.budget_usd, run.rule, run.certify, run.resume, run.checkpoint) == (9_000, "marginal", True, True, None)
    res = ResilientRun.of(rule="cost", jobs=2, outdir="out")
    assert res.options == RunOptions(jobs=2) and (res.rule, res.outdir, res.method) == ("cost", "out", "algorithm-2")
    with pytest.raises(TypeError, match="unexpected keyword argument 'budget'"):
        GreedyRun.of(9_000, "uniform", budget=1)  # a misspelt keyword is refused, never dropped


def test_a_run_function_refuses_an_unknown_keyword(tiny_problem) -> None:  # type: ignore[no-untyped-def]
    from sensorsel.api import run_greedy

    with pytest.raises(TypeError, match="lazyness"):
        run_greedy(tiny_problem, 5_000, lazyness=False)  # type: ignore[call-arg]
