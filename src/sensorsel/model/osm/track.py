"""Routes a team has, with OpenStreetMap landmarks: a GPS track, or a route in a local frame placed
by a georeference, with the extract's landmarks near it, merged with a survey's.

One function, :func:`route_landmarks`, gives a route its landmarks for both callers:
``sensorsel osm --gpx/--route`` (:func:`track_domain`, a one-route domain folder) and every route
command's ``--landmarks osm:FILE`` (:func:`load_geo_scenario`, which
:func:`sensorsel.model.problem.load_problem` calls for every scenario).

Merging: the same OSM node read from two extracts (overlapping tiles) is one landmark; an OSM
landmark within :data:`DUPLICATE_M` of a survey landmark is taken as the same object and dropped,
the survey's position kept (surveyed to centimetres, where OSM's positions are good to a few metres
at best, and poles along a street stand tens of metres apart). The OSM landmarks kept are those
within the reach of the route; the survey's are all kept.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from sensorsel.errors import InputError, SensorselWarning
from sensorsel.io.files import atomic_write_text
from sensorsel.model.osm.city import ATTRIBUTION, _near, _write_landmarks, sparse_message
from sensorsel.model.osm.extract import (
    LANDMARK_CLASSES,
    LocalFrame,
    OsmExtract,
    OsmLandmarks,
    kerb_note,
    parse_classes,
    parse_roads,
    read_osm,
)
from sensorsel.model.osm.gpx import GeoRef, read_gpx, track_route
from sensorsel.model.scenario import (
    DEFAULT_OSM_REACH_M,
    Frame,
    RouteFile,
    Scenario,
    ScenarioSpec,
    Trajectory,
    load_scenario,
)

SURVEY = "survey"  # the class of a landmark from a survey CSV merged with the OSM ones
DUPLICATE_M = 2.0  # an OSM landmark this close [m] to a survey landmark is the same object
DEFAULT_REACH_M = DEFAULT_OSM_REACH_M  # a route's OSM landmarks: those within this distance [m] of it
GPX_SPEED_KMH = 30.0  # the speed [km/h] that times a GPX track without times on the route commands


@dataclass(frozen=True)
class RouteMap:
    """A route's landmarks from :func:`route_landmarks`.

    Attributes:
        landmarks: in the route's frame [m]: the OSM ones (their classes, ids, kerb moves), then the
            survey's (class :data:`SURVEY`, id -1).
        notes: what was read, moved, merged or dropped, and the landmarks per km of route per class.
        warning: the sparse-map warning (fewer than :data:`~sensorsel.model.osm.city.SPARSE_PER_KM`
            landmarks per km of route), or None.
    """

    landmarks: OsmLandmarks
    notes: tuple[str, ...]
    warning: str | None


def is_gpx(path: str | Path) -> bool:
    """Whether a route file is a GPX track: a ``.gpx`` name, or XML content (no other route format
    starts with ``<``). An unreadable file is not (its reader names the problem)."""
    p = Path(path)
    if p.suffix.lower() == ".gpx":
        return True
    try:
        with p.open("rb") as fh:
            head = fh.read(256)
    except OSError:
        return False
    return head.lstrip(b"\xef\xbb\xbf \t\r\n").startswith(b"<")


def gpx_route(path: str | Path, speed_kmh: float = GPX_SPEED_KMH) -> tuple[RouteFile, LocalFrame]:
    """A GPX track as a route in the UTM frame of its mean position (:meth:`LocalFrame.around`):
    (the route, heading from the direction of travel, times from the file or from ``speed_kmh``
    [km/h]; the frame).

    Raises:
        ScenarioError: a bad GPX file (names it and the line).
    """
    track = read_gpx(path)
    frame = LocalFrame.around(float(np.mean(track.lon)), float(np.mean(track.lat)))
    poses, times, frames, notes = track_route(track, frame, speed_kmh / 3.6)
    route = Trajectory(poses, times, frames, str(path))
    return RouteFile(route, None, (f"route {path}: a GPX track, in {frame.describe()}", *notes)), frame


def _outside(extract: OsmExtract, map_xy: np.ndarray, frame: LocalFrame) -> np.ndarray:
    """(N,) distance [m] of each route position (``frame``) from the extract's box (0 inside)."""
    w, s, e, n = extract.bounds
    corners = frame.project(np.array([w, e, w, e]), np.array([s, s, n, n]))
    lo, hi = corners.min(axis=0), corners.max(axis=0)
    d = np.maximum(np.maximum(lo - map_xy, map_xy - hi), 0.0)
    return np.hypot(d[:, 0], d[:, 1])


