"""The reference engine: the paper's method, and the oracle of the tests."""

from __future__ import annotations

import numpy as np

from sensorsel.information.evaluators.base import ProblemEvaluator, Suite
from sensorsel.model.problem import Problem


class ReferenceEvaluator(ProblemEvaluator):
    """The paper's method: build the GTSAM graph, linearize, eliminate, 2 log|det R|, every time."""

    name = "reference"

    def __init__(self, problem: Problem, *, jobs: int = 1) -> None:
        super().__init__(problem, jobs=jobs)
        from sensorsel.information.graph import GraphBuilder  # gtsam is imported where graphs are built, when one is

        self._builder = GraphBuilder(problem)

    def _logdet(self, suite: Suite) -> float:
        return self._builder.logdet(suite)

    def _pose_covariances(self, suite: Suite, map_sigma_m: float | None) -> np.ndarray:
        """GTSAM's own ``Marginals`` of every pose (the oracle of the fast engine's)."""
        return self._builder.pose_covariances(suite, map_sigma_m=map_sigma_m)
