"""Read a local OpenStreetMap extract and project it to a local metric frame.

Reader: pyosmium (the ``osmium`` package: the libosmium C++ reader, BSD, binary wheels) reads both
``.osm`` XML and ``.osm.pbf`` with node locations attached to ways, and never touches the network.

Frame: the UTM zone of the extract's centre (pyproj, WGS 84 / UTM, EPSG:326zz north, 327zz south),
minus a round origin (the centre's easting and northing rounded down to the kilometre) so that
coordinates stay small. UTM is conformal and its scale error is below 0.1 % inside a zone, far less
than a landmark's mapping error over a city; a GPS track, a survey or another team's map given in
UTM then meets this one by subtracting the same origin (:class:`LocalFrame`). Planar X is east,
Y north (grid north), heading counter-clockwise from east, as in every sensorsel route.

Landmarks: OSM nodes of the pole-like classes of :data:`LANDMARK_CLASSES`. A node that matches
several classes (a lamp carrying a sign) is one landmark, of the first class in that order. Classes
that mappers usually put on the road's centre line (:data:`CENTRE_LINE_CLASSES`: signals, signs,
stop and give-way) are, when the node is a vertex of a road, moved to the right-hand kerb
(:data:`KERB_OFFSET_M` plus half the road's width from its ``width`` or ``lanes`` tag) and counted;
OSM gives no heights and says nothing about occlusion.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sensorsel.errors import InputError, ScenarioError

#: class name -> (OSM key, value; None: any value). The order is the priority of a node with several.
LANDMARK_CLASSES: dict[str, tuple[str, str | None]] = {
    "street_lamp": ("highway", "street_lamp"),
    "utility_pole": ("man_made", "utility_pole"),
    "power_pole": ("power", "pole"),
    "flagpole": ("man_made", "flagpole"),
    "tree": ("natural", "tree"),
    "traffic_signals": ("highway", "traffic_signals"),
    "stop": ("highway", "stop"),
    "give_way": ("highway", "give_way"),
    "traffic_sign": ("traffic_sign", None),
}
DEFAULT_CLASSES = tuple(LANDMARK_CLASSES)
#: classes OSM's mapping guidelines put on the way itself (a node of the road's centre line)
CENTRE_LINE_CLASSES = frozenset({"traffic_signals", "stop", "give_way", "traffic_sign"})
KERB_OFFSET_M = 0.5  # beyond the carriageway's edge: a pole stands on the pavement, not on the kerb line
LANE_WIDTH_M = 3.25  # metres a lane when a road has a lanes tag but no width
DEFAULT_HALF_WIDTH_M = 3.5  # half a two-lane road's width when it has neither width nor lanes
#: the highway values a car drives on (``--roads`` chooses among these; *_link follow their road)
DRIVABLE = (
    "motorway",
    "trunk",
    "primary",
    "secondary",
    "tertiary",
    "unclassified",
    "residential",
    "living_street",
    "service",
    "road",
)
DEFAULT_ROADS = ("primary", "secondary", "tertiary", "unclassified", "residential", "living_street")


@dataclass(frozen=True)
class LocalFrame:
    """WGS 84 latitude/longitude <-> a local metric frame: UTM ``zone`` (north or south) minus an origin.

    Attributes:
        zone: UTM zone 1..60.
        south: southern hemisphere (EPSG:327zz) instead of northern (EPSG:326zz).
        origin_e, origin_n: the UTM easting and northing [m] of the local frame's (0, 0).
    """

    zone: int
    south: bool
    origin_e: float
    origin_n: float

    @property
    def epsg(self) -> int:
        return (32700 if self.south else 32600) + self.zone

    @staticmethod
    def around(lon: float, lat: float) -> LocalFrame:
        """The frame of the UTM zone of (lon, lat) [deg], origin at it rounded down to the kilometre."""
        zone = min(60, int(math.floor((lon + 180.0) / 6.0)) + 1)
        frame = LocalFrame(zone, lat < 0, 0.0, 0.0)
        e, n = frame.to_utm(np.array([lon]), np.array([lat]))
        return LocalFrame(zone, lat < 0, math.floor(e[0] / 1000.0) * 1000.0, math.floor(n[0] / 1000.0) * 1000.0)

    def to_utm(self, lon: np.ndarray, lat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """UTM easting, northing [m] of (lon, lat) [deg] arrays of one shape."""
        from pyproj import Transformer

        tr = Transformer.from_crs("EPSG:4326", f"EPSG:{self.epsg}", always_xy=True)
        e, n = tr.transform(np.asarray(lon, dtype=float), np.asarray(lat, dtype=float))
        return np.asarray(e, dtype=float), np.asarray(n, dtype=float)

    def project(self, lon: np.ndarray, lat: np.ndarray) -> np.ndarray:
        """(N, 2) local x, y [m] of (lon, lat) [deg] arrays of length N."""
        e, n = self.to_utm(lon, lat)
        return np.column_stack([e - self.origin_e, n - self.origin_n]).reshape(-1, 2)

    def unproject(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(lon, lat) [deg] of (N, 2) local x, y [m]."""
        from pyproj import Transformer

        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        tr = Transformer.from_crs(f"EPSG:{self.epsg}", "EPSG:4326", always_xy=True)
        lon, lat = tr.transform(xy[:, 0] + self.origin_e, xy[:, 1] + self.origin_n)
        return np.asarray(lon, dtype=float), np.asarray(lat, dtype=float)

    def describe(self) -> str:
        return (
            f"UTM zone {self.zone}{'S' if self.south else 'N'} (EPSG:{self.epsg}) minus origin "
            f"E {self.origin_e:.0f} m, N {self.origin_n:.0f} m"
        )


