"""An operating domain from a city's road network (``sensorsel osm``).

The selected roads form a graph (one edge a pair of consecutive way nodes). Each connected piece is
made Eulerian by driving again the shortest path between pairs of odd-degree junctions (paired
greedily, nearest first: a minimum-weight matching would repeat a little less road but costs cubic
time in the number of junctions), and its Eulerian circuit (networkx) drives every selected road
at least once, in one go. The circuit is cut into routes of about ``route_km``; keyframes are
sampled along it at ``speed_kmh`` (the route CSV at :data:`SAMPLE_HZ`, the domain's keyframes at
``keyframe_rate_hz``). A piece of road network shorter than ``min_route_m`` (a stub cut by the
bounding box) is left out and counted. Each route carries the landmarks within ``reach_m`` of it;
its weight is its length in km.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from sensorsel.errors import InputError
from sensorsel.io.files import atomic_write_text
from sensorsel.model.osm.extract import LANDMARK_CLASSES, OsmExtract, OsmLandmarks, OsmWay, kerb_note

SAMPLE_HZ = 10.0  # poses a second in a route CSV (KITTI's rate); keyframes are chosen from these
SPARSE_PER_KM = 30.0  # warn below this many landmarks per km of road (SemanticKITTI's pole maps: ~150/km)
ATTRIBUTION = "Data © OpenStreetMap contributors, ODbL 1.0 (https://www.openstreetmap.org/copyright)"


@dataclass(frozen=True)
class CityRoute:
    """One route of the city: (N, 3) poses x, y [m], heading [rad], (N,) times [s], its landmarks."""

    name: str
    poses: np.ndarray
    times: np.ndarray
    landmarks: OsmLandmarks

    @property
    def length_m(self) -> float:
        return float(np.sum(np.hypot(*np.diff(self.poses[:, :2], axis=0).T)))


@dataclass(frozen=True)
class City:
    """What :func:`build_city` made.

    Attributes:
        routes: the routes, in circuit order.
        road_m: length of the selected roads [m] (each once), of the pieces kept.
        driven_m: length of the routes [m] (roads driven again to join them included).
        dropped_m: length of road in pieces shorter than ``min_route_m`` [m], left out.
        density: per class, landmarks within ``reach_m`` of the kept roads per km of road.
        landmarks: every landmark of the chosen classes (for the map and the drawing).
        notes: what was assumed, dropped or moved.
    """

    routes: tuple[CityRoute, ...]
    road_m: float
    driven_m: float
    dropped_m: float
    density: dict[str, float]
    landmarks: OsmLandmarks
    notes: tuple[str, ...]


def _graph(ways: tuple[OsmWay, ...]):  # type: ignore[no-untyped-def]
    import networkx as nx

    g = nx.MultiGraph()
    for w in ways:
        for k in range(len(w.nodes) - 1):
            a, b = w.nodes[k], w.nodes[k + 1]
            if a == b:
                continue
            seg = w.xy[k : k + 2]
            g.add_node(a, xy=seg[0])
            g.add_node(b, xy=seg[1])
            g.add_edge(a, b, length=float(np.hypot(*(seg[1] - seg[0]))), way=w.id, repeat=False)
    return g


def _eulerize(g) -> int:  # type: ignore[no-untyped-def]
    """Add repeat edges along shortest paths pairing the odd-degree nodes (greedy, nearest first,
    in node-id order: deterministic); the number of edges added."""
    import networkx as nx

    odd = sorted(n for n, d in g.degree() if d % 2)
    todo = set(odd)
    added = 0
    simple = nx.Graph()
    for a, b, d in g.edges(data=True):
        if not simple.has_edge(a, b) or simple[a][b]["length"] > d["length"]:
            simple.add_edge(a, b, length=d["length"])
    for a in odd:
        if a not in todo:
            continue
        todo.discard(a)
        dist, paths = nx.single_source_dijkstra(simple, a, weight="length")
        b = min((n for n in todo if n in dist), key=lambda n: (dist[n], n))
        todo.discard(b)
        path = paths[b]
        for u, v in zip(path[:-1], path[1:]):
            g.add_edge(u, v, length=simple[u][v]["length"], way=None, repeat=True)
            added += 1
    return added


def _resample(xy: np.ndarray, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Points every ``step`` [m] along the polyline ``xy`` (K, 2) (its last point included), and the
    heading [rad] of the segment each lies on."""
    seg = np.diff(xy, axis=0)
    seg_len = np.hypot(seg[:, 0], seg[:, 1])
    keep = seg_len > 0
    seg, seg_len = seg[keep], seg_len[keep]
    starts = np.r_[xy[:1], xy[1:][keep]][:-1] if keep.any() else xy[:1]
    cum = np.r_[0.0, np.cumsum(seg_len)]
    total = cum[-1]
    n = max(int(math.floor(total / step)), 1)
    s = np.r_[np.arange(n + 1) * step, total] if n * step < total - 1e-9 else np.arange(n + 1) * total / n
    i = np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(seg) - 1)
    frac = (s - cum[i]) / seg_len[i]
    pts = starts[i] + seg[i] * frac[:, None]
    return pts, np.arctan2(seg[i, 1], seg[i, 0])


