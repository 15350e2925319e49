"""The layering of issue 11 for selection, certify and api (docs/architecture.md), checked on the
import statements of the source: selection never imports certify, tradespace or api; certify never
imports tradespace or api; nothing but the CLI and the package's ``__init__`` imports api."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "sensorsel"


def _imports(path: Path) -> set[str]:
    """Top-level sensorsel modules a file imports (``certify`` for ``from ..certify.exact import x``)."""
    pkg = list(path.relative_to(SRC).parts[:-1])
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.level:
            base = pkg[: len(pkg) - node.level + 1] + (node.module.split(".") if node.module else [])
            out.update([base[0]] if base else [a.name for a in node.names])
        elif isinstance(node, ast.ImportFrom) and (node.module or "").startswith("sensorsel."):
            out.add(str(node.module).split(".")[1])
        elif isinstance(node, ast.Import):
            out.update(a.name.split(".")[1] for a in node.names if a.name.startswith("sensorsel."))
    return out


def _files(layer: str) -> list[Path]:
    p = SRC / layer
    return sorted(p.rglob("*.py")) if p.is_dir() else [p.with_suffix(".py")]


@pytest.mark.parametrize("layer, forbidden", [
    # results is a base layer now (record classes register their kinds with results.result_kind)
    ("selection", {"certify", "tradespace", "api", "resilient", "plotting", "cli"}),
    ("certify", {"tradespace", "api", "resilient", "plotting", "cli"}),
    ("tradespace", {"certify", "api", "resilient", "plotting", "cli"}),
    ("api", {"cli", "plotting"}),
])
def test_layer_imports_nothing_above_it(layer, forbidden):
    for f in _files(layer):
        bad = _imports(f) & forbidden
        assert not bad, f"{f.relative_to(SRC)} imports {sorted(bad)}"


def test_only_the_cli_and_the_package_import_api():
    users = [f.relative_to(SRC) for f in SRC.rglob("*.py") if "api" in _imports(f) and f.name != "api.py"]
    assert all(u.parts[0] == "cli" or u == Path("__init__.py") for u in users), users


def test_the_import_parser_sees_relative_imports():
    assert {"selection", "evaluators", "problem", "errors"} <= _imports(SRC / "selection" / "greedy.py")
    assert {"certify", "results", "selection"} <= _imports(SRC / "cli" / "select.py")
    assert {"selection", "evaluators"} <= _imports(SRC / "certify" / "exact.py")
    assert "certify" in _imports(SRC / "api.py")
