"""Records of robust selection (frozen dataclasses; they serialize with :mod:`sensorsel.io.results`).

Wall times are in fields named ``seconds`` (the only fields that differ between two identical runs).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from sensorsel.designs.parts import SuiteQuality
from sensorsel.designs.resilient.records import RobustOutcome
from sensorsel.designs.selection import REL_TOL as TIE_TOL
from sensorsel.io.records import AlphaBudget, MethodWorst, WorstOutcome, part_of
from sensorsel.io.results import result_kind
from sensorsel.model.constraints import Constraints
from sensorsel.model.problem import TargetInfo


@dataclass(frozen=True)
class Candidate(MethodWorst):
    """One method's suite, scored by its exact worst case.

    Its first fields are :class:`~sensorsel.io.records.MethodWorst`'s (documented there; ``method``:
    "greedy-uniform", "greedy-marginal", "algorithm-2", "saturate", "oblivious-eta2", "local-search", ...).

    Attributes:
        note: what the method did (levels tried, swaps made, ...); empty if nothing to say.
        n_evaluations: suites newly scored by the method and its worst case (memoized: a suite
            scored by an earlier method is free here).
        seconds: wall time of the method [s].
        worst_member: with ``aggregate="worst"`` over a domain, the route attaining the worst case
            (``failures`` are then that route's failure set); else empty.
    """

    note: str
    n_evaluations: int
    seconds: float = 0.0
    worst_member: str = ""


def better(a: Candidate, b: Candidate) -> bool:
    """True when candidate ``a`` beats ``b``: the higher worst case, then the higher nominal score
    (each a tie within a relative 1e-9), then the cheaper, then the smaller ids in library order."""
    tol = TIE_TOL * max(1.0, abs(a.worst_score), abs(b.worst_score))
    if abs(a.worst_score - b.worst_score) > tol:
        return a.worst_score > b.worst_score
    tol = TIE_TOL * max(1.0, abs(a.nominal_score), abs(b.nominal_score))
    if abs(a.nominal_score - b.nominal_score) > tol:
        return a.nominal_score > b.nominal_score
    if a.cost_usd != b.cost_usd:
        return a.cost_usd < b.cost_usd
    return a.suite < b.suite


def best_of(candidates: Sequence[Candidate]) -> Candidate:
    """The candidate that beats every other (:func:`better`; among equals the first)."""
    b = candidates[0]
    for c in candidates[1:]:
        if better(c, b):
            b = c
    return b


@dataclass(frozen=True)
class MemberWorst:
    """One route of a domain under the worst-route aggregate: the chosen suite's shares of the route's best.

    Attributes:
        name: the route.
        best_score: f_r(L), the whole library's score on the route [nats] (the normaliser).
        nominal_share: f_r(S) / f_r(L), nothing failed.
        worst_share: min over failure sets F (|F| = alpha) of f_r(S minus F) / f_r(L).
        failures: ids of the failure set attaining it on this route.
    """

    name: str
    best_score: float
    nominal_share: float
    worst_share: float
    failures: tuple[str, ...]


@dataclass(frozen=True)
class BoundLeaf:
    """One leaf of the bound's case split: the suites S ⊆ library minus ``removed`` with Cost(S) <= budget
    under ``alpha`` failures (``removed`` are sensors either absent or assumed failed, see :mod:`.bound`).

    Attributes:
        removed: ids taken out of the library on the way to this leaf.
        failed: those of them assumed in the suite and failed.
        budget_usd: the budget left for the leaf's suites [$].
        alpha: failures left.
        bound: upper bound on the best worst case of the leaf's suites [nats].
        how: "exact" (the whole leaf library fits: its worst case is the leaf's optimum),
            "knapsack at X" (X: ids of the anchor suite), "empty" (nothing affordable), "pruned".
    """

    removed: tuple[str, ...]
    failed: tuple[str, ...]
    budget_usd: float
    alpha: int
    bound: float
    how: str


@dataclass(frozen=True)
class RobustBound:
    """An upper bound on the best achievable worst case within the budget.

    Attributes:
        bound: no suite within the budget has a worst case above this [nats].
        leaves: the case split's leaves (bound = the largest, or the incumbent if that is larger).
        n_nodes: nodes of the case split.
        n_sweeps: marginal-gain sweeps made.
        proved: True when the bound equals the incumbent (to a relative 1e-9): it is optimal.
        n_evaluations: suites newly scored for the bound.
        seconds: wall time [s].
        relaxation: empty, or (under constraints) how the bound kept them: integer programs over
            every limit, or what it relaxed (the budget alone: a larger set of suites, so it stays an
            upper bound).
    """

    bound: float
    leaves: tuple[BoundLeaf, ...]
    n_nodes: int
    n_sweeps: int
    proved: bool
    n_evaluations: int
    seconds: float = 0.0
    relaxation: str = ""


@result_kind("robust")
@dataclass(frozen=True)
class RobustResult(SuiteQuality, RobustOutcome, AlphaBudget):
    """A robust selection: the best candidate by exact worst case, all candidates, the bound.

    Its first fields are :class:`~sensorsel.io.records.AlphaBudget`'s and
    :class:`~sensorsel.designs.resilient.records.RobustOutcome`'s (documented there; the answer's worst
    case is never below greedy's nor Algorithm 2's); its last, :class:`~sensorsel.designs.parts.SuiteQuality`'s
    (the chosen suite's).

    Attributes:
        candidates: every candidate, in the order the methods ran.
        skipped: methods not run, with why ("bound proves optimality", ...).
        bound_detail: how the bound was obtained.
        n_evaluations: suites scored in all (each at most once).
        engine: the evaluator used.
        problem: what it was computed on.
        seconds: wall time [s].
        aggregate: empty for one route (or a domain's combined score); "worst" for the max-min over a
            domain's routes: scores are then shares of each route's best, f_r(S) / f_r(L), the worst case
            is the minimum over routes and failure sets, and ``nominal_score`` the minimum over routes.
        worst_member: with "worst", the route attaining the worst case.
        members: with "worst", every route's shares (the breakdown).
        constraints: the limits besides the budget every candidate kept; None: the budget alone.
    """

    candidates: tuple[Candidate, ...]
    skipped: tuple[str, ...]
    bound_detail: RobustBound
    n_evaluations: int
    engine: str
    problem: TargetInfo | None = None
    seconds: float = 0.0
    aggregate: str = ""
    worst_member: str = ""
    members: tuple[MemberWorst, ...] = ()
    constraints: Constraints | None = None

    @classmethod
    def of(
        cls,
        win: Candidate,
        bound_detail: RobustBound,
        candidates: Sequence[Candidate],
        skipped: Sequence[str],
        **rest: Any,
    ) -> RobustResult:
        """The result whose answer is the candidate ``win`` (its method, suite, cost, scores and
        failures), with the bound the larger of ``bound_detail.bound`` and the answer's worst case
        (which it proves), and the gap to it in percent; ``rest``: the other fields by name."""
        bound = max(bound_detail.bound, win.worst_score)
        return cls(
            **part_of(win, MethodWorst),
            bound=bound,
            gap_percent=100.0 * (bound - win.worst_score) / bound if bound > 0 else 0.0,
            candidates=tuple(candidates),
            skipped=tuple(skipped),
            bound_detail=bound_detail,
            **rest,
        )


@result_kind("robust-optimum")
@dataclass(frozen=True)
class RobustOptimum(WorstOutcome, AlphaBudget):
    """The best worst case within the budget, by branch and bound (proved or not).

    Attributes:
        proved_optimal: every other suite ruled out.
        upper_bound: no suite within the budget has a worst case above this [nats].
        gap_percent: 100 * (upper_bound - worst_score) / upper_bound.
        n_nodes: nodes expanded.
        n_pruned: nodes dropped by their bound.
        n_evaluations: suites newly scored.
        stop_reason: why the search stopped.
        seconds: wall time [s].
        constraints: the limits besides the budget the search kept; None: the budget alone.
    """

    proved_optimal: bool
    upper_bound: float
    gap_percent: float
    n_nodes: int
    n_pruned: int
    n_evaluations: int
    stop_reason: str
    seconds: float = 0.0
    constraints: Constraints | None = None
