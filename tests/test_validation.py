"""Degenerate geometry and extreme parameters are refused up front, naming the
file and line or the option, or said in a note; never scored silently, never a traceback.

Each "silent answer" of commit a8085e6 has a test here that fails on it: rotation blocks that are
not rotations, a landmark at 1e300 m, a map out of the route's reach, a tiny landmark spacing (a
MemoryError there), a negative landmark seed (a ValueError there), a keyframe rate above the
data's own (every frame, silently)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from sensorsel.cli import cli
from sensorsel.errors import InputError, ScenarioError
from sensorsel.model import problem as problem_mod
from sensorsel.model.problem import build_problem, check_problem_size, load_problem
from sensorsel.model.scenario import (
    MAX_COORD_M,
    MAX_LANDMARKS,
    ROTATION_TOL,
    LandmarkModel,
    ScenarioSpec,
    Trajectory,
    generate_landmarks,
    load_scenario,
    read_kitti_poses,
    read_landmarks_csv,
    read_planar_csv,
    read_tum_trajectory,
    scenario_notes,
    write_kitti_poses,
)
from sensorsel.model.sensing import estimate_measurements, observe

SEQS = ("00", "02", "03", "04", "06", "08", "10")


def _write(path: Path, lines: list[str]) -> Path:
    path.write_text("".join(line + "\n" for line in lines))
    return path


def _straight(n: int = 61) -> Trajectory:
    x = np.arange(n, dtype=float)
    return Trajectory(np.column_stack([x, np.zeros(n), np.zeros(n)]), x / 10.0, np.arange(n))


def _cli_fails(args: list[str], *fragments: str) -> str:
    res = CliRunner().invoke(cli, args)
    assert res.exit_code == 2, (res.exit_code, res.output, res.exception)
    assert "Traceback" not in res.output
    for f in fragments:
        assert f in res.output, res.output
    return res.output


def _pose_line(r: np.ndarray, t=(0.0, 0.0, 0.0)) -> str:
    m = np.column_stack([r, t])
    return " ".join(f"{v:.9e}" for v in m.ravel())


# ----------------------------------------------------------------------------- rotations, quaternions


@pytest.mark.kitti
def test_kitti_rotation_blocks_are_orthonormal_far_within_the_tolerance(kitti_root):
    worst = 0.0
    for seq in SEQS:
        r = read_kitti_poses(kitti_root / "poses" / f"{seq}.txt")[:, :, :3]
        worst = max(
            worst, float(np.abs(r @ r.transpose(0, 2, 1) - np.eye(3)).max()), float(np.abs(np.linalg.det(r) - 1).max())
        )
    assert worst < 1e-6 and worst < ROTATION_TOL / 1000  # measured: 2.7e-7 (sequence 03)


@pytest.mark.parametrize(
    "block,fragment",
    [
        (np.zeros((3, 3)), "not a rotation"),  # the file: scored by a8085e6
        (np.diag([1.0, 1.0, -1.0]), "det R = -1"),  # a reflection
        (np.eye(3) * 2.0, "not a rotation"),  # scaled
        (np.eye(3) + 0.01 * np.eye(3)[::-1], "not a rotation"),  # skewed beyond the tolerance
    ],
)
def test_pose_blocks_that_are_not_rotations_are_refused_naming_file_and_line(tmp_path, block, fragment):
    good = _pose_line(np.eye(3))
    path = _write(tmp_path / "poses.txt", [good, _pose_line(np.eye(3), (0, 0, 1)), _pose_line(block, (0, 0, 2)), good])
    with pytest.raises(ScenarioError) as err:
        read_kitti_poses(path)
    assert err.value.line == 3 and err.value.path == str(path) and fragment in str(err.value), str(err.value)
    _cli_fails(["score", "--route", str(path), "--suite", "LRL-roof"], f"{path}:3:", "not a rotation")


def test_rotation_within_the_tolerance_is_accepted(tmp_path):
    eps = 1e-5  # 9-digit files, rounding, a little drift: fine
    path = _write(tmp_path / "poses.txt", [_pose_line(np.eye(3) + eps), _pose_line(np.eye(3), (0, 0, 1))])
    assert read_kitti_poses(path).shape == (2, 3, 4)


def test_tum_quaternion_must_have_unit_norm(tmp_path):
    ok = _write(tmp_path / "ok.txt", ["0 0 0 0 0 0 0 1.0005", "1 1 0 0 0 0 0.7071 0.7071"])  # 4-decimal rounding
    route = read_tum_trajectory(ok)
    np.testing.assert_allclose(route.poses[:, 2], [0.0, math.pi / 2], atol=1e-4)
    bad = _write(tmp_path / "bad.txt", ["0 0 0 0 0 0 0 1", "1 1 0 0 0 0 0 0.5"])
    with pytest.raises(ScenarioError) as err:
        read_tum_trajectory(bad)
    assert err.value.line == 2 and "norm 0.5" in str(err.value)
    _cli_fails(["score", "--route", str(bad), "--suite", "LRL-roof"], f"{bad}:2:", "quaternion")


# ------------------------------------------------------------------------------------- coordinates


@pytest.mark.parametrize(
    "row,fragment",
    [
        ("1e300,5", "beyond the limit"),
        ("5,-2e8", "beyond the limit"),
        ("inf,5", "NaN or infinite"),
        ("5,nan", "NaN or infinite"),
    ],
)
def test_absurd_or_non_finite_landmarks_are_refused_naming_file_and_line(tmp_path, row, fragment):
    path = _write(tmp_path / "lm.csv", ["x,y", "10,8", row, "20,-8"])
    with pytest.raises(ScenarioError) as err:
        read_landmarks_csv(path)
    assert err.value.line == 3 and fragment in str(err.value), str(err.value)
    poses = write_kitti_poses(tmp_path / "drive.txt", _straight().poses)
    _cli_fails(["score", "--route", str(poses), "--landmarks", str(path), "--suite", "LRL-roof"], f"{path}:3:")


def test_landmarks_up_to_the_limit_are_read(tmp_path):
    path = _write(tmp_path / "lm.csv", ["x,y", f"{MAX_COORD_M:g},{-MAX_COORD_M:g}", "5e6,9.9e6"])  # UTM-size numbers
    assert read_landmarks_csv(path).shape == (2, 2)


def test_absurd_route_positions_are_refused(tmp_path):
    csv = _write(tmp_path / "r.csv", ["t,x,y,heading", "0,0,0,0", "1,1e300,0,0"])
    with pytest.raises(ScenarioError, match="beyond the limit") as err:
        read_planar_csv(csv)
    assert err.value.line == 3
    tum = _write(tmp_path / "r.tum", ["0 0 0 0 0 0 0 1", "1 0 3e8 0 0 0 0 1"])
    with pytest.raises(ScenarioError, match="beyond the limit") as err:
        read_tum_trajectory(tum)
    assert err.value.line == 2
    kitti = _write(tmp_path / "p.txt", [_pose_line(np.eye(3)), _pose_line(np.eye(3), (0, 0, 1e12))])
    with pytest.raises(ScenarioError, match="beyond the limit") as err:
        read_kitti_poses(kitti)
    assert err.value.line == 2


def test_a_map_listed_twice_scores_as_the_map_once_and_says_so(tmp_path):
    poses = write_kitti_poses(tmp_path / "drive.txt", _straight().poses)
    rows = ["10,8", "20,-7", "35,9", "50,-6"]
    once = _write(tmp_path / "once.csv", ["x,y"] + rows)
    twice = _write(tmp_path / "twice.csv", ["x,y"] + rows + rows)
    base = ["score", "--route", str(poses), "--suite", "LRL-roof,LRR-12", "--json"]
    a = CliRunner().invoke(cli, base + ["--landmarks", str(once)])
    b = CliRunner().invoke(cli, base + ["--landmarks", str(twice)])
    assert a.exit_code == b.exit_code == 0, b.output
    assert json.loads(a.stdout)["score"] == json.loads(b.stdout)["score"]
    sc = load_scenario(ScenarioSpec(poses=str(poses), landmarks=str(twice)))
    assert sc.n_landmarks == 4 and any("4 exact duplicate(s) merged" in n for n in scenario_notes(sc))


# ------------------------------------------------------------------------------------------- reach


def test_a_map_out_of_the_routes_reach_is_an_error_naming_the_map(tmp_path):
    poses = write_kitti_poses(tmp_path / "drive.txt", _straight().poses)
    far = _write(tmp_path / "far.csv", ["x,y", "500000,400000", "500010,400020"])  # another origin (UTM?)
    with pytest.raises(InputError) as err:
        load_problem(ScenarioSpec(poses=str(poses), landmarks=str(far)))
    msg = str(err.value)
    assert str(far) in msg and "none of the 2 landmarks" in msg and "within reach" in msg
    _cli_fails(
        ["score", "--route", str(poses), "--landmarks", str(far), "--suite", "LRL-roof"], str(far), "within reach"
    )
    _cli_fails(
        ["greedy", "--route", str(poses), "--landmarks", str(far), "--budget", "10000"], str(far), "within reach"
    )


def test_landmarks_out_of_reach_are_counted_in_the_problem_and_its_notes(tmp_path):
    poses = write_kitti_poses(tmp_path / "drive.txt", _straight().poses)
    lm = _write(tmp_path / "lm.csv", ["x,y", "10,8", "30,-9", "5000,5000", "20,4", "15,-6"])
    p = load_problem(ScenarioSpec(poses=str(poses), landmarks=str(lm)))
    seen = {int(j) for o in p.observations for j in o.landmark}
    assert seen == {0, 1, 3, 4} and p.n_landmarks_out_of_reach == 1
    np.testing.assert_array_equal(p.landmarks_in_reach, [0, 1, 3, 4])
    notes = [n for n in p.notes if "sensor's reach" in n]
    assert notes == [
        f"landmarks: 1 of 5 landmarks ({lm}) are out of every sensor's reach from every keyframe: "
        "they add nothing to any suite"
    ]
    assert p.notes[: len(p.scenario.notes)] == list(p.scenario.notes)


def test_a_map_mostly_out_of_reach_is_said_loudly(tmp_path):
    """Another city's map on this route: most of its landmarks out of every sensor's reach is a
    warning naming the file and asking whether it is the route's map (a note was easy to miss)."""
    from sensorsel.model.problem import MapOutOfReachWarning

    poses = write_kitti_poses(tmp_path / "drive.txt", _straight().poses)
    lm = _write(tmp_path / "lm.csv", ["x,y", "10,8", "30,-9", "5000,5000", "-4000,100", "20,3000"])
    with pytest.warns(MapOutOfReachWarning, match=r"3 of 5 landmarks \(60 %\).*is this the route's map"):
        p = load_problem(ScenarioSpec(poses=str(poses), landmarks=str(lm)))
    assert p.n_landmarks_out_of_reach == 3 and not [n for n in p.notes if "sensor's reach" in n]  # said once
    r = CliRunner().invoke(cli, ["score", "--route", str(poses), "--landmarks", str(lm), "--suite", "LRL-roof"])
    warn = [ln for ln in r.stderr.splitlines() if "out of every sensor's reach" in ln]
    assert len(warn) == 1 and warn[0].startswith(f"sensorsel: warning: landmarks {lm}: 3 of 5 landmarks (60 %)"), (
        r.stderr
    )


