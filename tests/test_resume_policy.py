"""One resume policy for every design run, as ``--resume``'s help says.

Each design run (greedy, pareto, resilient, robust, optimal, study, require) is given, under its
``-o``, what another run left there: the stored results of a run with another budget (another
engine for a study, whose cells are named by their budget), written by the command itself where it
keeps them, else by the library call it runs (greedy, robust, optimal and require delete their store
once their result is written). Then the command runs with ``--resume``. Everywhere the same: exit 0,
a one-line warning naming a file of the store and saying it is not reused, no error, and the answer
of a fresh run of the same command (the JSON without timings and evaluation counts).

Remove the warning from ``sensorsel.pipeline.store.load_matching`` and every case fails; make one
store refuse (raise) and its case fails with exit 2.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml
from click.testing import CliRunner

from sensorsel.cli import cli
from sensorsel.io.resources import default_library_path

REPO = Path(__file__).resolve().parents[1]
STUDY = (
    "target: {fixture: tiny}\ngrid:\n  budgets: [5000]\n  rules: [uniform]\n  failures: [0, 1]\ncertificate: false\n"
)

#: run -> (its arguments, OUT: the output; where its store's files are; keys not compared)
RUNS = {
    "greedy": (
        ["greedy", "--fixture", "tiny", "--budget", "6000", "-o", "OUT/design.json"],
        "design.json.checkpoint",
        {"seconds", "n_evaluations"},
    ),
    "pareto": (
        [
            "pareto",
            "--fixture",
            "tiny",
            "--budgets",
            "3000,6000",
            "--rules",
            "uniform",
            "--plot-format",
            "svg",
            "--output-dir",
            "OUT",
        ],
        "runs/rule-*.json",
        {"seconds"},
    ),
    "resilient": (
        [
            "resilient",
            "--fixture",
            "tiny",
            "--budget",
            "6000",
            "--failures",
            "1",
            "--period",
            "6",
            "--plot-format",
            "svg",
            "--output-dir",
            "OUT",
        ],
        "periods/period-*.json",
        {"seconds"},
    ),
    "robust": (
        [
            "robust",
            "--fixture",
            "tiny",
            "--budget",
            "6000",
            "--failures",
            "1",
            "--rules",
            "uniform",
            "--methods",
            "oblivious",
            "-o",
            "OUT/robust.json",
        ],
        "robust.json.tasks/*.json",
        {"seconds"},
    ),
    "optimal": (
        ["optimal", "--fixture", "tiny", "--budget", "6000", "--max-nodes", "100", "-o", "OUT/optimal.json"],
        "optimal.json.checkpoint",
        {"seconds", "n_evaluations"},
    ),
    "study": (["study", "STUDY", "--output-dir", "OUT"], "cells/cell-*.json", {"seconds", "n_reused"}),
    # on Table I with four clock positions (22 sensors), a loose specification: a short search
    "require": (
        [
            "require",
            "--fixture",
            "tiny",
            "--library",
            "SMALL",
            "--lateral",
            "0.5",
            "--longitudinal",
            "0.5",
            "--budget",
            "50000",
            "-o",
            "OUT/require.json",
        ],
        "require.json.checkpoint",
        {"seconds", "seconds_checks", "seconds_programs", "n_checks", "n_refuted"},
    ),
}


def _args(run: str, out: Path, study: Path) -> list[str]:
    args = RUNS[run][0]
    small = str(study.with_name("small.yaml"))
    return [
        str(out) + a[3:] if a.startswith("OUT") else str(study) if a == "STUDY" else small if a == "SMALL" else a
        for a in args
    ] + ["-q"]


def _invoke(args: list[str]):
    return CliRunner().invoke(cli, args, catch_exceptions=False)


def _answer(text: str, ignore: set[str]) -> object:
    def rec(o: object) -> object:
        if isinstance(o, dict):
            return {k: rec(v) for k, v in o.items() if k not in ignore}
        return [rec(v) for v in o] if isinstance(o, list) else o

    return rec(json.loads(text))


def _another_run(run: str, out: Path, study: Path, tiny_problem) -> None:
    """Leave under ``out`` what a run of other inputs (a $5,000 budget; another engine for the study) stores."""
    if run in ("pareto", "resilient"):
        args = _args(run, out, study)
        args[args.index("6000") if "6000" in args else args.index("3000,6000")] = {"pareto": "3000,5000"}.get(
            run, "5000"
        )
        assert _invoke(args).exit_code == 0
    elif run == "study":
        other = study.with_name("other.yaml")
        other.write_text(STUDY + "engine: reference\n")
        assert _invoke(["study", str(other), "--output-dir", str(out), "-q"]).exit_code == 0
    elif run == "greedy":
        from sensorsel.api import run_greedy

        run_greedy(tiny_problem, 5_000, checkpoint=out / "design.json.checkpoint")
    elif run == "robust":
        from sensorsel.api import run_robust

        run_robust(tiny_problem, 5_000, 1, rules=("uniform",), methods=("oblivious",), outdir=out / "robust.json.tasks")
    elif run == "optimal":
        from sensorsel.designs.certify import optimal
        from sensorsel.information.evaluators import evaluator_for

        optimal(
            evaluator_for(tiny_problem),
            5_000,
            max_nodes=100,
            info=tiny_problem.info,
            checkpoint=out / "optimal.json.checkpoint",
        )
    else:
        from sensorsel.designs.requirements import DEFAULT_MAP_SIGMA_M, Specification, require
        from sensorsel.model.library import load_library
        from sensorsel.model.problem import build_problem

        problem = build_problem(load_library(study.with_name("small.yaml")), tiny_problem.scenario)
        require(
            problem,
            Specification(lateral=0.5, longitudinal=0.5),
            map_sigma_m=DEFAULT_MAP_SIGMA_M,
            budget_usd=40_000,
            checkpoint=out / "require.json.checkpoint",
        )


@pytest.mark.parametrize("run", list(RUNS))
def test_every_design_run_resumes_on_another_runs_store_the_same_way(run, tiny_problem, tmp_path):
    study = tmp_path / "study.yaml"
    study.write_text(STUDY)
    small = yaml.safe_load(default_library_path().read_text())
    small["clock_positions"] = [12, 3, 6, 9]
    study.with_name("small.yaml").write_text(yaml.safe_dump(small))
    _, stored, ignore = RUNS[run]
    out = tmp_path / "out"
    out.mkdir()
    _another_run(run, out, study, tiny_problem)
    files = sorted(out.glob(stored))
    assert files, f"{run}: the other run stored nothing under {stored}"

    res = _invoke(_args(run, out, study) + ["--resume", "--json"])
    assert res.exit_code == 0, res.output
    assert "sensorsel: error" not in res.stderr and "Traceback" not in res.stderr
    warned = [ln for ln in res.stderr.splitlines() if ln.startswith("sensorsel: warning:")]
    assert warned, res.stderr
    assert all("not reused" in ln and "recomputing and overwriting it" in ln for ln in warned), warned
    assert {ln.split(": ")[2] for ln in warned} & {str(f) for f in files}  # it names a file of the store

    fresh = _invoke(_args(run, tmp_path / "fresh", study) + ["--json"])
    assert fresh.exit_code == 0, fresh.output
    assert _answer(res.stdout, ignore) == _answer(fresh.stdout, ignore)


def test_the_resume_help_says_what_every_run_does():
    """The shared --resume help: matching results read back, the others warned and computed again."""
    for run in RUNS:
        (opt,) = [p for p in cli.commands[run].params if p.name == "resume"]
        assert "a warning names the file" in (opt.help or "") and "computed again and overwritten" in (opt.help or "")


def test_a_resumed_require_says_its_counts_are_its_own(tiny_problem, tmp_path):
    """A require resumed from its own interrupted run's journal reads the answers back and says so
    in its printout and its JSON (``n_resumed``): the accuracy computations and seconds it prints are
    this run's alone, not the whole search's; so are the integer programs' solutions it read back
    (``n_programs_resumed``). The interrupted run is the library call with a budget
    of 50_000 (an int; the command's is a float): the journal's fingerprint takes them as one budget
    (hash the budget as given and the resume is warned about and starts afresh)."""
    from sensorsel.designs.requirements import DEFAULT_MAP_SIGMA_M, Specification, require
    from sensorsel.io import results
    from sensorsel.model.library import load_library
    from sensorsel.model.problem import build_problem

    study = tmp_path / "study.yaml"
    small = yaml.safe_load(default_library_path().read_text())
    small["clock_positions"] = [12, 3, 6, 9]
    study.with_name("small.yaml").write_text(yaml.safe_dump(small))
    out = tmp_path / "out"
    out.mkdir()
    ck = out / "require.json.checkpoint"

    class Stop(KeyboardInterrupt):
        pass

    reports = []

    def stop(done: int, total: int) -> None:
        reports.append(done)
        if len(reports) == 2:
            raise Stop()

    problem = build_problem(load_library(study.with_name("small.yaml")), tiny_problem.scenario)
    with pytest.raises(Stop):  # the same inputs as the command's, interrupted at its second progress report
        require(
            problem,
            Specification(lateral=0.5, longitudinal=0.5),
            map_sigma_m=DEFAULT_MAP_SIGMA_M,
            budget_usd=50_000,
            checkpoint=ck,
            progress=stop,
        )
    journal = results.load(ck, "requirement-journal")
    n, m = len(journal.answers), len(journal.programs)
    assert n > 0 and m > 0
    res = _invoke(_args("require", out, study) + ["--resume"])
    assert res.exit_code == 0, res.output
    assert "warning" not in res.stderr  # its own journal: read back, not warned about
    said = json.loads((out / "require.json").read_text())
    assert said["n_resumed"] == n and said["n_programs_resumed"] >= m
    k = said["n_programs_resumed"]  # the programs it solved, read back, not solved again
    assert (
        f"resumed from {n} answers of an earlier run, not counted here, and {k} of its integer programs' solutions"
        in (res.stdout)
    )
    fresh = _invoke(_args("require", tmp_path / "fresh", study))
    assert fresh.exit_code == 0 and "resumed" not in fresh.stdout


def test_a_require_stopped_at_its_time_limit_keeps_its_journal_and_resume_goes_on(tmp_path):
    """The bundled route with one failure takes ~20 s to prove: stopped at 4 s, its gap is written and
    its journal kept, and --resume reads every answer of it back; a proved answer removes it. (The
    limit lies between the first suite, found at ~0.9 s on an idle 2-core machine, and the proof, with
    room on either side for a machine four times slower or faster: at 1 s two test runs side by side
    stopped before any suite was found.)"""
    from sensorsel.io import results

    out, ck = tmp_path / "r.json", tmp_path / "r.json.checkpoint"
    args = ["require", "--preset", "local-streets", "--failures", "1", "--time-limit", "4", "-q", "-o", str(out)]
    first = CliRunner().invoke(cli, args)
    assert first.exit_code == 0, first.output
    assert json.loads(out.read_text())["status"] == "gap" and ck.is_file()
    n = len(results.load(ck, "requirement-journal").answers)
    again = CliRunner().invoke(cli, [*args, "--resume"])
    assert again.exit_code == 0, again.output
    assert json.loads(out.read_text())["n_resumed"] == n > 0
    proved = CliRunner().invoke(cli, ["require", "--preset", "freeway", "-q", "-o", str(out)])
    assert proved.exit_code == 0 and json.loads(out.read_text())["status"] == "optimal" and not ck.exists()
