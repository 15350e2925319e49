"""What ``sensorsel simulate`` costs on a real route, against the slower way of solving and predicting it
(one factor per measurement, ``gtsam.Marginals``), side by side in one process.

    python bench/simulate.py [--kitti-root ../shared/kitti] [--seq 00] [--runs 10] [--jobs 2]
                             [--suite IDS] [--map-sigma 0.05] [--skip-old]

KITTI 00 (1 Hz keyframes, real pole map) with the $110,000 greedy suite on that map
(``docs/results/greedy00.json``: LRL-roof, MRL-roof, LRR-12, LRR-10, LRR-6, LRR-8), ``--runs``
Monte-Carlo runs on ``--jobs`` processes, in the SLAM graph and (``--map-sigma``) in a prior map.

- new: :func:`sensorsel.simulation.simulate` as the command runs it (runs, closed-form prediction,
  summary), wall time and its parts.
- old, side by side in this process: (1) one run solved as before (one BearingRangeFactor2D per
  measurement) and as now (one per (keyframe, landmark) pair), alternating, ``--old-runs`` runs
  each, one process: the per-run times, their ratio and the largest difference of the estimates;
  (2) the old prediction, ``gtsam.Marginals`` of the simulated graph at the truth (the joint
  marginal of all poses, then one ``marginalCovariance`` per measured landmark), once, against the
  closed form. Old whole simulation = the new runs' wall time × the per-run ratio + the Marginals
  time (the runs are spread over the same processes). ``--skip-old`` leaves (2) out (~300 s on 00).
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

GREEDY00_REAL = "LRL-roof,MRL-roof,LRR-12,LRR-10,LRR-6,LRR-8"


def marginals_prediction(payload) -> tuple[float, np.ndarray]:
    """The old prediction, GTSAM's Marginals; (seconds, joint pose covariance)."""
    import gtsam
    from gtsam.symbol_shorthand import L, X

    from sensorsel.information.graph import pose2
    from sensorsel.simulation.noise import truth
    from sensorsel.simulation.solve import Noise, build_graph

    t = time.perf_counter()
    graph = build_graph(payload, Noise(payload), truth(payload))
    values = gtsam.Values()
    for k in range(len(payload.poses)):
        values.insert(X(k), pose2(payload.poses[k]))
    for j in payload.measured_landmarks():
        values.insert(L(int(j)), gtsam.Point2(*map(float, payload.landmarks[j])))
    m = gtsam.Marginals(graph, values)
    cov = m.jointMarginalCovariance(gtsam.KeyVector([X(k) for k in range(len(payload.poses))])).fullMatrix()
    for j in payload.measured_landmarks():
        m.marginalCovariance(L(int(j)))
    return time.perf_counter() - t, cov


