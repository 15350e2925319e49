"""Scenarios: real KITTI ground truth, bad route / timestamp / landmark files, file round trips, the
landmark generator and the bundled fixtures."""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from sensorsel.cli import cli
from sensorsel.errors import InputError, ScenarioError
from sensorsel.io.resources import fixtures_dir
from sensorsel.model.scenario import (
    KITTI_ROOT_ENV,
    LandmarkModel,
    ScenarioSpec,
    Trajectory,
    generate_landmarks,
    load_scenario,
    load_sequence,
    load_trajectory,
    read_kitti_poses,
    read_landmarks_csv,
    read_times,
    resolve_kitti_root,
    select_keyframes,
    write_kitti_poses,
    write_landmarks_csv,
)

REPO = Path(__file__).resolve().parents[1]


def _wrap(a):
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def _heading_vs_travel_deg(poses: np.ndarray, window: int = 10, max_turn_deg: float = 1.0, min_move_m: float = 3.0):
    """Heading vs direction of travel [deg] on straight stretches, computed from positions alone.

    The direction of travel over ``window`` frames is that of the displacement between their end
    positions; a stretch is straight when the heading varies less than ``max_turn_deg`` over it.
    """
    d = poses[window:, :2] - poses[:-window, :2]
    moved = np.hypot(d[:, 0], d[:, 1])
    h = np.unwrap(poses[:, 2])
    turn = np.array([np.ptp(h[i : i + window + 1]) for i in range(len(poses) - window)])
    straight = (turn < math.radians(max_turn_deg)) & (moved > min_move_m)
    travel = np.arctan2(d[:, 1], d[:, 0])
    mean_heading = 0.5 * (h[window:] + h[:-window])
    return np.degrees(np.abs(_wrap(travel - mean_heading)))[straight]


# ------------------------------------------------------------------------------------ real KITTI


@pytest.mark.kitti
def test_kitti_00_loads_4541_frames_and_3_7_km(kitti_root):
    route = load_sequence(kitti_root, "00")
    assert len(route) == 4541
    assert route.poses.shape == (4541, 3) and route.times.shape == (4541,)
    assert 3500.0 < route.length_m < 3900.0
    assert 470.0 < route.duration_s < 471.0  # as the data's README states (470.6 s)
    # frame 0 is the origin of KITTI's poses: the car at (0, 0) heading along planar X
    np.testing.assert_allclose(route.poses[0], 0.0, atol=1e-6)


@pytest.mark.kitti
def test_kitti_03_loads_801_frames(kitti_root):
    route = load_sequence(kitti_root, "03")
    assert len(route) == 801
    assert 500.0 < route.length_m < 620.0  # "about 0.56 km"
    assert np.all(np.diff(route.times) > 0)


@pytest.mark.kitti
@pytest.mark.parametrize("seq", ["00", "03"])
def test_kitti_headings_follow_the_direction_of_travel(kitti_root, seq):
    poses = load_sequence(kitti_root, seq).poses
    err = _heading_vs_travel_deg(poses)
    assert len(err) > 150  # enough straight stretches to mean something
    assert err.max() < 5.0, err.max()
    # a heading off by a quarter turn (e.g. the camera's x axis taken as forward) would fail here
    assert np.median(_heading_vs_travel_deg(poses + [0.0, 0.0, math.pi / 2])) > 80.0


@pytest.mark.kitti
def test_kitti_03_keyframes_at_1_hz(kitti_root):
    # the synthetic map asked for explicitly: --seq alone uses the real pole map
    sc = load_scenario(ScenarioSpec(seq="03", kitti_root=str(kitti_root), landmarks="synthetic"))
    assert 78 <= sc.n_poses <= 84
    dt = np.diff(sc.keyframes.times)
    assert np.all((dt > 0.95) & (dt < 1.15)), dt
    assert sc.name == "03" and len(sc.route) == 801
    assert sc.n_landmarks > 100 and sc.landmark_source == "generated (seed 0)"
    # the keyframes are frames of the full route
    np.testing.assert_array_equal(sc.keyframes.poses, sc.route.poses[sc.keyframes.frames])


