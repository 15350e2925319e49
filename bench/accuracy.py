"""What the accuracy of a suite (pose marginals in metres) costs, against one evaluation of its score,
measured side by side in one process (target: at most 4 evaluations, linear in the route).

    python bench/accuracy.py [--kitti-root ../shared/kitti] [--seqs 00 03] [--km 10.4]
                             [--rates 0.625 1.25 2.5 5] [--repeat 3] [--gtsam]

For each KITTI route (1 Hz keyframes, real pole map) and each suite (the $4,000 roof LiDAR alone,
and all 62 sensors), in both localization models: the minimum over ``--repeat`` runs of one
evaluation (the log det, from a fresh base state) and of the suite's pose covariances, and their
ratio. With ``--gtsam``, GTSAM's ``Marginals`` of the same suite on the same route once (slow: ~30
s for one LiDAR on 00). Then the long loop-free synthetic route of ``bench/long_route.py`` at
several keyframe rates (the roof LiDAR), with the exponent of the accuracy's time against the
keyframes fitted over the rates (1 = linear).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))


def _time(fn, repeat: int) -> float:
    best = math.inf
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return best


def measure(problem, suite: tuple[int, ...], repeat: int, gtsam: bool) -> list[str]:
    from sensorsel.information.evaluators import FastEvaluator, ReferenceEvaluator

    ev = FastEvaluator(problem)
    rows = []
    for ms in (None, 0.05):

        def evaluation() -> None:
            ev._base = None  # a fresh base state each time: what scoring a new suite costs
            ev.logdet(suite)

        def accuracy() -> None:
            ev._base = None
            ev.pose_covariances(suite, map_sigma_m=ms)

        te, ta = _time(evaluation, repeat), _time(accuracy, repeat)
        path = "frontal" if ev.kernel.counts.get("front_covariance") else "dense"
        line = (
            f"{problem.scenario.name:>12} {problem.scenario.n_poses:6d} kf {len(suite):3d} sensors "
            f"{'map' if ms else 'slam':>4}: evaluation {1e3 * te:8.1f} ms, accuracy {1e3 * ta:8.1f} ms "
            f"({ta / te:4.2f} evaluations, {path})"
        )
        if gtsam:
            ref = ReferenceEvaluator(problem)
            tg = _time(lambda: ref.pose_covariances(suite, map_sigma_m=ms), 1)
            line += f"; GTSAM Marginals {tg:7.2f} s ({tg / ta:,.0f}x)"
        rows.append(line)
        ev.kernel.counts.clear()
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--kitti-root",
        default=os.environ.get("SENSORSEL_KITTI_ROOT", str(Path(__file__).resolve().parents[2] / "shared" / "kitti")),
    )
    ap.add_argument("--seqs", nargs="*", default=["03", "00"])
    ap.add_argument("--km", type=float, default=10.4)
    ap.add_argument("--rates", type=float, nargs="*", default=[0.625, 1.25, 2.5, 5.0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--gtsam", action="store_true", help="also time GTSAM's Marginals (slow)")
    args = ap.parse_args()

    from sensorsel import ScenarioSpec, load_problem
    from sensorsel.model.library import load_library
    from sensorsel.model.problem import build_problem
    from sensorsel.model.scenario import Scenario, generate_landmarks

    lib = load_library()
    lidar = (lib.position("LRL-roof"),)
    for seq in args.seqs:
        problem = load_problem(ScenarioSpec(seq=seq, kitti_root=args.kitti_root))
        for suite in (lidar, tuple(range(len(lib)))):
            for line in measure(problem, suite, args.repeat, args.gtsam):
                print(line, flush=True)
    if args.rates:
        from long_route import RATE_HZ, route

        full = route(args.km)
        landmarks = generate_landmarks(full, seed=0)
        ks, ts = [], []
        for rate in args.rates:
            kf = np.arange(0, len(full.poses), max(1, int(round(RATE_HZ / rate))))
            problem = build_problem(
                lib, Scenario(f"long-{args.km:g}km", full.select(kf), landmarks, "generated (seed 0)", route=full)
            )
            rows = measure(problem, lidar, args.repeat, False)
            for line in rows:
                print(line, flush=True)
            ks.append(problem.scenario.n_poses)
            ts.append(float(rows[0].split("accuracy")[1].split("ms")[0]))
        if len(ks) > 1:
            slope = np.polyfit(np.log(ks), np.log(ts), 1)[0]
            print(f"accuracy time ~ K^{slope:.2f} over {ks[0]}-{ks[-1]} keyframes (SLAM model, roof LiDAR)")


if __name__ == "__main__":
    main()