@dataclass(frozen=True)
class OsmWay:
    """A road of the extract: ``highway`` value, its node ids and local positions (K, 2) [m], half width [m]."""

    id: int
    highway: str
    nodes: tuple[int, ...]
    xy: np.ndarray
    half_width_m: float


@dataclass(frozen=True)
class OsmLandmarks:
    """Landmarks of an extract in the local frame.

    Attributes:
        xy: (M, 2) positions [m] (centre-line ones already moved to the kerb).
        classes: (M,) class name of each (a key of :data:`LANDMARK_CLASSES`).
        ids: (M,) OSM node id of each.
        moved: (M,) True where the node stood on a road's centre line and was moved to the kerb.
    """

    xy: np.ndarray
    classes: tuple[str, ...]
    ids: np.ndarray
    moved: np.ndarray

    def __len__(self) -> int:
        return len(self.classes)

    def of(self, classes: tuple[str, ...]) -> OsmLandmarks:
        keep = np.array([c in classes for c in self.classes], dtype=bool)
        return OsmLandmarks(
            self.xy[keep], tuple(c for c, k in zip(self.classes, keep) if k), self.ids[keep], self.moved[keep]
        )

    def counts(self) -> dict[str, int]:
        return {c: self.classes.count(c) for c in LANDMARK_CLASSES if c in self.classes}


@dataclass(frozen=True)
class OsmExtract:
    """What :func:`read_osm` read.

    Attributes:
        source: the file.
        frame: the local frame every position is in.
        bounds: (W, S, E, N) [deg] of the nodes read (after ``bbox``).
        n_nodes: nodes read (within ``bbox``).
        tag_counts: nodes carrying each class's tag (a node with two classes' tags counts in both).
        landmarks: one landmark a node, in class priority order (see :data:`LANDMARK_CLASSES`).
        ways: the roads with a ``highway`` value of :data:`DRIVABLE` (or its ``_link``), cut at ``bbox``.
        notes: what was assumed or moved, for the user.
    """

    source: str
    frame: LocalFrame
    bounds: tuple[float, float, float, float]
    n_nodes: int
    tag_counts: dict[str, int]
    landmarks: OsmLandmarks
    ways: tuple[OsmWay, ...]
    notes: tuple[str, ...] = field(default=())