@pytest.mark.kitti
def test_kitti_root_from_environment(kitti_root, monkeypatch):
    monkeypatch.setenv(KITTI_ROOT_ENV, str(kitti_root))
    assert resolve_kitti_root(None) == Path(kitti_root)
    assert len(load_scenario(ScenarioSpec(seq="03")).route) == 801


# --------------------------------------------------------------------------------- bad route files


def _pose_lines() -> list[str]:
    return (fixtures_dir() / "poses" / "tiny.txt").read_text().splitlines()


TIMES = fixtures_dir() / "sequences" / "tiny" / "times.txt"


def _write(path: Path, lines: list[str]) -> Path:
    path.write_text("".join(line + "\n" for line in lines))
    return path


def _raises_at(path: Path, line: int | None, fragment: str, fn, *args):
    with pytest.raises(ScenarioError) as err:
        fn(*args)
    msg = str(err.value)
    assert err.value.path == str(path) and str(path) in msg, msg
    assert err.value.line == line, msg
    if line is not None:
        assert f"{path}:{line}:" in msg
    assert fragment in msg, msg
    return msg


def test_truncated_pose_file(tmp_path):
    lines = _pose_lines()
    path = _write(tmp_path / "trunc.txt", lines[:40])
    _raises_at(path, 40, "truncated: 40 poses but 91 timestamps", load_trajectory, path, TIMES)


def test_pose_file_longer_than_its_timestamps(tmp_path):
    lines = _pose_lines()
    path = _write(tmp_path / "long.txt", lines + lines[-1:])
    with pytest.raises(ScenarioError, match="longer than its timestamps"):
        load_trajectory(path, TIMES)


def test_line_with_11_numbers(tmp_path):
    lines = _pose_lines()
    lines[6] = " ".join(lines[6].split()[:11])
    path = _write(tmp_path / "eleven.txt", lines)
    _raises_at(path, 7, "expected 12 numbers", read_kitti_poses, path)
    _raises_at(path, 7, "found 11", load_trajectory, path, TIMES)


@pytest.mark.parametrize(
    "bad,fragment",
    [("nan", "NaN"), ("inf", "infinite"), ("1.0.0", "not a number: '1.0.0'"), ("x", "not a number: 'x'")],
)
def test_bad_number_in_pose_file(tmp_path, bad, fragment):
    lines = _pose_lines()
    parts = lines[12].split()
    parts[3] = bad
    lines[12] = " ".join(parts)
    path = _write(tmp_path / "bad.txt", lines)
    _raises_at(path, 13, fragment, load_trajectory, path, TIMES)


def test_missing_and_empty_pose_files(tmp_path):
    _raises_at(tmp_path / "none.txt", None, "not found", load_trajectory, tmp_path / "none.txt", TIMES)
    empty = _write(tmp_path / "empty.txt", [])
    _raises_at(empty, None, "empty", load_trajectory, empty, TIMES)
    blank = _write(tmp_path / "blank.txt", ["", "   "])
    _raises_at(blank, None, "empty", read_kitti_poses, blank)


def test_missing_sequence_lists_those_present(tmp_path):
    for seq in ("05", "07"):
        (tmp_path / "poses").mkdir(exist_ok=True)
        _write(tmp_path / "poses" / f"{seq}.txt", _pose_lines())
    msg = _raises_at(tmp_path / "poses" / "03.txt", None, "'03' not found", load_sequence, tmp_path, "03")
    assert "05, 07" in msg
    # present poses but no times.txt: the missing timestamp file is named
    _raises_at(tmp_path / "sequences" / "05" / "times.txt", None, "not found", load_sequence, tmp_path, "05")


