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


# ------------------------------------------------------------------------------ notebook hygiene


def test_importing_plotting_leaves_the_backend_alone(tmp_path):
    """A notebook's backend (here svg, chosen by MPLBACKEND) survives importing sensorsel.plotting."""
    import os
    import subprocess
    import sys

    code = ("import matplotlib; before = matplotlib.get_backend(); import sensorsel.plotting; "
            "print(before, matplotlib.get_backend())")
    env = {**os.environ, "MPLBACKEND": "svg", "MPLCONFIGDIR": str(tmp_path)}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True).stdout.split()
    assert out == ["svg", "svg"]


def test_plots_draw_on_the_given_axes_and_never_show(tiny_problem, monkeypatch):
    import matplotlib.pyplot as plt

    from sensorsel.plotting import plot_scene

    monkeypatch.setattr(plt, "show", lambda *a, **k: pytest.fail("a plot called plt.show()"))
    fig, ax = plt.subplots()
    try:
        assert plot_scene(tiny_problem.scenario, ax) is ax
    finally:
        plt.close(fig)