def route_landmarks(
    osm_paths: Sequence[str | Path],
    route_xy: np.ndarray,
    frame: LocalFrame,
    georef: GeoRef | None,
    classes: tuple[str, ...],
    *,
    survey: np.ndarray | None = None,
    survey_label: str | None = None,
    reach_m: float = DEFAULT_REACH_M,
    roads: tuple[str, ...] | None = None,
    bbox: tuple[float, float, float, float] | None = None,
    route_label: str = "the route",
    map_option: str = "--landmarks osm:",
    reach_option: str = "--osm-reach",
    frame_told: bool = False,
) -> RouteMap:
    """The OSM landmarks of ``classes`` within ``reach_m`` of a route, merged with a survey (see the module).

    Args:
        osm_paths: OSM extracts (``.osm`` or ``.osm.pbf``), read with ``roads`` and ``bbox`` as
            :func:`~sensorsel.model.osm.extract.read_osm` reads them, projected to ``frame``.
        route_xy: (N, 2) the route's positions [m] in its own frame.
        frame: the map frame the extracts are projected to.
        georef: where the route's frame lies in ``frame`` (None: the route is in ``frame``, a GPX track).
        survey: (M, 2) survey landmarks [m] in the route's frame, or None; ``survey_label`` names them.
        route_label, map_option, reach_option: how the errors and notes name the route, an extract
            (``--landmarks osm:FILE``; the ``osm`` command: the file) and the reach option.
        frame_told: the route's own notes already name the map frame (a GPX track's): the
            extract's projection note is not repeated.

    Raises:
        InputError: a route that lies farther than ``reach_m`` outside an extract (is the
            georeference right?), no landmark within reach, a non-positive reach;
        ScenarioError: a bad extract (names it).
    """
    if not (math.isfinite(reach_m) and reach_m > 0):
        raise InputError(f"{reach_option} {reach_m!r}: expected a positive number of metres")
    route_xy = np.asarray(route_xy, dtype=float).reshape(-1, 2)
    map_xy = georef.to_map(np.column_stack([route_xy, np.zeros(len(route_xy))]), frame)[:, :2] if georef else route_xy
    notes: list[str] = []
    xy: list[np.ndarray] = []
    cls: list[str] = []
    ids: list[int] = []
    moved: list[bool] = []
    seen: set[int] = set()
    again = 0
    for path in osm_paths:
        ex = read_osm(path, bbox=bbox, roads=roads, frame=frame)
        off = _outside(ex, map_xy, frame)
        if off.min() > reach_m:
            hint = "is --georef right?" if georef is not None else "is it in this city?"
            raise InputError(
                f"{map_option}{path}: {route_label} lies {off.min() / 1000:,.1f} km outside the extract (its nodes "
                "span "
                f"W,S,E,N {','.join(f'{v:.5f}' for v in ex.bounds)}): {hint}"
            )
        if (off > 0).any():
            notes.append(
                f"{(off > 0).mean():.0%} of {route_label} lies outside the extract {path}: OSM landmarks there are "
                "missing"
            )
        notes += [n for n in ex.notes if n not in notes and not (frame_told and n.startswith("projection: "))]
        lms = ex.landmarks.of(classes)
        for k in range(len(lms)):
            if int(lms.ids[k]) in seen:
                again += 1
                continue
            seen.add(int(lms.ids[k]))
            xy.append(lms.xy[k])
            cls.append(lms.classes[k])
            ids.append(int(lms.ids[k]))
            moved.append(bool(lms.moved[k]))
    if again:
        notes.append(f"{again} OSM landmark(s) in more than one extract taken once")
    all_xy = np.array(xy, dtype=float).reshape(-1, 2)
    lm_xy = georef.from_map(all_xy, frame) if georef is not None else all_xy
    near = _near(cKDTree(lm_xy) if len(lm_xy) else None, route_xy, reach_m)
    osm = OsmLandmarks(
        lm_xy[near], tuple(cls[i] for i in near), np.array(ids, dtype=np.int64)[near], np.array(moved, dtype=bool)[near]
    )
    out = osm
    if survey is not None and len(survey):
        survey = np.asarray(survey, dtype=float).reshape(-1, 2)
        same = (cKDTree(survey).query(osm.xy)[0] <= DUPLICATE_M) if len(osm) else np.zeros(0, dtype=bool)
        keep = np.flatnonzero(~same)
        out = OsmLandmarks(
            np.vstack([osm.xy[keep], survey]),
            tuple(osm.classes[i] for i in keep) + (SURVEY,) * len(survey),
            np.r_[osm.ids[keep], np.full(len(survey), -1, dtype=np.int64)],
            np.r_[osm.moved[keep], np.zeros(len(survey), dtype=bool)],
        )
        notes.append(
            f"{len(survey)} survey landmark(s) of {survey_label} merged with {len(keep)} OSM one(s); "
            f"{int(same.sum())} OSM "
            f"landmark(s) within {DUPLICATE_M:g} m of a survey landmark taken as the same object (the "
            "survey's position kept)"
        )
    kerb = kerb_note(out)
    if kerb is not None:
        notes.append(kerb)
    if not len(out):
        raise InputError(
            f"{map_option}{', '.join(map(str, osm_paths))}: no landmark of {', '.join(classes)} within {reach_option} "
            f"{reach_m:g} m of {route_label} (is the georeference right?)"
        )
    km = float(np.sum(np.hypot(*np.diff(route_xy, axis=0).T))) / 1000.0
    warning = None
    if km > 0:
        counted = _near(cKDTree(out.xy), route_xy, reach_m)
        in_reach = [out.classes[i] for i in counted]
        per = {c: in_reach.count(c) / km for c in (*LANDMARK_CLASSES, SURVEY) if c in in_reach}
        total = len(in_reach) / km
        notes.append(
            f"landmarks per km of route ({km:.2f} km; within {reach_m:g} m): "
            + ", ".join(f"{c} {v:.1f}" for c, v in per.items())
            + f"; all {total:.1f}"
        )
        warning = sparse_message(total, "route")
    return RouteMap(out, tuple(notes), warning)