def solve_once(payload, run: int, every_measurement: bool) -> tuple[float, np.ndarray, int]:
    """One run's LM solve as the package does it, or (``every_measurement``) with one factor per
    measurement: (seconds, estimated poses, iterations)."""
    import dataclasses

    from sensorsel.simulation.noise import draw
    from sensorsel.simulation.solve import Noise, pairs, pose_array, solve_lm

    t = time.perf_counter()
    d = draw(payload, run)
    q = pairs(payload, d)
    if every_measurement:  # each measurement its own "pair": the old graph, factor for factor
        o = payload.order()
        q = dataclasses.replace(
            q,
            pose=payload.pose[o],
            landmark=payload.landmark[o],
            bearing_rad=d.bearing_rad[o],
            range_m=d.range_m[o],
            sigma_bearing_rad=payload.sigma_bearing_rad[o],
            sigma_range_m=payload.sigma_range_m[o],
            first=o,
            constant=0.0,
        )
    est, iterations, _ = solve_lm(payload, Noise(payload), d, d.dead_reckoning(), q)
    return time.perf_counter() - t, pose_array(est, len(payload.poses)), iterations


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kitti-root", default=os.environ.get("SENSORSEL_KITTI_ROOT", "../shared/kitti"))
    ap.add_argument("--seq", default="00")
    ap.add_argument("--runs", type=int, default=10)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--suite", default=GREEDY00_REAL)
    ap.add_argument("--map-sigma", type=float, default=0.05)
    ap.add_argument("--skip-old", action="store_true")
    ap.add_argument("--old-runs", type=int, default=2)
    a = ap.parse_args()

    from sensorsel.model.problem import load_problem
    from sensorsel.model.scenario import ScenarioSpec
    from sensorsel.simulation import simulate
    from sensorsel.simulation.consistency import predict
    from sensorsel.simulation.noise import make_payload

    problem = load_problem(ScenarioSpec(seq=a.seq, kitti_root=a.kitti_root))
    suite = problem.library.parse_suite(a.suite)
    print(
        f"KITTI {a.seq}: {problem.scenario.n_poses} keyframes, {problem.scenario.n_landmarks} landmarks; suite "
        f"{a.suite} "
        f"(${problem.library.cost(suite):,.0f}); {a.runs} runs on {a.jobs} process(es); {os.cpu_count()} cores"
    )
    for ms in (None, a.map_sigma):
        model = "SLAM" if ms is None else f"map {ms:g} m"
        t = time.perf_counter()
        res = simulate(problem, suite, runs=a.runs, jobs=a.jobs, map_sigma_m=ms)
        wall = time.perf_counter() - t
        tm = res.timing
        assert tm is not None
        iters = [r.iterations for r in res.runs]
        print(
            f"\n[{model}] new: {wall:.1f} s wall (runs {tm.runs_s:.1f} s, prediction {tm.covariance_s:.2f} s, "
            f"rest {wall - tm.runs_s - tm.covariance_s:.1f} s); LM iterations per run {min(iters)}-{max(iters)}"
        )
        acc = res.accuracy
        assert acc is not None
        for c in ("lateral", "longitudinal", "heading"):
            m, p = acc.spread("measured", c), acc.spread("predicted", c)
            print(
                f"    {c:<12} 95 % predicted {p.median:.4f} / {p.max:.4f}, measured {m.median:.4f} / {m.max:.4f} "
                f"(median / worst keyframe), {100 * dict(acc.coverage)[c]:.1f} % inside ±1.96σ"
            )
        payload = make_payload(problem, suite, (), 1.0, "lm", 0, ms)
        t_old_runs, t_new_runs, diff_runs = 0.0, 0.0, 0.0
        for r in range(a.old_runs):
            t_o, est_o, it_o = solve_once(payload, r, True)
            t_n, est_n, it_n = solve_once(payload, r, False)
            t_old_runs, t_new_runs = t_old_runs + t_o, t_new_runs + t_n
            diff_runs = max(diff_runs, float(np.max(np.abs(est_o - est_n))))
            print(
                f"    run {r}: one factor per measurement {t_o:.1f} s ({it_o} iterations), per pair {t_n:.1f} s "
                f"({it_n} iterations)"
            )
        ratio = t_old_runs / t_new_runs
        print(
            f"    per run: {ratio:.2f}x faster with one factor per pair; largest difference of the estimated poses "
            f"{diff_runs:.1e}"
        )
        if a.skip_old:
            continue
        t = time.perf_counter()
        new_cov = predict(payload).pose_cov
        t_new = time.perf_counter() - t
        t_old, old_cov = marginals_prediction(payload)
        diff = float(np.max(np.abs(new_cov - old_cov)) / np.max(np.abs(old_cov)))
        print(
            f"    prediction: old (gtsam.Marginals) {t_old:.1f} s, new (closed form) {t_new:.2f} s: "
            f"{t_old / t_new:.0f}x; "
            f"max relative difference of the pose covariance {diff:.1e}"
        )
        old = tm.runs_s * ratio + t_old
        print(
            f"    whole simulation: old {old:.1f} s (runs x {ratio:.2f} + Marginals), new {wall:.1f} s: "
            f"{old / wall:.1f}x"
        )


if __name__ == "__main__":
    main()
