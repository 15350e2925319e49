"""The whole ``sensorsel greedy`` command, this checkout against an earlier revision, side by side
(the target: KITTI 00 at 1 Hz, greedy at $110,000 without the certificate).

    python bench/command.py [--before REV] [--runs N] [--kitti-root DIR] [--seq 00] [--rate 1]
                            [--budget 110000] [--maps real synthetic]

``--before`` (default ``e2637e6^``, the engine before any issue-16 change) is extracted with
``git archive`` into a temporary directory and run from there (``PYTHONPATH``), this checkout from
``src/``; both in fresh processes of this interpreter, alternating (before, after, after, before,
...) over ``--runs`` rounds. Printed per map: wall seconds of every run of the whole command
(interpreter start, imports, loading, the engine's setup, selection, output), the evaluations,
and whether both answered the same suite with the same score (to 1e-9 relative; the bits may
differ across revisions) — and the floor the issue names: the run's evaluations times one dense
Cholesky of the 3K × 3K pose matrix on one thread, measured here in the same run (scipy's dpotrf,
min of 5). The load average is printed before and after: the machine may be shared, compare ratios.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tarfile
import tempfile
import time
from io import BytesIO
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def extract(rev: str, into: Path) -> Path:
    """The tree of ``rev`` under ``into`` (``git archive``); returns its ``src`` directory."""
    blob = subprocess.run(
        ["git", "-C", str(REPO), "archive", "--format=tar", rev], check=True, capture_output=True
    ).stdout
    with tarfile.open(fileobj=BytesIO(blob)) as tar:
        tar.extractall(into, filter="data")
    return into / "src"


def run(src: Path, args: list[str], kitti_root: str) -> tuple[float, dict]:
    """Wall seconds of one whole command run from ``src``, and its --json answer."""
    env = dict(os.environ, PYTHONPATH=str(src), SENSORSEL_KITTI_ROOT=kitti_root)
    t0 = time.perf_counter()
    out = subprocess.run(
        [sys.executable, "-c", "from sensorsel.cli import main; main()", *args],
        env=env,
        capture_output=True,
        text=True,
        cwd=src.parent,
    )
    wall = time.perf_counter() - t0
    if out.returncode != 0:
        raise SystemExit(f"{src}: exit {out.returncode}:\n{out.stderr}")
    return wall, json.loads(out.stdout)


def cholesky_ms(n: int) -> float:
    """One dense Cholesky (scipy's dpotrf, one BLAS thread) of an n × n SPD matrix [ms], min of 5."""
    import numpy as np
    from scipy.linalg import lapack
    from threadpoolctl import threadpool_limits

    x = np.random.default_rng(0).standard_normal((n, n))
    a = x @ x.T + n * np.eye(n)
    best = float("inf")
    with threadpool_limits(1):
        for _ in range(5):
            b = np.asfortranarray(a)
            t0 = time.perf_counter()
            lapack.dpotrf(b, lower=0, overwrite_a=1, clean=0)
            best = min(best, time.perf_counter() - t0)
    return 1e3 * best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--before",
        default="e2637e6^",
        help="the revision to compare with (default: the last without the frontal elimination)",
    )
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument(
        "--kitti-root", default=os.environ.get("SENSORSEL_KITTI_ROOT", str(REPO.parent / "shared" / "kitti"))
    )
    ap.add_argument("--seq", default="00")
    ap.add_argument("--rate", default="1")
    ap.add_argument("--budget", default="110000")
    ap.add_argument("--maps", nargs="+", default=["real", "synthetic"])
    a = ap.parse_args()
    print(f"load average before: {os.getloadavg()[0]:.2f}; python {sys.version.split()[0]}, {os.cpu_count()} cores")
    with tempfile.TemporaryDirectory(prefix="sensorsel-before-") as tmp:
        before = extract(a.before, Path(tmp))
        after = REPO / "src"
        for m in a.maps:
            args = [
                "greedy",
                "--seq",
                a.seq,
                "--rate",
                a.rate,
                "--landmarks",
                m,
                "--budget",
                a.budget,
                "--no-certificate",
                "-q",
                "--json",
            ]
            walls: dict[str, list[float]] = {"before": [], "after": []}
            answers: dict[str, dict] = {}
            for r in range(a.runs):
                for name in ("before", "after") if r % 2 == 0 else ("after", "before"):
                    wall, ans = run(before if name == "before" else after, args, a.kitti_root)
                    walls[name].append(wall)
                    answers[name] = ans
            b, n = answers["before"], answers["after"]
            same = b["suite"] == n["suite"] and abs(b["score"] - n["score"]) <= 1e-9 * max(1.0, abs(b["score"]))
            k = n["problem"]["n_poses"]
            chol = cholesky_ms(3 * k)
            lo_b, lo_n = min(walls["before"]), min(walls["after"])
            print(
                f"\n{a.seq} at {a.rate} Hz, {m} map ({n['problem']['n_landmarks']} landmarks, {k} keyframes), "
                f"greedy ${float(a.budget):,.0f}, no certificate"
            )
            print(
                f"  before ({a.before}): wall s {' '.join(f'{w:.2f}' for w in walls['before'])}  evaluations "
                f"{b['n_evaluations']}"
            )
            print(
                f"  after  (this tree): wall s {' '.join(f'{w:.2f}' for w in walls['after'])}  evaluations "
                f"{n['n_evaluations']}"
            )
            print(
                f"  min {lo_b:.2f} s -> {lo_n:.2f} s ({lo_b / lo_n:.2f}x); same suite and score: "
                f"{'yes' if same else 'NO'}"
            )
            print(
                f"  floor: {n['n_evaluations']} evaluations x {chol:.1f} ms (one dense Cholesky of {3 * k}², one "
                "thread, "
                f"here) = {n['n_evaluations'] * chol / 1e3:.2f} s; selection took {n['seconds']:.2f} s of the command"
            )
    print(f"\nload average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
