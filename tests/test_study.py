"""Design studies: the study file's validation, the cells' results against
independent runs, and resume. The same study on 2 Dask workers is in tests/test_distributed.py."""

from __future__ import annotations

import csv
import itertools
import json
import os
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

from sensorsel.api import run_greedy, score_suite
from sensorsel.designs.resilient import CacheWarning
from sensorsel.designs.study import StudyError, StudyResult, load_study, run_study, study_csv, write_study
from sensorsel.io import results
from sensorsel.model.problem import load_problem
from sensorsel.model.scenario import ScenarioSpec

REPO = Path(__file__).resolve().parents[1]
EXAMPLE = REPO / "configs" / "study_example.yaml"
ENV = {**os.environ, "PYTHONPATH": str(REPO / "src") + os.pathsep + os.environ.get("PYTHONPATH", "")}

SMALL = """\
target:
  fixture: tiny
  landmarks: synthetic
grid:
  budgets: [3000, "$6,000"]
  rules: [uniform]
  failures: [0, 1]
  landmark_seeds: [4]
"""


def untimed(obj: object) -> object:
    def rec(o: object) -> object:
        if isinstance(o, dict):
            return {k: rec(v) for k, v in o.items() if k != "seconds"}
        return [rec(v) for v in o] if isinstance(o, list) else o

    return rec(results.to_jsonable(obj))


def write(tmp_path: Path, text: str, name: str = "study.yaml") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def test_the_example_file_is_a_grid_of_32_cells_budget_fastest():
    s = load_study(EXAMPLE)
    assert len(s.cells) == 32 and len(s.targets) == 4
    got = [(c.library, c.landmark_seed, c.failures, c.rule, c.budget_usd) for c in s.cells]
    want = list(
        itertools.product(["default", "reduced_library.yaml"], [0, 1], [0, 1], ["uniform", "best-of"], [5000.0, 8000.0])
    )
    assert got == want
    assert s.targets[3].library == str((REPO / "configs" / "reduced_library.yaml").resolve())
    assert s.targets[1].spec.landmark_seed == 1 and s.targets[1].spec.landmarks == "synthetic"


def test_cells_equal_independent_runs(tmp_path):
    res = run_study(load_study(write(tmp_path, SMALL)))
    problem = load_problem(ScenarioSpec(fixture="tiny", landmarks="synthetic", landmark_seed=4))
    assert [(r.failures, r.budget_usd) for r in res.rows] == [(0, 3000.0), (0, 6000.0), (1, 3000.0), (1, 6000.0)]
    for r in res.rows[:2]:  # no failure: the greedy command's result and certificate
        g = run_greedy(problem, r.budget_usd, "uniform", certify=True)
        assert (r.suite, r.cost_usd, r.score, r.certificate_percent) == (
            g.suite,
            g.cost_usd,
            g.score,
            g.certificate.percent_of_best,
        )
        assert r.worst_score is None
    for r in res.rows[2:]:  # one failure: the worst case by brute force, each sensor removed, scored by GTSAM
        assert r.failures == 1 and len(r.assumed_failed) == 1 and r.certificate_percent is None
        left = {
            sid: score_suite(problem, [s for s in r.suite if s != sid], engine="reference").score for sid in r.suite
        }
        worst = min(left.values())
        assert r.worst_score == pytest.approx(worst, rel=1e-9)
        assert left[r.worst_failures[0]] == pytest.approx(worst, rel=1e-9)
        assert r.cost_usd <= r.budget_usd
    assert res.targets[0].problem.landmark_source.endswith("seed 4)")


