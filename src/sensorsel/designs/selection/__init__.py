"""Greedy sensor selection under a cost budget: rules and strategies in one registry, one engine.

    from sensorsel.designs.selection import RULES, greedy
    res = greedy(evaluator, 110_000, "best-of")      # GreedyResult; res.winning_rule: the run best-of kept

Modules: :mod:`.rules` (uniform, cost-benefit, marginal: the objective J), :mod:`.strategies`
(best-of: the better of uniform and marginal), :mod:`.registry` (:data:`RULES`, :func:`check_rule`),
:mod:`.greedy` (the engine, lazy evaluation, :func:`check_budget`, :func:`check_affordable`: what to do
when nothing fits), :mod:`.records` (:class:`Step`,
:class:`GreedyResult`). This package builds on the evaluators only; certificates and the run
functions that make evaluators live above it (:mod:`sensorsel.designs.certify`, :mod:`sensorsel.api`).
"""

from __future__ import annotations

from sensorsel.designs.selection.greedy import LAZY_BATCH, Selector, check_affordable, check_budget, greedy
from sensorsel.designs.selection.records import GreedyResult, Step
from sensorsel.designs.selection.registry import RULES, RuleOrStrategy, check_rule, rules_help
from sensorsel.designs.selection.rules import REL_TOL, CostBenefit, Marginal, Rule, Uniform
from sensorsel.designs.selection.strategies import BestOf, Strategy, better_run
from sensorsel.io.progress import Progress

__all__ = [
    "LAZY_BATCH",
    "REL_TOL",
    "RULES",
    "BestOf",
    "CostBenefit",
    "GreedyResult",
    "Marginal",
    "Progress",
    "Rule",
    "RuleOrStrategy",
    "Selector",
    "Step",
    "Strategy",
    "Uniform",
    "better_run",
    "check_affordable",
    "check_budget",
    "check_rule",
    "greedy",
    "rules_help",
]
