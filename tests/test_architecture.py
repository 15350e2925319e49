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


def test_selecting_does_not_import_gtsam_and_simulate_stays_the_function():
    """gtsam (~0.1-0.15 s to import) is loaded only where a graph is built or a simulation runs:
    importing the CLI and the API does not; ``sensorsel.simulate`` is still the run function, also
    after the simulation package's modules are imported."""
    code = ("import sys, sensorsel.cli, sensorsel.api\n"
            "assert 'gtsam' not in sys.modules, 'gtsam imported'\n"
            "import sensorsel, sensorsel.simulate.records\n"
            "f = sensorsel.simulate\n"
            "assert callable(f) and f.__name__ == 'simulate' and f.__module__ == 'sensorsel.simulate.run'\n"
            "import sensorsel.simulate.run\n"
            "from sensorsel.api import simulate\n"
            "assert simulate is f and sensorsel.simulate is f and 'gtsam' in sys.modules\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