def test_all_landmarks_in_reach_adds_no_note(tiny_problem):
    assert tiny_problem.n_landmarks_out_of_reach == 0 and not [n for n in tiny_problem.notes if "sensor's reach" in n]


def test_a_sub_library_that_sees_nothing_still_builds(tmp_path, library):
    # build_problem (used on sub-routes and sub-libraries) counts; only load_problem refuses
    sc = load_scenario(ScenarioSpec(fixture="tiny"))
    far = type(sc)(sc.name, sc.keyframes, np.array([[1e6, 1e6]]), "far", sc.route)
    p = build_problem(library, far)
    assert p.n_landmarks_out_of_reach == 1 and sum(len(o) for o in p.observations) == 0


# -------------------------------------------------------------------------------------- parameters


def test_tiny_spacing_is_refused_before_allocating_naming_the_option():
    route = _straight(2001)  # 2 km
    with pytest.raises(InputError) as err:
        generate_landmarks(route, LandmarkModel(near_spacing_m=1e-6))
    msg = str(err.value)
    assert "--near-spacing" in msg and "near_spacing_m" in msg and f"{MAX_LANDMARKS:,}" in msg
    assert "4,000,000,080" in msg  # the estimate: 2 roadsides x 2000 m / 1e-6 m, + 2000 m / 25 m
    with pytest.raises(InputError, match="--far-spacing"):
        generate_landmarks(route, LandmarkModel(far_spacing_m=1e-4))
    # just under the limit is allowed (estimated, not generated here)
    from sensorsel.model.scenario import estimate_landmark_count

    assert estimate_landmark_count(2000.0, LandmarkModel()) == 2 * 400 + 80