def build_city(
    extract: OsmExtract,
    classes: tuple[str, ...],
    *,
    speed_kmh: float = 30.0,
    route_km: float = 1.0,
    min_route_m: float = 100.0,
    reach_m: float = 100.0,
) -> City:
    """The routes and landmarks of an operating domain covering the extract's roads (see the module).

    Args:
        extract: what :func:`~sensorsel.model.osm.extract.read_osm` read (its ways are the selected roads).
        classes: landmark classes to keep.
        speed_kmh: driving speed [km/h] (times of the route CSVs).
        route_km: length of a route [km] (the last piece of a circuit joins the one before when
            shorter than half of it).
        min_route_m: pieces of road network shorter than this [m] are left out (counted).
        reach_m: a route's landmarks are those within this distance [m] of it.

    Raises:
        InputError: no selected road in the extract, a non-positive speed or length.
    """
    import networkx as nx

    for name, v in (("--speed", speed_kmh), ("--route-km", route_km)):
        if not (math.isfinite(v) and v > 0):
            raise InputError(f"{name} {v!r}: expected a positive number")
    if not extract.ways:
        raise InputError(f"{extract.source}: no road of the selected kinds (--roads) in the extract (or inside --bbox)")
    lms = extract.landmarks.of(classes)
    g = _graph(extract.ways)
    step = speed_kmh / 3.6 / SAMPLE_HZ
    routes: list[CityRoute] = []
    road_m = driven_m = dropped_m = 0.0
    n_dropped = 0
    kept_xy: list[np.ndarray] = []
    notes: list[str] = []
    tree = cKDTree(lms.xy) if len(lms) else None
    comps = sorted((sorted(c) for c in nx.connected_components(g)), key=lambda c: c[0])
    repeats = 0
    circuit_m = 0.0  # the circuits' length, stretches without landmarks included
    bare: list[tuple[float, np.ndarray]] = []  # (length [m], first point) of each stretch left out
    for comp in comps:
        sub = nx.MultiGraph(g.subgraph(comp))
        length = sum(d["length"] for _, _, d in sub.edges(data=True))
        if length < min_route_m:
            dropped_m += length
            n_dropped += 1
            continue
        road_m += length
        repeats += _eulerize(sub)
        pts = [sub.nodes[comp[0]]["xy"]]
        for _u, v, _k in nx.eulerian_circuit(sub, source=comp[0], keys=True):
            pts.append(sub.nodes[v]["xy"])
        poly = np.asarray(pts, dtype=float)
        kept_xy.append(poly)
        seg = np.hypot(*np.diff(poly, axis=0).T)
        cum = np.r_[0.0, np.cumsum(seg)]
        circuit_m += cum[-1]
        n_parts = max(int(round(cum[-1] / (route_km * 1000.0))), 1)
        cuts = np.searchsorted(cum, np.arange(1, n_parts) * cum[-1] / n_parts)
        bounds = [0, *cuts.tolist(), len(poly) - 1]
        for a, b in zip(bounds[:-1], bounds[1:]):
            if b <= a:
                continue
            xy, heading = _resample(poly[a : b + 1], step)
            near = _near(tree, xy, reach_m)
            if not near.size:  # no route: it gets no name (the next kept route takes the next one)
                bare.append((float(cum[b] - cum[a]), poly[a]))
                continue
            name = f"r{len(routes) + 1:03d}"
            routes.append(
                CityRoute(
                    name,
                    np.column_stack([xy, heading]),
                    np.arange(len(xy)) / SAMPLE_HZ,
                    OsmLandmarks(lms.xy[near], tuple(lms.classes[i] for i in near), lms.ids[near], lms.moved[near]),
                )
            )
    if not routes:
        raise InputError(
            f"{extract.source}: the selected roads make no route of at least {min_route_m:g} m with landmarks"
        )
    driven_m = float(sum(r.length_m for r in routes))
    if bare:
        lon, lat = extract.frame.unproject(np.array([p for _, p in bare]))
        starts = [f"{la:.5f},{lo:.5f}" for la, lo in zip(np.ravel(lat).tolist(), np.ravel(lon).tolist())]
        where = "; ".join(starts[:3]) + (f"; and {len(starts) - 3} more" if len(starts) > 3 else "")
        notes.append(
            f"{len(bare)} stretch(es) of road ({sum(m for m, _ in bare) / 1000:.2f} km driven) with no landmark within "
            f"{reach_m:g} m left out: no route of them (starting at lat,lon {where})"
        )
    if n_dropped:
        notes.append(
            f"{n_dropped} piece(s) of road network shorter than {min_route_m:g} m ({dropped_m:.0f} m in all) left out"
        )
    if repeats:
        notes.append(
            f"{circuit_m / 1000:.2f} km of circuits to cover {road_m / 1000:.2f} km of road once "
            f"(roads between odd junctions driven again)"
        )
    allxy = np.concatenate(kept_xy)
    near_all = _near(tree, _resample(allxy, 5.0)[0], reach_m) if len(allxy) > 1 else np.zeros(0, int)
    density = {c: sum(1 for i in near_all if lms.classes[i] == c) / (road_m / 1000.0) for c in classes}
    used = np.isin(lms.ids, np.concatenate([r.landmarks.ids for r in routes]))  # the routes' landmarks
    kerb = kerb_note(
        OsmLandmarks(lms.xy[used], tuple(c for c, k in zip(lms.classes, used) if k), lms.ids[used], lms.moved[used]),
        "the routes'",
    )
    if kerb is not None:
        notes.insert(0, kerb)
    return City(tuple(routes), road_m, driven_m, dropped_m, density, lms, tuple(notes))


