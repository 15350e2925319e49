"""The integrity results on the real maps stay tied to their files and to the code.

``docs/results/integrity/kitti03.json`` is written by ``python docs/regenerate.py --only
integrity-03 --maps real`` (docs/regenerate_integrity.py); ``docs/results-integrity.md`` quotes it.
Checked:

- the freeway risk per hour of the cheapest suite meeting freeway accuracy, with the lever, as the
  page quotes it, recomputed from the committed per-keyframe record by hand (the Gaussian tail
  Σ_c 2Φ(−AL_c/σ_c) with scipy, at Reid et al.'s freeway limits, plus the association bound, times
  the keyframes per hour): the summary and the page say the same;
- the engine, re-run on KITTI 03 (a second or two), gives the committed record of the $4,000
  suite (MRL-roof, map model): every keyframe's association bound and estimate to 1e-9.
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
