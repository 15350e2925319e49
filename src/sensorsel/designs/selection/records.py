"""What a greedy run produces: the suite after each pick (:class:`Step`) and the run (:class:`GreedyResult`)."""

from __future__ import annotations

from dataclasses import dataclass

from sensorsel.designs.parts import Provenance, SuiteQuality
from sensorsel.io.records import RuleBudget, SuiteScore
from sensorsel.io.results import result_kind

#: progress(done, total): called after each pick; total is an upper bound on the number of picks.


@dataclass(frozen=True)
class Step:
    """One intermediate architecture of a greedy run: the suite right after a pick.

    Attributes:
        pick: id of the sensor bought at this step.
        index: its paper index.
        sensor_cost_usd: its cost [$].
        suite: ids of the whole suite after the pick, in pick order.
        cost_usd: cost of the suite [$].
        score: f(suite) [nats].
        gain: f(suite) - f(suite before the pick) [nats].
        rule_value: J of the pick under the run's rule.
    """

    pick: str
    index: int
    sensor_cost_usd: float
    suite: tuple[str, ...]
    cost_usd: float
    score: float
    gain: float
    rule_value: float


@result_kind("greedy", read=False)  # a run without its certificate: a "greedy" file, certificate null
@dataclass(frozen=True)
class GreedyResult(SuiteQuality, Provenance, SuiteScore, RuleBudget):
    """A greedy run: the rule that ran and its budget, the chosen suite (in pick order), its cost
    (never above the budget) and score, and every intermediate architecture, what it was computed on,
    in how long, within which limits (:class:`~sensorsel.designs.parts.Provenance`), and the suite's
    accuracy and integrity (:class:`~sensorsel.designs.parts.SuiteQuality`).

    Attributes:
        steps: the suite after each pick.
        stop_reason: why selection stopped.
        n_evaluations: suites scored.
        engine: the evaluator used.
        lazy: whether lazy (Minoux) evaluation was used.
        winning_rule: the single rule whose run this is: for a strategy (best-of), the component run
            it kept; else ``rule`` itself.
    """

    steps: tuple[Step, ...]
    stop_reason: str
    n_evaluations: int
    engine: str
    lazy: bool
    winning_rule: str

    @property
    def rule_label(self) -> str:
        """``rule``, or ``"best-of (marginal)"`` when a strategy kept one of its component runs."""
        return self.rule if self.winning_rule == self.rule else f"{self.rule} ({self.winning_rule})"
