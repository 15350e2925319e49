"""A city from OpenStreetMap and GPS tracks (sensorsel.model.osm, ``sensorsel osm``).

Oracles: a minimal PBF decoder written here (protobuf varints + zlib, nothing of pyosmium) for the
element counts; the Krüger series of the transverse Mercator projection written here for UTM;
point-to-segment distances in numpy for the routes against the ways.
"""

from __future__ import annotations

import math
import zlib
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from sensorsel.cli import cli
from sensorsel.model.osm.city import build_city
from sensorsel.model.osm.extract import LANDMARK_CLASSES, LocalFrame, parse_roads, read_osm
from sensorsel.model.osm.gpx import GeoRef, read_gpx

REPO = Path(__file__).resolve().parents[1]
SAMPLE = (
    REPO / "data" / "osm" / "helsinki.osm.pbf"
)  # the shipped sample (a copy of $SENSORSEL_OSM_DIR/helsinki.osm.pbf)
SMALL_BBOX = (24.9380, 60.1650, 24.9460, 60.1700)  # a few hundred metres of central Helsinki


# ------------------------------------------------------------------------ an independent PBF decoder


def _varint(b: bytes, i: int) -> tuple[int, int]:
    shift = result = 0
    while True:
        c = b[i]
        i += 1
        result |= (c & 0x7F) << shift
        shift += 7
        if not c & 0x80:
            return result, i


def _fields(b: bytes):
    """(field number, wire type, value) of a protobuf message; length-delimited values as bytes."""
    i = 0
    while i < len(b):
        key, i = _varint(b, i)
        f, wt = key >> 3, key & 7
        if wt == 0:
            v, i = _varint(b, i)
        elif wt == 2:
            n, i = _varint(b, i)
            v, i = b[i : i + n], i + n
        elif wt == 5:
            v, i = b[i : i + 4], i + 4
        elif wt == 1:
            v, i = b[i : i + 8], i + 8
        else:
            raise ValueError(wt)
        yield f, wt, v


def _packed(b: bytes) -> list[int]:
    out, i = [], 0
    while i < len(b):
        v, i = _varint(b, i)
        out.append(v)
    return out


def _zigzag(v: int) -> int:
    return (v >> 1) ^ -(v & 1)


def decode_pbf_nodes(path: Path) -> list[tuple[int, float, float, dict[str, str]]]:
    """Every node of a .osm.pbf: (id, lat, lon, tags), from the OSM PBF specification."""
    data = path.read_bytes()
    nodes = []
    i = 0
    while i < len(data):
        hlen = int.from_bytes(data[i : i + 4], "big")
        header = dict((f, v) for f, _, v in _fields(data[i + 4 : i + 4 + hlen]))
        size = header[3]
        blob = dict((f, v) for f, _, v in _fields(data[i + 4 + hlen : i + 4 + hlen + size]))
        i += 4 + hlen + size
        if header[1] != b"OSMData":
            continue
        raw = blob[1] if 1 in blob else zlib.decompress(blob[3])
        strings: list[str] = []
        gran, lat_off, lon_off = 100, 0, 0
        groups = []
        for f, _, v in _fields(raw):
            if f == 1:
                strings = [s.decode("utf-8") for g, _, s in _fields(v) if g == 1]
            elif f == 2:
                groups.append(v)
            elif f == 17:
                gran = v
            elif f == 19:
                lat_off = v
            elif f == 20:
                lon_off = v
        for g in groups:
            for f, _, v in _fields(g):
                if f == 2:  # DenseNodes
                    d = {k: val for k, _, val in _fields(v)}
                    ids = np.cumsum([_zigzag(x) for x in _packed(d[1])])
                    lats = np.cumsum([_zigzag(x) for x in _packed(d[8])])
                    lons = np.cumsum([_zigzag(x) for x in _packed(d[9])])
                    kv = _packed(d.get(10, b""))
                    j = 0
                    for n in range(len(ids)):
                        tags = {}
                        while kv and kv[j] != 0:
                            tags[strings[kv[j]]] = strings[kv[j + 1]]
                            j += 2
                        j += 1 if kv else 0
                        nodes.append(
                            (int(ids[n]), 1e-9 * (lat_off + gran * lats[n]), 1e-9 * (lon_off + gran * lons[n]), tags)
                        )
                elif f == 1:  # a plain Node
                    d = {k: val for k, _, val in _fields(v)}
                    keys, vals = _packed(d.get(2, b"")), _packed(d.get(3, b""))
                    nodes.append(
                        (
                            _zigzag(d[1]),
                            1e-9 * (lat_off + gran * _zigzag(d[8])),
                            1e-9 * (lon_off + gran * _zigzag(d[9])),
                            {strings[k]: strings[v_] for k, v_ in zip(keys, vals)},
                        )
                    )
    return nodes


