"""The row checks the route readers share (KITTI poses, TUM trajectories, route CSVs): each bad file is
one ScenarioError naming the file, the first bad line and how many such lines the file holds, in
the exact words below (written out here by hand, as a user reads them)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sensorsel.errors import ScenarioError
from sensorsel.model.scenario.csv_route import read_csv_route
from sensorsel.model.scenario.kitti import read_kitti_poses
from sensorsel.model.scenario.tum import read_tum_route


def _write(path: Path, lines: list[str]) -> Path:
    path.write_text("\n".join(lines) + "\n")
    return path


def _refused(read, path: Path) -> str:
    with pytest.raises(ScenarioError) as err:
        read(path)
    return str(err.value)


def test_positions_beyond_the_limit_name_the_first_line_and_count_them(tmp_path):
    csv = _write(tmp_path / "r.csv", ["t,x,y", "0,0,0", "1,2e8,0", "2,3,0", "3,0,-4e8"])
    assert _refused(read_csv_route, csv) == (
        f"{csv}:3: position [200000000.0, 0.0] is beyond the limit of 1e+08 m from the origin "
        "(in metres? no map is that large); 2 such line(s) in the file"
    )
    # a TUM file's height counts too (its three coordinates are checked); a CSV's z is not a map position
    tum = _write(tmp_path / "r.tum", ["0 0 0 0 0 0 0 1", "1 1 0 5e8 0 0 0 1"])
    assert _refused(read_tum_route, tum) == (
        f"{tum}:2: position [1.0, 0.0, 500000000.0] is beyond the limit of 1e+08 m from the origin "
        "(in metres? no map is that large); 1 such line(s) in the file"
    )


def test_a_pose_that_is_no_rotation_names_its_line_and_counts_them(tmp_path):
    def line(r: np.ndarray, t: float) -> str:
        return " ".join(f"{v:g}" for v in np.hstack([r, [[t], [0.0], [0.0]]]).ravel())

    path = _write(tmp_path / "p.txt", [line(np.eye(3), 0.0), line(np.eye(3) * 2.0, 1.0), line(np.zeros((3, 3)), 2.0)])
    assert _refused(read_kitti_poses, path) == (
        f"{path}:2: the 3x3 block R of the pose is not a rotation (max |R R^T - I| = 3, det R = 8; allowed 0.001); "
        "2 such line(s) in the file"
    )


def test_no_rows_and_times_that_do_not_increase_are_refused_alike_in_both_formats(tmp_path):
    csv = _write(tmp_path / "empty.csv", ["t,x,y,heading"])
    assert _refused(read_csv_route, csv) == f"{csv}: route CSV has a header but no poses"
    tum = _write(tmp_path / "empty.tum", ["# only a comment"])
    assert _refused(read_tum_route, tum) == (
        f"{tum}: TUM trajectory is empty: expected lines of 'timestamp tx ty tz qx qy qz qw'"
    )
    csv = _write(tmp_path / "back.csv", ["t,x,y,heading", "0,0,0,0", "2,1,0,0", "1,2,0,0"])
    assert _refused(read_csv_route, csv) == f"{csv}:4: timestamps must increase: 1.0 after 2.0"
    tum = _write(tmp_path / "back.tum", ["0 0 0 0 0 0 0 1", "0 1 0 0 0 0 0 1"])
    assert _refused(read_tum_route, tum) == f"{tum}:2: timestamps must increase: 0.0 after 0.0"
