"""Integrity of a suite on a route: P(error beyond the alert limits), protection levels, per hour.

Per keyframe k, with σ the car's own 1σ after keyframe k's used measurements (the filter's
``filtered`` covariance; Pose2 tangent: x along the car = longitudinal, y = lateral) and the
association risk bound of :mod:`~sensorsel.information.integrity.association` at the prediction:

    P(error beyond the limits at k) ≤ P(beyond | right association) + P(a wrong association at k)
    P(beyond | right association) ≤ Σ_c 2 Φ(−AL_c / σ_c),  c ∈ {lateral, longitudinal, heading}

(a union over the components, each Gaussian with zero mean). ``integrity_risk[k]`` is that sum
(capped at 1); the wrong-association term is the bound (a safety case signs the bound), the
estimate is reported beside it.

Allocation over time: at n_h keyframes per hour (the route's keyframe rate), an hour's risk is at
most the sum of its keyframes' (a union bound over an hour's keyframes, however correlated), so a
requirement I_h per hour (Reid et al.: 10⁻⁸/h) is met when n_h × the mean of ``integrity_risk``
over the route's keyframes is ≤ I_h (``integrity_risk_per_hour``), and each keyframe's allocation is
I_k = I_h / n_h. Protection levels at I_k: the fault-free share I_ff = I_k − P(wrong association at
k) split equally over the three components, PL_c = σ_c Φ⁻¹(1 − I_ff / 6) (two-sided); when the
association risk alone exceeds I_k no protection level can be given: PL = inf.

The design lever (``max_association_risk``): a measurement whose bound exceeds it is not used (the
forward pass's ``use``): its information is lost, and it cannot be mis-associated. Which
measurements were left out is recorded per keyframe and sensor.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.special import ndtr, ndtri

from sensorsel.errors import InputError
from sensorsel.information.filtering import FilterPass, KeyframeMeasurements, Prediction, forward_pass
from sensorsel.information.integrity.association import AssociationModel, MeasurementRisk, Pending, keyframe_risk
from sensorsel.io.results import result_kind
from sensorsel.model.problem import Problem

__all__ = [
    "IntegritySpec",
    "LeftOut",
    "RouteIntegrity",
    "SensorAssociation",
    "integrity_and_pass",
    "route_integrity",
    "tail_risk",
    "protection_levels",
    "keyframes_per_hour",
]


@dataclass(frozen=True)
class IntegritySpec:
    """What integrity is judged against (defaults: Reid et al.'s local streets, 10⁻⁸ per hour).

    Attributes:
        integrity_risk: the allowed P(error beyond an alert limit, undetected) per hour of driving.
        alert_lateral_m, alert_longitudinal_m: alert limits [m].
        alert_heading_deg: alert limit on the heading [deg].
        gate_probability: the associator's χ²₂ gate probability.
        max_association_risk: the lever: measurements whose association risk bound exceeds it are
            not used (None: every measurement is used).
    """

    integrity_risk: float = 1e-8
    alert_lateral_m: float = 0.29
    alert_longitudinal_m: float = 0.29
    alert_heading_deg: float = 0.50
    gate_probability: float = 0.9999
    max_association_risk: float | None = None

    def __post_init__(self) -> None:
        def bad(x: float) -> bool:
            return not (isinstance(x, (int, float)) and math.isfinite(x))

        if bad(self.integrity_risk) or not 0.0 < self.integrity_risk < 1.0:
            raise InputError(f"--integrity-risk {self.integrity_risk}: a probability per hour strictly between 0 and 1")
        for opt, v in (
            ("--alert-lateral", self.alert_lateral_m),
            ("--alert-longitudinal", self.alert_longitudinal_m),
            ("--alert-heading", self.alert_heading_deg),
        ):
            if bad(v) or v <= 0.0:
                raise InputError(f"{opt} {v}: an alert limit must be a positive, finite number")
        if bad(self.gate_probability) or not 0.0 < self.gate_probability < 1.0:
            raise InputError(f"--gate-probability {self.gate_probability}: a probability strictly between 0 and 1")
        m = self.max_association_risk
        if m is not None and (bad(m) or not 0.0 < m < 1.0):
            raise InputError(f"--max-association-risk {m}: a probability strictly between 0 and 1")


@dataclass(frozen=True)
class LeftOut:
    """Measurements the lever left out at one keyframe, of one sensor (its id), and how many."""

    keyframe: int
    sensor: str
    count: int


@dataclass(frozen=True)
class SensorAssociation:
    """One sensor's association risk over a route (its used measurements only).

    Attributes:
        sensor: its id.
        measurements: measurements it made; used: those used.
        expected_wrong: the sum of their estimated P(wrong association): the expected number of
            wrong associations over the route.
        worst_bound: the largest bound of one of its measurements.
        expected_wrong_bound: the sum of their bounds: a bound on the expected number of wrong
            associations over the route (each measurement's probability is at most its bound).
    """

    sensor: str
    measurements: int
    used: int
    expected_wrong: float
    worst_bound: float
    expected_wrong_bound: float = 0.0


@result_kind("integrity")
@dataclass(frozen=True)
class RouteIntegrity:
    """The integrity of one suite on one route, per keyframe (module docstring for the formulas).

    Attributes:
        route: the route's name.
        model: ``"map"`` or ``"slam"``; map_sigma_m the map's std [m] (None in SLAM).
        estimate: always ``"filter"``: the car's own covariance as it drives.
        spec: what it was judged against.
        keyframes_per_hour: n_h.
        p_wrong_association: (K,) bound on P(at least one wrong association) at each keyframe.
        p_wrong_association_estimate: (K,) its calibrated estimate.
        integrity_risk: (K,) bound on P(error beyond an alert limit) at each keyframe.
        protection_level_lateral_m, protection_level_longitudinal_m: (K,) at the per-keyframe
            allocation [m] (inf where the association risk alone exceeds it).
        integrity_risk_per_hour: n_h × the mean of ``integrity_risk``.
        n_measured, n_used: (K,) measurements the suite made and used.
        left_out: what the lever left out, per keyframe and sensor.
        lateral_sigma_m, longitudinal_sigma_m, heading_sigma_deg: (K,) the car's 1σ after each
            keyframe's used measurements (the filter; with the lever, what is used) [m, m, deg].
        p_error_tail: (K,) P(error beyond an alert limit | right association) (its bound).
        by_sensor: each sensor's association risk over the route, in library order.
    """

    route: str
    model: str
    map_sigma_m: float | None
    spec: IntegritySpec
    keyframes_per_hour: float
    p_wrong_association: tuple[float, ...]
    p_wrong_association_estimate: tuple[float, ...]
    integrity_risk: tuple[float, ...]
    protection_level_lateral_m: tuple[float, ...]
    protection_level_longitudinal_m: tuple[float, ...]
    integrity_risk_per_hour: float
    n_measured: tuple[int, ...] = ()
    n_used: tuple[int, ...] = ()
    left_out: tuple[LeftOut, ...] = ()
    estimate: str = "filter"
    lateral_sigma_m: tuple[float, ...] = ()
    longitudinal_sigma_m: tuple[float, ...] = ()
    heading_sigma_deg: tuple[float, ...] = ()
    p_error_tail: tuple[float, ...] = ()
    by_sensor: tuple[SensorAssociation, ...] = ()

    @property
    def meets(self) -> bool:
        """Whether the route's risk per hour is within the specification's."""
        return self.integrity_risk_per_hour <= self.spec.integrity_risk

    def line(self) -> str:
        """One short line (≲ 100 characters): the risk per hour against the requirement and its two
        parts (association, error tail), the worst keyframe's association bound, the median protection
        levels (lateral/longitudinal, and at how many keyframes one exists when not at all), and what
        the lever left out. The rest (alert limits, estimates, per-sensor risks, σ) is in the record."""
        pw = np.asarray(self.p_wrong_association)
        s = self.spec
        n_h = self.keyframes_per_hour
        assoc_h = n_h * float(np.mean(pw)) if pw.size else 0.0
        tail_h = n_h * float(np.mean(self.p_error_tail)) if self.p_error_tail else 0.0
        parts = [
            f"{self.integrity_risk_per_hour:.2g}/h {'meets' if self.meets else 'FAILS'} {s.integrity_risk:.2g}/h "
            f"(assoc. {assoc_h:.2g} + tail {tail_h:.2g})"
        ]
        if pw.size:
            worst = int(np.argmax(pw))
            parts.append(f"P(wrong) ≤ {pw[worst]:.2g} (kf {worst})")
        lat, lon = np.asarray(self.protection_level_lateral_m), np.asarray(self.protection_level_longitudinal_m)
        finite = np.isfinite(lat)
        if finite.any():
            where = "" if finite.all() else f" ({int(finite.sum())}/{lat.size} kf)"
            parts.append(f"PL {np.median(lat[finite]):.2f}/{np.median(lon[finite]):.2f} m{where}")
        elif lat.size:
            parts.append("no PL")
        if s.max_association_risk is not None:
            parts.append(f"left out {sum(x.count for x in self.left_out)}/{sum(self.n_measured)}")
        return "; ".join(parts)


def _fmt(x: float) -> str:
    return "inf" if math.isinf(x) else f"{x:.3f}"


def keyframes_per_hour(problem: Problem) -> float:
    """n_h: the route's keyframes per hour (its mean keyframe rate; 3600 for a single keyframe)."""
    kf = problem.scenario.keyframes
    dur = kf.duration_s
    return 3600.0 * (len(kf.times) - 1) / dur if len(kf.times) > 1 and dur > 0 else 3600.0


def _sigmas(cov: np.ndarray) -> np.ndarray:
    """(K, 3) 1σ (longitudinal [m], lateral [m], heading [deg]) of (K, 3, 3) pose covariances."""
    d = np.sqrt(np.maximum(np.diagonal(np.asarray(cov, float), axis1=1, axis2=2), 0.0))
    return np.column_stack([d[:, 0], d[:, 1], np.degrees(d[:, 2])])


def tail_risk(covariances: np.ndarray, spec: IntegritySpec) -> np.ndarray:
    """(K,) P(error beyond an alert limit | right association) ≤ Σ_c 2 Φ(−AL_c/σ_c) (capped at 1)."""
    sig = _sigmas(covariances)
    limits = np.array([spec.alert_longitudinal_m, spec.alert_lateral_m, spec.alert_heading_deg])
    with np.errstate(divide="ignore"):
        z = np.where(sig > 0, limits[None, :] / np.where(sig > 0, sig, 1.0), np.inf)
    return np.minimum(1.0, np.sum(2.0 * ndtr(-z), axis=1))


def protection_levels(covariances: np.ndarray, p_wrong: np.ndarray, allocation: float) -> tuple[np.ndarray, np.ndarray]:
    """(lateral, longitudinal) (K,) protection levels [m] at the per-keyframe ``allocation``: the
    fault-free share allocation − p_wrong split over three components, PL = σ Φ⁻¹(1 − share/6);
    inf where p_wrong ≥ allocation."""
    sig = _sigmas(covariances)
    free = allocation - np.asarray(p_wrong, float)
    ok = free > 0
    z = np.full(len(free), np.inf)
    z[ok] = -ndtri(free[ok] / 6.0)
    with np.errstate(invalid="ignore"):
        lat = np.where(ok, z * sig[:, 1], np.inf)
        lon = np.where(ok, z * sig[:, 0], np.inf)
    return lat, lon


@dataclass
class _Collector:
    """The ``use`` hook of one forward pass. Without the lever it only takes each keyframe's
    snapshot (the predictions do not depend on the risks) and :meth:`finish` computes every
    keyframe's risks at once; with it, each keyframe's risks are computed at the keyframe (its mask
    changes what the pass predicts next). Either way the same numbers."""

    model: AssociationModel
    threshold: float | None
    sensor_ids: tuple[str, ...]
    n_keyframes: int = 0
    #: without the lever: the keyframes kept, their risks computed in batches
    pending: Pending | None = None
    #: with it: per keyframe with measurements, its measurements, risks and mask
    meas: list[KeyframeMeasurements] = field(default_factory=list)
    risks: list[MeasurementRisk] = field(default_factory=list)
    masks: list[np.ndarray] = field(default_factory=list)

    def __post_init__(self) -> None:
        if self.threshold is None:
            self.pending = Pending(self.model)

    def __call__(self, prediction: Prediction, meas: KeyframeMeasurements) -> np.ndarray:
        if self.pending is not None:
            self.pending.add(prediction, meas)
            return np.ones(len(meas.landmark), bool)
        if len(meas.landmark) == 0:
            return np.ones(0, bool)
        r = self.model.risks_of([self.model.snapshot(prediction, meas)])
        self.meas.append(meas)
        self.risks.append(r)
        self.masks.append(r.bound <= self.threshold)
        return self.masks[-1]

    def finish(self) -> tuple[np.ndarray, np.ndarray, list[LeftOut], np.ndarray]:
        """(bound (K,), estimate (K,), what the lever left out, per library sensor (S, 5): measurements
        made, used, Σ estimate, max bound, Σ bound), per keyframe from its used measurements."""
        bound, estimate = np.zeros(self.n_keyframes), np.zeros(self.n_keyframes)
        per_sensor = np.zeros((len(self.sensor_ids), 5))
        left_out: list[LeftOut] = []
        if self.pending is not None:
            r = self.pending.result()
            self.meas, est_all, bnd_all = self.pending.meas, r.estimate, r.bound
            mask = np.ones(len(est_all), bool)
        else:
            est_all = np.concatenate([x.estimate for x in self.risks]) if self.risks else np.zeros(0)
            bnd_all = np.concatenate([x.bound for x in self.risks]) if self.risks else np.zeros(0)
            mask = np.concatenate(self.masks) if self.masks else np.zeros(0, bool)
        if not self.meas:
            return bound, estimate, left_out, per_sensor
        sensor = np.concatenate([np.asarray(g.sensor, np.int64) for g in self.meas])
        used, est_used, bnd_used = sensor[mask], est_all[mask], bnd_all[mask]
        # the same additions in the same order as keyframe by keyframe
        np.add.at(per_sensor[:, 0], sensor, 1.0)
        np.add.at(per_sensor[:, 1], used, 1.0)
        np.add.at(per_sensor[:, 2], used, est_used)
        np.maximum.at(per_sensor[:, 3], used, bnd_used)
        np.add.at(per_sensor[:, 4], used, bnd_used)
        lo = 0
        for g in self.meas:  # each keyframe's own sums (np.sum's order, as before)
            hi = lo + len(g.landmark)
            keep = mask[lo:hi]
            est, bnd = est_all[lo:hi], bnd_all[lo:hi]  # without the lever, the slices as they are
            if not keep.all():
                est, bnd = est[keep], bnd[keep]
                sensors, counts = np.unique(sensor[lo:hi][~keep], return_counts=True)
                left_out.extend(
                    LeftOut(int(g.keyframe), self.sensor_ids[int(s)], int(c))
                    for s, c in zip(sensors.tolist(), counts.tolist())
                )
            estimate[g.keyframe], bound[g.keyframe] = keyframe_risk(est, bnd)
            lo = hi
        return bound, estimate, left_out, per_sensor


def route_integrity(
    problem: Problem,
    suite: Iterable[int],
    spec: IntegritySpec | None = None,
    *,
    map_sigma_m: float | None = None,
    route: str = "",
    passes: list[FilterPass] | None = None,
) -> RouteIntegrity:
    """The integrity of ``suite`` (library positions) on the problem's route: one forward pass (the
    filter: the car's covariance as it drives) whose ``use`` hook keeps what each keyframe's
    association risks need (and, with the lever, computes them at the keyframe to leave risky
    measurements out); then every keyframe's risks, the tail, the protection levels and the risk per
    hour. ``map_sigma_m``: localizing in a map known to that std [m]; None: SLAM. ``passes``: a list
    the forward pass is appended to (:func:`integrity_and_pass`)."""
    spec = spec or IntegritySpec()
    model = "slam" if map_sigma_m is None else "map"
    assoc = AssociationModel(problem, model=model, gate_probability=spec.gate_probability)
    hook = _Collector(
        assoc,
        spec.max_association_risk,
        tuple(s.id for s in problem.library.sensors),
        n_keyframes=problem.scenario.n_poses,
    )
    fp: FilterPass = forward_pass(problem, suite, map_sigma_m=map_sigma_m, use=hook)
    if passes is not None:
        passes.append(fp)
    p_wrong, p_estimate, left_out, per_sensor = hook.finish()
    n_h = keyframes_per_hour(problem)
    tail = tail_risk(fp.filtered, spec)
    risk = np.minimum(1.0, tail + p_wrong)
    lat, lon = protection_levels(fp.filtered, p_wrong, spec.integrity_risk / n_h)
    sig = _sigmas(fp.filtered)
    return RouteIntegrity(
        route=route or problem.scenario.name,
        model=model,
        map_sigma_m=map_sigma_m,
        spec=spec,
        keyframes_per_hour=n_h,
        p_wrong_association=tuple(p_wrong.tolist()),
        p_wrong_association_estimate=tuple(p_estimate.tolist()),
        integrity_risk=tuple(risk.tolist()),
        protection_level_lateral_m=tuple(lat.tolist()),
        protection_level_longitudinal_m=tuple(lon.tolist()),
        integrity_risk_per_hour=float(n_h * risk.mean()) if risk.size else 0.0,
        n_measured=tuple(int(x) for x in fp.n_measured),
        n_used=tuple(int(x) for x in fp.n_used),
        left_out=tuple(left_out),
        lateral_sigma_m=tuple(sig[:, 1].tolist()),
        longitudinal_sigma_m=tuple(sig[:, 0].tolist()),
        heading_sigma_deg=tuple(sig[:, 2].tolist()),
        p_error_tail=tuple(tail.tolist()),
        by_sensor=tuple(
            SensorAssociation(hook.sensor_ids[i], int(row[0]), int(row[1]), float(row[2]), float(row[3]), float(row[4]))
            for i, row in enumerate(per_sensor)
            if row[0] > 0
        ),
    )


def integrity_and_pass(
    problem: Problem, suite: Iterable[int], spec: IntegritySpec | None = None, **where: Any
) -> tuple[RouteIntegrity, FilterPass]:
    """:func:`route_integrity` (``where``: its keywords) and the forward pass it ran: without the
    lever its ``filtered`` are the suite's filtered covariances (every measurement used), what its
    accuracy needs too."""
    passes: list[FilterPass] = []
    return route_integrity(problem, suite, spec, passes=passes, **where), passes[0]
