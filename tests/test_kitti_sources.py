"""``sensorsel kitti``: the KITTI folder rebuilt from its sources (KITTI odometry's poses, times and
calib.txt; PRBonn/pole-localization's globalmap_gt_cluster.npz).

Oracles: hand-worked geometry on a made-up straight drive (always runs), and the published
``landmarks/NN.csv`` of the shared KITTI folder, built independently by whoever prepared it
($SENSORSEL_KITTI_ROOT, with its ``prbonn/`` and ``sequences/NN/calib.txt``).
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from sensorsel.cli import cli
from sensorsel.model.scenario import read_landmarks_csv

SEQS = ("00", "02", "03", "04", "06", "08", "10")
# A KITTI-like calibration: the LiDAR's x ahead, y left, z up; camera 0's x right, y down, z ahead;
# the LiDAR 0.27 m behind and 0.08 m below the camera.
TR = np.array([[0.0, -1.0, 0.0, 0.0], [0.0, 0.0, -1.0, -0.08], [1.0, 0.0, 0.0, -0.27]])


def _kitti(args: list[str]):
    return CliRunner().invoke(cli, ["kitti", *args], catch_exceptions=False)


def _straight_drive(root: Path, seq: str = "07", poles=((10.0, 2.0), (30.0, -4.5)), calib: str | None = None) -> None:
    """A made-up download: a 50 m drive straight along camera 0's z axis, KITTI's calib.txt with its
    P lines and Tr, and PRBonn's layout of a pole map (x, y in the LiDAR frame, then a radius)."""
    (root / "dataset" / "poses").mkdir(parents=True)
    (root / "dataset" / "sequences" / seq).mkdir(parents=True)
    rows = [[1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, float(k)] for k in range(51)]
    (root / "dataset" / "poses" / f"{seq}.txt").write_text("".join(" ".join(f"{v:e}" for v in r) + "\n" for r in rows))
    (root / "dataset" / "sequences" / seq / "times.txt").write_text("".join(f"{0.1 * k:e}\n" for k in range(51)))
    p = " ".join(["7.2e+02"] + ["0"] * 11)
    tr = " ".join(f"{v:.12e}" for v in TR.ravel())
    text = calib if calib is not None else f"P0: {p}\nP1: {p}\nP2: {p}\nP3: {p}\nTr: {tr}\n"
    (root / "dataset" / "sequences" / seq / "calib.txt").write_text(text)
    maps = root / "pole-localization" / "data" / "pole-dataset" / "KITTI" / f"kitti_label_{seq}"
    maps.mkdir(parents=True)
    np.savez(
        maps / "globalmap_gt_cluster.npz", poleparams=np.column_stack([np.asarray(poles), np.full(len(poles), 0.2)])
    )


def test_a_pole_lands_where_hand_worked_geometry_puts_it(tmp_path):
    """A pole 10 m ahead of and 2 m left of the LiDAR, which is 0.27 m behind the camera: 9.73 m ahead,
    2 m left in the route's frame (x ahead, y left at frame 0); one 4.5 m right: y = -4.5. The downloads'
    layouts as published."""
    _straight_drive(tmp_path)
    r = _kitti(
        [
            "--odometry",
            str(tmp_path / "dataset"),
            "--poles",
            str(tmp_path / "pole-localization"),
            "--output-dir",
            str(tmp_path / "out"),
        ]
    )
    assert r.exit_code == 0, r.output
    assert np.array_equal(read_landmarks_csv(tmp_path / "out" / "landmarks" / "07.csv"), [[9.73, 2.0], [29.73, -4.5]])
    assert (tmp_path / "out" / "poses" / "07.txt").read_bytes() == (
        tmp_path / "dataset" / "poses" / "07.txt"
    ).read_bytes()
    assert (tmp_path / "out" / "sequences" / "07" / "times.txt").is_file()
    # the built folder is one the route commands read
    r = CliRunner().invoke(cli, ["score", "--seq", "07", "--kitti-root", str(tmp_path / "out"), "--suite", "LRL-roof"])
    assert r.exit_code == 0, r.output
    assert "2 landmarks" in r.output


