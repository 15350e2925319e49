"""Domains and sweeps on a real Dask cluster (loopback only, bounded, stopped by the tests).

One LocalCluster of 2 worker processes serves the in-module tests; one test starts `dask scheduler`
and two `dask worker` processes itself and runs the CLI against them. Results must be the bytes of
the in-process run, timings aside.
"""

from __future__ import annotations

import dataclasses
import json
import os
import signal
import socket
import subprocess
import sys
from pathlib import Path

import pytest

distributed = pytest.importorskip("distributed")

from domains import untimed  # noqa: E402

from sensorsel.api import (  # noqa: E402
    design_domain,
    suite_accuracy,
    suite_integrity,
)
from sensorsel.designs.tradespace import run_tradespace  # noqa: E402
from sensorsel.information.evaluators.distributed import DistributedDomainEvaluator  # noqa: E402
from sensorsel.io import results  # noqa: E402
from sensorsel.model.problem import load_domain  # noqa: E402
from sensorsel.pipeline.cluster import DaskCluster  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
FIXTURES = REPO / "configs" / "domain_fixtures.yaml"
BIN = Path(sys.executable).parent
ENV = {**os.environ, "PYTHONPATH": str(REPO / "src") + os.pathsep + os.environ.get("PYTHONPATH", "")}


@pytest.fixture(scope="module")
def domain():
    return load_domain(FIXTURES)


@pytest.fixture(scope="module")
def cluster():
    with DaskCluster(workers=2, echo=lambda line: None) as c:
        yield c


def test_domain_greedy_on_two_workers_equals_in_process(cluster, domain):
    local = design_domain(domain, 12_000, certify=True)
    ev = DistributedDomainEvaluator(cluster.client, domain)
    remote = design_domain(domain, 12_000, certify=True, evaluator=ev)
    assert untimed(remote) == untimed(local)
    assert ev.step_bytes and max(s + r for s, r in ev.step_bytes) < 2_000  # suites and numbers, never matrices


def test_tradespace_rules_as_tasks_equal_in_process_and_resume(cluster, domain, tmp_path):
    grid, rules = [4_000, 12_000], ["best-of"]  # its two component rules: two tasks
    local = untimed(run_tradespace(domain, grid, rules))
    assert untimed(run_tradespace(domain, grid, rules, executor=cluster.executor, outdir=str(tmp_path))) == local
    files = sorted((tmp_path / "runs").glob("rule-*.json"))
    assert len(files) == 2
    stamps = [f.stat().st_mtime_ns for f in files]
    assert (
        untimed(run_tradespace(domain, grid, rules, executor=cluster.executor, outdir=str(tmp_path), resume=True))
        == local
    )
    assert [f.stat().st_mtime_ns for f in files] == stamps  # finished rules were read back, not run again


def test_resilient_periods_as_tasks_equal_in_process_and_resume(cluster, tmp_path):
    from sensorsel.designs.resilient import resilient_report
    from sensorsel.model.problem import load_problem
    from sensorsel.model.scenario import ScenarioSpec

    problem = load_problem(ScenarioSpec(fixture="suburb"))
    local = resilient_report(problem, 8_000, 1, period_s=20.0, outdir=tmp_path / "here")
    there = tmp_path / "there"
    remote = resilient_report(problem, 8_000, 1, period_s=20.0, outdir=str(there), executor=cluster.executor)
    assert untimed(remote) == untimed(local)
    files = sorted((there / "periods").glob("period-*.json"))
    assert len(files) == len(local.per_period.periods) > 1
    stamps = [f.stat().st_mtime_ns for f in files]
    again = resilient_report(
        problem, 8_000, 1, period_s=20.0, outdir=str(there), resume=True, executor=cluster.executor
    )
    assert untimed(again) == untimed(local)
    assert [f.stat().st_mtime_ns for f in files] == stamps  # finished periods were read back, not recomputed


def test_greedy_interrupted_in_process_resumes_on_two_workers(cluster, domain, tmp_path):
    from sensorsel.api import design_domain as design_with_checkpoint

    def counts_aside(obj: object) -> object:
        def rec(o: object) -> object:
            if isinstance(o, dict):
                return {k: rec(v) for k, v in o.items() if k != "n_evaluations"}
            return [rec(v) for v in o] if isinstance(o, list) else o

        return rec(untimed(obj))

    whole = design_domain(domain, 12_000, certify=True)
    ck = tmp_path / "design.json.checkpoint"

    def interrupt(done: int, total: int) -> None:
        if done == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        design_with_checkpoint(domain, 12_000, certify=True, checkpoint=ck, progress=interrupt)
    ev = DistributedDomainEvaluator(cluster.client, domain)
    resumed = design_with_checkpoint(domain, 12_000, certify=True, checkpoint=ck, resume=True, evaluator=ev)
    assert counts_aside(resumed) == counts_aside(whole)
    assert ev.step_bytes  # the steps after the recorded picks were scored on the workers


