"""Domain greedy on the seven KITTI routes (real pole maps) against each route's own greedy, one run.

    python bench/domain.py --kitti-root ../shared/kitti [--budget 110000] [--domain configs/domain_kitti.yaml]

Times, in one process and one run: loading each route (poses, pole map, what each sensor sees), building
its evaluator (the fast engine's one-off linearization and the whole library's score, the route's
normaliser), the domain greedy (every candidate scored on every route per step), and beside it each
route's own greedy at the same budget. Peak RSS of the process (ru_maxrss). Target: the
domain greedy at $110,000 in at most 60 s wall on the 2-core machine.
"""

from __future__ import annotations

import argparse
import os
import platform
import resource
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "src"))

from sensorsel.designs.selection import greedy  # noqa: E402
from sensorsel.information.evaluators import DomainEvaluator, make_evaluator  # noqa: E402
from sensorsel.model.domain import load_domain_file, load_domain_scenarios  # noqa: E402
from sensorsel.model.library import load_library  # noqa: E402
from sensorsel.model.problem import Domain, DomainRoute, build_problem  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--kitti-root", default=os.environ.get("SENSORSEL_KITTI_ROOT", str(REPO.parent / "shared" / "kitti"))
    )
    ap.add_argument("--domain", default=str(REPO / "configs" / "domain_kitti.yaml"))
    ap.add_argument("--budget", type=float, default=110_000.0)
    ap.add_argument("--rule", default="uniform")
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    args = ap.parse_args()
    os.environ["SENSORSEL_KITTI_ROOT"] = args.kitti_root

    t0 = time.perf_counter()
    spec = load_domain_file(args.domain)
    lib = load_library(spec.library)
    routes, load_s = [], {}
    for d in load_domain_scenarios(spec):
        t = time.perf_counter()
        routes.append(DomainRoute(d.name, build_problem(lib, d.scenario, spec=d.spec), d.weight, d.unit))
        load_s[d.name] = time.perf_counter() - t
    domain = Domain(tuple(routes), spec.source)
    t_load = time.perf_counter() - t0

    t = time.perf_counter()
    ev = DomainEvaluator(domain, jobs=args.jobs)
    t_setup = time.perf_counter() - t
    t = time.perf_counter()
    res = greedy(ev, args.budget, args.rule)
    t_select = time.perf_counter() - t

    own = {}
    for route, rev in zip(domain.routes, ev.routes):
        n0 = rev.n_evaluations
        t = time.perf_counter()
        g = greedy(make_evaluator(route.problem, jobs=args.jobs), args.budget, args.rule)
        own[route.name] = (time.perf_counter() - t, g, rev.n_evaluations - n0)
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024

    print(
        f"machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}; "
        f"budget ${args.budget:,.0f}, rule {args.rule}, fast engine jobs={args.jobs}"
    )
    print(
        f"{'route':<10} {'weight':>7} {'keyframes':>9} {'poles':>6} {'meas':>8} {'load s':>7} {'own greedy s':>12} "
        f"{'own evals':>9}  own suite"
    )
    for route, w in zip(domain.routes, ev.weights):
        p = route.problem
        s, g, _ = own[route.name]
        n_meas = sum(len(o) for o in p.observations)
        print(
            f"{route.name:<10} {w:>7.3f} {p.scenario.n_poses:>9} {p.scenario.n_landmarks:>6} {n_meas:>8} "
            f"{load_s[route.name]:>7.2f} {s:>12.2f} {g.n_evaluations:>9}  {','.join(g.suite)}"
        )
    print()
    print(
        f"domain: load {t_load:.2f} s, evaluators + normalisers {t_setup:.2f} s, greedy {t_select:.2f} s "
        f"({res.n_evaluations} domain evaluations = {res.n_evaluations * len(routes)} route evaluations); "
        f"wall {t_load + t_setup + t_select:.2f} s; peak RSS {peak_mb:,.0f} MB"
    )
    print(f"sum of the seven routes' own greedy runs: {sum(v[0] for v in own.values()):.2f} s")
    print(f"domain suite (${res.cost_usd:,.0f}, F = {res.score:.4f}): {','.join(res.suite)}")
    verdict = "met" if t_load + t_setup + t_select <= 60.0 else "NOT met"
    print(f"target: domain greedy (load + setup + selection) <= 60 s: {verdict}")


if __name__ == "__main__":
    main()
