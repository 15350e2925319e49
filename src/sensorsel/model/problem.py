"""The selection problem: a sensor library, a scenario, the graph's fixed noise, and what each sensor sees.

Built once per (library, scenario) and shared by every evaluator and selector.
"""

from __future__ import annotations

import hashlib
import json
import math
import warnings
from collections.abc import Iterable
from dataclasses import asdict, dataclass, field, replace
from functools import cached_property
from pathlib import Path
from typing import ClassVar, Literal

import numpy as np

from sensorsel.errors import InputError, ResultFileError, SensorselWarning
from sensorsel.model.conditions import Condition, condition_digest
from sensorsel.model.domain import load_domain_file, load_domain_scenarios
from sensorsel.model.library import SensorLibrary, load_library
from sensorsel.model.osm.track import (
    load_geo_scenario,
)  # load_scenario, and GPX routes and OSM landmarks (--landmarks osm:FILE)
from sensorsel.model.scenario import Scenario, ScenarioSpec, distance_to_route
from sensorsel.model.sensing import (
    BYTES_PER_MEASUREMENT,
    SensorObservations,
    apply_condition,
    estimate_measurements,
    observe,
)

# Limits and checks (docs/scenarios.md, "Limits and checks"):
MAX_MEASUREMENT_BYTES = 2 * 2**30  # most memory the measurements of a problem may take (estimated before observing)
#: above this share of a map out of every sensor's reach, the map is likely not the route's: a warning, not a note
MOSTLY_OUT_OF_REACH = 0.5


class MapOutOfReachWarning(SensorselWarning):
    """Most of a landmark map is out of every sensor's reach from the route (another city, frame or origin?)."""


@dataclass(frozen=True)
class GraphSettings:
    """The parts of the SLAM factor graph that do not depend on the sensor suite.

    Attributes:
        odometry_sigmas: std of each odometry step between keyframes (x [m], y [m], heading [rad]),
            in the frame of the earlier pose. Default 0.1 m, 0.1 m, 0.01 rad per 1 s keyframe step:
            wheel odometry of about 1% of a ~10 m step and half a degree of heading, a typical
            production car's wheel-speed + yaw-rate odometry (the paper does not state its choice).
        first_pose_sigmas: std of the prior on the first keyframe (anchors the gauge freedom).
        landmark_prior_sigma_m: std of the weak prior on every landmark [m]. It keeps the
            information matrix positive definite; its contribution cancels in the score
            f(S) = log det L(S) - log det L(empty), so an unseen landmark adds exactly 0.
    """

    odometry_sigmas: tuple[float, float, float] = (0.1, 0.1, 0.01)
    first_pose_sigmas: tuple[float, float, float] = (0.01, 0.01, 0.001)
    landmark_prior_sigma_m: float = 100.0

    def __post_init__(self) -> None:
        for name in ("odometry_sigmas", "first_pose_sigmas"):
            v = getattr(self, name)
            if len(v) != 3 or not all(isinstance(s, (int, float)) and math.isfinite(s) and s > 0 for s in v):
                raise InputError(f"graph settings: {name} must be three positive numbers, got {v!r}")
        s = self.landmark_prior_sigma_m
        if not (isinstance(s, (int, float)) and math.isfinite(s) and s > 0):
            raise InputError(f"graph settings: landmark_prior_sigma_m must be positive, got {s!r}")