def test_tiny_spacing_from_the_cli(tmp_path):
    _cli_fails(
        ["landmarks", "--fixture", "tiny", "--near-spacing", "1e-9", "-o", str(tmp_path / "lm.csv")],
        "--near-spacing",
        "more than the limit",
    )
    assert not (tmp_path / "lm.csv").exists()


def test_huge_offsets_are_refused():
    with pytest.raises(InputError, match="--far-offset"):
        LandmarkModel(far_offset_m=(25.0, 1e300))


def test_negative_landmark_seed_is_an_input_error_naming_the_option(tmp_path):
    for seed in (-1, 1.5, True):
        with pytest.raises(InputError, match="--landmark-seed"):
            generate_landmarks(_straight(), seed=seed)
    with pytest.raises(InputError, match="--landmark-seed"):
        load_scenario(ScenarioSpec(fixture="tiny", landmark_seed=-3))
    _cli_fails(
        ["score", "--fixture", "tiny", "--landmarks", "synthetic", "--landmark-seed", "-1", "--suite", "LRL-roof"],
        "--landmark-seed",
        "-1",
    )
    _cli_fails(
        ["landmarks", "--fixture", "tiny", "--landmark-seed", "-1", "-o", str(tmp_path / "lm.csv")], "--landmark-seed"
    )


