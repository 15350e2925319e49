"""Integrity as a requirement of ``require``: the check of a suite on every route and its two
monotone relaxations, cached per (route, suite).

A suite meets integrity when on every route its integrity risk per hour
(:func:`~sensorsel.information.integrity.route_integrity`) is within the specification's. That is not
monotone in the suite (a sensor added brings information and measurements that can be
mis-associated), so :func:`~sensorsel.designs.requirements.solver.cheapest_suite` is called with
``monotone=False`` and two necessary conditions of it
(:class:`~sensorsel.information.integrity.IntegrityBounds`, whose docstring proves them):

- :meth:`IntegrityRequirement.tail_met` (monotone: a suite that fails it, and every subset of it,
  fails integrity): the error tail with every measurement used is within the requirement;
- :meth:`IntegrityRequirement.floor_met` (anti-monotone: a suite that fails it, and every superset
  of it, fails integrity): the association floor, computed at the covariance of the whole allowed
  library, is within the requirement.

Both are compared with a relative slack of :data:`RELAXATION_SLACK` (a necessary condition made
looser stays necessary; the slack covers the floating-point order of their sums).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import replace

from sensorsel.information.integrity import IntegrityBounds, IntegritySpec, RouteIntegrity
from sensorsel.model.problem import Problem

__all__ = ["IntegrityRequirement", "RELAXATION_SLACK", "integrity_preset", "INTEGRITY_PRESETS"]

#: the relative slack of the two relaxations against the requirement (module docstring)
RELAXATION_SLACK = 1e-9

#: preset name -> its integrity specification: Reid et al. 2019, passenger cars, alert limits and
#: 10⁻⁸ per hour (the presets of :data:`~sensorsel.designs.requirements.spec.PRESETS`)
INTEGRITY_PRESETS: dict[str, IntegritySpec] = {
    "local-streets": IntegritySpec(
        integrity_risk=1e-8, alert_lateral_m=0.29, alert_longitudinal_m=0.29, alert_heading_deg=0.50
    ),
    "freeway": IntegritySpec(
        integrity_risk=1e-8, alert_lateral_m=0.57, alert_longitudinal_m=1.40, alert_heading_deg=1.50
    ),
}


def integrity_preset(name: str | None) -> IntegritySpec:
    """The integrity specification of the preset ``name`` (None or a name without one: local streets')."""
    return INTEGRITY_PRESETS.get(name or "local-streets", INTEGRITY_PRESETS["local-streets"])


class IntegrityRequirement:
    """Integrity on every route: the check and its two relaxations (module docstring), each computed
    once per (route, suite).

    Args:
        problems: the routes' problems; names: their names.
        allowed: the library positions any suite may use (the association floor is computed at
            their covariance: it is a floor for every suite of them).
        spec: the integrity specification.
        map_sigma_m: the map's std [m]; None: SLAM (no association floor: it is 0).
    """

    def __init__(
        self,
        problems: Sequence[Problem],
        names: Sequence[str],
        allowed: Iterable[int],
        spec: IntegritySpec,
        map_sigma_m: float | None,
    ) -> None:
        allowed = tuple(allowed)
        self.spec, self.names = spec, list(names)
        self.bounds = [IntegrityBounds(p, allowed, spec, map_sigma_m=map_sigma_m) for p in problems]
        self._checks: dict[tuple[int, tuple[int, ...]], RouteIntegrity] = {}
        self._tails: dict[tuple[int, tuple[int, ...]], float] = {}
        self.n_checks = 0  # integrity computations (route, suite)

    def _limit(self) -> float:
        return self.spec.integrity_risk * (1.0 + RELAXATION_SLACK)

    def route(self, r: int, suite: tuple[int, ...]) -> RouteIntegrity:
        """The integrity of ``suite`` on route ``r``."""
        key = (r, suite)
        got = self._checks.get(key)
        if got is None:
            got = self._checks[key] = replace(self.bounds[r].check(suite), route=self.names[r])
            self.n_checks += 1
        return got

    def meets(self, suite: tuple[int, ...]) -> bool:
        """Integrity is met on every route (routes asked in order; the first failing one ends it)."""
        return all(self.route(r, suite).meets for r in range(len(self.bounds)))

    def tail_met(self, suite: tuple[int, ...]) -> bool:
        """The monotone relaxation: the error tail with every measurement used, on every route."""
        for r, b in enumerate(self.bounds):
            key = (r, suite)
            if key not in self._tails:
                self._tails[key] = b.tail_relaxation(suite)
            if self._tails[key] > self._limit():
                return False
        return True

    def floor_met(self, suite: tuple[int, ...]) -> bool:
        """The anti-monotone relaxation: the association floor, on every route (cheap: a sum)."""
        return all(b.association_floor(suite) <= self._limit() for b in self.bounds)

    def with_accuracy(
        self, accuracy_met: Callable[[tuple[int, ...]], bool]
    ) -> tuple[Callable[[tuple[int, ...]], bool], Callable[[tuple[int, ...]], bool]]:
        """(the monotone relaxation, the whole check) of accuracy and integrity together, for the
        solver: ``accuracy_met`` (monotone) and :meth:`tail_met` make the relaxation; the whole check
        adds :meth:`meets`, asked only of a suite that passes the relaxation."""

        def down(suite: tuple[int, ...]) -> bool:
            return accuracy_met(suite) and self.tail_met(suite)

        def whole(suite: tuple[int, ...]) -> bool:
            return down(suite) and self.meets(suite)

        return down, whole

    def report(self, suite: tuple[int, ...]) -> tuple[RouteIntegrity, ...]:
        """The suite's integrity on every route."""
        return tuple(self.route(r, suite) for r in range(len(self.bounds)))
