"""``simulate --associate``: build each keyframe's case from the forward pass, run the draws through
the plan/executor (one task per keyframe), and set the observed rates beside the predictions.

The prediction is the integrity engine's own (:class:`~sensorsel.information.integrity.AssociationModel`
at each keyframe's :class:`~sensorsel.information.filtering.Prediction`, every measurement used), so
``predicted_bound`` per keyframe is the ``p_wrong_association`` of
:func:`~sensorsel.information.integrity.route_integrity` without the lever.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.spatial import cKDTree
from scipy.stats import beta

from sensorsel.errors import InputError
from sensorsel.information.filtering import KeyframeMeasurements, Prediction, forward_pass
from sensorsel.information.integrity.association import AssociationModel, keyframe_risk
from sensorsel.information.integrity.risk import IntegritySpec, keyframes_per_hour
from sensorsel.model.problem import Problem
from sensorsel.pipeline import Executor, Plan, execute
from sensorsel.simulation.association import (
    CANDIDATE_MARGIN_M,
    CANDIDATE_SCALE,
    RANGE_SIGMAS,
    KeyframeCase,
    KeyframeOutcome,
    SensorCone,
    Task,
    associate_keyframe,
)
from sensorsel.simulation.records import AssociationCheck, AssociationKeyframe, CalibrationBin, SensorAssociation

__all__ = ["SHIFT_NOTE", "calibration_bins", "check_association_args", "simulate_association"]

SHIFT_NOTE = (
    "the filter's one-measurement update with the wrong landmark from the prediction: "
    "shift K_j nu_j - K_i nu_i of the pose estimate at that keyframe (not carried to later keyframes)"
)
#: how each kind of draw samples, in words (AssociationCheck.sampling)
IMPORTANCE_SAMPLING = (
    "importance sampling: each measurement on its own, from a defensive mixture of mean shifts toward "
    "each wrong candidate's decision boundary, weighted by the likelihood ratio; a keyframe's figure is "
    "1 - prod(1 - P(wrong) of its measurements)"
)
PLAIN_MONTE_CARLO = (
    "plain Monte Carlo: each draw runs all of a keyframe's measurements on one shared pose and map error"
)
#: the calibration bins' edges of the predicted estimate: 0 and the decades 1e-12 .. 1
BIN_EDGES = (0.0,) + tuple(10.0**e for e in range(-12, 1))
#: plain Monte Carlo resolves a keyframe with at least this many wrong draws
RESOLVE_COUNT = 10
#: importance sampling resolves a keyframe at a relative standard error at most this
RESOLVE_RELATIVE_SE = 0.3
Z99 = 2.5758293035489004


def check_association_args(
    draws: int, seed: int, importance: bool, clutter_per_km: float, gate_probability: float
) -> None:
    """Raise InputError naming the option of the first bad value."""
    if isinstance(draws, bool) or not isinstance(draws, int) or draws < 1:
        raise InputError(f"--draws {draws!r}: a positive integer")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise InputError(f"--seed {seed!r}: a non-negative integer")
    if not (isinstance(clutter_per_km, (int, float)) and math.isfinite(clutter_per_km) and clutter_per_km >= 0.0):
        raise InputError(f"--clutter-per-km {clutter_per_km!r}: a density of clutter objects per km, >= 0")
    if importance and clutter_per_km > 0.0:
        raise InputError(
            "--clutter-per-km with --importance-sampling: clutter is simulated by plain Monte Carlo only; give one"
        )
    if not (
        isinstance(gate_probability, (int, float)) and math.isfinite(gate_probability) and 0.0 < gate_probability < 1.0
    ):
        raise InputError(f"--gate-probability {gate_probability!r}: a probability strictly between 0 and 1")


@dataclass
class _Cases:
    """The forward pass's ``on_prediction`` hook: each keyframe's case and prediction."""

    model: AssociationModel
    cones: tuple[SensorCone, ...]
    reach_m: float
    route_xy: np.ndarray
    route_reach_m: float
    cases: list[KeyframeCase] = field(default_factory=list)
    estimate: list[float] = field(default_factory=list)
    bound: list[float] = field(default_factory=list)
    per_sensor: list[dict[int, float]] = field(default_factory=list)

    def __call__(self, prediction: Prediction, meas: KeyframeMeasurements) -> None:
        r = self.model.risks(prediction, meas)
        est, bnd = keyframe_risk(r.estimate, r.bound)
        self.estimate.append(est)
        self.bound.append(bnd)
        sensors = np.asarray(meas.sensor, np.int64)
        self.per_sensor.append({c.position: float(r.estimate[sensors == c.position].sum()) for c in self.cones})
        self.cases.append(
            _case(self.model, prediction, meas, self.cones, self.reach_m, self.route_xy, self.route_reach_m)
        )


def _case(
    model: AssociationModel,
    prediction: Prediction,
    meas: KeyframeMeasurements,
    cones: tuple[SensorCone, ...],
    reach_m: float,
    route_xy: np.ndarray,
    route_reach_m: float,
) -> KeyframeCase:
    """One keyframe's numbers: candidates within ``reach_m`` of the car (SLAM: the state's), their
    joint covariance with the pose (a landmark outside the state: the prior σ², independent)."""
    pose = np.asarray(model.problem.scenario.keyframes.poses[meas.keyframe], float)
    points = np.asarray(model.problem.scenario.landmarks, float)
    near = np.flatnonzero(np.hypot(*(points - pose[:2]).T) <= reach_m) if len(points) else np.zeros(0, np.int64)
    state = np.asarray(prediction.landmarks, np.int64)  # in the pass's order (not sorted)
    if model.model == "slam":
        near = near[np.isin(near, state)]
    cand = np.asarray(near, np.int64)
    # the prediction's covariance restricted to the pose and the candidates (their places in the state)
    slot = prediction.slots_of(cand)
    inside = slot >= 0
    dim = 3 + 2 * len(cand)
    src = np.full(dim, -1)
    src[:3] = np.arange(3)
    for a in np.flatnonzero(inside):
        src[3 + 2 * a : 5 + 2 * a] = 3 + 2 * slot[a] + np.arange(2)
    cov = np.zeros((dim, dim))
    ok = src >= 0
    full = np.asarray(prediction.covariance, float)
    cov[np.ix_(ok, ok)] = full[np.ix_(src[ok], src[ok])]
    out = ~ok
    cov[out, out] = float(prediction.prior_sigma_m) ** 2
    lm = np.asarray(meas.landmark, np.int64)
    pos = np.searchsorted(cand, lm)
    right = (
        np.where((pos < len(cand)) & (cand[np.minimum(pos, max(len(cand) - 1, 0))] == lm), pos, -1)
        if len(cand)
        else np.full(len(lm), -1)
    )
    route = route_xy[np.hypot(*(route_xy - pose[:2]).T) <= route_reach_m] if len(route_xy) else route_xy
    return KeyframeCase(
        keyframe=int(meas.keyframe),
        pose=pose,
        sensor=np.asarray(meas.sensor, np.int64),
        landmark=lm,
        bearing_rad=np.asarray(meas.bearing_rad, float),
        range_m=np.asarray(meas.range_m, float),
        sigma_bearing_rad=np.asarray(meas.sigma_bearing_rad, float),
        sigma_range_m=np.asarray(meas.sigma_range_m, float),
        candidates=cand,
        points=points[cand],
        right=right.astype(np.int64),
        covariance=cov,
        cones=cones,
        route_xy=route,
    )


def _cones(problem: Problem, suite: tuple[int, ...]) -> tuple[SensorCone, ...]:
    """The suite's sensors as clutter sees them (the library's models; a condition's effects on
    range and noise are not applied to clutter)."""
    out = []
    for i in suite:
        s = problem.library[i]
        m = s.model
        stereo = m.type == "stereo"
        quad = float(m.sigma_disparity_px / (m.focal_px * m.baseline_m)) if stereo else 0.0  # type: ignore[operator]
        out.append(
            SensorCone(
                int(i),
                float(s.mount_angle_rad),
                float(m.fov_rad),
                float(m.range_m),
                float(m.bearing_sigma()),
                0.0 if stereo else float(m.sigma_range_m or 0.0),
                quad,
            )
        )
    return tuple(out)


def _route(problem: Problem) -> tuple[np.ndarray, float]:
    """The route's keyframe positions joined at most 1 m apart, and the corridor: the largest distance
    of a map landmark from it [m] (clutter stands where landmarks stand)."""
    xy = np.asarray(problem.scenario.keyframes.poses, float)[:, :2]
    parts = [xy[:1]]
    for a, b in zip(xy[:-1], xy[1:]):
        n = max(1, int(math.ceil(float(np.hypot(*(b - a))))))
        parts.append(a + (b - a) * (np.arange(1, n + 1)[:, None] / n))
    route = np.concatenate(parts)
    pts = np.asarray(problem.scenario.landmarks, float)
    corridor = float(cKDTree(route).query(pts)[0].max()) if len(pts) else 0.0
    return route, corridor


def route_length_m(problem: Problem) -> float:
    """The route's length along its keyframes [m]."""
    xy = np.asarray(problem.scenario.keyframes.poses, float)[:, :2]
    return float(np.sum(np.hypot(*np.diff(xy, axis=0).T))) if len(xy) > 1 else 0.0