@dataclass(frozen=True)
class Fingerprint:
    """What a result was computed on, by content: sha256 digests (hex) of four parts of a problem.

    The same data under another path or name gives the same fingerprint; one changed price, one
    moved landmark or another keyframe rate gives another.

    Attributes:
        library: every placed sensor in library order: its id, index, mounting, and its model's
            numbers (type, range, field of view, noise, cost); not the file's path nor model names.
        route: the keyframes' poses and timestamps (so the route and the keyframe rate).
        landmarks: the landmarks' coordinates, in order.
        settings: the graph settings (odometry, first-pose and landmark prior noise).
        condition: the operating condition's parameters and the physics applied to them
            (:func:`sensorsel.model.conditions.condition_digest`); None for clear (or no condition).
    """

    library: str
    route: str
    landmarks: str
    settings: str
    condition: str | None = None

    #: (field, what a difference means), in the order differences are reported.
    PARTS = (
        ("library", "another library: sensor costs or models differ"),
        ("route", "another route or keyframe rate"),
        ("landmarks", "another landmark map"),
        ("settings", "other graph settings"),
        ("condition", "another operating condition (night, rain, fog, snow) or other condition physics"),
    )

    @classmethod
    def of(
        cls, library: SensorLibrary, scenario: Scenario, settings: GraphSettings, condition: Condition | None
    ) -> Fingerprint:
        """The fingerprint of a problem's parts. ``condition`` has no default: a result computed under
        a condition must never be fingerprinted as a clear one (None: clear)."""
        sensors = []
        for s in library.sensors:
            # resources (power, mass, data rate) do not change a score: a constrained result records
            # the limits and resource values it used itself (sensorsel.model.constraints)
            model = {k: v for k, v in asdict(s.model).items() if k not in ("name", "resources")}
            sensors.append(
                {"id": s.id, "index": s.index, "clock": s.clock, "mount_angle_rad": s.mount_angle_rad, "model": model}
            )
        kf = scenario.keyframes
        return cls(
            library=_json_digest(sensors),
            route=_array_digest(kf.poses, kf.times),
            landmarks=_array_digest(scenario.landmarks),
            settings=_json_digest(asdict(settings)),
            condition=condition_digest(condition, library.physics),
        )

    def differences(self, other: Fingerprint, ignore: tuple[str, ...] = ()) -> list[str]:
        """What differs between two fingerprints, in words (empty when they are equal), but the parts in ``ignore``."""
        return [what for name, what in self.PARTS if name not in ignore and getattr(self, name) != getattr(other, name)]


def _json_digest(obj: object) -> str:
    return hashlib.sha256(json.dumps(obj, sort_keys=True, allow_nan=False).encode("utf-8")).hexdigest()


def _array_digest(*arrays: np.ndarray) -> str:
    h = hashlib.sha256()
    for a in arrays:
        a = np.ascontiguousarray(a, dtype=np.float64)
        h.update(str(a.shape).encode())
        h.update(a.tobytes())
    return h.hexdigest()


@dataclass(frozen=True)
class ProblemInfo:
    """What a result was computed on (recorded in every result file).

    Attributes:
        scenario: the scenario's name.
        n_poses: keyframes.
        n_landmarks: landmarks.
        route_length_m: length of the full-rate route [m].
        duration_s: its duration [s].
        landmark_source: where the landmarks came from (a file, or "generated (seed N)").
        library: the library file.
        n_sensors: sensors in the library.
        spec: the scenario as the user stated it (None when the problem was built from objects).
        settings: the graph's noise settings.
        fingerprint: digests of the library, route, landmarks and settings by content
            (:class:`Fingerprint`); None in files written before fingerprints existed.
        condition: the operating condition's label (:attr:`Condition.label`); None for clear.
    """

    scenario: str
    n_poses: int
    n_landmarks: int
    route_length_m: float
    duration_s: float
    landmark_source: str
    library: str
    n_sensors: int
    spec: ScenarioSpec | None = None
    settings: GraphSettings = field(default_factory=GraphSettings)
    fingerprint: Fingerprint | None = None
    condition: str | None = None

    #: what a result says it was computed on (:data:`TARGET_KINDS`); not a field: never written.
    kind: ClassVar[Literal["route"]] = "route"
    #: the unit of a score on this target: the log det of the information matrix [nats].
    score_unit: ClassVar[str] = "nats"

    @property
    def routes(self) -> tuple[RouteInfo, ...]:
        """This route as a domain's members record them: one, named by its scenario, weight 1 (as
        :attr:`Problem.routes`)."""
        return (RouteInfo(self.scenario, 1.0, "hours", self),)

    @property
    def route_keys(self) -> tuple[tuple[str, float, str], ...]:
        """What identifies each route of a result besides its problem: see :attr:`Problem.route_keys`."""
        return ONE_ROUTE_KEYS

    @property
    def headline(self) -> str:
        """What this result was computed on, in a few words (a figure's title)."""
        return f"scenario {self.scenario}"


