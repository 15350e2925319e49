"""A domain's greedy in-process against a local Dask cluster, and a measured model for 100 routes.

    python bench/distributed.py [--domain configs/domain_kitti.yaml] [--budget 110000] [--workers 2]

One run of each (timings depend on the machine's load; the ratio is what this run measured):

1. in-process: load the domain, build the :class:`DomainEvaluator` (every route's engine and its
   normaliser f_r(L)), lazy greedy "uniform" at the budget;
2. the same greedy with a :class:`DistributedDomainEvaluator` on a LocalCluster of ``--workers``
   processes (routes built on the workers, in parallel); the results must be equal (timings aside);
   bytes per greedy step (pickled arguments and results of every route's call);
3. per route: in-process, the time to build its evaluator and of one full greedy step (every sensor
   scored against an empty base); on its worker, the time and resident memory its actor's build
   added; the client's CPU time per route call during the distributed run: the inputs of the model
   in docs/distributed.md.

Prints one JSON document (and a short summary on stderr).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
# this file's folder would shadow Dask's own `distributed` package
sys.path = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).resolve().parent]
sys.path.insert(0, str(REPO / "src"))


def rss() -> int:
    import psutil

    return int(psutil.Process().memory_info().rss)


def untimed(text: str) -> object:
    def rec(o: object) -> object:
        if isinstance(o, dict):
            return {k: rec(v) for k, v in o.items() if k != "seconds"}
        if isinstance(o, list):
            return [rec(v) for v in o]
        return o

    return rec(json.loads(text))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--domain", default=str(REPO / "configs" / "domain_kitti.yaml"))
    ap.add_argument("--budget", type=float, default=110_000.0)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--rule", default="uniform")
    args = ap.parse_args()

    from sensorsel.designs.selection import greedy
    from sensorsel.information.evaluators import DomainEvaluator, make_evaluator
    from sensorsel.information.evaluators.distributed import DistributedDomainEvaluator, RouteRecipe
    from sensorsel.io import results
    from sensorsel.model.problem import load_domain
    from sensorsel.pipeline.cluster import DaskCluster

    out: dict = {
        "domain": args.domain,
        "budget_usd": args.budget,
        "workers": args.workers,
        "rule": args.rule,
        "cpus": os.cpu_count(),
    }
    m0, t0 = rss(), time.perf_counter()
    domain = load_domain(args.domain)
    out["load_s"] = round(time.perf_counter() - t0, 3)
    out["load_rss_bytes"] = rss() - m0
    n = len(domain.library)

    # 1. in-process greedy
    t0 = time.perf_counter()
    ev_local = DomainEvaluator(domain)
    build_local = time.perf_counter() - t0
    t0 = time.perf_counter()
    res_local = greedy(ev_local, args.budget, args.rule, lazy=True, info=domain.info)
    greedy_local = time.perf_counter() - t0
    out["in_process"] = {
        "build_s": round(build_local, 3),
        "greedy_s": round(greedy_local, 3),
        "wall_s": round(build_local + greedy_local, 3),
        "suite": list(res_local.suite),
        "score": res_local.score,
        "n_evaluations": res_local.n_evaluations,
    }
    print(f"in-process: build {build_local:.1f} s, greedy {greedy_local:.1f} s", file=sys.stderr)

    # 2. on a LocalCluster
    with DaskCluster(workers=args.workers, echo=lambda line: print(line, file=sys.stderr)) as cluster:
        c0, t0 = time.process_time(), time.perf_counter()
        ev = DistributedDomainEvaluator(cluster.client, domain)
        build_dist = time.perf_counter() - t0
        busy0 = ev.busy()  # the normalisers' scoring, before the greedy
        c1, t1 = time.process_time(), time.perf_counter()
        res_dist = greedy(ev, args.budget, args.rule, lazy=True, info=domain.info)
        greedy_dist = time.perf_counter() - t1
        client_cpu = time.process_time() - c1
        busy1 = ev.busy()  # each actor's scoring time, calls and worker, since it was built
        busy = {k: (busy1[k][0] - busy0[k][0], busy1[k][1] - busy0[k][1], busy1[k][2]) for k in busy1}  # the greedy's
        worker_costs = ev.costs()
    calls = len(ev.step_bytes) * len(domain.routes)
    steps = ev.step_bytes
    per_worker: dict[str, float] = {}
    for sec, _, w in busy.values():
        per_worker[w] = per_worker.get(w, 0.0) + sec
    slowest = max(per_worker.values())  # every step waits for its slowest worker: a floor of the greedy's wall
    overhead = max(0.0, greedy_dist - slowest)
    out["distributed_overhead"] = {
        "actor_scoring_s_by_worker": {w: round(v, 3) for w, v in sorted(per_worker.items())},
        "actor_scoring_s_total": round(sum(per_worker.values()), 3),
        "greedy_wall_minus_slowest_worker_s": round(overhead, 3),
        "overhead_per_step_ms": round(1e3 * overhead / max(1, len(ev.step_bytes)), 2),
        "overhead_per_route_call_ms": round(1e3 * overhead / max(1, len(ev.step_bytes) * len(domain.routes)), 3),
        "note": "the greedy's calls only; the wall minus the slowest worker's scoring is what the client, Dask's actor "
        "machinery, the network and the waits for the other worker cost",
    }
    out["distributed"] = {
        "build_s": round(build_dist, 3),
        "build_client_cpu_s": round(time.process_time() - c0 - client_cpu, 3),
        "greedy_s": round(greedy_dist, 3),
        "wall_s": round(build_dist + greedy_dist, 3),
        "greedy_client_cpu_s": round(client_cpu, 3),
        "client_cpu_per_route_call_ms": round(1e3 * client_cpu / max(1, calls), 3),
        "domain_steps": len(steps),
        "route_calls": calls,
        "bytes_per_step_sent": {
            "mean": round(sum(s for s, _ in steps) / max(1, len(steps)), 1),
            "max": max((s for s, _ in steps), default=0),
        },
        "bytes_per_step_received": {
            "mean": round(sum(r for _, r in steps) / max(1, len(steps)), 1),
            "max": max((r for _, r in steps), default=0),
        },
        "bytes_total_sent": ev.bytes_sent,
        "bytes_total_received": ev.bytes_received,
        "worker_build_s_by_route": {k: round(v[0], 3) for k, v in worker_costs.items()},
        "worker_rss_bytes_by_route": {k: v[1] for k, v in worker_costs.items()},
        "same_result": untimed(results.dumps(res_dist)) == untimed(results.dumps(res_local)),
    }
    # 3. per route, in-process (also the in-process build, route by route)
    per = []
    for r in domain.routes:
        problem = RouteRecipe.of(r.name, r.problem).build()  # afresh: nothing cached by the runs above
        t1 = time.perf_counter()
        ev = make_evaluator(problem)
        ev.score(tuple(range(n)))  # its normaliser f_r(L)
        build = time.perf_counter() - t1
        t2 = time.perf_counter()
        ev.scores_with((), list(range(n)))
        step = time.perf_counter() - t2
        per.append(
            {
                "route": r.name,
                "poses": problem.scenario.n_poses,
                "landmarks": problem.scenario.n_landmarks,
                "measurements": sum(len(o) for o in problem.observations),
                "build_s": round(build, 3),
                "first_step_s": round(step, 3),
            }
        )
        del ev, problem
    out["routes"] = per

    out["ratio_wall_in_process_over_distributed"] = round((build_local + greedy_local) / (build_dist + greedy_dist), 3)
    out["ratio_greedy_in_process_over_distributed"] = round(greedy_local / greedy_dist, 3)
    print(
        f"distributed: build {build_dist:.1f} s, greedy {greedy_dist:.1f} s; same result: "
        f"{out['distributed']['same_result']}",
        file=sys.stderr,
    )
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
