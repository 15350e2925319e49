"""The KITTI folder the tool reads, rebuilt from what a user downloads (``sensorsel kitti``, docs/guide-data.md).

Sources, as their publishers lay them out:

- KITTI odometry (``data_odometry_poses`` and ``data_odometry_calib``), its ``dataset/`` folder:
  ``poses/NN.txt`` (camera-0 poses), ``sequences/NN/times.txt`` and ``sequences/NN/calib.txt``, whose
  line ``Tr:`` is the row-major 3x4 Velodyne-to-camera-0 transform;
- PRBonn/pole-localization: ``data/pole-dataset/KITTI/kitti_label_NN/globalmap_gt_cluster.npz``,
  array ``poleparams``, one pole a row, x and y [m] in the Velodyne frame of the sequence's first scan
  (further columns, when there are any, are not used).

Each pole becomes ``p = Tr (x, y, 0, 1)`` in camera-0 coordinates of frame 0, then ``(p_z, -p_x)``:
the planar frame a KITTI route is read in (:func:`~sensorsel.model.scenario.kitti.planar_from_kitti`),
written with 3 decimals (1 mm) to ``landmarks/NN.csv``.
"""

from __future__ import annotations

import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sensorsel.errors import InputError, ScenarioError
from sensorsel.io.files import atomic_write_bytes, atomic_write_text
from sensorsel.model.scenario.base import ROTATION_TOL, _parse_row, _read_lines
from sensorsel.model.scenario.kitti import kitti_map_path, read_kitti_poses, read_times
from sensorsel.model.scenario.landmarks import distance_to_route

POLE_MAP = "globalmap_gt_cluster.npz"
POLE_FOLDERS = ("", "KITTI", "pole-dataset/KITTI", "data/pole-dataset/KITTI")  # where kitti_label_NN may be
# A pole map is labelled from LiDAR scans along the route: every pole of the right map lies within
# 56 m of its route (the seven shared sequences), another sequence's map mostly does not.
ALONG_ROUTE_M = 60.0
ALONG_ROUTE_SHARE = 0.9


@dataclass(frozen=True)
class KittiSources:
    """The downloaded files of one sequence ``seq``."""

    seq: str
    poses: Path
    times: Path
    calib: Path
    poles: Path


@dataclass(frozen=True)
class BuiltSequence:
    """What :func:`build_kitti_folder` wrote: the route's frame count, the poles [count] and their median
    distance to the route [m]."""

    seq: str
    frames: int
    poles: int
    median_distance_m: float
    landmarks: Path


def pole_map_folder(poles: str | Path) -> Path:
    """The folder holding ``kitti_label_NN/``: ``poles`` itself, or its ``data/pole-dataset/KITTI``
    (a clone of PRBonn/pole-localization), ...; InputError naming ``poles`` when there is none."""
    root = Path(poles)
    for sub in POLE_FOLDERS:
        if any((root / sub).glob(f"kitti_label_*/{POLE_MAP}")):
            return root / sub
    raise InputError(
        f"--poles {poles}: no kitti_label_NN/{POLE_MAP} there nor under data/pole-dataset/KITTI "
        "(a clone of PRBonn/pole-localization, or its data/pole-dataset/KITTI folder)"
    )


def find_sources(odometry: str | Path, poles: str | Path, seqs: list[str] | None = None) -> list[KittiSources]:
    """The sources of ``seqs`` (default: every sequence with both a pose file and a pole map).

    Raises:
        InputError: a folder without the expected files, a sequence asked for that one of them lacks.
    """
    odo, pole_dir = Path(odometry), pole_map_folder(poles)
    if not (odo / "poses").is_dir():
        raise InputError(
            f"--odometry {odometry}: not KITTI odometry's dataset/ folder (expected {odo / 'poses'}/NN.txt)"
        )
    have_maps = {p.parent.name.removeprefix("kitti_label_") for p in pole_dir.glob(f"kitti_label_*/{POLE_MAP}")}
    have_poses = {p.stem for p in (odo / "poses").glob("*.txt")}
    if seqs is None:
        seqs = sorted(have_maps & have_poses)
        if not seqs:
            raise InputError(
                f"no sequence has both a pose file in {odo / 'poses'} ({', '.join(sorted(have_poses)) or 'none'}) "
                f"and a pole map in {pole_dir} ({', '.join(sorted(have_maps)) or 'none'})"
            )
    out = []
    for seq in seqs:
        if seq not in have_poses:
            raise InputError(
                f"--seq {seq}: no {odo / 'poses' / (seq + '.txt')}; that folder has: "
                f"{', '.join(sorted(have_poses)) or 'none'}"
            )
        if seq not in have_maps:
            raise InputError(
                f"--seq {seq}: no pole map {pole_dir / ('kitti_label_' + seq) / POLE_MAP}; "
                f"there are: {', '.join(sorted(have_maps)) or 'none'}"
            )
        out.append(
            KittiSources(
                seq,
                odo / "poses" / f"{seq}.txt",
                odo / "sequences" / seq / "times.txt",
                odo / "sequences" / seq / "calib.txt",
                pole_dir / f"kitti_label_{seq}" / POLE_MAP,
            )
        )
    return out


