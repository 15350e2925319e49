"""The integrity results on the real maps stay tied to their files and to the code.

``docs/results/integrity/kitti03.json`` is written by ``python docs/regenerate.py --only
integrity-03 --maps real`` (docs/regenerate_integrity.py); ``docs/results-integrity.md`` quotes it.
Checked:

- the freeway risk per hour of the cheapest suite meeting freeway accuracy, with the lever, as the
  page quotes it, recomputed from the committed per-keyframe record by hand (the Gaussian tail
  Σ_c 2Φ(−AL_c/σ_c) with scipy, at Reid et al.'s freeway limits, plus the association bound, times
  the keyframes per hour): the summary and the page say the same;
- the engine, re-run on KITTI 03 (a second or two), gives the committed record of the $4,000
  suite (MRL-roof, map model): every keyframe's association bound and estimate to 1e-9;
- the page's tables (KITTI 03's published suites, the calibration runs, what the lever leaves out of
  00's greedy suite) are the rows of the generated ``docs/results/integrity/tables.md``, and the
  calibration simulated the freeway answer that the KITTI 03 record evaluates, which the page names:
  a page left quoting an older regeneration fails here.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import norm

from sensorsel import ScenarioSpec, load_problem
from sensorsel.api import suite_integrity
from sensorsel.information.integrity import IntegritySpec

pytestmark = pytest.mark.kitti

REPO = Path(__file__).resolve().parents[1]
RESULT = REPO / "docs" / "results" / "integrity" / "kitti03.json"
PAGE = REPO / "docs" / "results-integrity.md"
FREEWAY = (0.57, 1.40, 1.5)  # lateral [m], longitudinal [m], heading [deg]: Reid et al. 2019


def _run(label: str, variant: str) -> dict:
    data = json.loads(RESULT.read_text())
    return next(r for r in data["runs"] if r["label"] == label and r["variant"] == variant)


def test_quoted_freeway_risk_recomputed_by_hand():
    run = _run("require freeway", "map-lever")
    rec = run["records"][0]
    pw = np.asarray(rec["p_wrong_association"], float)
    sig = np.column_stack([rec["lateral_sigma_m"], rec["longitudinal_sigma_m"], rec["heading_sigma_deg"]])
    tail = np.minimum(1.0, np.sum(2.0 * norm.sf(np.asarray(FREEWAY)[None, :] / sig), axis=1))
    per_hour = rec["keyframes_per_hour"] * np.mean(np.minimum(1.0, tail + pw))
    summary = run["routes"][0]["per_hour"]["freeway"]
    assert summary == pytest.approx(per_hour, rel=1e-9)
    # the page quotes it as the tables print it (two significant digits)
    quoted = f"{per_hour:.2g}"
    text = PAGE.read_text()
    assert re.search(rf"freeway[^\n]*{re.escape(quoted)}/h", text), f"{PAGE.name} does not quote {quoted}/h"


def test_engine_gives_the_committed_record(kitti_root):
    run = _run("require local-streets", "map")
    rec = run["records"][0]
    p = load_problem(ScenarioSpec(seq="03", kitti_root=str(kitti_root), landmarks="real"))
    (now,) = suite_integrity(p, run["suite"], IntegritySpec(), map_sigma_m=run["map_sigma_m"])
    np.testing.assert_allclose(now.p_wrong_association, rec["p_wrong_association"], rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(
        now.p_wrong_association_estimate, rec["p_wrong_association_estimate"], rtol=1e-9, atol=1e-15
    )
    assert now.integrity_risk_per_hour == pytest.approx(run["routes"][0]["integrity_risk_per_hour"], rel=1e-9)


TABLES = REPO / "docs" / "results" / "integrity" / "tables.md"


def _rows(text: str, header: str) -> list[list[str]]:
    """The cells of the Markdown table whose header line starts with ``header`` (the first such)."""
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(header))
    out = []
    for line in lines[start + 2 :]:
        if not line.startswith("|"):
            break
        out.append([c.strip() for c in line.strip().strip("|").split("|")])
    return out


def _section(text: str, title: str) -> str:
    """The text of the generated tables' section ``## title`` up to the next ``## ``."""
    head = f"## {title}\n"
    body = text[text.index(head) + len(head) :]
    return body.split("\n## ", 1)[0]


def _norm(cell: str) -> str:
    """A cell as both pages may print it: no thousands separators or spaces, hyphenated presets."""
    return cell.replace(",", "").replace(" ", "").replace("localstreets", "local-streets")


def test_the_pages_kitti03_suites_are_the_generated_ones():
    """Each row of the page's KITTI 03 table (cost, model, risks, bound, estimate, tail, measurements,
    accuracy) is the generated tables' row of the same cost and model."""
    generated = {
        (r[2], r[3]): [r[4], r[5], r[6], r[7], r[8], r[11], r[13]]
        for r in _rows(_section(TABLES.read_text(), "KITTI 03: the published suites"), "| suite |")
    }
    cost = None
    rows = _rows(PAGE.read_text(), "| suite | cost | model |")
    assert len(rows) >= 6
    for r in rows:
        cost = r[1] or cost
        assert (cost, r[2]) in generated, f"{PAGE.name} quotes a {cost} suite ({r[2]}) the tables do not hold"
        assert [_norm(c) for c in r[3:]] == [_norm(c) for c in generated[cost, r[2]]], (cost, r[2])


def test_the_pages_calibration_is_the_generated_one():
    """The page's calibration rows are the generated ones, of the suite the calibration simulated, which
    is the freeway answer the KITTI 03 record evaluates; the page names that suite."""
    generated = {r[0]: r for r in _rows(TABLES.read_text(), "| run | suite | model |")}
    page = PAGE.read_text()
    rows = _rows(page, "| run | model | draws a keyframe |")
    assert {r[0] for r in rows} == set(generated)
    for r in rows:
        g = generated[r[0]]
        assert float(r[3].replace("10⁻⁴", "1e-4").replace("10⁻⁶", "1e-6")) == float(g[8]), r[0]
        assert r[4:] == g[9:], r[0]
        assert r[1] == g[2] and r[2] == g[3], r[0]
    suite = _run("require freeway", "map")["suite"]
    for name in generated:
        sim = json.loads((RESULT.parent / f"calibration03-{name}" / "simulation.json").read_text())
        assert sim["associations"][0]["suite"] == suite, name
    assert f"({', '.join(suite)}) at all" in " ".join(page.split()), f"{PAGE.name} does not name {suite}"


def test_the_pages_lever_table_on_00_is_the_generated_one():
    """The page's rows of what the lever leaves out of 00's greedy suite are the generated rows."""
    section = _section(TABLES.read_text(), "KITTI 00: the published suites")
    generated = {r[1]: r[2:] for r in _rows(section, "| suite | sensor |") if r[0] == "greedy $110,000"}
    rows = _rows(PAGE.read_text(), "| KITTI 00, greedy suite |")
    assert rows
    for r in rows:
        assert [_norm(c) for c in r[1:]] == [_norm(c) for c in generated[r[0]]], r[0]
