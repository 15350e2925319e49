"""The scenario a user states (:class:`ScenarioSpec`) built into a :class:`Scenario`: the route (a
sequence, a fixture or a route file in any of :data:`ROUTE_FORMATS`, sniffed when not given), its
keyframes, its landmarks, and the notes saying what was assumed, merged or dropped."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sensorsel.errors import InputError, ScenarioError
from sensorsel.io.inputs import is_number_text
from sensorsel.io.resources import fixtures_dir
from sensorsel.model.conditions import Condition
from sensorsel.model.scenario.base import (
    DEFAULT_FRAME_RATE_HZ,
    RouteFile,
    Scenario,
    Trajectory,
    _data_lines,
    route_rate_hz,
    select_keyframes,
)
from sensorsel.model.scenario.csv_route import _header, read_csv_route
from sensorsel.model.scenario.frames import Frame, check_not_degrees
from sensorsel.model.scenario.kitti import kitti_map_path, read_kitti_route, read_sequence, resolve_kitti_root
from sensorsel.model.scenario.landmarks import (
    LandmarkModel,
    check_landmark_seed,
    clean_landmarks,
    generate_landmarks,
    read_landmarks_file,
)
from sensorsel.model.scenario.tum import read_tum_route

DEFAULT_FIXTURE = "suburb"
ROUTE_FORMATS = ("kitti", "tum", "csv")
SYNTHETIC = "synthetic"  # ScenarioSpec.landmarks: always generate
REAL = "real"  # ScenarioSpec.landmarks: the KITTI sequence's pole map, an error if there is none
DEFAULT_OSM_REACH_M = 100.0  # ScenarioSpec.osm_reach_m: a route's OSM landmarks, those within this distance [m]
# file stems that say nothing about the drive: such a route is named after its folder
_GENERIC_STEMS = {
    "poses",
    "pose",
    "groundtruth",
    "ground_truth",
    "gt",
    "trajectory",
    "traj",
    "route",
    "odometry",
    "data",
}


def sniff_route_format(path: str | Path) -> str:
    """The format of a route file when none is given: ``csv`` for a ``.csv`` file; otherwise by the
    first line that is not blank or a ``#`` comment: a header (a field that is not a number, or a
    ``#`` comment naming t, x and y just before it) means ``csv``, 12 numbers ``kitti`` (a 3x4 pose
    matrix), 8 numbers ``tum``.

    Raises:
        ScenarioError: missing or empty file, or a first line that fits none of the formats.
    """
    path = Path(path)
    if path.suffix.lower() == ".csv":
        return "csv"
    lines = _data_lines(path, "route")
    if not lines:
        raise ScenarioError(path, "route file is empty")
    lineno, first = lines[0]
    if first.lstrip("\ufeff \t").startswith("<"):
        # a GPX track reaches here only from the API's load_scenario: the route commands' --route
        # and a domain file's route read GPX (sensorsel.model.osm.load_geo_scenario, above this layer)
        raise ScenarioError(
            path,
            "an XML file (a GPX track?) is read as a route by sensorsel.load_problem or "
            "sensorsel.model.osm.load_geo_scenario (as --route and a domain file's route are), "
            "not by load_scenario",
            lineno,
        )
    parts = first.replace(",", " ").split()
    if not all(is_number_text(p) for p in parts) or _header(path) is not None:
        return "csv"  # a header, or a '#' comment naming t,x,y just before the first row
    by_count = {12: "kitti", 8: "tum"}
    if len(parts) not in by_count:
        raise ScenarioError(
            path,
            f"cannot tell the route format: {len(parts)} numbers on the first line "
            "(KITTI poses have 12, TUM trajectories 8, a planar CSV has a header t,x,y,heading); "
            "give the format (--route-format kitti|tum|csv)",
            lineno,
        )
    return by_count[len(parts)]


def load_route_file(
    path: str | Path,
    fmt: str | None = None,
    times: str | Path | None = None,
    *,
    frame_rate_hz: float = DEFAULT_FRAME_RATE_HZ,
) -> tuple[Trajectory, tuple[str, ...]]:
    """Read a route in ``fmt`` (``kitti``, ``tum``, ``csv``; None: :func:`sniff_route_format`).

    Returns:
        (route, notes): see :func:`read_route_file`.
    """
    r = read_route_file(path, fmt, times, frame_rate_hz=frame_rate_hz)
    return r.route, r.notes


def read_route_file(
    path: str | Path,
    fmt: str | None = None,
    times: str | Path | None = None,
    *,
    frame_rate_hz: float = DEFAULT_FRAME_RATE_HZ,
    up: str | None = None,
    forward: str | None = None,
) -> RouteFile:
    """Read a route in ``fmt`` (``kitti``, ``tum``, ``csv``; None: :func:`sniff_route_format`), its
    ground plane and forward axis found (a 3-D file) and its heading from the direction of travel (a
    positions-only file).

    ``times`` goes with a KITTI pose file only (TUM and CSV routes carry their own timestamps); a
    KITTI pose file without it is taken at ``frame_rate_hz``, and the notes say so. ``up`` (a world
    axis, ``+z``, ``-y``) and ``forward`` (a body axis) state the frame instead of finding it.

    Returns:
        the route, its frame (None for a planar file) and notes: lines to tell the user (an assumed
        rate, a frame found other than the format's own, headings from the direction of travel).
    """
    path = Path(path)
    if fmt is None:
        fmt = sniff_route_format(path)
    if fmt not in ROUTE_FORMATS:
        raise InputError(f"unknown route format {fmt!r}; expected one of {', '.join(ROUTE_FORMATS)}")
    if times is not None and fmt != "kitti":
        raise InputError(f"timestamps {times} go with a KITTI pose file; a {fmt} route ({path}) carries its own")
    if fmt == "kitti":
        r = read_kitti_route(path, times, frame_rate_hz=frame_rate_hz, up=up, forward=forward)
        if times is None:
            r = RouteFile(
                r.route,
                r.frame,
                (
                    f"route {path} has no timestamps: assumed {frame_rate_hz:g} Hz (give its times file "
                    "to use real ones)",
                )
                + r.notes,
            )
        return r
    if fmt == "csv":
        if forward is not None:
            raise InputError(
                f"--forward {forward}: a CSV route ({path}) has no body axes (its heading is a column or the "
                "direction of travel)"
            )
        return read_csv_route(path, up=up)
    return read_tum_route(path, up=up, forward=forward)


def route_name(path: str | Path) -> str:
    """The name of a scenario read from a route file: the file's stem, or its folder's name when the
    stem says nothing about the drive (``poses``, ``groundtruth``, ``trajectory``, ...)."""
    path = Path(path)
    if path.stem.lower() in _GENERIC_STEMS and path.resolve().parent.name:
        return path.resolve().parent.name
    return path.stem


# ------------------------------------------------------------------------------------- pipeline


@dataclass(frozen=True)
class ScenarioSpec:
    """Everything that defines a scenario, as a user states it (and as results record it).

    Exactly one route source is used: ``route`` (a route file in ``route_format``: ``kitti``,
    ``tum`` or ``csv``; None: sniffed, see :func:`sniff_route_format`), else ``poses`` (a KITTI pose
    file, the older spelling of ``route`` + ``route_format="kitti"``), else ``seq`` (under
    ``kitti_root`` / ``$SENSORSEL_KITTI_ROOT``), else the bundled fixture ``fixture``. ``times``
    goes with a KITTI pose file (without it: 10 Hz, and a note says so).

    ``landmarks``: None (default) uses the route's own map: a sequence's ``landmarks/NN.csv`` pole
    map when the KITTI folder has one, a fixture's bundled CSV, else generated; ``"real"`` requires
    the sequence's pole map; ``"synthetic"`` always generates (``landmark_model``, ``landmark_seed``);
    anything else is a landmark CSV file (:func:`~sensorsel.model.scenario.landmarks.read_landmarks_file`).

    ``clearance_m``: drop landmarks closer than this to the route (None: count them, keep them).
    ``name``: the scenario's name (default: the sequence, the fixture, or the route file's name as
    :func:`route_name` gives it).
    ``condition``: the operating condition (night, rain, fog, snow; :mod:`sensorsel.model.conditions`)
    the route is driven in; None: clear. It does not change the scenario, only what each sensor
    sees on it (:func:`sensorsel.model.problem.build_problem` applies it).
    ``up``, ``forward``: with a route file, the world's up axis and the body's forward axis (``+z``,
    ``-y``, ...) instead of those found from the route (:func:`~sensorsel.model.scenario.frames.find_frame`).
    A landmark file naming ``x,y,z`` is in the route's world frame and projected by it.

    OpenStreetMap (read by :func:`sensorsel.model.osm.load_geo_scenario`, which
    :func:`sensorsel.model.problem.load_problem`
    calls; :func:`load_scenario` refuses these fields): ``osm``, OSM extracts whose pole-like
    landmarks of ``osm_classes`` (comma-separated; None: all) within ``osm_reach_m`` [m] of the route
    join ``landmarks`` (then only the file or pole map given there, never a generated map);
    ``georef``, where a route in a local frame lies (``LAT,LON,BEARING`` [deg] or ``utm:ZONE``); a
    ``route`` that is a GPX track is georeferenced by its own latitudes and longitudes.
    """

    seq: str | None = None
    kitti_root: str | None = None
    poses: str | None = None
    times: str | None = None
    fixture: str = DEFAULT_FIXTURE
    landmarks: str | None = None
    landmark_seed: int = 0
    keyframe_rate_hz: float = 1.0
    landmark_model: LandmarkModel = field(default_factory=LandmarkModel)
    route: str | None = None
    route_format: str | None = None
    clearance_m: float | None = None
    name: str | None = None
    up: str | None = None
    forward: str | None = None
    condition: Condition | None = None
    georef: str | None = None
    osm: tuple[str, ...] = ()
    osm_classes: str | None = None
    osm_reach_m: float = DEFAULT_OSM_REACH_M

    @property
    def geo(self) -> bool:
        """Whether OpenStreetMap landmarks, their choice or a georeference are asked for (read above this layer)."""
        return (
            bool(self.osm)
            or self.georef is not None
            or self.osm_classes is not None
            or self.osm_reach_m != DEFAULT_OSM_REACH_M
        )


#: landmarks from a map the scenario layer does not read (OpenStreetMap; :mod:`sensorsel.model.osm`):
#: (the full-rate route, its frame (None: planar), the landmarks given besides the map (M, 2) [m] or
#: None, their label) -> (every landmark (M', 2) [m] in the route's frame, the source's label, notes)
MapLandmarks = Callable[[Trajectory, Frame | None, np.ndarray | None, str | None], tuple[np.ndarray, str, list[str]]]


def fixture_names() -> list[str]:
    """Names of the bundled fixture scenarios."""
    return sorted(p.stem for p in (fixtures_dir() / "poses").glob("*.txt"))


@dataclass(frozen=True)
class _Route:
    route: Trajectory
    name: str
    own_landmarks: Path | None  # the route's own map (a pole map, a fixture's CSV), if it has one
    own_label: str  # how to name that map as a landmark source
    notes: tuple[str, ...]
    missing_map: str | None = None  # why a sequence has no own map (for the notes)
    frame: Frame | None = None  # the frame a 3-D route was found in (projects x,y,z landmark files)


def _load_route(spec: ScenarioSpec, given: RouteFile | None = None) -> _Route:
    if given is not None:  # read by a caller that knows the format (a GPX track): spec.route names it
        return _Route(
            given.route, route_name(spec.route or given.route.source), None, "", given.notes, frame=given.frame
        )
    if spec.route is not None and spec.poses is not None:
        raise InputError(f"give one route file: route {spec.route} or poses {spec.poses}, not both")
    if spec.route_format is not None and spec.route is None:
        raise InputError(f"a route format ({spec.route_format}) goes with a route file")
    if spec.times is not None and spec.route is None and spec.poses is None:
        raise InputError(
            f"timestamps {spec.times} go with a KITTI pose file (a sequence or fixture has its own times.txt)"
        )
    if spec.route is not None or spec.poses is not None:
        path: str = spec.route if spec.route is not None else spec.poses  # type: ignore[assignment]  # one is set
        fmt = spec.route_format if spec.route is not None else "kitti"
        rf = read_route_file(path, fmt, spec.times, up=spec.up, forward=spec.forward)
        return _Route(rf.route, route_name(path), None, "", rf.notes, frame=rf.frame)
    for option, value in (("--up", spec.up), ("--forward", spec.forward)):
        if value is not None:
            raise InputError(
                f"{option} {value} goes with a route file (--route FILE); a sequence or fixture is in KITTI's "
                "camera frame"
            )
    if spec.seq is not None:
        root = resolve_kitti_root(spec.kitti_root)
        lm = kitti_map_path(root, spec.seq)
        rf = read_sequence(root, spec.seq)
        if lm.is_file():
            return _Route(rf.route, spec.seq, lm, f"KITTI pole map {lm}", rf.notes, frame=rf.frame)
        return _Route(rf.route, spec.seq, None, "", rf.notes, f"no pole map {lm}", rf.frame)
    root = fixtures_dir()
    if spec.fixture not in fixture_names():
        raise InputError(f"unknown fixture {spec.fixture!r}; bundled fixtures: {', '.join(fixture_names())}")
    lm = root / "landmarks" / f"{spec.fixture}.csv"
    rf = read_sequence(root, spec.fixture)
    return _Route(rf.route, spec.fixture, lm, str(lm), rf.notes, frame=rf.frame)


def load_route(spec: ScenarioSpec = ScenarioSpec()) -> tuple[Trajectory, str, Path | None]:
    """The full-rate route of ``spec``: (route, scenario name, the route's own landmark map or None:
    a sequence's pole map, a fixture's CSV)."""
    r = _load_route(spec)
    return r.route, _name(spec, r.name), r.own_landmarks


def _name(spec: ScenarioSpec, default: str) -> str:
    if spec.name is None:
        return default
    if not isinstance(spec.name, str) or not spec.name.strip() or any(c in spec.name for c in "\r\n\t"):
        raise InputError(f"scenario name must be a non-empty line of text, got {spec.name!r}")
    return spec.name.strip()


def route_landmarks(spec: ScenarioSpec = ScenarioSpec()) -> np.ndarray:
    """Synthetic landmarks along the route of ``spec`` from ``spec.landmark_model`` and
    ``spec.landmark_seed``, always generated (a fixture's bundled CSV, a sequence's pole map and
    ``spec.landmarks`` are not read): the file a user writes once and edits, or passes back with
    ``--landmarks``.

    Returns:
        (M, 2) positions [m] in the planar frame.
    """
    route, _, _ = load_route(spec)
    return generate_landmarks(route, spec.landmark_model, spec.landmark_seed)


def load_scenario(
    spec: ScenarioSpec = ScenarioSpec(),
    *,
    route_file: RouteFile | None = None,
    map_landmarks: MapLandmarks | None = None,
) -> Scenario:
    """Build a scenario: read the route, take keyframes, read or generate landmarks, merge their
    exact duplicates and count (with ``spec.clearance_m``: drop) those standing on the road.

    What was assumed, merged or dropped is in the scenario's ``notes`` (:func:`scenario_notes`) and
    ``landmark_report``.

    ``route_file``: the route already read (a format this layer does not read, a GPX track), instead of
    reading ``spec``'s. ``map_landmarks``: the landmarks of a map (OpenStreetMap), given the route and
    the landmarks ``spec.landmarks`` names (a file or ``real``; none by default: the map's alone).
    Both are passed by :func:`sensorsel.model.osm.load_geo_scenario`.

    Raises:
        InputError: ``spec`` asks for OpenStreetMap landmarks or a georeference and no
            ``map_landmarks`` reads them (never ignored silently).
    """
    check_landmark_seed(spec.landmark_seed)
    if spec.geo and map_landmarks is None:
        raise InputError(
            "OpenStreetMap landmarks (--landmarks osm:FILE) and --georef are read by "
            "sensorsel.model.osm.load_geo_scenario "
            "(and sensorsel.load_problem), not by sensorsel.model.scenario.load_scenario"
        )
    r = _load_route(spec, route_file)
    route, name = r.route, _name(spec, r.name)
    keyframes = route.select(select_keyframes(route.times, spec.keyframe_rate_hz))
    if len(keyframes) < 2:
        raise InputError(
            f"route {route.source} gives {len(keyframes)} keyframe(s) at {spec.keyframe_rate_hz} Hz; need at least 2"
        )
    notes = list(r.notes)
    own_rate = route_rate_hz(route)
    if spec.keyframe_rate_hz > own_rate:
        used = (
            f"every frame ({len(route)})"
            if len(keyframes) == len(route)
            else f"{len(keyframes)} of {len(route)} frames"
        )
        notes.append(
            f"keyframes: the rate {spec.keyframe_rate_hz:g} Hz is above the route's own {own_rate:.3g} Hz (median "
            "frame "
            f"interval {1.0 / own_rate:.4g} s): used {used} as keyframes, at "
            f"{(len(keyframes) - 1) / keyframes.duration_s:.3g} Hz "
            "on average"
        )
    if map_landmarks is not None:
        raw, source = _with_map(spec, r, route, map_landmarks, notes)
    else:
        raw, source = _own_landmarks(spec, r, route, notes)
    landmarks, report = clean_landmarks(raw, route, spec.clearance_m, source)
    notes.extend(report.notes(always=False))  # the source itself is on every result's scenario line
    if not len(landmarks):
        raise InputError(
            f"no landmark left of the {report.n_read} of {source} (clearance {spec.clearance_m} m): every suite "
            "would score 0"
        )
    return Scenario(name, keyframes, landmarks, source, route, report, tuple(notes))


def _check_real(spec: ScenarioSpec, r: _Route) -> Path:
    """The sequence's pole map that landmarks 'real' names."""
    if spec.seq is None or spec.route is not None or spec.poses is not None:
        raise InputError("landmarks 'real' means a KITTI sequence's pole map: it goes with a sequence (--seq NN)")
    if r.own_landmarks is None:
        raise InputError(f"landmarks 'real': {r.missing_map} (the KITTI folder has no landmarks/{spec.seq}.csv)")
    return r.own_landmarks


def _read_map(path: Path, r: _Route, route: Trajectory, notes: list[str]) -> np.ndarray:
    raw = _landmarks_in_plane(path, r, notes)
    # longitude, latitude read as metres would stand every landmark within centimetres of each other
    check_not_degrees(raw, path, "landmarks", route_extent_m=float(np.ptp(route.poses[:, :2], axis=0).max()))
    return raw


def _own_landmarks(spec: ScenarioSpec, r: _Route, route: Trajectory, notes: list[str]) -> tuple[np.ndarray, str]:
    """(M, 2) landmarks [m] and their source's label as ``spec.landmarks`` chooses them (no map service)."""
    choice = spec.landmarks
    if choice == REAL:
        _check_real(spec, r)
    if choice == SYNTHETIC or (choice is None and r.own_landmarks is None):
        if choice is None and r.missing_map:
            notes.append(f"landmarks: {r.missing_map}: generated synthetic landmarks (seed {spec.landmark_seed})")
        elif choice is None:
            notes.append(
                f"landmarks: the route has no map: generated synthetic landmarks (seed {spec.landmark_seed}; "
                "give a landmark file for a real one)"
            )
        return generate_landmarks(
            route, spec.landmark_model, spec.landmark_seed
        ), f"generated (seed {spec.landmark_seed})"
    lm_path = Path(choice) if choice not in (None, REAL) else r.own_landmarks
    assert lm_path is not None
    return _read_map(lm_path, r, route, notes), (str(choice) if choice not in (None, REAL) else r.own_label)


def _with_map(
    spec: ScenarioSpec, r: _Route, route: Trajectory, map_landmarks: MapLandmarks, notes: list[str]
) -> tuple[np.ndarray, str]:
    """The map service's landmarks merged with the file or pole map ``spec.landmarks`` names (if any)."""
    choice = spec.landmarks
    if choice == SYNTHETIC:
        raise InputError(
            "--landmarks synthetic with an OpenStreetMap map (osm:FILE): a generated map does not mix with a "
            "real one; give osm:FILE alone, or with a survey CSV"
        )
    base: np.ndarray | None = None
    label: str | None = None
    if choice is not None:
        path = _check_real(spec, r) if choice == REAL else Path(choice)
        base = _read_map(path, r, route, notes)
        label = r.own_label if choice == REAL else str(choice)
    raw, source, more = map_landmarks(route, r.frame, base, label)
    notes.extend(more)
    return raw, source


def scenario_notes(scenario: Scenario) -> list[str]:
    """Lines a command prints on stderr before its output: what was assumed in building the
    scenario (a frame rate, synthetic landmarks for want of a map) and what was done to its
    landmarks (read, duplicates merged, on the road kept or dropped). Empty for a scenario built
    from arrays."""
    return list(scenario.notes)


def _landmarks_in_plane(path: Path, r: _Route, notes: list[str]) -> np.ndarray:
    """A landmark file's positions in the route's planar frame: x,y as they are; x,y,z (a 3-D map in
    the route's world frame) projected by the route's frame (a planar route: z dropped)."""
    raw = read_landmarks_file(path)
    if raw.shape[1] == 2:
        return raw
    if r.frame is None:
        return raw[:, :2]
    notes.append(
        f"landmarks: {path}: x,y,z taken in the route's world frame, projected into its ground plane "
        f"({r.frame.describe})"
    )
    return r.frame.project(raw)