@pytest.mark.parametrize(
    "times,line,fragment",
    [
        (["0.0", "0.1", "0.1"], 3, "must increase"),
        (["0.0", "0.2", "0.1"], 3, "must increase"),
        (["0.0", "0.1 0.2"], 2, "expected 1 numbers"),
        (["0.0", "nan"], 2, "NaN"),
        (["0.0", "soon"], 2, "not a number"),
    ],
)
def test_bad_timestamps(tmp_path, times, line, fragment):
    path = _write(tmp_path / "times.txt", times)
    _raises_at(path, line, fragment, read_times, path)


def test_empty_timestamps(tmp_path):
    path = _write(tmp_path / "times.txt", [])
    _raises_at(path, None, "empty", read_times, path)


@pytest.mark.parametrize(
    "rows,line,fragment",
    [
        (["x,y", "1,2", "3"], 3, "found 1 fields"),
        (["x,y", "1,2,3"], 2, "found 3 fields"),
        (["1,nan"], 1, "NaN"),
        (["x,y", "1;2"], 2, "found 1 fields"),
        (["x,y", "1,2", "a,b"], 3, "not a number: 'a'"),
        (["x,y", "1,2", "x,y"], 3, "not a number: 'x'"),  # a header only before the data
    ],
)
def test_bad_landmark_csv(tmp_path, rows, line, fragment):
    path = _write(tmp_path / "lm.csv", rows)
    _raises_at(path, line, fragment, read_landmarks_csv, path)


def test_landmark_csv_missing_or_without_landmarks(tmp_path):
    _raises_at(tmp_path / "none.csv", None, "not found", read_landmarks_csv, tmp_path / "none.csv")
    for rows in ([], ["x,y"], ["# my map", "x,y", ""]):
        path = _write(tmp_path / "empty.csv", rows)
        _raises_at(path, None, "no landmarks", read_landmarks_csv, path)


def test_landmark_csv_comments_and_header(tmp_path):
    path = _write(tmp_path / "lm.csv", ["# surveyed poles", "x, y", "1.5,-2", "", "# more", "3,4e1"])
    np.testing.assert_array_equal(read_landmarks_csv(path), [[1.5, -2.0], [3.0, 40.0]])


def _cli_error(args, env=None) -> str:
    result = CliRunner().invoke(cli, args, env=env)
    assert result.exit_code == 2, result.output
    assert isinstance(result.exception, SystemExit) and "Traceback" not in result.output
    err = result.stderr.strip()
    assert len(err.splitlines()) == 1 and err.startswith("sensorsel: error: "), err
    return err


def test_seq_without_kitti_root_says_how_to_point_at_one(monkeypatch):
    monkeypatch.delenv(KITTI_ROOT_ENV, raising=False)
    err = _cli_error(["score", "--seq", "03", "--suite", "LRL-roof"], env={KITTI_ROOT_ENV: None})
    assert "--kitti-root" in err and KITTI_ROOT_ENV in err and "poses/NN.txt" in err
    with pytest.raises(InputError, match="--kitti-root"):
        load_scenario(ScenarioSpec(seq="03"))


def test_kitti_root_that_is_not_a_dataset(tmp_path):
    err = _cli_error(["score", "--seq", "03", "--kitti-root", str(tmp_path), "--suite", "LRL-roof"])
    assert str(tmp_path) in err and "poses" in err


def test_bad_files_from_the_cli(tmp_path):
    lines = _pose_lines()
    lines[4] = lines[4].replace(lines[4].split()[2], "nan", 1)
    poses = _write(tmp_path / "drive.txt", lines)
    assert f"{poses}:5:" in _cli_error(["score", "--route", str(poses), "--suite", "LRL-roof"])
    good = _write(tmp_path / "good.txt", _pose_lines())
    lm = _write(tmp_path / "lm.csv", ["x,y", "1,2", "3,4,5"])
    assert f"{lm}:3:" in _cli_error(["score", "--route", str(good), "--landmarks", str(lm), "--suite", "LRL-roof"])
    times = _write(tmp_path / "times.txt", ["0", "1", "1"])
    assert f"{times}:3:" in _cli_error(["score", "--route", str(good), "--times", str(times), "--suite", "LRL-roof"])
    assert "'nope'" in _cli_error(["score", "--fixture", "nope", "--suite", "LRL-roof"])
    assert "keyframe rate" in _cli_error(["score", "--rate", "0", "--suite", "LRL-roof"])


