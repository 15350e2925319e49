"""What a new user hit with ``sensorsel osm`` and the route options, each checked on the message a
person reads. The extracts are small ``.osm`` XML files written here (three road pieces near
Vaduz), so every count in a message is known by construction."""

from __future__ import annotations

import bz2
import gzip
from pathlib import Path

import pytest
import yaml
from click.testing import CliRunner

from sensorsel.cli import cli

LAT0, LON0 = 47.14, 9.50
DLON_100M = 100.0 / 75_800.0  # degrees of longitude in 100 m at 47.1 N (cos 47.1 deg * 111.3 km)


def _city_xml() -> str:
    """Three road pieces, each its own network, listed by their first node's id:
    a 600 m road with no landmark within 100 m (nodes 1-7), a 600 m road with five street lamps
    beside it and traffic signals on its centre line (nodes 101-107, lamps 151-155), 1.1 km north,
    and a 45 m road (too short for a route) with traffic signals on it (nodes 201-202), 2.2 km north."""
    nodes, ways = [], []

    def road(first: int, lat: float, n: int, tags_at: dict[int, str]) -> None:
        ids = []
        for k in range(n):
            nid = first + k
            tag = f'<tag k="highway" v="{tags_at[k]}"/>' if k in tags_at else ""
            nodes.append(f'<node id="{nid}" lat="{lat!r}" lon="{LON0 + k * DLON_100M!r}">{tag}</node>')
            ids.append(nid)
        refs = "".join(f'<nd ref="{i}"/>' for i in ids)
        ways.append(f'<way id="{first}">{refs}<tag k="highway" v="residential"/></way>')

    road(1, LAT0, 7, {})
    road(101, LAT0 + 0.010, 7, {3: "traffic_signals"})
    for k in range(5):
        nodes.append(
            f'<node id="{151 + k}" lat="{LAT0 + 0.01015!r}" lon="{LON0 + (k + 1) * DLON_100M!r}">'
            '<tag k="highway" v="street_lamp"/></node>'
        )
    nodes.append(f'<node id="201" lat="{LAT0 + 0.020!r}" lon="{LON0!r}"><tag k="highway" v="traffic_signals"/></node>')
    nodes.append(f'<node id="202" lat="{LAT0 + 0.020!r}" lon="{LON0 + 0.6 * DLON_100M!r}"/>')
    ways.append('<way id="201"><nd ref="201"/><nd ref="202"/><tag k="highway" v="residential"/></way>')
    return (
        "<?xml version='1.0' encoding='UTF-8'?>\n<osm version=\"0.6\">\n"
        + "\n".join(nodes)
        + "\n"
        + "\n".join(ways)
        + "\n</osm>\n"
    )


@pytest.fixture(scope="module")
def city(tmp_path_factory) -> Path:
    p = tmp_path_factory.mktemp("city") / "vaduz.osm"
    p.write_text(_city_xml(), encoding="utf-8")
    return p


def _osm(*args):
    return CliRunner().invoke(cli, ["osm", *map(str, args)])


def test_a_road_without_landmarks_is_not_named_after_the_next_route(city, tmp_path):
    """The bare road comes first: it is left out without a name (it was 'route r001', the name the
    kept route then got too), and the header's kilometres are the routes' own. A dead end is driven
    there and back: the bare 600 m road is 1.2 km of driving."""
    r = _osm(city, "--output-dir", tmp_path / "d")
    assert r.exit_code == 0, r.output
    dom = yaml.safe_load((tmp_path / "d" / "domain.yaml").read_text())
    assert [x["name"] for x in dom["routes"]] == ["r001"]
    notes = [ln for ln in r.stderr.splitlines() if "note:" in ln]
    assert not any("route r00" in n for n in notes), notes
    bare = [n for n in notes if "no landmark within 100 m" in n]
    assert (
        len(bare) == 1 and "1 stretch(es) of road (1.20 km driven)" in bare[0] and "lat,lon 47.14000,9.50000" in bare[0]
    )
    km = sum(x["weight"]["km"] for x in dom["routes"])
    header = next(ln for ln in r.stdout.splitlines() if ln.startswith("city"))
    assert f"1 routes, {km:.2f} km driven" in header, header
    assert f"# 1 routes, {km:.3f} km driven" in (tmp_path / "d" / "domain.yaml").read_text()


def test_the_kerb_note_counts_the_routes_landmarks_and_every_note_says_sensorsel(city, tmp_path):
    """Two traffic signals are moved to the kerb in the extract, one of them on a route: the note
    counts the routes' one. The projection is told once, and every line on stderr is 'sensorsel: ...'."""
    r = _osm(city, "--output-dir", tmp_path / "d")
    assert r.exit_code == 0, r.output
    lines = r.stderr.splitlines()
    assert lines and all(ln.startswith("sensorsel: ") for ln in lines), lines
    kerb = [ln for ln in lines if "kerb" in ln]
    assert len(kerb) == 1 and "note: 1 of the routes' 6 landmarks" in kerb[0], kerb
    assert sum("UTM zone 32N" in ln for ln in lines) == 1


