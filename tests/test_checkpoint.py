"""Resume of an interrupted greedy run: the checkpoint written after each pick.

An interrupted run is resumed from its checkpoint and must give the bytes of an uninterrupted run,
timings and evaluation counts aside (the resumed run's lazy bounds start afresh), without scoring
again what the interrupted run finished; a checkpoint of another run is not read back: a warning names
the file and what differs, and the run starts afresh, as every store's resume does
(tests/test_resume_policy). The cluster's side (resuming on 2 Dask workers) is in tests/test_distributed.py.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import pytest

from sensorsel.api import design_domain, run_greedy, suite_accuracy
from sensorsel.designs.checkpoint import GreedyCheckpoint, checkpoint_path
from sensorsel.information.evaluators import DomainEvaluator
from sensorsel.io import results
from sensorsel.model.problem import load_domain
from sensorsel.pipeline.store import CacheWarning

REPO = Path(__file__).resolve().parents[1]
FIXTURES = REPO / "configs" / "domain_fixtures.yaml"
ENV = {**os.environ, "PYTHONPATH": str(REPO / "src") + os.pathsep + os.environ.get("PYTHONPATH", "")}


def same_but_counts(obj: object) -> object:
    """A result's JSON without its timings and evaluation counts (the two fields a resume may change)."""

    def rec(o: object) -> object:
        if isinstance(o, dict):
            return {k: rec(v) for k, v in o.items() if k not in ("seconds", "n_evaluations")}
        if isinstance(o, list):
            return [rec(v) for v in o]
        return o

    return rec(json.loads(results.dumps(obj)))


class Interrupt(KeyboardInterrupt):
    pass


def stop_after(picks: int):
    """A progress callback that interrupts the run (as Ctrl-C would) once ``picks`` calls were made."""
    calls = []

    def progress(done: int, total: int) -> None:
        calls.append(done)
        if len(calls) == picks:
            raise Interrupt

    return progress


class Recording(DomainEvaluator):
    """A real domain evaluator that remembers the base suite of every greedy step it is asked for."""

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.bases: list[tuple[int, ...]] = []

    def scores_with(self, suite, candidates):
        self.bases.append(tuple(suite))
        return super().scores_with(suite, candidates)

    def scores_or_bounds(self, suite, candidates, needed, **kw):  # lazy greedy's way of asking
        self.bases.append(tuple(suite))
        return super().scores_or_bounds(suite, candidates, needed, **kw)


@pytest.fixture(scope="module")
def domain():
    return load_domain(FIXTURES)


def test_an_interrupted_domain_greedy_resumes_to_the_uninterrupted_result(domain, tmp_path):
    whole = design_domain(domain, 12_000, certify=True)
    ck = tmp_path / "design.json.checkpoint"
    with pytest.raises(Interrupt):
        design_domain(domain, 12_000, certify=True, checkpoint=ck, progress=stop_after(2))
    saved = results.load(ck, GreedyCheckpoint)
    assert [s.pick for s in saved.steps] == [s.pick for s in whole.greedy.steps[:2]]
    assert saved.steps == whole.greedy.steps[:2]  # recorded as computed
    assert saved.n_evaluations > 0 and saved.certificate is None and saved.routes == ()

    ev = Recording(domain)
    resumed = design_domain(domain, 12_000, certify=True, checkpoint=ck, resume=True, evaluator=ev)
    assert same_but_counts(resumed) == same_but_counts(whole)
    # greedy runs before the certificate (which sweeps every intermediate suite, the empty one too):
    # its first step scored here starts from the two recorded picks, which were not scored again
    assert len(ev.bases[0]) == 2
    done = results.load(ck, GreedyCheckpoint)  # the API leaves the checkpoint; the CLI deletes it after writing -o
    assert done.certificate is not None and len(done.routes) == len(domain.routes)


def test_an_interrupted_breakdown_resumes_without_its_finished_routes(domain, tmp_path):
    whole = design_domain(domain, 12_000)
    ck = tmp_path / "ck"
    with pytest.raises(Interrupt):
        design_domain(domain, 12_000, checkpoint=ck, breakdown_progress=stop_after(1))
    saved = results.load(ck, GreedyCheckpoint)
    assert len(saved.runs) == 1 and len(saved.routes) == 1
    ev = Recording(domain)
    resumed = design_domain(domain, 12_000, checkpoint=ck, resume=True, evaluator=ev)
    assert same_but_counts(resumed) == same_but_counts(whole)
    assert ev.bases == []  # greedy finished before the interruption: no domain step is scored again
    assert resumed.routes[0] == saved.routes[0]