def test_keyframe_rate_validation():
    t = np.arange(50) * 0.1
    for bad in (0.0, -1.0, float("nan"), float("inf")):
        with pytest.raises(InputError, match="keyframe rate"):
            select_keyframes(t, bad)
    np.testing.assert_array_equal(select_keyframes(t, 1.0), [0, 10, 20, 30, 40])
    np.testing.assert_array_equal(select_keyframes(t, 10.0), np.arange(50))


# -------------------------------------------------------------------------------------- round trips


def test_kitti_pose_file_round_trip(tmp_path):
    rng = np.random.default_rng(7)
    planar = np.column_stack(
        [rng.uniform(-800, 800, 200), rng.uniform(-800, 800, 200), rng.uniform(-np.pi, np.pi, 200)]
    )
    path = write_kitti_poses(tmp_path / "poses.txt", planar)
    raw = read_kitti_poses(path)
    rot = raw[:, :, :3]
    # proper rotations about the camera's (vertical) y axis
    np.testing.assert_allclose(np.einsum("nij,nkj->nik", rot, rot), np.broadcast_to(np.eye(3), rot.shape), atol=1e-8)
    np.testing.assert_allclose(np.linalg.det(rot), 1.0, atol=1e-8)
    np.testing.assert_allclose(raw[:, 1, 3], 0.0)
    back = load_trajectory(path)  # no times file: 10 Hz
    np.testing.assert_allclose(back.poses[:, :2], planar[:, :2], atol=1e-5)
    np.testing.assert_allclose(_wrap(back.poses[:, 2] - planar[:, 2]), 0.0, atol=1e-8)
    np.testing.assert_allclose(back.times, np.arange(200) / 10.0)


def test_landmark_csv_round_trip(tmp_path):
    rng = np.random.default_rng(11)
    lm = rng.uniform(-1000, 1000, (300, 2))
    path = write_landmarks_csv(tmp_path / "sub" / "lm.csv", lm)
    assert path.read_text().startswith("x,y\n")
    np.testing.assert_allclose(read_landmarks_csv(path), lm, atol=1e-6)


def test_poses_file_with_landmark_csv_as_a_scenario(tmp_path):
    planar = np.column_stack([np.arange(0, 60.0, 1.0), np.zeros(60), np.zeros(60)])
    poses = write_kitti_poses(tmp_path / "mydrive.txt", planar)
    lm = write_landmarks_csv(tmp_path / "map.csv", [[10.0, 5.0], [30.0, -5.0]])
    sc = load_scenario(ScenarioSpec(poses=str(poses), landmarks=str(lm)))
    assert sc.name == "mydrive" and sc.n_poses == 6 and sc.landmark_source == str(lm)
    np.testing.assert_allclose(sc.keyframes.poses[:, 0], [0, 10, 20, 30, 40, 50], atol=1e-6)


# ------------------------------------------------------------------------------ landmark generator


def _straight(length_m: float = 1000.0, step_m: float = 1.0) -> Trajectory:
    x = np.arange(0.0, length_m + step_m / 2, step_m)
    return Trajectory(np.column_stack([x, np.zeros_like(x), np.zeros_like(x)]), x / 10.0, np.arange(len(x)))


