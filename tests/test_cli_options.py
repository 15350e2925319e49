"""Options every command shares: one progress adapter, budgets, -q, --json, plot
format, -o; and notebook hygiene (no backend chosen at import)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from sensorsel.cli import cli
from sensorsel.cli import options as cli_options
from sensorsel.cli import progress as cli_progress

REDUCED = Path(__file__).resolve().parents[1] / "configs" / "reduced_library.yaml"


def invoke(*args: str):
    return CliRunner().invoke(cli, list(args))


@pytest.fixture
def terminal(monkeypatch):
    """Pretend stderr is a terminal, and record every progress(done, total) call the bars get."""
    calls: list[tuple[str, int, int]] = []
    real_call = cli_progress.Display.__call__

    def record(self, done: int, total: int) -> None:
        calls.append((self.label, done, total))
        real_call(self, done, total)

    monkeypatch.setattr(cli_progress, "on_terminal", lambda: True)
    monkeypatch.setattr(cli_progress.Display, "__call__", record)
    return calls


@pytest.mark.parametrize(
    "args, label",
    [
        (
            [
                "simulate",
                "--fixture",
                "tiny",
                "--suite",
                "LRL-roof",
                "--runs",
                "2",
                "--jobs",
                "1",
                "--output-dir",
                "{tmp}/sim",
            ],
            "simulating",
        ),
        (
            [
                "resilient",
                "--fixture",
                "tiny",
                "--budget",
                "5000",
                "--period",
                "30",
                "--engine",
                "reference",
                "--jobs",
                "1",
                "--output-dir",
                "{tmp}/res",
            ],
            "periods",
        ),
        (
            [
                "optimal",
                "--fixture",
                "tiny",
                "--budget",
                "20000",
                "--max-nodes",
                "5",
                "--engine",
                "reference",
                "--jobs",
                "1",
                "--library",
                str(REDUCED),
            ],
            "branch and bound",
        ),
    ],
)
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

    code = (
        "import matplotlib; before = matplotlib.get_backend(); import sensorsel.plotting; "
        "print(before, matplotlib.get_backend())"
    )
    env = {**os.environ, "MPLBACKEND": "svg", "MPLCONFIGDIR": str(tmp_path)}
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True
    ).stdout.split()
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


# ----------------------------------------------------------------------- the same options everywhere

RESULT_COMMANDS = {
    "library",
    "score",
    "greedy",
    "pareto",
    "resilient",
    "certify",
    "optimal",
    "simulate",
    "robust",
    "study",
    "require",
    "scene",
    "landmarks",
    "osm",
    "kitti",
}
PROGRESS_COMMANDS = {"greedy", "pareto", "resilient", "certify", "optimal", "simulate", "robust", "study"}
BUDGET_COMMANDS = {"greedy", "pareto", "resilient", "certify", "optimal", "robust", "require"}
PLOT_COMMANDS = {"scene", "pareto", "resilient", "simulate"}
REQUIRED = {  # the other required options of each command, to parse its --budget alone
    "greedy": [],
    "pareto": ["--output-dir", "out"],
    "resilient": ["--output-dir", "out"],
    "certify": [],
    "optimal": [],
    "robust": [],
    "require": ["--preset", "freeway"],
}


def _params(name: str) -> dict[str, object]:
    return {p.name: p for p in cli.commands[name].params}


def _opts(name: str) -> set[str]:
    return {o for p in cli.commands[name].params for o in p.opts}


def test_every_result_command_has_json_and_every_progress_command_has_q():
    assert RESULT_COMMANDS | PROGRESS_COMMANDS | BUDGET_COMMANDS | PLOT_COMMANDS <= set(cli.commands)
    for name in RESULT_COMMANDS:
        assert "--json" in _opts(name), name
    for name in PROGRESS_COMMANDS:
        assert {"-q", "--quiet"} <= _opts(name), name


def test_every_budget_is_a_budget_type_and_every_plot_has_one_format_option():
    for name in cli.commands:
        budget = _params(name).get("budget")
        assert (budget is not None) == (name in BUDGET_COMMANDS), name
        if budget is not None:
            assert isinstance(budget.type, cli_options.BudgetType), name
        fmt = _params(name).get("plot_format")
        assert (fmt is not None) == (name in PLOT_COMMANDS), name
        if fmt is not None:
            assert fmt.opts == ["--plot-format"] and list(fmt.type.choices) == ["png", "svg", "pdf"], name


@pytest.mark.parametrize("name", sorted(BUDGET_COMMANDS))
@pytest.mark.parametrize("text", ["110000", "110,000", "$110,000", "110_000"])
def test_every_command_with_a_budget_accepts_every_spelling(name, text):
    ctx = cli.commands[name].make_context(name, ["--budget", text, *REQUIRED[name]])
    got = ctx.params["budget"]
    assert (got == (110_000.0,)) if name == "pareto" else (got == 110_000.0)


def test_a_budget_with_thousands_separators_runs(tmp_path):
    r = invoke(
        "greedy",
        "--fixture",
        "tiny",
        "--budget",
        "$5,000",
        "--engine",
        "reference",
        "--jobs",
        "1",
        "--no-certificate",
        "--json",
    )
    assert r.exit_code == 0, r.output
    assert json.loads(r.stdout)["budget_usd"] == 5000.0
    r = invoke(
        "pareto",
        "--fixture",
        "tiny",
        "--budget",
        "2,000",
        "--budget",
        "6,000",
        "--budgets",
        "$4_000",
        "--rules",
        "marginal",
        "--engine",
        "reference",
        "--jobs",
        "1",
        "--output-dir",
        str(tmp_path / "p"),
        "--json",
        "-q",
    )
    assert r.exit_code == 0, r.output
    data = json.loads(r.stdout)
    assert data["kind"] == "tradespace" and data["budgets_usd"] == [2000.0, 4000.0, 6000.0]


@pytest.mark.parametrize("name", sorted(n for n in cli.commands if "output" in _params(n) or "outdir" in _params(n)))
def test_an_empty_output_is_an_error_naming_the_option(name, tmp_path):
    folder = "outdir" in _params(name)
    r = invoke(name, "--output-dir" if folder else "-o", "")
    assert r.exit_code == 2
    assert ("'--output-dir'" if folder else "'-o' / '--output'") in r.output and "must not be empty" in r.output
    assert list(tmp_path.iterdir()) == []


def test_scene_format_and_extension_must_agree(tmp_path):
    r = invoke("scene", "--fixture", "tiny", "-o", str(tmp_path / "s.svg"), "--plot-format", "pdf")
    assert r.exit_code == 2 and "s.svg is a .svg file but --plot-format is pdf" in r.stderr
    r = invoke("scene", "--fixture", "tiny", "-o", str(tmp_path / "s.svg"), "--plot-format", "svg")
    assert r.exit_code == 0 and (tmp_path / "s.svg").read_bytes().lstrip().startswith(b"<?xml")


def test_library_json_lists_62_sensors():
    r = invoke("library", "--json")
    assert r.exit_code == 0, r.output
    data = json.loads(r.stdout)
    assert data["n_sensors"] == len(data["sensors"]) == 62
    first = data["sensors"][0]
    assert {"id", "model", "clock", "range_m", "fov_deg", "sigma_bearing_rad", "sigma_range_m", "cost_usd"} <= set(
        first
    )
    assert len({s["id"] for s in data["sensors"]}) == 62


def test_simulate_json_is_the_simulation_result(tmp_path):
    r = invoke(
        "simulate",
        "--fixture",
        "tiny",
        "--suite",
        "LRL-roof",
        "--runs",
        "1",
        "--jobs",
        "1",
        "--plot-format",
        "svg",
        "--output-dir",
        str(tmp_path),
        "--json",
    )
    assert r.exit_code == 0, r.output
    data = json.loads(r.stdout)
    assert data["kind"] == "simulation" and data["format"] == 1 and len(data["simulations"]) == 1
    assert (tmp_path / "simulate.svg").is_file()


def test_certify_refuses_a_result_of_another_kind(tmp_path):
    score = tmp_path / "score.json"
    r = invoke("score", "--fixture", "tiny", "--suite", "LRL-roof", "--engine", "reference", "--json")
    score.write_text(r.stdout)
    r = invoke("certify", "--fixture", "tiny", "--suite", str(score), "--engine", "reference", "--jobs", "1")
    assert r.exit_code == 2
    assert str(score) in r.stderr and "'score' result, expected a 'greedy'" in r.stderr
