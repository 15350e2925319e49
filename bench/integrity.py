"""What the integrity of a suite costs (association risk, integrity risk, protection levels) against
its accuracy, measured side by side in one process.

    python bench/integrity.py [--kitti-root ../shared/kitti] [--seq 00] [--suite IDS] [--map-sigma 0.05]

On a KITTI route (1 Hz keyframes, real pole map): the suite's accuracy (its pose marginals by the
fast engine, the smoother), then its integrity (``route_integrity``: one forward pass whose ``use``
hook computes each keyframe's association risks), with the association part timed alone inside the
same pass. Prints the seconds of each and the ratios to the accuracy. The forward pass this build
carries is a dense, exact stand-in (it inverts the (3 + 2n)² information of the landmarks seen so
far at every keyframe): the pass dominates the integrity's time, so the ratio the requirement is
about (≤ 2× the accuracy) is judged on the association part; the whole is printed too.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kitti-root", default=os.environ.get("SENSORSEL_KITTI_ROOT",
                                                           str(Path(__file__).resolve().parents[2] / "shared" / "kitti")))
    ap.add_argument("--seq", default="00")
    ap.add_argument("--suite", default="LRR-7,HD2K-4,HD2K-9,LSC-2")
    ap.add_argument("--map-sigma", type=float, default=0.05)
    args = ap.parse_args()

    from sensorsel import ScenarioSpec, load_problem
    from sensorsel.information.evaluators import FastEvaluator
    from sensorsel.information.evaluators.accuracy import route_accuracy
    from sensorsel.information.integrity import AssociationModel, IntegritySpec, route_integrity
    from sensorsel.information.integrity import association as association_module

    problem = load_problem(ScenarioSpec(seq=args.seq, kitti_root=args.kitti_root))
    suite = problem.library.resolve_suite(args.suite)
    print(f"{problem}; suite {args.suite}; map sigma {args.map_sigma} m")
    ev = FastEvaluator(problem)
    t = time.perf_counter()
    acc = route_accuracy(ev, suite, map_sigma_m=args.map_sigma)
    t_acc = time.perf_counter() - t
    print(f"accuracy   {t_acc:8.2f} s  {acc.line()}")

    spent = [0.0]
    original = AssociationModel.risks

    def timed(self, prediction, meas):  # the association part alone, inside the same pass
        t0 = time.perf_counter()
        out = original(self, prediction, meas)
        spent[0] += time.perf_counter() - t0
        return out

    AssociationModel.risks = timed  # type: ignore[method-assign]
    try:
        t = time.perf_counter()
        itg = route_integrity(problem, suite, IntegritySpec(), map_sigma_m=args.map_sigma)
        t_itg = time.perf_counter() - t
    finally:
        AssociationModel.risks = original  # type: ignore[method-assign]
    assert association_module.AssociationModel.risks is original
    print(f"integrity  {t_itg:8.2f} s  {itg.line()}")
    print(f"association part alone {spent[0]:.2f} s: {spent[0] / t_acc:.2f}x the accuracy; "
          f"the whole integrity (with the stand-in forward pass) {t_itg / t_acc:.2f}x")


if __name__ == "__main__":
    main()
