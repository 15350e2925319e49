"""The sensor library: sensor models (Table I of the paper) and their placements on the car.

A :class:`SensorLibrary` is an ordered tuple of :class:`PlacedSensor`; everywhere else in sensorsel a
sensor is referred to by its position in that tuple (``int``) or by its readable id (``"LRR-12"``).
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from sensorsel.errors import InputError, LibraryError
from sensorsel.io.inputs import StrictLoader, is_number_text
from sensorsel.io.resources import default_library_path
from sensorsel.model.conditions import ConditionPhysics, parse_physics

SENSOR_TYPES = ("lidar", "radar", "stereo")
MOUNTS = ("roof", "clock")
_TWO_PI = 2.0 * math.pi

_COMMON_KEYS = {"code", "name", "type", "digit", "mount", "range_m", "fov_rad", "cost_usd"}
#: Optional keys of a model (every other key is required).
_OPTIONAL_KEYS = {"resources"}
#: A resource name: lower-case letters, digits and '_' ("power_w", "mass_kg", "data_rate_mbps").
_RESOURCE_NAME = re.compile(r"^[a-z][a-z0-9_]*$")
#: Units shown for resource names by their suffix (anything else is shown without a unit).
RESOURCE_UNITS = {"_w": "W", "_kg": "kg", "_mbps": "Mbit/s", "_usd": "$", "_l": "l", "_a": "A"}
#: Places of a slot besides the clock numbers "1".."12": the roof, and every clock position.
SLOT_PLACES = ("roof", "clock")
#: Kinds a slot counts besides the sensor types: any sensor.
SLOT_ANY = "any"
_TYPE_KEYS = {
    "lidar": {"sigma_range_m", "sigma_bearing_rad"},
    "radar": {"sigma_range_m", "sigma_bearing_rad"},
    "stereo": {"baseline_m", "focal_px", "sigma_disparity_px", "sigma_pixel_px"},
}


@dataclass(frozen=True)
class SensorModel:
    """One sensor model of Table I.

    Attributes:
        code: short unique code used in sensor ids ("LRL", "HD2K").
        name: human-readable name.
        type: "lidar", "radar" or "stereo".
        digit: the paper's type digit, first digit of a placed sensor's index (0-9).
        mount: "roof" (one placement) or "clock" (one per clock position).
        range_m: maximum sensing range [m].
        fov_rad: full field of view, centred on the sensor's facing [rad], in (0, 2*pi].
        cost_usd: price of one unit [$].
        sigma_range_m, sigma_bearing_rad: measurement noise std (lidar, radar) [m], [rad].
        baseline_m, focal_px, sigma_disparity_px, sigma_pixel_px: stereo parameters [m], [px].
        resources: what one unit draws or weighs, by resource name (``("power_w", 60.0)``, ...;
            units by the name's suffix, :func:`resource_unit`); empty when the file declares none.
    """

    code: str
    name: str
    type: str
    digit: int
    mount: str
    range_m: float
    fov_rad: float
    cost_usd: float
    sigma_range_m: float | None = None
    sigma_bearing_rad: float | None = None
    baseline_m: float | None = None
    focal_px: float | None = None
    sigma_disparity_px: float | None = None
    sigma_pixel_px: float | None = None
    resources: tuple[tuple[str, float], ...] = ()

    def resource(self, name: str) -> float:
        """The amount of resource ``name`` one unit uses (0 when the model does not declare it: a
        limit on it refuses such a library, :mod:`sensorsel.model.constraints`)."""
        return dict(self.resources).get(name, 0.0)

    def range_sigma(self, distance_m: np.ndarray) -> np.ndarray:
        """Range noise std [m] at the given distances [m] (shape preserved).

        Stereo: z^2 / (f b) * sigma_d (the paper's eq. 5, z = range); others: constant.
        """
        z = np.asarray(distance_m, dtype=float)
        if self.type == "stereo":
            assert self.focal_px and self.baseline_m and self.sigma_disparity_px
            return z * z / (self.focal_px * self.baseline_m) * self.sigma_disparity_px
        assert self.sigma_range_m is not None
        return np.full_like(z, self.sigma_range_m)

    def bearing_sigma(self) -> float:
        """Bearing noise std [rad]: sigma_px / f for stereo cameras, the table's value otherwise."""
        if self.type == "stereo":
            assert self.sigma_pixel_px and self.focal_px
            return self.sigma_pixel_px / self.focal_px
        assert self.sigma_bearing_rad is not None
        return self.sigma_bearing_rad


@dataclass(frozen=True)
class PlacedSensor:
    """A sensor model mounted at one place on the car.

    Attributes:
        id: readable, stable id: "<code>-<clock>" or "<code>-roof".
        index: the paper's numeric index (type digit followed by clock position 0..11).
        model: the sensor model.
        clock: clock position 1..12 (12 = straight ahead), or None on the roof.
        mount_angle_rad: facing relative to the car's heading, counter-clockwise positive [rad]
            (3 o'clock, the car's right, is -pi/2).
    """

    id: str
    index: int
    model: SensorModel
    clock: int | None
    mount_angle_rad: float

    @property
    def cost_usd(self) -> float:
        return self.model.cost_usd

    @property
    def position_label(self) -> str:
        return "roof" if self.clock is None else f"{self.clock} o'clock"


@dataclass(frozen=True)
class Slot:
    """A mounting slot: at most ``capacity`` sensors of ``kind`` at one place on the car.

    Attributes:
        place: "roof", or a clock position "1".."12".
        kind: a sensor type ("lidar", "radar", "stereo") or "any".
        capacity: how many such sensors the place holds (>= 0).
        members: library positions of the sensors this slot counts, ascending.
    """

    place: str
    kind: str
    capacity: int
    members: tuple[int, ...]

    @property
    def label(self) -> str:
        """``"3 o'clock radar"``, ``"roof lidar"``."""
        where = "roof" if self.place == "roof" else f"{self.place} o'clock"
        return f"{where} {'sensors' if self.kind == SLOT_ANY else self.kind}"


@dataclass(frozen=True)
class SensorLibrary:
    """An ordered collection of placed sensors, with the file it was read from and its mounting slots.

    Attributes:
        sensors: the placed sensors; a sensor's position in this tuple is its handle everywhere.
        source: the file it was read from.
        slots: the car's mounting capacities (:class:`Slot`), empty when the file declares none.
        physics: the numbers of the weather and night models (the file's ``conditions:`` section,
            :mod:`sensorsel.model.conditions`); the defaults when the file has none.
    """

    sensors: tuple[PlacedSensor, ...]
    source: str = "<memory>"
    slots: tuple[Slot, ...] = ()
    physics: ConditionPhysics = field(default_factory=ConditionPhysics)

    def __repr__(self) -> str:
        return f"SensorLibrary({len(self.sensors)} sensors from {self.source!r})"

    def __len__(self) -> int:
        return len(self.sensors)

    def __iter__(self):
        return iter(self.sensors)

    def __getitem__(self, i: int) -> PlacedSensor:
        return self.sensors[i]

    @property
    def ids(self) -> tuple[str, ...]:
        return tuple(s.id for s in self.sensors)

    @property
    def costs(self) -> np.ndarray:
        """Cost of each sensor [$], shape (n_sensors,)."""
        return np.array([s.cost_usd for s in self.sensors], dtype=float)

    def position(self, sensor_id: str) -> int:
        """Position in the library of the sensor with this id (or paper index as a string)."""
        for i, s in enumerate(self.sensors):
            if s.id == sensor_id or str(s.index) == sensor_id:
                return i
        raise InputError(
            f"unknown sensor id {sensor_id!r}{self._suggest(sensor_id)} (see `sensorsel library` for the ids)"
        )

    def _suggest(self, sensor_id: str) -> str:
        """'; did you mean X?' for an id that differs from one of the library's only in case, or
        is close to one in spelling; '' when none is."""
        import difflib

        same = [s.id for s in self.sensors if s.id.lower() == str(sensor_id).lower()]
        close = same or difflib.get_close_matches(
            str(sensor_id).upper(), [s.id.upper() for s in self.sensors], n=3, cutoff=0.8
        )
        if not close:
            return ""
        ids = {s.id.upper(): s.id for s in self.sensors}
        names = [ids.get(c, c) for c in close]
        return (
            f"; did you mean {' or '.join(names)}? (ids are case-sensitive)"
            if same
            else f"; did you mean {' or '.join(names)}?"
        )

    def parse_suite(self, text: str | Iterable[str]) -> tuple[int, ...]:
        """Positions of a comma-separated list of ids (or indices); sorted, duplicates refused."""
        items = [t.strip() for t in text.split(",")] if isinstance(text, str) else [str(t).strip() for t in text]
        items = [t for t in items if t]
        positions = [self.position(t) for t in items]
        if len(set(positions)) != len(positions):
            raise InputError(f"suite {','.join(items)!r} names a sensor twice")
        return tuple(sorted(positions))

    def resolve_suite(self, suite: str | Iterable[str | int]) -> tuple[int, ...]:
        """The canonical form of a suite, however it is given: sorted unique library positions.

        Accepts comma-separated ids (``"LRL-roof,LRR-12"``), an iterable of ids (a result's
        ``suite``), or an iterable of library positions (ints, numpy ints included).

        Raises:
            InputError: an unknown id, a position outside 0..n-1, an id named twice, or a value that
                is neither an id nor a position.
        """
        if isinstance(suite, str):
            return self.parse_suite(suite)
        items = list(suite)
        if all(isinstance(x, str) for x in items):
            return self.parse_suite(items)  # type: ignore[arg-type]
        positions: list[int] = []
        for x in items:
            if isinstance(x, str):
                positions.append(self.position(x))
            elif isinstance(x, (bool, np.bool_)) or not isinstance(x, (int, np.integer)):
                raise InputError(f"a suite holds sensor ids or library positions, got {x!r}")
            elif not 0 <= int(x) < len(self.sensors):
                raise InputError(f"sensor position {int(x)} is outside the library (0..{len(self.sensors) - 1})")
            else:
                positions.append(int(x))
        return tuple(sorted(set(positions)))

    def suite_ids(self, suite: Iterable[int]) -> tuple[str, ...]:
        return tuple(self.sensors[i].id for i in suite)

    def cost(self, suite: Iterable[int]) -> float:
        """Total cost of a suite [$]."""
        return float(sum(self.sensors[i].cost_usd for i in suite))

    @property
    def resource_names(self) -> tuple[str, ...]:
        """The resources any model declares, in file order."""
        names: dict[str, None] = {}
        for s in self.sensors:
            for name, _ in s.model.resources:
                names.setdefault(name)
        return tuple(names)

    def resource(self, name: str) -> np.ndarray:
        """What each sensor uses of resource ``name``, shape (n_sensors,), in the resource's unit."""
        return np.array([s.model.resource(name) for s in self.sensors], dtype=float)

    def subset(self, positions: Sequence[int]) -> SensorLibrary:
        """A smaller library of the sensors at these positions, in this order (slots kept, renumbered)."""
        new = {int(p): k for k, p in enumerate(positions)}
        slots = tuple(
            Slot(sl.place, sl.kind, sl.capacity, tuple(sorted(new[m] for m in sl.members if m in new)))
            for sl in self.slots
        )
        return SensorLibrary(
            tuple(self.sensors[i] for i in positions),
            self.source,
            tuple(sl for sl in slots if sl.members),
            self.physics,
        )


def resource_unit(name: str) -> str:
    """The unit of a resource, from its name's suffix ("power_w" -> "W"); "" when unknown."""
    for suffix, unit in RESOURCE_UNITS.items():
        if name.endswith(suffix):
            return unit
    return ""


def clock_to_angle(clock: int) -> float:
    """Mounting angle [rad] of a clock position: 12 -> 0, 3 -> -pi/2, 9 -> +pi/2."""
    return -(clock % 12) * math.pi / 6.0


def _number(value: Any, path: Path, key: str, *, positive: bool = True) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        hint = ""
        if isinstance(value, str) and is_number_text(value):
            hint = " (a number in quotes is text: remove the quotes)"
        raise LibraryError(path, key, f"expected a number, got {value!r}{hint}")
    v = float(value)
    if not math.isfinite(v):
        raise LibraryError(path, key, f"expected a finite number, got {value!r}")
    if positive and v <= 0:
        raise LibraryError(path, key, f"must be positive, got {value!r}")
    return v


def _string(value: Any, path: Path, key: str) -> str:
    if not isinstance(value, str) or not value.strip():
        raise LibraryError(path, key, f"expected a non-empty string, got {value!r}")
    return value.strip()


def _parse_model(raw: Any, path: Path, key: str) -> SensorModel:
    if not isinstance(raw, dict):
        raise LibraryError(path, key, f"expected a mapping of model fields, got {type(raw).__name__}")
    if "type" not in raw:
        raise LibraryError(path, f"{key}.type", f"missing required field; expected one of {', '.join(SENSOR_TYPES)}")
    stype = raw["type"]
    if not isinstance(stype, str) or stype not in SENSOR_TYPES:
        raise LibraryError(
            path, f"{key}.type", f"unknown sensor type {stype!r}; expected one of {', '.join(SENSOR_TYPES)}"
        )
    allowed = _COMMON_KEYS | _TYPE_KEYS[stype]
    for k in raw:
        if k not in allowed | _OPTIONAL_KEYS:
            raise LibraryError(
                path,
                f"{key}.{k}",
                f"unknown key for a {stype} model; allowed: {', '.join(sorted(allowed | _OPTIONAL_KEYS))}",
            )
    for k in sorted(allowed):
        if k not in raw:
            raise LibraryError(path, f"{key}.{k}", "missing required field")
    code = _string(raw["code"], path, f"{key}.code")
    if not code.replace("_", "").isalnum():
        raise LibraryError(path, f"{key}.code", f"must be letters, digits or '_', got {code!r}")
    digit = raw["digit"]
    if isinstance(digit, bool) or not isinstance(digit, int) or not 0 <= digit <= 9:
        raise LibraryError(path, f"{key}.digit", f"expected an integer 0..9, got {digit!r}")
    mount = raw["mount"]
    if mount not in MOUNTS:
        raise LibraryError(path, f"{key}.mount", f"expected one of {', '.join(MOUNTS)}, got {mount!r}")
    fov = _number(raw["fov_rad"], path, f"{key}.fov_rad", positive=False)
    if not 0.0 < fov <= _TWO_PI + 1e-9:
        raise LibraryError(path, f"{key}.fov_rad", f"must be in (0, 2*pi], got {raw['fov_rad']!r}")
    fields = {
        k: _number(raw[k], path, f"{key}.{k}")
        for k in sorted(allowed - {"code", "name", "type", "digit", "mount", "fov_rad"})
    }
    return SensorModel(
        code=code,
        name=_string(raw["name"], path, f"{key}.name"),
        type=stype,
        digit=digit,
        mount=mount,
        fov_rad=min(fov, _TWO_PI),
        resources=_parse_resources(raw.get("resources", {}), path, f"{key}.resources"),
        **fields,
    )


def _parse_resources(raw: Any, path: Path, key: str) -> tuple[tuple[str, float], ...]:
    """A model's ``resources`` mapping (name -> non-negative number), in file order."""
    if not isinstance(raw, dict):
        raise LibraryError(path, key, f"expected a mapping of resource name to amount (power_w: 8), got {raw!r}")
    out = []
    for name, value in raw.items():
        if not isinstance(name, str) or not _RESOURCE_NAME.match(name):
            raise LibraryError(
                path,
                f"{key}.{name}",
                "a resource name is lower-case letters, digits and '_' (power_w, mass_kg, data_rate_mbps)",
            )
        v = _number(value, path, f"{key}.{name}", positive=False)
        if v < 0:
            raise LibraryError(path, f"{key}.{name}", f"must be 0 or more, got {value!r}")
        out.append((name, v))
    return tuple(out)


def _parse_slots(raw: Any, path: Path, sensors: list[PlacedSensor], clocks: list[int]) -> tuple[Slot, ...]:
    """The ``slots`` section: place -> {kind: capacity}; "clock" applies to each clock position, a
    clock number ("6") to that position alone (its kinds replacing those of "clock")."""
    if not isinstance(raw, dict):
        raise LibraryError(
            path, "slots", f"expected a mapping of place (roof, clock, 1..12) to capacities, got {raw!r}"
        )
    per_place: dict[str, dict[str, int]] = {}
    for place, caps in raw.items():
        p = str(place)
        if p not in SLOT_PLACES and not (p.isdigit() and 1 <= int(p) <= 12):
            raise LibraryError(path, f"slots.{p}", "unknown place; expected roof, clock (each clock position) or 1..12")
        if p.isdigit() and int(p) not in clocks:
            raise LibraryError(path, f"slots.{p}", f"clock position {p} is not in clock_positions {clocks}")
        if not isinstance(caps, dict) or not caps:
            raise LibraryError(
                path, f"slots.{p}", f"expected a mapping of sensor type to capacity (radar: 1), got {caps!r}"
            )
        kinds = {}
        for kind, cap in caps.items():
            if kind not in SENSOR_TYPES + (SLOT_ANY,):
                raise LibraryError(
                    path, f"slots.{p}.{kind}", f"unknown kind; expected {', '.join(SENSOR_TYPES + (SLOT_ANY,))}"
                )
            if isinstance(cap, bool) or not isinstance(cap, int) or cap < 0:
                raise LibraryError(path, f"slots.{p}.{kind}", f"expected a whole number of sensors >= 0, got {cap!r}")
            kinds[kind] = cap
        per_place[p] = kinds
    slots = []
    places = ["roof"] + [str(c) for c in clocks]
    for p in places:
        kinds = (
            dict(per_place.get("roof", {})) if p == "roof" else {**per_place.get("clock", {}), **per_place.get(p, {})}
        )
        for kind, cap in kinds.items():
            members = tuple(
                i
                for i, s in enumerate(sensors)
                if (s.clock is None if p == "roof" else s.clock == int(p)) and kind in (SLOT_ANY, s.model.type)
            )
            if members:
                slots.append(Slot(p, kind, cap, members))
    return tuple(slots)


#: Top-level keys of a library file.
_TOP_KEYS = ("extends", "clock_positions", "models", "slots", "conditions")
#: Longest chain of ``extends`` followed (a longer one is a loop or a mistake).
_MAX_EXTENDS = 8


def parse_library(data: Any, path: str | Path = "<memory>") -> SensorLibrary:
    """Validate a parsed library document and expand its models into placed sensors.

    Raises:
        LibraryError: naming ``path`` and the key path of the first problem found.
    """
    path = Path(path)
    if not isinstance(data, dict):
        raise LibraryError(
            path, "", f"expected a mapping with keys 'clock_positions' and 'models', got {type(data).__name__}"
        )
    if "extends" in data:
        raise LibraryError(path, "extends", "only a library file can extend another (load it with load_library)")
    for k in data:
        if k not in _TOP_KEYS:
            raise LibraryError(path, str(k), f"unknown top-level key; allowed: {', '.join(_TOP_KEYS)}")
    clocks = data.get("clock_positions", list(range(1, 13)))
    if not isinstance(clocks, list) or not clocks:
        raise LibraryError(
            path, "clock_positions", f"expected a non-empty list of clock positions 1..12, got {clocks!r}"
        )
    for j, c in enumerate(clocks):
        if isinstance(c, bool) or not isinstance(c, int) or not 1 <= c <= 12:
            raise LibraryError(path, f"clock_positions[{j}]", f"expected an integer 1..12, got {c!r}")
    if len(set(clocks)) != len(clocks):
        raise LibraryError(path, "clock_positions", f"repeats a position: {clocks!r}")
    models_raw = data.get("models")
    if not isinstance(models_raw, list) or not models_raw:
        raise LibraryError(path, "models", "expected a non-empty list of sensor models")

    models = [_parse_model(m, path, f"models[{i}]") for i, m in enumerate(models_raw)]
    for attr in ("code", "digit"):
        seen: dict[Any, int] = {}
        for i, m in enumerate(models):
            v = getattr(m, attr)
            if v in seen:
                raise LibraryError(path, f"models[{i}].{attr}", f"duplicate {attr} {v!r} (also models[{seen[v]}])")
            seen[v] = i

    sensors: list[PlacedSensor] = []
    for m in models:
        if m.mount == "roof":
            sensors.append(PlacedSensor(f"{m.code}-roof", m.digit, m, None, 0.0))
        else:
            for c in clocks:
                sensors.append(PlacedSensor(f"{m.code}-{c}", int(f"{m.digit}{c % 12}"), m, c, clock_to_angle(c)))
    # Distinct codes and digits can still collide: a roof model with digit d and a clock model with
    # digit 0 at d o'clock both get index d.
    owner = {id(m): i for i, m in enumerate(models)}
    for attr, value_of in (("code", lambda s: s.id), ("digit", lambda s: s.index)):
        first: dict[Any, PlacedSensor] = {}
        for s in sensors:
            v = value_of(s)
            if v in first:
                o = first[v]
                raise LibraryError(
                    path,
                    f"models[{owner[id(s.model)]}].{attr}",
                    f"placed sensor {s.id} (index {s.index}) collides with {o.id} (index {o.index}) "
                    f"of models[{owner[id(o.model)]}]",
                )
            first[v] = s
    slots = _parse_slots(data["slots"], path, sensors, clocks) if "slots" in data else ()
    physics = parse_physics(data["conditions"], path) if "conditions" in data else ConditionPhysics()
    return SensorLibrary(tuple(sensors), str(path), slots, physics)


def load_library(path: str | Path | None = None) -> SensorLibrary:
    """Read and validate a sensor library YAML file (safe loading); default: the paper's Table I.

    A file may start from another with ``extends: OTHER.yaml`` (a path relative to it): its own
    top-level sections (``slots``, ``models``, ``clock_positions``) replace the other file's. So a
    car's mounting slots fit in a few lines on top of the stock library.

    Raises:
        LibraryError: missing file, malformed YAML (with its line), an invalid field, or an
            ``extends`` that is missing, loops, or is longer than 8 files.
    """
    path = Path(path) if path is not None else default_library_path()
    return parse_library(_resolved_document(path, ()), path)


def _resolved_document(path: Path, chain: tuple[Path, ...]) -> Any:
    """The file's document with its ``extends`` chain merged in (each base validated on its own, so
    that a base's mistake is reported against the base file)."""
    data = _read_document(path)
    if not isinstance(data, dict) or "extends" not in data:
        return data
    base_name = data["extends"]
    if not isinstance(base_name, str) or not base_name.strip():
        raise LibraryError(path, "extends", f"expected the path of another library file, got {base_name!r}")
    base_path = (path.parent / base_name).resolve()
    seen = chain + (path.resolve(),)
    if base_path in seen:
        raise LibraryError(path, "extends", f"{base_name!r} extends back to this file (a loop)")
    if len(seen) >= _MAX_EXTENDS:
        raise LibraryError(path, "extends", f"more than {_MAX_EXTENDS} files extend one another")
    if not base_path.is_file():
        raise LibraryError(path, "extends", f"{base_name!r} not found (looked for {base_path})")
    base = _resolved_document(base_path, seen)
    parse_library(base, base_path)  # a mistake in the base is reported against the base
    return {**base, **{k: v for k, v in data.items() if k != "extends"}}


def _read_document(path: Path) -> Any:
    """The YAML document of a library file (a SafeLoader that refuses repeated keys)."""
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise LibraryError(path, "", "file not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise LibraryError(path, "", f"cannot read: {exc}") from None
    try:
        return yaml.load(text, Loader=StrictLoader)  # a SafeLoader: plain data only
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        if mark is not None:
            where = f"line {mark.line + 1}, column {mark.column + 1}: "
            problem = getattr(exc, "problem", None) or str(exc)
        elif isinstance(exc, yaml.reader.ReaderError):  # bad bytes: no mark, a character position
            line = text.count("\n", 0, exc.position) + 1
            char = f"#x{exc.character:04x}" if isinstance(exc.character, int) else repr(exc.character)
            where, problem = f"line {line}: ", f"unacceptable character {char}: {exc.reason}"
        else:
            where, problem = "", str(exc)
        raise LibraryError(path, "", "malformed YAML: " + " ".join(f"{where}{problem}".split())) from None
