"""The numbers of docs/guide-conditions.md, computed in one run (Markdown on stdout).

    python bench/conditions_guide.py --kitti-root ../shared/kitti [--budget 110000] > /tmp/guide-numbers.md

1. The seven KITTI routes at the budget: the domain suite for clear days only
   (configs/domain_kitti.yaml) and for the city's mix (configs/domain_kitti_conditions.yaml), side
   by side, and what each condition costs each suite (its members' weighted share of their best).
2. Which sensors gain value: each single sensor's score summed over the seven routes in each
   condition, as a share of its clear score; and the suite bought for each condition alone.
3. The worst condition of the city-mix design.
4. Dense fog on KITTI 00 with one failure: the robust design against greedy (exact worst cases).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "src"))

import numpy as np  # noqa: E402

from sensorsel.api import (  # noqa: E402
    by_condition,
    design_domain,
    run_robust,
)
from sensorsel.designs.selection import greedy  # noqa: E402
from sensorsel.information.evaluators import DomainEvaluator, make_evaluator  # noqa: E402
from sensorsel.model.conditions import parse_condition  # noqa: E402
from sensorsel.model.problem import Domain, load_domain, load_problem, with_condition  # noqa: E402
from sensorsel.model.scenario import ScenarioSpec  # noqa: E402


def compact(suite: tuple[str, ...]) -> str:
    by: dict[str, list[str]] = {}
    for s in suite:
        code, _, where = s.partition("-")
        by.setdefault(code, []).append(where)
    return ", ".join(f"{c}-{'/'.join(w)}" if w != ["roof"] else c for c, w in by.items())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--kitti-root", default=os.environ.get("SENSORSEL_KITTI_ROOT", str(REPO.parent / "shared" / "kitti"))
    )
    ap.add_argument("--budget", type=float, default=110_000.0)
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    args = ap.parse_args()
    os.environ["SENSORSEL_KITTI_ROOT"] = args.kitti_root
    t0 = time.perf_counter()
    plain = load_domain(REPO / "configs" / "domain_kitti.yaml")
    mixed = load_domain(REPO / "configs" / "domain_kitti_conditions.yaml")
    ev_mixed = DomainEvaluator(mixed, jobs=args.jobs)

    d_clear = design_domain(plain, args.budget, jobs=args.jobs)
    d_mix = design_domain(mixed, args.budget, jobs=args.jobs, evaluator=ev_mixed)
    print(f"## 1. Seven routes at ${args.budget:,.0f}: clear days only against the city's mix\n")
    print("| design | suite | cost | F on clear days | F in the city's mix |")
    print("|---|---|---:|---:|---:|")
    ev_plain = DomainEvaluator(plain, jobs=args.jobs)
    for name, d in (("clear days only", d_clear), ("city's mix", d_mix)):
        s = mixed.resolve_suite(d.greedy.suite)
        print(
            f"| {name} | {compact(d.greedy.suite)} | ${d.greedy.cost_usd:,.0f} | {ev_plain.score(s):.4f} | "
            f"{ev_mixed.score(s):.4f} |"
        )
    print("\nWhat each condition costs each suite (its members' share of their best, weighted by km):\n")
    print("| condition | weight | clear-days suite | city-mix suite |")
    print("|---|---:|---:|---:|")
    for cond in mixed.condition_names:
        idx = [k for k, r in enumerate(mixed.routes) if r.condition == cond]
        w = ev_mixed.weights[idx]
        row = []
        for d in (d_clear, d_mix):
            f = ev_mixed.route_scores(mixed.resolve_suite(d.greedy.suite))[idx] / ev_mixed.best[idx]
            row.append(float(np.dot(w, f) / w.sum()))
        print(f"| {cond} | {w.sum():.1%} | {row[0]:.4f} | {row[1]:.4f} |")
    worst = min(by_condition(d_mix), key=lambda c: c.share_of_best)
    print(
        f"\nWorst condition of the city-mix suite: {worst.name} (share of its best {worst.share_of_best:.4f}; "
        f"worst member {d_mix.worst_route}, "
        f"{next(r for r in d_mix.routes if r.name == d_mix.worst_route).share_of_own:.1%} "
        "of its own design)"
    )

    print("\n## 2. Which sensors gain value\n")
    singles = ("LRL-roof", "MRL-roof", "LRR-12", "MRR-12", "WSC-12", "HD2K-12")
    print("Each sensor alone, summed over the seven routes, as a share of its clear-day score:\n")
    print("| condition | " + " | ".join(singles) + " |")
    print("|---|" + "---:|" * len(singles))
    clear_f = {}
    for cond in mixed.condition_names:
        members = [(k, r) for k, r in enumerate(mixed.routes) if r.condition == cond]
        vals = []
        for s in singles:
            pos = mixed.resolve_suite(s)
            total = sum(ev_mixed.routes[k].score(pos) for k, _ in members)
            if cond == "clear":
                clear_f[s] = total
            vals.append(total / clear_f[s])
        print(f"| {cond} | " + " | ".join(f"{v:.3f}" for v in vals) + " |")
    print("\nThe suite bought for each condition alone (the seven routes all in it):\n")
    print("| condition | suite | cost | radars | LiDARs | cameras |")
    print("|---|---|---:|---:|---:|---:|")
    for cond in mixed.condition_names:
        sub = Domain(tuple(r for r in mixed.routes if r.condition == cond), f"{cond} only")
        g = greedy(DomainEvaluator(sub, jobs=args.jobs), args.budget)
        kinds = [mixed.library[mixed.library.position(s)].model.type for s in g.suite]
        print(
            f"| {cond} | {compact(g.suite)} | ${g.cost_usd:,.0f} | {kinds.count('radar')} | {kinds.count('lidar')} | "
            f"{kinds.count('stereo')} |"
        )

    print("\n## 3. Dense fog on KITTI 00 with one failure\n")
    fog = parse_condition("fog_visibility_m=150")
    p00 = load_problem(ScenarioSpec(seq="00", kitti_root=args.kitti_root, landmarks="real"))
    p00_fog = with_condition(p00, fog)
    print("| route | design | suite | cost | nominal [nats] | worst case after 1 failure [nats] | failing |")
    print("|---|---|---|---:|---:|---:|---|")
    for label, prob in (("00 clear", p00), ("00 fog 150 m", p00_fog)):
        r = run_robust(prob, args.budget, 1, jobs=args.jobs)
        g = greedy(make_evaluator(prob, jobs=args.jobs), args.budget)
        print(
            f"| {label} | greedy | {compact(g.suite)} | ${g.cost_usd:,.0f} | {g.score:,.1f} | "
            f"{r.greedy_worst_score:,.1f} | |"
        )
        print(
            f"| {label} | robust ({r.method}) | {compact(r.suite)} | ${r.cost_usd:,.0f} | {r.nominal_score:,.1f} | "
            f"{r.worst_score:,.1f} | {', '.join(r.failures)} |"
        )
        print(f"| {label} | bound | | | | <= {r.bound:,.1f} (gap {r.gap_percent:.1f}%) | |")
    print(f"\n(all of the above: {time.perf_counter() - t0:.0f} s on {os.cpu_count()} cores)")


if __name__ == "__main__":
    main()