@pytest.fixture(scope="module")
def decoded():
    return decode_pbf_nodes(SAMPLE)


@pytest.fixture(scope="module")
def helsinki():
    return read_osm(SAMPLE)


def test_sample_is_the_original_extract(osm_dir):
    """The shipped sample is byte for byte the original extract ($SENSORSEL_OSM_DIR, tests/conftest.py)."""
    assert (osm_dir / "helsinki.osm.pbf").read_bytes() == SAMPLE.read_bytes()


def test_class_counts_match_an_independent_decoder(decoded, helsinki):
    expected = {
        c: sum(1 for *_, t in decoded if k in t and (v is None or t[k] == v)) for c, (k, v) in LANDMARK_CLASSES.items()
    }
    assert helsinki.tag_counts == expected
    assert helsinki.n_nodes == len(decoded)
    # the README's counts (one more independent decoding)
    assert (
        expected["street_lamp"],
        expected["tree"],
        expected["utility_pole"],
        expected["traffic_signals"],
        expected["traffic_sign"],
    ) == (586, 649, 85, 135, 1671)
    # one landmark a node, every node with a class tag
    assert len(helsinki.landmarks) == sum(
        1 for *_, t in decoded if any(k in t and (v is None or t[k] == v) for k, v in LANDMARK_CLASSES.values())
    )


# ---------------------------------------------------------------------------------- UTM oracle


def utm_kruger(lat: float, lon: float, zone: int) -> tuple[float, float]:
    """UTM easting, northing [m] (northern hemisphere) by the Krüger n-series (WGS 84), to third order."""
    a, f = 6378137.0, 1 / 298.257223563
    n = f / (2 - f)
    A = a / (1 + n) * (1 + n**2 / 4 + n**4 / 64)
    alpha = (n / 2 - 2 * n**2 / 3 + 5 * n**3 / 16, 13 * n**2 / 48 - 3 * n**3 / 5, 61 * n**3 / 240)
    phi, lam = math.radians(lat), math.radians(lon - (zone * 6 - 183))
    c = 2 * math.sqrt(n) / (1 + n)
    t = math.sinh(math.atanh(math.sin(phi)) - c * math.atanh(c * math.sin(phi)))
    xi, eta = math.atan2(t, math.cos(lam)), math.atanh(math.sin(lam) / math.sqrt(1 + t * t))
    e = eta + sum(al * math.cos(2 * j * xi) * math.sinh(2 * j * eta) for j, al in enumerate(alpha, 1))
    nn = xi + sum(al * math.sin(2 * j * xi) * math.cosh(2 * j * eta) for j, al in enumerate(alpha, 1))
    return 500000.0 + 0.9996 * A * e, 0.9996 * A * nn