def test_study_cells_as_tasks_equal_in_process_and_resume(cluster, tmp_path):
    from sensorsel.designs.study import load_study, run_study, study_csv

    path = tmp_path / "study.yaml"
    path.write_text("target: {fixture: suburb}\ngrid:\n  budgets: [4000, 9000]\n  rules: [uniform, marginal]\n")
    study = load_study(path)
    local = run_study(study)
    remote = run_study(study, executor=cluster.executor, outdir=tmp_path / "out")
    assert len(remote.rows) == 4 and untimed(remote) == untimed(local)

    def untimed_csv(text: str) -> list[list[str]]:
        return [line.split(",")[:-1] for line in text.splitlines()]  # seconds is the last column

    assert untimed_csv(study_csv(remote)) == untimed_csv(study_csv(local))
    files = sorted((tmp_path / "out" / "cells").glob("cell-*.json"))
    stamps = [f.stat().st_mtime_ns for f in files]
    again = run_study(study, executor=cluster.executor, outdir=tmp_path / "out", resume=True)
    assert again.n_reused == 4 and [f.stat().st_mtime_ns for f in files] == stamps
    assert untimed(again)["rows"] == untimed(local)["rows"]


def test_score_certify_optimal_robust_on_a_domain_equal_in_process(cluster, domain):
    from sensorsel.api import run_robust, score_domain_suite
    from sensorsel.designs.certify import certify_greedy, optimal
    from sensorsel.designs.selection import greedy
    from sensorsel.information.evaluators import DomainEvaluator

    ev = DistributedDomainEvaluator(cluster.client, domain, aggregate="raw")
    here = DomainEvaluator(domain, aggregate="raw")
    suite = "MRL-roof,HD2K-8,HD2K-2"
    assert untimed(score_domain_suite(domain, suite, aggregate="raw", evaluator=ev)) == untimed(
        score_domain_suite(domain, suite, aggregate="raw")
    )
    res = greedy(here, 6_000, "uniform", info=domain.info)
    assert untimed(certify_greedy(ev, res)) == untimed(certify_greedy(here, res))
    assert untimed(optimal(ev, 3_000, max_nodes=4, info=domain.info)) == untimed(
        optimal(here, 3_000, max_nodes=4, info=domain.info)
    )  # small: a few hundred node evaluations
    kw = dict(rules=("uniform",), methods=(), bound_nodes=5)
    # an evaluator given: one run on it, all methods on one memo (the plan of tasks: tests/test_pipeline.py)
    assert untimed(run_robust(domain, 3_000, 1, aggregate="raw", evaluator=ev, **kw)) == untimed(
        run_robust(domain, 3_000, 1, aggregate="raw", evaluator=DomainEvaluator(domain, aggregate="raw"), **kw)
    )
    worst = DistributedDomainEvaluator(cluster.client, domain)  # the worst route: each route's share of its best
    assert untimed(run_robust(domain, 3_000, 1, aggregate="worst", evaluator=worst, **kw)) == untimed(
        run_robust(domain, 3_000, 1, aggregate="worst", **kw)
    )


def test_simulation_runs_as_tasks_equal_in_process(cluster):
    from sensorsel.model.problem import load_problem
    from sensorsel.model.scenario import ScenarioSpec
    from sensorsel.simulation import simulate

    problem = load_problem(ScenarioSpec(fixture="tiny"))
    done = []
    there = simulate(
        problem, "MRL-roof,HD2K-8", runs=3, seed=5, executor=cluster.executor, progress=lambda d, t: done.append(d)
    )
    here = simulate(problem, "MRL-roof,HD2K-8", runs=3, seed=5)
    assert sorted(done) == [1, 2, 3]

    def untimed_run(r: object) -> object:
        d = untimed(r)
        assert isinstance(d, dict)
        d.pop("timing")
        return d

    assert untimed_run(there) == untimed_run(here)


