"""The public API: every run function importable from ``sensorsel``, and the documented examples run."""

from __future__ import annotations

import doctest

import sensorsel
import sensorsel.api
import sensorsel.information.evaluators.domain


def test_every_run_function_is_importable_from_sensorsel():
    for name in ("score_suite", "run_greedy", "run_tradespace", "resilient_report", "certify_result", "run_optimal",
                 "simulate", "design_domain", "score_domain_suite", "load_problem", "load_domain"):
        assert callable(getattr(sensorsel, name)), name
    assert set(sensorsel.__all__) <= set(dir(sensorsel))


def test_the_documented_examples_run():
    for module in (sensorsel.api,):
        failed, attempted = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
        assert attempted > 0 and failed == 0, module.__name__
