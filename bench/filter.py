"""What the filter's accuracy (the forward pass: as the car drives) costs against the smoother's
(today's pose marginals), measured side by side in one process, same suite, same route.

    python bench/filter.py [--kitti-root ../shared/kitti] [--seqs 00] [--repeat 3] [--all]

For each route (the bundled suburb route, then each KITTI sequence at 1 Hz with its real pole map)
and each suite (the roof LiDAR alone, the smoother's $2,840 local-streets answer on the bundled
route; with ``--all`` also all 62 sensors), in both localization models: the minimum CPU time over
``--repeat`` runs of the
smoother's pose covariances (from a fresh base state: what a new suite costs) and of the forward
pass, dense (every landmark held updated at every keyframe) and in windows (the default: the
landmarks not measured in a window left out of its updates), their ratios, and the filter's largest
state (landmarks held at once). CPU time, not wall:
the machine this was written on was shared; the ratio is what to read.
"""

from __future__ import annotations

import argparse
import math
import os
import time
from pathlib import Path


def _cpu(fn, repeat: int) -> float:
    best = math.inf
    for _ in range(repeat):
        t = time.process_time()
        fn()
        best = min(best, time.process_time() - t)
    return best


def measure(problem, name: str, suite: tuple[int, ...], repeat: int) -> None:
    from sensorsel.information.evaluators import FastEvaluator
    from sensorsel.information.filtering import forward_pass

    ev = FastEvaluator(problem)
    for ms in (None, 0.05):

        def smoother() -> None:
            ev._base = None  # a fresh base state each time: what a new suite costs
            ev.pose_covariances(suite, map_sigma_m=ms, estimate="smoother")

        held = [0]
        forward_pass(
            problem,
            suite,
            map_sigma_m=ms,
            on_prediction=lambda p, m: held.__setitem__(0, max(held[0], len(p.landmarks))),
        )

        def filt() -> None:
            forward_pass(problem, suite, map_sigma_m=ms, window=0)

        def windowed() -> None:
            forward_pass(problem, suite, map_sigma_m=ms)

        ts, tf, tw = _cpu(smoother, repeat), _cpu(filt, repeat), _cpu(windowed, repeat)
        print(
            f"{problem.scenario.name:>8} {problem.scenario.n_poses:4d} kf {name:>22} {'map' if ms else 'slam':>4}: "
            f"smoother {1e3 * ts:9.1f} ms, filter dense {1e3 * tf:9.1f} ms ({tf / ts:6.1f}x), "
            f"in windows {1e3 * tw:9.1f} ms ({tf / tw:4.1f}x faster), at most {held[0]} landmarks held",
            flush=True,
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--kitti-root",
        default=os.environ.get("SENSORSEL_KITTI_ROOT", str(Path(__file__).resolve().parents[2] / "shared" / "kitti")),
    )
    ap.add_argument("--seqs", nargs="*", default=["00"])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--all", action="store_true", help="also all 62 sensors (minutes on KITTI 00)")
    args = ap.parse_args()

    from sensorsel import ScenarioSpec, load_problem
    from sensorsel.model.library import load_library

    lib = load_library()
    suites = [
        ("LRL-roof", (lib.position("LRL-roof"),)),
        ("LRR-7,HD2K-4,HD2K-9,LSC-2", tuple(sorted(lib.position(i) for i in ("LRR-7", "HD2K-4", "HD2K-9", "LSC-2")))),
    ]
    if args.all:
        suites.append(("all 62", tuple(range(len(lib)))))
    problems = [load_problem(ScenarioSpec())] + [
        load_problem(ScenarioSpec(seq=s, kitti_root=args.kitti_root)) for s in args.seqs
    ]
    for problem in problems:
        for name, suite in suites:
            measure(problem, name, suite, args.repeat)


if __name__ == "__main__":
    main()