def read_velodyne_to_camera(path: str | Path) -> np.ndarray:
    """The (3, 4) transform ``Tr`` of a KITTI ``calib.txt`` (its line ``Tr: 12 numbers``).

    Raises:
        ScenarioError: no ``Tr:`` line, not 12 finite numbers, a 3x3 block that is not a rotation.
    """
    path = Path(path)
    for lineno, line in enumerate(_read_lines(path, "calibration"), start=1):
        if line.startswith("Tr:"):
            tr = np.asarray(
                _parse_row(line[3:], path, lineno, 12, "the Velodyne-to-camera transform Tr"), dtype=float
            ).reshape(3, 4)
            r = tr[:, :3]
            err = max(float(np.abs(r @ r.T - np.eye(3)).max()), abs(float(np.linalg.det(r)) - 1.0))
            if err > ROTATION_TOL:
                raise ScenarioError(
                    path, f"Tr's 3x3 block is not a rotation (error {err:.3g}, allowed {ROTATION_TOL:g})", lineno
                )
            return tr
    raise ScenarioError(
        path, "no line 'Tr:' (KITTI odometry's calib.txt holds the Velodyne-to-camera-0 transform there)"
    )


def read_pole_map(path: str | Path) -> np.ndarray:
    """The poles (M, 2), x and y [m] in the Velodyne frame of the first scan, of a PRBonn
    ``globalmap_gt_cluster.npz`` (array ``poleparams``, M rows of at least 2 numbers).

    Raises:
        ScenarioError: not an npz file, no ``poleparams``, a wrong shape, a number that is not finite.
    """
    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as npz:
            if "poleparams" not in npz.files:
                raise ScenarioError(
                    path,
                    "no array 'poleparams' (a PRBonn pole map has one; this file has: "
                    f"{', '.join(npz.files) or 'none'})",
                )
            params = np.asarray(npz["poleparams"])
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as exc:
        raise ScenarioError(path, f"not a NumPy .npz pole map ({exc.__class__.__name__}: {exc})") from None
    if params.ndim != 2 or params.shape[1] < 2 or params.shape[0] < 1 or not np.issubdtype(params.dtype, np.number):
        raise ScenarioError(
            path,
            f"'poleparams' must be M rows of at least 2 numbers (x, y, ...); got shape {params.shape}, dtype "
            f"{params.dtype}",
        )
    xy = params[:, :2].astype(float)
    bad = np.flatnonzero(~np.isfinite(xy).all(axis=1))
    if len(bad):
        raise ScenarioError(
            path, f"pole {int(bad[0])} (row of 'poleparams') has a coordinate that is not a finite number"
        )
    return xy


def poles_in_route_frame(poles_xy: np.ndarray, tr: np.ndarray) -> np.ndarray:
    """Poles (M, 2) in the Velodyne frame -> (M, 2) in the route's planar frame: ``p = Tr (x, y, 0, 1)``
    in camera-0 coordinates, then ``(p_z, -p_x)``."""
    xy = np.asarray(poles_xy, dtype=float).reshape(-1, 2)
    p = xy[:, 0:1] * tr[:, 0] + xy[:, 1:2] * tr[:, 1] + tr[:, 3]
    return np.column_stack([p[:, 2], -p[:, 0]])


def pole_landmarks(src: KittiSources) -> tuple[np.ndarray, np.ndarray]:
    """(landmarks (M, 2) in the route's planar frame [m], their distances to the route (M,) [m]),
    every source of ``src`` read and checked.

    Raises:
        ScenarioError: a bad pose, times, calibration or pole file (naming it); a pole map that does not
            lie along the route (another sequence's map or calibration).
    """
    poses = read_kitti_poses(src.poses)
    times = read_times(src.times)
    if len(times) != len(poses):
        raise ScenarioError(src.poses, f"{len(poses)} poses but {len(times)} timestamps in {src.times}")
    lm = poles_in_route_frame(read_pole_map(src.poles), read_velodyne_to_camera(src.calib))
    route = np.column_stack([poses[:, 2, 3], -poses[:, 0, 3]])  # the route's planar positions (planar_from_kitti)
    dist = distance_to_route(lm, route)
    share = float(np.mean(dist <= ALONG_ROUTE_M))
    if share < ALONG_ROUTE_SHARE:
        raise ScenarioError(
            src.poles,
            f"does not lie along sequence {src.seq}'s route: {share:.0%} of its {len(lm)} poles within "
            f"{ALONG_ROUTE_M:g} m of it (a sequence's own map: at least {ALONG_ROUTE_SHARE:.0%}; median distance "
            f"{float(np.median(dist)):.0f} m); another sequence's pole map, or {src.calib} of another sequence?",
        )
    return lm, dist


def build_kitti_folder(sources: list[KittiSources], out: str | Path) -> list[BuiltSequence]:
    """Write ``out/landmarks/NN.csv`` for every sequence (and copy ``poses/NN.txt`` and
    ``sequences/NN/times.txt`` there byte for byte, unless ``out`` holds them already), each file
    atomically; every source is read and checked before anything is written.

    Raises:
        ScenarioError: as :func:`pole_landmarks` (nothing written).
    """
    out = Path(out)
    checked = [(src, *pole_landmarks(src)) for src in sources]
    built = []
    for src, lm, dist in checked:
        for source, target in (
            (src.poses, out / "poses" / f"{src.seq}.txt"),
            (src.times, out / "sequences" / src.seq / "times.txt"),
        ):
            if not (target.exists() and target.resolve() == source.resolve()):
                target.parent.mkdir(parents=True, exist_ok=True)
                atomic_write_bytes(target, source.read_bytes())
        target = kitti_map_path(out, src.seq)
        target.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(target, "x,y\n" + "".join(f"{x:.3f},{y:.3f}\n" for x, y in lm))
        built.append(BuiltSequence(src.seq, len(read_times(src.times)), len(lm), float(np.median(dist)), target))
    return built


__all__ = [
    "ALONG_ROUTE_M",
    "ALONG_ROUTE_SHARE",
    "BuiltSequence",
    "KittiSources",
    "POLE_MAP",
    "build_kitti_folder",
    "find_sources",
    "pole_landmarks",
    "pole_map_folder",
    "poles_in_route_frame",
    "read_pole_map",
    "read_velodyne_to_camera",
]
