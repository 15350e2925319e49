"""The published requirement rows stay tied to the code: the search that proves them still takes
the path it took.

``docs/results/require/require-03-*.json`` are ``docs/regenerate.py``'s runs of ``sensorsel require``
on KITTI 03 with its real pole map (step ``require-03-a0`` and ``require-03-a1``). Each of the cheap
ones is run again here, exactly as that step runs it, and compared with its file: the suite, the
cost and the lower bound, the proof, the ties, the margin and every keyframe's 95 % errors, and the
counts of the search (integer programs, accuracy computations, suites refuted or accepted by a
bound). The counts are compared too because the requirements table quotes them (its "accuracy
checks" column) and because they are where a change to the search shows first: a new order of
checks, another cut, another suite proposed on a plateau proves the same cost by another path.

A change that moves any of them fails here until the rows are regenerated::

    python docs/regenerate.py --only require-03-a0 require-03-a1 tables --maps real

Not compared: wall times (any key holding ``seconds``), the paths of the machine that wrote the file
(the KITTI folder, the library file, the landmarks' file) and keys a file predates (a count added to
the record after the file was written). Numbers are compared to a relative 1e-9 (a platform's BLAS
may round the last bits otherwise; the search's path, which the counts pin, may not differ).

The expensive rows (KITTI 00, the seven-route domain, Helsinki, KITTI 03 at local streets with a
failure: a minute to an hour each) are not run here.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

from sensorsel.cli import cli

pytestmark = pytest.mark.kitti

REPO = Path(__file__).resolve().parents[1]
RESULTS = REPO / "docs" / "results" / "require"
TABLES = REPO / "docs" / "results" / "tables.md"
REL = 1e-9
#: where the result names files and folders of the machine that wrote it (the fingerprint's
#: "library", a digest of the file's contents, is compared)
MACHINE = {".problem.landmark_source", ".problem.library", ".problem.spec.kitti_root"}
#: (preset, failures) of the rows run here: the cheap ones of docs/regenerate.py's steps
ROWS = [("local-streets", 0), ("freeway", 0), ("freeway", 1)]


def _differences(published: Any, now: Any, path: str, out: list[str]) -> None:
    """Where ``now`` differs from ``published`` (keys only ``now`` has are new since: not compared)."""
    if isinstance(published, dict):
        if not isinstance(now, dict):
            out.append(f"{path}: {now!r} is not a mapping")
            return
        for key, value in published.items():
            if "seconds" in key or f"{path}.{key}" in MACHINE:
                continue
            if key not in now:
                out.append(f"{path}.{key}: missing")
            else:
                _differences(value, now[key], f"{path}.{key}", out)
    elif isinstance(published, list):
        if not isinstance(now, list) or len(now) != len(published):
            out.append(f"{path}: {len(published)} entries published, {now!r:.80} now")
            return
        for i, (a, b) in enumerate(zip(published, now)):
            _differences(a, b, f"{path}[{i}]", out)
    elif isinstance(published, float) and isinstance(now, (int, float)) and not isinstance(now, bool):
        if not math.isclose(published, now, rel_tol=REL, abs_tol=REL * 1e-3):
            out.append(f"{path}: {published!r} published, {now!r} now")
    elif published != now or type(published) is not type(now):
        out.append(f"{path}: {published!r} published, {now!r} now")


def _rerun(kitti_root: Path, preset: str, failures: int, out: Path) -> dict:
    """The row as docs/regenerate.py's step writes it (``_require``: the filter's estimate, quiet)."""
    args = ["require", "--seq", "03", "--kitti-root", str(kitti_root), "--landmarks", "real"]
    args += ["--preset", preset, "--failures", str(failures), "--estimate", "filter", "-q", "-o", str(out)]
    got = CliRunner().invoke(cli, args)
    assert got.exit_code == 0, got.output
    return json.loads(out.read_text())


@pytest.mark.parametrize(("preset", "failures"), ROWS, ids=[f"{p}-a{a}" for p, a in ROWS])
def test_published_require_row_is_what_the_code_gives(kitti_root, tmp_path, preset, failures):
    published = json.loads((RESULTS / f"require-03-{preset}-a{failures}.json").read_text())
    assert published["status"] == "optimal"  # a row worth pinning: a proof
    now = _rerun(kitti_root, preset, failures, tmp_path / "row.json")
    out: list[str] = []
    _differences(published, now, "", out)
    assert not out, "the published row is no longer what the code gives:\n" + "\n".join(out[:20])


@pytest.mark.parametrize(("preset", "failures"), ROWS, ids=[f"{p}-a{a}" for p, a in ROWS])
def test_tables_quote_the_published_require_row(preset, failures):
    """The requirements table (tables.md, built from the files) has the file's cost, proof and
    accuracy checks on the row of KITTI 03 at that preset and failures."""
    published = json.loads((RESULTS / f"require-03-{preset}-a{failures}.json").read_text())
    row = re.search(rf"^\| 03 \| {re.escape(preset)} \| {failures} \|(.*)$", TABLES.read_text(), re.M)
    assert row, f"tables.md has no row for KITTI 03, {preset}, {failures} failure(s)"
    cells = [c.strip() for c in row.group(1).split("|")]
    assert cells[1] == f"${published['cost_usd']:,.0f}" and cells[3] == "proved"
    assert cells[-3] == f"{published['n_checks']}"
