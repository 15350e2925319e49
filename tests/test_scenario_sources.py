"""Real maps first (KITTI pole maps, landmark CSVs with extra columns, duplicates and
on-road landmarks counted or dropped), routes in TUM and planar-CSV formats, scenario names, notes."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from sensorsel.cli import cli
from sensorsel.errors import InputError, ScenarioError
from sensorsel.io.resources import fixtures_dir
from sensorsel.model.scenario import (
    ScenarioSpec,
    Trajectory,
    clean_landmarks,
    distance_to_route,
    load_route_file,
    load_scenario,
    load_sequence,
    read_landmarks_csv,
    read_planar_csv,
    read_tum_trajectory,
    route_name,
    scenario_notes,
    sniff_route_format,
    write_kitti_poses,
    write_planar_csv,
    write_tum_trajectory,
)

TINY_POSES = fixtures_dir() / "poses" / "tiny.txt"
TINY_TIMES = fixtures_dir() / "sequences" / "tiny" / "times.txt"


def _write(path: Path, lines: list[str]) -> Path:
    path.write_text("".join(line + "\n" for line in lines))
    return path


def _wrap(a):
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def _straight(n: int = 61) -> Trajectory:
    x = np.arange(n, dtype=float)
    return Trajectory(np.column_stack([x, np.zeros(n), np.zeros(n)]), x / 10.0, np.arange(n))


# ------------------------------------------------------------------------------------ real maps


@pytest.mark.kitti
def test_seq_03_uses_the_real_pole_map_by_default(kitti_root):
    sc = load_scenario(ScenarioSpec(seq="03", kitti_root=str(kitti_root)))
    path = kitti_root / "landmarks" / "03.csv"
    assert sc.landmark_source == f"KITTI pole map {path}" and sc.name == "03"
    # the oracle: the file itself (no duplicates in it, nothing dropped without a clearance)
    raw = np.loadtxt(path, delimiter=",", skiprows=1)
    np.testing.assert_array_equal(sc.landmarks, raw)
    r = sc.landmark_report
    assert (r.n_read, r.n_duplicates, r.n_dropped, r.clearance_m) == (len(raw), 0, 0, None)
    assert r.n_on_road == int(np.sum(distance_to_route(raw, sc.route.poses[:, :2]) < 3.0))
    notes = scenario_notes(sc)
    assert len(notes) == 1 and str(path) in notes[0] and f"{len(raw)} read" in notes[0]
    # explicit choices
    assert load_scenario(ScenarioSpec(seq="03", kitti_root=str(kitti_root), landmarks="real")).n_landmarks == len(raw)
    syn = load_scenario(ScenarioSpec(seq="03", kitti_root=str(kitti_root), landmarks="synthetic"))
    assert syn.landmark_source == "generated (seed 0)"


@pytest.mark.kitti
def test_seq_03_clearance_drops_the_poles_on_the_road(kitti_root):
    sc = load_scenario(ScenarioSpec(seq="03", kitti_root=str(kitti_root), clearance_m=5.0))
    raw = np.loadtxt(kitti_root / "landmarks" / "03.csv", delimiter=",", skiprows=1)
    d = distance_to_route(raw, sc.route.poses[:, :2])
    np.testing.assert_array_equal(sc.landmarks, raw[d >= 5.0])
    r = sc.landmark_report
    assert r.n_dropped == r.n_on_road == int(np.sum(d < 5.0)) > 0 and r.min_distance_m >= 5.0
    assert "dropped" in scenario_notes(sc)[0]


def test_seq_without_a_map_generates_and_says_so(tmp_path):
    (tmp_path / "poses").mkdir()
    (tmp_path / "poses" / "05.txt").write_bytes(TINY_POSES.read_bytes())
    (tmp_path / "sequences" / "05").mkdir(parents=True)
    (tmp_path / "sequences" / "05" / "times.txt").write_bytes(TINY_TIMES.read_bytes())
    sc = load_scenario(ScenarioSpec(seq="05", kitti_root=str(tmp_path)))
    assert sc.landmark_source == "generated (seed 0)"
    assert any("no pole map" in n and "05.csv" in n for n in scenario_notes(sc))
    with pytest.raises(InputError, match="real"):
        load_scenario(ScenarioSpec(seq="05", kitti_root=str(tmp_path), landmarks="real"))
    (tmp_path / "landmarks").mkdir()
    _write(tmp_path / "landmarks" / "05.csv", ["x,y", "10,20", "30,-40"])
    sc = load_scenario(ScenarioSpec(seq="05", kitti_root=str(tmp_path)))
    assert sc.landmark_source.startswith("KITTI pole map") and sc.n_landmarks == 2


def test_real_landmarks_need_a_sequence():
    with pytest.raises(InputError, match="sequence"):
        load_scenario(ScenarioSpec(route=str(TINY_POSES), times=str(TINY_TIMES), landmarks="real"))


# ------------------------------------------------------------------------------ landmark CSVs


def test_landmark_csv_with_extra_named_columns_in_any_order(tmp_path):
    path = _write(tmp_path / "lm.csv", ["# poles", "id,kind,Y,z,X", "1,lamp,2.5,7,1", '2,"sign, tall",-4,3.5,3'])
    np.testing.assert_array_equal(read_landmarks_csv(path), [[1.0, 2.5], [3.0, -4.0]])


def test_landmark_csv_without_header_takes_the_first_two_columns(tmp_path):
    path = _write(tmp_path / "lm.csv", ["1,2,9", "3,4,9"])
    np.testing.assert_array_equal(read_landmarks_csv(path), [[1.0, 2.0], [3.0, 4.0]])
    bad = _write(tmp_path / "bad.csv", ["1,2,9", "3,4"])
    with pytest.raises(ScenarioError, match="found 2 fields") as err:
        read_landmarks_csv(bad)
    assert err.value.line == 2


@pytest.mark.parametrize(
    "rows,line,fragment",
    [
        (["a,b", "1,2"], 1, "no x and no y column"),
        (["x,z", "1,2"], 1, "no y column"),
        (["x,y,x", "1,2,3"], 1, "column x twice"),
        (["x,y,kind", "1,2"], 2, "found 2 fields"),
        (["x,y,kind", "1,zz,lamp"], 2, "not a number: 'zz'"),
        (["5"], 1, "found 1 fields"),
    ],
)
def test_bad_landmark_headers_and_rows(tmp_path, rows, line, fragment):
    path = _write(tmp_path / "lm.csv", rows)
    with pytest.raises(ScenarioError) as err:
        read_landmarks_csv(path)
    assert err.value.line == line and fragment in str(err.value) and str(path) in str(err.value)


def test_exact_duplicates_are_always_merged_and_counted(tmp_path):
    route = _straight()
    lm = np.array([[10.0, 8.0], [20.0, -9.0], [10.0, 8.0], [10.0, 8.000001], [20.0, -9.0]])
    kept, r = clean_landmarks(lm, route, source="m")
    np.testing.assert_array_equal(kept, [[10.0, 8.0], [20.0, -9.0], [10.0, 8.000001]])  # first occurrences, in order
    assert (r.n_read, r.n_duplicates, r.n_dropped, r.n_kept) == (5, 2, 0, 3)
    assert "2 exact duplicate(s) merged" in r.notes()[0]
    # through a scenario built from files
    poses = write_kitti_poses(tmp_path / "drive.txt", route.poses)
    path = _write(tmp_path / "lm.csv", ["x,y"] + [f"{x!r},{y!r}" for x, y in lm.tolist()])
    sc = load_scenario(ScenarioSpec(route=str(poses), landmarks=str(path)))
    assert sc.n_landmarks == 3 and sc.landmark_report.n_duplicates == 2
    assert any("2 exact duplicate(s) merged" in n for n in scenario_notes(sc))


def test_on_road_landmarks_counted_without_clearance_dropped_with_it(tmp_path):
    route = _straight()  # the x axis from 0 to 60 m
    lm = np.array([[10.0, 0.5], [20.0, -2.9], [30.0, 3.0], [40.0, 6.0], [70.0, 0.0], [65.0, 3.5]])
    # distances to the polyline: 0.5, 2.9, 3.0, 6.0, 10 (beyond its end), hypot(5, 3.5)
    np.testing.assert_allclose(
        distance_to_route(lm, route.poses[:, :2]), [0.5, 2.9, 3.0, 6.0, 10.0, math.hypot(5, 3.5)]
    )
    kept, r = clean_landmarks(lm, route)
    assert len(kept) == 6 and (r.n_on_road, r.on_road_m, r.n_dropped) == (2, 3.0, 0)
    assert "2 within 3 m of the route kept" in r.notes()[0]
    kept, r = clean_landmarks(lm, route, clearance_m=4.0)
    np.testing.assert_array_equal(kept, lm[[3, 4, 5]])
    assert (r.n_on_road, r.n_dropped, r.n_kept, r.clearance_m) == (3, 3, 3, 4.0)
    assert "3 closer than the clearance 4 m to the route dropped" in r.notes()[0]
    with pytest.raises(InputError, match="clearance"):
        clean_landmarks(lm, route, clearance_m=-1.0)
    # a clearance that leaves nothing is an error, not an empty map
    poses = write_kitti_poses(tmp_path / "drive.txt", route.poses)
    path = _write(tmp_path / "lm.csv", ["x,y", "10,0.5"])
    with pytest.raises(InputError, match="no landmark left"):
        load_scenario(ScenarioSpec(route=str(poses), landmarks=str(path), clearance_m=1.0))


def test_clearance_from_the_cli(tmp_path):
    route = _straight()
    poses = write_kitti_poses(tmp_path / "drive.txt", route.poses)
    lm = _write(tmp_path / "lm.csv", ["x,y", "10,0.5", "20,8", "30,-7", "40,9", "20,8"])
    base = ["score", "--route", str(poses), "--landmarks", str(lm), "--suite", "LRL-roof", "--json"]
    import json

    for extra, n in (([], 4), (["--clearance", "2"], 3)):
        res = CliRunner().invoke(cli, base + extra)
        assert res.exit_code == 0, res.output
        assert json.loads(res.stdout)["problem"]["n_landmarks"] == n


# ---------------------------------------------------------------------------------------- routes


@pytest.mark.kitti
def test_tum_and_planar_csv_routes_load_as_the_kitti_file(kitti_root, tmp_path):
    kitti = load_sequence(kitti_root, "03")
    tum = write_tum_trajectory(tmp_path / "03.tum", kitti.poses, kitti.times)
    pcsv = write_planar_csv(tmp_path / "03.csv", kitti.poses, kitti.times)
    for path, fmt in ((tum, "tum"), (pcsv, "csv")):
        assert sniff_route_format(path) == fmt
        route, notes = load_route_file(path)
        assert notes == ()
        np.testing.assert_allclose(route.poses[:, :2], kitti.poses[:, :2], atol=1e-9, rtol=0)
        np.testing.assert_allclose(_wrap(route.poses[:, 2] - kitti.poses[:, 2]), 0.0, atol=1e-9)
        np.testing.assert_array_equal(route.times, kitti.times)
    # the same scenario, named after the file
    a = load_scenario(ScenarioSpec(seq="03", kitti_root=str(kitti_root), landmarks="synthetic"))
    b = load_scenario(ScenarioSpec(route=str(tum), landmarks="synthetic"))
    assert b.name == "03"
    np.testing.assert_array_equal(a.keyframes.frames, b.keyframes.frames)
    np.testing.assert_allclose(a.landmarks, b.landmarks, atol=1e-6)


def test_tum_yaw_and_frame(tmp_path):
    # a 3-D TUM pose: yaw 30 degrees about z, a pitch, z = 1.6 m: planar x, y = tx, ty, heading = yaw
    yaw, pitch = math.radians(30), math.radians(5)
    cy, sy, cp, sp = math.cos(yaw / 2), math.sin(yaw / 2), math.cos(pitch / 2), math.sin(pitch / 2)
    q = (-sy * sp, cy * sp, sy * cp, cy * cp)  # q = q_z(yaw) * q_y(pitch), as (x, y, z, w)
    path = _write(
        tmp_path / "groundtruth.txt",
        ["# TUM", f"1.0 3 4 1.6 {q[0]} {q[1]} {q[2]} {q[3]}", f"2.0 5 6 1.6 {q[0]} {q[1]} {q[2]} {q[3]}"],
    )
    route = read_tum_trajectory(path)
    np.testing.assert_allclose(route.poses, [[3, 4, yaw], [5, 6, yaw]], atol=1e-12)
    np.testing.assert_array_equal(route.times, [1.0, 2.0])
    assert sniff_route_format(path) == "tum"


@pytest.mark.parametrize(
    "lines,line,fragment",
    [
        (["0 1 2 3 0 0 0 1", "1 1 2 3 0 0 0"], 2, "expected 8 numbers"),
        (["0 1 2 3 0 0 0 1", "0 1 2 3 0 0 0 1"], 2, "must increase"),
        (["0 1 2 3 0 0 0 0"], 1, "quaternion"),
        (["# only a comment"], None, "empty"),
    ],
)
def test_bad_tum_files(tmp_path, lines, line, fragment):
    path = _write(tmp_path / "t.txt", lines)
    with pytest.raises(ScenarioError) as err:
        read_tum_trajectory(path)
    assert err.value.line == line and fragment in str(err.value)


def test_planar_csv_columns_by_name_and_errors(tmp_path):
    path = _write(tmp_path / "r.csv", ["heading,speed,y,x,t", "0.5,3,2,1,0", "0.25,3,4,3,0.5"])
    route = read_planar_csv(path)
    np.testing.assert_array_equal(route.poses, [[1, 2, 0.5], [3, 4, 0.25]])
    np.testing.assert_array_equal(route.times, [0, 0.5])
    for rows, line, fragment in (
        (["t,x", "0,1"], 1, "lacks column(s) y"),
        (["0,1,2,0"], 1, "lacks column(s) t, x, y"),
        (["t,x,y,heading", "0,1,2"], 2, "found 3"),
        (["t,x,y,heading", "0,1,2,0", "0,1,2,0"], 3, "must increase"),
        (["t,x,y,heading"], None, "no poses"),
    ):
        bad = _write(tmp_path / "bad.csv", rows)
        with pytest.raises(ScenarioError) as err:
            read_planar_csv(bad)
        assert err.value.line == line and fragment in str(err.value), str(err.value)


def test_route_format_sniffing(tmp_path):
    assert sniff_route_format(TINY_POSES) == "kitti"
    assert sniff_route_format(_write(tmp_path / "r.txt", ["# c", "t,x,y,heading", "0,0,0,0"])) == "csv"
    bad = _write(tmp_path / "five.txt", ["1 2 3 4 5"])
    with pytest.raises(ScenarioError, match="--route-format") as err:
        sniff_route_format(bad)
    assert err.value.line == 1


def test_kitti_route_without_times_states_the_assumed_rate():
    sc = load_scenario(ScenarioSpec(route=str(TINY_POSES)))
    rate_notes = [n for n in scenario_notes(sc) if "no timestamps" in n]
    assert len(rate_notes) == 1 and "10 Hz" in rate_notes[0] and str(TINY_POSES) in rate_notes[0]
    sc = load_scenario(ScenarioSpec(route=str(TINY_POSES), times=str(TINY_TIMES)))
    assert not [n for n in scenario_notes(sc) if "no timestamps" in n]


def test_times_only_with_a_kitti_route(tmp_path):
    tum = write_tum_trajectory(tmp_path / "r.tum", _straight().poses, _straight().times)
    with pytest.raises(InputError, match="carries its own"):
        load_scenario(ScenarioSpec(route=str(tum), times=str(TINY_TIMES)))


# ----------------------------------------------------------------------------------------- names


def test_scenario_names(tmp_path):
    assert route_name(tmp_path / "mydrive.txt") == "mydrive"
    (tmp_path / "drive7").mkdir()
    for generic in ("poses.txt", "groundtruth.txt", "trajectory.csv"):
        assert route_name(tmp_path / "drive7" / generic) == "drive7"
    poses = write_kitti_poses(tmp_path / "drive7" / "poses.txt", _straight().poses)
    assert load_scenario(ScenarioSpec(poses=str(poses))).name == "drive7"
    assert load_scenario(ScenarioSpec(poses=str(poses), name="  Lap 1 ")).name == "Lap 1"
    assert load_scenario(ScenarioSpec(fixture="tiny")).name == "tiny"
    for bad in ("", "  ", "a\nb"):
        with pytest.raises(InputError, match="name"):
            load_scenario(ScenarioSpec(fixture="tiny", name=bad))


def test_cli_route_options(tmp_path):
    import json

    route = load_sequence(fixtures_dir(), "tiny")
    tum = write_tum_trajectory(tmp_path / "lap.txt", route.poses, route.times)

    def score(*args):
        res = CliRunner().invoke(cli, ["score", "--suite", "LRL-roof", "--json", *args])
        assert res.exit_code == 0, res.output
        return json.loads(res.stdout)

    ref = score("--route", str(TINY_POSES), "--times", str(TINY_TIMES), "--landmarks", "synthetic")
    got = score("--route", str(tum), "--landmarks", "synthetic", "--name", "lap one")
    assert got["problem"]["scenario"] == "lap one" and ref["problem"]["scenario"] == "tiny"
    assert got["score"] == pytest.approx(ref["score"], rel=1e-9)
    got = score("--route", str(tum), "--route-format", "tum", "--landmarks", "synthetic")
    assert got["problem"]["scenario"] == "lap"
    for args, fragment in (
        (["--seq", "03", "--route", str(tum)], "one route"),
        (["--route-format", "tum"], "goes with --route"),
        (["--route", str(tum), "--route-format", "bogus"], "bogus"),
    ):
        res = CliRunner().invoke(cli, ["score", "--suite", "LRL-roof", *args])
        assert res.exit_code == 2 and fragment in res.output, res.output