@pytest.mark.parametrize("lat,lon", [(60.1699, 24.9384), (60.17911, 24.95341), (60.16416, 24.93518), (59.0, 27.5)])
def test_projection_matches_the_utm_formula(lat, lon):
    frame = LocalFrame.around(24.94, 60.17)
    assert (frame.zone, frame.south, frame.epsg) == (35, False, 32635)
    xy = frame.project(np.array([lon]), np.array([lat]))[0]
    e, n = utm_kruger(lat, lon, 35)
    assert abs(xy[0] + frame.origin_e - e) < 0.01 and abs(xy[1] + frame.origin_n - n) < 0.01
    lon2, lat2 = frame.unproject(xy[None])
    assert abs(lon2[0] - lon) < 1e-9 and abs(lat2[0] - lat) < 1e-9


def test_landmarks_sit_where_the_decoder_puts_them(decoded, helsinki):
    by_id = {i: (la, lo) for i, la, lo, _ in decoded}
    f = helsinki.frame
    for k in range(0, len(helsinki.landmarks), 97):
        la, lo = by_id[int(helsinki.landmarks.ids[k])]
        e, n = utm_kruger(la, lo, f.zone)
        d = math.hypot(helsinki.landmarks.xy[k, 0] + f.origin_e - e, helsinki.landmarks.xy[k, 1] + f.origin_n - n)
        if helsinki.landmarks.moved[k]:
            assert 3.0 < d < 31.0  # moved to the kerb: half a road's width + 0.5 m
        else:
            assert d < 0.02


def test_centre_line_signals_are_moved_and_the_rest_are_not(helsinki):
    lm = helsinki.landmarks
    moved = {c for c, m in zip(lm.classes, lm.moved) if m}
    assert moved and moved <= {"traffic_signals", "stop", "give_way", "traffic_sign"}
    assert not any(m for c, m in zip(lm.classes, lm.moved) if c in ("street_lamp", "tree"))
    # the extract does not count them: a route or a city counts its own (kerb_note)
    assert not any("kerb" in n for n in helsinki.notes)
    from sensorsel.model.osm.extract import kerb_note

    assert kerb_note(lm, "the extract's").startswith(f"{int(lm.moved.sum())} of the extract's {len(lm)} landmarks")


# ------------------------------------------------------------------------------ routes on the roads


