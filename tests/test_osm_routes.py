"""OpenStreetMap and GPS tracks on every route command: ``--route TRACK.gpx``, ``--georef``, ``--landmarks osm:FILE``
(merged with a survey CSV), the density report and the bad inputs; and the Helsinki sample in the wheel.

Oracles: the same drive given two ways (a GPX track, and a planar CSV with its georeference) must
score the same; the landmarks ``sensorsel osm --gpx`` writes for a track; a brute-force distance
matrix (numpy) for which OSM landmarks lie within reach and for the density per class; counts
worked by hand for the merge.
"""

from __future__ import annotations

import json
import math
import re
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from sensorsel.cli import cli
from sensorsel.model.osm.extract import LocalFrame, parse_roads, read_osm
from sensorsel.model.osm.gpx import GeoRef
from sensorsel.model.osm.track import DUPLICATE_M
from sensorsel.model.problem import load_problem
from sensorsel.model.scenario import ScenarioSpec, write_planar_csv

REPO = Path(__file__).resolve().parents[1]
SAMPLE = REPO / "data" / "osm" / "helsinki.osm.pbf"
GEOREF = "60.1675,24.9400,35"  # the drive's (0, 0) in central Helsinki, its +X axis bearing 35 degrees


def _drive(folder: Path) -> tuple[Path, Path, np.ndarray]:
    """A 294 m drive (200 m straight, a quarter circle of 60 m) as a planar CSV in its own frame and
    as the GPX track of the same positions placed by GEOREF; (csv, gpx, (N, 3) poses)."""
    s = np.arange(0, 200 + 60 * math.pi / 2, 1.0)
    x = np.where(s <= 200, s, 200 + 60 * np.sin((s - 200) / 60))
    y = np.where(s <= 200, 0.0, 60 - 60 * np.cos((s - 200) / 60))
    h = np.where(s <= 200, 0.0, (s - 200) / 60)
    poses, t = np.column_stack([x, y, h]), s / 10.0
    csv = write_planar_csv(folder / "drive.csv", poses, t)
    ref = GeoRef.parse(GEOREF)
    frame = ref.frame()
    lon, lat = frame.unproject(ref.to_map(poses, frame)[:, :2])
    pts = "".join(
        f'<trkpt lat="{la!r}" lon="{lo!r}"><time>2024-05-01T12:{int(tt) // 60:02d}:{tt % 60:06.3f}Z</time></trkpt>\n'
        for la, lo, tt in zip(lat.tolist(), lon.tolist(), t.tolist())
    )
    gpx = folder / "drive.gpx"
    gpx.write_text(
        '<?xml version="1.0"?>\n<gpx version="1.1" xmlns="http://www.topografix.com/GPX/1/1">\n<trk><trkseg>\n'
        + pts
        + "</trkseg></trk>\n</gpx>\n"
    )
    return csv, gpx, poses


@pytest.fixture(scope="module")
def drive(tmp_path_factory):
    return _drive(tmp_path_factory.mktemp("drive"))


def _ok(args: list[str]):
    r = CliRunner().invoke(cli, args)
    assert r.exit_code == 0, r.output
    return r


def test_gpx_track_and_georeferenced_csv_score_the_same_through_the_cli(drive):
    csv, gpx, _ = drive
    for suite in ("LRL-roof", "HD2K-2,LRR-1,MRL-roof"):
        a = json.loads(
            _ok(["score", "--route", str(gpx), "--landmarks", f"osm:{SAMPLE}", "--suite", suite, "--json"]).stdout
        )
        b = json.loads(
            _ok(
                [
                    "score",
                    "--route",
                    str(csv),
                    "--georef",
                    GEOREF,
                    "--landmarks",
                    f"osm:{SAMPLE}",
                    "--suite",
                    suite,
                    "--json",
                ]
            ).stdout
        )
        assert a["problem"]["n_landmarks"] == b["problem"]["n_landmarks"] > 100
        assert a["problem"]["n_poses"] == b["problem"]["n_poses"] == 30
        assert a["score"] == pytest.approx(b["score"], rel=1e-7), suite
    # the bearing is used: the same CSV turned by 90 degrees sees other landmarks and scores otherwise
    c = json.loads(
        _ok(
            [
                "score",
                "--route",
                str(csv),
                "--georef",
                "60.1675,24.9400,125",
                "--landmarks",
                f"osm:{SAMPLE}",
                "--suite",
                "LRL-roof",
                "--json",
            ]
        ).stdout
    )
    assert c["score"] != pytest.approx(a["score"], rel=1e-3)


