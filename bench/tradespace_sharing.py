"""What prefix sharing saves in the tradespace, measured side by side in one run.

    python bench/tradespace_sharing.py [--seq 03 --kitti-root ../shared/kitti] [--engine fast] [--jobs 1]

Runs the default tradespace (uniform, cost-benefit, marginal over 14 log-spaced budgets) twice on
the same problem, each with a fresh evaluator: every budget from the empty suite
(``share_prefix=False``), then smaller budgets resumed from the picks of larger-budget runs that
still fit (``share_prefix=True``). Prints suites scored, selection time, their ratios, and whether
the two tradespaces agree (same architectures, same front; scores to 1e-9 relative). Without --seq
it uses the bundled "suburb" fixture. Timings depend on the machine's load; the ratio is what this
run measured, nothing else.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "src"))

from sensorsel.designs.tradespace import tradespace  # noqa: E402
from sensorsel.information.evaluators import make_evaluator  # noqa: E402
from sensorsel.model.problem import load_problem  # noqa: E402
from sensorsel.model.scenario import ScenarioSpec  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seq", default=None, help="KITTI sequence (default: the suburb fixture)")
    ap.add_argument("--kitti-root", default=None)
    ap.add_argument("--engine", default=None, help="scoring engine (default: the fastest registered)")
    ap.add_argument("--jobs", type=int, default=1)
    args = ap.parse_args()

    spec = ScenarioSpec(seq=args.seq, kitti_root=args.kitti_root) if args.seq else ScenarioSpec()
    problem = load_problem(spec)
    out = {}
    for share in (False, True):
        ev = make_evaluator(problem, args.engine, jobs=args.jobs)
        t0 = time.perf_counter()
        res = tradespace(ev, share_prefix=share)
        out[share] = (res, time.perf_counter() - t0)
        print(
            f"share_prefix={share!s:5}  engine {res.engine}: {res.n_evaluations:6d} suites scored in "
            f"{out[share][1]:8.2f} s; "
            f"{len(res.architectures)} architectures, {len(res.front)} on the front; "
            f"{sum(r.shared_steps for r in res.runs)} of {sum(r.n_steps for r in res.runs)} picks taken from "
            "larger runs"
        )
    (a, ta), (b, tb) = out[False], out[True]
    same = (
        [x.suite for x in a.architectures] == [x.suite for x in b.architectures]
        and [x.on_front for x in a.architectures] == [x.on_front for x in b.architectures]
        and all(abs(x.score - y.score) <= 1e-9 * abs(y.score) for x, y in zip(a.architectures, b.architectures))
    )
    print(
        f"scenario {problem.scenario.name}: sharing scores {a.n_evaluations / b.n_evaluations:.2f}x fewer suites, "
        f"{ta / tb:.2f}x faster; same tradespace: {same}"
    )


if __name__ == "__main__":
    main()