#: A one-route target's :attr:`Problem.route_keys`: a route's name is not part of what it is (the same
#: data under another name is the same problem), so a one-route result names no route.
ONE_ROUTE_KEYS: tuple[tuple[str, float, str], ...] = (("", 1.0, ""),)

#: Each target kind (``kind``) as a message names it.
TARGET_KINDS = {"route": "one route", "domain": "a domain"}


@dataclass(frozen=True, eq=False)
class Problem:
    """A library on a scenario: the input of every evaluator.

    Attributes:
        library: the placed sensors (positions 0..n-1 are the sensors' handles everywhere).
        scenario: keyframes and landmarks.
        settings: odometry and prior noise.
        observations: what each sensor sees, one entry per library sensor.
        spec: what the scenario was loaded from (set by :func:`load_problem`; None when the
            problem was built from objects). Results record it through :attr:`info`.
        condition: the operating condition the observations are under (:func:`with_condition`);
            None for clear (a neutral condition is stored as None).
    """

    library: SensorLibrary
    scenario: Scenario
    settings: GraphSettings = field(default_factory=GraphSettings)
    observations: tuple[SensorObservations, ...] = ()
    spec: ScenarioSpec | None = None
    condition: Condition | None = None

    def __repr__(self) -> str:
        sc = self.scenario
        when = f", {self.condition.label}" if self.condition is not None else ""
        return (
            f"Problem({sc.name!r}{when}: {sc.n_poses} keyframes, {sc.n_landmarks} landmarks, "
            f"{self.n_sensors} sensors, {sum(len(o) for o in self.observations)} measurements)"
        )

    #: what a result says it was computed on (:data:`TARGET_KINDS`).
    kind: ClassVar[Literal["route"]] = "route"

    @property
    def n_sensors(self) -> int:
        return len(self.library)

    @property
    def routes(self) -> tuple[DomainRoute, ...]:
        """This route as an operating domain's members: one, named by its scenario, weight 1 (so
        that a run reads ``target.routes`` alike on a route and on a :class:`Domain`)."""
        return (DomainRoute(self.scenario.name, self, 1.0),)

    @property
    def route_keys(self) -> tuple[tuple[str, float, str], ...]:
        """Each route's ``(name, weight, unit)`` as a stored result's inputs name it, in :attr:`routes`
        order: :data:`ONE_ROUTE_KEYS` here (a route's name is not part of what it is), a domain's
        members by their names, weights and units (:attr:`Domain.route_keys`)."""
        return ONE_ROUTE_KEYS

    @property
    def time_line(self) -> Problem | None:
        """The route whose keyframes are this target's one time line: this problem (a run that splits
        time into periods, or keeps one route's stored result, reads it here). A :class:`Domain` has
        none (each member has its own): None there."""
        return self

    @property
    def info(self) -> ProblemInfo:
        """What this problem is, as results record it."""
        sc = self.scenario
        route = sc.route or sc.keyframes
        return ProblemInfo(
            scenario=sc.name,
            n_poses=sc.n_poses,
            n_landmarks=sc.n_landmarks,
            route_length_m=round(route.length_m, 3),
            duration_s=round(route.duration_s, 3),
            landmark_source=sc.landmark_source,
            library=self.library.source,
            n_sensors=self.n_sensors,
            spec=self.spec,
            settings=self.settings,
            fingerprint=self.fingerprint,
            condition=self.condition.label if self.condition is not None else None,
        )

    @cached_property
    def fingerprint(self) -> Fingerprint:
        """What this problem is, by content (computed once)."""
        return self.fingerprint_on(self.scenario)

    def fingerprint_on(self, scenario: Scenario) -> Fingerprint:
        """The fingerprint of this problem's library, graph settings and condition on ``scenario``
        (a period of its route): what a result computed on that part depends on."""
        return Fingerprint.of(self.library, scenario, self.settings, self.condition)

    @cached_property
    def landmarks_in_reach(self) -> np.ndarray:
        """Sorted indices of the landmarks some library sensor sees from some keyframe."""
        seen = [o.landmark for o in self.observations if len(o)]
        return np.unique(np.concatenate(seen)) if seen else np.zeros(0, dtype=int)

    @cached_property
    def measured_pairs(self) -> np.ndarray:
        """Sorted unique ``landmark * n_poses + keyframe`` of every (landmark, keyframe) some library
        sensor measures (computed once): whether any suite can measure a landmark within a span of
        keyframes is then two binary searches."""
        n = self.scenario.n_poses
        pairs = [
            np.asarray(o.landmark, np.int64) * n + np.asarray(o.pose, np.int64) for o in self.observations if len(o)
        ]
        return np.unique(np.concatenate(pairs)) if pairs else np.zeros(0, np.int64)

    def measured_within(self, landmarks: np.ndarray, first: int, last: int) -> np.ndarray:
        """(m,) bool: whether some library sensor measures each of ``landmarks`` (m,) at a keyframe
        in ``first`` .. ``last`` (inclusive)."""
        n, keys = self.scenario.n_poses, self.measured_pairs
        base = np.asarray(landmarks, np.int64) * n
        return np.searchsorted(keys, base + min(last, n - 1), side="right") > np.searchsorted(keys, base + first)

    @property
    def n_landmarks_out_of_reach(self) -> int:
        """Landmarks no sensor of the library sees from any keyframe: they add nothing to any suite."""
        return self.scenario.n_landmarks - len(self.landmarks_in_reach)

    @property
    def notes(self) -> list[str]:
        """Lines a command prints on stderr: the scenario's notes (:func:`scenario_notes`), then how
        many landmarks are out of every sensor's reach, when some are."""
        notes = list(self.scenario.notes)
        out, m = self.n_landmarks_out_of_reach, self.scenario.n_landmarks
        if out and self.observations and out <= MOSTLY_OUT_OF_REACH * m:  # more: a warning (check_reach)
            notes.append(
                f"landmarks: {out} of {m} landmarks ({self.scenario.landmark_source}) are out of every sensor's reach "
                f"from every keyframe: they add nothing to any suite"
            )
        return notes

    def resolve_suite(self, suite: str | Iterable[str | int]) -> tuple[int, ...]:
        """Sorted library positions of a suite given as ids or positions (:meth:`SensorLibrary.resolve_suite`)."""
        return self.library.resolve_suite(suite)


