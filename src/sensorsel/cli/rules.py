"""The ``--rule`` option (a greedy rule or strategy of :data:`sensorsel.designs.selection.RULES`) and
``--rules`` (several of them)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import click

from sensorsel.api import RULES, check_rule, rules_help
from sensorsel.errors import InputError


class RuleType(click.ParamType):
    """A name of :data:`RULES`, validated by :func:`check_rule` (the one check of rule names)."""

    name = "RULE"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> str:
        try:
            return check_rule(value)
        except InputError as exc:
            self.fail(str(exc), param, ctx)

    def get_metavar(self, param: click.Parameter, *args: Any, **kwargs: Any) -> str:
        return "[" + "|".join(RULES) + "]"


def rule_option(default: str, help: str = "") -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """``--rule RULE`` (passed as ``rule=``)."""
    return click.option(
        "--rule", type=RuleType(), default=default, show_default=True, help=(help + " " if help else "") + rules_help()
    )


def rules_option(default: str) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """``--rules R1,R2`` (passed as ``rules=``, unparsed)."""
    return click.option(
        "--rules",
        default=default,
        show_default=True,
        metavar="RULES",
        help=f"Comma-separated rules among {', '.join(RULES)}.",
    )


def kept_label(rule: str, winning_rule: str) -> str:
    """``best-of (kept the marginal run)`` for a strategy, else the rule."""
    return rule if winning_rule == rule else f"{rule} (kept the {winning_rule} run)"