def parse_bbox(text: str, option: str = "--bbox") -> tuple[float, float, float, float]:
    """'W,S,E,N' [deg] -> (W, S, E, N); W < E within ±180, S < N within ±90.

    Raises:
        InputError: naming ``option`` and the text.
    """
    try:
        w, s, e, n = (float(v) for v in text.split(","))
    except ValueError:
        raise InputError(
            f"{option} {text!r}: expected four numbers W,S,E,N in degrees, e.g. 24.93,60.16,24.96,60.18"
        ) from None
    if not all(math.isfinite(v) for v in (w, s, e, n)) or not (-180 <= w < e <= 180 and -90 <= s < n <= 90):
        raise InputError(f"{option} {text!r}: expected west < east within ±180 and south < north within ±90 degrees")
    return w, s, e, n


def parse_classes(text: str | None, option: str = "--osm-classes") -> tuple[str, ...]:
    """'street_lamp,tree' (or 'all', or None: all) -> the class names, in :data:`LANDMARK_CLASSES` order.

    Raises:
        InputError: an unknown class (names the option and the known classes).
    """
    if text is None or text.strip() == "all":
        return DEFAULT_CLASSES
    names = [c.strip() for c in text.split(",") if c.strip()]
    unknown = [c for c in names if c not in LANDMARK_CLASSES]
    if unknown or not names:
        raise InputError(
            f"{option} {text!r}: unknown class {', '.join(unknown) or '(none given)'}; "
            f"known: {', '.join(LANDMARK_CLASSES)} or all"
        )
    return tuple(c for c in LANDMARK_CLASSES if c in names)


def parse_roads(text: str | None, option: str = "--roads") -> tuple[str, ...]:
    """'primary,secondary' (None: :data:`DEFAULT_ROADS`) -> highway values, each with its ``_link``.

    Raises:
        InputError: a value that is not a road a car drives on (:data:`DRIVABLE`).
    """
    names = DEFAULT_ROADS if text is None else tuple(r.strip() for r in text.split(",") if r.strip())
    unknown = [r for r in names if r.removesuffix("_link") not in DRIVABLE]
    if unknown or not names:
        raise InputError(
            f"{option} {text!r}: not a road a car drives on: {', '.join(unknown) or '(none given)'}; "
            f"known: {', '.join(DRIVABLE)}"
        )
    return tuple(sorted({r for n in names for r in (n.removesuffix("_link"), n.removesuffix("_link") + "_link")}))


def _class_of(tags: dict[str, str]) -> list[str]:
    return [c for c, (k, v) in LANDMARK_CLASSES.items() if k in tags and (v is None or tags[k] == v)]


def _half_width(tags: dict[str, str]) -> float:
    try:
        if "width" in tags:
            w = float(tags["width"].replace("m", "").strip())
            if 1.0 <= w <= 60.0:
                return w / 2.0
        if "lanes" in tags:
            lanes = int(tags["lanes"])
            if 1 <= lanes <= 12:
                return lanes * LANE_WIDTH_M / 2.0
    except ValueError:
        pass
    return DEFAULT_HALF_WIDTH_M


def _osm_format(path: Path) -> str:
    """'osm' (XML), 'osm.bz2' or 'osm.gz' (compressed XML) or 'pbf' by the file's first bytes, so that
    the extension does not matter."""
    try:
        with path.open("rb") as fh:
            head = fh.read(64)
    except FileNotFoundError:
        raise ScenarioError(path, "OSM extract not found") from None
    except OSError as exc:
        raise ScenarioError(path, f"cannot read: {exc.strerror or exc}") from None
    if not head:
        raise ScenarioError(path, "empty file: expected an OSM extract (.osm XML or .osm.pbf)")
    stripped = head.lstrip(b"\xef\xbb\xbf \t\r\n")
    if stripped.startswith(b"<"):
        return "osm"
    if head[4:15] == b"\x0a\x09OSMHeader":  # a BlobHeader whose type is OSMHeader
        return "pbf"
    for magic, fmt in ((b"BZh", "osm.bz2"), (b"\x1f\x8b", "osm.gz")):  # compressed XML (osmium decompresses it)
        if head.startswith(magic):
            return fmt
    raise ScenarioError(
        path,
        "not an OSM extract: expected .osm XML (starting with '<'), .osm.bz2 or .osm.gz (compressed "
        "XML) or .osm.pbf (an OSMHeader block)",
    )


