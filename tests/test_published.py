"""The published numbers stay tied to the code.

Re-runs the README's headline greedy result on KITTI 03 with its real pole map ($110,000, uniform
rule, with certificate) through the public Python API and compares it with the result file the docs
were generated from, ``docs/results/greedy03.json``, and checks that README.md and
docs/real-maps.md quote that file's score, cost and certificate as sensorsel prints them.

A change that moves a published number fails here until the docs are regenerated::

    python docs/regenerate.py --only greedy03 tables      # then update the numbers quoted in the docs

Compared: suite (ids and pick order), cost, score (relative 1e-9), every step (pick, suite, cost,
score, gain, rule value), why it stopped, the certificate's bound, ratio and gap (1e-9), and what the
problem was (keyframes, landmarks, route length). Not compared:

- ``seconds`` / ``timing``: wall times;
- ``landmark_source``, ``library``, ``spec``: they name files and folders of the machine that wrote the
  file (the KITTI folder, the worktree);
- ``n_evaluations`` and ``engine``: how the numbers were computed, not what they are. Lazy batching, the
  certificate's step skipping or a new default engine change the counts (the README's "184 suites")
  while every published score stays the same to 1e-9; the speed benchmark (bench/speed.py) is where
  evaluation counts are measured;
- the certificate's ``step_bounds`` at steps one run skipped (``None``: skipping is the same kind of
  bookkeeping); the bounds of steps both runs swept are compared.
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

import pytest

from sensorsel import ScenarioSpec, load_problem
from sensorsel.api import with_suite_quality
from sensorsel.io import results

try:  # the public API module, where there is one
    from sensorsel.api import run_greedy  # type: ignore[attr-defined]
except ImportError:
    from sensorsel.designs.selection import run_greedy

pytestmark = pytest.mark.kitti

REPO = Path(__file__).resolve().parents[1]
PUBLISHED = REPO / "docs" / "results" / "greedy03.json"
DOCS_QUOTING = (REPO / "README.md", REPO / "docs" / "real-maps.md", REPO / "docs" / "results.md")
BUDGET = 110_000
REL = 1e-9

IGNORED = {"seconds", "timing", "landmark_source", "library", "spec", "n_evaluations", "engine"}


def _close(a: float, b: float, scale: float) -> bool:
    return math.isclose(a, b, rel_tol=REL, abs_tol=REL * scale)


def _diff(a: Any, b: Any, path: str, scale: float, out: list[str]) -> None:
    """Differences between two JSON-like trees, floats to a relative 1e-9 (absolute 1e-9 * scale)."""
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b)):
            if k in IGNORED:
                continue
            if k not in a or k not in b:
                out.append(f"{path}.{k}: only in {'the published file' if k in b else 'the new result'}")
            elif k == "step_bounds":
                pairs = [(x, y) for x, y in zip(a[k], b[k]) if x is not None and y is not None]
                if len(a[k]) != len(b[k]):
                    out.append(f"{path}.{k}: {len(a[k])} steps against {len(b[k])}")
                for i, (x, y) in enumerate(pairs):
                    _diff(x, y, f"{path}.{k}[{i}]", scale, out)
            else:
                _diff(a[k], b[k], f"{path}.{k}", scale, out)
    elif isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        if len(a) != len(b):
            out.append(f"{path}: {len(a)} items against {len(b)} published")
        for i, (x, y) in enumerate(zip(a, b)):
            _diff(x, y, f"{path}[{i}]", scale, out)
    elif isinstance(a, float) or isinstance(b, float):
        if not (isinstance(a, (int, float)) and isinstance(b, (int, float)) and _close(float(a), float(b), scale)):
            out.append(f"{path}: {a!r} now, {b!r} published")
    elif a != b:
        out.append(f"{path}: {a!r} now, {b!r} published")


@pytest.fixture(scope="module")
def published():
    if not PUBLISHED.is_file():
        pytest.fail(f"{PUBLISHED} is missing: run python docs/regenerate.py --only greedy03")
    rec = results.load(PUBLISHED, "greedy")
    return rec, results.to_jsonable(rec)


@pytest.fixture(scope="module")
def rerun(kitti_root, published):
    if not (kitti_root / "landmarks" / "03.csv").is_file():
        pytest.fail(
            f"{kitti_root} has no landmarks/03.csv (the KITTI pole map the published results use; "
            "sensorsel kitti builds it)",
            pytrace=False,
        )
    # landmarks="real": the pole map, required (a KITTI folder without it is an error, not a silent
    # fall-back to generated landmarks that would compare unlike with like)
    problem = load_problem(ScenarioSpec(seq="03", kitti_root=str(kitti_root), landmarks="real"))
    res = run_greedy(problem, BUDGET, "uniform", certify=True)
    # as `sensorsel greedy` writes it: with the suite's accuracy in metres and its integrity (the SLAM
    # graph, the filter's estimate: the command's defaults)
    res = with_suite_quality(res, problem)
    return res, results.to_jsonable(res)


def test_published_greedy03_is_what_the_code_gives(published, rerun):
    pub, pub_js = published
    new, new_js = rerun
    assert tuple(new.suite) == tuple(pub.suite), "suite (ids, pick order)"
    assert _close(new.cost_usd, pub.cost_usd, 1.0), "cost"
    assert _close(new.score, pub.score, pub.score), "score"
    assert [s.pick for s in new.steps] == [s.pick for s in pub.steps]
    for a, b in zip(new.steps, pub.steps):
        assert _close(a.score, b.score, pub.score), f"step {b.pick}: score {a.score} now, {b.score} published"
    assert new.certificate is not None and pub.certificate is not None
    assert _close(new.certificate.bound, pub.certificate.bound, pub.score), "certificate bound"
    assert _close(new.certificate.percent_of_best, pub.certificate.percent_of_best, 100.0)
    # and everything else the file records, but timings, paths and evaluation counts
    out: list[str] = []
    _diff(new_js, pub_js, "greedy03", abs(pub.score), out)
    assert not out, "docs/results/greedy03.json no longer matches the code (regenerate the docs):\n" + "\n".join(
        out[:30]
    )


def _quoted(text: str, number: str) -> bool:
    """``number`` appears in ``text`` as a whole number (not as the start of a longer one)."""
    return re.search(r"(?<![\d,.])" + re.escape(number) + r"(?![\d])", text) is not None


def _certificate_pct(p: float) -> str:
    # as sensorsel prints it: one decimal, rounded down
    return "100" if p >= 100.0 else f"{math.floor(p * 10) / 10:.1f}"


@pytest.mark.parametrize("doc", DOCS_QUOTING, ids=lambda p: p.name)
def test_docs_quote_the_published_greedy03(published, doc):
    pub, _ = published
    text = doc.read_text(encoding="utf-8")
    score2, score3 = f"{pub.score:,.2f}", f"{pub.score:,.3f}"
    assert _quoted(text, score3) or _quoted(text, score2), (
        f"{doc.name} does not quote Greedy03's score {score3} (or {score2})"
    )
    cost = f"${pub.cost_usd:,.0f}"
    assert cost in text, f"{doc.name} does not quote Greedy03's cost {cost}"
    pct = _certificate_pct(pub.certificate.percent_of_best)
    assert f"{pct}%" in text, f"{doc.name} does not quote Greedy03's certificate ({pct}%)"