class ProblemMismatchWarning(SensorselWarning):
    """A result of another problem (or without a fingerprint) used anyway, because of ``force``."""


def check_result_problem(
    recorded: TargetInfo | None,
    problem: Target,
    path: str | Path,
    *,
    force: bool = False,
    what: str = "the result",
    ignore: tuple[str, ...] = (),
) -> None:
    """Check that a result read from ``path`` was computed on ``problem``: the same library (sensor
    models and costs), route and keyframe rate, landmarks and graph settings, by content (see
    :class:`Fingerprint`; the paths and names the files had do not matter). For a domain: the same
    routes, in the same order, with the same weights, each checked so.

    Args:
        recorded: the ``problem`` the result records (its :class:`ProblemInfo` or :class:`DomainInfo`).
        force: warn (:class:`ProblemMismatchWarning`) instead of refusing.
        what: how to name the result in the message.
        ignore: parts of the :class:`Fingerprint` not compared (``simulate --start-sigmas`` changes
            the settings on purpose: ``("settings",)``).
    Raises:
        ResultFileError: (without ``force``) the result names no problem, records no fingerprint (a
            file of an older sensorsel), or was computed on another problem; the message names the
            file and what differs.
    """
    hint = (
        "give the same library, route, rate, landmark, noise and --condition options (or --domain file) as the run "
        "that wrote it, or --force to use it anyway"
    )
    if recorded is not None and recorded.kind == problem.kind and recorded.route_keys == problem.route_keys:
        unchecked = [r.name for r in recorded.routes if r.problem.fingerprint is None]
    else:
        unchecked = []
    if recorded is None or unchecked:
        why = (
            "records no problem it was computed on"
            if recorded is None
            else "records no fingerprint of what it was computed on (written before fingerprints)"
        )
        _refuse(
            path,
            f"{what} {why}, so it cannot be checked against this library, route and landmarks",
            "rerun the command that wrote it, or give --force to use it anyway",
            force,
        )
        return
    diffs = target_differences(recorded, problem, ignore)
    if diffs:
        _refuse(path, f"{what} was computed on another {_NOUNS[problem.kind]} ({'; '.join(diffs)})", hint, force)


