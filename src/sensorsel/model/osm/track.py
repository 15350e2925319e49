"""A domain of one route the team has: a GPS track, or a route in a local frame with its
georeference, with the OSM landmarks near it (and a survey's, merged)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sensorsel.errors import InputError
from sensorsel.io.files import atomic_write_text
from sensorsel.model.osm.city import ATTRIBUTION, _near, _write_landmarks
from sensorsel.model.osm.extract import LocalFrame, OsmLandmarks, read_osm
from sensorsel.model.osm.gpx import GeoRef, read_gpx, track_route

SURVEY = "survey"  # the class of a landmark from --merge-landmarks


def track_domain(osm_path: str | Path, bbox: tuple[float, float, float, float] | None, classes: tuple[str, ...],
                 roads: tuple[str, ...], gpx: str | None, route_file: str | None, georef: str | None,
                 merge_landmarks: str | None, speed_kmh: float, reach_m: float, keyframe_rate_hz: float,
                 folder: str | Path, command: str) -> tuple[Path, list[str]]:
    """Write a domain folder whose one route is the GPX track ``gpx`` (in the map's UTM frame) or
    ``route_file`` (in its own frame, placed by ``georef``: the OSM landmarks are moved into it),
    with the extract's landmarks of ``classes`` within ``reach_m`` [m] of the route, plus the
    survey CSV ``merge_landmarks`` (x, y [m] in the route's frame). Everything is read and checked
    before anything is written. Returns (the domain file, notes).

    Raises:
        ScenarioError: a bad GPX, route, landmark or OSM file (names it and the line);
        InputError: a bad --georef, no landmark near the route.
    """
    from sensorsel.model.scenario import load_route_file, read_landmarks_csv, write_planar_csv

    notes: list[str] = []
    if gpx is not None:
        track = read_gpx(gpx)
        frame = LocalFrame.around(float(np.mean(track.lon)), float(np.mean(track.lat)))
        poses, times, tn = track_route(track, frame, speed_kmh / 3.6)
        notes += tn
        extract = read_osm(osm_path, bbox=bbox, roads=roads, frame=frame)
        lm_xy = extract.landmarks.xy
        name = Path(gpx).stem
    else:
        assert route_file is not None and georef is not None
        ref = GeoRef.parse(georef)
        traj, rnotes = load_route_file(route_file)
        notes += list(rnotes)
        frame = ref.frame()
        extract = read_osm(osm_path, bbox=bbox, roads=roads, frame=frame)
        poses, times = np.asarray(traj.poses), np.asarray(traj.times)
        lm_xy = ref.from_map(extract.landmarks.xy, frame)
        name = Path(route_file).stem
    notes += list(extract.notes)
    lms = extract.landmarks
    lms = OsmLandmarks(lm_xy, lms.classes, lms.ids, lms.moved).of(classes)
    if merge_landmarks is not None:
        survey = read_landmarks_csv(merge_landmarks)
        lms = OsmLandmarks(np.vstack([lms.xy, survey]), lms.classes + (SURVEY,) * len(survey),
                           np.r_[lms.ids, np.full(len(survey), -1, dtype=np.int64)], np.r_[lms.moved, np.zeros(len(survey), bool)])
        notes.append(f"{len(survey)} survey landmark(s) from {merge_landmarks} merged with the OSM ones")
    from scipy.spatial import cKDTree

    near = _near(cKDTree(lms.xy) if len(lms) else None, poses[:, :2], reach_m)
    if not near.size:
        raise InputError(f"{osm_path}: no landmark of {', '.join(classes)} within --reach {reach_m:g} m of the route "
                         f"{gpx or route_file} (is --georef right?)")
    sel = OsmLandmarks(lms.xy[near], tuple(lms.classes[i] for i in near), lms.ids[near], lms.moved[near])
    km = float(np.sum(np.hypot(*np.diff(poses[:, :2], axis=0).T))) / 1000.0
    counts = sel.counts() | ({SURVEY: sel.classes.count(SURVEY)} if SURVEY in sel.classes else {})
    notes.append(f"landmarks per km of route ({km:.2f} km): " + ", ".join(f"{c} {n / km:.1f}" for c, n in counts.items())
                 + f"; all {len(sel) / km:.1f}")
    folder = Path(folder)
    write_planar_csv(folder / "routes" / f"{name}.csv", poses, times)
    _write_landmarks(folder / "routes" / f"{name}_landmarks.csv", sel)
    text = (f"# An operating domain written by: {command}\n# landmarks from {osm_path}; {ATTRIBUTION}\n"
            f"# map frame: {frame.describe()}\n"
            f"keyframe_rate_hz: {keyframe_rate_hz!r}\nweight_unit: km\nroutes:\n"
            f"  - name: {name}\n    route: routes/{name}.csv\n    format: csv\n"
            f"    landmarks: routes/{name}_landmarks.csv\n")
    return atomic_write_text(folder / "domain.yaml", text), notes
