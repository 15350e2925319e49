"""How a design run scores suites and reports its progress: the keywords every run function takes,
declared once (:class:`RunOptions`) and passed through as one value.

The public run functions (:mod:`sensorsel.api`) take them as keywords (``engine=``, ``jobs=``,
``aggregate=``, ``lazy=``, ``constraints=``, ``progress=``: :class:`RunKeywords`, checked by mypy) and
hand one :class:`RunOptions` to the design below; a run that takes more (a greedy run's certificate and
checkpoint, a resilient run's periods) takes its own keywords beside them (:meth:`RunOptions.split`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import Any, TypedDict, overload

from sensorsel.information.evaluators import DomainEvaluator, Evaluator, evaluator_for
from sensorsel.io.progress import Progress
from sensorsel.model.constraints import Constraints
from sensorsel.model.problem import Domain, Target

__all__ = ["RunKeywords", "RunOptions", "ScoringKeywords"]


@dataclass(frozen=True)
class RunOptions:
    """The options every design run shares.

    Attributes:
        engine: the log det engine of each route (:data:`sensorsel.information.evaluators.ENGINES`;
            None: the default).
        jobs: threads an evaluator may use (the answer does not depend on it).
        aggregate: how a domain combines its routes' scores ("normalised" or "raw"; on one route any
            aggregate picks the same suites, but a typo is still refused).
        lazy: lazy (Minoux) evaluation in greedy runs (the same picks, fewer suites scored).
        constraints: limits besides the budget (:mod:`sensorsel.model.constraints`; None: the budget
            alone).
        progress: called with ``(done, total)`` as the run's main loop goes (picks, rules, periods).
    """

    engine: str | None = None
    jobs: int = 1
    aggregate: str = "normalised"
    lazy: bool = True
    constraints: Constraints | None = None
    progress: Progress | None = None

    @overload
    def evaluator(self, target: Domain) -> DomainEvaluator: ...

    @overload
    def evaluator(self, target: Target) -> Evaluator: ...

    def evaluator(self, target: Target) -> Evaluator:
        """A fresh evaluator of ``target`` (:func:`~sensorsel.information.evaluators.evaluator_for`:
        a domain's is a :class:`~sensorsel.information.evaluators.DomainEvaluator`)."""
        return evaluator_for(target, self.engine, jobs=self.jobs, aggregate=self.aggregate)

    @classmethod
    def split(cls, keywords: Mapping[str, Any]) -> tuple[RunOptions, dict[str, Any]]:
        """``keywords`` as the run options they name and the rest (a run's own keywords), in order."""
        names = {f.name for f in fields(cls)}
        ours = {k: v for k, v in keywords.items() if k in names}
        return cls(**ours), {k: v for k, v in keywords.items() if k not in names}


class ScoringKeywords(TypedDict, total=False):
    """The evaluator's part of :class:`RunOptions` as keywords (a run that scores but does not
    select, e.g. a certificate): ``engine``, ``jobs``, ``aggregate``."""

    engine: str | None
    jobs: int
    aggregate: str


class RunKeywords(ScoringKeywords, total=False):
    """:class:`RunOptions` as the keywords of a public run function (``**options:
    Unpack[RunKeywords]``); each means what the attribute of that name does, with its default."""

    lazy: bool
    constraints: Constraints | None
    progress: Progress | None
