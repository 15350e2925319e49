"""What the integrity of a suite costs (association risk, integrity risk, protection levels) against
its accuracy, measured side by side in one process.

    python bench/integrity.py [--kitti-root ../shared/kitti] [--seq 00] [--suite IDS ...] [--map-sigma 0.05]
                              [--repeat 1] [--reference-src DIR] [--rounds 1] [--require]

``--suite`` (repeatable): the suites measured, each in turn; by default :data:`SUITES`, a stereo
suite (``LRR-7,HD2K-4,HD2K-9,LSC-2``: fresh stereo landmarks, SLAM's bent pairs) and KITTI 00's
$110,000 greedy LiDAR suite (``docs/results/greedy00.json``).

On a KITTI route (1 Hz keyframes, real pole map), in the map model and in SLAM: the suite's
accuracy (the filter: one forward pass), then its integrity (``route_integrity``: one forward pass
whose ``use`` hook keeps what each keyframe's association risks need, then every keyframe's risks
at once), with the association part timed alone inside the same run. Prints the seconds of each
and the ratio to the accuracy (the target: ≤ 2×, i.e. the association part at most one forward
pass). ``--repeat N``: each timed N times, alternating, and the least of each kept (on a shared,
loaded machine one run's ratio moves by ±20 %).

``--reference-src DIR``: also the same measurement of another source tree (e.g. main's ``src``,
exported by ``git archive main src configs data | tar -x -C DIR``, then ``DIR/src``), in a child
process, alternating with this tree's for ``--rounds`` rounds: the rows ``reference`` and ``this
tree`` of each round, under the same load. Each ratio is of one process's own two timings.

``--require``: instead, the wall time of ``sensorsel require --seq NN --integrity`` with each of the
presets ``local-streets`` and ``freeway`` (the target: it ends, proved, within 2 minutes), and its
answer's line; with ``--reference-src``, the reference tree's run before this tree's, each round.
"""

from __future__ import annotations

import argparse
import math
import os
import subprocess
import sys
import time
from pathlib import Path

#: the default suites: stereo (the guide's), and KITTI 00's greedy LiDAR suite
SUITES = ("LRR-7,HD2K-4,HD2K-9,LSC-2", "LRL-roof,MRL-roof,LRR-12,LRR-10,LRR-6,LRR-8")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--kitti-root",
        default=os.environ.get("SENSORSEL_KITTI_ROOT", str(Path(__file__).resolve().parents[2] / "shared" / "kitti")),
    )
    ap.add_argument("--seq", default="00")
    ap.add_argument("--suite", action="append", default=None, help="a suite's ids (repeatable; default: SUITES)")
    ap.add_argument("--map-sigma", type=float, default=0.05)
    ap.add_argument("--repeat", type=int, default=1, help="time each N times, keep the least (default 1)")
    ap.add_argument("--reference-src", default=None, help="another tree's src folder, measured alternately")
    ap.add_argument("--rounds", type=int, default=1, help="with --reference-src: rounds of both (default 1)")
    ap.add_argument("--require", action="store_true", help="time require --integrity with each preset instead")
    args = ap.parse_args()
    args.suite = args.suite or list(SUITES)
    if args.require:
        require(args)
        return
    if args.reference_src is None:
        measure(args)
        return
    child = [sys.executable, __file__, "--kitti-root", args.kitti_root, "--seq", args.seq]
    child += [x for suite in args.suite for x in ("--suite", suite)]
    child += ["--map-sigma", str(args.map_sigma), "--repeat", str(args.repeat)]
    trees = (
        ("reference", str(Path(args.reference_src).resolve())),
        ("this tree", str(Path(__file__).parents[1] / "src")),
    )
    for r in range(max(1, args.rounds)):
        for label, src in trees:
            env = dict(os.environ, PYTHONPATH=src)
            out = subprocess.run(child, env=env, capture_output=True, text=True, check=True).stdout
            for line in out.splitlines():
                if "integrity / accuracy" in line:
                    print(f"round {r + 1} {label:9s} {line}", flush=True)


