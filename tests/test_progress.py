"""Feedback on long work: the CLI's one progress display (sensorsel.cli.progress).

Off a terminal (a pipe, a log) a run says it is alive with a status line on stderr every few seconds,
with where it stands in words; ``--progress/--no-progress`` force it. Oracles: a hand-driven clock
for the display, and for ``require`` the result file of the same run (its cost, lower bound and
counts), read through a real pipe.
"""

from __future__ import annotations

import io
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

from sensorsel.cli import cli
from sensorsel.cli.progress import Display
from sensorsel.io.progress import report
from sensorsel.model.library import load_library

BIN = Path(sys.executable).parent
#: ten sensors of the library, the rest excluded: a search of a few integer programs
SMALL = ("LRL-roof", "MRL-roof", "LRR-12", "LRR-6", "MRR-12", "WSC-12", "HD2K-12", "HD2K-6", "LSC-12", "HD2K-3")
STATUS = re.compile(
    r"^sensorsel: searching: cost in \[\$([\d,]+), \$([\d,]+)\]; (\d+) integer programs, ([\d,]+) suites checked; "
    r"\d+ s$"
)
FINAL = re.compile(
    r"^sensorsel: searching: done in \d+ s; cost in \[\$([\d,]+), \$([\d,]+)\]; (\d+) integer programs, ([\d,]+) "
    r"suites checked$"
)


class Clock:
    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


def _num(s: str) -> float:
    return float(s.replace(",", ""))


def test_off_a_terminal_a_status_line_every_few_seconds_with_the_time_left():
    clock, out = Clock(), io.StringIO()
    d = Display("study cells", terminal=False, every=5.0, stream=out, clock=clock)
    with d:
        for done in range(1, 9):  # 8 cells, 2 s each
            clock.t += 2.0
            d(done, 8)
    lines = out.getvalue().splitlines()
    # lines at 6 s (3 cells) and 12 s (6 cells) only: not one a unit; then the end
    assert lines == [
        "sensorsel: study cells: 3 of 8 (38%), 6 s, about 10 s left",
        "sensorsel: study cells: 6 of 8 (75%), 12 s, about 4 s left",
        "sensorsel: study cells: done in 16 s",
    ]


def test_a_short_run_writes_nothing_and_a_run_without_honest_count_shows_its_text():
    clock, out = Clock(), io.StringIO()
    with Display("greedy", terminal=False, every=5.0, stream=out, clock=clock) as d:
        d(1, 3)
        clock.t += 1.0
        d(3, 3)
    assert out.getvalue() == ""  # under 5 s: a log gets no noise
    with Display("searching", terminal=False, every=0.0, stream=out, clock=clock, counted=False) as d:
        report(d, 0, 1000, "cost >= $0, no suite found yet")
        clock.t += 61.0
        report(d, 1, 1000, "cost in [$898, $2,694]")
    assert out.getvalue().splitlines() == [
        "sensorsel: searching: cost >= $0, no suite found yet; 0 s",
        "sensorsel: searching: cost in [$898, $2,694]; 1 min 01 s",
        "sensorsel: searching: done in 1 min 01 s; cost in [$898, $2,694]",
    ]


def test_report_gives_a_plain_callable_the_count_alone():
    calls: list[tuple[int, int]] = []
    report(lambda done, total: calls.append((done, total)), 2, 5, "text a plain callable cannot take")
    report(None, 1, 1, "nothing to tell")
    assert calls == [(2, 5)]


def _require(tmp_path: Path, *extra: str, every: str = "0") -> subprocess.CompletedProcess[str]:
    exclude = ",".join(sorted(set(load_library().ids) - set(SMALL)))
    env = {**os.environ, "SENSORSEL_PROGRESS_EVERY": every}
    env.pop("SENSORSEL_PROGRESS", None)
    return subprocess.run(
        [
            str(BIN / "sensorsel"),
            "require",
            "--fixture",
            "tiny",
            "--engine",
            "fast",
            "--jobs",
            "1",
            "--preset",
            "freeway",
            "--exclude",
            exclude,
            "-o",
            str(tmp_path / "req.json"),
            *extra,
        ],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )


def test_require_into_a_pipe_says_the_cost_interval_closing_and_the_count(tmp_path):
    p = _require(tmp_path)
    assert p.returncode == 0, p.stderr
    res = json.loads((tmp_path / "req.json").read_text())
    lines = [line for line in p.stderr.splitlines() if line.startswith("sensorsel: searching:")]
    status = [STATUS.match(line) for line in lines[:-1]]
    assert len(status) >= 2 and all(status), lines
    low, up, ips, checked = (list(map(_num, col)) for col in zip(*(m.groups() for m in status)))
    assert ips == list(range(len(ips)))  # one line an integer program, counted from 0
    assert all(a <= b for a, b in zip(low, low[1:])) and all(a >= b for a, b in zip(up, up[1:]))  # the interval closes
    assert all(a <= b for a, b in zip(low, up)) and all(a <= b for a, b in zip(checked, checked[1:]))
    final = FINAL.match(lines[-1])
    assert final, lines[-1]
    f_low, f_up, f_ips, f_checked = map(_num, final.groups())
    assert res["status"] == "optimal"
    assert f_low == f_up == round(res["cost_usd"]) and round(res["lower_bound_usd"]) == f_low
    assert f_ips == res["iterations"]
    # the suites asked: computed (less the bounds' base passes, which answer none), refuted without
    # computing, and accepted by an upper bound
    asked = res["n_checks"] - res["n_base_passes"] + res["n_refuted"] + res["n_accepted"]
    assert f_checked == asked


def _require_here(tmp_path: Path, *extra: str, every: str = "0"):
    """The same run in this process (click's runner: stderr is no terminal, as a pipe)."""
    exclude = ",".join(sorted(set(load_library().ids) - set(SMALL)))
    return CliRunner().invoke(
        cli,
        [
            "require",
            "--fixture",
            "tiny",
            "--engine",
            "fast",
            "--jobs",
            "1",
            "--preset",
            "freeway",
            "--exclude",
            exclude,
            "-o",
            str(tmp_path / "req.json"),
            *extra,
        ],
        env={"SENSORSEL_PROGRESS_EVERY": every, "SENSORSEL_PROGRESS": None},
    )


def test_quiet_is_silent_off_a_terminal_unless_progress_is_asked_for(tmp_path):
    assert _require_here(tmp_path, "-q").stderr == ""
    assert "sensorsel: searching:" not in _require_here(tmp_path, "--no-progress").stderr
    assert "sensorsel: searching:" in _require_here(tmp_path, "-q", "--progress").stderr
    # the default interval: a search of under 5 s writes no status line to a log
    assert "sensorsel: searching:" not in _require_here(tmp_path, every="1000").stderr


@pytest.mark.parametrize("value", ["soon", "-1", "nan"])
def test_a_bad_interval_is_one_line_naming_the_variable(tmp_path, value):
    r = _require_here(tmp_path, every=value)
    assert r.exit_code == 2 and r.stderr.strip().splitlines() == [
        f"sensorsel: error: $SENSORSEL_PROGRESS_EVERY={value!r}: expected a number of seconds >= 0"
    ], r.stderr


def test_osm_into_a_pipe_says_each_stage_it_is_in(tmp_path):
    """sensorsel osm on the bundled sample, its stderr a pipe: a status line at each stage (reading the
    extract, the routes, writing), the routes counted as the domain it wrote holds them; -q silences it."""
    env = {**os.environ, "SENSORSEL_PROGRESS_EVERY": "0"}
    env.pop("SENSORSEL_PROGRESS", None)
    p = subprocess.run(
        [str(BIN / "sensorsel"), "osm", "--sample", "helsinki", "--output-dir", str(tmp_path / "city")],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )
    assert p.returncode == 0, p.stderr
    lines = [line for line in p.stderr.splitlines() if line.startswith("sensorsel: osm:")]
    n_routes = len([f for f in (tmp_path / "city" / "routes").glob("*.csv") if not f.name.endswith("_landmarks.csv")])
    assert lines[0].startswith("sensorsel: osm: reading helsinki.osm.pbf; ")
    assert lines[1].startswith("sensorsel: osm: routes that drive every road of ")
    assert lines[2].startswith(f"sensorsel: osm: writing {n_routes} routes; ")
    assert re.match(rf"^sensorsel: osm: done in \d+ s; wrote {n_routes} routes$", lines[-1]), lines
    q = subprocess.run(
        [str(BIN / "sensorsel"), "osm", "--sample", "helsinki", "-q", "--output-dir", str(tmp_path / "city2")],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )
    assert q.returncode == 0 and "sensorsel: osm:" not in q.stderr