def test_osm_landmarks_on_a_route_are_those_sensorsel_osm_writes_and_those_within_reach(drive, tmp_path):
    _, gpx, _ = drive
    _ok(["osm", str(SAMPLE), "--gpx", str(gpx), "--output-dir", str(tmp_path / "dom")])
    written = np.loadtxt(tmp_path / "dom" / "routes" / "drive_landmarks.csv", delimiter=",", skiprows=1, usecols=(0, 1))
    route_csv = np.loadtxt(tmp_path / "dom" / "routes" / "drive.csv", delimiter=",", skiprows=1)
    problem = load_problem(ScenarioSpec(route=str(gpx), osm=(str(SAMPLE),)))
    got = np.asarray(problem.scenario.landmarks)
    assert got.shape == written.shape and len(got) > 100
    order = lambda a: a[np.lexsort((a[:, 1], a[:, 0]))]  # noqa: E731
    assert np.allclose(order(got), order(written), atol=1e-3)  # the CSV has millimetres
    assert np.allclose(problem.scenario.route.poses, route_csv[:, 1:], atol=1e-9)
    # brute force: every landmark of the extract within 100 m of a route position, and no other
    frame = LocalFrame.around(*np.mean(_lonlat(gpx), axis=0))
    every = read_osm(
        SAMPLE, frame=frame, roads=parse_roads(None)
    ).landmarks.xy  # centre-line nodes moved off these roads
    d = np.sqrt(((every[:, None, :] - route_csv[None, :, 1:3]) ** 2).sum(-1)).min(axis=1)
    assert np.allclose(order(every[d <= 100.0]), order(got), atol=1e-9)


def _lonlat(gpx: Path) -> np.ndarray:
    pts = re.findall(r'lat="([^"]+)" lon="([^"]+)"', gpx.read_text())
    return np.array([[float(lo), float(la)] for la, lo in pts])


def test_density_per_class_and_the_sparse_warning(drive):
    csv, gpx, _ = drive
    problem = load_problem(ScenarioSpec(route=str(gpx), osm=(str(SAMPLE),)))
    route = problem.scenario.route
    km = route.length_m / 1000.0
    frame = LocalFrame.around(*np.mean(_lonlat(gpx), axis=0))
    lms = read_osm(SAMPLE, frame=frame, roads=parse_roads(None)).landmarks
    d = np.sqrt(((lms.xy[:, None, :] - route.poses[None, :, :2]) ** 2).sum(-1)).min(axis=1)
    near = [c for c, dd in zip(lms.classes, d) if dd <= 100.0]
    r = _ok(["score", "--route", str(gpx), "--landmarks", f"osm:{SAMPLE}", "--suite", "LRL-roof"])
    line = next(ln for ln in r.stderr.splitlines() if "landmarks per km of route" in ln)
    for c in ("street_lamp", "tree", "traffic_sign"):
        assert f"{c} {near.count(c) / km:.1f}" in line, (c, line)
    assert f"all {len(near) / km:.1f}" in line
    assert "sparse" not in r.stderr  # ~630 per km
    few = ("give_way", "utility_pole")
    sparse = _ok(
        [
            "score",
            "--route",
            str(csv),
            "--georef",
            GEOREF,
            "--landmarks",
            f"osm:{SAMPLE}",
            "--osm-classes",
            ",".join(few),
            "--suite",
            "LRL-roof",
        ]
    )
    assert 0 < sum(near.count(c) for c in few) / km < 30
    assert "sensorsel: warning: the map looks sparse" in sparse.stderr