def _geo_checks(spec: ScenarioSpec, gpx: bool) -> None:
    """Refuse a georeference or OSM landmarks that cannot apply (one line naming the options)."""
    route = spec.route or spec.poses or (f"sequence {spec.seq}" if spec.seq else f"fixture {spec.fixture}")
    if gpx:
        if spec.georef is not None:
            raise InputError(
                f"--georef {spec.georef}: the route {spec.route} is a GPX track, placed by its own latitudes and "
                "longitudes: drop --georef"
            )
        for option, value in (
            ("--route-format", spec.route_format),
            ("--times", spec.times),
            ("--up", spec.up),
            ("--forward", spec.forward),
        ):
            if value is not None:
                raise InputError(
                    f"{option} {value}: the route {spec.route} is a GPX track (its own format, times and axes)"
                )
    elif spec.osm and spec.georef is None:
        raise InputError(
            f"--landmarks osm:{spec.osm[0]}: the route {route} is not georeferenced: give --georef LAT,LON,BEARING "
            "(its origin in degrees and the compass bearing of its +X axis) or --georef utm:ZONE (x, y are UTM), "
            "or a GPX track as --route"
        )
    if spec.georef is not None and not spec.osm:
        raise InputError(
            f"--georef {spec.georef} places the route on an OpenStreetMap map: give --landmarks osm:FILE with it "
            "(alone it changes nothing)"
        )
    if (spec.osm_classes is not None or spec.osm_reach_m != DEFAULT_REACH_M) and not spec.osm:
        raise InputError("--osm-classes and --osm-reach choose the landmarks of --landmarks osm:FILE: give one")
    for p in spec.osm:
        if not str(p).strip():
            raise InputError("--landmarks osm: names no file: give osm:FILE (an .osm or .osm.pbf extract)")


