"""Routes in any frame, never read wrong: the same drive written as other tools write it
scores the same; positions-only routes get their heading from the direction of travel; degenerate
and degree-valued files are refused naming the file.

Oracles: the KITTI pose file itself (read as sensorsel always read it), the drive's known headings,
hand-built rotations (scipy's quaternions, not sensorsel's).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from scipy.spatial.transform import Rotation

from sensorsel.api import score_suite
from sensorsel.cli import cli
from sensorsel.errors import InputError, ScenarioError
from sensorsel.model.problem import load_problem
from sensorsel.model.scenario import (
    ScenarioSpec,
    find_frame,
    headings_from_travel,
    load_scenario,
    read_kitti_poses,
    read_route_file,
    read_times,
    route_from_positions,
    scenario_notes,
)

# radars at four clock positions and cameras: a turned or mirrored heading changes the score
SUITE = "LRR-12,LRR-3,LRR-10,HD2K-12,HD2K-4,HD2K-9"
# KITTI camera axes (x right, y down, z forward) -> vehicle / z-up axes (x forward, y left, z up)
C = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])


def _wrap(a):
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def _tum(path: Path, t: np.ndarray, p: np.ndarray, r: np.ndarray) -> Path:
    """A TUM file as evo writes one: ``t tx ty tz qx qy qz qw``, full precision."""
    q = Rotation.from_matrix(r).as_quat()  # (x, y, z, w)
    path.write_text(
        "".join(
            f"{a!r} {b[0]!r} {b[1]!r} {b[2]!r} {c[0]!r} {c[1]!r} {c[2]!r} {c[3]!r}\n"
            for a, b, c in zip(t.tolist(), p.tolist(), q.tolist())
        )
    )
    return path


def _kitti(path: Path, p: np.ndarray, r: np.ndarray) -> Path:
    m = np.concatenate([r, p[:, :, None]], axis=2).reshape(-1, 12)
    path.write_text("".join(" ".join(repr(v) for v in row) + "\n" for row in m.tolist()))
    return path


def _score(spec: ScenarioSpec) -> float:
    return score_suite(load_problem(spec), SUITE).score


@pytest.fixture(scope="module")
def drive03(kitti_root):
    poses = read_kitti_poses(kitti_root / "poses" / "03.txt")
    times = read_times(kitti_root / "sequences" / "03" / "times.txt")
    lm = np.loadtxt(kitti_root / "landmarks" / "03.csv", delimiter=",", skiprows=1)
    ref = _score(ScenarioSpec(seq="03", kitti_root=str(kitti_root)))
    return poses[:, :, 3], poses[:, :, :3], times, lm, ref


@pytest.mark.kitti
def test_the_same_drive_in_every_axis_aligned_frame_scores_the_same(drive03, kitti_root, tmp_path):
    p, r, t, lm, ref = drive03
    lm_file = kitti_root / "landmarks" / "03.csv"
    variants = {
        # evo_traj kitti 03.txt --save_as_tum: camera frames, y down, z forward
        "camera-frame TUM": (_tum(tmp_path / "cam.txt", t, p, r), "camera frame: y down, z forward"),
        # the drive in a z-up world with a z-up body (x forward, y left): TUM's own convention
        "z-up TUM": (_tum(tmp_path / "zup.txt", t, p @ C.T, C @ r @ C.T), None),
        # z-up positions with camera-axis quaternions (a common SLAM output)
        "z-up positions, camera quaternions": (
            _tum(tmp_path / "zcam.txt", t, p @ C.T, C @ r),
            "body (camera frame): y down, z forward",
        ),
        # a z-up trajectory written in KITTI's format (evo_traj tum x.txt --save_as_kitti)
        "z-up KITTI file": (_kitti(tmp_path / "zup_kitti.txt", p @ C.T, C @ r @ C.T), "vehicle frame: z up, x forward"),
    }
    for label, (path, said) in variants.items():
        spec = ScenarioSpec(
            route=str(path),
            landmarks=str(lm_file),
            times=str(kitti_root / "sequences" / "03" / "times.txt") if path.name.endswith("kitti.txt") else None,
        )
        got = _score(spec)
        assert got == pytest.approx(ref, rel=1e-6), label
        notes = scenario_notes(load_scenario(spec))
        if said is None:
            assert not any("frame" in n for n in notes), (label, notes)
        else:
            assert any(said in n and str(path) in n for n in notes), (label, notes)


@pytest.mark.kitti
def test_the_same_drive_under_a_rigid_3d_motion_with_its_map_moved_alike(drive03, tmp_path):
    p, r, t, lm, ref = drive03
    q = Rotation.from_euler("zyx", [37.0, -52.0, 71.0], degrees=True).as_matrix()
    c = np.array([1234.5, -678.0, 91.0])
    path = _tum(tmp_path / "moved.txt", t, p @ q.T + c, q @ r)
    # the pole map in camera-0 coordinates (x = -Y, z = X, a height on y), then moved alike, as x,y,z
    rng = np.random.default_rng(3)
    cam = np.column_stack([-lm[:, 1], rng.uniform(-4.0, 1.0, len(lm)), lm[:, 0]])
    moved = cam @ q.T + c
    lm_file = tmp_path / "map3d.csv"
    lm_file.write_text("x,y,z\n" + "".join(f"{a!r},{b!r},{d!r}\n" for a, b, d in moved.tolist()))
    spec = ScenarioSpec(route=str(path), landmarks=str(lm_file))
    assert _score(spec) == pytest.approx(ref, rel=1e-3)
    sc = load_scenario(spec)
    assert sc.n_landmarks == len(lm)
    assert any("projected into its ground plane" in n for n in scenario_notes(sc))
    # a generated map follows the route, so it is the same map up to the plane's rotation: as many landmarks
    a = load_scenario(ScenarioSpec(route=str(path), landmarks="synthetic"))
    b = load_scenario(ScenarioSpec(route=str(_tum(tmp_path / "cam.txt", t, p, r)), landmarks="synthetic"))
    assert a.n_landmarks == b.n_landmarks


@pytest.mark.kitti
def test_planar_and_positions_only_csv_of_the_drive(drive03, kitti_root, tmp_path):
    p, r, t, lm, ref = drive03
    kitti = read_route_file(
        kitti_root / "poses" / "03.txt", "kitti", kitti_root / "sequences" / "03" / "times.txt"
    ).route
    lm_file = kitti_root / "landmarks" / "03.csv"
    planar = tmp_path / "planar.csv"
    planar.write_text(
        "t,x,y,heading\n"
        + "".join(f"{a!r},{x!r},{y!r},{h!r}\n" for a, (x, y, h) in zip(t.tolist(), kitti.poses.tolist()))
    )
    assert _score(ScenarioSpec(route=str(planar), landmarks=str(lm_file))) == pytest.approx(ref, rel=1e-6)
    # positions only: the heading from the direction of travel, against KITTI's own headings
    pos = tmp_path / "positions.csv"
    pos.write_text(
        "t,x,y\n" + "".join(f"{a!r},{x!r},{y!r}\n" for a, (x, y, _) in zip(t.tolist(), kitti.poses.tolist()))
    )
    route = read_route_file(pos).route
    err = np.degrees(np.abs(_wrap(route.poses[:, 2] - kitti.poses[:, 2])))
    # measured: median 0.37 deg, 95% 3.6 deg, worst 7.0 deg in 03's tight turn (the camera is ahead of the
    # rear axle: its velocity is not along the car in a turn), whatever the window (2, 4 m)
    assert np.median(err) < 1.0 and np.percentile(err, 95) < 5.0 and err.max() < 10.0, (np.median(err), err.max())
    # stated tolerance where the heading comes from positions: 1% of the score (measured 0.36% for SUITE on 03;
    # 0.01-0.5% for radars and cameras on 03 and 00; a 360-degree LiDAR alone: 2e-14)
    assert _score(ScenarioSpec(route=str(pos), landmarks=str(lm_file))) == pytest.approx(ref, rel=1e-2)
    # a GPS-like log Time,X,Y,Z (z up, the drive's height on z), as GTSAM's KittiGps example writes it
    gps = tmp_path / "gps.txt"
    z_up = p @ C.T
    gps.write_text(
        "Time,X,Y,Z\n" + "".join(f"{a!r},{x!r},{y!r},{z!r}\n" for a, (x, y, z) in zip(t.tolist(), z_up.tolist()))
    )
    r3 = read_route_file(gps)
    np.testing.assert_allclose(r3.route.poses[:, :2], kitti.poses[:, :2], atol=1e-9)
    np.testing.assert_array_equal(r3.route.poses[:, 2], route.poses[:, 2])
    assert any("direction of travel" in n for n in r3.notes)


@pytest.mark.kitti
def test_every_kitti_sequence_is_read_as_before(kitti_root):
    """KITTI's own files: the frame found is KITTI's, the arithmetic the very projection sensorsel
    always used (x = t_z, y = -t_x, heading = atan2(-R_02, R_22)), no note."""
    for seq in sorted(p.stem for p in (kitti_root / "poses").glob("*.txt")):
        poses = read_kitti_poses(kitti_root / "poses" / f"{seq}.txt")
        rf = read_route_file(kitti_root / "poses" / f"{seq}.txt", "kitti", kitti_root / "sequences" / seq / "times.txt")
        expect = np.column_stack([poses[:, 2, 3], -poses[:, 0, 3], np.arctan2(-poses[:, 0, 2], poses[:, 2, 2])])
        np.testing.assert_array_equal(rf.route.poses, expect)
        assert rf.notes == () and rf.frame is not None and rf.frame.describe == "camera frame: y down, z forward"


# ----------------------------------------------------------------------------- positions only


def test_headings_from_travel_on_a_circle_a_stop_and_a_reversal():
    # a circle of radius 50 m, 1 m apart, counter-clockwise: the heading is the tangent
    s = np.arange(0.0, 200.0)
    a = s / 50.0
    xy = np.column_stack([50 * np.sin(a), 50 * (1 - np.cos(a))])
    h, notes = headings_from_travel(s, xy)
    inner = slice(3, -3)  # the window (4 m) is whole: the chord of a circle is parallel to the tangent at its middle
    np.testing.assert_allclose(_wrap(h[inner] - a[inner]), 0.0, atol=1e-9)
    assert np.abs(_wrap(h - a)).max() < 0.03 and notes == []  # ends: half the window's arc, 2 / 50 / 2 rad
    # a stop keeps the last heading: 10 repeated positions in the middle of a straight road heading 30 deg
    d = np.array([math.cos(math.radians(30)), math.sin(math.radians(30))])
    xy = np.concatenate(
        [np.arange(20)[:, None] * d, np.repeat(19 * d[None], 10, axis=0), (19 + np.arange(1, 20))[:, None] * d]
    )
    h, notes = headings_from_travel(np.arange(len(xy), dtype=float), xy)
    np.testing.assert_allclose(h, math.radians(30), atol=1e-12)
    # a reversal: 30 m along +x, then back: said in a note (with the time), heading along the travel each way
    xy = np.concatenate(
        [np.column_stack([np.arange(31.0), np.zeros(31)]), np.column_stack([np.arange(29.0, -1.0, -1.0), np.zeros(30)])]
    )
    t = np.arange(len(xy), dtype=float)
    h, notes = headings_from_travel(t, xy)
    assert len(notes) == 1 and "reverses near t = " in notes[0] and "backed up" in notes[0]
    np.testing.assert_allclose(h[:25], 0.0, atol=1e-12)
    np.testing.assert_allclose(np.abs(h[37:]), math.pi, atol=1e-12)


def test_route_from_positions_checks_what_a_reader_gives_it(tmp_path):
    t = np.arange(5.0)
    xy = np.column_stack([np.arange(5.0) * 3, np.zeros(5)])
    rf = route_from_positions(t, xy, "gpx:track")
    np.testing.assert_array_equal(rf.route.poses[:, 2], 0.0)
    assert rf.frame is None and "direction of travel" in rf.notes[0] and "gpx:track" in rf.notes[0]
    for tt, pp, fragment in (
        (np.array([0.0, 1, 1, 2, 3]), xy, "must increase"),
        (t, np.zeros((5, 2)) + 7.0, "never moves"),
        (t, np.column_stack([8.42 + 1e-5 * t, 49.01 + 1e-5 * t]), "degrees"),
    ):
        with pytest.raises(ScenarioError, match=fragment) as err:
            route_from_positions(tt, pp, "gpx:track")
        assert "gpx:track" in str(err.value)


def test_gtsam_style_gps_log_with_a_commented_header_is_sniffed(tmp_path):
    path = tmp_path / "KittiGps_converted.txt"
    a = np.linspace(0.0, math.pi, 40)  # a half circle of radius 30 m, counter-clockwise, slightly climbing
    xy = np.column_stack([30 * np.sin(a), 30 * (1 - np.cos(a))])
    rows = "".join(f"{46534.5 + i!r},{x!r},{y!r},{0.01 * i!r}\n" for i, (x, y) in enumerate(xy.tolist()))
    path.write_text("#time(s),x(m),y(m),z(m)\n" + rows)
    rf = read_route_file(path)
    np.testing.assert_allclose(
        rf.route.poses[:, :2], xy, atol=1e-3
    )  # the plane is tilted by the climb, 1e-2 m per 30 m
    np.testing.assert_allclose(_wrap(rf.route.poses[2:-2, 2] - a[2:-2]), 0.0, atol=1e-3)
    assert rf.frame is not None and rf.frame.describe == "ground plane: z up"


# ----------------------------------------------------------------------------- refusals


def _cli(*args: str):
    return CliRunner().invoke(cli, ["score", "--suite", "LRL-roof", *args])


def test_degenerate_routes_exit_2_naming_the_file(tmp_path):
    still = np.zeros((30, 3))
    eye = np.broadcast_to(np.eye(3), (30, 3, 3))
    straight_3d = tmp_path / "line.csv"
    straight_3d.write_text("Time,X,Y,Z\n" + "".join(f"{i},{5.0 * i},{2.0 * i},{0.1 * i}\n" for i in range(30)))
    cases = {
        _kitti(tmp_path / "still_kitti.txt", still, eye): "never moves",
        _tum(tmp_path / "still_tum.txt", np.arange(30.0), still + [3, 4, 0], eye): "never moves",
        straight_3d: "straight line",
    }
    csv_still = tmp_path / "still.csv"
    csv_still.write_text("t,x,y\n" + "".join(f"{i},100.0,200.0\n" for i in range(30)))
    cases[csv_still] = "never moves"
    for path, fragment in cases.items():
        res = _cli("--route", str(path))
        assert res.exit_code == 2 and fragment in res.output and str(path) in res.output, res.output
        assert res.output.startswith("sensorsel: error:") and "Traceback" not in res.output
    # the straight 3-D line is fine once the up axis is stated
    res = _cli("--route", str(straight_3d), "--up", "+z", "--json")
    assert res.exit_code == 0, res.output


def test_positions_and_rotations_that_disagree_on_the_ground_plane_are_refused(tmp_path):
    # rotations turn about z, positions wind in the x-z plane
    n = 60
    a = np.linspace(0, math.pi, n)
    p = np.column_stack([30 * np.sin(a), np.zeros(n), 30 * (1 - np.cos(a))])
    r = Rotation.from_euler("z", a[:, None]).as_matrix()
    path = _tum(tmp_path / "twisted.txt", np.arange(n, dtype=float), p, r)
    res = _cli("--route", str(path))
    assert res.exit_code == 2 and "cannot tell the ground plane" in res.output and str(path) in res.output, res.output
    with pytest.raises(ScenarioError, match="--up"):
        find_frame(p, r, path, convention="z-up")


def test_a_camera_quaternion_is_checked_against_the_direction_of_travel(tmp_path):
    """z-up positions with camera-axis quaternions: the heading is the camera's z along the travel,
    not the quaternion's yaw (which points the camera's x, 90 deg off: radars at 9 o'clock for 12)."""
    n = 80
    a = np.linspace(0, 1.5 * math.pi, n)
    p = np.column_stack([40 * np.sin(a), 40 * (1 - np.cos(a)), np.zeros(n)])  # counter-clockwise, heading = a
    body = Rotation.from_euler("z", a[:, None]).as_matrix() @ C  # camera axes: z forward, y down, x right
    rf = read_route_file(_tum(tmp_path / "cam_q.txt", np.arange(n, dtype=float), p, body))
    np.testing.assert_allclose(_wrap(rf.route.poses[:, 2] - a), 0.0, atol=1e-9)
    np.testing.assert_allclose(rf.route.poses[:, :2], p[:, :2], atol=1e-12)
    assert any("z up" in x and "y down, z forward" in x for x in rf.notes), rf.notes
    # stated axes win: --forward +x gives the quaternion's yaw back (90 deg off), said in the note
    rf = read_route_file(tmp_path / "cam_q.txt", up="+z", forward="+x")
    np.testing.assert_allclose(_wrap(rf.route.poses[:, 2] - a + math.pi / 2), 0.0, atol=1e-9)
    with pytest.raises(InputError, match="--up"):
        read_route_file(tmp_path / "cam_q.txt", up="up")


