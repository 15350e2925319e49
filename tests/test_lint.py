"""ruff's lint and format checks over the code (pyproject.toml's [tool.ruff]; the same as the pre-commit
hooks of .pre-commit-config.yaml), run through ``python -m ruff`` of this environment: the test extra
pins its version, so every machine formats alike. Fix a failure with ``ruff check --fix`` and
``ruff format`` (or ``pre-commit run --all-files``)."""

from __future__ import annotations

import importlib.util
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
PATHS = [p for p in ("src", "tests", "bench", "docs") if (ROOT / p).is_dir()]
needs_ruff = pytest.mark.skipif(
    importlib.util.find_spec("ruff") is None, reason="ruff is not installed (pip install -e '.[test]' installs it)"
)


def _ruff(*args: str, stdin: str | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "ruff", *args], cwd=ROOT, input=stdin, capture_output=True, text=True, timeout=120
    )


def _head(r: subprocess.CompletedProcess[str], lines: int = 60) -> str:
    """The first lines of ruff's report and its last (the count), not a diff of the whole tree."""
    out = (r.stdout + r.stderr).splitlines()
    return "\n".join(out if len(out) <= lines else [*out[:lines], "...", out[-1]])


def _pinned() -> str:
    extra = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"]["test"]
    pins = [re.fullmatch(r"ruff==([\w.]+)", d) for d in extra]
    found = [m.group(1) for m in pins if m]
    assert len(found) == 1, f"the test extra should pin ruff exactly once (ruff==X.Y.Z), got {extra}"
    return found[0]


def test_the_pre_commit_hooks_run_the_pinned_ruff():
    config = yaml.safe_load((ROOT / ".pre-commit-config.yaml").read_text())
    (repo,) = [r for r in config["repos"] if r["repo"].endswith("/ruff-pre-commit")]
    assert repo["rev"] == f"v{_pinned()}", "keep .pre-commit-config.yaml's rev and pyproject's ruff pin the same"
    assert {h["id"] for h in repo["hooks"]} == {"ruff-check", "ruff-format"}


@needs_ruff
def test_the_installed_ruff_is_the_pinned_one():
    got = _ruff("--version").stdout.split()[-1]
    assert got == _pinned(), f"ruff {got} installed, the test extra pins {_pinned()}: its format may differ"


@needs_ruff
def test_ruff_check_finds_nothing():
    r = _ruff("check", "--no-cache", "--output-format", "concise", *PATHS)
    assert r.returncode == 0, f"ruff check {' '.join(PATHS)}:\n{_head(r)}"


@needs_ruff
def test_ruff_format_would_change_nothing():
    r = _ruff("format", "--check", "--no-cache", *PATHS)
    assert r.returncode == 0, f"ruff format --check {' '.join(PATHS)} (run ruff format):\n{_head(r)}"


@needs_ruff
def test_the_project_settings_are_the_ones_checked():
    """The checks above read pyproject.toml: a 120-character line passes where ruff's default (88) would
    fail, a 121-character one and an unused import do not (so a check that found no settings, or no
    files, would not pass unnoticed)."""
    name = "src/sensorsel/_lint_probe.py"
    ok = "x = " + repr("a" * 114) + "\n"
    assert len(ok.rstrip("\n")) == 120
    assert _ruff("check", "--no-cache", "--stdin-filename", name, "-", stdin=ok).returncode == 0
    long = "x = " + repr("a" * 115) + "\n"
    r = _ruff("check", "--no-cache", "--stdin-filename", name, "-", stdin=long)
    assert r.returncode == 1 and "E501" in r.stdout
    r = _ruff("check", "--no-cache", "--stdin-filename", name, "-", stdin="import os\n")
    assert r.returncode == 1 and "F401" in r.stdout