def test_cli_score_and_simulate_with_workers_print_the_in_process_json(tmp_path):
    score = ["score", "--domain", str(FIXTURES), "--suite", "MRL-roof,HD2K-8", "--json"]
    here, there = _here(*score), _cli(*score, "--workers", "2")
    assert there.returncode == 0 and "LocalCluster of 2 worker processes" in there.stderr, there.stderr
    assert untimed(there.stdout) == untimed(here.stdout)
    sim = [
        "simulate",
        "--fixture",
        "tiny",
        "--suite",
        "MRL-roof,HD2K-8",
        "--runs",
        "2",
        "--jobs",
        "1",
        "--plot-format",
        "svg",
        "--json",
        "-q",
    ]
    here, there = (
        _here(*sim, "--output-dir", str(tmp_path / "here")),
        _cli(*sim, "--output-dir", str(tmp_path / "there"), "--workers", "2"),
    )
    assert there.returncode == 0, there.stderr

    def untimed_runs(text: str) -> object:
        d = untimed(text)
        assert isinstance(d, dict)
        for s in d["simulations"]:
            s.pop("timing")
        return d

    assert untimed_runs(there.stdout) == untimed_runs(here.stdout)


def test_cluster_options_on_one_route_are_a_usage_error_naming_domain():
    # robust runs its methods as tasks on one route too (tests/test_pipeline.py); its worst route needs a domain
    # in this process: the error comes before any cluster starts (a subprocess a case proved nothing more)
    from click.testing import CliRunner

    from sensorsel.cli import cli

    for args in (
        ["certify", "--budget", "5000"],
        ["optimal", "--budget", "5000"],
        ["robust", "--budget", "5000", "--aggregate", "worst"],
        ["score", "--suite", "LRL-roof"],
    ):
        r = CliRunner().invoke(
            cli, [*args, "--fixture", "tiny", "-q" if args[0] != "score" else "--json", "--workers", "2"]
        )
        assert r.exit_code == 2 and "go with --domain FILE" in r.stderr and isinstance(r.exception, SystemExit), (
            args,
            r.stderr,
        )


def test_a_worker_killed_mid_run_loses_nothing(cluster, domain):
    local = design_domain(domain, 20_000)
    ev = DistributedDomainEvaluator(cluster.client, domain)
    pids = cluster.client.run(os.getpid)  # worker address -> pid (processes of this test's cluster)
    killed = []

    def kill_once(done: int, total: int) -> None:
        if not killed and done >= 1:
            where = cluster.client.who_has()  # the actors' keys -> workers
            holder = next(iter(where[ev._actors[0].key]))
            os.kill(pids[holder], signal.SIGKILL)
            killed.append(holder)

    remote = design_domain(domain, 20_000, evaluator=ev, progress=kill_once)
    assert killed and ev.n_rebuilt >= 1
    assert untimed(remote) == untimed(local)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _here(*args: object):
    """The same command in this process (its in-process answer, without a process start)."""
    from click.testing import CliRunner

    from sensorsel.cli import cli

    r = CliRunner().invoke(cli, list(map(str, args)), catch_exceptions=False)
    assert r.exit_code == 0, r.output
    return r


def _cli(*args: object, timeout: float = 120) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [str(BIN / "sensorsel"), *map(str, args)], capture_output=True, text=True, env=ENV, cwd=REPO, timeout=timeout
    )


def test_cli_greedy_on_a_scheduler_and_two_workers_started_here(tmp_path, domain):
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    procs = [
        subprocess.Popen(
            [
                str(BIN / "dask"),
                "scheduler",
                "--host",
                "127.0.0.1",
                "--port",
                str(port),
                "--no-dashboard",
                "--idle-timeout",
                "300",
            ],
            env=ENV,
            cwd=tmp_path,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
    ]
    try:
        for _ in range(2):
            procs.append(
                subprocess.Popen(
                    [
                        str(BIN / "dask"),
                        "worker",
                        address,
                        "--host",
                        "127.0.0.1",
                        "--nthreads",
                        "1",
                        "--no-dashboard",
                        "--death-timeout",
                        "60",
                    ],
                    env=ENV,
                    cwd=tmp_path,
                    stdout=subprocess.DEVNULL,
                    stderr=subprocess.DEVNULL,
                )
            )
        with distributed.Client(address, timeout=30) as client:
            client.wait_for_workers(2, timeout=60)
        args = ["greedy", "--domain", str(FIXTURES), "--budget", "12000", "--json", "-q"]
        there = _cli(*args, "--scheduler", address)
        assert there.returncode == 0, there.stderr
        want = design_domain(domain, 12_000, certify=True)
        # what --json prints in-process: the design, with its suite's accuracy in metres (the SLAM graph)
        want = dataclasses.replace(
            want,
            greedy=dataclasses.replace(
                want.greedy,
                accuracy=suite_accuracy(domain, want.greedy.suite),
                integrity=suite_integrity(domain, want.greedy.suite),
            ),
        )
        assert untimed(there.stdout) == untimed(want)
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=15)
            except subprocess.TimeoutExpired:
                p.kill()


