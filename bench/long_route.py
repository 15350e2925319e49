"""A long loop-free synthetic route at several keyframe rates (the 5,000-keyframe target
and the growth target on a route without loops, with selections long enough to time).

    python bench/long_route.py [--km 10.4] [--rates 0.625 1.25 2.5 5] [--budget 110000] [--jobs 2]

The route is made the way the fixture generator makes its routes (constant speed, segments of
constant yaw rate integrated at 10 Hz; ``data/kitti_fixtures/generate.py``): straights and gentle
bends alternating left and right, so that it never comes back near itself, with the generator's
synthetic landmarks (``generate_landmarks``, default model, seed 0). Keyframes are taken from
the 10 Hz route at each rate (10 m/s: 2 m apart at 5 Hz). Each rate runs in a fresh child process
(peak RSS is its own ``ru_maxrss``): build the problem, the fast engine (``jobs`` threads), lazy
greedy at the budget without certificate. Printed per rate: keyframes, landmarks, evaluations,
setup and selection seconds, peak RSS (total and per keyframe), which kernel paths ran; then the
exponent of selection time against keyframes fitted over the rates.
"""

from __future__ import annotations

import argparse
import json
import math
import resource
import subprocess
import sys
import time

SPEED_MPS = 10.0
RATE_HZ = 10.0
#: (duration [s], yaw rate [rad/s]): 30 s straight, a 10 s bend left, 30 s straight, a 10 s bend
#: right (±0.5 rad each): the heading swings within ±0.5 rad, so the route never turns back
PATTERN = [(30.0, 0.0), (10.0, 0.05), (30.0, 0.0), (10.0, -0.05)]


def route(km: float):
    """The 10 Hz route of ``km`` kilometres: a Trajectory."""
    import numpy as np

    from sensorsel.model.scenario import Trajectory

    n = int(round(km * 1000.0 / SPEED_MPS * RATE_HZ))
    rates = []
    while len(rates) < n:
        for duration, yaw in PATTERN:
            rates.extend([yaw] * int(round(duration * RATE_HZ)))
    yaw_rate = np.asarray(rates[:n])
    dt = 1.0 / RATE_HZ
    th = np.concatenate([[0.0], np.cumsum(yaw_rate * dt)])[:-1]
    mid = th + 0.5 * yaw_rate * dt  # the fixture generator's midpoint rule
    x = np.concatenate([[0.0], np.cumsum(SPEED_MPS * dt * np.cos(mid))])[:-1]
    y = np.concatenate([[0.0], np.cumsum(SPEED_MPS * dt * np.sin(mid))])[:-1]
    poses = np.column_stack([x, y, th])
    return Trajectory(poses, np.arange(n) / RATE_HZ, np.arange(n), f"synthetic {km:g} km route")


def worker(km: float, rate: float, budget: float, jobs: int) -> dict:
    """One rate, in this process: build, set up, select; the numbers to print."""
    import numpy as np

    from sensorsel.designs.selection import greedy
    from sensorsel.information.evaluators.fast import FastEvaluator
    from sensorsel.model.library import load_library
    from sensorsel.model.problem import build_problem
    from sensorsel.model.scenario import Scenario, generate_landmarks

    full = route(km)
    step = max(1, int(round(RATE_HZ / rate)))
    kf = np.arange(0, len(full.poses), step)
    name = f"long-{km:g}km"
    scenario = Scenario(name, full.select(kf), generate_landmarks(full, seed=0), "generated (seed 0)", route=full)
    t0 = time.perf_counter()
    problem = build_problem(load_library(), scenario)
    t1 = time.perf_counter()
    ev = FastEvaluator(problem, jobs=jobs)
    t2 = time.perf_counter()
    res = greedy(ev, budget)
    t3 = time.perf_counter()
    return {
        "keyframes": problem.scenario.n_poses,
        "landmarks": problem.scenario.n_landmarks,
        "evaluations": res.n_evaluations,
        "load": t1 - t0,
        "setup": t2 - t1,
        "select": t3 - t2,
        "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "paths": dict(ev.kernel.counts),
        "suite": list(res.suite),
        "score": res.score,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--km", type=float, default=10.4, help="route length [km] (default 10.4: 5,200 keyframes at 5 Hz)")
    ap.add_argument("--rates", type=float, nargs="+", default=[0.625, 1.25, 2.5, 5.0], help="keyframe rates [Hz]")
    ap.add_argument("--budget", type=float, default=110_000.0)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--worker", nargs=2, type=float, help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.worker:
        print(json.dumps(worker(a.km, a.worker[1], a.budget, a.jobs)))
        return
    rows = []
    for rate in a.rates:
        out = subprocess.run(
            [
                sys.executable,
                __file__,
                "--km",
                str(a.km),
                "--budget",
                str(a.budget),
                "--jobs",
                str(a.jobs),
                "--worker",
                "0",
                str(rate),
            ],
            capture_output=True,
            text=True,
        )
        if out.returncode != 0:
            raise SystemExit(f"rate {rate:g} Hz failed:\n{out.stderr}")
        r = json.loads(out.stdout)
        rows.append((rate, r))
        print(
            f"{a.km:g} km at {rate:g} Hz: {r['keyframes']:,} keyframes, {r['landmarks']:,} landmarks, "
            f"{r['evaluations']} evaluations; load {r['load']:.1f} s, setup {r['setup']:.2f} s, selection "
            f"{r['select']:.2f} s; "
            f"peak RSS {r['peak_mb']:,.0f} MB ({1024 * r['peak_mb'] / r['keyframes']:.0f} kB per keyframe); "
            f"paths {r['paths']}; "
            f"suite {','.join(r['suite'])}",
            flush=True,
        )
    if len(rows) >= 2:
        xs = [math.log(r["keyframes"]) for _, r in rows]
        ys = [math.log(r["select"]) for _, r in rows]
        mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
        slope = sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sum((x - mx) ** 2 for x in xs)
        k0, k1 = rows[0][1]["keyframes"], rows[-1][1]["keyframes"]
        print(
            f"selection time ~ keyframes^{slope:.2f} over {', '.join(str(r['keyframes']) for _, r in rows)} keyframes "
            f"(x{rows[-1][1]['select'] / rows[0][1]['select']:.1f} time for x{k1 / k0:.1f} keyframes; "
            f"4x keyframes -> x{4**slope:.1f} time)"
        )


if __name__ == "__main__":
    main()