def test_survey_merge_counts_and_duplicates(drive, tmp_path):
    csv, _, _ = drive
    base = ScenarioSpec(route=str(csv), georef=GEOREF, osm=(str(SAMPLE),))
    osm = np.asarray(load_problem(base).scenario.landmarks)
    # a landmark with no other within 6 m: a survey point 1 m from it is the same pole
    from scipy.spatial import cKDTree

    tree = cKDTree(osm)
    gaps = tree.query(osm, k=2)[0][:, 1]
    k = int(np.flatnonzero(gaps > 6.0)[0])
    same = osm[k] + [1.0, 0.0]
    # a point 2.5 m and more from every OSM landmark: another object, both kept
    grid = np.array([[x, y] for x in range(0, 200, 5) for y in (-30, -20, 20, 30)], dtype=float)
    other = grid[int(np.flatnonzero(tree.query(grid)[0] > DUPLICATE_M + 0.5)[0])]
    far = np.array([600.0, 600.0])  # beyond the OSM reach: a survey landmark is kept all the same
    survey = tmp_path / "survey.csv"
    survey.write_text("x,y\n" + "".join(f"{x!r},{y!r}\n" for x, y in np.array([same, other, far]).tolist()))
    r = _ok(
        [
            "score",
            "--route",
            str(csv),
            "--georef",
            GEOREF,
            "--landmarks",
            f"osm:{SAMPLE}",
            "--landmarks",
            str(survey),
            "--suite",
            "LRL-roof",
            "--json",
        ]
    )
    merged = load_problem(
        ScenarioSpec(route=str(csv), georef=GEOREF, osm=(str(SAMPLE),), landmarks=str(survey))
    ).scenario.landmarks
    assert json.loads(r.stdout)["problem"]["n_landmarks"] == len(merged) == len(osm) - 1 + 3
    assert not np.isclose(merged, osm[k]).all(axis=1).any()  # the OSM position of the duplicate is gone
    for p in (same, other, far):
        assert np.isclose(merged, p).all(axis=1).any()
    assert "1 OSM landmark(s) within 2 m of a survey landmark" in r.stderr
    assert f"osm:{SAMPLE} + {survey}" in json.loads(r.stdout)["problem"]["landmark_source"]
    # the same extract twice (overlapping tiles): each node once
    twice = load_problem(ScenarioSpec(route=str(csv), georef=GEOREF, osm=(str(SAMPLE), str(SAMPLE)))).scenario
    assert len(twice.landmarks) == len(osm) and any("taken once" in n for n in twice.notes)


def test_sensorsel_osm_merge_landmarks_shares_the_merge(drive, tmp_path):
    csv, _, _ = drive
    osm = np.asarray(load_problem(ScenarioSpec(route=str(csv), georef=GEOREF, osm=(str(SAMPLE),))).scenario.landmarks)
    survey = tmp_path / "survey.csv"
    from scipy.spatial import cKDTree

    k = int(np.flatnonzero(cKDTree(osm).query(osm, k=2)[0][:, 1] > 6.0)[0])  # no other landmark within 6 m
    survey.write_text(f"x,y\n{float(osm[k, 0]) + 0.5!r},{float(osm[k, 1])!r}\n")
    _ok(
        [
            "osm",
            str(SAMPLE),
            "--route",
            str(csv),
            "--georef",
            GEOREF,
            "--merge-landmarks",
            str(survey),
            "--output-dir",
            str(tmp_path / "d"),
        ]
    )
    rows = (tmp_path / "d" / "routes" / "drive_landmarks.csv").read_text().splitlines()[1:]
    assert len(rows) == len(osm) and sum(r.split(",")[2] == "survey" for r in rows) == 1


def _refused(tmp_path: Path, args: list[str], *words: str) -> None:
    out = tmp_path / "out.json"
    r = CliRunner().invoke(cli, ["greedy", "--budget", "110000", *args, "-o", str(out)])
    assert r.exit_code == 2, r.output
    # (click's usage errors come after its two usage lines)
    lines = [
        ln for ln in r.stderr.splitlines() if ln.strip() and not ln.startswith(("sensorsel: note:", "Usage:", "Try "))
    ]
    assert len(lines) == 1 and lines[0].startswith(("sensorsel: error:", "Error:")), r.stderr
    for w in words:
        assert w in lines[0], (w, lines[0])
    assert "Traceback" not in r.output and not out.exists()