def test_no_scheduler_is_exit_2_naming_the_address():
    port = _free_port()  # nothing listens there
    r = _cli("greedy", "--domain", str(FIXTURES), "--budget", "20000", "-q", "--scheduler", f"tcp://127.0.0.1:{port}")
    assert r.returncode == 2
    assert f"tcp://127.0.0.1:{port}" in r.stderr and "5 s" in r.stderr and "Traceback" not in r.stderr


_PLAIN_RUN = """
import sys
from sensorsel.cli import cli
try:
    cli(["greedy", "--domain", sys.argv[1], "--budget", "4000", "-q", "--no-certificate"], prog_name="sensorsel")
except SystemExit as e:
    assert not e.code, e.code
print(sorted(m for m in sys.modules if m.split(".")[0] in ("dask", "distributed")))
"""


def test_a_plain_run_does_not_import_dask():
    r = subprocess.run(
        [sys.executable, "-c", _PLAIN_RUN, str(FIXTURES)], capture_output=True, text=True, env=ENV, timeout=120
    )
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip().splitlines()[-1] == "[]"


def test_missing_extra_is_exit_2_with_the_install_hint():
    code = (
        "import sys; sys.modules['distributed'] = None\nfrom sensorsel.cli import cli\n"
        "cli(['greedy', '--domain', sys.argv[1], '--budget', '20000', '-q', '--workers', '2'], prog_name='sensorsel')"
    )
    r = subprocess.run(
        [sys.executable, "-c", code, str(FIXTURES)], capture_output=True, text=True, env=ENV, timeout=120
    )
    assert r.returncode == 2, r.stderr
    assert 'pip install "sensorsel[dask]"' in r.stderr and "Traceback" not in r.stderr


def test_pareto_with_limits_and_slots_on_two_workers_equals_in_process(tmp_path):
    """Limits and slots on a cluster: ``pareto --workers 2`` under a power limit and mounting slots gives the
    bytes of the in-process run (timings aside), and every architecture keeps the limits."""
    import yaml

    from sensorsel.designs.tradespace import TradespaceResult
    from sensorsel.io.resources import default_library_path
    from sensorsel.model.constraints import Constraints, feasible_set
    from sensorsel.model.library import load_library

    stock = yaml.safe_load(default_library_path().read_text())
    stock["clock_positions"] = [12, 3, 6, 9]
    (tmp_path / "small.yaml").write_text(yaml.safe_dump(stock))
    car = tmp_path / "car.yaml"  # extends the stock file with one radar and one camera per position
    car.write_text("extends: small.yaml\nslots:\n  roof: {lidar: 1}\n  clock: {radar: 1, stereo: 1}\n")
    args = [
        "pareto",
        "--fixture",
        "tiny",
        "--engine",
        "fast",
        "--library",
        car,
        "--budgets",
        "5000,20000,110000",
        "--rules",
        "uniform,marginal",
        "--limit",
        "power_w=40",
        "--max-sensors",
        "6",
        "-q",
    ]
    _here(*args, "--jobs", "1", "--output-dir", tmp_path / "here")
    there = _cli(*args, "--workers", "2", "--output-dir", tmp_path / "there", timeout=240)
    assert there.returncode == 0, there.stderr
    a = (tmp_path / "here" / "tradespace.json").read_text()
    b = (tmp_path / "there" / "tradespace.json").read_text()
    assert untimed(b) == untimed(a)
    # and the limits bite and hold: every run's suite fits, and the library's slots were read
    res = results.load(tmp_path / "there" / "tradespace.json", TradespaceResult)
    c = Constraints.of(limits={"power_w": 40.0}, max_sensors=6)
    lib = load_library(car)
    assert res.constraints is not None and res.constraints.limits == c.limits and res.constraints.slots
    assert lib.slots
    tight = 0
    for r in res.runs:
        feas = feasible_set(lib, r.budget_usd, c)
        s = lib.resolve_suite(r.suite)
        assert feas.fits(s), (r.rule, r.budget_usd, feas.violations(s))
        tight += len(s) == 6 or feas.usage(s)[1] > 30  # a limit (not the budget) stopped this run
    assert tight


