"""sensorsel: which sensors to buy for an autonomous vehicle, and where to mount them.

The score of a sensor suite is the log det of the SLAM information matrix of a GTSAM factor graph
of what the suite measures along a route (Collin & Teran Espinoza, arXiv 1907.08541).

Data flows one way::

    library + scenario -> sensing (what each sensor sees) -> graph / evaluators (log det)
                       -> selection (rules) -> certify, tradespace, resilient -> api -> results -> plots and CLI
"""

from __future__ import annotations

__version__ = "0.1.0"

from .errors import InputError, LibraryError, ResultFileError, ScenarioError, SensorselError
from .evaluators import ENGINES, Evaluator, make_evaluator
from .library import PlacedSensor, SensorLibrary, SensorModel, load_library
from .api import ProblemInfo, ScoreResult, load_problem, run_greedy, score_suite
from .problem import GraphSettings, Problem, build_problem
from .scenario import LandmarkModel, Scenario, ScenarioSpec, Trajectory, load_scenario

__all__ = [
    "ENGINES", "Evaluator", "GraphSettings", "InputError", "LandmarkModel", "LibraryError", "PlacedSensor",
    "Problem", "ProblemInfo", "ResultFileError", "Scenario", "ScenarioError", "ScenarioSpec", "ScoreResult",
    "SensorLibrary", "SensorModel", "SensorselError", "Trajectory", "build_problem", "load_library",
    "load_problem", "load_scenario", "make_evaluator", "run_greedy", "score_suite",
]