def test_degree_valued_landmark_and_route_files_are_refused(tmp_path):
    lm = tmp_path / "poles.csv"
    rng = np.random.default_rng(0)
    lm.write_text("".join(f"{8.42 + d:.6f},{49.01 + e:.6f}\n" for d, e in rng.uniform(-1e-4, 1e-4, (40, 2))))
    res = _cli("--landmarks", str(lm))  # the bundled 420 m route
    assert res.exit_code == 2 and str(lm) in res.output and "degrees" in res.output and "GPX" in res.output, res.output
    route = tmp_path / "drive.csv"
    route.write_text("t,x,y\n" + "".join(f"{i},{8.42 + 1e-5 * i!r},{49.01 + 1e-5 * i!r}\n" for i in range(50)))
    res = _cli("--route", str(route))
    assert res.exit_code == 2 and str(route) in res.output and "degrees" in res.output, res.output
    # metres near the origin are not degrees: a 2 m map beside a 3 m route is read
    small = tmp_path / "small.csv"
    small.write_text("t,x,y\n" + "".join(f"{i},{1.0 + 0.1 * i},{2.0}\n" for i in range(30)))
    near = tmp_path / "near.csv"
    near.write_text("x,y\n3,7\n4,-6\n")
    assert _cli("--route", str(small), "--landmarks", str(near)).exit_code == 0