def test_cli_require_with_workers_gives_the_in_process_answer():
    """require --workers 2 on a domain: each route's accuracy checks on its worker's actor, the same
    answer, bounds and accuracies to the byte as in-process (seconds aside)."""
    keep = ("MRL-roof", "LRR-12", "LRR-6", "HD2K-12", "HD2K-6", "HD2K-3", "WSC-12", "LSC-12")
    from sensorsel.model.library import load_library

    excl = ",".join(sorted(set(load_library().ids) - set(keep)))
    args = ["require", "--domain", str(FIXTURES), "--preset", "freeway", "--exclude", excl, "--json", "-q"]
    here, there = _here(*args), _cli(*args, "--workers", "2", timeout=240)
    assert there.returncode == 0 and "LocalCluster of 2 worker processes" in there.stderr, there.stderr
    a, b = json.loads(here.stdout), json.loads(there.stdout)
    assert a["status"] == "optimal" and a["engine"] == b["engine"] == "fast"
    for key in ("seconds", "seconds_checks", "seconds_programs"):  # wall times
        a.pop(key), b.pop(key)
    assert a == b


def test_require_in_one_condition_on_workers_checks_that_conditions_members(cluster, tmp_path):
    """require --domain D --in fog with --workers: the members checked on the workers are the fog
    ones (the actors hold every member, in the domain's order; the clear ones must be left out).
    Oracle: the in-process answer in fog, which differs from the answer in clear air."""
    from sensorsel.designs.requirements import Specification, require
    from sensorsel.model.constraints import Constraints

    dom = tmp_path / "d.yaml"
    dom.write_text(
        "keyframe_rate_hz: 1.0\nconditions:\n  - {name: fog, fog_visibility_m: 60, share: 0.2}\n"
        "routes:\n  - {name: tiny, fixture: tiny}\n"
    )
    d = load_domain(dom)
    keep = ("LRL-roof", "MRL-roof", "LRR-12", "LRR-6", "MRR-12", "WSC-12", "HD2K-12", "HD2K-6", "LSC-12", "HD2K-3")
    kw = dict(map_sigma_m=0.05, constraints=Constraints(exclude=tuple(sorted(set(d.library.ids) - set(keep)))))
    spec = Specification(lateral=0.06, heading=0.1)  # met in clear air by a suite that misses it in fog
    here = {c: require(d, spec, conditions=(c,), **kw) for c in ("clear", "fog")}
    assert here["clear"].cost_usd < here["fog"].cost_usd
    ev = DistributedDomainEvaluator(cluster.client, d, "fast", aggregate="normalised")
    for c in ("clear", "fog"):
        there = require(d, spec, conditions=(c,), evaluator=ev, **kw)
        assert [r.route for r in there.routes] == [f"tiny/{c}"]
        assert (there.suite, there.cost_usd, there.status) == (here[c].suite, here[c].cost_usd, here[c].status)
        assert there.routes[0].accuracy == here[c].routes[0].accuracy


def test_two_local_clusters_at_once_take_no_fixed_port():
    # without bokeh the scheduler's HTTP server still starts, on 8787 unless told otherwise: the
    # second cluster (a test beside another, two users on one machine) then warns it is taken
    import warnings

    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        with DaskCluster(workers=1, echo=lambda line: None), DaskCluster(workers=1, echo=lambda line: None):
            pass
    assert not [w for w in seen if "already in use" in str(w.message)], [str(w.message) for w in seen]


def test_a_routes_own_error_on_a_worker_is_raised_once_not_repaired_as_a_lost_worker(cluster, domain):
    """Only a worker that is gone is repaired (its routes rebuilt, its calls repeated: the kill test
    above); an error of the routes' own code on a live worker would recur on every try, so it is
    raised at once as what it is, not after rebuilds as "its worker was lost 4 times" (on worker
    processes: tests/test_processes.py)."""
    from sensorsel.pipeline import ClusterError

    ev = DistributedDomainEvaluator(cluster.client, domain)
    rounds = ev.n_rounds
    with pytest.raises(Exception) as got:
        ev._call({0: ("score", ())})  # a caller's bug: the route's method called without its suite
    assert not isinstance(got.value, (ClusterError, OSError)), got.value
    assert "TypeError" in f"{type(got.value).__name__}: {got.value}", got.value
    assert ev.n_rebuilt == 0 and ev.n_rounds == rounds + 1  # one round: no repeat
