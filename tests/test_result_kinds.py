"""Result kinds are registered by their record classes (``@result_kind``), not named as strings in
results.py: importing the package registers every kind a module of it defines (so a file of any
kind can be read by kind), and results.py imports none of them (the layers contract sees that)."""

from __future__ import annotations

import importlib
import pkgutil
import subprocess
import sys

import sensorsel
from sensorsel.io import results


def test_importing_the_package_registers_every_kind_its_modules_define():
    # in a fresh interpreter: this test process has imported more than the package imports
    code = "import sensorsel, sensorsel.io.results as r; print(' '.join(sorted(r.KINDS)))"
    on_import = set(
        subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    )
    for m in pkgutil.walk_packages(sensorsel.__path__, "sensorsel."):
        importlib.import_module(m.name)
    assert on_import == set(results.KINDS)
    assert len(results.KINDS) >= 24  # the kinds of this version (docs/results)
    for kind, cls in results.KINDS.items():
        assert results.kind_of(cls) == kind


def test_a_greedy_run_without_certificate_is_written_as_a_greedy_file():
    from sensorsel.designs.certify import CertifiedGreedyResult
    from sensorsel.designs.selection import GreedyResult

    assert results.kind_of(GreedyResult) == "greedy" and results.record_class("greedy") is CertifiedGreedyResult


def test_results_names_no_record_module():
    text = open(results.__file__, encoding="utf-8").read()
    assert "importlib" not in text and '":' not in text.split("KINDS: dict")[1].split("\n")[0]