def _near(tree: cKDTree | None, xy: np.ndarray, reach_m: float) -> np.ndarray:
    """Sorted indices of the landmarks within ``reach_m`` of any of the points ``xy`` (K, 2)."""
    if tree is None:
        return np.zeros(0, dtype=int)
    dense = xy
    hits = tree.query_ball_point(dense, r=reach_m)
    return np.array(sorted({i for h in hits for i in h}), dtype=int)


def density_table(city: City) -> list[tuple[str, int, float]]:
    """(class, landmarks within reach of the roads, per km of road) of each class, then 'all'."""
    km = city.road_m / 1000.0
    rows = [(c, int(round(v * km)), v) for c, v in city.density.items()]
    total = sum(v for _, _, v in rows)
    return rows + [("all", int(round(total * km)), total)]


def sparse_warning(city: City) -> str | None:
    """A warning when the map has fewer than :data:`SPARSE_PER_KM` landmarks per km of road."""
    return sparse_message(sum(city.density.values()), "road")


def sparse_message(per_km: float, what: str) -> str | None:
    """The sparse-map warning for ``per_km`` landmarks per km of ``what`` (road, route), or None
    when there are at least :data:`SPARSE_PER_KM`."""
    if per_km < SPARSE_PER_KM:
        return (
            f"the map looks sparse: {per_km:.1f} landmarks per km of {what} (SemanticKITTI's pole maps have ~150/km); "
            "OSM's pole coverage varies by orders of magnitude between cities: a suite chosen on it favours long range"
        )
    return None