def test_bad_route_options_are_one_line_and_write_nothing(drive, tmp_path):
    csv, gpx, _ = drive
    osm = f"osm:{SAMPLE}"
    _refused(tmp_path, ["--route", str(csv), "--landmarks", osm], "--landmarks osm:", "not georeferenced", "--georef")
    _refused(tmp_path, ["--landmarks", osm], "--landmarks osm:", "fixture suburb", "--georef")
    _refused(
        tmp_path,
        ["--route", str(csv), "--georef", "10,10,0", "--landmarks", osm],
        str(SAMPLE),
        "outside the extract",
        "--georef",
    )
    _refused(tmp_path, ["--route", str(csv), "--georef", GEOREF], "--georef", "--landmarks osm:FILE")
    _refused(tmp_path, ["--route", str(csv), "--georef", "95,24,0", "--landmarks", osm], "--georef", "latitude")
    _refused(tmp_path, ["--route", str(gpx), "--georef", GEOREF, "--landmarks", osm], "--georef", "GPX")
    _refused(tmp_path, ["--route", str(gpx), "--landmarks", osm, "--landmarks", "synthetic"], "synthetic")
    _refused(
        tmp_path,
        ["--route", str(gpx), "--landmarks", "a.csv", "--landmarks", "b.csv"],
        "--landmarks",
        "one landmark map",
    )
    _refused(tmp_path, ["--route", str(gpx), "--landmarks", "osm:"], "osm:", "no file")
    _refused(
        tmp_path, ["--route", str(gpx), "--landmarks", f"osm:{tmp_path / 'missing.pbf'}"], "missing.pbf", "not found"
    )
    _refused(tmp_path, ["--route", str(gpx), "--landmarks", f"osm:{csv}"], str(csv), "not an OSM extract")
    _refused(
        tmp_path, ["--route", str(gpx), "--landmarks", osm, "--osm-classes", "lamppost"], "--osm-classes", "lamppost"
    )
    _refused(tmp_path, ["--route", str(gpx), "--landmarks", osm, "--osm-reach", "-5"], "--osm-reach")
    _refused(tmp_path, ["--route", str(gpx), "--osm-reach", "50"], "--osm-reach", "osm:FILE")
    _refused(tmp_path, ["--route", str(csv), "--osm-classes", "tree"], "--osm-classes", "osm:FILE")
    _refused(
        tmp_path,
        ["--route", str(gpx), "--landmarks", osm, "--osm-classes", "flagpole", "--osm-reach", "5"],
        "no landmark",
        "--osm-reach",
    )
    empty = tmp_path / "empty.gpx"
    empty.write_text('<?xml version="1.0"?>\n<gpx version="1.1"><trk><trkseg></trkseg></trk></gpx>\n')
    _refused(tmp_path, ["--route", str(empty), "--landmarks", osm], str(empty), "no points")
    _refused(
        tmp_path,
        ["--domain", str(REPO / "configs" / "domain_fixtures.yaml"), "--landmarks", osm],
        "--domain",
        "--landmarks",
    )
    # sensorsel osm --route shares the merge, and its refusal of a route outside the extract
    r = CliRunner().invoke(
        cli, ["osm", str(SAMPLE), "--route", str(csv), "--georef", "10,10,0", "--output-dir", str(tmp_path / "d")]
    )
    assert r.exit_code == 2 and "outside the extract" in r.stderr and not (tmp_path / "d").exists(), r.output


def test_the_wheel_ships_the_helsinki_sample_and_its_attribution(tmp_path):
    """The built wheel (hatchling's API, no network) holds the sample and its README, byte for byte,
    and the package's resource lookup finds them when sensorsel is imported from the wheel."""
    from hatchling.builders.wheel import WheelBuilder

    wheel = Path(next(iter(WheelBuilder(str(REPO)).build(directory=str(tmp_path / "dist"), versions=["standard"]))))
    with zipfile.ZipFile(wheel) as z:
        names = set(z.namelist())
        assert {"sensorsel/_data/osm/helsinki.osm.pbf", "sensorsel/_data/osm/README.md"} <= names
        assert z.read("sensorsel/_data/osm/helsinki.osm.pbf") == SAMPLE.read_bytes()
        readme = z.read("sensorsel/_data/osm/README.md").decode()
        assert "OpenStreetMap contributors" in readme and "ODbL" in readme
        z.extractall(tmp_path / "site")
    code = (
        "import sensorsel, sys; from sensorsel.io.resources import sample_osm_dir, sample_osm_names; "
        "from sensorsel.model.osm import read_osm; d = sample_osm_dir(); "
        "print(sensorsel.__file__); print(d); print(sample_osm_names()); "
        "print(len(read_osm(d / 'helsinki.osm.pbf').landmarks))"
    )
    r = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        timeout=120,
        env={"PYTHONPATH": str(tmp_path / "site"), "PATH": "/usr/bin:/bin"},
        cwd=tmp_path,
    )
    assert r.returncode == 0, r.stderr
    mod, folder, names_, n = r.stdout.splitlines()
    assert mod.startswith(str(tmp_path / "site")) and folder == str(tmp_path / "site" / "sensorsel" / "_data" / "osm")
    assert names_ == "['helsinki']" and int(n) == len(read_osm(SAMPLE).landmarks)


