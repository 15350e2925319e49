"""Options every command shares (issue 11, part 6): one progress adapter, budgets, -q, --json, plot
format, -o; and notebook hygiene (no backend chosen at import)."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from sensorsel.cli import cli
from sensorsel.cli import options as cli_options

REDUCED = Path(__file__).resolve().parents[1] / "configs" / "reduced_library.yaml"


def invoke(*args: str):
    return CliRunner().invoke(cli, list(args))


@pytest.fixture
def terminal(monkeypatch):
    """Pretend stderr is a terminal, and record every progress(done, total) call the bars get."""
    calls: list[tuple[str, int, int]] = []
    real_call = cli_options._Bar.__call__

    def record(self, done: int, total: int) -> None:
        calls.append((self.label, done, total))
        real_call(self, done, total)

    monkeypatch.setattr(cli_options, "_on_terminal", lambda: True)
    monkeypatch.setattr(cli_options._Bar, "__call__", record)
    return calls


@pytest.mark.parametrize("args, label", [
    (["simulate", "--fixture", "tiny", "--suite", "LRL-roof", "--runs", "2", "--jobs", "1", "-o", "{tmp}/sim"], "simulating"),
    (["resilient", "--fixture", "tiny", "--budget", "5000", "--period", "30", "--engine", "reference", "--jobs", "1",
      "-o", "{tmp}/res"], "periods"),
    (["optimal", "--fixture", "tiny", "--budget", "20000", "--max-nodes", "5", "--engine", "reference", "--jobs", "1",
      "--library", str(REDUCED)], "branch and bound"),
])
def test_every_bar_is_the_one_adapter_fed_done_and_total(terminal, tmp_path, args, label):
    r = invoke(*(a.replace("{tmp}", str(tmp_path)) for a in args))
    assert r.exit_code == 0, (r.output, r.exception)
    mine = [(d, t) for lab, d, t in terminal if label in lab]
    assert mine, terminal
    assert all(0 <= d <= t for d, t in mine)
    r = invoke(*(a.replace("{tmp}", str(tmp_path / "q")) for a in args), "-q")
    assert r.exit_code == 0, (r.output, r.exception)
    assert len([c for c in terminal if label in c[0]]) == len(mine)  # -q: no bar
