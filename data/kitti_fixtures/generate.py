"""Regenerate the bundled fixture scenarios (synthetic, made by this project; no KITTI data).

Each fixture is laid out as KITTI odometry's dataset/ folder, plus landmark CSVs:
    poses/NAME.txt            one row-major 3x4 camera pose per frame (x right, y down, z forward)
    sequences/NAME/times.txt  one timestamp [s] per frame (10 Hz)
    landmarks/NAME.csv        x,y [m] in sensorsel's planar frame (X = camera z, Y = -camera x)

Fixtures:
    suburb  416 m at 8 m/s: a straight, a 90-degree left turn, a gentle S-bend (53 s). The default
            scenario of every command.
    tiny    ~70 m straight then a slight curve (9 s), ~40 landmarks: small enough for brute force.

Run:  python data/kitti_fixtures/generate.py [OUT_DIR]   (deterministic: same files every time;
      OUT_DIR defaults to this folder, tests regenerate into a temporary one and compare)
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from sensorsel.io.files import atomic_write_text
from sensorsel.model.scenario import (
    LandmarkModel,
    Trajectory,
    generate_landmarks,
    write_kitti_poses,
    write_landmarks_csv,
)

HERE = Path(__file__).resolve().parent
RATE_HZ = 10.0


def drive(segments: list[tuple[float, float]], speed: float) -> np.ndarray:
    """Integrate (duration [s], yaw rate [rad/s]) segments at constant speed [m/s]; (N, 3) poses."""
    dt = 1.0 / RATE_HZ
    x = y = th = 0.0
    out = [(x, y, th)]
    for duration, yaw_rate in segments:
        for _ in range(int(round(duration * RATE_HZ))):
            x += speed * dt * np.cos(th + 0.5 * yaw_rate * dt)
            y += speed * dt * np.sin(th + 0.5 * yaw_rate * dt)
            th += yaw_rate * dt
            out.append((x, y, th))
    return np.asarray(out)


FIXTURES = {
    "suburb": dict(
        segments=[(20.0, 0.0), (6.0, np.pi / 12), (10.0, 0.0), (8.0, -0.08), (8.0, 0.08)],
        speed=8.0,
        seed=3,
        model=LandmarkModel(),
    ),
    "tiny": dict(
        segments=[(5.0, 0.0), (4.0, 0.06)],
        speed=8.0,
        seed=5,
        model=LandmarkModel(near_spacing_m=4.0, far_spacing_m=20.0, far_offset_m=(25.0, 60.0)),
    ),
}


def main(out_dir: str | Path = HERE) -> list[Path]:
    """Write every fixture under ``out_dir`` (KITTI layout + landmarks/); returns the files written."""
    out = Path(out_dir)
    written = []
    for name, spec in FIXTURES.items():
        planar = drive(spec["segments"], spec["speed"])
        times = np.arange(len(planar)) / RATE_HZ
        written.append(write_kitti_poses(out / "poses" / f"{name}.txt", planar))
        written.append(atomic_write_text(out / "sequences" / name / "times.txt", "".join(f"{t:.6e}\n" for t in times)))
        route = Trajectory(planar, times, np.arange(len(planar)), name)
        landmarks = generate_landmarks(route, spec["model"], spec["seed"])
        written.append(write_landmarks_csv(out / "landmarks" / f"{name}.csv", landmarks))
        print(f"{name}: {len(planar)} frames, {route.length_m:.0f} m, {len(landmarks)} landmarks")
    return written


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else HERE)