def test_landmarks_command_generates_along_a_gpx_track(drive, tmp_path):
    csv, gpx, _ = drive
    out = tmp_path / "lm.csv"
    _ok(["landmarks", "--route", str(gpx), "-o", str(out)])
    lm = np.loadtxt(out, delimiter=",", skiprows=1)
    route = load_problem(ScenarioSpec(route=str(gpx), landmarks=str(out))).scenario.route
    d = np.sqrt(((lm[:, None, :2] - route.poses[None, :, :2]) ** 2).sum(-1)).min(axis=1)
    assert len(lm) > 50 and d.max() < 100.0  # along the track, in its frame
    r = CliRunner().invoke(cli, ["landmarks", "--route", str(csv), "--georef", GEOREF, "-o", str(tmp_path / "x.csv")])
    assert r.exit_code == 2 and "--georef" in r.stderr and not (tmp_path / "x.csv").exists()


def test_a_worker_rebuilds_the_same_problem_and_load_scenario_refuses_a_geo_spec(drive):
    import pickle

    from sensorsel.errors import InputError
    from sensorsel.model.recipes import TargetRecipe
    from sensorsel.model.scenario import load_scenario

    csv, gpx, _ = drive
    for spec in (
        ScenarioSpec(route=str(csv), georef=GEOREF, osm=(str(SAMPLE),), osm_classes="street_lamp,tree"),
        ScenarioSpec(route=str(gpx), osm=(str(SAMPLE),), osm_reach_m=60.0),
    ):
        problem = load_problem(spec)
        rebuilt = pickle.loads(pickle.dumps(TargetRecipe.of(problem))).build()  # what a Dask worker does
        assert rebuilt.fingerprint == problem.fingerprint
        assert np.array_equal(rebuilt.scenario.landmarks, problem.scenario.landmarks)
        # the scenario layer cannot read OSM: it refuses instead of silently giving the fixture's map
        with pytest.raises(InputError, match="load_geo_scenario"):
            load_scenario(spec)


@pytest.mark.parametrize("lat, lon", [(47.1410, 9.5215), (60.1675, 24.9400)])  # Vaduz; central Helsinki
@pytest.mark.parametrize("bearing", [0.0, 35.0, 90.0, 200.0, 300.0])
def test_the_georef_bearing_is_the_compass_bearing_of_the_route_x_axis(lat, lon, bearing):
    """--georef LAT,LON,BEARING: BEARING is the compass bearing (clockwise from true north) of the
    route's +X axis, and +Y is 90 deg to its left. Oracle: pyproj's geodesic on the WGS 84
    ellipsoid (not the code's UTM projection): the azimuth from the origin to a route point 500 m
    along +X is BEARING, to one along +Y is BEARING - 90; a point Geod.fwd puts 500 m away at
    BEARING comes back at (500, 0). The tolerance is the UTM grid's meridian convergence the code
    neglects (0.4 deg in Vaduz, 1.8 deg in Helsinki, off its zone's central meridian)."""
    from pyproj import Geod

    geod, ref = Geod(ellps="WGS84"), GeoRef.parse(f"{lat},{lon},{bearing}")
    frame = ref.frame()
    tol = abs(lon - (6 * (frame.zone - 1) - 177)) * math.sin(math.radians(lat)) + 0.2  # convergence + 0.2 deg
    for local, want in (((500.0, 0.0), bearing), ((0.0, 500.0), bearing - 90.0)):
        x, y, _ = ref.to_map(np.array([[*local, 0.0]]), frame)[0]
        lo, la = frame.unproject(np.array([[x, y]]))
        az, _, dist = geod.inv(lon, lat, float(np.ravel(lo)[0]), float(np.ravel(la)[0]))
        assert math.remainder(az - want, 360.0) == pytest.approx(0.0, abs=tol), (local, az)
        assert dist == pytest.approx(500.0, rel=2e-3)  # the UTM scale factor, within 0.1 %
    lo, la, _ = geod.fwd(lon, lat, bearing, 500.0)
    back = ref.from_map(frame.project(np.array([lo]), np.array([la])), frame)[0]
    assert back[0] == pytest.approx(500.0, rel=2e-3)
    assert abs(back[1]) < 500.0 * math.radians(tol)
