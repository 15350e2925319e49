"""sensorsel: which sensors to buy for an autonomous vehicle, and where to mount them.

The score of a sensor suite is the log det of the SLAM information matrix of a GTSAM factor graph
of what the suite measures along a route (Collin & Teran Espinoza, arXiv 1907.08541).

Data flows one way, through a handful of packages (docs/architecture.md)::

    model (library, conditions, scenario, osm, domain, sensing, problem, constraints)
      -> information (linearize, graph, evaluators: log det, accuracy)
      -> pipeline (plans of tasks, executors, stores, the Dask cluster)
      -> designs (selection, certify, tradespace, resilient, robust, requirements, study) and simulation
      -> api, plotting -> cli
"""

from __future__ import annotations

__version__ = "0.1.0"

from sensorsel.api import (
    CertifiedGreedyResult,
    DomainDesign,
    DomainScoreResult,
    ScoreResult,
    certify_result,
    design_domain,
    resilient_report,
    run_greedy,
    run_optimal,
    run_require,
    run_robust,
    run_tradespace,
    score_domain_suite,
    score_suite,
    simulate,
    suite_accuracy,
)
from sensorsel.designs import study as _study  # noqa: F401  (with the api's imports: every result kind registered, sensorsel.io.results)
from sensorsel.errors import InputError, LibraryError, ResultFileError, ScenarioError, SensorselError
from sensorsel.information.evaluators import ENGINES, Evaluator, evaluator_for, make_evaluator
from sensorsel.model.library import PlacedSensor, SensorLibrary, SensorModel, load_library
from sensorsel.model.problem import (
    Domain,
    GraphSettings,
    Problem,
    ProblemInfo,
    build_problem,
    load_domain,
    load_problem,
)
from sensorsel.model.scenario import LandmarkModel, Scenario, ScenarioSpec, Trajectory, load_scenario

__all__ = [
    # run functions (sensorsel.api)
    "score_suite",
    "score_domain_suite",
    "run_greedy",
    "design_domain",
    "run_tradespace",
    "resilient_report",
    "run_robust",
    "certify_result",
    "run_optimal",
    "simulate",
    "run_require",
    "suite_accuracy",
    # inputs
    "Domain",
    "GraphSettings",
    "LandmarkModel",
    "PlacedSensor",
    "Problem",
    "ProblemInfo",
    "Scenario",
    "ScenarioSpec",
    "SensorLibrary",
    "SensorModel",
    "Trajectory",
    "build_problem",
    "load_domain",
    "load_library",
    "load_problem",
    "load_scenario",
    # evaluators
    "ENGINES",
    "Evaluator",
    "evaluator_for",
    "make_evaluator",
    # results
    "CertifiedGreedyResult",
    "DomainDesign",
    "DomainScoreResult",
    "ScoreResult",
    # errors
    "InputError",
    "LibraryError",
    "ResultFileError",
    "ScenarioError",
    "SensorselError",
]
