"""This tree's greedy (or pareto, resilient) against an earlier commit's, side by side in one run
(alternating, same machine).

    python bench/versus.py --base 60d5466 --kitti-root ../shared/kitti [--seq 03 00] [--repeats 3] [--command greedy]

``--command pareto`` times ``sensorsel pareto`` (default budgets and rules) and ``--command
resilient`` times ``sensorsel resilient --budget 110000 --failures 1`` (whole route and 10 s
periods) the same way; both write to a temporary folder. ``--command robust`` times ``sensorsel robust
--budget 110000 --failures 1`` (its answer: the suite, the winning method and the worst case).

The earlier commit is checked out with ``git worktree`` into a temporary folder (removed afterwards)
and run with the same Python environment on its own ``src/``. Both run the CLI,
``sensorsel greedy --seq NN --budget 110000 --no-certificate --json`` on the synthetic landmark map
(the one both versions have: ``--landmarks synthetic`` where the CLI knows it), one process per run,
alternating base and head so that machine load hits both alike. Reported: the selection time the
result records (``seconds``), the wall time of the whole command, and that both pick the same suite
with the same score. Medians over ``--repeats``.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


#: the CLI of the tree on PYTHONPATH (every version has sensorsel.cli.main; not all have a __main__)
CLI = [sys.executable, "-c", "import sys; from sensorsel.cli import main; sys.argv[0] = 'sensorsel'; main()"]


def _run(src: Path, args: list[str], env: dict[str, str]) -> tuple[float, dict]:
    cmd = [*CLI, *args]
    t = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True, env={**env, "PYTHONPATH": str(src)}, cwd=src.parent)
    wall = time.perf_counter() - t
    if p.returncode != 0:
        raise SystemExit(f"{src}: {' '.join(args)} failed:\n{p.stderr}")
    return wall, json.loads(p.stdout)


def _args(src: Path, seq: str, root: str, env: dict[str, str], command: str = "greedy", out: str = "") -> list[str]:
    help_text = subprocess.run(
        [*CLI, command, "--help"], capture_output=True, text=True, env={**env, "PYTHONPATH": str(src)}, cwd=src.parent
    ).stdout
    if "Usage:" not in help_text:
        raise SystemExit(f"{src}: could not read `sensorsel {command} --help`")
    extra = ["--landmarks", "synthetic"] if "real|synthetic" in help_text else []  # older CLIs generate by default
    common = ["--seq", seq, "--kitti-root", root, "--json", *extra]
    # the folder and plot format options under their names of the revision measured
    folder = "--output-dir" if "--output-dir" in help_text else "-o"
    fmt = "--plot-format" if "--plot-format" in help_text else "--format"
    if command == "pareto":
        return ["pareto", *common, folder, out, fmt, "svg", "-q"]
    if command == "resilient":
        return ["resilient", *common, "--budget", "110000", "--failures", "1", folder, out, fmt, "svg", "-q"]
    if command == "robust":
        return ["robust", *common, "--budget", "110000", "--failures", "1", "-q"]
    return ["greedy", *common, "--budget", "110000", "--no-certificate"]


def _answer(command: str, res: dict) -> tuple[object, float]:
    """What must be the same in both trees' results, and a score to compare."""
    if command == "pareto":
        return [(a["suite"], a["score"]) for a in res["architectures"]], float(res["best_score"])
    if command == "robust":
        return (res["suite"], res["method"]), float(res["worst_score"])
    if command == "resilient":
        return (
            res["suite"],
            [(p["worst"]["suite"], p["worst"]["score"]) for p in res["per_period"]["periods"]],
        ), float(res["comparison"]["resilient"]["score"])
    return res["suite"], float(res["score"])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--base", required=True, help="the earlier commit (any git revision)")
    ap.add_argument(
        "--kitti-root", default=os.environ.get("SENSORSEL_KITTI_ROOT", str(REPO.parent / "shared" / "kitti"))
    )
    ap.add_argument("--seq", nargs="+", default=["03", "00"])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--command", choices=["greedy", "pareto", "resilient", "robust"], default="greedy")
    a = ap.parse_args()
    env = dict(os.environ)
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(tmp) / "base"
        subprocess.run(["git", "-C", str(REPO), "worktree", "add", "--detach", "-q", str(base), a.base], check=True)
        try:
            trees = {"base": base / "src", "head": REPO / "src"}
            print(
                f"sensorsel {a.command}: base {a.base} against this tree; {a.repeats} alternating runs each; "
                "synthetic landmarks; "
                f"{os.cpu_count()} cores"
            )
            print(f"{'seq':<4} {'tree':<5} {'select s (median)':>17} {'wall s (median)':>15}  runs (select s)")
            for seq in a.seq:
                args = {
                    k: _args(src, seq, a.kitti_root, env, a.command, str(Path(tmp) / f"out-{k}"))
                    for k, src in trees.items()
                }
                sel: dict[str, list[float]] = {"base": [], "head": []}
                wall: dict[str, list[float]] = {"base": [], "head": []}
                out: dict[str, dict] = {}
                for _ in range(a.repeats):
                    for k, src in trees.items():
                        w, res = _run(src, args[k], env)
                        sel[k].append(float(res["seconds"]))
                        wall[k].append(w)
                        out[k] = res
                for k in trees:
                    print(
                        f"{seq:<4} {k:<5} {statistics.median(sel[k]):>17.2f} {statistics.median(wall[k]):>15.2f}  "
                        + ", ".join(f"{v:.2f}" for v in sel[k])
                    )
                (ans_b, score_b), (ans_h, score_h) = _answer(a.command, out["base"]), _answer(a.command, out["head"])
                same = ans_b == ans_h
                rel = abs(score_b - score_h) / max(1.0, abs(score_b))
                ratio = statistics.median(sel["head"]) / statistics.median(sel["base"])
                print(
                    f"{seq}: head/base selection time {ratio:.2f} (below 1: faster); same suite: {same}; "
                    f"relative score difference {rel:.1e}"
                )
        finally:
            subprocess.run(["git", "-C", str(REPO), "worktree", "remove", "--force", str(base)], check=False)


if __name__ == "__main__":
    main()
