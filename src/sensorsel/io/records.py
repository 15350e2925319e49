"""The small parts result records are made of: a suite and its cost, its score, the budget and failures
designed for, a worst case and the failures attaining it.

A record is a frozen dataclass that inherits the parts it holds, listed last part first: its fields
are the first part's, then the next part's, then its own (``class Candidate(WorstOutcome, Method)``
holds ``method``, then ``suite, cost_usd, nominal_score, worst_score, failures``, then its own). Its
JSON is its fields in that order, so a record composed of parts writes the bytes it would with the
fields written out. Each part documents its fields once; a record's docstring adds only what its own
fields mean. The parts records end with (what a run was computed on, its wall time and limits; the
suite's accuracy and integrity) hold types of the model and the information: they are
:mod:`sensorsel.designs.parts`, written last by :func:`sensorsel.io.codec.last`.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any

__all__ = [
    "AlphaBudget",
    "Budget",
    "Method",
    "MethodWorst",
    "RuleBudget",
    "SuiteCost",
    "SuiteScore",
    "WorstOutcome",
    "part_of",
]


@dataclass(frozen=True)
class SuiteCost:
    """A suite and what it costs.

    Attributes:
        suite: sensor ids (in library order, or in pick order where a record says so).
        cost_usd: its total cost [$].
    """

    suite: tuple[str, ...]
    cost_usd: float


@dataclass(frozen=True)
class SuiteScore(SuiteCost):
    """A suite, its cost and its score.

    Attributes:
        score: f(suite) = log det L(suite) - log det L(empty) [nats] on a route; a domain's combined
            score (a share of the best when normalised) on a domain.
    """

    score: float


@dataclass(frozen=True)
class WorstOutcome(SuiteCost):
    """A suite, its cost, its score with nothing failed and its worst case under failures.

    Attributes:
        nominal_score: f(suite), nothing failed [nats].
        worst_score: its exact worst case, the least f(suite minus the failures) [nats].
        failures: ids of the failure set attaining it (first in library order among ties).
    """

    nominal_score: float
    worst_score: float
    failures: tuple[str, ...]


@dataclass(frozen=True)
class Method:
    """Which method chose a suite.

    Attributes:
        method: the method's name.
    """

    method: str


@dataclass(frozen=True)
class Budget:
    """What a suite could cost.

    Attributes:
        budget_usd: the budget [$].
    """

    budget_usd: float


@dataclass(frozen=True)
class RuleBudget:
    """A greedy rule and its budget.

    Attributes:
        rule: a name of :data:`sensorsel.designs.selection.RULES`.
        budget_usd: the budget [$].
    """

    rule: str
    budget_usd: float


@dataclass(frozen=True)
class AlphaBudget:
    """The failures a design is made for, and its budget.

    Attributes:
        alpha: how many of the bought sensors may fail.
        budget_usd: the budget [$].
    """

    alpha: int
    budget_usd: float


@dataclass(frozen=True)
class MethodWorst(WorstOutcome, Method):
    """The suite a method chose, its cost, its score with nothing failed and its worst case: ``method``,
    then :class:`WorstOutcome`'s fields."""


def part_of(record: Any, part: type[Any]) -> dict[str, Any]:
    """``record``'s values of the fields of ``part`` (a part above, or a record made of parts), by
    name: what another record holding the same part is built with, ``Other(**part_of(r, MethodWorst), ...)``."""
    return {f.name: getattr(record, f.name) for f in fields(part)}
