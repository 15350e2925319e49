"""Greedy on the seven KITTI routes in four conditions against the seven routes alone, one run.

    python bench/conditions.py --kitti-root ../shared/kitti [--budget 110000] [--repeat 1] [--gaps]

Loads the domain of configs/domain_kitti_conditions.yaml (seven routes x clear, night, rain, fog:
28 members) and the same seven routes without conditions (configs/domain_kitti.yaml), then times,
side by side in one process: building each domain (loading the routes, what each sensor sees, the
members derived from the clear measurements), its evaluator (each member's engine and normaliser)
and the greedy selection at the budget. Target: the 28 members' greedy (setup +
selection) in at most 2.5x the time of the seven routes alone, in-process on the 2-core machine.
Runs alternate (routes, conditions, routes, ...) so that load on a shared machine hits both alike;
the ratio is of the medians. The CPU time of evaluators + greedy (all threads) is printed beside the
wall time: on a machine shared with other jobs it is the steadier of the two.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "src"))

from sensorsel.designs.selection import greedy  # noqa: E402
from sensorsel.information.evaluators import DomainEvaluator  # noqa: E402
from sensorsel.model.problem import load_domain  # noqa: E402


def _by_condition(domain, ev: DomainEvaluator) -> dict[str, int]:
    """Route evaluations of the members of each condition (a night member's scores copied from its
    clear member cost none: they are not counted)."""
    out: dict[str, int] = {}
    for r, e in zip(domain.routes, ev.routes):
        name = r.condition or "no condition"
        out[name] = out.get(name, 0) + e.n_evaluations
    return out


def run(path: Path, budget: float, jobs: int) -> dict[str, float | str | int]:
    t0 = time.perf_counter()
    domain = load_domain(path)
    t1, c1 = time.perf_counter(), time.process_time()
    ev = DomainEvaluator(domain, jobs=jobs)
    t2, c2 = time.perf_counter(), time.process_time()
    res = greedy(ev, budget)
    t3, c3 = time.perf_counter(), time.process_time()
    return {
        "load": t1 - t0,
        "setup": t2 - t1,
        "select": t3 - t2,
        "cpu": (c2 - c1) + (c3 - c2),
        "members": len(domain.routes),
        "evals": res.n_evaluations,
        "route_evals": sum(r.n_evaluations for r in ev.routes),
        "by_condition": ", ".join(f"{c} {n}" for c, n in _by_condition(domain, ev).items()),
        "suite": ",".join(res.suite),
        "score": res.score,
        "steps": repr([(s.pick, s.score) for s in res.steps]),
    }


def gaps(path: Path, budget: float, jobs: int, top: int = 6) -> None:
    """At each pick's suite, every affordable candidate scored exactly on every member (no laziness):
    the best ``top`` domain scores and each one's rain and fog terms, F's part that those members'
    gains make (why the lazy greedy must score close candidates on their light members)."""
    domain = load_domain(path)
    ev = DomainEvaluator(domain, jobs=jobs)
    res = greedy(ev, budget)
    lib = ev.library
    cond = [r.problem.condition.name if r.problem.condition is not None else "clear" for r in domain.routes]
    suite: list[int] = []
    for st in res.steps:
        spent = float(sum(lib.costs[i] for i in suite))
        cand = [i for i in range(len(lib)) if i not in suite and spent + lib.costs[i] <= budget]
        per = np.stack([r.scores_with(tuple(suite), cand) for r in ev.routes])  # (members, candidates) [nats]
        own = np.array([r.score(tuple(suite)) for r in ev.routes])
        F = ev.combine(per)
        best = np.argsort(-F, kind="stable")[:top]
        terms = {
            c: [
                float(np.sum([ev.scale[k] * (per[k, i] - own[k]) for k in range(len(cond)) if cond[k] == c]))
                for i in best
            ]
            for c in ("rain", "fog")
        }
        print(f"pick {len(suite) + 1} ({st.pick}): " + ", ".join(f"{lib.ids[cand[i]]} {F[i]:.6f}" for i in best))
        print(
            "   rain terms "
            + " ".join(f"{x:.1e}" for x in terms["rain"])
            + "; fog terms "
            + " ".join(f"{x:.1e}" for x in terms["fog"])
        )
        suite.append(lib.position(st.pick))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--kitti-root", default=os.environ.get("SENSORSEL_KITTI_ROOT", str(REPO.parent / "shared" / "kitti"))
    )
    ap.add_argument("--budget", type=float, default=110_000.0)
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument(
        "--gaps",
        action="store_true",
        help="instead of timing: every candidate's exact score at each "
        "pick's suite (the best six and their rain and fog terms), ~1 min",
    )
    args = ap.parse_args()
    os.environ["SENSORSEL_KITTI_ROOT"] = args.kitti_root
    plain, mixed = REPO / "configs" / "domain_kitti.yaml", REPO / "configs" / "domain_kitti_conditions.yaml"
    if args.gaps:
        gaps(mixed, args.budget, args.jobs)
        return
    runs: dict[str, list[dict]] = {"routes": [], "conditions": []}
    for _ in range(args.repeat):
        runs["routes"].append(run(plain, args.budget, args.jobs))
        runs["conditions"].append(run(mixed, args.budget, args.jobs))
    print(
        f"machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}; budget "
        f"${args.budget:,.0f}, uniform greedy, fast engine jobs={args.jobs}; {args.repeat} run(s) each, alternating"
    )
    med, cpu = {}, {}
    for name, rs in runs.items():
        m = {k: statistics.median(float(r[k]) for r in rs) for k in ("load", "setup", "select")}
        med[name], cpu[name] = m, statistics.median(float(r["cpu"]) for r in rs)
        r = rs[0]
        print(
            f"{name:<10} members {r['members']:>2}: load {m['load']:6.2f} s  evaluators {m['setup']:6.2f} s  "
            f"greedy {m['select']:6.2f} s (CPU of both {cpu[name]:6.2f} s; {r['evals']} domain evaluations, "
            f"{r['route_evals']} route evaluations: {r['by_condition']})  F = {float(r['score']):.4f}  {r['suite']}"
        )
        if any(x["steps"] != r["steps"] for x in rs):
            raise SystemExit(f"{name}: runs picked differently: greedy is not deterministic")
    ratio = (med["conditions"]["setup"] + med["conditions"]["select"]) / (
        med["routes"]["setup"] + med["routes"]["select"]
    )
    ratio_all = sum(med["conditions"].values()) / sum(med["routes"].values())
    print(
        f"ratio, 4 conditions / routes alone: evaluators + greedy {ratio:.2f}x (CPU "
        f"{cpu['conditions'] / cpu['routes']:.2f}x); "
        f"with loading {ratio_all:.2f}x"
    )
    print(f"target: <= 2.5x (evaluators + greedy, wall): {'met' if ratio <= 2.5 else 'NOT met'}")


if __name__ == "__main__":
    main()