def _seg_dist(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(P, S) distance of points p (P, 2) to segments a-b (S, 2)."""
    ab = b - a
    t = np.clip(((p[:, None, :] - a[None]) * ab[None]).sum(-1) / np.maximum((ab * ab).sum(-1), 1e-12)[None], 0, 1)
    q = a[None] + t[..., None] * ab[None]
    return np.hypot(*(p[:, None, :] - q).transpose(2, 0, 1))


def test_routes_stay_on_the_ways_and_cover_every_way():
    ex = read_osm(SAMPLE, bbox=SMALL_BBOX, roads=parse_roads(None))
    city = build_city(ex, tuple(LANDMARK_CLASSES), speed_kmh=30.0, route_km=0.5)
    a = np.concatenate([w.xy[:-1] for w in ex.ways])
    b = np.concatenate([w.xy[1:] for w in ex.ways])
    poses = np.concatenate([r.poses[:, :2] for r in city.routes])
    assert len(city.routes) >= 2
    assert _seg_dist(poses, a, b).min(axis=1).max() < 2.0  # every keyframe within 2 m of a selected way
    # every segment of a selected way driven: its midpoint within 2 m of some pose (poses every 0.83 m)
    mid = (a + b) / 2
    seg_len = np.hypot(*(b - a).T)
    from scipy.spatial import cKDTree

    dist, _ = cKDTree(poses).query(mid)
    uncovered = dist > 2.0
    # what is not covered is exactly the pieces left out as too short, and they are counted
    assert seg_len[uncovered].sum() == pytest.approx(city.dropped_m, abs=1e-6)
    assert city.road_m + city.dropped_m == pytest.approx(seg_len[seg_len > 0].sum(), rel=1e-9)
    # what the header calls driven is the routes' own length (what the domain's weights add up to)
    assert city.driven_m == pytest.approx(sum(r.length_m for r in city.routes), rel=1e-12)


def test_sample_domain_runs_greedy_end_to_end(tmp_path):
    out = tmp_path / "city"
    r = CliRunner().invoke(
        cli,
        [
            "osm",
            "--sample",
            "helsinki",
            "--bbox",
            ",".join(map(str, SMALL_BBOX)),
            "--route-km",
            "0.4",
            "--output-dir",
            str(out),
        ],
    )
    assert r.exit_code == 0, r.output
    assert "per km" in r.stdout and "OpenStreetMap contributors" in (out / "domain.yaml").read_text()
    assert "ODbL" in (out / "README.md").read_text()
    g = CliRunner().invoke(cli, ["greedy", "--domain", str(out / "domain.yaml"), "--budget", "110000"])
    assert g.exit_code == 0, g.output
    assert "domain" in g.stdout
    png = tmp_path / "city.png"
    sc = CliRunner().invoke(cli, ["scene", "--domain", str(out / "domain.yaml"), "-o", str(png)])
    assert sc.exit_code == 0, sc.output
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


# ------------------------------------------------------------------------------------------ GPX


def _gpx(points: list[tuple[float, float, str | None]]) -> str:
    body = "".join(
        f'<trkpt lat="{la!r}" lon="{lo!r}">' + (f"<time>{t}</time>" if t else "") + "</trkpt>\n" for la, lo, t in points
    )
    return (
        '<?xml version="1.0"?>\n<gpx version="1.1" xmlns="http://www.topografix.com/GPX/1/1">\n<trk><trkseg>\n'
        + body
        + "</trkseg></trk>\n</gpx>\n"
    )


def test_gpx_track_and_the_same_route_as_csv_score_the_same(tmp_path):
    from sensorsel.api import score_suite
    from sensorsel.model.problem import load_domain
    from sensorsel.model.scenario import write_planar_csv

    # a planar route: 200 m straight then a quarter circle of radius 60 m, at 10 m/s, 10 Hz
    s = np.arange(0, 200 + 60 * math.pi / 2, 1.0)
    x = np.where(s <= 200, s, 200 + 60 * np.sin((s - 200) / 60))
    y = np.where(s <= 200, 0.0, 60 - 60 * np.cos((s - 200) / 60))
    h = np.where(s <= 200, 0.0, (s - 200) / 60)
    poses, t = np.column_stack([x, y, h]), s / 10.0
    write_planar_csv(tmp_path / "drive.csv", poses, t)
    ref = GeoRef.parse("60.1675,24.9400,35")  # the route's +X axis bears 35 degrees (north-east)
    frame = ref.frame()
    lon, lat = frame.unproject(ref.to_map(poses, frame)[:, :2])
    (tmp_path / "drive.gpx").write_text(
        _gpx(
            [
                (la, lo, f"2024-05-01T12:{int(tt) // 60:02d}:{tt % 60:06.3f}Z")
                for la, lo, tt in zip(lat.tolist(), lon.tolist(), t.tolist())
            ]
        )
    )
    track = read_gpx(tmp_path / "drive.gpx")
    assert np.allclose(track.times, t, atol=1e-6)
    r1 = CliRunner().invoke(
        cli, ["osm", str(SAMPLE), "--gpx", str(tmp_path / "drive.gpx"), "--output-dir", str(tmp_path / "a")]
    )
    r2 = CliRunner().invoke(
        cli,
        [
            "osm",
            str(SAMPLE),
            "--route",
            str(tmp_path / "drive.csv"),
            "--georef",
            "60.1675,24.9400,35",
            "--output-dir",
            str(tmp_path / "b"),
        ],
    )
    assert r1.exit_code == 0 and r2.exit_code == 0, (r1.output, r2.output)
    pa = load_domain(tmp_path / "a" / "domain.yaml").routes[0].problem
    pb = load_domain(tmp_path / "b" / "domain.yaml").routes[0].problem
    assert pa.scenario.n_landmarks == pb.scenario.n_landmarks > 20
    for suite in ("LRL-roof", "HD2K-2,LRR-1,MRL-roof"):
        fa, fb = score_suite(pa, suite).score, score_suite(pb, suite).score
        assert fa == pytest.approx(fb, rel=2e-3), suite


# ----------------------------------------------------------------------------------- bad input


def _bad(tmp_path: Path, args: list[str], *names: str) -> None:
    out = tmp_path / "out"
    r = CliRunner().invoke(cli, ["osm", *args, "--output-dir", str(out)])
    assert r.exit_code == 2, r.output
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith(("sensorsel: error:", "Error:")), r.stderr
    assert "Traceback" not in r.output
    for n in names:
        assert n in lines[0], (n, lines[0])
    assert not out.exists()


def test_bad_osm_inputs(tmp_path):
    notosm = tmp_path / "notes.osm"
    notosm.write_text("hello, this is no map\n")
    _bad(tmp_path, [str(notosm)], str(notosm), "not an OSM extract")
    empty = tmp_path / "empty.osm"
    empty.write_text('<?xml version="1.0"?>\n<osm version="0.6">\n</osm>\n')
    _bad(tmp_path, [str(empty)], str(empty), "empty")
    _bad(tmp_path, [str(tmp_path / "missing.osm.pbf")], "missing.osm.pbf", "not found")
    trunc = tmp_path / "trunc.osm"
    trunc.write_text(
        '<?xml version="1.0"?>\n<osm version="0.6">\n<node id="1" lat="60.1" lon="24.9">\n<tag k="highway" v="street'
    )
    _bad(tmp_path, [str(trunc)], str(trunc), "XML")
    _bad(tmp_path, ["--sample", "helsinki", "--bbox", "10,50,11,51"], "--bbox", "outside")
    _bad(tmp_path, ["--sample", "helsinki", "--bbox", "24.9,60.1,24.95"], "--bbox")
    _bad(tmp_path, ["--sample", "helsinki", "--bbox", "24.96,60.1,24.95,60.2"], "--bbox")
    _bad(tmp_path, ["--sample", "helsinki", "--osm-classes", "street_lamp,lamppost"], "--osm-classes", "lamppost")
    _bad(tmp_path, ["--sample", "helsinki", "--roads", "footway"], "--roads", "footway")
    _bad(tmp_path, ["--sample", "atlantis"], "--sample")


def test_bad_gpx_inputs(tmp_path):
    cases = {
        "nopoints.gpx": ('<?xml version="1.0"?>\n<gpx version="1.1"><trk><trkseg></trkseg></trk></gpx>\n', "no points"),
        "backwards.gpx": (
            _gpx([(60.167, 24.94, "2024-05-01T12:00:10Z"), (60.1671, 24.94, "2024-05-01T12:00:05Z")]),
            "backwards",
        ),
        "pole.gpx": (_gpx([(60.167, 24.94, None), (90.5, 24.94, None)]), "latitude"),
        "trunc.gpx": (_gpx([(60.167, 24.94, None), (60.168, 24.94, None)])[:-30], "malformed"),
        "notgpx.gpx": ('<?xml version="1.0"?>\n<kml></kml>\n', "not a GPX"),
    }
    for name, (text, words) in cases.items():
        (tmp_path / name).write_text(text)
        _bad(tmp_path, ["--sample", "helsinki", "--gpx", str(tmp_path / name)], name, words)
    # the line of the bad point is named
    r = CliRunner().invoke(
        cli, ["osm", "--sample", "helsinki", "--gpx", str(tmp_path / "pole.gpx"), "--output-dir", str(tmp_path / "o")]
    )
    assert "pole.gpx:5:" in r.stderr
    _bad(tmp_path, ["--sample", "helsinki", "--route", str(tmp_path / "x.csv"), "--georef", "95,24,0"], "--georef")
