"""The accuracy a suite gives, in metres and degrees: per keyframe, from the poses' marginal covariances.

A suite's score is in nats; a vehicle team signs off metres. From the 3×3 marginal covariance of
each keyframe's pose (the diagonal blocks of the inverse information, landmarks eliminated:
:meth:`~sensorsel.information.evaluators.base.ProblemEvaluator.pose_covariances`), in Pose2's tangent space at
the truth, whose translation is in the keyframe's own frame (x forward along the car, y to its left):

    longitudinal σ = √Σ[0, 0]  [m]      lateral σ = √Σ[1, 1]  [m]      heading σ = √Σ[2, 2]  [rad → deg]

(the routes' headings are their direction of travel, so the body frame is the car's own).

Two localization models (:data:`MODELS`), and an accuracy always says which produced it:

- ``slam``: the paper's graph. Landmarks are unknown (a weak prior only); the uncertainty is
  relative to the first pose's prior and grows along the route between loop closures.
- ``map``: a deployed car localizing in a prior map whose landmarks are known to ``map_sigma_m``
  (each landmark's weak prior replaced by an isotropic prior of that std).

Two estimates (:data:`ESTIMATES`), and an accuracy always says which it is of:

- ``filter`` (the default): at each keyframe, from the measurements up to it: the accuracy the car
  has as it drives (:func:`sensorsel.information.filtering.forward_pass`).
- ``smoother``: from every measurement of the route, before and after the keyframe (what a
  survey solved afterwards has); never worse than the filter's, equal at the last keyframe.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from sensorsel.information.evaluators.base import ProblemEvaluator
from sensorsel.information.filtering import ESTIMATES, check_estimate

__all__ = ["ESTIMATES", "MODELS", "Z95", "RouteAccuracy", "Spread", "route_accuracy", "model_label", "estimate_label"]

#: the localization models: the paper's SLAM graph, or localization in a prior map
MODELS = ("slam", "map")

#: the two-sided 95 % quantile of a normal distribution: a 95 % bound is Z95 × σ
Z95 = 1.959963984540054

#: the per-keyframe components: (field, unit, label)
COMPONENTS = (
    ("lateral_sigma_m", "m", "lateral"),
    ("longitudinal_sigma_m", "m", "longitudinal"),
    ("heading_sigma_deg", "deg", "heading"),
)


@dataclass(frozen=True)
class Spread:
    """How one component's 1σ is spread over a route's keyframes.

    Attributes:
        median, p95, max: the median, 95th percentile (linear interpolation) and largest 1σ over
            the keyframes (the unit of the component: m or deg).
        worst_keyframe: the keyframe with the largest σ (the first such, by index).
    """

    median: float
    p95: float
    max: float
    worst_keyframe: int


@dataclass(frozen=True)
class RouteAccuracy:
    """The accuracy of one suite on one route, per keyframe (1σ).

    Attributes:
        model: ``"slam"`` or ``"map"`` (:data:`MODELS`).
        map_sigma_m: with the map model, the std of the landmarks' positions [m]; None with ``slam``.
        lateral_sigma_m: (K,) 1σ position error across the car (its y axis) [m].
        longitudinal_sigma_m: (K,) 1σ position error along the car (its x axis) [m].
        heading_sigma_deg: (K,) 1σ heading error [deg].
        lateral, longitudinal, heading: each component's :class:`Spread` over the keyframes.
        route: the route's name (a domain's accuracy has one per route).
        estimate: ``"filter"`` (as the car drives) or ``"smoother"`` (the whole route) (:data:`ESTIMATES`);
            result files written before estimates existed hold the smoother's, and load so.
    """

    model: str
    map_sigma_m: float | None
    lateral_sigma_m: tuple[float, ...]
    longitudinal_sigma_m: tuple[float, ...]
    heading_sigma_deg: tuple[float, ...]
    lateral: Spread
    longitudinal: Spread
    heading: Spread
    route: str = ""
    estimate: str = "smoother"

    @property
    def n_keyframes(self) -> int:
        return len(self.lateral_sigma_m)

    def sigmas(self, component: str) -> np.ndarray:
        """The (K,) 1σ of ``component`` ("lateral", "longitudinal" or "heading")."""
        field = {label: f for f, _, label in COMPONENTS}[component]
        return np.asarray(getattr(self, field), dtype=float)

    def line(self) -> str:
        """One line: the 95 % errors (1.96σ) over the keyframes (median / 95th percentile / worst,
        and the worst keyframe) of each component, with the model that produced them."""
        parts = []
        for _, unit, label in COMPONENTS:
            s: Spread = getattr(self, label)
            d = 3 if unit == "m" else 2
            parts.append(
                f"{label} {Z95 * s.median:.{d}f} / {Z95 * s.p95:.{d}f} / {Z95 * s.max:.{d}f} {unit} "
                f"(keyframe {s.worst_keyframe})"
            )
        return (
            f"{model_label(self.model, self.map_sigma_m)}, {estimate_label(self.estimate)}; 95% errors, median / "
            "95th percentile / worst keyframe: " + ", ".join(parts)
        )


def model_label(model: str, map_sigma_m: float | None) -> str:
    """Words for a localization model: "SLAM (landmarks unknown)" or "prior map (landmarks known to 0.05 m)"."""
    if model == "map":
        return f"prior map (landmarks known to {map_sigma_m:g} m)"
    return "SLAM (landmarks unknown)"


def estimate_label(estimate: str) -> str:
    """Words for an estimate: "filter (as the car drives)" or "smoother (whole route)"."""
    return {"filter": "filter (as the car drives)", "smoother": "smoother (whole route)"}.get(estimate, estimate)


def _spread(values: np.ndarray) -> Spread:
    if values.size == 0:
        return Spread(math.nan, math.nan, math.nan, -1)
    return Spread(
        float(np.median(values)), float(np.percentile(values, 95.0)), float(values.max()), int(np.argmax(values))
    )


def accuracy_from_covariances(
    covariances: np.ndarray, *, map_sigma_m: float | None, route: str = "", estimate: str = "smoother"
) -> RouteAccuracy:
    """The :class:`RouteAccuracy` of (K, 3, 3) pose marginal covariances (Pose2 tangent: x forward,
    y left [m], θ [rad]); ``map_sigma_m`` None for the SLAM model; ``estimate`` the estimate they
    are of (:data:`ESTIMATES`)."""
    cov = np.asarray(covariances, dtype=float)
    diag = np.sqrt(np.maximum(np.diagonal(cov, axis1=1, axis2=2), 0.0))  # (K, 3)
    lon, lat, head = diag[:, 0], diag[:, 1], np.degrees(diag[:, 2])
    return RouteAccuracy(
        model="slam" if map_sigma_m is None else "map",
        map_sigma_m=map_sigma_m,
        lateral_sigma_m=tuple(lat.tolist()),
        longitudinal_sigma_m=tuple(lon.tolist()),
        heading_sigma_deg=tuple(head.tolist()),
        lateral=_spread(lat),
        longitudinal=_spread(lon),
        heading=_spread(head),
        route=route,
        estimate=check_estimate(estimate),
    )


def route_accuracy(
    evaluator: ProblemEvaluator,
    suite: Iterable[int],
    *,
    map_sigma_m: float | None = None,
    route: str = "",
    estimate: str = "filter",
) -> RouteAccuracy:
    """The accuracy of ``suite`` (library positions) on the evaluator's route, in the SLAM model
    (``map_sigma_m`` None) or localizing in a map whose landmarks are known to ``map_sigma_m`` [m];
    of the filter's estimate (as the car drives, the default) or the smoother's (:data:`ESTIMATES`)."""
    return accuracy_from_covariances(
        evaluator.pose_covariances(suite, map_sigma_m=map_sigma_m, estimate=estimate),
        map_sigma_m=map_sigma_m,
        route=route or evaluator.problem.scenario.name,
        estimate=estimate,
    )
