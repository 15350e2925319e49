"""A localization specification in metres and degrees, and whether a suite's accuracy meets it.

A specification bounds the lateral and longitudinal position error [m] and the heading error [deg]
of the car, each optional, as 95 % bounds (1.96σ, the way Reid et al. state them) or as 1σ bounds
(``sigma=True``), at a share of the route's keyframes (``at``: 1.0, every keyframe, by default).

The presets are the passenger-car requirements of Reid, Houts, Cammarata et al., "Localization
Requirements for Autonomous Vehicles", SAE Int. J. CAV 2(3), 2019 (arXiv 1906.01061), 95 % values:

    local-streets   0.10 m lateral, 0.10 m longitudinal, 0.17° heading
    freeway         0.20 m lateral, 0.48 m longitudinal, 0.51° heading

Meeting a specification is monotone in the suite: a sensor added only adds information, so every
marginal variance only falls (Λ' ⪰ Λ ⇒ Λ'⁻¹ ⪯ Λ⁻¹, and so on every diagonal block), and a keyframe
that met a bound keeps meeting it. "At a share p of the keyframes" is read as an order statistic (at
least ⌈p K⌉ keyframes meet each bound), not an interpolated percentile, so monotonicity is exact.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from sensorsel.errors import InputError
from sensorsel.information.evaluators.accuracy import Z95, RouteAccuracy
from sensorsel.io.inputs import Checker, Map, read_yaml
from sensorsel.model.domain import DomainError

__all__ = [
    "PRESETS",
    "DEFAULT_MAP_SIGMA_M",
    "Specification",
    "SpecificationError",
    "RouteVerdict",
    "RouteRequirement",
    "preset",
    "load_specification_file",
    "specifications_for",
    "verdict",
    "covariance_verdict",
    "component_sigmas",
]

#: the default accuracy of a prior map's landmarks [m] for ``require`` (assumed: survey-grade
#: mobile-mapping LiDAR maps are stated to a few centimetres relative accuracy; see
#: docs/guide-requirements.md, "The localization model")
DEFAULT_MAP_SIGMA_M = 0.05

#: the components a specification may bound: (field, unit)
BOUNDS = (("lateral", "m"), ("longitudinal", "m"), ("heading", "deg"))


class SpecificationError(DomainError):
    """A specification file is malformed: names the file, the key path and the line."""


@dataclass(frozen=True)
class Specification:
    """What a suite must achieve on a route.

    Attributes:
        lateral: bound on the lateral position error [m], or None (not required).
        longitudinal: bound on the longitudinal position error [m], or None.
        heading: bound on the heading error [deg], or None.
        sigma: the bounds are 1σ (True) or 95 % bounds, 1.96σ (False, default).
        at: the share of the route's keyframes that must meet every bound, in (0, 1].
        name: a preset's name, or "custom".
        margin: the share of each bound demanded to spare, in [0, 1): a suite must keep each
            error within ``(1 - margin) ×`` the bound (``--margin 10%``: within 90 % of it).
    """

    lateral: float | None = None
    longitudinal: float | None = None
    heading: float | None = None
    sigma: bool = False
    at: float = 1.0
    name: str = "custom"
    margin: float = 0.0

    def __post_init__(self) -> None:
        for field, _ in BOUNDS:
            v = getattr(self, field)
            if v is not None and not (
                isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v > 0
            ):
                raise InputError(f"--{field}: a requirement must be a positive finite number, got {v!r}")
        if not (isinstance(self.at, (int, float)) and math.isfinite(self.at) and 0.0 < self.at <= 1.0):
            raise InputError(
                f"--at: the share of keyframes must be above 0 % and at most 100 %, got {100 * self.at:g} %"
            )
        if not (isinstance(self.margin, (int, float)) and math.isfinite(self.margin) and 0.0 <= self.margin < 1.0):
            raise InputError(
                f"--margin: the share of each bound to spare must be at least 0 % and below 100 %, "
                f"got {100 * self.margin:g} %"
            )
        if all(getattr(self, f) is None for f, _ in BOUNDS):
            raise InputError("no requirement given: name --lateral, --longitudinal, --heading, --preset or --spec")

    @property
    def factor(self) -> float:
        """What a 1σ is multiplied by before it is compared with a bound: 1 or :data:`Z95`."""
        return 1.0 if self.sigma else Z95

    def bounds(self) -> list[tuple[str, float, str]]:
        """The bounded components as demanded: (component, bound × (1 - margin), unit)."""
        return [
            (f, float(getattr(self, f)) * (1.0 - self.margin), u) for f, u in BOUNDS if getattr(self, f) is not None
        ]

    def stated_bounds(self) -> list[tuple[str, float, str]]:
        """The bounded components as stated (before the margin): (component, bound, unit)."""
        return [(f, float(getattr(self, f)), u) for f, u in BOUNDS if getattr(self, f) is not None]

    def describe(self) -> str:
        """e.g. "local-streets: lateral 0.1 m, longitudinal 0.1 m, heading 0.17 deg (95 %, every keyframe)"."""
        parts = ", ".join(f"{c} {b:g} {u}" for c, b, u in self.stated_bounds())
        where = "every keyframe" if self.at >= 1.0 else f"{100 * self.at:g} % of the keyframes"
        spare = f", {100 * self.margin:g} % to spare" if self.margin else ""
        return f"{self.name}: {parts} ({'1σ' if self.sigma else '95 %'}, {where}{spare})"


#: name -> the specification (95 % bounds, every keyframe): Reid et al. 2019, passenger cars
PRESETS: dict[str, Specification] = {
    "local-streets": Specification(lateral=0.10, longitudinal=0.10, heading=0.17, name="local-streets"),
    "freeway": Specification(lateral=0.20, longitudinal=0.48, heading=0.51, name="freeway"),
}


def preset(name: str) -> Specification:
    """The preset ``name`` (an InputError naming the presets when there is none)."""
    try:
        return PRESETS[name]
    except KeyError:
        raise InputError(f"--preset: unknown preset {name!r}; available: {', '.join(PRESETS)}") from None


@dataclass(frozen=True)
class RouteVerdict:
    """How one route's accuracy stands against its specification.

    Attributes:
        route: the route's name.
        meets: every bounded component is met at the required share of keyframes.
        violation: how far from meeting (0 when met): the largest, over the components, of the ratio
            of the error at the required rank of keyframes to its bound, minus 1.
        worst: per bounded component, (component, error at the required rank of keyframes [m or
            deg, 1σ or 95 % as the specification], its bound, the keyframes that fail it).
    """

    route: str
    meets: bool
    violation: float
    worst: tuple[tuple[str, float, float, tuple[int, ...]], ...]

    def failing(self) -> str:
        """Words for what fails, e.g. "lateral 0.21 m > 0.10 m at 12 keyframes (first 4)"."""
        out = []
        for comp, err, bound, bad in self.worst:
            if err > bound:
                unit = "deg" if comp == "heading" else "m"
                out.append(f"{comp} {err:.3f} {unit} > {bound:g} at {len(bad)} keyframes (first {bad[0]})")
        return "; ".join(out)


@dataclass(frozen=True)
class RouteRequirement:
    """One route's specification and how a suite stands against it.

    Attributes:
        route: the route's name.
        specification: what the route requires.
        accuracy: the suite's accuracy there (per keyframe, 1σ).
        verdict: whether it meets the specification, by how much it misses, where.
    """

    route: str
    specification: Specification
    accuracy: RouteAccuracy
    verdict: RouteVerdict


def _rank(at: float, k: int) -> int:
    """How many of ``k`` keyframes must meet a bound at a share ``at`` of them (at least 1)."""
    return max(1, math.ceil(at * k - 1e-9))


def at_rank(values: np.ndarray, at: float) -> float:
    """The value a share ``at`` of the keyframes is within: the ⌈at K⌉-th smallest (0 for no keyframe)."""
    v = np.asarray(values, dtype=float)
    return float(np.sort(v)[_rank(at, len(v)) - 1]) if len(v) else 0.0


def verdict(accuracy: RouteAccuracy, spec: Specification) -> RouteVerdict:
    """Whether ``accuracy`` meets ``spec`` (see the module's documentation for the rank rule)."""
    worst = []
    violation = 0.0
    for comp, bound, _ in spec.bounds():
        err = spec.factor * accuracy.sigmas(comp)
        at_rank_err = at_rank(err, spec.at)
        bad = tuple(int(i) for i in np.flatnonzero(err > bound))
        worst.append((comp, at_rank_err, bound, bad))
        violation = max(violation, at_rank_err / bound - 1.0)
    return RouteVerdict(accuracy.route, violation <= 0.0, max(violation, 0.0), tuple(worst))


def component_sigmas(covariances: np.ndarray) -> dict[str, np.ndarray]:
    """Each component's σ at each of the (K, 3, 3) pose ``covariances`` (Pose2 tangent: x forward,
    y left [m], θ [rad]): longitudinal and lateral [m], heading [deg], (K,) each; what every verdict
    of a specification compares with its limits."""
    cov = np.asarray(covariances, dtype=float)
    diag = np.sqrt(np.maximum(np.diagonal(cov, axis1=1, axis2=2), 0.0))  # (K, 3): x forward, y left, θ
    return {"longitudinal": diag[:, 0], "lateral": diag[:, 1], "heading": np.degrees(diag[:, 2])}


def covariance_verdict(covariances: np.ndarray, spec: Specification) -> tuple[bool, float]:
    """(meets, violation) of (K, 3, 3) pose covariances against ``spec``: the same numbers as
    :func:`verdict` of their :class:`RouteAccuracy` (the same operations on the same σ), without
    building it: what the solver asks thousands of times."""
    sig = component_sigmas(covariances)
    violation = 0.0
    for comp, bound, _ in spec.bounds():
        violation = max(violation, at_rank(spec.factor * sig[comp], spec.at) / bound - 1.0)
    return violation <= 0.0, max(violation, 0.0)


# ---------------------------------------------------------------------------------------- files

_KEYS = ("preset", "lateral", "longitudinal", "heading", "sigma", "at")


def _one(chk: Checker, m: Any, key: str, line: int, base: Specification | None) -> Specification:
    """A specification from a mapping (``preset`` plus overrides) or a preset's name."""
    if isinstance(m, str):
        if m not in PRESETS:
            chk.fail(key, f"unknown preset {m!r}; available: {', '.join(PRESETS)}", line)
        return PRESETS[m]
    if not isinstance(m, Map):
        chk.fail(key, f"expected a preset's name or a mapping of {', '.join(_KEYS)}, got {m!r}", line)
    chk.keys(m, key, _KEYS)
    spec = base
    if "preset" in m:
        spec = _one(chk, m["preset"], f"{key}.preset" if key else "preset", m.lines["preset"], None)
    changes: dict[str, Any] = {}
    for field, _ in BOUNDS:
        if field in m:
            changes[field] = chk.number(m[field], f"{key}.{field}" if key else field, m.lines[field])
    if "sigma" in m:
        if not isinstance(m["sigma"], bool):
            chk.fail(
                f"{key}.sigma" if key else "sigma", f"expected true or false, got {m['sigma']!r}", m.lines["sigma"]
            )
        changes["sigma"] = m["sigma"]
    if "at" in m:
        at = chk.number(m["at"], f"{key}.at" if key else "at", m.lines["at"])
        if at > 100:
            chk.fail(
                f"{key}.at" if key else "at",
                f"expected a percentage of keyframes in (0, 100], got {m['at']!r}",
                m.lines["at"],
            )
        changes["at"] = at / 100.0
    if spec is None:
        if not any(f in changes for f, _ in BOUNDS):
            chk.fail(key, "names no requirement: give a preset or lateral, longitudinal, heading", line)
        spec = Specification(
            lateral=changes.get("lateral"),
            longitudinal=changes.get("longitudinal"),
            heading=changes.get("heading"),
            sigma=changes.get("sigma", False),
            at=changes.get("at", 1.0),
        )
        return spec
    return replace(spec, **changes, name=spec.name if not changes else f"{spec.name}*")


def load_specification_file(path: str | Path) -> tuple[Specification | None, dict[str, Specification]]:
    """A specification file: a default for every route and per-route overrides (a domain whose
    routes have different road classes)::

        preset: local-streets        # or lateral/longitudinal/heading [m, m, deg], sigma, at [%]
        routes:
          "03": freeway              # a preset, or a mapping of the same keys
          "00": {lateral: 0.15}

    Returns:
        (the default, or None when only routes are named; {route name: its specification}).

    Raises:
        SpecificationError: naming the file, the key and the line of the first problem.
    """
    p = Path(path)
    data = read_yaml(p, SpecificationError, "specification file")
    chk = Checker(p, SpecificationError)
    if not isinstance(data, Map):
        chk.fail("", f"expected a mapping of {', '.join(_KEYS + ('routes',))}, got {type(data).__name__}", None)
    routes_node = data.get("routes")
    top = Map({k: v for k, v in data.items() if k != "routes"})
    top.line, top.lines = data.line, {k: v for k, v in data.lines.items() if k != "routes"}
    default = _one(chk, top, "", data.line, None) if top else None
    per_route: dict[str, Specification] = {}
    if routes_node is not None:
        if not isinstance(routes_node, Map):
            chk.fail("routes", "expected a mapping of route name -> specification", data.lines["routes"])
        for name, value in routes_node.items():
            per_route[str(name)] = _one(chk, value, f"routes.{name}", routes_node.lines[name], default)
    if default is None and not per_route:
        chk.fail("", "names no requirement: give a preset or lateral, longitudinal, heading", data.line)
    return default, per_route


def specifications_for(
    routes: list[str], default: Specification | None, per_route: Mapping[str, Specification], source: str = "--spec"
) -> list[Specification]:
    """Each route's specification (its own, else the default). A domain member in a condition,
    ``route/condition``, takes its own entry, else its route's. A name in ``per_route`` that is
    neither a member nor a route, or a member with no specification, is an InputError naming it."""

    def own(r: str) -> Specification | None:
        return per_route.get(r, per_route.get(r.split("/")[0]))

    names = set(routes) | {r.split("/")[0] for r in routes}
    unknown = sorted(set(per_route) - names)
    if unknown:
        raise InputError(f"{source}: route(s) {', '.join(unknown)} are not in the domain (routes: {', '.join(routes)})")
    missing = [r for r in routes if own(r) is None and default is None]
    if missing:
        raise InputError(f"{source}: no specification for route(s) {', '.join(missing)}: give a default at the top")
    return [own(r) or default for r in routes]  # type: ignore[misc]
