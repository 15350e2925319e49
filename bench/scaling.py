"""How the fast engine's cost grows with the route: the route-order (frontal) path
against the dense pose Cholesky, side by side, in one run.

    python bench/scaling.py [--kitti-root DIR] [--jobs N] [--budget USD] [--runs SPEC ...] [--quick]

Each run is a lazy greedy ($110,000, uniform rule, real pole maps) in a fresh child process (peak
RSS is its own ``ru_maxrss``). ``new`` is the engine as shipped (the kernel picks the frontal or
the dense path per evaluation by predicted flops, :data:`sensorsel.information.evaluators.fast.kernel.FRONT_BELOW`);
``old`` is the same engine held to the dense path (``front_below=0``: no frontal elimination).
Old and new of one configuration run back to back, alternating which goes first, so that both see
the same machine load. Printed: keyframes, suites scored, setup (one-off linearization) and
selection seconds, peak RSS (total and per keyframe), which kernel paths ran, and for each pair the
speed-up and whether the picks and every step's score agree (1e-9 relative). Then the fitted
exponent of selection time against keyframes for each sequence run at several rates.

A run SPEC is ``SEQ@HZ:ENGINES``, e.g. ``02@3:old,new`` or ``02@10:new``; an engine ``fb=X`` is the
new one with ``front_below=X`` (to measure the crossover).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import resource
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

DEFAULT_RUNS = [
    "03@1:old,new",
    "03@2:old,new",
    "03@4:old,new",
    "03@8:old,new",
    "02@1:old,new",
    "02@3:old,new",
    "00@1:old,new",
    "02@10:new",
]
QUICK_RUNS = ["03@1:old,new", "03@2:old,new", "03@4:old,new", "03@8:old,new"]


def worker(seq: str, hz: float, engine: str, kitti_root: str, budget: float, jobs: int) -> dict:
    """One lazy greedy in this process; returns its measurements."""
    sys.path.insert(0, str(REPO / "src"))
    from sensorsel.designs.selection import greedy
    from sensorsel.information.evaluators.fast import FastEvaluator
    from sensorsel.model.problem import load_problem
    from sensorsel.model.scenario import ScenarioSpec

    t0 = time.perf_counter()
    problem = load_problem(ScenarioSpec(seq=seq, kitti_root=kitti_root, keyframe_rate_hz=hz))
    t1 = time.perf_counter()
    kw = (
        {"front_below": 0.0}
        if engine == "old"
        else {"front_below": float(engine[3:])}
        if engine.startswith("fb=")
        else {}
    )
    ev = FastEvaluator(problem, jobs=jobs, **kw)
    t2 = time.perf_counter()
    c0 = time.process_time()
    res = greedy(ev, budget, "uniform", lazy=True)
    t3 = time.perf_counter()
    return {
        "seq": seq,
        "hz": hz,
        "engine": engine,
        "jobs": ev.jobs,
        "n_poses": problem.scenario.n_poses,
        "n_landmarks": problem.scenario.n_landmarks,
        "load_s": t1 - t0,
        "setup_s": t2 - t1,
        "select_s": t3 - t2,
        "cpu_s": time.process_time() - c0,
        "n_evaluations": res.n_evaluations,
        "suite": list(res.suite),
        "score": res.score,
        "step_scores": [s.score for s in res.steps],
        "counts": dict(ev.kernel.counts),
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
    }


def run_child(seq: str, hz: float, engine: str, args: argparse.Namespace) -> dict:
    cmd = [
        sys.executable,
        __file__,
        "--worker",
        seq,
        str(hz),
        engine,
        "--kitti-root",
        args.kitti_root,
        "--budget",
        str(args.budget),
        "--jobs",
        str(args.jobs),
    ]
    out = subprocess.run(cmd, check=True, capture_output=True, text=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def table(rows: list[list[str]], header: list[str]) -> str:
    widths = [max(len(str(r[i])) for r in [header] + rows) for i in range(len(header))]

    def line(r: list) -> str:
        return "  ".join(str(v).rjust(w) if i else str(v).ljust(w) for i, (v, w) in enumerate(zip(r, widths)))

    return "\n".join([line(header), "  ".join("-" * w for w in widths)] + [line(r) for r in rows])


def agree(a: dict, b: dict) -> tuple[bool, float]:
    """(same picks and step scores to 1e-9 relative, largest relative difference)."""
    n = min(len(a["step_scores"]), len(b["step_scores"]))
    rel = max([abs(x - y) / max(1.0, abs(y)) for x, y in zip(a["step_scores"][:n], b["step_scores"][:n])] + [0.0])
    return a["suite"] == b["suite"] and len(a["step_scores"]) == len(b["step_scores"]) and rel <= 1e-9, rel


def fit_exponent(points: list[tuple[int, float]]) -> float:
    """Least-squares slope of log(time) against log(keyframes)."""
    xs = [math.log(k) for k, _ in points]
    ys = [math.log(t) for _, t in points]
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    return sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sum((x - mx) ** 2 for x in xs)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument(
        "--kitti-root", default=os.environ.get("SENSORSEL_KITTI_ROOT", str(REPO.parent / "shared" / "kitti"))
    )
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--budget", type=float, default=110_000.0)
    ap.add_argument(
        "--runs", nargs="+", default=None, help="SEQ@HZ:ENGINES, e.g. 02@3:old,new (default: the issue's table)"
    )
    ap.add_argument("--quick", action="store_true", help="KITTI 03 at 1, 2, 4, 8 Hz only")
    ap.add_argument("--worker", nargs=3, metavar=("SEQ", "HZ", "ENGINE"), help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        seq, hz, engine = args.worker
        print(json.dumps(worker(seq, float(hz), engine, args.kitti_root, args.budget, args.jobs)))
        return
    specs = args.runs or (QUICK_RUNS if args.quick else DEFAULT_RUNS)
    print(
        f"machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}; "
        f"budget ${args.budget:,.0f}, jobs={args.jobs}; load average at start {os.getloadavg()[0]:.1f}",
        flush=True,
    )
    results: list[dict] = []
    for i, spec in enumerate(specs):
        where, engines = spec.split(":")
        seq, hz = where.split("@")
        order = engines.split(",")
        if i % 2:
            order = order[::-1]  # alternate which engine goes first
        for engine in order:
            print(f"... {seq} @ {hz} Hz {engine}", file=sys.stderr, flush=True)
            results.append(run_child(seq, float(hz), engine, args))
    rows = []
    for r in results:
        paths = ",".join(f"{k}:{v}" for k, v in sorted(r["counts"].items()) if k in ("front", "potrf", "splu"))
        rows.append(
            [
                r["seq"],
                f"{r['hz']:g}",
                r["engine"],
                r["n_poses"],
                r["n_evaluations"],
                f"{r['setup_s']:.2f}",
                f"{r['select_s']:.2f}",
                f"{r['cpu_s']:.1f}",
                f"{r['setup_s'] + r['select_s']:.2f}",
                f"{r['peak_rss_mb']:.0f}",
                f"{1024 * r['peak_rss_mb'] / r['n_poses']:.0f}",
                paths,
                f"{r['score']:.4f}",
            ]
        )
    print()
    print(
        table(
            rows,
            [
                "seq",
                "Hz",
                "engine",
                "keyframes",
                "evals",
                "setup s",
                "select s",
                "cpu s",
                "wall s",
                "peak MB",
                "kB/kf",
                "paths (evaluations)",
                "score f [nats]",
            ],
        )
    )
    print("\nwall = setup + selection (loading excluded); cpu = process CPU of the selection (all threads);")
    print("kB/kf = peak RSS per keyframe (the whole process: interpreter, numpy, gtsam, the scenario).")
    by = {(r["seq"], r["hz"], r["engine"]): r for r in results}
    print()
    for (seq, hz, engine), new in by.items():
        old = by.get((seq, hz, "old"))
        if engine != "new" or old is None:
            continue
        ok, rel = agree(new, old)
        print(
            f"{seq} @ {hz:g} Hz: selection {old['select_s']:.2f} s -> {new['select_s']:.2f} s "
            f"({old['select_s'] / new['select_s']:.1f}x; CPU {old['cpu_s'] / max(new['cpu_s'], 1e-9):.1f}x), "
            f"picks and scores agree: {'yes' if ok else 'NO'} (largest relative difference {rel:.1e})"
        )
    for engine in ("old", "new"):
        seqs = sorted({r["seq"] for r in results if r["engine"] == engine})
        for seq in seqs:
            pts = sorted((r["n_poses"], r["select_s"]) for r in results if r["engine"] == engine and r["seq"] == seq)
            if len(pts) >= 3:
                print(
                    f"{seq} {engine}: selection time ~ keyframes^{fit_exponent(pts):.2f} over "
                    f"{', '.join(str(k) for k, _ in pts)} keyframes "
                    f"(x{pts[-1][1] / pts[0][1]:.1f} time for x{pts[-1][0] / pts[0][0]:.1f} keyframes)"
                )


if __name__ == "__main__":
    main()
