"""The layering of docs/architecture.md holds (import-linter), and the check would catch a breach."""

from __future__ import annotations

import ast
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
LINT = Path(sys.executable).with_name("lint-imports")


def _lint(src: Path) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": str(src)}
    return subprocess.run(
        [str(LINT), "--config", str(REPO / "pyproject.toml"), "--no-cache"],
        cwd=REPO,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )


def test_layers_and_no_cycles_hold():
    out = _lint(REPO / "src")
    assert out.returncode == 0, out.stdout + out.stderr
    assert "0 broken" in out.stdout


@pytest.mark.parametrize(
    "module, line, broken, path",
    [
        # across packages: the model imports plotting
        (
            "model/sensing.py",
            "from sensorsel import plotting",
            "sensorsel.model is not allowed to import sensorsel.plotting",
            "sensorsel.model.sensing -> sensorsel.plotting",
        ),
        # inside a package: the greedy selection imports a search built on it
        (
            "designs/selection/greedy.py",
            "from sensorsel.designs import robust",
            "sensorsel.designs.selection is not allowed to import sensorsel.designs.robust",
            "sensorsel.designs.selection.greedy -> sensorsel.designs.robust",
        ),
        # plotting and the api are independent floors
        (
            "plotting/__init__.py",
            "from sensorsel import api",
            "sensorsel.plotting is not allowed to import sensorsel.api",
            "sensorsel.plotting -> sensorsel.api",
        ),
        # the command line goes around the api to a design
        (
            "cli/select.py",
            "from sensorsel.designs.selection import greedy",
            "sensorsel.cli is not allowed to import sensorsel.designs",
            "sensorsel.cli.select -> sensorsel.designs.selection",
        ),
        # ... or to an evaluator
        (
            "cli/options.py",
            "from sensorsel.information.evaluators import ENGINES",
            "sensorsel.cli is not allowed to import sensorsel.information",
            "sensorsel.cli.options -> sensorsel.information.evaluators",
        ),
        # the generic pipeline reaches up to the sensor code (the Dask evaluators sit with the evaluators)
        (
            "pipeline/cluster.py",
            "from sensorsel.information.evaluators import DomainEvaluator",
            "sensorsel.pipeline is not allowed to import sensorsel.information",
            "sensorsel.pipeline.cluster -> sensorsel.information.evaluators",
        ),
        (
            "pipeline/store.py",
            "from sensorsel.model.problem import Domain",
            "sensorsel.pipeline is not allowed to import sensorsel.model",
            "sensorsel.pipeline.store -> sensorsel.model.problem",
        ),
        # one command borrows a helper from another command's module
        (
            "cli/core.py",
            "from sensorsel.cli.simulate import simulate_cmd",
            "sensorsel.cli.core is not allowed to import sensorsel.cli.simulate",
            "sensorsel.cli.core -> sensorsel.cli.simulate",
        ),
    ],
)
def test_an_upward_import_breaks_the_build(module, line, broken, path, tmp_path):
    # a copy of the package with one upward import added: the check must fail and name it
    src = tmp_path / "src"
    shutil.copytree(REPO / "src" / "sensorsel", src / "sensorsel", ignore=shutil.ignore_patterns("__pycache__"))
    target = src / "sensorsel" / module
    target.write_text(target.read_text() + f"\n{line}  # an upward import\n")
    out = _lint(src)
    assert out.returncode != 0
    assert broken in out.stdout and path in out.stdout


def test_the_package_is_a_handful_of_concept_packages_and_no_module_is_long():
    """At most 14 modules and packages at the top level, no source module over 400 statements.

    Statements are counted on the syntax tree, which the formatter does not change (ruff format puts
    one argument per line in a call that passes 120 columns, so a line count says as much about the
    formatting as about the size); 400 statements is about 700 formatted lines."""
    pkg = REPO / "src" / "sensorsel"
    top = sorted(p.name for p in pkg.iterdir() if (p.suffix == ".py") or (p.is_dir() and (p / "__init__.py").is_file()))
    assert len(top) <= 14, top
    long = {str(p.relative_to(pkg)): n for p in pkg.rglob("*.py") if (n := statements(p.read_text())) > MAX_STATEMENTS}
    assert not long, long


MAX_STATEMENTS = 400


def statements(source: str) -> int:
    """The statements of a module's source, nested ones included (a def, each line of its body, ...)."""
    return sum(isinstance(node, ast.stmt) for node in ast.walk(ast.parse(source)))


def test_statements_are_counted_whatever_the_formatting():
    # the limit's measure: one call over one line or ten, the same count; a statement more, one more
    one = "f(a, b, c)\nx = 1\n"
    many = "f(\n    a,\n    b,\n    c,\n)\nx = 1\n"
    assert statements(one) == statements(many) == 2
    assert statements("def g():\n    return 1\n") == 2
    assert statements(one + "y = 2\n") == 3


def test_selecting_does_not_import_gtsam_and_simulate_stays_the_function():
    """gtsam (~0.1-0.15 s to import) is loaded only where a graph is built or a simulation runs:
    importing the CLI and the API does not; ``sensorsel.simulate`` is the run function, also after
    the simulation package's modules are imported."""
    code = (
        "import sys, sensorsel.cli, sensorsel.api\n"
        "assert 'gtsam' not in sys.modules, 'gtsam imported'\n"
        "import sensorsel, sensorsel.simulation.records\n"
        "f = sensorsel.simulate\n"
        "assert callable(f) and f.__name__ == 'simulate' and f.__module__ == 'sensorsel.api'\n"
        "import sensorsel.simulation.run\n"
        "from sensorsel.api import simulate\n"
        "assert simulate is f and sensorsel.simulate is f and 'gtsam' in sys.modules\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
