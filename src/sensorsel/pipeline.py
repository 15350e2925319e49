"""Pipeline functions: what each CLI command calls, usable as-is from scripts and notebooks.

    problem = load_problem(ScenarioSpec(seq="03", kitti_root="../shared/kitti"))
    result = score_suite(problem, "LRL-roof,LRR-12")
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable

from .evaluators import make_evaluator
from .problem import Problem, ProblemInfo, load_problem

__all__ = ["ProblemInfo", "ScoreResult", "load_problem", "score_suite"]


@dataclass(frozen=True)
class ScoreResult:
    """The score of one suite.

    Attributes:
        suite: sensor ids, in library order.
        cost_usd: total cost [$].
        score: f(S) = log det L(S) - log det L(empty) [nats].
        logdet: log det L(S) [nats].
        baseline_logdet: log det L(empty) [nats].
        n_measurements: range-bearing measurements the suite makes along the route.
        n_landmarks_seen: landmarks measured at least once.
        engine: evaluator used.
        problem: what it was computed on.
    """

    suite: tuple[str, ...]
    cost_usd: float
    score: float
    logdet: float
    baseline_logdet: float
    n_measurements: int
    n_landmarks_seen: int
    engine: str
    problem: ProblemInfo


def score_suite(problem: Problem, suite: str | Iterable[str | int], *, engine: str | None = None) -> ScoreResult:
    """Score a suite given as comma-separated ids (``"LRL-roof,LRR-12"``), ids, or library positions."""
    lib = problem.library
    positions = lib.resolve_suite(suite)
    ev = make_evaluator(problem, engine)
    logdet = ev.logdet(positions)
    seen: set[int] = set()
    for i in positions:
        seen.update(problem.observations[i].landmark.tolist())
    return ScoreResult(
        suite=lib.suite_ids(positions),
        cost_usd=lib.cost(positions),
        score=logdet - ev.baseline_logdet,
        logdet=logdet,
        baseline_logdet=ev.baseline_logdet,
        n_measurements=sum(len(problem.observations[i]) for i in positions),
        n_landmarks_seen=len(seen),
        engine=ev.name,
        problem=problem.info,
    )
