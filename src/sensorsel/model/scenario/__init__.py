"""Scenarios: a route (planar keyframe poses) and the landmarks standing along it.

A package with one module per job, so that a new route format plugs in beside the others:

- :mod:`.base`: the types (:class:`Trajectory`, :class:`Scenario`), the limits and the line parsing
  every reader shares;
- :mod:`.frames`: the ground plane and the forward axis of a 3-D route found from its positions and
  rotations (never assumed), the planar poses they give, headings from the direction of travel for
  positions-only routes, 3-D landmark maps projected into the same plane;
- one module per route format: :mod:`.kitti` (pose files, ``times.txt``, the ``dataset/`` layout),
  :mod:`.tum` (``timestamp tx ty tz qx qy qz qw``), :mod:`.csv_route` (planar ``t,x,y[,heading]``
  and positions-only logs);
- :mod:`.positions`: :func:`route_from_positions`, (t, x, y) to a route (every positions-only reader);
- :mod:`.landmarks`: the generator, landmark files (x,y or x,y,z), the duplicate and on-road checks;
- :mod:`.loading`: :class:`ScenarioSpec`, format sniffing and :func:`load_scenario`.

Every name the rest of sensorsel imports is re-exported here (``from sensorsel.model.scenario import ...``).

Planar frame: right-handed seen from above, heading counter-clockwise from X. For a KITTI sequence:
X = KITTI's z (forward at frame 0), Y = -KITTI's x (left at frame 0). Other routes: see
:mod:`.frames` and docs/scenarios.md.
"""

from sensorsel.model.scenario.base import (
    DEFAULT_FRAME_RATE_HZ,
    MAX_COORD_M,
    MAX_LANDMARKS,
    ON_ROAD_M,
    QUATERNION_TOL,
    ROTATION_TOL,
    LandmarkReport,
    RouteFile,
    Scenario,
    Trajectory,
    route_rate_hz,
    select_keyframes,
)
from sensorsel.model.scenario.csv_route import PLANAR_CSV_COLUMNS, read_csv_route, read_planar_csv, write_planar_csv
from sensorsel.model.scenario.frames import Frame, find_frame, headings_from_travel
from sensorsel.model.scenario.kitti import (
    KITTI_ROOT_ENV,
    kitti_from_planar,
    kitti_map_path,
    load_sequence,
    load_trajectory,
    planar_from_kitti,
    read_kitti_poses,
    read_kitti_route,
    read_sequence,
    read_times,
    resolve_kitti_root,
    write_kitti_poses,
)
from sensorsel.model.scenario.landmarks import (
    LandmarkModel,
    check_landmark_seed,
    clean_landmarks,
    distance_to_route,
    estimate_landmark_count,
    generate_landmarks,
    read_landmarks_csv,
    read_landmarks_file,
    write_landmarks_csv,
)
from sensorsel.model.scenario.loading import (
    DEFAULT_FIXTURE,
    DEFAULT_OSM_REACH_M,
    REAL,
    ROUTE_FORMATS,
    SYNTHETIC,
    MapLandmarks,
    ScenarioSpec,
    fixture_names,
    load_route,
    load_route_file,
    load_scenario,
    read_route_file,
    route_landmarks,
    route_name,
    scenario_notes,
    sniff_route_format,
)
from sensorsel.model.scenario.positions import route_from_positions
from sensorsel.model.scenario.tum import (
    read_tum_route,
    read_tum_trajectory,
    rotations_from_quaternions,
    write_tum_trajectory,
    yaw_from_quaternion,
)

__all__ = [
    "DEFAULT_FIXTURE",
    "DEFAULT_FRAME_RATE_HZ",
    "DEFAULT_OSM_REACH_M",
    "KITTI_ROOT_ENV",
    "MAX_COORD_M",
    "MAX_LANDMARKS",
    "ON_ROAD_M",
    "PLANAR_CSV_COLUMNS",
    "QUATERNION_TOL",
    "REAL",
    "ROTATION_TOL",
    "ROUTE_FORMATS",
    "SYNTHETIC",
    "LandmarkModel",
    "LandmarkReport",
    "MapLandmarks",
    "Scenario",
    "ScenarioSpec",
    "Trajectory",
    "check_landmark_seed",
    "clean_landmarks",
    "distance_to_route",
    "estimate_landmark_count",
    "fixture_names",
    "generate_landmarks",
    "kitti_from_planar",
    "kitti_map_path",
    "load_route",
    "load_route_file",
    "load_scenario",
    "load_sequence",
    "load_trajectory",
    "planar_from_kitti",
    "read_kitti_poses",
    "read_landmarks_csv",
    "read_planar_csv",
    "read_times",
    "read_tum_trajectory",
    "resolve_kitti_root",
    "route_landmarks",
    "route_name",
    "route_rate_hz",
    "scenario_notes",
    "select_keyframes",
    "sniff_route_format",
    "write_kitti_poses",
    "write_landmarks_csv",
    "write_planar_csv",
    "write_tum_trajectory",
    "yaw_from_quaternion",
    "Frame",
    "RouteFile",
    "find_frame",
    "headings_from_travel",
    "read_csv_route",
    "read_kitti_route",
    "read_landmarks_file",
    "read_route_file",
    "read_sequence",
    "read_tum_route",
    "rotations_from_quaternions",
    "route_from_positions",
]