def test_up_and_forward_options(tmp_path):
    res = _cli("--seq", "03", "--up", "+z", "--kitti-root", str(tmp_path))
    assert res.exit_code == 2 and "--up" in res.output
    res = _cli("--route", str(tmp_path / "none.csv"), "--up", "sideways")
    assert res.exit_code == 2
    with pytest.raises(InputError, match="goes with a route file"):
        load_scenario(ScenarioSpec(fixture="tiny", up="+z"))


def test_a_positions_only_route_in_camera_axes_keeps_right_on_the_right(tmp_path):
    """A t,x,y,z log in camera axes (x right, y down, z forward), no rotations: the car drives 60 m
    ahead (+z) then turns right (towards +x) on a 30 m arc, and a pole stands 6 m to its right
    (camera +x) halfway along the straight. Up and down cannot be told apart from positions on a
    plane: taken the wrong way, the route is mirrored, the turn goes left and the pole is seen by
    the left sensors. The oracle is the geometry by hand: a right turn is clockwise seen from above
    (the heading falls by 90 deg), and a pole on the right has a negative car-relative bearing."""
    straight = np.column_stack([np.zeros(31), np.full(31, 1.65), np.linspace(0.0, 60.0, 31)])
    a = np.linspace(0.0, math.pi / 2, 31)[1:]
    arc = np.column_stack([30.0 * (1 - np.cos(a)), np.full(30, 1.65), 60.0 + 30.0 * np.sin(a)])  # bends to +x
    p = np.vstack([straight, arc])
    route = tmp_path / "camera_axes.csv"
    route.write_text("t,x,y,z\n" + "".join(f"{i},{x!r},{y!r},{z!r}\n" for i, (x, y, z) in enumerate(p.tolist())))
    poles = tmp_path / "poles3d.csv"
    poles.write_text("x,y,z\n6.0,0.0,30.0\n")
    rf = read_route_file(route)
    assert rf.frame is not None and "y down" in rf.frame.describe
    heading = np.unwrap(rf.route.poses[:, 2])
    assert heading[-1] - heading[0] == pytest.approx(-math.pi / 2, abs=0.05)  # clockwise: a right turn
    sc = load_scenario(ScenarioSpec(route=str(route), landmarks=str(poles), keyframe_rate_hz=1.0))
    k = int(np.argmin(np.linalg.norm(sc.keyframes.poses[:, :2] - sc.landmarks[0], axis=1)))
    x, y, h = sc.keyframes.poses[k]
    d = sc.landmarks[0] - (x, y)
    bearing = math.atan2(d[1], d[0]) - h
    assert math.sin(bearing) == pytest.approx(-1.0, abs=0.01)  # straight to the right