def _hairpin() -> Trajectory:
    """200 m out, a half circle of radius 6 m, 200 m back: the two carriageways are 12 m apart."""
    out = np.column_stack([np.arange(0, 200.0, 0.5), np.zeros(400)])
    a = np.linspace(-np.pi / 2, np.pi / 2, 60)
    turn = np.column_stack([200 + 6 * np.cos(a), 6 + 6 * np.sin(a)])
    back = np.column_stack([np.arange(200.0, 0, -0.5), np.full(400, 12.0)])
    xy = np.concatenate([out, turn, back])
    return Trajectory(np.column_stack([xy, np.zeros(len(xy))]), np.arange(len(xy)) / 10.0, np.arange(len(xy)))


def _distance_to_polyline(points: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """Exact distance of each point to the polyline through xy (brute force over segments)."""
    a, b = xy[:-1], xy[1:]
    ab = b - a
    t = np.einsum("psk,sk->ps", points[:, None, :] - a[None], ab) / np.maximum(np.einsum("sk,sk->s", ab, ab), 1e-300)
    closest = a[None] + np.clip(t, 0, 1)[..., None] * ab[None]
    return np.min(np.linalg.norm(points[:, None, :] - closest, axis=2), axis=1)


def test_generator_is_deterministic_per_seed():
    route = _hairpin()
    a = generate_landmarks(route, seed=4)
    np.testing.assert_array_equal(a, generate_landmarks(route, seed=4))
    b = generate_landmarks(route, seed=5)
    assert a.shape[1] == 2 and (a.shape != b.shape or not np.allclose(a, b))


def test_generator_keeps_clearance_from_the_route():
    route = _hairpin()
    model = LandmarkModel(clearance_m=3.0)
    lm = generate_landmarks(route, model, seed=1)
    dist = _distance_to_polyline(lm, route.poses[:, :2])
    assert dist.min() >= 3.0 - 0.02  # the generator measures to points at most 0.5 m apart on the route
    # on this route (carriageways 12 m apart) some near landmarks of one side fall on the other road
    all_lm = generate_landmarks(route, LandmarkModel(clearance_m=0.0), seed=1)
    assert len(all_lm) > len(lm)
    assert _distance_to_polyline(all_lm, route.poses[:, :2]).min() < 3.0
    wide = generate_landmarks(route, LandmarkModel(clearance_m=8.0), seed=1)
    assert _distance_to_polyline(wide, route.poses[:, :2]).min() >= 8.0 - 0.02


def test_generator_densities_as_documented():
    """Near: both roadsides every ~5 m, 4-12 m off; far: every ~25 m on one side, 25-80 m off."""
    route = _straight(1000.0)
    lm = generate_landmarks(route, LandmarkModel(), seed=2)
    off = np.abs(lm[:, 1])
    near, far = lm[off <= 12.0], lm[off >= 25.0]
    assert len(near) + len(far) == len(lm)  # nothing in between
    assert off[off <= 12.0].min() >= 4.0 and off.max() <= 80.0
    assert abs(np.sum(near[:, 1] > 0) - 1000 / 5) <= 10 and abs(np.sum(near[:, 1] < 0) - 1000 / 5) <= 10
    assert abs(len(far) - 1000 / 25) <= 4
    assert np.all((lm[:, 0] >= 0) & (lm[:, 0] <= 1000))
    # spacing along the road: one near landmark per 5 m bin and side (jittered within its bin)
    left = np.sort(near[near[:, 1] > 0, 0])
    assert np.median(np.diff(left)) == pytest.approx(5.0, rel=0.2)
    # a denser model gives proportionally more
    dense = generate_landmarks(route, LandmarkModel(near_spacing_m=2.5, far_spacing_m=50.0), seed=2)
    assert np.sum(np.abs(dense[:, 1]) <= 12) == pytest.approx(800, abs=10)
    assert np.sum(np.abs(dense[:, 1]) >= 25) == pytest.approx(20, abs=3)


@pytest.mark.parametrize(
    "kw",
    [
        dict(near_spacing_m=0.0),
        dict(far_spacing_m=-5.0),
        dict(near_offset_m=(12.0, 4.0)),
        dict(far_offset_m=(-1.0, 5.0)),
        dict(clearance_m=-1.0),
        dict(near_spacing_m=float("nan")),
    ],
)
def test_landmark_model_validation(kw):
    with pytest.raises(InputError, match=next(iter(kw))):
        LandmarkModel(**kw)


# ------------------------------------------------------------------------------------------ fixtures


def test_bundled_fixtures_as_documented():
    suburb = load_scenario(ScenarioSpec())
    assert (suburb.name, suburb.n_poses, suburb.n_landmarks) == ("suburb", 53, 182)
    tiny = load_scenario(ScenarioSpec(fixture="tiny"))
    assert (tiny.name, tiny.n_poses, tiny.n_landmarks) == ("tiny", 10, 37)
    for sc in (suburb, tiny):
        err = _heading_vs_travel_deg(sc.route.poses, window=5, min_move_m=1.0)
        assert len(err) > 20 and err.max() < 1.0


def test_fixture_files_equal_what_the_generator_writes(tmp_path):
    script = REPO / "data" / "kitti_fixtures" / "generate.py"
    spec = importlib.util.spec_from_file_location("_fixture_generator", script)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    written = module.main(tmp_path)
    assert len(written) == 6
    for path in written:
        rel = Path(path).relative_to(tmp_path)
        assert (fixtures_dir() / rel).read_bytes() == Path(path).read_bytes(), rel


def test_times_without_poses_is_refused(tmp_path):
    times = _write(tmp_path / "times.txt", ["0", "1"])
    result = CliRunner().invoke(cli, ["score", "--times", str(times), "--suite", "LRL-roof"])
    assert result.exit_code == 2 and "Traceback" not in result.output
    assert "--times" in result.output and "--route" in result.output


def test_pose_files_read_as_pythons_float_reads_each_number(tmp_path):
    """read_kitti_poses parses all lines at once (numpy) where every line is good: the same numbers
    as Python's float() on each token, commas and blank lines included."""
    import numpy as np

    from sensorsel.model.scenario import read_kitti_poses

    rng = np.random.default_rng(7)
    rows = []
    for k in range(50):
        c, s = np.cos(0.1 * k), np.sin(0.1 * k)
        rows.append([c, 0.0, s, rng.normal() * 1e3, 0.0, 1.0, 0.0, rng.normal(), -s, 0.0, c, rng.normal() * 1e-3])
    text = "\n".join(
        (", " if k % 2 else " ").join(repr(float(v)) for v in r) + ("\n" if k == 10 else "") for k, r in enumerate(rows)
    )
    path = tmp_path / "poses.txt"
    path.write_text(text + "\n")
    want = np.array([[float(t) for t in line.replace(",", " ").split()] for line in text.splitlines() if line.strip()])
    got = read_kitti_poses(path)
    assert got.shape == (50, 3, 4) and np.array_equal(got.reshape(50, 12), want)


def test_densified_route_is_each_segment_cut_into_equal_steps():
    """Oracle: each segment a -> b cut by hand into n = ceil(|b - a| / step) equal steps (a repeated
    point and a zero-length segment included)."""
    import numpy as np

    from sensorsel.model.scenario.landmarks import _densify

    xy = np.array([[0.0, 0.0], [1.2, 0.0], [1.2, 0.0], [1.2, -0.7], [4.0, 3.0]])
    want = [xy[0]]
    for a, b in zip(xy[:-1], xy[1:]):
        n = max(1, math.ceil(math.hypot(*(b - a)) / 0.5))
        want += [a + (k / n) * (b - a) for k in range(1, n + 1)]
    got = _densify(xy, 0.5)
    assert got.shape == (len(want), 2) and np.array_equal(got, np.array(want))
    assert np.all(np.hypot(*np.diff(got, axis=0).T) <= 0.5 + 1e-12)