def load_geo_scenario(spec: ScenarioSpec) -> Scenario:
    """:func:`~sensorsel.model.scenario.load_scenario`, and besides: a ``spec.route`` that is a GPX track
    (:func:`is_gpx`; times from the file, else :data:`GPX_SPEED_KMH`), ``spec.georef`` and the OSM
    landmarks of ``spec.osm`` (:func:`route_landmarks`, merged with ``spec.landmarks``' file or
    pole map). Landmarks per km of route per class are in the scenario's notes; a sparse map is a
    :class:`~sensorsel.errors.SensorselWarning`.

    Raises:
        InputError: OSM landmarks on a route that is not georeferenced, a georeference without
            them, a route far outside an extract, and :func:`route_landmarks`' errors.
    """
    gpx = spec.route is not None and is_gpx(spec.route)
    if not gpx and not spec.geo:
        return load_scenario(spec)
    _geo_checks(spec, gpx)
    classes = parse_classes(spec.osm_classes)
    georef = GeoRef.parse(spec.georef) if spec.georef is not None else None
    rf: RouteFile | None = None
    if gpx:
        assert spec.route is not None
        rf, frame = gpx_route(spec.route)
    elif georef is not None:
        frame = georef.frame()
    if not spec.osm:
        return load_scenario(spec, route_file=rf)

    def from_map(
        route: Trajectory, _frame: Frame | None, base: np.ndarray | None, label: str | None
    ) -> tuple[np.ndarray, str, list[str]]:
        m = route_landmarks(
            spec.osm,
            route.poses[:, :2],
            frame,
            georef,
            classes,
            survey=base,
            survey_label=label,
            reach_m=spec.osm_reach_m,
            roads=parse_roads(None),
            route_label=f"the route {route.source}",
            frame_told=gpx,
        )
        if m.warning:
            warnings.warn(m.warning, SensorselWarning, stacklevel=3)
        which = f" ({','.join(classes)})" if spec.osm_classes is not None else ""
        source = " + ".join(f"osm:{p}" for p in spec.osm) + which + (f" + {label}" if label else "")
        return m.landmarks.xy, source, list(m.notes)

    return load_scenario(spec, route_file=rf, map_landmarks=from_map)


def track_domain(
    osm_path: str | Path,
    bbox: tuple[float, float, float, float] | None,
    classes: tuple[str, ...],
    roads: tuple[str, ...],
    gpx: str | None,
    route_file: str | None,
    georef: str | None,
    merge_landmarks: str | None,
    speed_kmh: float,
    reach_m: float,
    keyframe_rate_hz: float,
    folder: str | Path,
    command: str,
) -> tuple[Path, list[str]]:
    """Write a domain folder whose one route is the GPX track ``gpx`` (in the map's UTM frame) or
    ``route_file`` (in its own frame, placed by ``georef``: the OSM landmarks are moved into it),
    with the landmarks :func:`route_landmarks` gives it (the survey CSV ``merge_landmarks``: x, y [m]
    in the route's frame). Everything is read and checked before anything is written; a sparse
    map is a warning. Returns (the domain file, notes).

    Raises:
        ScenarioError: a bad GPX, route, landmark or OSM file (names it and the line);
        InputError: a bad --georef, no landmark near the route, a route outside the extract.
    """
    from sensorsel.model.scenario import load_route_file, read_landmarks_csv, write_planar_csv

    notes: list[str] = []
    ref: GeoRef | None = None
    if gpx is not None:
        rf, frame = gpx_route(gpx, speed_kmh)
        poses, times = np.asarray(rf.route.poses), np.asarray(rf.route.times)
        notes += list(rf.notes)
        name = Path(gpx).stem
    else:
        assert route_file is not None and georef is not None
        ref = GeoRef.parse(georef)
        traj, rnotes = load_route_file(route_file)
        notes += list(rnotes)
        frame = ref.frame()
        poses, times = np.asarray(traj.poses), np.asarray(traj.times)
        name = Path(route_file).stem
    survey = read_landmarks_csv(merge_landmarks) if merge_landmarks is not None else None
    m = route_landmarks(
        [osm_path],
        poses[:, :2],
        frame,
        ref,
        classes,
        survey=survey,
        survey_label=merge_landmarks,
        reach_m=reach_m,
        roads=roads,
        bbox=bbox,
        route_label=f"the route {gpx or route_file}",
        map_option="",
        reach_option="--osm-reach",
        frame_told=gpx is not None,
    )
    notes += list(m.notes)
    if m.warning:
        warnings.warn(m.warning, SensorselWarning, stacklevel=2)
    folder = Path(folder)
    write_planar_csv(folder / "routes" / f"{name}.csv", poses, times)
    _write_landmarks(folder / "routes" / f"{name}_landmarks.csv", m.landmarks)
    text = (
        f"# An operating domain written by: {command}\n# landmarks from {osm_path}; {ATTRIBUTION}\n"
        f"# map frame: {frame.describe()}\n"
        f"keyframe_rate_hz: {keyframe_rate_hz!r}\nweight_unit: km\nroutes:\n"
        f"  - name: {name}\n    route: routes/{name}.csv\n    format: csv\n"
        f"    landmarks: routes/{name}_landmarks.csv\n"
    )
    return atomic_write_text(folder / "domain.yaml", text), notes
