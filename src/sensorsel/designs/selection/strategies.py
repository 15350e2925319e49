"""Greedy strategies: rules made of other rules' runs.

``best-of``  runs ``uniform`` and ``marginal`` and keeps the better suite. For a monotone
             submodular f under a budget this carries the known constant-factor guarantee
             f >= (1 - 1/e)/2 * f(OPT) (Leskovec et al. 2007), which neither rule has alone.

A strategy names its ``component_rules``; whoever runs it (greedy, the tradespace, the exact search)
runs those and asks the strategy which run to :meth:`Strategy.keep`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import replace
from typing import ClassVar

from sensorsel.designs.selection.records import GreedyResult
from sensorsel.designs.selection.rules import REL_TOL
from sensorsel.model.problem import TargetInfo


class Strategy(ABC):
    """A rule made of the runs of other rules (``component_rules``), of which it keeps one.

    Attributes:
        name: the strategy's name in :data:`sensorsel.designs.selection.RULES`.
        summary: one line for ``--help``.
        component_rules: names of the rules it runs, in the order they run.
    """

    name: ClassVar[str] = ""
    summary: ClassVar[str] = ""
    component_rules: ClassVar[tuple[str, ...]] = ()
    lazy_ok: ClassVar[bool] = True

    @abstractmethod
    def keep(self, runs: Sequence[GreedyResult]) -> GreedyResult:
        """The run kept among the component runs (same order as ``component_rules``)."""

    def combine(self, runs: Sequence[GreedyResult], *, info: TargetInfo | None, seconds: float) -> GreedyResult:
        """The strategy's result: the kept run, named after the strategy, counting every run's evaluations."""
        best = self.keep(runs)
        return replace(
            best, rule=self.name, n_evaluations=sum(r.n_evaluations for r in runs), problem=info, seconds=seconds
        )


class BestOf(Strategy):
    """The better of the uniform and marginal runs (constant-factor guarantee under a budget)."""

    name = "best-of"
    summary = "the better of uniform and marginal"
    component_rules = ("uniform", "marginal")

    def keep(self, runs: Sequence[GreedyResult]) -> GreedyResult:
        return better_run(runs)


def better_run(runs: Sequence[GreedyResult]) -> GreedyResult:
    """The run best-of keeps: the higher score; scores within a relative :data:`REL_TOL` are tied,
    and a tie goes to the cheaper suite, then to the earlier run (uniform before marginal)."""
    best = runs[0]
    for r in runs[1:]:
        tol = REL_TOL * max(1.0, abs(best.score), abs(r.score))
        if r.score > best.score + tol or (abs(r.score - best.score) <= tol and r.cost_usd < best.cost_usd):
            best = r
    return best