def test_resume_reads_finished_cells_back_and_recomputes_a_stale_one(tmp_path):
    study = load_study(write(tmp_path, SMALL))
    out = tmp_path / "out"
    first = run_study(study, outdir=out)
    files = sorted((out / "cells").glob("cell-*.json"))
    assert len(files) == 4
    stamps = {f: f.stat().st_mtime_ns for f in files}
    again = run_study(study, outdir=out, resume=True)
    assert again.n_reused == 4 and {f: f.stat().st_mtime_ns for f in files} == stamps
    assert untimed(again.rows) == untimed(first.rows) and again.targets == first.targets
    stale = files[0]
    data = json.loads(stale.read_text())
    data["fingerprint"] = "0" * 64
    stale.write_text(json.dumps(data))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        third = run_study(study, outdir=out, resume=True)
    assert third.n_reused == 3
    assert any(issubclass(w.category, CacheWarning) and str(stale) in str(w.message) for w in caught)
    assert untimed(third.rows) == untimed(first.rows)


def test_csv_and_json_written_atomically_one_row_per_cell(tmp_path):
    res = run_study(load_study(write(tmp_path, SMALL)))
    paths = write_study(res, tmp_path / "o")
    assert results.load(paths[0], StudyResult) == res
    rows = list(csv.DictReader(paths[1].open()))
    assert [int(r["cell"]) for r in rows] == [0, 1, 2, 3]
    assert [float(r["score"]) for r in rows] == [r.score for r in res.rows]  # repr floats: exact
    assert paths[1].read_text() == study_csv(res)


@pytest.mark.parametrize(
    "text, key, line, words",
    [
        (SMALL.replace("  rules: [uniform]", "  rule: [uniform]"), "grid.rule", 6, "unknown key"),
        (SMALL.replace('"$6,000"', '"lots"'), "grid.budgets[1]", 5, "number of dollars"),
        (SMALL.replace('3000, "$6,000"', "-5, 3000"), "grid.budgets[0]", 5, ">= 0"),
        (SMALL.replace('3000, "$6,000"', "300, 3000"), "grid.budgets[0]", 5, "below the cheapest sensor"),
        (SMALL.replace("failures: [0, 1]", "failures: [0, two]"), "grid.failures[1]", 7, "integer"),
        (SMALL.replace("rules: [uniform]", "rules: [uniform, greedy]"), "grid.rules[1]", 6, "unknown rule"),
        (SMALL.replace("  landmarks: synthetic\n", ""), "grid.landmark_seeds", 7, "target.landmarks: synthetic"),
        (SMALL.replace("fixture: tiny", "fixture: nowhere"), "target.fixture", 2, "unknown fixture"),
        (SMALL.replace("fixture: tiny", "fixture: tiny\n  domain: x.yaml"), "target", 2, ""),
        (SMALL + "engine: slow\n", "engine", 9, "unknown engine"),
        (SMALL.replace('3000, "$6,000"', "3000, 3000"), "grid.budgets[1]", 5, "repeated"),
    ],
)
def test_bad_study_files_name_file_key_and_line(tmp_path, text, key, line, words):
    p = write(tmp_path, text)
    with pytest.raises(StudyError) as exc:
        load_study(p)
    msg = str(exc.value)
    assert msg.startswith(f"{p}:{line}: {key}") and words in msg, msg


def test_cli_study_bad_input_is_one_line_exit_2(tmp_path):
    p = write(tmp_path, SMALL.replace("  rules: [uniform]", "  rules: [uniform]\n  colour: blue"))
    r = subprocess.run(
        [str(Path(sys.executable).parent / "sensorsel"), "study", str(p), "--output-dir", str(tmp_path / "o")],
        capture_output=True,
        text=True,
        env=ENV,
        timeout=120,
    )
    assert r.returncode == 2 and "Traceback" not in r.stderr
    (line,) = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert f"{p}:7: grid.colour: unknown key" in line


def test_an_interrupted_study_resumes_with_only_the_cells_left(tmp_path):
    study = load_study(write(tmp_path, SMALL))
    out = tmp_path / "out"

    def interrupt(done: int, total: int) -> None:
        if done == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_study(study, outdir=out, progress=interrupt)
    assert len(list((out / "cells").glob("cell-*.json"))) == 2  # saved as they finished
    resumed = run_study(study, outdir=out, resume=True)
    assert resumed.n_reused == 2
    assert untimed(resumed.rows) == untimed(run_study(study).rows)