@pytest.mark.parametrize(
    "break_it, named, says",
    [
        (
            lambda d, m: (m / "globalmap_gt_cluster.npz").write_text("not a zip"),
            "globalmap_gt_cluster.npz",
            "not a NumPy .npz",
        ),
        (
            lambda d, m: np.savez(m / "globalmap_gt_cluster.npz", poles=np.zeros((3, 2))),
            "globalmap_gt_cluster.npz",
            "no array 'poleparams'",
        ),
        (
            lambda d, m: np.savez(m / "globalmap_gt_cluster.npz", poleparams=np.zeros(3)),
            "globalmap_gt_cluster.npz",
            "got shape (3,)",
        ),
        (
            lambda d, m: np.savez(m / "globalmap_gt_cluster.npz", poleparams=np.array([[1.0, np.nan]])),
            "globalmap_gt_cluster.npz",
            "finite",
        ),
        (lambda d, m: (d / "sequences" / "07" / "calib.txt").write_text("P0: 1 2 3\n"), "calib.txt", "no line 'Tr:'"),
        (
            lambda d, m: (d / "sequences" / "07" / "calib.txt").write_text("Tr: 1 0 0 0 0 1 0 0 0 0 1\n"),
            "calib.txt:1",
            "expected 12 numbers",
        ),
        (
            lambda d, m: (d / "sequences" / "07" / "calib.txt").write_text("Tr: 2 0 0 0 0 1 0 0 0 0 1 0\n"),
            "calib.txt:1",
            "not a rotation",
        ),
        (
            lambda d, m: (d / "sequences" / "07" / "times.txt").write_text("0\n0.1\n"),
            "07.txt",
            "51 poses but 2 timestamps",
        ),
        # another drive's map: poles 400 m away from this route
        (
            lambda d, m: np.savez(m / "globalmap_gt_cluster.npz", poleparams=np.array([[400.0, 5.0], [420.0, -3.0]])),
            "globalmap_gt_cluster.npz",
            "does not lie along sequence 07's route",
        ),
    ],
)
def test_a_wrong_source_is_refused_in_one_line_and_nothing_is_written(tmp_path, break_it, named, says):
    _straight_drive(tmp_path)
    break_it(
        tmp_path / "dataset", tmp_path / "pole-localization" / "data" / "pole-dataset" / "KITTI" / "kitti_label_07"
    )
    r = _kitti(
        [
            "--odometry",
            str(tmp_path / "dataset"),
            "--poles",
            str(tmp_path / "pole-localization"),
            "--output-dir",
            str(tmp_path / "out"),
        ]
    )
    assert r.exit_code == 2
    lines = r.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("sensorsel: error: "), r.output
    assert named in lines[0] and says in lines[0], lines[0]
    assert not (tmp_path / "out").exists()


def test_missing_folders_and_sequences_are_named(tmp_path):
    _straight_drive(tmp_path)
    odo, poles = str(tmp_path / "dataset"), str(tmp_path / "pole-localization")
    for args, says in (
        (["--odometry", str(tmp_path), "--poles", poles], "not KITTI odometry's dataset/ folder"),
        (["--odometry", odo, "--poles", str(tmp_path / "dataset")], "no kitti_label_NN/globalmap_gt_cluster.npz"),
        (["--odometry", odo, "--poles", poles, "--seq", "03"], "--seq 03: no"),
    ):
        r = _kitti([*args, "--output-dir", str(tmp_path / "out")])
        assert r.exit_code == 2 and says in r.output and len(r.output.strip().splitlines()) == 1, r.output


@pytest.mark.kitti
def test_rebuilds_the_published_pole_maps_within_a_millimetre(kitti_root, tmp_path):
    """Every pole of the seven shared sequences' landmarks/NN.csv, rebuilt from prbonn/ and calib.txt."""
    prbonn = kitti_root / "prbonn"
    if not prbonn.is_dir():
        pytest.fail(f"{prbonn} not found: the shared KITTI folder keeps PRBonn's pole maps there", pytrace=False)
    r = _kitti(["--odometry", str(kitti_root), "--poles", str(prbonn), "--output-dir", str(tmp_path)])
    assert r.exit_code == 0, r.output
    for seq in SEQS:
        built, published = (read_landmarks_csv(root / "landmarks" / f"{seq}.csv") for root in (tmp_path, kitti_root))
        assert built.shape == published.shape and len(built) > 100, seq
        assert np.abs(built - published).max() <= 1e-3 + 1e-9, seq


@pytest.mark.kitti
def test_another_sequences_pole_map_is_refused(kitti_root, tmp_path):
    """Sequence 00's pole map filed as 03's (a mix-up a download invites) is named, not converted."""
    shutil.copytree(kitti_root / "prbonn" / "kitti_label_00", tmp_path / "kitti_label_03")
    r = _kitti(
        ["--odometry", str(kitti_root), "--poles", str(tmp_path), "--seq", "03", "--output-dir", str(tmp_path / "out")]
    )
    assert r.exit_code == 2 and "does not lie along sequence 03's route" in r.output, r.output
    assert not (tmp_path / "out").exists()
