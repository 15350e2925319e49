"""GPS tracks (GPX 1.0/1.1) and the georeference of routes given in a local frame.

A small reader on the standard library's XML parser: the points of every ``trk/trkseg/trkpt`` (else
``rte/rtept``, else ``wpt``) in file order, with their ``time`` when every point has one. Namespaces
are ignored (GPX 1.0 and 1.1 differ only there for these elements). expat (the standard library's parser,
which gives each point's line for the errors) fetches no external entities and (expat >= 2.4)
bounds entity expansion.

A route in a local frame (a KITTI, TUM or planar CSV file) meets an OSM map through a
:class:`GeoRef`: the latitude and longitude of the route's (0, 0) and the compass bearing of its +X
axis, or ``utm:ZONE[N|S]`` when the route's x, y already are UTM easting and northing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from xml.parsers import expat

import numpy as np

from sensorsel.errors import InputError, ScenarioError
from sensorsel.model.osm.extract import LocalFrame
from sensorsel.model.scenario.frames import headings_from_travel


@dataclass(frozen=True)
class Track:
    """The points of a GPX file.

    Attributes:
        lat, lon: (N,) [deg] WGS 84.
        times: (N,) [s] since the first point, strictly increasing; None when the file has no times.
        lines: (N,) the line of each point in the file.
        source: the file.
    """

    lat: np.ndarray
    lon: np.ndarray
    times: np.ndarray | None
    lines: tuple[int, ...]
    source: str


def _local(tag: str) -> str:
    return tag.rsplit("}", 1)[-1]


def _time(text: str, path: Path, line: int) -> float:
    try:
        t = datetime.fromisoformat(text.strip().replace("Z", "+00:00"))
    except ValueError:
        raise ScenarioError(
            path, f"bad GPX time {text.strip()!r}: expected ISO 8601, e.g. 2024-05-01T12:00:00Z", line
        ) from None
    if t.tzinfo is None:  # GPX times are UTC
        t = t.replace(tzinfo=datetime.fromisoformat("2000-01-01T00:00:00+00:00").tzinfo)
    return t.timestamp()


def _parse(data: bytes, path: Path) -> tuple[str | None, list[tuple[str, dict[str, str], str | None, int]]]:
    """(root element's local name, [(point kind, attributes, time text or None, line)]) by expat,
    which gives each element's line."""
    pts: list[tuple[str, dict[str, str], str | None, int]] = []
    stack: list[str] = []
    state: dict[str, object] = {"root": None, "time": None}
    p = expat.ParserCreate(namespace_separator="}")

    def start(name: str, attrs: dict[str, str]) -> None:
        name = _local(name)
        if not stack:
            state["root"] = name
        stack.append(name)
        if name in ("trkpt", "rtept", "wpt"):
            pts.append((name, dict(attrs), None, p.CurrentLineNumber))
        elif name == "time":
            state["time"] = ""

    def end(name: str) -> None:
        name = _local(name)
        stack.pop()
        if name == "time" and state["time"] is not None:
            if stack and stack[-1] in ("trkpt", "rtept", "wpt") and pts:
                k, a, _, ln = pts[-1]
                pts[-1] = (k, a, str(state["time"]), ln)
            state["time"] = None

    def chars(text: str) -> None:
        if state["time"] is not None:
            state["time"] = str(state["time"]) + text

    p.StartElementHandler = start
    p.EndElementHandler = end
    p.CharacterDataHandler = chars
    try:
        p.Parse(data, True)
    except expat.ExpatError as exc:
        raise ScenarioError(path, f"malformed GPX (XML): {expat.ErrorString(exc.code)}", exc.lineno) from None
    root = state["root"]
    return (root if isinstance(root, str) else None), pts


def read_gpx(path: str | Path) -> Track:
    """Read the track points of a GPX file (see the module's documentation).

    Raises:
        ScenarioError: missing file, malformed or truncated XML (names the line), not GPX, no
            points, a latitude beyond ±90 or longitude beyond ±180 or a bad number, times on some
            points only, times that do not increase (each names the file and line).
    """
    path = Path(path)
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        raise ScenarioError(path, "GPX file not found") from None
    except OSError as exc:
        raise ScenarioError(path, f"cannot read: {exc.strerror or exc}") from None
    root, pts = _parse(data, path)
    if root != "gpx":
        raise ScenarioError(path, f"not a GPX file: the root element is {root or 'missing'!r}, expected gpx")
    kind = next((k for k in ("trkpt", "rtept", "wpt") if any(p[0] == k for p in pts)), None)
    if kind is None:
        raise ScenarioError(path, "GPX file has no points (no trkpt, rtept or wpt)")
    lat, lon, times, lns = [], [], [], []
    for k, attrib, t, ln in pts:
        if k != kind:
            continue
        try:
            la, lo = float(attrib["lat"]), float(attrib["lon"])
        except KeyError as exc:
            raise ScenarioError(path, f"<{kind}> lacks the attribute {exc.args[0]}", ln) from None
        except ValueError:
            raise ScenarioError(
                path, f"<{kind}> lat/lon not numbers: {attrib.get('lat')!r}, {attrib.get('lon')!r}", ln
            ) from None
        if not (math.isfinite(la) and -90.0 <= la <= 90.0):
            raise ScenarioError(path, f"latitude {la!r} beyond ±90 degrees", ln)
        if not (math.isfinite(lo) and -180.0 <= lo <= 180.0):
            raise ScenarioError(path, f"longitude {lo!r} beyond ±180 degrees", ln)
        lat.append(la)
        lon.append(lo)
        times.append(None if t is None else _time(t, path, ln))
        lns.append(ln)
    have = [t is not None for t in times]
    tarr: np.ndarray | None = None
    if any(have):
        if not all(have):
            raise ScenarioError(path, f"<{kind}> without a <time> while others have one", lns[have.index(False)])
        tt = np.array(times, dtype=float)
        bad = np.flatnonzero(np.diff(tt) <= 0)
        if bad.size:
            i = int(bad[0]) + 1
            raise ScenarioError(
                path,
                f"times going backwards or repeated: point {i} at {times[i]!r} s is not after point {i - 1}",
                lns[i],
            )
        tarr = tt - tt[0]
    return Track(np.array(lat), np.array(lon), tarr, tuple(lns), str(path))


def track_route(
    track: Track, frame: LocalFrame, speed_mps: float | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[str]]:
    """A GPX track as a planar route in ``frame``: ((N, 3) x [m], y [m], heading [rad]; (N,) times [s];
    (N,) index of each pose among the file's points; notes).

    Points of the same position as the previous one are dropped. Without times in the file, the
    times are the distance travelled at ``speed_mps`` (required then).

    Raises:
        InputError: a track without times and no speed; ScenarioError: fewer than 2 distinct points.
    """
    xy = frame.project(track.lon, track.lat)
    step = np.r_[np.inf, np.hypot(*np.diff(xy, axis=0).T)]
    keep = step > 0
    xy = xy[keep]
    notes = []
    if (~keep).any():
        notes.append(f"{int((~keep).sum())} GPX point(s) at the previous point's position dropped")
    if len(xy) < 2:
        raise ScenarioError(track.source, "GPX track has fewer than 2 distinct points: no route")
    if track.times is not None:
        t = track.times[keep]
    else:
        if speed_mps is None:
            raise InputError(f"{track.source}: the GPX points have no times: give --speed")
        t = np.r_[0.0, np.cumsum(np.hypot(*np.diff(xy, axis=0).T))] / speed_mps
        notes.append(f"GPX without times: times from the distance at {speed_mps * 3.6:g} km/h")
    h, hn = headings_from_travel(t, xy)
    return np.column_stack([xy, h]), t, np.flatnonzero(keep), notes + hn


@dataclass(frozen=True)
class GeoRef:
    """Where a route given in a local frame lies on the Earth.

    Either ``lat``/``lon`` [deg] of the route's (0, 0) and ``bearing_deg``, the compass bearing of
    its +X axis (clockwise from north: 90 when +X points east), or ``utm_zone``/``south`` when the
    route's x, y are UTM easting and northing [m] of that zone.
    """

    lat: float | None = None
    lon: float | None = None
    bearing_deg: float = 90.0
    utm_zone: int | None = None
    south: bool = False

    @staticmethod
    def parse(text: str, option: str = "--georef") -> GeoRef:
        """'LAT,LON,BEARING' [deg] or 'utm:35N' -> GeoRef.

        Raises:
            InputError: naming ``option`` and the text.
        """
        s = text.strip()
        if s.lower().startswith("utm:"):
            z = s[4:].strip().upper()
            hemi = z[-1:] if z[-1:] in ("N", "S") else "N"
            num = z[:-1] if z[-1:] in ("N", "S") else z
            if not num.isdigit() or not 1 <= int(num) <= 60:
                raise InputError(f"{option} {text!r}: expected utm:ZONE with a zone 1..60 and N or S, e.g. utm:35N")
            return GeoRef(utm_zone=int(num), south=hemi == "S")
        try:
            la, lo, b = (float(v) for v in s.split(","))
        except ValueError:
            raise InputError(
                f"{option} {text!r}: expected LAT,LON,BEARING in degrees (BEARING of the route's +X axis, "
                "clockwise from north) or utm:ZONE, e.g. 60.17,24.94,90 or utm:35N"
            ) from None
        if not (math.isfinite(la) and -90 <= la <= 90 and math.isfinite(lo) and -180 <= lo <= 180 and math.isfinite(b)):
            raise InputError(f"{option} {text!r}: latitude within ±90, longitude within ±180, a finite bearing")
        return GeoRef(la, lo, b)

    def frame(self) -> LocalFrame:
        """A map frame for this route: the UTM zone of its origin (or its own zone)."""
        if self.utm_zone is not None:
            return LocalFrame(self.utm_zone, self.south, 0.0, 0.0)
        assert self.lat is not None and self.lon is not None
        return LocalFrame.around(self.lon, self.lat)

    def _pose(self, frame: LocalFrame) -> tuple[np.ndarray, float]:
        """(origin (2,) in ``frame`` [m], rotation [rad] from route axes to frame axes)."""
        if self.utm_zone is not None:
            if (frame.zone, frame.south) != (self.utm_zone, self.south):
                raise InputError(
                    f"--georef utm:{self.utm_zone}{'S' if self.south else 'N'}: the map is in {frame.describe()}"
                )
            return np.array([-frame.origin_e, -frame.origin_n]), 0.0
        assert self.lat is not None and self.lon is not None
        o = frame.project(np.array([self.lon]), np.array([self.lat]))[0]
        # +X at compass bearing b is at math angle 90 - b from east; UTM grid north differs from true
        # north by the meridian convergence (< 1.5 degrees within a zone at 60 N), neglected
        return o, math.radians(90.0 - self.bearing_deg)

    def to_map(self, poses: np.ndarray, frame: LocalFrame) -> np.ndarray:
        """(N, 3) route poses (x, y [m], heading [rad]) -> the same poses in the map's ``frame``."""
        o, r = self._pose(frame)
        p = np.asarray(poses, dtype=float).reshape(-1, 3)
        c, s = math.cos(r), math.sin(r)
        x = o[0] + c * p[:, 0] - s * p[:, 1]
        y = o[1] + s * p[:, 0] + c * p[:, 1]
        return np.column_stack([x, y, p[:, 2] + r])

    def from_map(self, xy: np.ndarray, frame: LocalFrame) -> np.ndarray:
        """(N, 2) positions [m] in the map's ``frame`` -> the route's local frame."""
        o, r = self._pose(frame)
        d = np.asarray(xy, dtype=float).reshape(-1, 2) - o
        c, s = math.cos(r), math.sin(r)
        return np.column_stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]])
