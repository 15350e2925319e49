"""How long `sensorsel require` takes to prove its answer, against the solver it had before (kept in
bench/require_reference_solver.py) and against its checks without the upper bounds that accept
suites (:mod:`sensorsel.designs.requirements.accept`), side by side in one process on the same problems.

    python bench/require.py [--kitti-root ../shared/kitti] [--rows tour 03 00 drive helsinki fixtures]
                            [--helsinki DIR/domain.yaml] [--presets local-streets freeway]
                            [--failures 0 1] [--time-limit 300]
                            [--solvers new ahead noaccept nowindows nofloor noswap dense nogreedyfloor nostop reference]

Rows: "tour" is the README's tour (the bundled suburb route), "03" / "00" the KITTI sequences with
their real pole maps, "drive" a user's own drive (KITTI 00's ground truth as a route file, with
generated landmarks), "helsinki" the 31 routes `sensorsel osm --sample helsinki` writes, "fixtures"
the bundled fixtures' domain (configs/domain_fixtures.yaml, two routes: many integer programs on
plateaus of one price); each row is
run for every preset and failure count given, first with the solver of the package, then with the
reference solver behind the same accuracy oracle (so the two differ only in the search); "ahead" is
the package's solver at ``jobs=2`` (one route of ``processes.AHEAD_FROM_KEYFRAMES`` keyframes or more:
a worker process computes the smoother's marginals the greedy likely asks next; the same answer and
counts, its CPU not in this process's); "noaccept"
is the package's solver with the oracle's upper bounds off (every suite the smoother does not refute
gets its own pass, as before they existed); "nowindows" is the package's solver with the oracle's
windows off (no suite decided by the filter's floors and ceilings from a window of the route,
:mod:`sensorsel.information.window_bounds`); "nofloor" is the package's solver with no integer
program carrying the proved lower bound as a row (``programs.FLOOR_AFTER_NODES`` out of reach: every
program proves its optimum by branch and bound, as before); "noswap" is the package's solver
proposing every suite by an integer program (no plateau swap, ``programs.plateau_swap``); "dense" is
the package's solver with the filter's passes dense (no window ever pays:
``filtering.WINDOW_WORTH`` at 0, so the landmarks held are updated at every keyframe);
"nogreedyfloor" is the package's solver with its greedy's candidates evaluated without the
violation's floor (``cheapest_suite(violation_floor=None)``: every candidate the lazy bounds put on
top gets its violation computed); "nostop" is the package's solver with its capped completions never
stopped early (``solver.COMPLETION_GAP_SHARE`` infinite: each completes its suite, as before the
stop existed). Printed per
run: the status, cost and lower bound, integer programs and plateau swaps ("pswaps"), accuracy
computations (and the suites the cheap floor refuted), the answers inferred from dominance among
sensors ("swaps"), the filter passes stopped early ("short") and the
suites accepted by an upper bound without their pass ("accepted"), the time in checks and in
programs, the wall time and the process's CPU time (less sensitive to other work on the machine).
Timings on a shared machine are noisy: compare the two solvers' columns of one run, and the counts,
which do not depend on the machine. To compare with an older version of the package (accuracy oracle
included), run this file from a `git archive` of it in the same session, with PYTHONPATH pointing at
that copy's src/.
"""

from __future__ import annotations

import argparse
import importlib.util
import math
import os
import sys
import time
from dataclasses import fields
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def _reference():
    """cheapest_suite of the reference solver, returning the package's CheapestSuite."""
    spec = importlib.util.spec_from_file_location(
        "require_reference_solver", REPO / "bench" / "require_reference_solver.py"
    )
    ref = importlib.util.module_from_spec(spec)
    assert spec.loader is not None
    sys.modules["require_reference_solver"] = ref  # dataclasses look their module up there
    spec.loader.exec_module(ref)
    from sensorsel.designs.requirements.solver import CheapestSuite

    def cheapest_suite(
        feas,
        meets,
        *,
        failures=0,
        violation=None,
        time_limit=None,
        progress=None,
        status=None,
        max_tie_programs=0,
        dominance=(),
    ):
        r = ref.cheapest_suite(
            feas, meets, failures=failures, violation=violation, time_limit=time_limit, progress=progress
        )
        return CheapestSuite(**{f.name: getattr(r, f.name) for f in fields(r)})

    return cheapest_suite


