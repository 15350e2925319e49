"""A city the fleet has not driven yet: routes and landmarks from OpenStreetMap and GPS tracks.

- :mod:`.extract`: read a local OSM extract (``.osm`` XML or ``.osm.pbf``, never the network) with
  pyosmium, project it to a local metric frame (the extract's UTM zone, minus a round origin) and
  pick its pole-like landmarks by class (:data:`.extract.LANDMARK_CLASSES`).
- :mod:`.gpx`: a small GPX reader (tracks, routes, waypoints) and the georeference that puts a route
  given in a local frame (KITTI, TUM, planar CSV) into the same frame as the map.
- :mod:`.track`: a route the team has (a GPS track, a georeferenced route) with the extract's
  landmarks near it, merged with a survey's: every route command's ``--landmarks osm:FILE``
  (:func:`load_geo_scenario`) and ``sensorsel osm --gpx/--route``.
- :mod:`.city`: an operating domain from the road network: the selected ways cut into routes that
  cover every way, keyframes at a stated speed, landmarks per route, written as a domain folder.
"""

from __future__ import annotations

from sensorsel.model.osm.extract import (
    DEFAULT_CLASSES,
    LANDMARK_CLASSES,
    LocalFrame,
    OsmExtract,
    OsmLandmarks,
    parse_bbox,
    parse_classes,
    read_osm,
)
from sensorsel.model.osm.gpx import GeoRef, Track, read_gpx
from sensorsel.model.osm.track import (
    DUPLICATE_M,
    SURVEY,
    RouteMap,
    gpx_route,
    is_gpx,
    load_geo_scenario,
    route_landmarks,
)

__all__ = [
    "DEFAULT_CLASSES",
    "LANDMARK_CLASSES",
    "LocalFrame",
    "OsmExtract",
    "OsmLandmarks",
    "parse_bbox",
    "parse_classes",
    "read_osm",
    "GeoRef",
    "Track",
    "read_gpx",
    "DUPLICATE_M",
    "SURVEY",
    "RouteMap",
    "gpx_route",
    "is_gpx",
    "load_geo_scenario",
    "route_landmarks",
]
