"""The one registry of greedy rules and strategies (:data:`RULES`) and its one check (:func:`check_rule`)."""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType

from sensorsel.designs.selection.rules import CostBenefit, Marginal, Rule, Uniform
from sensorsel.designs.selection.strategies import BestOf, Strategy
from sensorsel.errors import InputError

#: A registry entry: a single rule or a strategy over single rules.
RuleOrStrategy = Rule | Strategy


def _registry(*entries: RuleOrStrategy) -> Mapping[str, RuleOrStrategy]:
    table: dict[str, RuleOrStrategy] = {}
    for e in entries:
        if not e.name or e.name in table:
            raise ValueError(f"greedy rule registered twice or without a name: {e.name!r}")
        table[e.name] = e
    for e in entries:  # a strategy runs registered single rules
        for c in e.component_rules:
            if not isinstance(table.get(c), Rule):
                raise ValueError(f"{e.name}: component {c!r} is not a registered single rule")
    return MappingProxyType(table)


#: Every greedy rule and strategy by name, in the order shown to users (read-only).
RULES: Mapping[str, RuleOrStrategy] = _registry(Uniform(), CostBenefit(), Marginal(), BestOf())


def check_rule(name: object) -> str:
    """``name`` if it is a registered rule or strategy; else an InputError naming it and the choices."""
    if not isinstance(name, str) or name not in RULES:
        raise InputError(f"unknown rule {name!r}; available: {', '.join(RULES)}")
    return name


def rules_help() -> str:
    """``uniform: f(S+s), ...; best-of: ...``: one clause per registered rule, for ``--help``."""
    return "; ".join(f"{name}: {entry.summary}" for name, entry in RULES.items()) + "."
