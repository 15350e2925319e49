"""The layering of docs/architecture.md holds (import-linter), and the check would catch a breach."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
LINT = Path(sys.executable).with_name("lint-imports")


def _lint(src: Path) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": str(src)}
    return subprocess.run([str(LINT), "--config", str(REPO / "pyproject.toml"), "--no-cache"], cwd=REPO, env=env,
                          capture_output=True, text=True, timeout=120)


def test_layers_and_no_cycles_hold():
    out = _lint(REPO / "src")
    assert out.returncode == 0, out.stdout + out.stderr
    assert "0 broken" in out.stdout


def test_an_upward_import_breaks_the_build(tmp_path):
    # a copy of the package in which the selection layer imports the CLI: the check must fail and name it
    src = tmp_path / "src"
    shutil.copytree(REPO / "src" / "sensorsel", src / "sensorsel", ignore=shutil.ignore_patterns("__pycache__"))
    target = src / "sensorsel" / "sensing.py"
    target.write_text(target.read_text() + "\nfrom . import plotting  # an upward import\n")
    out = _lint(src)
    assert out.returncode != 0
    assert "sensorsel.sensing is not allowed to import sensorsel.plotting" in out.stdout