def require(args: argparse.Namespace) -> None:
    """The wall time of ``require --integrity`` per preset, per tree (module docstring)."""
    trees = [("this tree", str(Path(__file__).resolve().parents[1] / "src"))]
    if args.reference_src is not None:
        trees.insert(0, ("reference", str(Path(args.reference_src).resolve())))
    cli = [sys.executable, "-c", "from sensorsel.cli import main; main()", "require"]
    cli += ["--kitti-root", args.kitti_root, "--seq", args.seq, "--integrity"]
    for r in range(max(1, args.rounds)):
        for preset in ("local-streets", "freeway"):
            for label, src in trees:
                t = time.perf_counter()
                run = subprocess.run(
                    [*cli, "--preset", preset], env=dict(os.environ, PYTHONPATH=src), capture_output=True, text=True
                )
                seconds = time.perf_counter() - t
                suite = next((x for x in run.stdout.splitlines() if x.startswith("suite")), "")
                error = run.stderr.strip().splitlines()[-1:] if run.returncode else []
                answer = (suite or " ".join(error))[:110]
                print(
                    f"round {r + 1} {label:9s} require --integrity {args.seq} {preset}: {seconds:6.1f} s  {answer}",
                    flush=True,
                )


def measure(args: argparse.Namespace) -> None:
    from sensorsel import ScenarioSpec, load_problem

    problem = load_problem(ScenarioSpec(seq=args.seq, kitti_root=args.kitti_root))
    print(problem)
    for ids in args.suite:  # the first suite's rows carry the process's first calls (imports, caches)
        _measure_suite(args, problem, ids)


def _measure_suite(args: argparse.Namespace, problem, ids: str) -> None:
    """One suite's rows, both models, side by side in one process."""
    from sensorsel.information.evaluators import FastEvaluator
    from sensorsel.information.evaluators.accuracy import route_accuracy
    from sensorsel.information.integrity import IntegritySpec, route_integrity

    suite = problem.library.resolve_suite(ids)
    for map_sigma in (args.map_sigma, None):
        model = f"{ids} map {map_sigma} m" if map_sigma is not None else f"{ids} SLAM"
        ev = FastEvaluator(problem)
        t_acc, t_itg, t_assoc = math.inf, math.inf, math.inf
        for _ in range(max(1, args.repeat)):
            t = time.perf_counter()
            acc = route_accuracy(ev, suite, map_sigma_m=map_sigma)  # the filter (as the car drives)
            t_acc = min(t_acc, time.perf_counter() - t)
            itg, t_run, spent = _integrity(problem, suite, map_sigma, IntegritySpec(), route_integrity)
            t_itg, t_assoc = min(t_itg, t_run), min(t_assoc, spent)
        print(f"{model}: accuracy {t_acc:6.2f} s  {acc.line()[:60]}...")
        print(f"{model}: integrity {t_itg:6.2f} s  {itg.line()}")
        print(
            f"{model}: integrity / accuracy {t_itg / t_acc:.2f}x (association part alone {t_assoc:.2f} s, "
            f"{t_assoc / t_acc:.2f}x)",
            flush=True,
        )


def _integrity(problem, suite, map_sigma, spec, route_integrity):
    """One timed integrity run: (result, its seconds, the seconds of the association part alone: the
    model's methods the forward pass's hook calls, ``snapshot`` and ``risks_of`` where the model has
    them, else ``risks`` one keyframe at a time as before)."""
    from sensorsel.information.integrity import AssociationModel

    names = ("snapshot", "risks_of") if hasattr(AssociationModel, "risks_of") else ("risks",)
    originals = {n: getattr(AssociationModel, n) for n in names}
    spent = [0.0]

    def timed(original):
        def method(self, *a, **kw):  # the association part alone, inside the same pass
            t0 = time.perf_counter()
            out = original(self, *a, **kw)
            spent[0] += time.perf_counter() - t0
            return out

        return method

    for n, f in originals.items():
        setattr(AssociationModel, n, timed(f))
    try:
        t = time.perf_counter()
        itg = route_integrity(problem, suite, spec, map_sigma_m=map_sigma)
        t_itg = time.perf_counter() - t
    finally:
        for n, f in originals.items():
            setattr(AssociationModel, n, f)
    return itg, t_itg, spent[0]


if __name__ == "__main__":
    main()
