"""Issue 15 on a Dask cluster: ``sensorsel pareto --workers 2`` under a power limit and mounting
slots gives the bytes of the in-process run (timings aside), and every architecture keeps the limits.

The cluster is a LocalCluster of 2 worker processes on 127.0.0.1 that the command starts and stops
itself (``--workers 2``); each command runs in a subprocess with a time limit.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

pytest.importorskip("distributed")

from sensorsel import results  # noqa: E402
from sensorsel._resources import default_library_path  # noqa: E402
from sensorsel.constraints import Constraints, feasible_set  # noqa: E402
from sensorsel.library import load_library  # noqa: E402
from sensorsel.tradespace import TradespaceResult  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent
ENV = {**os.environ, "PYTHONPATH": str(REPO / "src") + os.pathsep + os.environ.get("PYTHONPATH", "")}


def _untimed(text: str) -> object:
    def rec(o: object) -> object:
        if isinstance(o, dict):
            return {k: rec(v) for k, v in o.items() if k != "seconds"}
        if isinstance(o, list):
            return [rec(v) for v in o]
        return o
    return rec(json.loads(text))


def _cli(*args: str, timeout: float = 240) -> subprocess.CompletedProcess[str]:
    return subprocess.run([str(BIN / "sensorsel"), *map(str, args)], capture_output=True, text=True, env=ENV, cwd=REPO,
                          timeout=timeout)


def test_pareto_with_limits_and_slots_on_two_workers_equals_in_process(tmp_path):
    stock = yaml.safe_load(default_library_path().read_text())
    stock["clock_positions"] = [12, 3, 6, 9]
    (tmp_path / "small.yaml").write_text(yaml.safe_dump(stock))
    car = tmp_path / "car.yaml"  # extends the stock file with one radar and one camera per position
    car.write_text("extends: small.yaml\nslots:\n  roof: {lidar: 1}\n  clock: {radar: 1, stereo: 1}\n")
    args = ["pareto", "--fixture", "tiny", "--engine", "fast", "--library", car, "--budgets", "5000,20000,110000",
            "--rules", "uniform,marginal", "--limit", "power_w=40", "--max-sensors", "6", "-q"]
    here = _cli(*args, "--jobs", "1", "-o", tmp_path / "here")
    assert here.returncode == 0, here.stderr
    there = _cli(*args, "--workers", "2", "-o", tmp_path / "there")
    assert there.returncode == 0, there.stderr
    a = (tmp_path / "here" / "tradespace.json").read_text()
    b = (tmp_path / "there" / "tradespace.json").read_text()
    assert _untimed(b) == _untimed(a)
    # and the limits bite and hold: every run's suite fits, and the library's slots were read
    res = results.load(tmp_path / "there" / "tradespace.json", TradespaceResult)
    c = Constraints.of(limits={"power_w": 40.0}, max_sensors=6)
    lib = load_library(car)
    assert res.constraints is not None and res.constraints.limits == c.limits and res.constraints.slots
    assert lib.slots
    tight = 0
    for r in res.runs:
        feas = feasible_set(lib, r.budget_usd, c)
        s = lib.resolve_suite(r.suite)
        assert feas.fits(s), (r.rule, r.budget_usd, feas.violations(s))
        tight += len(s) == 6 or feas.usage(s)[1] > 30  # a limit (not the budget) stopped this run
    assert tight
