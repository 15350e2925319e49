"""Fewer evaluations, same answer: the lazy greedy with and without the gain
bounds of :mod:`sensorsel.information.evaluators.fast.bound`, side by side, in one run.

    python bench/bound.py [--kitti-root DIR] [--jobs N] [--budget USD] [--repeat R]
                          [--landmarks real|synthetic] [ROUTE ...]

A ROUTE is ``suburb`` (the bundled fixture) or ``SEQ@HZ`` (KITTI, real pole maps), default
``suburb 03@1 00@1``; ``--landmarks synthetic`` generates the KITTI routes' maps instead. For each
route one problem and, per run, a fresh fast evaluator (so no run
reuses another's cached state); ``off`` is the lazy greedy without any bound (``bound_from=0``:
neither the Fischer bounds on the scores nor the covariance bounds on the gains), ``on``
asks for both as shipped (:data:`sensorsel.designs.selection.greedy.BOUND_FROM`; the engine declines
where they are predicted not to pay, :data:`sensorsel.information.evaluators.fast.evaluator.BOUND_SPARE`),
``always`` (with ``--always``) computes them wherever asked (``bound_spare=0``). Lazy greedy, uniform
rule, $110,000, no certificate. The two alternate (off, on, on, off, ...) over ``--repeat`` rounds;
printed: suites scored, base covariances computed, selection seconds (min over rounds), the
speed-up and whether every step's pick and score is bit-identical. The load average is printed
before and after: the machine is shared, compare ratios.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("routes", nargs="*", default=["suburb", "03@1", "00@1"])
    ap.add_argument(
        "--kitti-root", default=os.environ.get("SENSORSEL_KITTI_ROOT", str(REPO.parent / "shared" / "kitti"))
    )
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--budget", type=float, default=110_000.0)
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument(
        "--landmarks",
        default=None,
        help="landmarks of the KITTI routes: real (default: the pole map) "
        "or synthetic (generated, seed 0; KITTI 00 at 1 Hz: 1,614 landmarks instead of 598)",
    )
    ap.add_argument(
        "--always",
        action="store_true",
        help="also run 'always': bounds at every step where more "
        "than BOUND_FROM candidates would be re-scored, whatever their predicted cost (bound_spare=0)",
    )
    args = ap.parse_args()
    sys.path.insert(0, str(REPO / "src"))
    from sensorsel.designs.selection.greedy import BOUND_FROM, Selector
    from sensorsel.designs.selection.registry import RULES
    from sensorsel.information.evaluators.fast import FastEvaluator
    from sensorsel.information.evaluators.fast.evaluator import BOUND_SPARE
    from sensorsel.model.problem import load_problem
    from sensorsel.model.scenario import ScenarioSpec

    print(
        f"load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())}; jobs {args.jobs}; "
        f"BOUND_FROM {BOUND_FROM}, BOUND_SPARE {BOUND_SPARE}"
    )
    modes = ("off", "on", "always") if args.always else ("off", "on")
    header = ["route", "keyframes", "bound", "evals", "covariances", "select s (min)", "all s"]
    rows, notes = [], []
    for route in args.routes:
        if route == "suburb":
            spec = ScenarioSpec()
        else:
            seq, hz = route.split("@")
            spec = ScenarioSpec(
                seq=seq, kitti_root=args.kitti_root, keyframe_rate_hz=float(hz), landmarks=args.landmarks
            )
        problem = load_problem(spec)
        got: dict[str, list] = {m: [] for m in modes}
        for r in range(args.repeat):
            for mode in modes if r % 2 == 0 else modes[::-1]:
                ev = FastEvaluator(problem, jobs=args.jobs, bound_spare=0.0 if mode == "always" else BOUND_SPARE)
                sel = Selector(ev, RULES["uniform"], lazy=True, bound_from=0 if mode == "off" else BOUND_FROM)
                t0 = time.perf_counter()
                res = sel.select(args.budget)
                got[mode].append((time.perf_counter() - t0, res, ev.n_bounds))
        k = problem.scenario.n_poses
        for mode in modes:
            times = [t for t, _, _ in got[mode]]
            _, res, nb = got[mode][0]
            rows.append(
                [route, k, mode, res.n_evaluations, nb, f"{min(times):.2f}", " ".join(f"{t:.2f}" for t in times)]
            )
        a, b = got["off"][0][1], got["on"][0][1]
        same = [(s.pick, s.score) for s in a.steps] == [(s.pick, s.score) for s in b.steps] and a.score == b.score
        t_off, t_on = min(t for t, _, _ in got["off"]), min(t for t, _, _ in got["on"])
        if args.always:
            c = got["always"][0][1]
            t_al = min(t for t, _, _ in got["always"])
            same_always = [(s.pick, s.score) for s in c.steps] == [(s.pick, s.score) for s in a.steps]
            notes.append(
                f"{route} always: evaluations {c.n_evaluations}, selection {t_al:.2f} s ({t_off / t_al:.2f}x), "
                f"bit-identical: {'yes' if same_always else 'NO'}"
            )
        notes.append(
            f"{route}: evaluations {a.n_evaluations} -> {b.n_evaluations} "
            f"({b.n_evaluations / a.n_evaluations:.2f}x), selection {t_off:.2f} s -> {t_on:.2f} s "
            f"({t_off / t_on:.2f}x faster), picks and scores bit-identical: {'yes' if same else 'NO'} "
            f"({len(a.steps)} picks, f = {a.score:.4f})"
        )
    print(table(rows, header))
    print()
    print("\n".join(notes))
    print(f"load average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


def table(rows: list[list], header: list[str]) -> str:
    widths = [max(len(str(r[i])) for r in [header] + rows) for i in range(len(header))]

    def line(r: list) -> str:
        return "  ".join(str(v).rjust(w) if i else str(v).ljust(w) for i, (v, w) in enumerate(zip(r, widths)))

    return "\n".join([line(header), "  ".join("-" * w for w in widths)] + [line(r) for r in rows])


if __name__ == "__main__":
    main()
