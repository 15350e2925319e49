"""Speed of robust selection against plain greedy on KITTI 00, real pole map.

    python bench/robust.py [--kitti-root DIR] [--seq 00] [--budget 110000] [--failures 1] [--out bench/robust.md]

One run of each, each in a fresh child process (so its peak memory is its own): the plain uniform
greedy (fast engine, lazy) and ``robust_select`` at the same budget and alpha, on a problem loaded with
``load_problem(ScenarioSpec(seq=..., kitti_root=...))`` (the sequence's real pole map by default).
Printed and written as a small Markdown table: wall seconds of the selection (loading the scenario
and building the engine are timed apart), suites scored, peak RSS (``ru_maxrss`` at the child's end:
interpreter, numpy, gtsam and the scenario included), the suite's worst case. Timings depend on the
machine's load (the 1-minute load average is recorded); nothing else is claimed.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def worker(what: str, seq: str, kitti_root: str, budget: float, alpha: int) -> dict:
    sys.path.insert(0, str(REPO / "src"))
    from sensorsel.designs.resilient import worst_case
    from sensorsel.designs.robust import robust_select
    from sensorsel.designs.selection import greedy
    from sensorsel.information.evaluators import make_evaluator
    from sensorsel.model.problem import load_problem
    from sensorsel.model.scenario import ScenarioSpec

    t0 = time.perf_counter()
    problem = load_problem(ScenarioSpec(seq=seq, kitti_root=kitti_root))
    t_load = time.perf_counter() - t0
    t0 = time.perf_counter()
    ev = make_evaluator(problem, "fast", jobs=1)
    t_setup = time.perf_counter() - t0
    t0 = time.perf_counter()
    if what == "greedy":
        g = greedy(ev, budget, "uniform")
        sel = time.perf_counter() - t0
        n = ev.n_evaluations
        w = worst_case(ev, [problem.library.position(s) for s in g.suite], alpha)
        out = {
            "suite": list(g.suite),
            "nominal": g.score,
            "worst": w.score,
            "method": "greedy-uniform",
            "bound": None,
            "skipped": [],
        }
    else:
        r = robust_select(ev, budget, alpha)
        sel = time.perf_counter() - t0
        n = r.n_evaluations
        out = {
            "suite": list(r.suite),
            "nominal": r.nominal_score,
            "worst": r.worst_score,
            "method": r.method,
            "bound": r.bound,
            "skipped": list(r.skipped),
            "candidates": [(c.method, c.worst_score, c.n_evaluations, c.seconds) for c in r.candidates],
        }
    out.update(
        what=what,
        load_s=t_load,
        setup_s=t_setup,
        seconds=sel,
        evaluations=n,
        peak_rss_mb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
    )
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kitti-root", default=os.environ.get("SENSORSEL_KITTI_ROOT", "/work/shared/kitti"))
    ap.add_argument("--seq", default="00")
    ap.add_argument("--budget", type=float, default=110_000.0)
    ap.add_argument("--failures", type=int, default=1)
    ap.add_argument("--out", default=None, help="also write the table here (Markdown)")
    ap.add_argument("--worker", choices=["greedy", "robust"], help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.worker:
        print(json.dumps(worker(a.worker, a.seq, a.kitti_root, a.budget, a.failures)))
        return
    rows = []
    for what in ("greedy", "robust"):
        load = os.getloadavg()[0]
        p = subprocess.run(
            [
                sys.executable,
                __file__,
                "--worker",
                what,
                "--seq",
                a.seq,
                "--kitti-root",
                a.kitti_root,
                "--budget",
                str(a.budget),
                "--failures",
                str(a.failures),
            ],
            capture_output=True,
            text=True,
            check=True,
        )
        r = json.loads(p.stdout.strip().splitlines()[-1])
        r["load"] = load
        rows.append(r)
    lines = [
        f"KITTI {a.seq}, real pole map, ${a.budget:,.0f}, alpha = {a.failures}, fast engine, jobs = 1",
        "",
        "| run | method | seconds | evaluations | peak RSS [MB] | worst case | load (1 min) |",
        "|---|---|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        lines.append(
            f"| {r['what']} | {r['method']} | {r['seconds']:.1f} | {r['evaluations']:,} | {r['peak_rss_mb']:.0f} | "
            f"{r['worst']:,.2f} | {r['load']:.1f} |"
        )
    rob = rows[1]
    lines += ["", f"robust suite: {','.join(rob['suite'])}", f"bound: {rob['bound']}", f"skipped: {rob['skipped']}"]
    for m, w, n, s in rob.get("candidates", []):
        lines.append(f"  candidate {m}: worst {w:,.2f}, {n} evaluations, {s:.1f} s")
    text = "\n".join(lines) + "\n"
    print(text)
    if a.out:
        Path(a.out).write_text(text)


if __name__ == "__main__":
    main()