def simulate_association(
    problem: Problem,
    suite: Iterable[int],
    *,
    map_sigma_m: float | None = None,
    draws: int = 2000,
    seed: int = 0,
    gate_probability: float = 0.9999,
    importance: bool = False,
    clutter_per_km: float = 0.0,
    label: str = "suite",
    executor: Executor | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> AssociationCheck:
    """Run the stated associator on ``draws`` draws per keyframe (module :mod:`.association`) and set
    the observed rates beside the integrity engine's predictions.

    Args:
        problem: the route, its landmarks and library; suite: library positions.
        map_sigma_m: localizing in a map known to this std [m]; None: SLAM.
        draws: per keyframe (per measurement with importance sampling).
        seed: keyframe k draws from (seed, 3, k).
        gate_probability: p_G of the χ²₂ gate.
        importance: importance sampling (a defensive mixture of mean shifts toward the decision
            boundary, weighted by the likelihood ratio; module :mod:`.association`); else plain Monte Carlo.
        clutter_per_km: unmapped clutter objects per km of route (plain Monte Carlo only).
        executor: where the keyframes' tasks run (default: here); the result does not depend on it.
    Raises:
        InputError: a bad option (named).
    """
    check_association_args(draws, seed, importance, clutter_per_km, gate_probability)
    positions = tuple(sorted(int(i) for i in suite))
    model = "slam" if map_sigma_m is None else "map"
    assoc = AssociationModel(problem, model=model, gate_probability=gate_probability)
    cones = _cones(problem, positions)
    # the keyframe's candidates: the widest reach of a measurement of the suite (its measured range up
    # to RANGE_SIGMAS σ_r past its sensor's range; _pairs narrows it per measurement)
    reach = (
        CANDIDATE_SCALE
        * max(
            (
                c.range_m + RANGE_SIGMAS * (c.sigma_range_const_m + c.sigma_range_quad_per_m * c.range_m**2)
                for c in cones
            ),
            default=0.0,
        )
        + CANDIDATE_MARGIN_M
        + 10.0
    )
    route, corridor = _route(problem)
    half = max((c.range_m for c in cones), default=0.0)
    hook = _Cases(assoc, cones, reach, route if clutter_per_km > 0 else np.zeros((0, 2)), half + corridor)
    forward_pass(problem, positions, map_sigma_m=map_sigma_m, on_prediction=hook)
    spec = IntegritySpec(gate_probability=gate_probability)
    alert = (spec.alert_lateral_m, spec.alert_longitudinal_m, math.radians(spec.alert_heading_deg))
    per_m2 = (
        clutter_per_km / 1000.0 / (2.0 * corridor) if clutter_per_km > 0 and corridor > 0 else 0.0
    )  # per m² of corridor
    tasks = tuple(
        Task(
            keyframe=c.keyframe,
            draws=draws,
            seed=seed,
            gate=assoc.gate,
            importance=bool(importance),
            clutter_per_m2=per_m2,
            corridor_m=corridor,
            alert_m_rad=alert,
        )
        for c in hook.cases
    )
    plan = Plan("association keyframe", run_case, tasks, states=tuple(hook.cases), state_of=tuple(range(len(tasks))))
    outcomes: list[KeyframeOutcome] = execute(plan, executor, progress=progress)
    return AssociationCheck(
        label=label,
        suite=problem.library.suite_ids(positions),
        model=model,
        map_sigma_m=map_sigma_m,
        gate_probability=gate_probability,
        draws=draws,
        seed=seed,
        importance_sampling=bool(importance),
        sampling=IMPORTANCE_SAMPLING if importance else PLAIN_MONTE_CARLO,
        clutter_per_km=float(clutter_per_km),
        corridor_m=corridor,
        shift=SHIFT_NOTE,
        **_measured(problem, positions, hook, outcomes, clutter=clutter_per_km > 0),
    )


def run_case(case: KeyframeCase, task: Task) -> KeyframeOutcome:
    """The plan's step: one keyframe's draws (a module-level function: pickled by name)."""
    return associate_keyframe(case, task)


def _ci(obs: float, se: float, wrong: int, n: int) -> tuple[float, float]:
    """99 % interval: Clopper–Pearson on counts (``wrong`` ≥ 0), else normal ± Z99 se."""
    if wrong >= 0:
        lo = 0.0 if wrong == 0 else float(beta.ppf(0.005, wrong, n - wrong + 1))
        hi = 1.0 if wrong == n else float(beta.ppf(0.995, wrong + 1, n - wrong))
        return lo, hi
    return max(0.0, obs - Z99 * se), obs + Z99 * se


def calibration_bins(rows: tuple[AssociationKeyframe, ...]) -> tuple[CalibrationBin, ...]:
    """The keyframes pooled by decade of predicted estimate (:data:`BIN_EDGES`), with 99 % intervals."""
    out = []
    est = np.array([r.predicted_estimate for r in rows])
    for lo, hi in zip(BIN_EDGES[:-1], BIN_EDGES[1:]):
        pick = [r for r, e in zip(rows, est) if lo <= e < hi or (hi == 1.0 and e == 1.0)]
        if not pick:
            continue
        n = sum(r.draws for r in pick)
        plain = all(r.wrong_draws >= 0 for r in pick)
        if plain:
            k = sum(r.wrong_draws for r in pick)
            obs = k / n
            ci = _ci(obs, 0.0, k, n)
        else:
            obs = float(np.mean([r.observed for r in pick]))
            se = math.sqrt(sum(r.standard_error**2 for r in pick)) / len(pick)
            ci = _ci(obs, se, -1, n)
        out.append(
            CalibrationBin(
                lo=lo,
                hi=hi,
                keyframes=len(pick),
                predicted=float(np.mean([r.predicted_estimate for r in pick])),
                bound=float(np.mean([r.predicted_bound for r in pick])),
                observed=obs,
                ci_low=ci[0],
                ci_high=ci[1],
            )
        )
    return tuple(out)


def _resolved(r: AssociationKeyframe) -> bool:
    if r.wrong_draws >= 0:
        return r.wrong_draws >= RESOLVE_COUNT
    return r.observed > 0 and r.standard_error <= RESOLVE_RELATIVE_SE * r.observed


def _measured(
    problem: Problem, positions: tuple[int, ...], hook: _Cases, outcomes: list[KeyframeOutcome], *, clutter: bool
) -> dict[str, Any]:
    """What the draws measured beside what the integrity engine predicted: the fields of an
    :class:`AssociationCheck` after its settings (per keyframe, per sensor, the calibration bins, the
    rates per hour and the counts), by name. ``clutter``: whether the draws had clutter."""
    rows = tuple(
        AssociationKeyframe(
            keyframe=o.keyframe,
            n_measurements=len(c.landmark),
            predicted_estimate=e,
            predicted_bound=b,
            observed=o.p_wrong,
            standard_error=o.standard_error,
            wrong_draws=o.wrong_draws,
            draws=o.draws,
            observed_clutter=o.p_wrong_clutter if clutter else math.nan,
            shift_lateral_m=o.shift_lateral_m,
            shift_longitudinal_m=o.shift_longitudinal_m,
            shift_heading_deg=o.shift_heading_deg,
            p_beyond_alert=o.p_beyond_alert,
        )
        for o, c, e, b in zip(outcomes, hook.cases, hook.estimate, hook.bound)
    )
    k = max(1, len(rows))
    lib = problem.library
    sensors = tuple(
        SensorAssociation(
            sensor=lib[p].id,
            predicted_per_keyframe=sum(d[p] for d in hook.per_sensor) / k,
            observed_per_keyframe=sum(dict(o.wrong_per_sensor).get(p, 0.0) for o in outcomes) / k,
        )
        for p in positions
    )
    resolved = [r for r in rows if _resolved(r)]
    within = sum(1 for r in resolved if r.observed / 2.0 <= r.predicted_estimate <= 2.0 * r.observed)
    below = sum(1 for r in rows if r.predicted_bound < _ci(r.observed, r.standard_error, r.wrong_draws, r.draws)[0])
    n_h = keyframes_per_hour(problem)
    return dict(
        keyframes=rows,
        sensors=sensors,
        bins=calibration_bins(rows),
        keyframes_per_hour=n_h,
        predicted_per_hour=n_h * float(np.mean(hook.estimate)) if rows else 0.0,
        bound_per_hour=n_h * float(np.mean(hook.bound)) if rows else 0.0,
        observed_per_hour=n_h * float(np.mean([r.observed for r in rows])) if rows else 0.0,
        resolved=len(resolved),
        within_factor_2=within,
        bound_below_lower=below,
    )
