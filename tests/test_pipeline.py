"""One pipeline, run anywhere: every selecting command gives the same answer in this
process, on a LocalCluster of 2 workers, and after a SIGKILL part-way and ``--resume``.

One parametrised test over the commands: each runs on a small fixture. The cluster is one
LocalCluster of 2 worker processes for the module, reached through ``--scheduler`` (the command's
executor); the interrupted run is a real ``sensorsel`` process killed with SIGKILL as soon as its
store holds a first result (a period, a rule's runs, a study cell, a greedy checkpoint), then run
again with ``--resume``. Answers are compared as JSON without timings (and, for greedy, without the
evaluation counts a resume may change: tests/test_checkpoint.py; for require, the accuracy
computations it counts).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from click.testing import CliRunner

from sensorsel.cli import cli

distributed = pytest.importorskip("distributed")

from sensorsel.pipeline.cluster import DaskCluster  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
DOMAIN = str(REPO / "configs" / "domain_fixtures.yaml")
BIN = Path(sys.executable).parent
ENV = {**os.environ, "PYTHONPATH": str(REPO / "src") + os.pathsep + os.environ.get("PYTHONPATH", "")}
STUDY = "target: {fixture: suburb}\ngrid:\n  budgets: [4000, 9000]\n  rules: [uniform, marginal]\n"

ODD_CLOCK = ",".join(f"{m}-{h}" for m in ("LRR", "MRR", "WSC", "HD2K", "LSC") for h in (1, 3, 5, 7, 9, 11))
#: command -> (arguments with OUT for the output path, where its store's files appear, keys not compared)
COMMANDS = {
    "greedy": (
        ["greedy", "--domain", DOMAIN, "--budget", "12000", "--certificate", "-o", "OUT/design.json"],
        "design.json.checkpoint",
        {"seconds", "n_evaluations"},
    ),
    "pareto": (
        [
            "pareto",
            "--fixture",
            "suburb",
            "--budgets",
            "4000,12000",
            "--rules",
            "best-of",
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
            "suburb",
            "--budget",
            "8000",
            "--failures",
            "1",
            "--period",
            "20",
            "--plot-format",
            "svg",
            "--output-dir",
            "OUT",
        ],
        "periods/period-*.json",
        {"seconds"},
    ),
    "resilient-robust": (
        [
            "resilient",
            "--fixture",
            "tiny",
            "--budget",
            "5000",
            "--failures",
            "1",
            "--period",
            "10",
            "--method",
            "robust",
            "--plot-format",
            "svg",
            "--output-dir",
            "OUT",
        ],
        "periods/period-*.json",
        {"seconds"},
    ),
    "study": (["study", "STUDY", "--output-dir", "OUT"], "cells/cell-*.json", {"seconds", "n_reused"}),
    # every method on a fresh memo, also in-process: evaluation counts compared too
    "robust": (
        ["robust", "--fixture", "tiny", "--budget", "8000", "--failures", "1", "-o", "OUT/robust.json"],
        "robust.json.tasks/*.json",
        {"seconds"},
    ),
    # the checkpoint is written after the greedy start (then every 500 nodes: tests/test_certify.py)
    "optimal": (
        ["optimal", "--domain", DOMAIN, "--budget", "4000", "--max-nodes", "30", "-o", "OUT/optimal.json"],
        "optimal.json.checkpoint",
        {"seconds", "n_evaluations"},
    ),
    # radars and cameras at the even clock positions only: 4 integer programs, not 18 (the same code paths)
    "require": (
        [
            "require",
            "--domain",
            DOMAIN,
            "--preset",
            "freeway",
            "--failures",
            "1",
            "--exclude",
            ODD_CLOCK,
            "-o",
            "OUT/require.json",
        ],
        "require.json.checkpoint",
        {
            "seconds",
            "seconds_checks",
            "seconds_programs",
            "n_checks",
            "n_refuted",
            "n_short",
            "n_accepted",
            "n_base_passes",
            "n_resumed",
            "n_programs_resumed",
        },
    ),  # counts of work, not the answer: a resume redoes no journalled work and counts what it read back
    # (in process and on workers the counts are the same: tests/test_distributed.py)
}


def _args(command: str, out: Path, study: Path) -> list[str]:
    args, _, _ = COMMANDS[command]
    return [str(out) + a[3:] if a.startswith("OUT") else str(study) if a == "STUDY" else a for a in args] + [
        "--json",
        "-q",
    ]


def _answer(text: str, ignore: set[str]) -> object:
    def rec(o: object) -> object:
        if isinstance(o, dict):
            return {k: rec(v) for k, v in o.items() if k not in ignore}
        return [rec(v) for v in o] if isinstance(o, list) else o

    return rec(json.loads(text))


def _invoke(args: list[str]) -> str:
    res = CliRunner().invoke(cli, args, catch_exceptions=False)
    assert res.exit_code == 0, res.output
    return res.stdout


@pytest.fixture(scope="module")
def scheduler():
    with DaskCluster(workers=2, echo=lambda line: None) as c:
        yield c._local.scheduler_address


@pytest.mark.parametrize("command", list(COMMANDS))
def test_same_answer_in_process_on_two_workers_and_after_a_kill_and_resume(command, scheduler, tmp_path):
    study = tmp_path / "study.yaml"
    study.write_text(STUDY)
    _, stored, ignore = COMMANDS[command]
    here = _answer(_invoke(_args(command, tmp_path / "here", study)), ignore)

    there = _answer(_invoke(_args(command, tmp_path / "there", study) + ["--scheduler", scheduler]), ignore)
    assert there == here

    out = tmp_path / "killed"
    proc = subprocess.Popen(
        [str(BIN / "sensorsel"), *_args(command, out, study)],
        env=ENV,
        start_new_session=True,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        deadline = time.monotonic() + 120
        while not list(out.glob(stored)) and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.02)
        assert list(out.glob(stored)), f"{command} stored nothing before it ended (exit {proc.poll()})"
        os.killpg(proc.pid, signal.SIGKILL)  # as a lost machine would: no clean-up
    finally:
        proc.wait(timeout=30)
    assert proc.returncode == -signal.SIGKILL or proc.returncode == 0
    resumed = _answer(_invoke(_args(command, out, study) + ["--resume"]), ignore)
    assert resumed == here


SELECTING = ("greedy", "pareto", "resilient", "robust", "optimal", "study", "require")


@pytest.mark.parametrize("command", SELECTING)
def test_every_selecting_command_takes_the_executor_and_the_store_options(command):
    """--workers/--scheduler (the executor) and --resume (the store), declared once (cli.options)."""
    params = {p.name for p in cli.commands[command].params}
    assert {"dask_workers", "dask_scheduler", "resume"} <= params


@pytest.mark.parametrize("command", ["robust", "optimal"])
def test_resume_without_an_output_is_one_line_and_exit_2(command):
    res = CliRunner().invoke(cli, [command, "--fixture", "tiny", "--budget", "5000", "--resume"])
    assert res.exit_code == 2 and "give -o" in res.output and "Traceback" not in res.output