def read_osm(
    path: str | Path,
    *,
    bbox: tuple[float, float, float, float] | None = None,
    roads: tuple[str, ...] | None = None,
    frame: LocalFrame | None = None,
) -> OsmExtract:
    """Read the landmarks and roads of a local OSM extract, projected to a local metric frame.

    Args:
        path: ``.osm`` XML (also ``.osm.bz2``, ``.osm.gz``) or ``.osm.pbf`` (sniffed from the content, not the name).
        bbox: (W, S, E, N) [deg]: read only what lies inside (ways cut where they leave it).
        roads: the ``highway`` values of the roads to keep (default: every :data:`DRIVABLE` one
            and its ``_link``); centre-line landmarks are moved off every one of these.
        frame: the local frame (default: :meth:`LocalFrame.around` the centre of what was read).

    Raises:
        ScenarioError: missing or unreadable file, not OSM, malformed or truncated XML, no nodes
            (names the file); InputError: ``bbox`` outside the extract (names --bbox).
    """
    import osmium

    path = Path(path)
    fmt = _osm_format(path)
    keep_roads = set(roads) if roads is not None else {r for d in DRIVABLE for r in (d, d + "_link")}
    lon_l: list[float] = []
    lat_l: list[float] = []
    lm_lon: list[float] = []
    lm_lat: list[float] = []
    lm_cls: list[str] = []
    lm_id: list[int] = []
    tag_counts = {c: 0 for c in LANDMARK_CLASSES}
    raw_ways: list[tuple[int, str, list[int], list[float], list[float], float]] = []
    w_, s_, e_, n_ = bbox if bbox is not None else (-180.0, -90.0, 180.0, 90.0)

    def inside(lon: float, lat: float) -> bool:
        return w_ <= lon <= e_ and s_ <= lat <= n_

    all_lon: list[float] = []
    all_lat: list[float] = []
    try:
        fp = osmium.FileProcessor(osmium.io.File(str(path), fmt), osmium.osm.NODE | osmium.osm.WAY).with_locations()
        for obj in fp:
            if isinstance(obj, osmium.osm.Node):
                loc = obj.location
                if not loc.valid():
                    continue
                lon, lat = loc.lon, loc.lat
                all_lon.append(lon)
                all_lat.append(lat)
                if not inside(lon, lat):
                    continue
                lon_l.append(lon)
                lat_l.append(lat)
                if len(obj.tags):
                    tags = {t.k: t.v for t in obj.tags}
                    cls = _class_of(tags)
                    for c in cls:
                        tag_counts[c] += 1
                    if cls:
                        lm_lon.append(lon)
                        lm_lat.append(lat)
                        lm_cls.append(cls[0])
                        lm_id.append(obj.id)
            elif isinstance(obj, osmium.osm.Way):
                hw = obj.tags.get("highway")
                if hw is None or hw not in keep_roads:
                    continue
                tags = {t.k: t.v for t in obj.tags}
                ids, lons, lats = [], [], []
                for nd in obj.nodes:
                    if nd.location.valid():
                        ids.append(nd.ref)
                        lons.append(nd.location.lon)
                        lats.append(nd.location.lat)
                raw_ways.append((obj.id, hw, ids, lons, lats, _half_width(tags)))
    except RuntimeError as exc:  # libosmium's parse and I/O errors
        raise ScenarioError(path, f"not a readable OSM extract: {' '.join(str(exc).split())}") from None
    if not all_lon:
        raise ScenarioError(path, "empty OSM extract: no nodes with a location")
    extent = (min(all_lon), min(all_lat), max(all_lon), max(all_lat))
    if bbox is not None and not lon_l:
        w, s, e, n = bbox
        swapped = (s, w, n, e)  # the same box with latitude and longitude exchanged
        hint = ""
        if swapped[0] <= extent[2] and extent[0] <= swapped[2] and swapped[1] <= extent[3] and extent[1] <= swapped[3]:
            hint = (
                f": with latitude and longitude exchanged, --bbox {','.join(f'{v:g}' for v in swapped)} lies in it "
                "(--bbox is W,S,E,N: longitude first)"
            )
        raise InputError(
            f"--bbox {','.join(f'{v:g}' for v in bbox)}: outside the extract {path}, whose nodes span "
            f"W,S,E,N {','.join(f'{v:.5f}' for v in extent)}{hint}"
        )
    bounds = (min(lon_l), min(lat_l), max(lon_l), max(lat_l))
    if frame is None:
        frame = LocalFrame.around((bounds[0] + bounds[2]) / 2.0, (bounds[1] + bounds[3]) / 2.0)
    # ways cut to the runs of their nodes inside the bbox (a run of one node is no road)
    runs: list[tuple[int, str, list[int], list[float], list[float], float]] = []
    for wid, hw, ids, lons, lats, hwidth in raw_ways:
        run: list[int] = []
        for i in range(len(ids) + 1):
            if i < len(ids) and inside(lons[i], lats[i]):
                run.append(i)
                continue
            if len(run) >= 2:
                runs.append((wid, hw, [ids[j] for j in run], [lons[j] for j in run], [lats[j] for j in run], hwidth))
            run = []
    # one projection call for every road vertex (a pyproj transformer is costly to make)
    flat = (
        frame.project(np.array([v for r in runs for v in r[3]]), np.array([v for r in runs for v in r[4]]))
        if runs
        else np.zeros((0, 2))
    )
    ways: list[OsmWay] = []
    at = 0
    for wid, hw, ids_, _lons, _, hwidth in runs:
        ways.append(OsmWay(wid, hw, tuple(ids_), flat[at : at + len(ids_)], hwidth))
        at += len(ids_)
    lm_xy = frame.project(np.array(lm_lon), np.array(lm_lat)) if lm_lon else np.zeros((0, 2))
    moved = _move_to_kerb(lm_xy, lm_cls, lm_id, ways)
    # the landmarks moved to the kerb are counted by what uses them (kerb_note): a route's or a
    # city's, not every one of the extract
    notes = [f"projection: {frame.describe()}"]
    lms = OsmLandmarks(lm_xy, tuple(lm_cls), np.array(lm_id, dtype=np.int64), moved)
    return OsmExtract(str(path), frame, bounds, len(lon_l), tag_counts, lms, tuple(ways), tuple(notes))


