"""Speed of the fast engine against the paper-style reference, measured side by side.

    python bench/speed.py --kitti-root ../shared/kitti [--quick] [--jobs N] [--budget USD]

For KITTI 03 and 00 (03 only with --quick), in one run: the paper-style plain greedy (every
candidate re-scored at every step) with the reference engine (GTSAM graph built, linearized and
eliminated per suite), and the lazy greedy with the fast engine, both at the same budget (default
$110,000), 1 Hz keyframes and the default landmark model. Printed per run: suites scored, setup
time (the fast engine's one-off GTSAM linearization of every sensor; building the reference's
noise models), selection time, wall = setup + selection, time per evaluation, peak memory, the
chosen suite; then the speed-up and whether picks and scores agree (1e-9 relative).

Each run is a fresh child process, so that its peak memory is its own: peak RSS from
``resource.getrusage(RUSAGE_SELF).ru_maxrss`` at its end, which includes the interpreter, numpy,
gtsam and the loaded scenario. Loading the scenario (common to both) is timed apart, not in wall.
Timings depend on the machine's load; the ratio is what the run measured, nothing else.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def worker(seq: str, kitti_root: str, engine: str, budget: float, jobs: int) -> dict:
    """One greedy run in this process; returns its measurements."""
    sys.path.insert(0, str(REPO / "src"))
    from sensorsel.designs.selection import greedy
    from sensorsel.information.evaluators import make_evaluator
    from sensorsel.model.problem import load_problem
    from sensorsel.model.scenario import ScenarioSpec

    t0 = time.perf_counter()
    problem = load_problem(ScenarioSpec(seq=seq, kitti_root=kitti_root))
    t1 = time.perf_counter()
    ev = make_evaluator(problem, engine, jobs=jobs)
    t2 = time.perf_counter()
    res = greedy(ev, budget, "uniform", lazy=(engine == "fast"))
    t3 = time.perf_counter()
    return {
        "seq": seq,
        "engine": engine,
        "lazy": res.lazy,
        "jobs": ev.jobs,
        "n_poses": problem.scenario.n_poses,
        "n_landmarks": problem.scenario.n_landmarks,
        "n_measurements": int(sum(len(o) for o in problem.observations)),
        "load_s": t1 - t0,
        "setup_s": t2 - t1,
        "select_s": t3 - t2,
        "n_evaluations": res.n_evaluations,
        "suite": list(res.suite),
        "score": res.score,
        "cost_usd": res.cost_usd,
        "step_scores": [s.score for s in res.steps],
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
    }


def run_child(seq: str, kitti_root: str, engine: str, budget: float, jobs: int) -> dict:
    cmd = [
        sys.executable,
        __file__,
        "--worker",
        seq,
        engine,
        "--kitti-root",
        kitti_root,
        "--budget",
        str(budget),
        "--jobs",
        str(jobs),
    ]
    out = subprocess.run(cmd, check=True, capture_output=True, text=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def table(rows: list[list[str]], header: list[str]) -> str:
    widths = [max(len(str(r[i])) for r in [header] + rows) for i in range(len(header))]

    def line(r: list) -> str:
        return "  ".join(str(v).rjust(w) if i else str(v).ljust(w) for i, (v, w) in enumerate(zip(r, widths)))

    return "\n".join([line(header), "  ".join("-" * w for w in widths)] + [line(r) for r in rows])


def agree(a: dict, b: dict) -> tuple[bool, bool, float]:
    """(same picks in the same order, same step scores to 1e-9 relative, largest relative difference)."""
    picks = a["suite"] == b["suite"]
    n = min(len(a["step_scores"]), len(b["step_scores"]))
    rel = max([abs(x - y) / max(1.0, abs(y)) for x, y in zip(a["step_scores"][:n], b["step_scores"][:n])] + [0.0])
    return picks, picks and rel <= 1e-9 and len(a["step_scores"]) == len(b["step_scores"]), rel


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument(
        "--kitti-root", default=os.environ.get("SENSORSEL_KITTI_ROOT", str(REPO.parent / "shared" / "kitti"))
    )
    ap.add_argument("--quick", action="store_true", help="KITTI 03 only")
    ap.add_argument(
        "--jobs", type=int, default=os.cpu_count() or 1, help="threads of the fast engine (default: all cores)"
    )
    ap.add_argument("--budget", type=float, default=110_000.0)
    ap.add_argument("--engines", default="reference,fast", help="comma-separated subset of reference,fast")
    ap.add_argument("--worker", nargs=2, metavar=("SEQ", "ENGINE"), help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        print(json.dumps(worker(args.worker[0], args.kitti_root, args.worker[1], args.budget, args.jobs)))
        return

    seqs = ["03"] if args.quick else ["03", "00"]
    engines = [e for e in ("reference", "fast") if e in args.engines.split(",")]
    print(
        f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, Python "
        f"{platform.python_version()}; "
        f"budget ${args.budget:,.0f}, fast engine jobs={args.jobs}",
        flush=True,
    )
    results: dict[tuple[str, str], dict] = {}
    for seq in seqs:
        for engine in reversed(engines):  # fast first: its numbers are ready in seconds
            print(f"... {seq} {engine}", file=sys.stderr, flush=True)
            results[seq, engine] = run_child(seq, args.kitti_root, engine, args.budget, args.jobs)

    rows = []
    for (seq, engine), r in results.items():
        wall = r["setup_s"] + r["select_s"]
        rows.append(
            [
                seq,
                engine,
                "lazy" if r["lazy"] else "plain",
                str(r["jobs"]) if engine == "fast" else "1",
                f"{r['n_poses']}/{r['n_landmarks']}/{r['n_measurements']}",
                r["n_evaluations"],
                f"{r['load_s']:.2f}",
                f"{r['setup_s']:.2f}",
                f"{r['select_s']:.2f}",
                f"{wall:.2f}",
                f"{1e3 * r['select_s'] / max(1, r['n_evaluations']):.1f}",
                f"{r['peak_rss_mb']:.0f}",
                f"{r['score']:.4f}",
            ]
        )
    print()
    print(
        table(
            rows,
            [
                "seq",
                "engine",
                "greedy",
                "jobs",
                "poses/lm/meas",
                "evals",
                "load s",
                "setup s",
                "select s",
                "wall s",
                "ms/eval",
                "peak MB",
                "score f [nats]",
            ],
        )
    )
    print("\nwall = setup + selection (scenario loading excluded, same for both); ms/eval = selection / evals;")
    print("peak MB = peak RSS of the run's own process (ru_maxrss).")
    for seq in seqs:
        if (seq, "reference") in results and (seq, "fast") in results:
            ref, fa = results[seq, "reference"], results[seq, "fast"]
            w_ref, w_fast = ref["setup_s"] + ref["select_s"], fa["setup_s"] + fa["select_s"]
            per_ref = ref["select_s"] / ref["n_evaluations"]
            per_fast = fa["select_s"] / fa["n_evaluations"]
            picks, scores, rel = agree(fa, ref)
            print(
                f"\n{seq}: speed-up {w_ref / w_fast:.1f}x in wall time ({w_ref:.1f} s -> {w_fast:.2f} s), "
                f"{per_ref / per_fast:.1f}x per evaluation ({1e3 * per_ref:.1f} -> {1e3 * per_fast:.2f} ms), "
                f"{ref['n_evaluations'] / fa['n_evaluations']:.1f}x fewer evaluations"
            )
            print(
                f"{seq}: picks agree: {'yes' if picks else 'NO'}; scores agree (1e-9 rel): {'yes' if scores else 'NO'} "
                f"(largest relative difference {rel:.1e})"
            )
            print(f"{seq}: suite {', '.join(fa['suite'])}  (${fa['cost_usd']:,.0f})")


if __name__ == "__main__":
    main()