#: Each target kind as "another ..." names it.
_NOUNS = {"route": "problem", "domain": "domain"}


def target_differences(recorded: TargetInfo, target: Target, ignore: tuple[str, ...] = ()) -> list[str]:
    """How the target a result or checkpoint records differs from ``target``, in words (empty: the
    same): another kind (one route against a domain), other routes, weights or units (a domain's
    :attr:`~Domain.route_keys`; a route's name is not part of what it is), then each route's
    :class:`Fingerprint` differences (but the parts in ``ignore``), prefixed by the member's name
    in a domain. A route recorded without a fingerprint (a file written before fingerprints) is a
    difference: it is never taken for this one."""
    if recorded.kind != target.kind:
        return [f"it was computed on {TARGET_KINDS[recorded.kind]}, this run is on {TARGET_KINDS[target.kind]}"]
    theirs, ours = list(recorded.route_keys), list(target.route_keys)
    if theirs != ours:
        return [f"routes and weights {theirs} against {ours}"]
    out: list[str] = []
    for (name, _, _), r_theirs, r_ours in zip(ours, recorded.routes, target.routes):
        fp = r_theirs.problem.fingerprint
        diffs = (
            ["it records no fingerprint of its route"]
            if fp is None
            else fp.differences(r_ours.problem.fingerprint, ignore)
        )
        out += [f"route {name}: {d}" if name else d for d in diffs]
    return out


def _refuse(path: str | Path, msg: str, hint: str, force: bool) -> None:
    if force:
        warnings.warn(f"{path}: {msg}; used anyway (--force)", ProblemMismatchWarning, stacklevel=3)
    else:
        raise ResultFileError(path, f"{msg}; {hint}")


def build_problem(
    library: SensorLibrary,
    scenario: Scenario,
    settings: GraphSettings | None = None,
    *,
    spec: ScenarioSpec | None = None,
    condition: Condition | None = None,
) -> Problem:
    """Compute what every sensor of ``library`` sees along ``scenario`` and bundle it.

    ``spec``: what the scenario was loaded from, recorded as the problem's provenance.
    ``condition``: the operating condition (default: ``spec.condition``, else clear); what the
    sensors see under it is derived from what they see in clear air (:func:`with_condition`).

    Raises:
        InputError: the measurements would take more than :data:`MAX_MEASUREMENT_BYTES` (estimated
            from the landmarks within each sensor's range and its field of view, before anything is
            allocated).
    """
    check_problem_size(library, scenario)
    if condition is None and spec is not None:
        condition = spec.condition
    clear_spec = replace(spec, condition=None) if spec is not None and spec.condition is not None else spec
    clear = Problem(library, scenario, settings or GraphSettings(), observe(library, scenario), clear_spec)
    return with_condition(clear, condition)


