"""How much to spare an answer has: the smallest slack between a suite's errors and the limits, where
it is, and the keyframes that bind.

For one route and one bounded component, the error at keyframe k is e_k = factor × σ_k (95 % or 1σ,
as the specification states) and the stated limit is b. With every keyframe required, the slack is
b − max_k e_k, at the keyframe of the largest error; with a share ``at`` of the keyframes, it is
b − e_(r), e_(r) the r-th smallest error (r = ⌈at K⌉, the rank rule of :mod:`.spec`), at the
keyframe holding that rank. The answer's *margin* is the smallest slack over routes and components,
compared in % of each limit (a heading slack in degrees and a lateral one in metres are compared as
shares of their limits). The *binding keyframes* are those of the binding route and component whose
error is within :data:`BINDING_SHARE` of the limit of the binding error: the keyframes that would
fail first if the suite lost accuracy.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from sensorsel.designs.requirements.spec import Specification, _rank
from sensorsel.information.evaluators.accuracy import RouteAccuracy

__all__ = ["BINDING_SHARE", "Margin", "margin_of"]

#: keyframes whose error is within this share of the limit of the binding error bind with it
BINDING_SHARE = 0.01


@dataclass(frozen=True)
class Margin:
    """The smallest slack of a suite against its specification.

    Attributes:
        route: where it is.
        component: "lateral", "longitudinal" or "heading".
        keyframe: the keyframe of the binding error (index along the route).
        error: the error there [m or deg; 95 % or 1σ as the specification].
        limit: the stated limit [m or deg] (before any demanded margin).
        slack: limit − error [m or deg] (negative: the limit is missed).
        slack_share: slack / limit (0.05: 5 % of the limit to spare).
        unit: "m" or "deg".
        binding_keyframes: the keyframes of that route and component whose error is within
            :data:`BINDING_SHARE` of the limit of the binding error, in route order.
    """

    route: str
    component: str
    keyframe: int
    error: float
    limit: float
    slack: float
    slack_share: float
    unit: str
    binding_keyframes: tuple[int, ...]

    def line(self) -> str:
        """e.g. "0.007 deg (4.1 % of the 0.17 deg limit): route suburb, heading at keyframe 52;
        binding keyframes 52 (1)"."""
        d = 3
        kf = ", ".join(str(k) for k in self.binding_keyframes[:8]) + (" ..." if len(self.binding_keyframes) > 8 else "")
        return (
            f"{self.slack:.{d}f} {self.unit} ({100 * self.slack_share:.1f} % of the {self.limit:g} {self.unit} limit): "
            f"route {self.route}, {self.component} at keyframe {self.keyframe}; binding keyframes {kf} "
            f"({len(self.binding_keyframes)})"
        )


def margin_of(routes: Sequence[tuple[str, Specification, RouteAccuracy]]) -> Margin | None:
    """The :class:`Margin` of a suite over ``routes`` (name, specification, the suite's accuracy
    there); None when no route has a keyframe."""
    best: Margin | None = None
    for name, spec, acc in routes:
        for comp, limit, unit in spec.stated_bounds():
            err = spec.factor * acc.sigmas(comp)
            if err.size == 0:
                continue
            order = np.argsort(err, kind="stable")
            k = int(order[_rank(spec.at, len(err)) - 1])
            slack = limit - float(err[k])
            share = slack / limit
            if best is None or share < best.slack_share:
                near = np.flatnonzero(np.abs(err - err[k]) <= BINDING_SHARE * limit)
                best = Margin(name, comp, k, float(err[k]), limit, slack, share, unit, tuple(int(i) for i in near))
    return best
