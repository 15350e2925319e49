"""The objective: log det of the SLAM information matrix of a suite, and the score f(S) built on it.

    log det L(S)  [nats]   the information matrix of the suite's factor graph, linearized at the truth
    f(S) = log det L(S) - log det L(empty) >= 0   the information the suite adds over odometry alone

f is monotone (adding a sensor never lowers it) and submodular (diminishing returns), which the
greedy guarantees and the lazy evaluation rely on.

Evaluators compute these numbers; they differ in speed, not in answers. ``reference`` rebuilds,
relinearizes and eliminates the GTSAM graph for every suite (the paper's method, and the oracle of
the tests); faster engines register themselves in :data:`ENGINES`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Callable, ClassVar, Iterable, Sequence

import numpy as np

from .errors import InputError
from .problem import Problem

Suite = tuple[int, ...]


def as_suite(suite: Iterable[int]) -> Suite:
    """Canonical form of a suite: sorted tuple of unique library positions."""
    return tuple(sorted(set(int(i) for i in suite)))


class Evaluator(ABC):
    """Scores suites of one problem. Subclasses implement :meth:`logdet`.

    Attributes:
        problem: the library and scenario being scored.
        n_evaluations: how many suites have been scored (each log det computed counts one).
    """

    name: ClassVar[str] = ""

    def __init__(self, problem: Problem, *, jobs: int = 1) -> None:
        self.problem = problem
        self.jobs = max(1, int(jobs))
        self.n_evaluations = 0
        self._baseline: float | None = None

    @abstractmethod
    def _logdet(self, suite: Suite) -> float:
        """log det L(suite) [nats] for a canonical suite."""

    def logdet(self, suite: Iterable[int]) -> float:
        """log det of the information matrix of the suite [nats]."""
        s = as_suite(suite)
        for i in s:
            if not 0 <= i < self.problem.n_sensors:
                raise InputError(f"sensor position {i} is outside the library (0..{self.problem.n_sensors - 1})")
        self.n_evaluations += 1
        return self._logdet(s)

    @property
    def baseline_logdet(self) -> float:
        """log det L(empty): odometry, first-pose prior and landmark priors only [nats]."""
        if self._baseline is None:
            self._baseline = self.logdet(())
        return self._baseline

    def score(self, suite: Iterable[int]) -> float:
        """f(S) = log det L(S) - log det L(empty) [nats]."""
        return self.logdet(suite) - self.baseline_logdet

    def scores_with(self, suite: Iterable[int], candidates: Sequence[int]) -> np.ndarray:
        """f(S + {c}) for each candidate c [nats], shape (len(candidates),).

        Engines override this to reuse the work shared by the candidates (same base suite).
        """
        base = as_suite(suite)
        return np.array([self.score(base + (c,)) for c in candidates], dtype=float)


class ReferenceEvaluator(Evaluator):
    """The paper's method: build the GTSAM graph, linearize, eliminate, 2 log|det R|, every time."""

    name = "reference"

    def __init__(self, problem: Problem, *, jobs: int = 1) -> None:
        super().__init__(problem, jobs=jobs)
        from .graph import GraphBuilder  # gtsam only where graphs are built

        self._builder = GraphBuilder(problem)

    def _logdet(self, suite: Suite) -> float:
        return self._builder.logdet(suite)


def _fast_evaluator(problem: Problem, *, jobs: int = 1) -> Evaluator:
    """The fast engine (sensorsel.fast), imported on first use: fast.py builds on this module."""
    from .fast import FastEvaluator

    return FastEvaluator(problem, jobs=jobs)


ENGINES: dict[str, Callable[..., Evaluator]] = {"reference": ReferenceEvaluator, "fast": _fast_evaluator}
DEFAULT_ENGINE = "fast"


def make_evaluator(problem: Problem, engine: str | None = None, *, jobs: int = 1) -> Evaluator:
    """An evaluator of the named engine (default: the fastest registered)."""
    name = engine or DEFAULT_ENGINE
    if name not in ENGINES:
        raise InputError(f"unknown engine {name!r}; available: {', '.join(sorted(ENGINES))}")
    return ENGINES[name](problem, jobs=jobs)
