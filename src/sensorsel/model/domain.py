"""Operating domains: the routes a car drives, each with its landmarks and its share of the driving.

An operating-domain file is YAML (read safely, a key repeated in one mapping refused)::

    # shared settings (all optional)
    kitti_root: ../shared/kitti      # KITTI odometry dataset/ folder (default: $SENSORSEL_KITTI_ROOT)
    keyframe_rate_hz: 1.0            # keyframes per second along every route
    library: sensor_library.yaml     # sensor library (default: the paper's Table I)
    clearance_m: 3.0                 # drop landmarks closer than this to their route (default: keep, counted)
    weight_unit: km                  # hours (default) or km: the unit of every route's weight
    routes:
      - name: city                   # required, unique
        seq: "03"                    # a KITTI sequence (in quotes: 03 unquoted is the number 3) ...
        kitti_root: other/kitti      #   ... optionally under its own folder
        landmarks: real              # real (default for a sequence with a pole map), synthetic,
                                     # {synthetic: {seed: 3}}, or a landmark CSV file
        weight: {km: 12}             # {km: X}, {hours: X} or a plain number in weight_unit
      - name: my-drive
        route: drives/a.txt          # or a route file ...
        format: tum                  #   kitti, tum or csv (default: sniffed from the file)
        times: drives/a_times.txt    #   timestamps of a KITTI pose file
        landmarks: maps/a.csv
      - name: suburb
        fixture: suburb              # or a bundled fixture
      - name: helsinki-morning
        route: tracks/morning.gpx    # a GPS track (GPX): placed by its own latitudes and longitudes
        osm: helsinki.osm.pbf        # OpenStreetMap landmarks near the route (a file or a list of them)
        osm_classes: street_lamp,tree  #   their classes (default: all pole-like ones)
        osm_reach_m: 100             #   within this distance of the route [m]
      - name: survey-drive
        route: drives/b.csv          # a route in a local frame ...
        georef: 60.17,24.94,90       #   ... placed by LAT,LON,BEARING of its origin (or utm:ZONE)
        osm: helsinki.osm.pbf        #   for its OSM landmarks, merged with ...
        landmarks: maps/b.csv        #   ... a survey (an OSM landmark within 2 m of one is dropped)

Operating conditions (optional; :mod:`sensorsel.model.conditions`): the shares of driving time spent
in each, for every route, optionally overridden per route; the rest of the driving is clear::

    conditions:
      - {name: night, night: true, share: 0.25}
      - {name: rain, rain_mm_h: 5, share: 0.08}
      - {name: fog, fog_visibility_m: 200, share: 0.005}
    routes:
      - {name: city, seq: "00", conditions: {night: 0.3}}   # this route: 30 % at night

The domain's members are then (route, condition) pairs, named ``route/condition`` ("city/night",
"city/clear"), each weighing the route's weight times the condition's share; a share of 0 leaves
the member out. Without ``conditions`` the members are the routes themselves.

Relative paths are relative to the domain file's folder. A route's weight is its share of the
driving the suite is chosen for; omitted, it is the route's own duration in hours (its length in km
when ``weight_unit: km``). Every weight of a domain is in its ``weight_unit``: a weight given in the
other unit is refused rather than mixed.

Every error names the file, the key path (``routes[2].weight``) and the line of the problem.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from sensorsel.errors import InputError, SensorselError
from sensorsel.io.inputs import Checker, Map, Seq, read_yaml
from sensorsel.model.conditions import CLEAR, CONDITION_KEYS, Condition
from sensorsel.model.osm import GeoRef, is_gpx, load_geo_scenario, parse_classes
from sensorsel.model.scenario import (
    KITTI_ROOT_ENV,
    REAL,
    ROUTE_FORMATS,
    SYNTHETIC,
    Scenario,
    ScenarioSpec,
    fixture_names,
    kitti_map_path,
    load_scenario,
)

WEIGHT_UNITS = ("hours", "km")
_TOP_KEYS = ("routes", "kitti_root", "keyframe_rate_hz", "library", "clearance_m", "weight_unit", "conditions")
#: the keys of a route's entry (also a study's target: sensorsel.designs.study)
ROUTE_KEYS = (
    "name",
    "seq",
    "kitti_root",
    "route",
    "format",
    "times",
    "fixture",
    "landmarks",
    "weight",
    "conditions",
    "georef",
    "osm",
    "osm_classes",
    "osm_reach_m",
)
_GEO_KEYS = ("georef", "osm", "osm_classes", "osm_reach_m")
_CONDITION_KEYS = ("name", "share") + CONDITION_KEYS
#: shares of a route's conditions may add up to 1 plus this (round-off of decimal shares)
_SHARE_SLACK = 1e-9


class DomainError(SensorselError):
    """An operating-domain file is malformed: names the file, the key path and the line."""

    def __init__(self, path: str | Path, key: str, message: str, line: int | None = None) -> None:
        self.path = str(path)
        self.key = key
        self.line = line
        where = f"{path}:{line}" if line is not None else f"{path}"
        super().__init__(f"{where}: {key}: {message}" if key else f"{where}: {message}")


@dataclass(frozen=True)
class DomainRoute:
    """One route of an operating domain.

    Attributes:
        name: unique name in the domain.
        spec: the scenario (route, landmarks, keyframe rate, clearance), paths made absolute.
        weight: its share of the driving in the domain's unit; None: the route's own duration
            (hours) or length (km), known once the route is read (:func:`load_domain_scenarios`).
        line: the line of the route's entry in the file.
        conditions: (condition, share of the route's driving) of each member of the route, clear
            first (the rest of the driving, when above 0), then the file's conditions in file order
            (those of share 0 left out); empty when the file has no ``conditions``.
    """

    name: str
    spec: ScenarioSpec
    weight: float | None
    line: int
    conditions: tuple[tuple[Condition, float], ...] = ()


@dataclass(frozen=True)
class DomainSpec:
    """An operating domain as its file states it (see the module's documentation).

    Attributes:
        source: the file.
        routes: its routes, in file order.
        weight_unit: "hours" or "km".
        library: the sensor library file (None: the default Table I).
        keyframe_rate_hz, clearance_m, kitti_root: the shared settings (already in each route's spec).
        conditions: the file's named conditions with their shares (before any route's own), in
            file order; empty without a ``conditions`` section.
    """

    source: str
    routes: tuple[DomainRoute, ...]
    weight_unit: str = "hours"
    library: str | None = None
    keyframe_rate_hz: float = 1.0
    clearance_m: float | None = None
    kitti_root: str | None = None
    conditions: tuple[tuple[Condition, float], ...] = ()

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(r.name for r in self.routes)


@dataclass(frozen=True)
class DomainScenario:
    """A route of a domain, loaded: what the evaluator layer builds one Problem from.

    Attributes:
        name: the route's name (also the scenario's name).
        spec: what the scenario was loaded from (a Problem's provenance).
        scenario: the loaded scenario (its notes say what was assumed, merged or dropped).
        weight: its share of the driving, in ``unit``.
        unit: "hours" or "km".
        conditions: (condition, share) of each of its members (:attr:`DomainRoute.conditions`).
    """

    name: str
    spec: ScenarioSpec
    scenario: Scenario
    weight: float
    unit: str
    conditions: tuple[tuple[Condition, float], ...] = ()


def parse_domain(data: Any, path: str | Path = "<memory>") -> DomainSpec:
    """Validate a parsed domain document (as :func:`load_domain_file` reads it: mappings and lists
    carry their lines) and resolve its paths against the file's folder and ``$SENSORSEL_KITTI_ROOT``.

    Raises:
        DomainError: naming ``path``, the key path and the line of the first problem found.
    """
    path = Path(path)
    c = Checker(path, DomainError)
    if not isinstance(data, Map):
        c.fail(
            "",
            f"expected a mapping with a list of routes (routes: ...), got {type(data).__name__}",
            getattr(data, "line", None),
        )
    c.keys(data, "", _TOP_KEYS)

    def line(key: str) -> int | None:
        return data.lines.get(key)

    root = None
    if "kitti_root" in data:
        root = c.kitti_root(data["kitti_root"], "kitti_root", line("kitti_root"))
    rate = (
        c.number(data["keyframe_rate_hz"], "keyframe_rate_hz", line("keyframe_rate_hz"))
        if "keyframe_rate_hz" in data
        else 1.0
    )
    clearance = (
        c.number(data["clearance_m"], "clearance_m", line("clearance_m"), strict=False)
        if "clearance_m" in data
        else None
    )
    library = c.file(data["library"], "library", line("library")) if "library" in data else None
    unit = data.get("weight_unit", "hours")
    if unit not in WEIGHT_UNITS:
        c.fail("weight_unit", f"expected one of {', '.join(WEIGHT_UNITS)}, got {unit!r}", line("weight_unit"))
    routes_raw = data.get("routes")
    if "routes" not in data:
        c.fail("routes", "missing: expected a list of routes", data.line)
    if not isinstance(routes_raw, Seq) or not routes_raw:
        c.fail("routes", f"expected a non-empty list of routes, got {routes_raw!r}", line("routes"))
    shared = ScenarioSpec(keyframe_rate_hz=rate, clearance_m=clearance)
    conditions = _parse_conditions(c, data["conditions"], line("conditions")) if "conditions" in data else ()
    routes: list[DomainRoute] = []
    seen: dict[str, int] = {}
    for i, raw in enumerate(routes_raw):
        key, rline = f"routes[{i}]", routes_raw.lines[i]
        r = parse_route(c, raw, key, rline, shared, root, unit)
        if isinstance(raw, Map) and "conditions" in raw and not conditions:
            c.fail(
                f"{key}.conditions",
                "a route's shares of conditions need the conditions the file lists (a top-level conditions: section)",
                raw.lines["conditions"],
            )
        if conditions:
            own = raw.get("conditions") if isinstance(raw, Map) else None
            r = replace(
                r,
                conditions=_route_members(
                    c,
                    conditions,
                    own,
                    f"{key}.conditions",
                    raw.lines.get("conditions", rline) if own is not None else line("conditions"),
                ),
            )
        if r.name in seen:
            j = seen[r.name]
            c.fail(
                f"{key}.name", f"duplicate name {r.name!r} (also routes[{j}], line {routes[j].line})", raw.lines["name"]
            )
        seen[r.name] = i
        routes.append(r)
    return DomainSpec(str(path), tuple(routes), unit, library, rate, clearance, root, conditions)


def _parse_conditions(c: Checker, raw: Any, line: int | None) -> tuple[tuple[Condition, float], ...]:
    """The top-level ``conditions`` list: named conditions and their shares of driving time."""
    if not isinstance(raw, Seq) or not raw:
        c.fail(
            "conditions",
            f"expected a list of conditions ({{name: night, night: true, share: 0.25}}), got {raw!r}",
            line,
        )
    out: list[tuple[Condition, float]] = []
    names: dict[str, int] = {}
    for i, item in enumerate(raw):
        key, iline = f"conditions[{i}]", raw.lines[i]
        if not isinstance(item, Map):
            c.fail(
                key,
                f"expected a mapping (name, share, and night, rain_mm_h, fog_visibility_m or snow_mm_h), got {item!r}",
                iline,
            )
        c.keys(item, key, _CONDITION_KEYS)
        at = lambda k, item=item: item.lines.get(k, item.line)  # noqa: E731
        for k in ("name", "share"):
            if k not in item:
                c.fail(f"{key}.{k}", "missing: every condition needs a name and its share of the driving", item.line)
        name = c.string(item["name"], f"{key}.name", at("name"), "a name (text)")
        if name == CLEAR or "/" in name or any(ch in name for ch in "\r\n\t,"):
            why = (
                "clear is the rest of the driving, not listed"
                if name == CLEAR
                else "a name without '/', ',' or line breaks"
            )
            c.fail(f"{key}.name", f"{why}; got {name!r}", at("name"))
        if name in names:
            c.fail(f"{key}.name", f"duplicate condition name {name!r} (also conditions[{names[name]}])", at("name"))
        names[name] = i
        share = c.number(item["share"], f"{key}.share", at("share"), strict=False)
        if share > 1:
            c.fail(f"{key}.share", f"a share of the driving is at most 1, got {item['share']!r}", at("share"))
        values: dict[str, Any] = {}
        if "night" in item:
            if not isinstance(item["night"], bool):
                c.fail(f"{key}.night", f"expected true or false, got {item['night']!r}", at("night"))
            values["night"] = item["night"]
        for k in ("rain_mm_h", "snow_mm_h"):
            if k in item:
                values[k] = c.number(item[k], f"{key}.{k}", at(k), strict=False)
        if "fog_visibility_m" in item:
            values["fog_visibility_m"] = c.number(
                item["fog_visibility_m"], f"{key}.fog_visibility_m", at("fog_visibility_m")
            )
        try:
            cond = Condition(name=name, **values)
        except InputError as exc:
            c.fail(key, str(exc), item.line)
        out.append((cond, share))
    total = sum(share for _, share in out)
    if total > 1 + _SHARE_SLACK:
        c.fail("conditions", f"the shares add up to {total:g}, more than 1 (the whole of the driving)", line)
    return tuple(out)


def _route_members(
    c: Checker, conditions: tuple[tuple[Condition, float], ...], own: Any, key: str, line: int | None
) -> tuple[tuple[Condition, float], ...]:
    """A route's members: clear (the rest) first, then each condition with the route's own share
    (``own``: its ``conditions`` mapping of name -> share) or the file's; shares of 0 left out."""
    shares = {cond.name: share for cond, share in conditions}
    if own is not None:
        if not isinstance(own, Map):
            c.fail(
                key, f"expected a mapping of condition name to this route's share ({{night: 0.3}}), got {own!r}", line
            )
        for name, value in own.items():
            if name not in shares:
                c.fail(
                    f"{key}.{name}",
                    f"unknown condition {name!r}; the file's conditions: {', '.join(shares)}",
                    own.lines.get(name, own.line),
                )
            v = c.number(value, f"{key}.{name}", own.lines.get(name, own.line), strict=False)
            if v > 1:
                c.fail(
                    f"{key}.{name}",
                    f"a share of the driving is at most 1, got {value!r}",
                    own.lines.get(name, own.line),
                )
            shares[name] = v
    total = sum(shares.values())
    if total > 1 + _SHARE_SLACK:
        c.fail(
            key,
            f"the shares of this route's conditions add up to {total:g}, more than 1 (the whole of the driving)",
            line,
        )
    members = []
    rest = 1.0 - total
    if rest > _SHARE_SLACK:
        members.append((Condition(name=CLEAR), rest))
    members += [(cond, shares[cond.name]) for cond, _ in conditions if shares[cond.name] > 0]
    return tuple(members)


def parse_route(
    c: Checker, raw: Any, key: str, rline: int, shared: ScenarioSpec, root: str | None, unit: str
) -> DomainRoute:
    """One route's entry ``raw`` (under the key path ``key``, on line ``rline``), checked by ``c``: the
    route of a domain file, or a study's target (sensorsel.designs.study reads it with this)."""
    if not isinstance(raw, Map):
        c.fail(key, f"expected a mapping (name, seq or route or fixture, landmarks, weight), got {raw!r}", rline)
    c.keys(raw, key, ROUTE_KEYS)
    line = lambda k: raw.lines.get(k, raw.line)  # noqa: E731
    if "name" not in raw:
        c.fail(f"{key}.name", "missing: every route needs a name", raw.line)
    name = raw["name"]
    if not isinstance(name, str) or not name.strip() or any(ch in name for ch in "\r\n\t"):
        hint = " (in quotes: YAML reads 03 as the number 3)" if isinstance(name, (int, float)) else ""
        c.fail(f"{key}.name", f"expected a non-empty line of text, got {name!r}{hint}", line("name"))
    name = name.strip()
    sources = [k for k in ("seq", "route", "fixture") if k in raw]
    if len(sources) != 1:
        c.fail(
            key,
            f"expected exactly one of seq, route, fixture; got {', '.join(sources) or 'none'}",
            max(line(k) for k in sources) if len(sources) > 1 else raw.line,
        )
    source = sources[0]
    for k, only in (("kitti_root", "seq"), ("format", "route"), ("times", "route")):
        if k in raw and source != only:
            c.fail(f"{key}.{k}", f"goes with {only}, not with {source}", line(k))
    spec = replace(shared, name=name)
    own_map = False
    if source == "seq":
        seq = raw["seq"]
        if not isinstance(seq, str) or not seq.strip():
            hint = (
                f' (in quotes: "{seq:02d}"; YAML reads 03 as the number 3)'
                if isinstance(seq, int) and not isinstance(seq, bool)
                else ""
            )
            c.fail(f"{key}.seq", f"expected a sequence name as text, got {seq!r}{hint}", line("seq"))
        seq_root = (
            c.kitti_root(raw["kitti_root"], f"{key}.kitti_root", line("kitti_root")) if "kitti_root" in raw else root
        )
        if seq_root is None:
            env = os.environ.get(KITTI_ROOT_ENV)
            if not env:
                c.fail(
                    f"{key}.seq",
                    f"no KITTI folder: give kitti_root (in the file or this route) or set ${KITTI_ROOT_ENV}",
                    line("seq"),
                )
            seq_root = str(Path(env).resolve())
            if not (Path(seq_root) / "poses").is_dir():
                c.fail(f"{key}.seq", f"${KITTI_ROOT_ENV}={env} is not a KITTI odometry dataset folder", line("seq"))
        poses = Path(seq_root) / "poses" / f"{seq.strip()}.txt"
        if not poses.is_file():
            c.fail(f"{key}.seq", f"sequence {seq!r} not found: no {poses}", line("seq"))
        spec = replace(spec, seq=seq.strip(), kitti_root=seq_root)
        own_map = kitti_map_path(seq_root, seq.strip()).is_file()
    elif source == "route":
        fmt = raw.get("format")
        if "format" in raw and fmt not in ROUTE_FORMATS:
            c.fail(f"{key}.format", f"expected one of {', '.join(ROUTE_FORMATS)}, got {fmt!r}", line("format"))
        times = c.file(raw["times"], f"{key}.times", line("times")) if "times" in raw else None
        if times is not None and fmt not in (None, "kitti"):
            c.fail(
                f"{key}.times", f"timestamps go with a KITTI pose file; a {fmt} route carries its own", line("times")
            )
        spec = replace(spec, route=c.file(raw["route"], f"{key}.route", line("route")), route_format=fmt, times=times)
    else:
        fx = raw["fixture"]
        if fx not in fixture_names():
            c.fail(
                f"{key}.fixture",
                f"unknown fixture {fx!r}; bundled fixtures: {', '.join(fixture_names())}",
                line("fixture"),
            )
        spec = replace(spec, fixture=fx)
        own_map = True
    if "landmarks" in raw:
        spec = _parse_landmarks(c, raw["landmarks"], f"{key}.landmarks", line("landmarks"), spec, source, own_map)
    gpx = source == "route" and spec.route is not None and is_gpx(spec.route)
    if gpx:
        for k in ("format", "times"):
            if k in raw:
                c.fail(
                    f"{key}.{k}", f"the route {spec.route} is a GPX track: it carries its own format and times", line(k)
                )
    if any(k in raw for k in _GEO_KEYS):
        spec = _parse_geo(c, raw, key, line, spec, gpx)
    weight = _parse_weight(c, raw["weight"], f"{key}.weight", line("weight"), unit) if "weight" in raw else None
    return DomainRoute(name, spec, weight, rline)


def _parse_landmarks(
    c: Checker, value: Any, key: str, line: int, spec: ScenarioSpec, source: str, own_map: bool
) -> ScenarioSpec:
    if value == REAL:
        if source != "seq":
            c.fail(
                key,
                f"'real' is a KITTI sequence's pole map; this route is a {source}: give a landmark file or synthetic",
                line,
            )
        if not own_map:
            c.fail(key, f"'real': no pole map {kitti_map_path(spec.kitti_root or '', spec.seq or '')}", line)
        return replace(spec, landmarks=REAL)
    if value == SYNTHETIC:
        return replace(spec, landmarks=SYNTHETIC)
    if isinstance(value, Map):
        if set(value) != {SYNTHETIC}:
            c.fail(key, f"a mapping here is {{synthetic: {{seed: N}}}}, got keys {', '.join(map(str, value))}", line)
        opts = value[SYNTHETIC]
        if opts is None:
            return replace(spec, landmarks=SYNTHETIC)
        if not isinstance(opts, Map):
            c.fail(f"{key}.synthetic", f"expected a mapping {{seed: N}}, got {opts!r}", value.lines[SYNTHETIC])
        c.keys(opts, f"{key}.synthetic", ("seed",))
        seed = opts.get("seed", 0)
        if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
            c.fail(
                f"{key}.synthetic.seed", f"expected an integer >= 0, got {seed!r}", opts.lines.get("seed", opts.line)
            )
        return replace(spec, landmarks=SYNTHETIC, landmark_seed=seed)
    if not isinstance(value, str):
        c.fail(key, f"expected real, synthetic, {{synthetic: {{seed: N}}}} or a landmark CSV file, got {value!r}", line)
    return replace(spec, landmarks=c.file(value, key, line))


def _parse_geo(c: Checker, raw: Map, key: str, line: Any, spec: ScenarioSpec, gpx: bool) -> ScenarioSpec:
    """A route's OpenStreetMap landmarks and georeference (``osm``, ``osm_classes``, ``osm_reach_m``,
    ``georef``), checked as the route commands' ``--landmarks osm:FILE``, ``--osm-classes``,
    ``--osm-reach`` and ``--georef`` are, each error naming the key and its line (``gpx``: the
    route is a GPX track)."""
    if "osm" not in raw:
        k = next(k for k in _GEO_KEYS if k in raw)
        what = (
            "places the route on an OpenStreetMap map: alone it changes nothing"
            if k == "georef"
            else "chooses OSM landmarks"
        )
        c.fail(f"{key}.{k}", f"{what}; give osm: FILE (an .osm or .osm.pbf extract) with it", line(k))
    value = raw["osm"]
    files = value if isinstance(value, Seq) else [value]
    if not files:
        c.fail(f"{key}.osm", "expected an OSM extract file or a list of them, got an empty list", line("osm"))
    osm = tuple(
        c.file(f, f"{key}.osm" if not isinstance(value, Seq) else f"{key}.osm[{i}]", line("osm"))
        for i, f in enumerate(files)
    )
    if spec.landmarks == SYNTHETIC:
        c.fail(
            f"{key}.landmarks",
            "OSM landmarks join a survey file or a sequence's pole map, not a generated map: drop synthetic",
            line("landmarks"),
        )
    georef = None
    if "georef" in raw:
        text = c.string(raw["georef"], f"{key}.georef", line("georef"), "LAT,LON,BEARING or utm:ZONE")
        if gpx:
            c.fail(
                f"{key}.georef",
                f"the route {spec.route} is a GPX track, placed by its own latitudes and longitudes: drop georef",
                line("georef"),
            )
        _osm_value(c, GeoRef.parse, text, f"{key}.georef", line("georef"))
        georef = text
    elif not gpx:
        c.fail(
            f"{key}.osm",
            "the route is not georeferenced: give georef: LAT,LON,BEARING (its origin in degrees and "
            "the compass bearing of its +X axis) or georef: utm:ZONE (x, y are UTM), or a GPX track as route",
            line("osm"),
        )
    classes = None
    if "osm_classes" in raw:
        v = raw["osm_classes"]
        text = (
            ",".join(str(x) for x in v)
            if isinstance(v, Seq)
            else c.string(v, f"{key}.osm_classes", line("osm_classes"))
        )
        _osm_value(c, parse_classes, text, f"{key}.osm_classes", line("osm_classes"))
        classes = text
    reach = spec.osm_reach_m
    if "osm_reach_m" in raw:
        reach = c.number(raw["osm_reach_m"], f"{key}.osm_reach_m", line("osm_reach_m"))
    return replace(spec, osm=osm, georef=georef, osm_classes=classes, osm_reach_m=reach)


def _osm_value(c: Checker, parse: Any, text: str, key: str, line: int | None) -> None:
    """``parse(text, option=key)`` (an OSM option's own check), its error as this file's."""
    try:
        parse(text, key)
    except InputError as e:
        c.fail(key, str(e).removeprefix(f"{key} "), line)


def _parse_weight(c: Checker, value: Any, key: str, line: int, unit: str) -> float:
    if isinstance(value, Map):
        if len(value) != 1 or next(iter(value)) not in WEIGHT_UNITS:
            c.fail(
                key,
                f"expected {{km: X}}, {{hours: X}} or a number, got keys {', '.join(map(str, value)) or 'none'}",
                line,
            )
        ((u, v),) = value.items()
        if u != unit:
            c.fail(
                f"{key}.{u}",
                f"a weight in {u} in a domain whose weights are in {unit} (weight_unit: {unit}): "
                "give every weight in one unit",
                value.lines[u],
            )
        return c.number(v, f"{key}.{u}", value.lines[u])
    return c.number(value, key, line)


def load_domain_file(path: str | Path) -> DomainSpec:
    """Read and validate an operating-domain YAML file (safe loading; see the module's documentation).

    Raises:
        DomainError: missing file, malformed YAML, an unknown key, a wrong type, a missing route,
            times, landmark or library file, a duplicate name, an empty route list (each naming the
            file, the key path and the line).
    """
    path = Path(path)
    return parse_domain(read_yaml(path, DomainError, "operating-domain file"), path)


def load_domain_scenarios(domain: DomainSpec) -> tuple[DomainScenario, ...]:
    """Load every route of ``domain``: its scenario and its weight (an omitted weight becomes the
    route's duration in hours, or its length in km in a km domain). Errors reading a route's files
    are :class:`~sensorsel.errors.ScenarioError` naming the file and line."""
    out = []
    for i, r in enumerate(domain.routes):
        sc = _load_route(domain, i, r)
        weight = r.weight
        if weight is None:
            route = sc.route or sc.keyframes
            weight = route.length_m / 1000.0 if domain.weight_unit == "km" else route.duration_s / 3600.0
        out.append(DomainScenario(r.name, r.spec, sc, float(weight), domain.weight_unit, r.conditions))
    return tuple(out)


def _load_route(domain: DomainSpec, i: int, r: DomainRoute) -> Scenario:
    """Route ``i``'s scenario (a GPX track and OSM landmarks too: :func:`~sensorsel.model.osm.load_geo_scenario`);
    what only reading the route and the extract can find (a route outside the extract, a file that is
    no OSM extract) named as this file's route, its errors in files naming those files already."""
    if not r.spec.geo and not (r.spec.route is not None and is_gpx(r.spec.route)):
        return load_scenario(r.spec)
    try:
        return load_geo_scenario(r.spec)
    except InputError as e:  # (a ScenarioError names its own file and is no InputError: it passes)
        text = str(e)
        for option, key in _OPTION_KEYS:  # the route commands' words for this file's keys
            text = text.replace(option, key)
        raise DomainError(domain.source, f"routes[{i}]", f"{r.name}: {text}", r.line) from None


#: the route commands' options and the domain file's keys that say the same
_OPTION_KEYS = (
    ("--landmarks osm:", "osm: "),
    ("--georef", "georef:"),
    ("--osm-classes", "osm_classes:"),
    ("--osm-reach", "osm_reach_m:"),
)
