"""The smoother's marginals of a route's suites, the floor ``require`` puts under the filter's
(:class:`SmootherFloor`), and the one place where ``require`` asks a route's engine for marginals
(:func:`route_covariances`).

With the filter's estimate (the accuracy the car has as it drives), the smoother's marginals of the
same suite are a floor under it: every keyframe's smoothed estimate uses the filter's measurements
and more, so every σ is no larger, and a suite whose smoothed accuracy misses the specification
misses it as the car drives. They cost ~1/20-1/50 of the filter's pass. Each suite's are computed
once, here, or, for the suites the solver's greedy likely asks next, ahead on the route's worker
processes (:class:`~sensorsel.information.evaluators.processes.CovariancesAhead`): the same bits.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING, Protocol

import numpy as np

from sensorsel.designs.requirements.spec import Specification, covariance_verdict
from sensorsel.information.evaluators.base import Suite

if TYPE_CHECKING:
    from sensorsel.information.evaluators.processes import CovariancesAhead

__all__ = ["RouteEngine", "SmootherFloor", "route_covariances"]


class RouteEngine(Protocol):
    """What require asks of a route's engine: its pose marginals and their cheap floor (a
    :class:`~sensorsel.information.evaluators.base.ProblemEvaluator`, asked where the route lives)."""

    @property
    def name(self) -> str: ...

    def pose_covariances(
        self, suite: Iterable[int], *, map_sigma_m: float | None = None, estimate: str = "smoother"
    ) -> np.ndarray: ...

    def pose_covariance_floor(self, suite: Iterable[int], *, map_sigma_m: float | None = None) -> np.ndarray | None: ...


def route_covariances(engine: RouteEngine, suite: Suite, map_sigma_m: float | None, estimate: str) -> np.ndarray:
    """The (K, 3, 3) pose covariances ``require`` judges a suite by on one route (the filter's or the
    smoother's ``estimate``): the one place where it asks a route's engine for them."""
    return engine.pose_covariances(suite, map_sigma_m=map_sigma_m, estimate=estimate)


class SmootherFloor:
    """The smoother's (meets, violation) of a route's suites (:func:`~.spec.covariance_verdict` of
    their marginals), each computed once: the floor under the filter's (module docstring).

    Args:
        engine: the route's engine; spec: its specification; map_sigma_m: the prior map's σ [m]
            (None: SLAM).
        ahead: the route's worker processes computing marginals ahead, or None (all computed here).
    """

    def __init__(
        self,
        engine: RouteEngine,
        spec: Specification,
        map_sigma_m: float | None,
        ahead: CovariancesAhead | None = None,
    ) -> None:
        self.engine, self.spec, self.map_sigma_m, self.ahead = engine, spec, map_sigma_m, ahead
        self._verdicts: dict[Suite, tuple[bool, float]] = {}

    def known(self, suite: Suite) -> tuple[bool, float] | None:
        """``suite``'s (meets, violation) if computed already, else None (nothing computed)."""
        return self._verdicts.get(suite)

    def verdict(self, suite: Suite) -> tuple[bool, float]:
        """``suite``'s (meets, violation), computed at its first call (or taken from :attr:`ahead`)."""
        got = self._verdicts.get(suite)
        if got is None:
            cov = self._marginals(suite) if self.ahead is None else self.ahead.take(suite, self._marginals)
            got = self._verdicts[suite] = covariance_verdict(cov, self.spec)
        return got

    def look_ahead(self, suites: Sequence[Suite]) -> None:
        """The suites likely asked next, in order: those not yet computed go to :attr:`ahead`'s idle
        workers (nothing without it)."""
        if self.ahead is not None:
            todo = [s for s in suites if s not in self._verdicts]
            if todo:
                self.ahead.submit(todo)

    def _marginals(self, suite: Suite) -> np.ndarray:
        return route_covariances(self.engine, suite, self.map_sigma_m, "smoother")