def test_a_car_that_rolls_back_millimetres_at_a_light_does_not_reverse():
    """Ground truth of a car stopped at a light: 40 m ahead, 10 s standing while the position jitters
    back by 7 mm and forward again, 40 m more. No reversal (the heading is the travel's, 0); a car
    that backs up 3 m is still one."""
    ahead = np.arange(0.0, 40.5, 0.5)
    jitter = 40.0 + np.array([0.0, -0.003, -0.007, -0.004, 0.0, -0.002, 0.0, 0.0, 0.0, 0.0])
    x = np.concatenate([ahead, jitter, 40.0 + np.arange(0.5, 40.5, 0.5)])
    xy = np.column_stack([x, np.zeros_like(x)])
    h, notes = headings_from_travel(np.arange(len(x), dtype=float), xy)
    assert notes == [] and np.abs(h).max() < 1e-9
    back = np.concatenate([ahead, 40.0 - np.arange(0.5, 3.5, 0.5), 37.0 + np.arange(0.5, 40.5, 0.5)])
    _, notes = headings_from_travel(np.arange(len(back), dtype=float), np.column_stack([back, np.zeros_like(back)]))
    assert len(notes) == 1 and "reverses" in notes[0]


def test_a_hand_held_recording_that_moves_70_cm_is_not_taken_for_degrees(tmp_path):
    """A TUM file from a hand-held camera that moves 0.7 m: too little travel, said as such (it was
    'positions that look like degrees'); a drive in degrees spanning a few hundred metres still is."""
    n = 40
    p = np.column_stack([1.2 + 0.7 * np.linspace(0, 1, n), 1.5 + 0.1 * np.sin(np.linspace(0, 3, n)), np.full(n, 1.1)])
    r = np.repeat(np.eye(3)[None], n, axis=0)
    path = _tum(tmp_path / "hand.txt", np.arange(n) * 0.1, p, r)
    with pytest.raises(ScenarioError) as err:
        read_route_file(path)
    msg = str(err.value)
    assert "never moves" in msg and "0.7 m" in msg and "degrees" not in msg
    xy = np.column_stack([8.42 + 1e-5 * np.arange(30.0), 49.01 + 1e-5 * np.arange(30.0)])  # 300 m in degrees
    with pytest.raises(ScenarioError, match="look like degrees"):
        route_from_positions(np.arange(30.0), xy, "gpx:track")
