"""A suite is the same thing on every command: ids, library positions or a result file,
and a result file is checked to be of the problem it is used on (its fingerprint), as
``simulate --suite FILE`` always did: ``certify RESULT``, ``scene --suite RESULT``, ``score --suite RESULT``."""

from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

from sensorsel.cli import cli

TINY = ["--fixture", "tiny", "--landmarks", "synthetic"]


@pytest.fixture(scope="module")
def greedy_tiny(tmp_path_factory):
    out = tmp_path_factory.mktemp("suites") / "greedy.json"
    res = CliRunner().invoke(cli, ["greedy", *TINY, "--budget", "10000", "--no-certificate", "-o", str(out), "--quiet"])
    assert res.exit_code == 0, res.output
    return out, json.loads(out.read_text())["suite"]


def test_score_takes_a_result_file_as_its_ids(greedy_tiny):
    path, suite = greedy_tiny
    by_ids = CliRunner().invoke(cli, ["score", *TINY, "--suite", ",".join(suite), "--json"])
    by_file = CliRunner().invoke(cli, ["score", *TINY, "--suite", str(path), "--json"])
    assert by_ids.exit_code == 0 and by_file.exit_code == 0, by_file.output
    a, b = json.loads(by_ids.stdout), json.loads(by_file.stdout)
    assert a["suite"] == b["suite"] and sorted(b["suite"]) == sorted(suite) and a["score"] == b["score"]


def test_certify_takes_the_greedy_result_as_its_suite(greedy_tiny):
    """certify --suite FILE bounds the run the file records: the same bound as certifying that greedy
    run made now (--budget, the same rule); sensor ids name no run and are refused, naming --suite."""
    path, _ = greedy_tiny
    by_file = CliRunner().invoke(cli, ["certify", "--suite", str(path), *TINY, "--json"])
    now = CliRunner().invoke(cli, ["certify", "--budget", "10000", "--rule", "uniform", *TINY, "--json", "-q"])
    assert by_file.exit_code == 0 and now.exit_code == 0, (by_file.output, now.output)
    assert json.loads(by_file.stdout)["bound"] == json.loads(now.stdout)["bound"]
    ids = CliRunner().invoke(cli, ["certify", "--suite", "LRL-roof,LRR-12", *TINY])
    assert ids.exit_code == 2 and "--suite LRL-roof,LRR-12" in ids.stderr and "greedy result file" in ids.stderr
    positional = CliRunner().invoke(cli, ["certify", str(path), *TINY])
    assert positional.exit_code == 2


def test_scene_draws_a_result_files_suite(greedy_tiny, tmp_path):
    path, _ = greedy_tiny
    res = CliRunner().invoke(cli, ["scene", *TINY, "--suite", str(path), "-o", str(tmp_path / "s.png")])
    assert res.exit_code == 0, res.output
    assert (tmp_path / "s.png").stat().st_size > 0


@pytest.mark.parametrize(
    "argv",
    [
        ["certify", "--suite", "{path}"],
        ["scene", "--suite", "{path}", "-o", "{tmp}/s.png"],
        ["score", "--suite", "{path}"],
    ],
)
def test_a_result_of_another_problem_is_refused_everywhere(greedy_tiny, tmp_path, argv):
    path, _ = greedy_tiny
    args = [a.format(path=path, tmp=tmp_path) for a in argv]
    res = CliRunner().invoke(cli, [*args, "--fixture", "suburb"])  # another route than the result's
    assert res.exit_code == 2 and str(path) in res.output and "sensorsel: error:" in res.output, res.output
    res = CliRunner().invoke(cli, [*args, "--fixture", "suburb", "--force"])
    assert res.exit_code == 0 and "warning" in res.output, res.output
