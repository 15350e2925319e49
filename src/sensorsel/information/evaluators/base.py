"""The objective: log det of the SLAM information matrix of a suite, and the score f(S) built on it.

    log det L(S)  [nats]   the information matrix of the suite's factor graph, linearized at the truth
    f(S) = log det L(S) - log det L(empty) >= 0   the information the suite adds over odometry alone

f is monotone (adding a sensor never lowers it) and submodular (diminishing returns), which the
greedy guarantees and the lazy evaluation rely on.

Evaluators compute these numbers; they differ in speed, not in answers. ``reference`` rebuilds,
relinearizes and eliminates the GTSAM graph for every suite (the paper's method, and the oracle of
the tests); faster engines are registered in :data:`sensorsel.information.evaluators.ENGINES`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Iterable, Sequence
from typing import Any, ClassVar

import numpy as np

from sensorsel.errors import InputError
from sensorsel.information.filtering import check_estimate, check_map_sigma, forward_pass
from sensorsel.model.library import SensorLibrary
from sensorsel.model.problem import Problem

#: a canonical suite: sorted tuple of unique library positions
Suite = tuple[int, ...]


def as_suite(suite: Iterable[int]) -> Suite:
    """Canonical form of a suite: sorted tuple of unique library positions."""
    return tuple(sorted(set(int(i) for i in suite)))


class Evaluator(ABC):
    """The one small interface every selector, certificate and robust design talks to: the score
    f(S) of a suite of one library's sensors, monotone submodular, f(empty) = 0.

    Subclasses: :class:`ProblemEvaluator` (one route: f(S) = log det L(S) - log det L(empty)) and
    :class:`~sensorsel.information.evaluators.domain.DomainEvaluator` (a weighted combination over routes).

    Attributes:
        library: the sensors; suites are sorted tuples of positions in it.
        jobs: threads the engine may use (>= 1; engines that do not use threads ignore it).
        n_evaluations: how many suites have been scored.
    """

    #: the engine's name (in :data:`sensorsel.information.evaluators.ENGINES` for per-problem engines)
    name: ClassVar[str] = ""
    #: whether :meth:`scores_or_bounds` may answer with bounds (then lazy greedy scores the first
    #: candidate of a step alone, to have a best to bound the others against)
    bounds_candidates: ClassVar[bool] = False

    def __init__(self, library: SensorLibrary, *, jobs: int = 1) -> None:
        self.library = library
        self.jobs = max(1, int(jobs))
        self.n_evaluations = 0

    @property
    def n_sensors(self) -> int:
        return len(self.library)

    def prime(self) -> None:
        """Compute, and count in :attr:`n_evaluations`, what every score of this evaluator shares,
        before the first score: a route's sensorless log det (:meth:`ProblemEvaluator.prime`); nothing
        by default (a domain's routes are primed as they are scored). A run that counts evaluations
        calls it first, so its count does not depend on whether its evaluator was fresh."""
        return None

    def _check_positions(self, positions: Iterable[int]) -> None:
        """Raise :class:`InputError` for a position outside the library (0..n_sensors - 1)."""
        n = len(self.library)
        for i in positions:
            if not 0 <= i < n:
                raise InputError(f"sensor position {i} is outside the library (0..{n - 1})")

    def _counted(self, suite: Iterable[int], candidates: Sequence[int]) -> tuple[Suite, list[int]]:
        """``suite`` as a :data:`Suite` and ``candidates`` as ints, every position checked
        (:meth:`_check_positions`) and each candidate counted in ``n_evaluations``: what a
        ``scores_with`` that scores them all does first."""
        base, cand = as_suite(suite), [int(c) for c in candidates]
        self._check_positions(base + tuple(cand))
        self.n_evaluations += len(cand)
        return base, cand

    @abstractmethod
    def score(self, suite: Iterable[int]) -> float:
        """f(S): the information the suite adds (>= 0; units: nats, or a share for a normalised domain)."""

    def scores_with(self, suite: Iterable[int], candidates: Sequence[int]) -> np.ndarray:
        """f(S + {c}) for each candidate c, shape (len(candidates),).

        Engines override this to reuse the work shared by the candidates (same base suite).
        """
        base = as_suite(suite)
        return np.array([self.score(base + (c,)) for c in candidates], dtype=float)

    def scores_or_bounds(
        self, suite: Iterable[int], candidates: Sequence[int], needed: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """For each candidate c, f(S + {c}) exactly, or (where the evaluator can tell more cheaply)
        an upper bound on it below ``needed[i]``, the value it must reach to matter to the caller:
        (values, exact), shape (len(candidates),) each. Lazy greedy calls this; the default scores
        every candidate exactly (:meth:`scores_with`). A domain scores its routes one at a time
        (:meth:`~sensorsel.information.evaluators.domain.DomainEvaluator.scores_or_bounds`)."""
        vals = self.scores_with(suite, candidates)
        return vals, np.ones(len(vals), dtype=bool)

    def gain_bounds(self, suite: Iterable[int], candidates: Sequence[int]) -> np.ndarray | None:
        """Upper bounds on the gains f(S + {c}) − f(S), shape (len(candidates),), in exact
        arithmetic (callers allow for round-off), or None when the engine has none (the default)
        or judges them dearer than scoring that many candidates.
        Computing them is not counted in :attr:`n_evaluations`."""
        return None

    def score_bounds(self, suite: Iterable[int], candidates: Sequence[int]) -> tuple[float, np.ndarray] | None:
        """Cheap upper bounds, in exact arithmetic, on f(S) and on each f(S + {c}) (shape
        (len(candidates),)), or None when the engine has none (the default). Cheap: far below one
        evaluation per suite (the fast engine: Fischer's inequality, :mod:`.fast.fischer`), so a
        caller may ask for f(S)'s alone (no candidates) to judge whether they can help: a bound on
        a gain is the bound on f(S + {c}) minus the exact f(S), so it is at least the gap between
        the bound on f(S) and f(S). Not counted in :attr:`n_evaluations`."""
        return None


class ProblemEvaluator(Evaluator):
    """Scores suites on one problem (one route) by log det. Subclasses implement :meth:`_logdet`.

    Attributes:
        problem: the library and scenario being scored.
        n_evaluations: each log det computed counts one.
        kept: work that keeps state beside this route between calls, by a key its caller chooses
            (a ``require`` run's route oracle, run where the route lives:
            :meth:`~sensorsel.information.evaluators.domain.DomainEvaluator.apply_routes`).
    """

    def __init__(self, problem: Problem, *, jobs: int = 1) -> None:
        super().__init__(problem.library, jobs=jobs)
        self.problem = problem
        self.kept: dict[str, Any] = {}
        self._baseline: float | None = None

    @abstractmethod
    def _logdet(self, suite: Suite) -> float:
        """log det L(suite) [nats] for a canonical suite."""

    def logdet(self, suite: Iterable[int]) -> float:
        """log det of the information matrix of the suite [nats]."""
        s = as_suite(suite)
        self._check_positions(s)
        self.n_evaluations += 1
        return self._logdet(s)

    @property
    def baseline_logdet(self) -> float:
        """log det L(empty): odometry, first-pose prior and landmark priors only [nats]."""
        if self._baseline is None:
            self._baseline = self.logdet(())
        return self._baseline

    def prime(self) -> None:
        """Compute (and count) :attr:`baseline_logdet` now, if not yet done."""
        _ = self.baseline_logdet

    def score(self, suite: Iterable[int]) -> float:
        """f(S) = log det L(S) - log det L(empty) [nats]."""
        return self.logdet(suite) - self.baseline_logdet

    def pose_covariances(
        self, suite: Iterable[int], *, map_sigma_m: float | None = None, estimate: str = "smoother"
    ) -> np.ndarray:
        """The marginal covariance of every keyframe's pose under the suite, shape (K, 3, 3), in
        Pose2's tangent space at the truth: (dx, dy [m] in the keyframe's own frame, x forward and
        y to the left; dθ [rad]), as GTSAM's ``Marginals.marginalCovariance(X(k))`` gives it.

        ``estimate``: "smoother" (the 3×3 diagonal blocks of the inverse information of the whole
        route, landmarks eliminated: every measurement, before and after the keyframe) or "filter"
        (at each keyframe, from the measurements up to it: what the car has as it drives, by one
        forward pass, :func:`sensorsel.information.filtering.forward_pass`). The filter's is ⪰ the
        smoother's at every keyframe (PSD order), equal at the last.

        ``map_sigma_m``: None for the paper's SLAM graph (landmarks unknown: a weak prior only, so
        the uncertainty grows along the route from the first pose's prior); a number [m] for
        localization in a prior map whose landmarks are known to that std (the weak landmark prior
        replaced by an isotropic prior of that std). Not counted in :attr:`n_evaluations`.
        """
        s = as_suite(suite)
        self._check_positions(s)
        check_estimate(estimate)
        check_map_sigma(map_sigma_m)
        ms = None if map_sigma_m is None else float(map_sigma_m)
        if estimate == "filter":
            return forward_pass(self.problem, s, map_sigma_m=ms).filtered
        return self._pose_covariances(s, ms)

    def _pose_covariances(self, suite: Suite, map_sigma_m: float | None) -> np.ndarray:
        raise NotImplementedError(f"the {self.name!r} engine computes no pose covariances")

    def pose_covariance_floor(self, suite: Iterable[int], *, map_sigma_m: float | None = None) -> np.ndarray | None:
        """A cheap lower bound on :meth:`pose_covariances`, shape (K, 3, 3) (each block below the
        true marginal covariance in the positive semidefinite order, so each σ below the true one),
        or None when the engine has none (the default). Not counted in :attr:`n_evaluations`.
        A floor under the smoother's covariances is one under the filter's too (the filter's are
        ⪰ the smoother's: fewer measurements), so one floor serves both estimates."""
        return None