def with_condition(problem: Problem, condition: Condition | None) -> Problem:
    """``problem`` under an operating condition: each sensor's measurements derived from the
    problem's (:func:`sensorsel.model.sensing.apply_condition`: no sensor observes again, nothing is
    linearized by GTSAM), the condition recorded in the problem, its spec (so that a worker
    rebuilding the problem from its spec applies it again) and its fingerprint.

    ``problem`` must be clear (its own condition None). A neutral condition (or None) returns
    ``problem`` itself: results bit-identical to no condition.

    Raises:
        InputError: ``problem`` is already under a condition (conditions are not stacked).
    """
    if condition is None or condition.neutral:
        return problem
    if problem.condition is not None:
        raise InputError(
            f"problem {problem.scenario.name} is already under the condition {problem.condition.label}; "
            "apply a condition to the clear problem"
        )
    spec = replace(problem.spec, condition=condition) if problem.spec is not None else None
    return Problem(
        problem.library,
        problem.scenario,
        problem.settings,
        apply_condition(problem.library, problem.observations, condition),
        spec,
        condition,
    )


def check_problem_size(library: SensorLibrary, scenario: Scenario, limit_bytes: int | None = None) -> int:
    """Estimated bytes of the measurements of ``library`` along ``scenario``; InputError beyond
    ``limit_bytes`` (default :data:`MAX_MEASUREMENT_BYTES`). The estimate counts the (keyframe,
    landmark) pairs within each sensor's range, times the share of the circle its field of view
    covers, times :data:`BYTES_PER_MEASUREMENT`."""
    limit_bytes = MAX_MEASUREMENT_BYTES if limit_bytes is None else limit_bytes
    n = estimate_measurements(library, scenario, fov_share=True)
    need = n * BYTES_PER_MEASUREMENT
    if need > limit_bytes:
        raise InputError(
            f"problem too large: {scenario.n_poses:,} keyframes of {scenario.name} and "
            f"{scenario.n_landmarks:,} landmarks "
            f"({scenario.landmark_source}) give about {n:,} measurements for the {len(library)} sensors, "
            f"{need / 2**30:.1f} GiB, beyond the limit of {limit_bytes / 2**30:g} GiB: use a lower keyframe "
            "rate (--rate) "
            "or fewer landmarks"
        )
    return need


def check_reach(problem: Problem) -> None:
    """InputError when no sensor of the library sees any landmark from any keyframe: the map is out
    of the route's reach (another frame or origin?), and every suite would score 0. A
    :class:`MapOutOfReachWarning` when more than :data:`MOSTLY_OUT_OF_REACH` of it is: a map that
    mostly misses the route is likely another place's (a score on the few landmarks it shares
    with the route says little)."""
    sc = problem.scenario
    out, m = problem.n_landmarks_out_of_reach, sc.n_landmarks
    if m and problem.n_sensors and len(problem.landmarks_in_reach) and out > MOSTLY_OUT_OF_REACH * m:
        route = sc.route or sc.keyframes
        warnings.warn(
            f"landmarks {sc.landmark_source}: {out} of {m} landmarks ({100 * out / m:.0f} %) are out of every "
            f"sensor's reach from every keyframe of the route {route.source}: is this the route's map (not another "
            "city's, frame or origin)? Only the other "
            f"{m - out} count",
            MapOutOfReachWarning,
            stacklevel=3,
        )
    if sc.n_landmarks and problem.n_sensors and not len(problem.landmarks_in_reach):
        route = sc.route or sc.keyframes
        nearest = float(distance_to_route(sc.landmarks, route.poses[:, :2]).min())
        longest = max(s.model.range_m for s in problem.library)
        raise InputError(
            f"landmarks {sc.landmark_source}: none of the {sc.n_landmarks} landmarks is within reach of any sensor "
            f"from any keyframe of the route {route.source} (nearest {nearest:,.0f} m from the route, longest "
            "sensor range "
            f"{longest:g} m): is the map in the route's frame? Every suite would score 0"
        )


