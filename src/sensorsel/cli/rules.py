"""The ``--rule`` option (a greedy rule or strategy of :data:`sensorsel.designs.selection.RULES`) and its
hidden, deprecated alias ``--objective``; and ``--rules`` with its alias ``--selectors``."""

from __future__ import annotations

import functools
from typing import Any, Callable

import click
from click.core import ParameterSource

from sensorsel.designs.selection import RULES, check_rule, rules_help
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


def _deprecated_alias(new: str, old: str, old_value: Any, new_value: Any) -> Any:
    """The value of ``new``, or of its deprecated alias ``old`` when only that was given (a note on stderr)."""
    if old_value is None:
        return new_value
    source = click.get_current_context().get_parameter_source(new.lstrip("-"))
    if source not in (None, ParameterSource.DEFAULT):
        raise click.UsageError(f"{old} is a deprecated alias of {new}; give only {new}")
    click.echo(f"sensorsel: {old} is deprecated; use {new}", err=True)
    return old_value


def rule_option(default: str, help: str = "") -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """``--rule RULE`` (passed as ``rule=``), with ``--objective`` as a hidden deprecated alias."""

    def decorate(fn: Callable[..., Any]) -> Callable[..., Any]:
        @functools.wraps(fn)
        def wrapper(*args: Any, rule: str, objective: str | None, **kw: Any) -> Any:
            return fn(*args, rule=_deprecated_alias("--rule", "--objective", objective, rule), **kw)

        wrapper = click.option("--objective", type=RuleType(), default=None, hidden=True,
                               help="Deprecated alias of --rule.")(wrapper)
        return click.option("--rule", type=RuleType(), default=default, show_default=True,
                            help=(help + " " if help else "") + rules_help())(wrapper)

    return decorate


def rules_option(default: str) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """``--rules R1,R2`` (passed as ``rules=``, unparsed), with ``--selectors`` as a hidden deprecated alias."""

    def decorate(fn: Callable[..., Any]) -> Callable[..., Any]:
        @functools.wraps(fn)
        def wrapper(*args: Any, rules: str, selectors: str | None, **kw: Any) -> Any:
            return fn(*args, rules=_deprecated_alias("--rules", "--selectors", selectors, rules), **kw)

        wrapper = click.option("--selectors", default=None, hidden=True, help="Deprecated alias of --rules.")(wrapper)
        return click.option("--rules", default=default, show_default=True,
                            help=f"Comma-separated rules among {', '.join(RULES)}.")(wrapper)

    return decorate


def kept_label(rule: str, winning_rule: str) -> str:
    """``best-of (kept the marginal run)`` for a strategy, else the rule."""
    return rule if winning_rule == rule else f"{rule} (kept the {winning_rule} run)"
