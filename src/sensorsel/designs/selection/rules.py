"""Greedy rules: the objective J a greedy step maximizes over the affordable candidates s.

f is the score, f(S) = log det L(S) - log det L(empty) [nats]; costs in $.

``uniform``       J = f(S + s). The paper's Algorithm 1.
``cost-benefit``  J = f(S + s) / Cost(S + s). As the paper's Section V writes it: performance per
                  dollar of the whole suite. Not a marginal rule: it favours cheap sensors once S
                  is good, which is what spreads its architectures over low cost levels.
``marginal``      J = (f(S + s) - f(S)) / cost(s). The classic cost-benefit rule for budgeted
                  submodular maximization (Krause & Guestrin 2005; Leskovec et al. 2007).

Strategies that combine several rules' runs (best-of) are in :mod:`.strategies`; both kinds share
one registry, :data:`sensorsel.designs.selection.RULES`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from typing import ClassVar

import numpy as np

from sensorsel.designs.selection.records import GreedyResult

#: Relative tolerance under which two objective values are tied, and a gain counts as zero.
REL_TOL = 1e-9


class Rule(ABC):
    """One greedy rule: J for each candidate, from f(S + s), f(S), Cost(S) and cost(s).

    Attributes:
        name: the rule's name in :data:`sensorsel.designs.selection.RULES`.
        summary: one line for ``--help``.
        lazy_ok: True when J is a gain (or a gain scaled by a constant per candidate), so that a
            candidate's last J is an upper bound on its J later (lazy evaluation is exact).
    """

    name: ClassVar[str] = ""
    summary: ClassVar[str] = ""
    lazy_ok: ClassVar[bool] = False

    @property
    def component_rules(self) -> tuple[str, ...]:
        """The single rules whose runs make this one's result: itself."""
        return (self.name,)

    def keep(self, runs: Sequence[GreedyResult]) -> GreedyResult:
        """The run of this rule among its (one) component runs."""
        (run,) = runs
        return run

    @abstractmethod
    def value(self, f_new: np.ndarray, f_old: float, suite_cost: float, cand_cost: np.ndarray) -> np.ndarray:
        """J for each candidate given f(S + s) [nats], f(S) [nats], Cost(S) [$] and cost(s) [$]."""

    def needed(self, j: float, f_old: float, suite_cost: float, cand_cost: np.ndarray) -> np.ndarray:
        """The least f(S + s) [nats] at which each candidate's J reaches ``j``, shape (len(cand_cost),)
        (J grows with f(S + s)); −inf (no saving) unless the rule says (the lazy rules do)."""
        return np.full(len(cand_cost), -np.inf)


class Uniform(Rule):
    """J = f(S + s): the most informative affordable sensor (the paper's Algorithm 1)."""

    name = "uniform"
    summary = "f(S+s), the paper's Algorithm 1"
    lazy_ok = True

    def value(self, f_new: np.ndarray, f_old: float, suite_cost: float, cand_cost: np.ndarray) -> np.ndarray:
        return np.asarray(f_new, dtype=float)

    def needed(self, j: float, f_old: float, suite_cost: float, cand_cost: np.ndarray) -> np.ndarray:
        return np.full(len(cand_cost), float(j))


class CostBenefit(Rule):
    """J = f(S + s) / Cost(S + s): the paper's cost-benefit rule (performance per dollar of the suite)."""

    name = "cost-benefit"
    summary = "f(S+s)/Cost(S+s), the paper's cost-benefit rule"

    def value(self, f_new: np.ndarray, f_old: float, suite_cost: float, cand_cost: np.ndarray) -> np.ndarray:
        return np.asarray(f_new, dtype=float) / (suite_cost + np.asarray(cand_cost, dtype=float))


class Marginal(Rule):
    """J = (f(S + s) - f(S)) / cost(s): the classic marginal gain per dollar."""

    name = "marginal"
    summary = "(f(S+s)-f(S))/cost(s), gain per dollar"
    lazy_ok = True

    def value(self, f_new: np.ndarray, f_old: float, suite_cost: float, cand_cost: np.ndarray) -> np.ndarray:
        return (np.asarray(f_new, dtype=float) - f_old) / np.asarray(cand_cost, dtype=float)

    def needed(self, j: float, f_old: float, suite_cost: float, cand_cost: np.ndarray) -> np.ndarray:
        return f_old + float(j) * np.asarray(cand_cost, dtype=float)
