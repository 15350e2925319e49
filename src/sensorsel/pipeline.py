"""Pipeline functions: what each CLI command calls, usable as-is from scripts and notebooks.

    problem = load_problem(ScenarioSpec(seq="03", kitti_root="../shared/kitti"))
    result = score_suite(problem, "LRL-roof,LRR-12")
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable

from .library import load_library
from .objective import as_suite, make_evaluator
from .problem import GraphSettings, Problem, build_problem
from .scenario import ScenarioSpec, load_scenario


@dataclass(frozen=True)
class ProblemInfo:
    """What a result was computed on (recorded in every result file)."""

    scenario: str
    n_poses: int
    n_landmarks: int
    route_length_m: float
    duration_s: float
    landmark_source: str
    library: str
    n_sensors: int
    spec: ScenarioSpec = field(default_factory=ScenarioSpec)
    settings: GraphSettings = field(default_factory=GraphSettings)


def load_problem(spec: ScenarioSpec = ScenarioSpec(), library: str | Path | None = None, settings: GraphSettings = GraphSettings()) -> Problem:
    """Read the library (default: Table I) and the scenario, and compute what each sensor sees."""
    return build_problem(load_library(library), load_scenario(spec), settings)


def problem_info(problem: Problem, spec: ScenarioSpec = ScenarioSpec()) -> ProblemInfo:
    sc = problem.scenario
    route = sc.route or sc.keyframes
    return ProblemInfo(
        scenario=sc.name,
        n_poses=sc.n_poses,
        n_landmarks=sc.n_landmarks,
        route_length_m=round(route.length_m, 3),
        duration_s=round(route.duration_s, 3),
        landmark_source=sc.landmark_source,
        library=problem.library.source,
        n_sensors=problem.n_sensors,
        spec=spec,
        settings=problem.settings,
    )


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


def score_suite(problem: Problem, suite: str | Iterable[int], *, engine: str | None = None, spec: ScenarioSpec = ScenarioSpec()) -> ScoreResult:
    """Score a suite given as comma-separated ids (``"LRL-roof,LRR-12"``) or library positions."""
    lib = problem.library
    positions = lib.parse_suite(suite) if isinstance(suite, str) else as_suite(suite)
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
        problem=problem_info(problem, spec),
    )