def test_keyframe_rate_above_the_routes_own_rate_is_said(tmp_path):
    sc = load_scenario(ScenarioSpec(fixture="tiny", keyframe_rate_hz=50.0))
    route = sc.route
    assert len(sc.keyframes) == len(route)
    own = 1.0 / float(np.median(np.diff(route.times)))
    notes = [n for n in scenario_notes(sc) if n.startswith("keyframes:")]
    assert len(notes) == 1 and "50 Hz" in notes[0] and f"{own:.3g} Hz" in notes[0] and "every frame" in notes[0]
    assert not [n for n in scenario_notes(load_scenario(ScenarioSpec(fixture="tiny"))) if n.startswith("keyframes:")]


@pytest.mark.parametrize("rate", ["0", "-2", "nan", "inf"])
def test_bad_keyframe_rates_name_the_option(rate):
    with pytest.raises(InputError, match="--rate"):
        load_scenario(ScenarioSpec(fixture="tiny", keyframe_rate_hz=float(rate)))
    _cli_fails(["score", "--fixture", "tiny", "--rate", rate, "--suite", "LRL-roof"], "--rate")


# ------------------------------------------------------------------------------------------ memory


def test_measurement_estimate_is_close_and_the_bound_is_a_bound(suburb_problem):
    n = sum(len(o) for o in suburb_problem.observations)
    lib, sc = suburb_problem.library, suburb_problem.scenario
    assert estimate_measurements(lib, sc) >= n
    assert abs(estimate_measurements(lib, sc, fov_share=True) - n) < 0.1 * n


def test_problem_too_large_is_refused_before_observing_with_the_estimate(monkeypatch, library):
    sc = load_scenario(ScenarioSpec(fixture="tiny"))
    need = check_problem_size(library, sc)
    with pytest.raises(InputError, match="problem too large") as err:
        check_problem_size(library, sc, limit_bytes=need - 1)
    assert "GiB" in str(err.value) and "--rate" in str(err.value)

    def boom(*a, **k):
        raise AssertionError("observe ran")

    monkeypatch.setattr(problem_mod, "observe", boom)
    monkeypatch.setattr(problem_mod, "MAX_MEASUREMENT_BYTES", 1000)
    with pytest.raises(InputError, match="problem too large"):
        build_problem(library, sc)
    _cli_fails(["score", "--fixture", "tiny", "--suite", "LRL-roof"], "problem too large")


def test_observe_in_blocks_equals_observe_at_once(monkeypatch, library):
    from sensorsel.model import sensing

    sc = load_scenario(ScenarioSpec(fixture="tiny"))
    whole = observe(library, sc)
    monkeypatch.setattr(sensing, "_CHUNK_PAIRS", 7)
    parts = observe(library, sc)
    for a, b in zip(whole, parts):
        for f in ("pose", "landmark", "bearing_rad", "range_m", "sigma_bearing_rad", "sigma_range_m"):
            np.testing.assert_array_equal(getattr(a, f), getattr(b, f))
