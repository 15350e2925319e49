"""Where a domain greedy's time goes, per executor, and what more threads or workers can give.

    python bench/parallel.py [--domain configs/domain_kitti.yaml] [--budget 110000] [--jobs 1,2] [--workers 1,2]
    python bench/parallel.py --domain configs/domain_fixtures.yaml --budget 12000     # the small fixture domain
    python bench/parallel.py --generated 100 --budget 12000 --jobs 1 --workers 2      # 100 generated routes
    python bench/parallel.py --whole --workers ""                        # + certificate and breakdown, in-process

(The KITTI domain needs ``SENSORSEL_KITTI_ROOT``, e.g. /work/shared/kitti.) ``--generated N`` writes a
domain of N routes (the bundled tiny route, each with its own synthetic landmark map, seeds 1..N)
to a temporary folder and measures that: many small routes, so wide rounds.

One run of each configuration, side by side in one process (the machine is shared: the ratios and
CPU times are what to read, not the seconds alone):

- in-process on 1 and N threads (``DomainEvaluator(jobs=...)``): wall, the process's CPU (every
  thread's), the parallel rounds (each time the evaluator hands its routes to its threads: a greedy
  batch's scores, the routes' gain bounds) with each task's seconds, and the serial rest;
- on LocalClusters of 1 and 2 workers (``DistributedDomainEvaluator``): wall, the client's CPU, the
  workers' and the scheduler's CPU (``psutil`` in each process), messages and pickled bytes per greedy
  step, the seconds the client waited for answers, and the result compared with the in-process one.

**The model** (printed as ``model``), from the trace of a run on n threads (``--model-at``; on a
2-core machine the threads beyond 2 take turns, but each route call's CPU is its own):

    T(n) = S + sum_rounds LPT_n(tasks of the round on n threads) + rounds * c(n)

The n-thread run's trace, not the 1-thread run's: a lazy round's idle threads score ahead
(:mod:`sensorsel.information.evaluators.ahead`), so a round on n threads holds more calls than on one
and later rounds fewer (the same answers and counts). ``model.in_process_one_thread_trace`` is the
model without it (every n from the 1-thread trace), for comparison.

S the serial part (everything outside the rounds: the greedy's bookkeeping, combining routes),
LPT_n a round's makespan when its tasks (route calls, dearest first) go to n threads or workers, c(n)
the communication per round (0 in-process; on a cluster the client's measured CPU per round: pickling,
sending, gathering, and a LocalCluster's scheduler, which runs in the client's process; the
client's wall wait beyond the slower worker's scoring is reported beside it, which on a loaded
machine is mostly waiting for a core). Amdahl's law with the serial fraction s = S / T(1) is the looser bound
``amdahl`` (every round perfectly divisible): T(n) = T(1) (s + (1 - s) / n). The round-aware model
is the honest one: a lazy greedy round asks one or two candidates at a time, on the routes whose
bounds matter, so a round rarely has more than a handful of tasks, whatever the number of workers.
Both are checked against the measured 2-thread and 1-/2-worker runs (``model_check``).

``--commands greedy,pareto,robust`` adds the rows of ``pareto`` (its rules' budget chains, at
``--pareto-budgets``) and ``robust --failures 1`` (its methods) on the same domain: in-process on each
``--jobs`` (every evaluator they build traced: the same model) and on each LocalCluster (their plans'
tasks on the workers: wall, the client's and the workers' CPU, the client's wait). ``require`` adds
the domain's ``require`` (``--require-preset``, ``--require-failures``; a map known to 0.05 m, the
filter's estimate): wall and CPU in-process on each ``--jobs`` and with each route's checks on a
LocalCluster's workers, the integer programs and accuracy computations and the seconds in each,
messages and bytes per integer program, and whether every run gave the same result; and its model
(``require.model``, :func:`pinned_model`) from the 1-thread run's trace of every question's seconds
on each route: each route pinned to one place (its oracle learns there), the speed-up at n places,
and the slowest-route bound no number of places beats, checked against the ``--jobs`` runs.

Prints one JSON document (and a summary on stderr).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parents[1]
# this file's folder holds bench/distributed.py, which would shadow Dask's own `distributed` package
sys.path = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).resolve().parent]
sys.path.insert(0, str(REPO / "src"))

from sensorsel.information.evaluators import DomainEvaluator  # noqa: E402

PREDICT_AT = (1, 2, 4, 8, 16, 64)


def untimed(text: str) -> object:
    def rec(o: object) -> object:
        if isinstance(o, dict):
            return {k: rec(v) for k, v in o.items() if not k.startswith("seconds")}  # seconds, seconds_checks, ...
        if isinstance(o, list):
            return [rec(v) for v in o]
        return o

    return rec(json.loads(text))


class TracedDomainEvaluator(DomainEvaluator):
    """A :class:`DomainEvaluator` that records each parallel round: its tasks' CPU seconds (of the
    thread that ran each: BLAS is held at one thread there) and the round's wall time. Same numbers:
    it only times. CPU, not wall, feeds the model: other processes on the machine stretch a task's
    wall time, not its CPU time."""

    def __init__(self, *args: Any, **kw: Any) -> None:
        self.rounds: list[tuple[float, list[float]]] = []
        #: each round's CPU seconds by route (which route each task was: what pinned routes need)
        self.route_rounds: list[dict[int, float]] = []
        self._tracing = False
        super().__init__(*args, **kw)
        # each route call on its one thread: a route engine's own threads (it scores a large route's
        # candidates on them) would hide their CPU from the calling thread's clock, and the model
        # would count a merged call as cheaper than it is (the same bytes either way)
        for r in self.routes:
            r.jobs = 1

    def _on_threads(self, one: Any, members: list[int], work: Any = None) -> dict[int, Any]:
        if not self._tracing:
            return super()._on_threads(one, members, work)
        times: list[float] = []
        by_route: dict[int, float] = {}
        lock = threading.Lock()

        def timed(k: int) -> Any:
            t0 = time.thread_time()
            out = one(k)
            with lock:
                times.append(time.thread_time() - t0)
                by_route[k] = by_route.get(k, 0.0) + times[-1]
            return out

        t0 = time.perf_counter()
        got = super()._on_threads(timed, members, work)
        self.rounds.append((time.perf_counter() - t0, times))
        self.route_rounds.append(by_route)
        return got


def lpt(tasks: list[float], n: int) -> float:
    """Makespan of ``tasks`` [s] on ``n`` machines, longest first to the least loaded (as
    :meth:`DomainEvaluator._on_threads` starts the dearest routes first)."""
    if n <= 1 or len(tasks) <= 1:
        return sum(tasks) if n <= 1 else max(tasks, default=0.0)
    load = [0.0] * min(n, len(tasks))
    for t in sorted(tasks, reverse=True):
        i = load.index(min(load))
        load[i] += t
    return max(load)


def rss() -> int:
    import psutil

    return int(psutil.Process().memory_info().rss)


def cpu_of_this_process() -> float:
    """The calling process's CPU seconds (user + system): here, and on each worker and the scheduler
    through ``client.run`` (cloudpickle sends this script's functions by value)."""
    import psutil

    t = psutil.Process().cpu_times()
    return float(t.user + t.system)


def _stage(ev: TracedDomainEvaluator, jobs: int, run: Any) -> tuple[Any, dict[str, Any]]:
    """Run ``run()`` with ``ev``'s rounds traced afresh: its result and what the stage cost."""
    ev.rounds = []
    c1, t1 = cpu_of_this_process(), time.perf_counter()
    out = run()
    wall = time.perf_counter() - t1
    cpu = cpu_of_this_process() - c1
    in_rounds = sum(w for w, _ in ev.rounds)
    tasks = [len(t) for _, t in ev.rounds]
    task_cpu = sum(sum(t) for _, t in ev.rounds)
    by_width: dict[str, float] = {}
    for _, t in ev.rounds:
        if t:
            by_width[str(len(t))] = by_width.get(str(len(t)), 0.0) + sum(t)
    return out, {
        "wall_s": round(wall, 3),
        "cpu_s": round(cpu, 3),
        "rounds": len(ev.rounds),
        "route_calls": sum(tasks),
        "rounds_by_tasks": {str(n): tasks.count(n) for n in sorted(set(tasks))},
        "route_call_cpu_s": round(task_cpu, 3),
        "route_call_cpu_s_by_round_width": {
            k: round(v, 3) for k, v in sorted(by_width.items(), key=lambda kv: int(kv[0]))
        },
        "rounds_wall_s": round(in_rounds, 3),
        "serial_wall_s": round(wall - in_rounds, 3),
        # the client's CPU outside the rounds (jobs=1: the one thread's CPU minus its tasks')
        "serial_cpu_s": round(max(0.0, cpu - task_cpu), 3) if jobs == 1 else None,
        "_trace": [t for _, t in ev.rounds],
    }


def run_in_process(domain: Any, budget: float, rule: str, jobs: int, whole: bool) -> dict[str, Any]:
    """The lazy greedy (and with ``whole``, the command's certificate and per-route breakdown too),
    each stage traced on its own."""
    from sensorsel.designs.certify import certificate
    from sensorsel.designs.domain_design import route_breakdown
    from sensorsel.designs.selection import greedy
    from sensorsel.io import results

    c0, t0 = cpu_of_this_process(), time.perf_counter()
    ev = TracedDomainEvaluator(domain, jobs=jobs)
    build = time.perf_counter() - t0
    ev._tracing = True
    res, g = _stage(ev, jobs, lambda: greedy(ev, budget, rule, lazy=True, info=domain.info))
    out = {
        "jobs": jobs,
        "build_s": round(build, 3),
        "build_cpu_s": round(cpu_of_this_process() - c0 - g["cpu_s"], 3),
        "greedy_wall_s": g["wall_s"],
        "greedy_cpu_s": g["cpu_s"],
        "steps": len(res.steps),
        "route_calls_scored_ahead": ev.n_ahead,
        "route_calls_scored_ahead_used": ev.n_ahead_used,
        "n_evaluations": res.n_evaluations,
        **{k: v for k, v in g.items() if k not in ("wall_s", "cpu_s")},
    }
    record = [results.dumps(res)]
    if whole:
        cert, c = _stage(ev, jobs, lambda: certificate(ev, res))
        shares, b = _stage(ev, jobs, lambda: route_breakdown(ev, res))
        out["certificate"], out["breakdown"] = c, b
        record += [repr(cert.bound), repr(shares)]  # the certificate's bound and every route's share (no timings)
    out["_result"] = "\x00".join(record)
    return out


def run_on_cluster(domain: Any, budget: float, rule: str, workers: int) -> dict[str, Any]:
    from sensorsel.designs.selection import greedy
    from sensorsel.information.evaluators.distributed import DistributedDomainEvaluator
    from sensorsel.io import results
    from sensorsel.pipeline.cluster import DaskCluster

    with DaskCluster(workers=workers, echo=lambda line: None) as cluster:
        client = cluster.client
        mem0, t0 = rss(), time.perf_counter()
        ev = DistributedDomainEvaluator(client, domain)
        build = time.perf_counter() - t0
        w0, s0 = client.run(cpu_of_this_process), client.run_on_scheduler(cpu_of_this_process)
        busy0 = ev.busy()
        m0, b0, r0, wait0, rounds0 = ev.n_messages, ev.bytes_sent, ev.bytes_received, ev.wait_s, ev.n_rounds
        c1, t1 = cpu_of_this_process(), time.perf_counter()
        res = greedy(ev, budget, rule, lazy=True, info=domain.info)
        wall = time.perf_counter() - t1
        client_cpu = cpu_of_this_process() - c1
        msgs, sent, recv, wait = ev.n_messages - m0, ev.bytes_sent - b0, ev.bytes_received - r0, ev.wait_s - wait0
        rounds = ev.n_rounds - rounds0
        w1, s1 = client.run(cpu_of_this_process), client.run_on_scheduler(cpu_of_this_process)
        client_rss_growth = rss() - mem0
        workers_rss = client.run(rss)
        busy1 = ev.busy()
    busy_by_worker: dict[str, float] = {}
    for k in busy1:
        busy_by_worker[busy1[k][2]] = busy_by_worker.get(busy1[k][2], 0.0) + busy1[k][0] - busy0[k][0]
    steps = max(1, len(res.steps))
    return {
        "workers": workers,
        "build_s": round(build, 3),
        "greedy_wall_s": round(wall, 3),
        "client_cpu_s": round(client_cpu, 3),
        "workers_cpu_s": round(sum(w1[a] - w0[a] for a in w1), 3),
        "scheduler_cpu_s": round(s1 - s0, 3),
        "workers_scoring_s": {a: round(v, 3) for a, v in sorted(busy_by_worker.items())},
        "client_wait_s": round(wait, 3),
        "rounds": rounds,
        "client_rss_growth_bytes": client_rss_growth,
        "workers_rss_bytes": sorted(workers_rss.values()),
        "route_calls_scored_ahead": ev.n_ahead,
        "route_calls_scored_ahead_used": ev.n_ahead_used,
        "messages": msgs,
        "messages_per_step": round(msgs / steps, 1),
        "bytes_sent_per_step": round(sent / steps, 1),
        "bytes_received_per_step": round(recv / steps, 1),
        "_result": results.dumps(res),
    }


def run_on_processes(domain: Any, budget: float, rule: str, processes: int, repeat: int = 1) -> dict[str, Any]:
    """The lazy greedy with the routes owned by worker processes of this machine
    (:class:`~sensorsel.information.evaluators.processes.ProcessDomainEvaluator`, what ``--jobs N``
    runs on a domain): wall, the client's CPU, the workers' CPU (``psutil``), rounds and bytes; with
    ``repeat``, the greedy run again on the same (warm) processes, each run's wall reported."""
    import psutil  # type: ignore[import-untyped]

    from sensorsel.designs.selection import greedy
    from sensorsel.information.evaluators.processes import ProcessDomainEvaluator
    from sensorsel.io import results

    def workers_cpu(ev: Any) -> float:
        return sum(sum(psutil.Process(w.process.pid).cpu_times()[:2]) for w in ev._processes)

    t0 = time.perf_counter()
    with ProcessDomainEvaluator(domain, processes=processes) as ev:
        build = time.perf_counter() - t0
        w0, b0, r0, rounds0, wait0 = workers_cpu(ev), ev.bytes_sent, ev.bytes_received, ev.n_rounds, ev.wait_s
        c1, t1 = cpu_of_this_process(), time.perf_counter()
        res = greedy(ev, budget, rule, lazy=True, info=domain.info)
        wall = time.perf_counter() - t1
        client_cpu = cpu_of_this_process() - c1
        w1 = workers_cpu(ev)
        rounds, ahead, ahead_used = ev.n_rounds - rounds0, ev.n_ahead, ev.n_ahead_used  # the first run's
        moved, wait = ev.bytes_sent - b0 + ev.bytes_received - r0, ev.wait_s - wait0
        again = []
        for _ in range(repeat - 1):
            t2 = time.perf_counter()
            greedy(ev, budget, rule, lazy=True, info=domain.info)
            again.append(round(time.perf_counter() - t2, 3))
        steps = max(1, len(res.steps))
        out = {
            "processes": processes,
            "build_s": round(build, 3),
            "greedy_wall_s": round(wall, 3),
            "greedy_wall_again_s": again,
            "client_cpu_s": round(client_cpu, 3),
            "workers_cpu_s": round(w1 - w0, 3),
            "client_wait_s": round(wait, 3),
            "rounds": rounds,
            "route_calls_scored_ahead": ahead,
            "route_calls_scored_ahead_used": ahead_used,
            "bytes_per_step": round(moved / steps, 1),
            "_result": results.dumps(res),
        }
    return out


def model(
    trace: list[list[float]],
    serial: float,
    comm_per_round: float = 0.0,
    traces: dict[int, list[list[float]]] | None = None,
) -> dict[str, Any]:
    """Predicted greedy seconds and speed-ups at each n of :data:`PREDICT_AT` (see the module's doc):
    ``trace`` the 1-thread run's rounds, ``traces`` the n-thread runs' (default: the 1-thread one)."""
    t1 = serial + sum(sum(t) for t in trace)
    s = serial / t1 if t1 > 0 else 1.0
    out: dict[str, Any] = {
        "serial_s": round(serial, 3),
        "serial_fraction": round(s, 4),
        "rounds": len(trace),
        "comm_per_round_ms": round(1e3 * comm_per_round, 3),
    }
    for n in PREDICT_AT:
        tr = (traces or {}).get(n)
        if traces is not None and tr is None:
            continue
        tr = trace if tr is None else tr
        rounds_aware = serial + sum(lpt(t, n) for t in tr) + len(tr) * comm_per_round
        amdahl = t1 * (s + (1 - s) / n)
        out[f"at_{n}"] = {
            "round_aware_s": round(rounds_aware, 3),
            "round_aware_speedup": round(t1 / rounds_aware, 2),
            "amdahl_speedup": round(t1 / amdahl, 2),
        }
    return out


def pinned_model(
    route_rounds: list[dict[int, float]], serial: float, n_routes: int, costs: list[float]
) -> dict[str, Any]:
    """Predicted seconds and speed-ups of a search whose every round asks each route once and waits
    for all (``require``'s questions: :mod:`sensorsel.designs.requirements.domain_checks`), from its
    1-thread trace: ``route_rounds`` each round's CPU seconds by route, ``serial`` the rest.

    ``pinned``: each route stays on one place for the whole search (worker processes, Dask workers:
    its oracle learns there), placed as the package places them: by ``costs`` (the package's model of
    a route's work), dearest first to the least loaded; ``pinned_by_seconds``: the same by each
    route's measured seconds; at n = 2 with at most 16 routes, the best of every placement too.
    T(n) = serial + the sum over rounds of the most loaded place's seconds.
    ``slowest_route_bound``: serial + the sum over rounds of the round's slowest route: what no number
    of places beats while a route's question runs on one core (the speed-up at n = infinity)."""
    work = np.zeros((len(route_rounds), n_routes))
    for i, r in enumerate(route_rounds):
        for k, v in r.items():
            work[i, k] = v
    t1 = serial + float(work.sum())
    totals = work.sum(axis=0)

    def makespan(place: np.ndarray, n: int) -> float:
        loads = np.zeros((len(work), n))
        for k in range(n_routes):
            loads[:, place[k]] += work[:, k]
        return serial + float(loads.max(axis=1).sum())

    out: dict[str, Any] = {"serial_s": round(serial, 3), "rounds": len(route_rounds), "one_place_s": round(t1, 3)}

    def lpt_place(weights: np.ndarray, n: int) -> np.ndarray:
        place, load = np.zeros(n_routes, int), np.zeros(n)
        for k in sorted(range(n_routes), key=lambda k: (-weights[k], k)):
            place[k] = int(np.argmin(load))  # the least loaded, the first among ties (as the package)
            load[place[k]] += weights[k]
        return place

    for n in PREDICT_AT[1:]:
        t = makespan(lpt_place(np.asarray(costs, float), n), n)
        by_seconds = makespan(lpt_place(totals, n), n)
        row = {
            "pinned_s": round(t, 3),
            "pinned_speedup": round(t1 / t, 2),
            "pinned_by_seconds_speedup": round(t1 / by_seconds, 2),
        }
        if n == 2 and n_routes <= 16:
            best = min(
                makespan(np.array([(m >> k) & 1 for k in range(n_routes)]), 2) for m in range(2 ** (n_routes - 1))
            )
            row.update(best_placement_s=round(best, 3), best_placement_speedup=round(t1 / best, 2))
        out[f"at_{n}"] = row
    bound = serial + float(work.max(axis=1).sum()) if len(work) else serial
    out["slowest_route_bound_s"] = round(bound, 3)
    out["slowest_route_bound_speedup"] = round(t1 / bound, 2)
    return out


def run_command_in_process(command: str, domain: Any, args: Any, jobs: int) -> dict[str, Any]:
    """``pareto`` or ``robust --failures 1`` in-process on ``jobs`` threads, every evaluator it builds
    traced (the designs build theirs through ``evaluator_for``): wall, CPU and the model's trace."""
    from sensorsel.designs import tradespace
    from sensorsel.designs.robust import select as robust_select
    from sensorsel.io import results

    built: list[TracedDomainEvaluator] = []

    def traced_for(target: Any, engine: str | None = None, *, jobs: int = 1, aggregate: str = "normalised") -> Any:
        ev = TracedDomainEvaluator(target, engine, jobs=jobs, aggregate=aggregate)
        ev._tracing = True
        built.append(ev)
        return ev

    saved = tradespace.evaluator_for, robust_select.evaluator_for
    tradespace.evaluator_for = robust_select.evaluator_for = traced_for  # type: ignore[assignment]
    try:
        c0, t0 = cpu_of_this_process(), time.perf_counter()
        res = _run_command(command, domain, args, jobs=jobs)
        wall, cpu = time.perf_counter() - t0, cpu_of_this_process() - c0
    finally:
        tradespace.evaluator_for, robust_select.evaluator_for = saved
    trace = [t for ev in built for _, t in ev.rounds if t]
    task_cpu = sum(map(sum, trace))
    return {
        "jobs": jobs,
        "wall_s": round(wall, 3),
        "cpu_s": round(cpu, 3),
        "rounds": len(trace),
        "route_calls": sum(map(len, trace)),
        "route_call_cpu_s": round(task_cpu, 3),
        "serial_cpu_s": round(max(0.0, cpu - task_cpu), 3) if jobs == 1 else None,
        "_trace": trace,
        "_result": results.dumps(res),
    }


def _run_command(command: str, domain: Any, args: Any, *, jobs: int = 1, executor: Any = None) -> Any:
    from sensorsel import api

    where = {} if executor is None else {"executor": executor}
    if command == "pareto":
        budgets = [float(b) for b in args.pareto_budgets.split(",")]
        return api.run_tradespace(domain, budgets, jobs=jobs, **where)
    if command == "robust":
        return api.run_robust(domain, args.budget, 1, jobs=jobs, **where)
    raise ValueError(command)


def run_command_on_cluster(command: str, domain: Any, args: Any, workers: int) -> dict[str, Any]:
    """The command's plan (pareto's rule chains, robust's methods) as tasks on a LocalCluster."""
    from sensorsel.io import results
    from sensorsel.pipeline.cluster import DaskCluster

    with DaskCluster(workers=workers, echo=lambda line: None) as cluster:
        client = cluster.client
        w0, s0 = client.run(cpu_of_this_process), client.run_on_scheduler(cpu_of_this_process)
        c0, t0 = cpu_of_this_process(), time.perf_counter()
        res = _run_command(command, domain, args, executor=cluster.executor)
        wall, client_cpu = time.perf_counter() - t0, cpu_of_this_process() - c0
        w1, s1 = client.run(cpu_of_this_process), client.run_on_scheduler(cpu_of_this_process)
    return {
        "workers": workers,
        "wall_s": round(wall, 3),
        "client_cpu_s": round(client_cpu, 3),
        "workers_cpu_s": round(sum(w1[a] - w0[a] for a in w1), 3),
        "scheduler_cpu_s": round(s1 - s0, 3),
        "_result": results.dumps(res),
    }


def command_rows(command: str, domain: Any, args: Any) -> dict[str, Any]:
    """One command's rows: in-process on each --jobs, on each LocalCluster, the model and the check."""
    runs = [run_command_in_process(command, domain, args, int(j)) for j in args.jobs.split(",") if j]
    clusters = [run_command_on_cluster(command, domain, args, int(w)) for w in args.workers.split(",") if w]
    base = runs[0]
    same = all(untimed(r["_result"]) == untimed(base["_result"]) for r in runs + clusters)
    traces = {r["jobs"]: r["_trace"] for r in runs}
    m = model(base["_trace"], base["serial_cpu_s"] or 0.0, traces=traces)
    m_one = model(base["_trace"], base["serial_cpu_s"] or 0.0)
    checks = [
        {
            "run": f"{r['jobs']} threads",
            "measured_speedup": round(base["wall_s"] / r["wall_s"], 2),
            "predicted_round_aware": m.get(f"at_{r['jobs']}", {}).get("round_aware_speedup"),
        }
        for r in runs[1:]
    ]
    checks += [
        {"run": f"{c['workers']} workers", "measured_speedup": round(base["wall_s"] / c["wall_s"], 2)} for c in clusters
    ]
    for r in runs:
        print(f"{command}, {r['jobs']} thread(s): {r['wall_s']:.2f} s wall, {r['cpu_s']:.2f} s CPU", file=sys.stderr)
    for c in clusters:
        print(
            f"{command}, {c['workers']} worker(s): {c['wall_s']:.2f} s wall, client CPU {c['client_cpu_s']:.2f} s, "
            f"workers CPU {c['workers_cpu_s']:.2f} s",
            file=sys.stderr,
        )
    return {
        "same_result": same,
        "model": {"in_process": m, "in_process_one_thread_trace": m_one},
        "model_check": checks,
        "in_process": [{k: v for k, v in r.items() if not k.startswith("_")} for r in runs],
        "cluster": [{k: v for k, v in c.items() if not k.startswith("_")} for c in clusters],
    }


def run_require(domain: Any, args: Any, *, jobs: int = 1, workers: int = 0) -> dict[str, Any]:
    """The domain's ``require`` (``--require-preset``, ``--require-failures``, the map model at 0.05 m,
    the filter's estimate) in-process on ``jobs`` threads, or with each route's accuracy on the
    workers of a LocalCluster of ``workers`` (``evaluator=``, as ``require --workers`` runs it): wall,
    CPU here (and on the workers), the integer programs and accuracy computations and the time in
    each, and on a cluster the messages and bytes per integer program."""
    from sensorsel import api
    from sensorsel.io import results

    spec = api.preset(args.require_preset)
    kw = {"map_sigma_m": 0.05, "failures": args.require_failures, "jobs": jobs}
    row: dict[str, Any] = {"jobs": jobs} if not workers else {"workers": workers}
    if not workers and jobs == 1:  # traced: each question's seconds on each route (the same answers)
        ev = TracedDomainEvaluator(domain, jobs=1)
        ev._tracing = True
        c0, t0 = cpu_of_this_process(), time.perf_counter()
        res = api.run_require(domain, spec, evaluator=ev, **kw)
        cpu = cpu_of_this_process() - c0
        row.update(wall_s=round(time.perf_counter() - t0, 3), cpu_s=round(cpu, 3))
        serial = max(0.0, cpu - sum(sum(r.values()) for r in ev.route_rounds))
        # the package's placement of routes on worker processes and workers: its cost model of a route
        from sensorsel.information.evaluators.distributed import _route_cost

        costs = [float(_route_cost(r.problem)) for r in domain.routes]
        row["_model"] = pinned_model([r for r in ev.route_rounds if r], serial, len(domain.routes), costs)
    elif not workers:
        c0, t0 = cpu_of_this_process(), time.perf_counter()
        res = api.run_require(domain, spec, **kw)
        row.update(wall_s=round(time.perf_counter() - t0, 3), cpu_s=round(cpu_of_this_process() - c0, 3))
    else:
        from sensorsel.information.evaluators.distributed import DistributedDomainEvaluator
        from sensorsel.pipeline.cluster import DaskCluster

        with DaskCluster(workers=workers, echo=lambda line: None) as cluster:
            client = cluster.client
            ev = DistributedDomainEvaluator(client, domain)
            w0 = client.run(cpu_of_this_process)
            c0, t0 = cpu_of_this_process(), time.perf_counter()
            res = api.run_require(domain, spec, evaluator=ev, **kw)
            row.update(wall_s=round(time.perf_counter() - t0, 3), cpu_s=round(cpu_of_this_process() - c0, 3))
            w1 = client.run(cpu_of_this_process)
            programs = max(1, res.iterations)
            row.update(
                workers_cpu_s=round(sum(w1[a] - w0[a] for a in w1), 3),
                messages=ev.n_messages,
                messages_per_program=round(ev.n_messages / programs, 1),
                bytes_per_program=round((ev.bytes_sent + ev.bytes_received) / programs, 1),
                client_wait_s=round(ev.wait_s, 3),
            )
    row.update(
        status=res.status,
        cost_usd=res.cost_usd,
        integer_programs=res.iterations,
        accuracy_computations=res.n_checks,
        seconds_checks=round(res.seconds_checks, 3),
        seconds_programs=round(res.seconds_programs, 3),
        _result=results.dumps(res),
    )
    return row


def require_rows(domain: Any, args: Any) -> dict[str, Any]:
    """``require``'s rows: in-process on each --jobs, on each LocalCluster, and whether every run gave
    the same result (its timings aside)."""
    runs = [run_require(domain, args, jobs=int(j)) for j in args.jobs.split(",") if j]
    runs += [run_require(domain, args, workers=int(w)) for w in args.workers.split(",") if w]
    base = runs[0]
    for r in runs:
        where = f"--jobs {r['jobs']}" if "jobs" in r else f"{r['workers']} worker(s)"
        print(
            f"require, {where}: {r['wall_s']:.2f} s wall, {r['cpu_s']:.2f} s CPU here, {r['integer_programs']} "
            f"integer programs, {r['accuracy_computations']} accuracy computations ({r['seconds_checks']:.1f} s)",
            file=sys.stderr,
        )
    model = base.get("_model")
    checks = []
    if model is not None:
        for r in runs[1:]:
            at = model.get(f"at_{r.get('jobs') or r.get('workers')}", {})
            checks.append(
                {
                    "run": f"--jobs {r['jobs']}" if "jobs" in r else f"{r['workers']} workers",
                    "measured_speedup": round(base["wall_s"] / r["wall_s"], 2),
                    "predicted_pinned": at.get("pinned_speedup"),
                }
            )
    return {
        "preset": args.require_preset,
        "failures": args.require_failures,
        "model": model,
        "model_check": checks,
        "same_result": all(untimed(r["_result"]) == untimed(base["_result"]) for r in runs),
        "speedup": {
            (f"{r['jobs']} threads" if "jobs" in r else f"{r['workers']} workers"): round(
                base["wall_s"] / r["wall_s"], 2
            )
            for r in runs[1:]
        },
        "runs": [{k: v for k, v in r.items() if not k.startswith("_")} for r in runs],
    }


def generated_domain(folder: Path, n: int) -> str:
    """A domain file of ``n`` routes: the bundled tiny route, with synthetic landmarks of seeds 1..n."""
    data = REPO / "data" / "kitti_fixtures"
    tiny = f"route: {data / 'poses' / 'tiny.txt'}, format: kitti, times: {data / 'sequences' / 'tiny' / 'times.txt'}"
    lines = ["keyframe_rate_hz: 1.0", "routes:"]
    lines += [
        f"  - {{name: tiny-{seed:03d}, {tiny}, landmarks: {{synthetic: {{seed: {seed}}}}}}}" for seed in range(1, n + 1)
    ]
    path = folder / f"generated-{n}.yaml"
    path.write_text("\n".join(lines) + "\n")
    return str(path)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--domain", default=str(REPO / "configs" / "domain_kitti.yaml"))
    ap.add_argument("--budget", type=float, default=110_000.0)
    ap.add_argument("--rule", default="uniform")
    ap.add_argument("--jobs", default=f"1,{os.cpu_count() or 1}", help="thread counts in-process (comma-separated)")
    ap.add_argument("--workers", default="1,2", help="LocalCluster sizes (comma-separated; empty: none)")
    ap.add_argument("--processes", default="2", help="worker-process counts in-process (comma-separated; empty: none)")
    ap.add_argument(
        "--repeat", type=int, default=1, help="greedy runs on each set of worker processes (warm after the first)"
    )
    ap.add_argument("--generated", type=int, default=0, help="measure a generated domain of N routes instead")
    ap.add_argument(
        "--model-at",
        default=",".join(map(str, PREDICT_AT)),
        help="thread counts whose greedy runs' traces make the model (comma-separated)",
    )
    ap.add_argument("--commands", default="greedy", help="greedy, pareto, robust, require (comma-separated)")
    ap.add_argument("--require-preset", default="local-streets", help="require's preset (default local-streets)")
    ap.add_argument("--require-failures", type=int, default=0, help="require's failures (default 0)")
    ap.add_argument("--pareto-budgets", default="20000,50000,110000", help="pareto's budgets (comma-separated) [$]")
    ap.add_argument(
        "--whole",
        action="store_true",
        help="in-process, also the certificate and the per-route breakdown (what greedy --domain runs)",
    )
    ap.add_argument(
        "--ahead-from",
        type=int,
        default=None,
        help="the fewest threads or workers a lazy round scores ahead on (default: the package's)",
    )
    args = ap.parse_args()
    if args.ahead_from is not None:  # this script's own evaluators only (workers build theirs from the package)
        TracedDomainEvaluator.ahead_from = args.ahead_from
    if args.generated:
        import tempfile

        args.domain = generated_domain(Path(tempfile.mkdtemp(prefix="sensorsel-bench-")), args.generated)

    from sensorsel.model.problem import load_domain

    out: dict[str, Any] = {
        "domain": args.domain,
        "budget_usd": args.budget,
        "rule": args.rule,
        "cpus": os.cpu_count(),
        "load_avg_before": os.getloadavg(),
    }
    m0, t0 = rss(), time.perf_counter()
    domain = load_domain(args.domain)
    out["routes"] = len(domain.routes)
    out["load_s"] = round(time.perf_counter() - t0, 3)
    out["client_rss_of_the_loaded_domain_bytes"] = rss() - m0  # the client holds every route's problem
    run_in_process(domain, args.budget, args.rule, 1, False)  # warm-up, not reported: first imports and caches
    runs = [run_in_process(domain, args.budget, args.rule, int(j), args.whole) for j in args.jobs.split(",") if j]
    for r in runs:
        print(
            f"in-process, {r['jobs']} thread(s): greedy {r['greedy_wall_s']:.2f} s wall, {r['greedy_cpu_s']:.2f} s "
            "CPU, "
            f"{r['rounds']} rounds, serial {r['serial_wall_s']:.2f} s wall",
            file=sys.stderr,
        )
    base = runs[0]
    procs = [
        run_on_processes(domain, args.budget, args.rule, int(p), args.repeat) for p in args.processes.split(",") if p
    ]
    for p in procs:
        print(
            f"in-process, {p['processes']} worker process(es): greedy {p['greedy_wall_s']:.2f} s wall "
            f"({base['greedy_wall_s'] / p['greedy_wall_s']:.2f}x one thread), client CPU {p['client_cpu_s']:.2f} s, "
            f"workers CPU {p['workers_cpu_s']:.2f} s, {p['rounds']} rounds, "
            f"{p['route_calls_scored_ahead_used']}/{p['route_calls_scored_ahead']} scored ahead used"
            + (f"; again (warm): {p['greedy_wall_again_s']} s" if p["greedy_wall_again_s"] else ""),
            file=sys.stderr,
        )
    clusters = [run_on_cluster(domain, args.budget, args.rule, int(w)) for w in args.workers.split(",") if w]
    for c in clusters:
        print(
            f"{c['workers']} worker(s): greedy {c['greedy_wall_s']:.2f} s wall, client CPU {c['client_cpu_s']:.2f} s, "
            f"workers CPU {c['workers_cpu_s']:.2f} s, {c['messages_per_step']} messages/step, "
            f"{c['bytes_sent_per_step'] + c['bytes_received_per_step']:.0f} B/step",
            file=sys.stderr,
        )

    def parts(text: str) -> list[object]:
        first, *rest = text.split("\x00")
        return [untimed(first), *rest]

    same = all(parts(r["_result"]) == parts(base["_result"]) for r in runs) and all(
        untimed(c["_result"]) == parts(base["_result"])[0] for c in clusters + procs
    )
    out["same_result"] = same
    trace, serial = [t for t in base["_trace"] if t], base["serial_cpu_s"]  # rounds with work (none: nothing sent)
    traces = {r["jobs"]: [t for t in r["_trace"] if t] for r in runs}
    for n in [int(x) for x in args.model_at.split(",") if x]:
        if n not in traces:  # a traced run on n threads (the machine's cores take turns; each call's CPU is its own)
            traces[n] = [t for t in run_in_process(domain, args.budget, args.rule, n, False)["_trace"] if t]
    out["model"] = {
        "in_process": model(trace, serial, traces=traces),
        "in_process_one_thread_trace": model(trace, serial),
    }
    if args.whole:  # the whole command in-process: the three stages' rounds and serial parts together
        stages = [base, base["certificate"], base["breakdown"]]
        whole_trace = [t for st in stages for t in st["_trace"] if t]
        out["model"]["in_process_whole_command"] = model(whole_trace, sum(st["serial_cpu_s"] for st in stages))
        for name in ("certificate", "breakdown"):
            st = base[name]
            out["model"][f"in_process_{name}"] = model([t for t in st["_trace"] if t], st["serial_cpu_s"])
        for r in runs:
            for name in ("certificate", "breakdown"):
                r[name] = {k: v for k, v in r[name].items() if not k.startswith("_")}
    # a cluster's communication per round: the client's CPU per round beyond the greedy's own serial
    # work (pickling, sending, gathering; a LocalCluster's scheduler runs in the client's process and
    # is counted there): what a round costs on quiet cores (the model's c). The wall time the client
    # waited beyond the slower worker's scoring, per round, is reported beside it: on a loaded
    # machine it is mostly waiting for a core
    for c in clusters:
        scoring = max(c["workers_scoring_s"].values(), default=0.0)
        c["comm_cpu_per_round_ms"] = round(1e3 * max(0.0, c["client_cpu_s"] - serial) / max(1, c["rounds"]), 3)
        c["comm_wall_per_round_ms"] = round(1e3 * max(0.0, c["client_wait_s"] - scoring) / max(1, c["rounds"]), 3)
    if clusters:
        comm = max(c["comm_cpu_per_round_ms"] for c in clusters) / 1e3
        out["model"]["cluster"] = model(trace, serial, comm, traces=traces)
    checks = []
    for r in runs[1:]:
        pred = (
            out["model"]["in_process"][f"at_{r['jobs']}"] if f"at_{r['jobs']}" in out["model"]["in_process"] else None
        )
        checks.append(
            {
                "run": f"{r['jobs']} threads",
                "measured_speedup": round(base["greedy_wall_s"] / r["greedy_wall_s"], 2),
                "predicted_round_aware": pred and pred["round_aware_speedup"],
                "predicted_amdahl": pred and pred["amdahl_speedup"],
            }
        )
    for p in procs:
        checks.append(
            {
                "run": f"{p['processes']} worker processes",
                "measured_speedup": round(base["greedy_wall_s"] / p["greedy_wall_s"], 2),
            }
        )
    for c in clusters:
        pred = out["model"]["cluster"].get(f"at_{c['workers']}")
        checks.append(
            {
                "run": f"{c['workers']} workers",
                "measured_speedup": round(base["greedy_wall_s"] / c["greedy_wall_s"], 2),
                "predicted_round_aware": pred and pred["round_aware_speedup"],
            }
        )
    if args.whole:
        for r in runs[1:]:
            w = [x["greedy_wall_s"] + x["certificate"]["wall_s"] + x["breakdown"]["wall_s"] for x in (base, r)]
            pred = out["model"]["in_process_whole_command"].get(f"at_{r['jobs']}")
            checks.append(
                {
                    "run": f"whole command, {r['jobs']} threads",
                    "measured_speedup": round(w[0] / w[1], 2),
                    "predicted_round_aware": pred and pred["round_aware_speedup"],
                }
            )
    out["model_check"] = checks
    out["in_process"] = [{k: v for k, v in r.items() if not k.startswith("_")} for r in runs]
    out["processes"] = [{k: v for k, v in p.items() if not k.startswith("_")} for p in procs]
    out["cluster"] = [{k: v for k, v in c.items() if not k.startswith("_")} for c in clusters]
    for command in [c for c in args.commands.split(",") if c and c != "greedy"]:
        out[command] = require_rows(domain, args) if command == "require" else command_rows(command, domain, args)
    out["load_avg_after"] = os.getloadavg()
    print(f"same result everywhere: {same}", file=sys.stderr)
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