def _problem(row: str, kitti_root: str, helsinki: str | None):
    from sensorsel.api import load_problem
    from sensorsel.model.problem import load_domain
    from sensorsel.model.scenario.loading import ScenarioSpec

    if row == "tour":
        return load_problem()
    if row == "drive":  # a user's own drive: KITTI 00's ground truth as a route file, generated landmarks
        root = Path(kitti_root)
        times = root / "sequences" / "00" / "times.txt"
        return load_problem(
            ScenarioSpec(
                poses=str(root / "poses" / "00.txt"),
                times=str(times) if times.is_file() else None,
                landmarks="synthetic",
            )
        )
    if row == "helsinki":
        if helsinki is None:
            raise SystemExit(
                "row helsinki: give --helsinki DOMAIN.yaml (written by sensorsel osm --sample helsinki -o DIR)"
            )
        return load_domain(helsinki)
    if row == "fixtures":
        return load_domain(str(REPO / "configs" / "domain_fixtures.yaml"))
    return load_problem(ScenarioSpec(seq=row, kitti_root=kitti_root))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--kitti-root", default=os.environ.get("SENSORSEL_KITTI_ROOT", str(REPO.parent / "shared" / "kitti"))
    )
    ap.add_argument(
        "--rows",
        nargs="+",
        default=["tour", "03", "00"],
        help="tour, 03, 00 (real pole maps), drive (00's ground truth, generated landmarks), helsinki, fixtures",
    )
    ap.add_argument("--helsinki", help="the domain file of `sensorsel osm --sample helsinki -o DIR` (DIR/domain.yaml)")
    ap.add_argument("--presets", nargs="+", default=["local-streets", "freeway"])
    ap.add_argument("--failures", nargs="+", type=int, default=[0, 1])
    ap.add_argument("--time-limit", type=float, default=300.0)
    ap.add_argument(
        "--solvers",
        nargs="+",
        default=["new", "noaccept", "reference"],
        choices=[
            "new",
            "ahead",
            "noaccept",
            "nowindows",
            "nofloor",
            "noswap",
            "dense",
            "nogreedyfloor",
            "nostop",
            "reference",
        ],
    )
    a = ap.parse_args()
    from sensorsel.designs.requirements import design, programs, solver
    from sensorsel.designs.requirements.checks import RouteOracle
    from sensorsel.designs.requirements.spec import DEFAULT_MAP_SIGMA_M, preset
    from sensorsel.information import filtering

    package = design.cheapest_suite
    solvers = {k: package for k in ("new", "ahead", "noaccept", "nowindows", "nofloor", "noswap", "dense", "nostop")}
    solvers["reference"] = _reference()
    solvers["nogreedyfloor"] = lambda *args, **kw: package(*args, **{**kw, "violation_floor": None})
    after, swap, worth = programs.FLOOR_AFTER_NODES, solver._plateau_swap, filtering.WINDOW_WORTH
    share = solver.COMPLETION_GAP_SHARE
    print(
        f"{'row':>5} {'preset':>13} a solver    {'status':>8} {'cost':>9} {'lower':>9} {'programs':>8} {'pswaps':>6} "
        f"{'checks':>6} "
        f"{'refuted':>7} {'swaps':>5} {'short':>5} {'accepted':>8} {'checks s':>8} {'progs s':>8} {'wall s':>7} "
        f"{'cpu s':>7}  suite",
        flush=True,
    )
    for row in a.rows:
        problem = _problem(row, a.kitti_root, a.helsinki)
        for name in a.presets:
            for alpha in a.failures:
                for which in a.solvers:
                    design.cheapest_suite = solvers[which]
                    RouteOracle.accept = which != "noaccept"
                    RouteOracle.window_bounds = which != "nowindows"
                    programs.FLOOR_AFTER_NODES = 1 << 62 if which == "nofloor" else after
                    solver._plateau_swap = (lambda *_: None) if which == "noswap" else swap
                    filtering.WINDOW_WORTH = 0.0 if which == "dense" else worth
                    solver.COMPLETION_GAP_SHARE = math.inf if which == "nostop" else share
                    t0, c0 = time.perf_counter(), time.process_time()
                    try:
                        r = design.require(
                            problem,
                            preset(name),
                            map_sigma_m=DEFAULT_MAP_SIGMA_M,
                            failures=alpha,
                            time_limit_s=a.time_limit,
                            jobs=2 if which == "ahead" else 1,
                        )
                    finally:
                        design.cheapest_suite = package
                        RouteOracle.accept = True
                        RouteOracle.window_bounds = True
                        programs.FLOOR_AFTER_NODES = after
                        solver._plateau_swap = swap
                        filtering.WINDOW_WORTH = worth
                        solver.COMPLETION_GAP_SHARE = share
                    dt, cpu = time.perf_counter() - t0, time.process_time() - c0
                    print(
                        f"{row:>5} {name:>13} {alpha} {which:<9} {r.status:>8} {r.cost_usd:>9,.0f} "
                        f"{r.lower_bound_usd:>9,.0f} "
                        f"{r.iterations:>8} {getattr(r, 'plateau_swaps', 0):>6} "
                        f"{r.n_checks:>6} {r.n_refuted:>7} {getattr(r, 'n_swap_inferred', 0):>5} "
                        f"{getattr(r, 'n_short', 0):>5} {getattr(r, 'n_accepted', 0):>8} {r.seconds_checks:>8.1f} "
                        f"{r.seconds_programs:>8.1f} {dt:>7.1f} {cpu:>7.1f}  {','.join(r.suite) or '-'}",
                        flush=True,
                    )


if __name__ == "__main__":
    sys.exit(main())
