"""The public run functions: what each CLI command calls, usable as-is from scripts and notebooks.

    problem = load_problem(ScenarioSpec(seq="03", kitti_root="../shared/kitti"))
    result = score_suite(problem, "LRL-roof,LRR-12")
    greedy = run_greedy(problem, 110_000, "best-of", certify=True)

Each takes a :class:`~sensorsel.problem.Problem`, builds its evaluator, and records ``problem.info``.
This is the top of the library's layers: nothing below it imports it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable

from .certify import CertifiedGreedyResult, certificate
from .evaluators import make_evaluator
from .problem import Problem, ProblemInfo, load_problem
from .selection import Progress, check_budget, check_rule, greedy
from .tradespace import run_tradespace

__all__ = ["CertifiedGreedyResult", "ProblemInfo", "ScoreResult", "load_problem", "run_greedy", "run_tradespace",
           "score_suite"]


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


def run_greedy(problem: Problem, budget_usd: float, rule: str = "uniform", *, engine: str | None = None, jobs: int = 1,
               lazy: bool = True, progress: Progress | None = None,
               certify: bool = False, certify_progress: Progress | None = None) -> CertifiedGreedyResult:
    """The ``sensorsel greedy`` run: :func:`~sensorsel.selection.greedy` with a fresh evaluator of
    ``engine``, recording what the problem is.

    With ``certify``, the result carries its :class:`~sensorsel.certify.Certificate` (an upper bound
    on the best possible score within the budget), computed with the same evaluator: at most one sweep
    of the library per greedy step, fewer where a step provably cannot lower the bound
    (``certify_progress(done, total)`` after each); else its ``certificate`` is None.

    Raises:
        InputError: a bad budget or rule (before any evaluator is built).
    """
    check_budget(budget_usd)
    check_rule(rule)
    ev = make_evaluator(problem, engine, jobs=jobs)
    res = greedy(ev, budget_usd, rule, lazy=lazy, progress=progress, info=problem.info)
    cert = certificate(ev, res, progress=certify_progress) if certify else None
    return CertifiedGreedyResult.of(res, cert)