def kerb_note(landmarks: OsmLandmarks, whose: str = "the route's") -> str | None:
    """The note on those of ``landmarks`` (``whose``: a route's, a city's routes') that were moved
    from a road's centre line to its kerb (None when none was)."""
    moved = np.asarray(landmarks.moved, dtype=bool)
    if not moved.any():
        return None
    classes = sorted({c for c, m in zip(landmarks.classes, moved) if m})
    return (
        f"{int(moved.sum())} of {whose} {len(moved)} landmarks (of classes mapped on a road's centre line: "
        f"{', '.join(classes)}) moved to the right-hand kerb (half the road's width + {KERB_OFFSET_M:g} m)"
    )


def _move_to_kerb(xy: np.ndarray, classes: list[str], ids: list[int], ways: list[OsmWay]) -> np.ndarray:
    """Move (in place) each centre-line-class landmark that is a vertex of a road to the right of
    the road's direction by its half width + :data:`KERB_OFFSET_M`; the (M,) mask of those moved."""
    moved = np.zeros(len(classes), dtype=bool)
    at: dict[int, tuple[OsmWay, int]] = {}
    for w in ways:
        for k, nid in enumerate(w.nodes):
            at.setdefault(nid, (w, k))
    for i, (c, nid) in enumerate(zip(classes, ids)):
        if c not in CENTRE_LINE_CLASSES or nid not in at:
            continue
        w, k = at[nid]
        a, b = w.xy[max(k - 1, 0)], w.xy[min(k + 1, len(w.xy) - 1)]
        d = b - a
        norm = float(np.hypot(*d))
        if norm == 0.0:
            continue
        right = np.array([d[1], -d[0]]) / norm
        xy[i] = w.xy[k] + right * (w.half_width_m + KERB_OFFSET_M)
        moved[i] = True
    return moved