def write_city(
    city: City, extract: OsmExtract, folder: str | Path, *, command: str, keyframe_rate_hz: float = 1.0
) -> Path:
    """Write the domain folder: ``domain.yaml``, ``routes/rNNN.csv`` + ``routes/rNNN_landmarks.csv``,
    ``landmarks.csv`` (every landmark with its class and OSM id) and ``README.md`` (attribution,
    frame, density). Every file atomically; ``domain.yaml`` last. Returns the domain file."""
    from sensorsel.model.scenario import write_planar_csv

    folder = Path(folder)
    lines = [
        f"# An operating domain written by: {command}",
        f"# from {extract.source}; {ATTRIBUTION}",
        f"# frame: {extract.frame.describe()}",
        f"# {len(city.routes)} routes, {city.driven_m / 1000:.3f} km driven covering "
        f"{city.road_m / 1000:.3f} km of road;",
        "# each route weighs its length in km.",
        f"keyframe_rate_hz: {keyframe_rate_hz!r}",
        "weight_unit: km",
        "routes:",
    ]
    for r in city.routes:
        write_planar_csv(folder / "routes" / f"{r.name}.csv", r.poses, r.times)
        _write_landmarks(folder / "routes" / f"{r.name}_landmarks.csv", r.landmarks)
        lines += [
            f"  - name: {r.name}",
            f"    route: routes/{r.name}.csv",
            "    format: csv",
            f"    landmarks: routes/{r.name}_landmarks.csv",
            f"    weight: {{km: {r.length_m / 1000.0:.6f}}}",
        ]
    _write_landmarks(folder / "landmarks.csv", city.landmarks)
    table = "\n".join(f"| {c} | {n} | {v:.1f} |" for c, n, v in density_table(city))
    readme = (
        f"# Operating domain from OpenStreetMap\n\n{ATTRIBUTION}. Source: `{extract.source}`.\n\n"
        f"Written by `{command}`.\n\nFrame: {extract.frame.describe()}; x east, y north [m].\n\n"
        f"{len(city.routes)} routes, {city.driven_m / 1000:.3f} km driven, {city.road_m / 1000:.3f} km of road.\n\n"
        f"| class | landmarks near the roads | per km of road |\n|---|---:|---:|\n{table}\n\n"
        + "".join(f"- {n}\n" for n in (*extract.notes, *city.notes))
    )
    atomic_write_text(folder / "README.md", readme)
    return atomic_write_text(folder / "domain.yaml", "\n".join(lines) + "\n")


def _write_landmarks(path: Path, lms: OsmLandmarks) -> Path:
    body = "".join(
        f"{x:.3f},{y:.3f},{c},{i},{int(m)}\n"
        for (x, y), c, i, m in zip(lms.xy.tolist(), lms.classes, lms.ids.tolist(), lms.moved.tolist())
    )
    return atomic_write_text(path, "x,y,class,osm_id,moved\n" + body)


def read_landmark_classes(path: str | Path) -> tuple[np.ndarray, tuple[str, ...]] | None:
    """(M, 2) positions [m] and classes of a landmark CSV with a ``class`` column (as written here),
    or None when it has none (a plain x,y map)."""
    import csv

    try:
        with open(path, newline="", encoding="utf-8") as fh:
            rows = [r for r in csv.reader(fh) if r and not r[0].lstrip().startswith("#")]
    except OSError:
        return None
    if not rows or "class" not in [h.strip().lower() for h in rows[0]]:
        return None
    head = [h.strip().lower() for h in rows[0]]
    ix, iy, ic = head.index("x"), head.index("y"), head.index("class")
    xy = np.array([[float(r[ix]), float(r[iy])] for r in rows[1:]], dtype=float).reshape(-1, 2)
    return xy, tuple(r[ic].strip() for r in rows[1:])


__all__ = [
    "City",
    "CityRoute",
    "build_city",
    "write_city",
    "density_table",
    "sparse_warning",
    "sparse_message",
    "read_landmark_classes",
    "LANDMARK_CLASSES",
    "SPARSE_PER_KM",
    "ATTRIBUTION",
]
