"""What a search for the cheapest suite meeting integrity needs, per route: the check, and two
monotone bounds that hold whatever the suite.

Integrity is not monotone in the suite: a sensor added brings information (the error tail falls)
and measurements that can be mis-associated (the association risk rises). With n_h keyframes per
hour and ``integrity_risk_per_hour(S) = n_h · mean_k min(1, tail_k(S) + w_k(S))``:

- :meth:`IntegrityBounds.check` (a): the integrity of S itself (:func:`route_integrity`).
- :meth:`IntegrityBounds.tail_relaxation` (b): n_h · mean_k tail_k computed with **every**
  measurement of S used. **Non-increasing in S** (a sensor added only adds information, the filtered
  covariance falls in the Loewner order, each 2Φ(−AL/σ) falls) and **≤ the integrity risk of S**
  (w_k ≥ 0; with the lever S uses a subset of its measurements, its covariance is larger, its tail
  larger). So a suite whose relaxation exceeds the requirement, and every sub-suite of it, fails.
- :meth:`IntegrityBounds.association_floor` (c): n_h · mean_k min(1, Σ_{s∈S} floor[s, k]), floor[s, k]
  the sum of sensor s's association-risk bounds at keyframe k computed at the predicted covariance
  of the **whole allowed library** (every measurement used), each the bound of the model
  linearized at the truth (``MeasurementRisk.linear``). **Non-decreasing in S** (a sum of
  non-negative terms over S's sensors, fixed once) and **≤ the association part of S's risk, hence
  ≤ its integrity risk**: the library's predicted joint covariance is below S's (more information),
  each pair's λ = dᵀ S_j⁻¹ d is larger with it, the linear bound is a non-increasing function of every
  λ, and S's own bound (which covers the Taylor remainder) is at least its linear bound, term by term
  (module :mod:`~sensorsel.information.integrity.association`; tested on random suites). So a suite
  whose floor exceeds the requirement, and every super-suite of it, fails.
  With the lever, a measurement counts in the floor only when its bound robust to the covariance
  (the gate sum with the remainder whitened by the noise alone: non-decreasing in the covariance) at
  the predicted covariance of the **empty** suite (priors and odometry only, the largest any suite
  has) is within the threshold: then it is at least the bound any suite computes, every suite keeps
  the measurement, and its risk there is at least its floor. A measurement that some suite may leave
  out counts 0 (valid, and still non-decreasing).
  In the SLAM model the candidates of a measurement are the landmarks the suite itself has put in
  the state, which grow with the suite: no such floor is claimed there (it is 0).
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from sensorsel.information.filtering import KeyframeMeasurements, Prediction, forward_pass
from sensorsel.information.integrity.association import AssociationModel, Pending
from sensorsel.information.integrity.risk import (
    IntegritySpec,
    RouteIntegrity,
    keyframes_per_hour,
    route_integrity,
    tail_risk,
)
from sensorsel.model.problem import Problem

__all__ = ["IntegrityBounds"]


class IntegrityBounds:
    """The integrity check of a suite on one route and its two monotone bounds (module docstring).

    Args:
        problem: the route.
        allowed: the library positions any suite may use (the floor is computed at their covariance).
        spec: the integrity specification.
        map_sigma_m: the map's std [m]; None for SLAM (then the floor is 0).
    """

    def __init__(
        self, problem: Problem, allowed: Iterable[int], spec: IntegritySpec, *, map_sigma_m: float | None = None
    ) -> None:
        self.problem, self.spec, self.map_sigma_m = problem, spec, map_sigma_m
        self.allowed = tuple(sorted(set(int(s) for s in allowed)))
        self.keyframes_per_hour = keyframes_per_hour(problem)
        n_poses = problem.scenario.n_poses
        self.floor = np.zeros((problem.n_sensors, n_poses))
        if map_sigma_m is not None:
            self._compute_floor()

    def _compute_floor(self) -> None:
        """Every keyframe's linear bounds at the allowed library's prediction, computed at once after
        one forward pass that keeps what they need (:meth:`AssociationModel.snapshot`)."""
        assoc = AssociationModel(self.problem, model="map", gate_probability=self.spec.gate_probability)
        pending = Pending(assoc, linear=True, estimate=False)  # the floor reads bounds only

        def keep(pred: Prediction, meas: KeyframeMeasurements) -> np.ndarray:
            pending.add(pred, meas)
            return np.ones(len(meas.landmark), bool)

        forward_pass(self.problem, self.allowed, map_sigma_m=self.map_sigma_m, use=keep)
        metas = pending.meas
        if not metas:
            return
        bound = pending.result().linear
        threshold = self.spec.max_association_risk
        if threshold is not None:
            prior = Pending(
                assoc, robust_to_covariance=True, estimate=False
            )  # the empty suite's: priors and odometry only
            by_keyframe = {m.keyframe: m for m in metas}
            forward_pass(
                self.problem,
                (),
                map_sigma_m=self.map_sigma_m,
                on_prediction=lambda p, m: prior.add(p, by_keyframe[p.keyframe]) if p.keyframe in by_keyframe else None,
            )
            upper = prior.result().bound
            bound = np.where(upper <= threshold, bound, 0.0)
        sensor = np.concatenate([np.asarray(m.sensor, np.int64) for m in metas])
        keyframe = np.repeat([m.keyframe for m in metas], [len(m.landmark) for m in metas])
        # the same additions in the same order as keyframe by keyframe
        np.add.at(self.floor, (sensor, keyframe), bound)

    def check(self, suite: Iterable[int]) -> RouteIntegrity:
        """(a) The integrity of ``suite`` (its ``meets`` against the specification)."""
        return route_integrity(self.problem, suite, self.spec, map_sigma_m=self.map_sigma_m)

    def tail_relaxation(self, suite: Iterable[int]) -> float:
        """(b) Per hour: the error tail with every measurement of ``suite`` used. Non-increasing in the
        suite; at most its integrity risk per hour."""
        fp = forward_pass(self.problem, suite, map_sigma_m=self.map_sigma_m)
        return float(self.keyframes_per_hour * tail_risk(fp.filtered, self.spec).mean())

    def association_floor(self, suite: Iterable[int]) -> float:
        """(c) Per hour: the association risk bound at the library's covariance. Non-decreasing in the
        suite; at most its integrity risk per hour (0 in SLAM)."""
        idx = np.asarray(sorted(set(int(s) for s in suite)), np.int64)
        if idx.size == 0:
            return 0.0
        per_keyframe = np.minimum(1.0, self.floor[idx].sum(axis=0))
        return float(self.keyframes_per_hour * per_keyframe.mean())