def load_problem(
    spec: ScenarioSpec | None = None, library: str | Path | None = None, settings: GraphSettings | None = None
) -> Problem:
    """Read the library (default: Table I) and the scenario (default: the bundled fixture), and
    compute what each sensor sees. The problem remembers ``spec``: results computed on it record it.

    Raises:
        InputError: besides the scenario's and library's own errors, a problem too large
            (:func:`check_problem_size`) or a map no sensor can see from the route (:func:`check_reach`).
    """
    spec = spec or ScenarioSpec()
    problem = build_problem(load_library(library), load_geo_scenario(spec), settings, spec=spec)
    check_reach(problem)
    return problem


# ----------------------------------------------------------------------------------------- domains


@dataclass(frozen=True, eq=False)
class DomainRoute:
    """One member of an operating domain (a route, or a route in one condition), as a problem.

    Attributes:
        name: the member's name in the domain (unique): the route's, or ``route/condition``.
        problem: the library on this route's scenario (under the member's condition).
        weight: its share of the fleet's driving, in ``unit`` (> 0).
        unit: "hours" or "km" (the domain file's ``weight_unit``).
        route: the route's name ("" : ``name``).
        condition: the condition's name ("" : the domain has no conditions).
    """

    name: str
    problem: Problem
    weight: float
    unit: str = "hours"
    route: str = ""
    condition: str = ""

    @property
    def route_name(self) -> str:
        """The route this member drives (its name without the condition)."""
        return self.route or self.name


@dataclass(frozen=True)
class RouteInfo:
    """What a domain result records of each member: its name, weight and problem, and its route
    and condition ("" when the domain has no conditions)."""

    name: str
    weight: float
    unit: str
    problem: ProblemInfo
    route: str = ""
    condition: str = ""


@dataclass(frozen=True)
class DomainInfo:
    """What a domain result was computed on: the domain file and each route."""

    source: str
    routes: tuple[RouteInfo, ...]

    kind: ClassVar[Literal["domain"]] = "domain"
    #: a domain's score is a weighted share of each route's best: a number without a unit.
    score_unit: ClassVar[str] = ""

    @property
    def route_keys(self) -> tuple[tuple[str, float, str], ...]:
        """Each member's ``(name, weight, unit)`` (:attr:`Domain.route_keys`)."""
        return tuple((r.name, r.weight, r.unit) for r in self.routes)

    @property
    def headline(self) -> str:
        """What this result was computed on, in a few words (a figure's title)."""
        return f"domain of {len(self.routes)} routes"