def test_a_route_track_tells_its_projection_once(city, tmp_path):
    """osm --gpx: the track's note names the map frame; the extract's projection note is not repeated."""
    gpx = tmp_path / "t.gpx"
    pts = "".join(
        f'<trkpt lat="{LAT0 + 0.0101!r}" lon="{LON0 + k * DLON_100M / 10!r}">'
        f"<time>2024-05-01T12:00:{k:02d}Z</time></trkpt>"
        for k in range(50)
    )
    gpx.write_text(
        f'<?xml version="1.0"?><gpx version="1.1" xmlns="http://www.topografix.com/GPX/1/1"><trk><trkseg>{pts}'
        "</trkseg></trk></gpx>"
    )
    r = _osm(city, "--gpx", gpx, "--output-dir", tmp_path / "d")
    assert r.exit_code == 0, r.output
    lines = r.stderr.splitlines()
    assert sum("UTM zone 32N" in ln for ln in lines) == 1, lines
    assert all(ln.startswith("sensorsel: ") for ln in lines), lines


@pytest.mark.parametrize("suffix, pack", [(".osm.bz2", bz2.compress), (".osm.gz", gzip.compress)])
def test_a_compressed_extract_is_read_as_its_xml(city, tmp_path, suffix, pack):
    packed = tmp_path / f"vaduz{suffix}"
    packed.write_bytes(pack(city.read_bytes()))
    plain, comp = _osm(city, "--output-dir", tmp_path / "a"), _osm(packed, "--output-dir", tmp_path / "b")
    assert plain.exit_code == 0 and comp.exit_code == 0, comp.output
    for f in ("routes/r001.csv", "routes/r001_landmarks.csv", "landmarks.csv"):
        assert (tmp_path / "a" / f).read_bytes() == (tmp_path / "b" / f).read_bytes()


def test_something_else_is_still_not_an_extract(tmp_path):
    bad = tmp_path / "x.osm.bz2"
    bad.write_bytes(b"PK\x03\x04 a zip file")
    r = _osm(bad, "--output-dir", tmp_path / "d")
    assert r.exit_code == 2 and "not an OSM extract" in r.stderr and ".osm.bz2" in r.stderr


def test_a_bbox_with_latitude_and_longitude_swapped_says_so(city, tmp_path):
    lat_first = f"{LAT0 - 0.001},{LON0 - 0.001},{LAT0 + 0.03},{LON0 + 0.01}"
    r = _osm(city, "--bbox", lat_first, "--output-dir", tmp_path / "d")
    assert r.exit_code == 2 and len(r.stderr.splitlines()) == 1
    assert "outside the extract" in r.stderr and "latitude and longitude exchanged" in r.stderr
    assert f"--bbox {LON0 - 0.001:g},{LAT0 - 0.001:g},{LON0 + 0.01:g},{LAT0 + 0.03:g} lies in it" in r.stderr
    far = _osm(city, "--bbox", "10,50,11,51", "--output-dir", tmp_path / "e")  # simply elsewhere: no such hint
    assert far.exit_code == 2 and "outside the extract" in far.stderr and "exchanged" not in far.stderr


def test_a_suite_id_in_the_wrong_case_is_suggested():
    r = CliRunner().invoke(cli, ["score", "--fixture", "tiny", "--suite", "lrl-roof,HD2K-3"])
    assert r.exit_code == 2 and len(r.stderr.splitlines()) == 1
    assert "unknown sensor id 'lrl-roof'; did you mean LRL-roof? (ids are case-sensitive)" in r.stderr
    r = CliRunner().invoke(cli, ["score", "--fixture", "tiny", "--suite", "QQQ"])
    assert r.exit_code == 2 and "did you mean" not in r.stderr


def test_the_city_guide_states_the_sample_citys_numbers(tmp_path):
    """docs/guide-new-city.md's numbers for the bundled Helsinki sample, from the command itself."""
    guide = (Path(__file__).resolve().parents[1] / "docs" / "guide-new-city.md").read_text(encoding="utf-8")
    r = _osm("--sample", "helsinki", "--output-dir", tmp_path / "h")
    assert r.exit_code == 0, r.output
    header = next(ln for ln in r.stdout.splitlines() if ln.startswith("city"))
    road, routes = header.split(": ", 1)[1].split(" km of road")[0], header.split("), ")[1].split(" driven")[0]
    assert f"{road} km of road, {routes} driven at 30 km/h" in " ".join(guide.split())
    circuits = next(ln for ln in r.stderr.splitlines() if "km of circuits" in ln)
    assert f"circuits are {circuits.split('note: ')[1].split(' km')[0]} km" in " ".join(guide.split())
    kerb = next(ln for ln in r.stderr.splitlines() if "kerb" in ln)
    assert f"{kerb.split('note: ')[1].split(' of ')[0]} centre-line nodes" in guide