def test_best_of_interrupted_in_its_second_rule_resumes(tiny_problem, tmp_path):
    whole = run_greedy(tiny_problem, 8_000, "best-of", certify=True)
    n_uniform = len(run_greedy(tiny_problem, 8_000, "uniform").steps)
    ck = tmp_path / "ck"
    with pytest.raises(Interrupt):
        run_greedy(tiny_problem, 8_000, "best-of", certify=True, checkpoint=ck, progress=stop_after(n_uniform + 1))
    saved = results.load(ck, GreedyCheckpoint)
    assert [r.rule for r in saved.runs] == ["uniform"] and len(saved.steps) == 1
    resumed = run_greedy(tiny_problem, 8_000, "best-of", certify=True, checkpoint=ck, resume=True)
    assert same_but_counts(resumed) == same_but_counts(whole)


def test_resume_without_a_checkpoint_starts_afresh(tiny_problem, tmp_path):
    whole = run_greedy(tiny_problem, 5_000)
    got = run_greedy(tiny_problem, 5_000, checkpoint=tmp_path / "none", resume=True)
    assert same_but_counts(got) == same_but_counts(whole)


def test_a_checkpoint_of_another_budget_or_route_is_not_read_back_naming_what_differs(
    tiny_problem, suburb_problem, tmp_path
):
    ck = tmp_path / "ck"
    with pytest.raises(Interrupt):
        run_greedy(tiny_problem, 8_000, checkpoint=ck, progress=stop_after(1))
    before = ck.read_bytes()
    with pytest.warns(CacheWarning) as caught:
        got = run_greedy(tiny_problem, 9_000, checkpoint=ck, resume=True)
    (msg,) = [str(w.message) for w in caught]
    assert str(ck) in msg and "budget $8,000 (this run: $9,000)" in msg
    assert same_but_counts(got) == same_but_counts(run_greedy(tiny_problem, 9_000))
    assert ck.read_bytes() != before and results.load(ck, GreedyCheckpoint).budget_usd == 9_000  # overwritten
    with pytest.warns(CacheWarning) as caught:
        got = run_greedy(suburb_problem, 9_000, "marginal", checkpoint=ck, resume=True)
    (msg,) = [str(w.message) for w in caught]
    assert "another route or keyframe rate" in msg and "rule uniform (this run: marginal)" in msg
    assert same_but_counts(got) == same_but_counts(run_greedy(suburb_problem, 9_000, "marginal"))


def _cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [str(Path(sys.executable).parent / "sensorsel"), *args],
        capture_output=True,
        text=True,
        env=ENV,
        cwd=REPO,
        timeout=120,
    )


def test_cli_resume_warns_of_another_domain_budget_in_one_line_and_deletes_a_finished_checkpoint(domain, tmp_path):
    out = tmp_path / "design.json"
    with pytest.raises(Interrupt):
        design_domain(domain, 12_000, checkpoint=checkpoint_path(out), progress=stop_after(1))
    other = _cli("greedy", "--domain", str(FIXTURES), "--budget", "13000", "-q", "-o", str(out), "--resume")
    assert other.returncode == 0 and "Traceback" not in other.stderr
    (line,) = [ln for ln in other.stderr.splitlines() if "warning" in ln]
    assert str(checkpoint_path(out)) in line and "budget $12,000 (this run: $13,000)" in line
    assert results.load(out).greedy.budget_usd == 13_000 and not checkpoint_path(out).exists()
    with pytest.raises(Interrupt):
        design_domain(domain, 12_000, checkpoint=checkpoint_path(out), progress=stop_after(1))
    good = _cli("greedy", "--domain", str(FIXTURES), "--budget", "12000", "-q", "-o", str(out), "--resume", "--json")
    assert good.returncode == 0, good.stderr
    want = design_domain(domain, 12_000, certify=True)
    # the command line adds the suite's accuracy in metres (the SLAM graph) to the design's greedy run
    want = replace(want, greedy=replace(want.greedy, accuracy=suite_accuracy(domain, want.greedy.suite)))
    got = results.load(out)
    # and its integrity lines (tests/test_integrity*.py check them)
    assert same_but_counts(replace(got, greedy=replace(got.greedy, integrity=()))) == same_but_counts(want)
    assert not checkpoint_path(out).exists()
    usage = _cli("greedy", "--budget", "5000", "-q", "--resume")
    assert usage.returncode == 2 and "-o" in usage.stderr