@dataclass(frozen=True, eq=False)
class Domain:
    """An operating domain: routes scored with one sensor library, one suite for all of them.

    Attributes:
        routes: the routes, in the domain file's order.
        source: the domain file (or a description).

    Raises:
        InputError: no route, a name used twice, a weight that is not positive and finite, or routes
            built on different libraries (a suite's ids would mean different sensors).
    """

    routes: tuple[DomainRoute, ...]
    source: str = "<memory>"

    kind: ClassVar[Literal["domain"]] = "domain"

    def __post_init__(self) -> None:
        if not self.routes:
            raise InputError(f"domain {self.source}: no route")
        names = [r.name for r in self.routes]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise InputError(f"domain {self.source}: route name(s) {', '.join(dup)} used twice")
        for r in self.routes:
            if not (math.isfinite(r.weight) and r.weight > 0):
                raise InputError(f"domain {self.source}: route {r.name!r} has weight {r.weight!r}; expected > 0")
        first = self.routes[0].problem.library
        for r in self.routes[1:]:
            if r.problem.library.sensors != first.sensors:
                raise InputError(
                    f"domain {self.source}: route {r.name!r} uses another sensor library than route "
                    f"{self.routes[0].name!r}; one suite needs one library"
                )

    def __repr__(self) -> str:
        return f"Domain({len(self.routes)} routes from {self.source!r}: {', '.join(r.name for r in self.routes)})"

    @property
    def library(self) -> SensorLibrary:
        return self.routes[0].problem.library

    @property
    def n_sensors(self) -> int:
        return len(self.library)

    @property
    def info(self) -> DomainInfo:
        return DomainInfo(
            self.source,
            tuple(RouteInfo(r.name, r.weight, r.unit, r.problem.info, r.route, r.condition) for r in self.routes),
        )

    @property
    def route_keys(self) -> tuple[tuple[str, float, str], ...]:
        """Each member's ``(name, weight, unit)``: a domain's result is one of these named, weighted routes."""
        return tuple((r.name, r.weight, r.unit) for r in self.routes)

    @property
    def time_line(self) -> Problem | None:
        """None: a domain has no one time line (:attr:`Problem.time_line`), even of one member."""
        return None

    @property
    def condition_names(self) -> tuple[str, ...]:
        """The conditions of the domain's members, in first-seen order (empty without conditions)."""
        return tuple(dict.fromkeys(r.condition for r in self.routes if r.condition))

    def in_conditions(self, names: str | Iterable[str]) -> Domain:
        """The domain of the members in the named conditions only (``"clear,rain"`` or a list), their
        weights unchanged (a share of the whole driving).

        Raises:
            InputError: a name that is none of the domain's conditions, or no name.
        """
        wanted = [t.strip() for t in names.split(",")] if isinstance(names, str) else [str(t).strip() for t in names]
        wanted = [t for t in wanted if t]
        known = self.condition_names
        if not wanted:
            raise InputError(f"domain {self.source}: no condition named (its conditions: {', '.join(known) or 'none'})")
        for name in wanted:
            if name not in known:
                raise InputError(
                    f"domain {self.source}: unknown condition {name!r} (its conditions: "
                    f"{', '.join(known) or 'none: the file has no conditions section'})"
                )
        return Domain(tuple(r for r in self.routes if r.condition in wanted), f"{self.source} [{','.join(wanted)}]")

    def resolve_suite(self, suite: str | Iterable[str | int]) -> tuple[int, ...]:
        """Sorted library positions of a suite given as ids or positions."""
        return self.library.resolve_suite(suite)

    def route(self, name: str) -> DomainRoute:
        for r in self.routes:
            if r.name == name:
                return r
        raise InputError(
            f"domain {self.source}: no route named {name!r} (routes: {', '.join(r.name for r in self.routes)})"
        )


def load_domain(path: str | Path, library: str | Path | None = None, settings: GraphSettings | None = None) -> Domain:
    """Read an operating-domain file (:mod:`sensorsel.model.domain`), load every route and compute what each
    sensor sees on it. ``library`` overrides the file's ``library`` (default: the paper's Table I)."""
    spec = load_domain_file(path)
    lib = load_library(library if library is not None else spec.library)
    routes = []
    for d in load_domain_scenarios(spec):
        problem = build_problem(lib, d.scenario, settings, spec=d.spec)
        check_reach(problem)  # a route no sensor can measure has no share of a best to be scored on
        if not d.conditions:
            routes.append(DomainRoute(d.name, problem, d.weight, d.unit))
            continue
        # each (route, condition) member derived from the route's clear measurements, observed once
        for condition, share in d.conditions:
            routes.append(
                DomainRoute(
                    f"{d.name}/{condition.name}",
                    with_condition(problem, condition),
                    d.weight * share,
                    d.unit,
                    d.name,
                    condition.name,
                )
            )
    return Domain(tuple(routes), spec.source)


#: what a run is computed on: one route, or an operating domain of several
Target = Problem | Domain
#: what a result records of its target
TargetInfo = ProblemInfo | DomainInfo
