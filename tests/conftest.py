"""Shared fixtures, and the data some tests need that the repository does not ship.

Three kinds of outside data, each named by its own environment variable (docs/development.md):

- ``SENSORSEL_KITTI_ROOT``: KITTI odometry ground truth and its pole maps (``poses/NN.txt``,
  ``sequences/NN/times.txt``, ``landmarks/NN.csv``), the folder ``sensorsel kitti`` builds;
- ``SENSORSEL_PAPER_DIR``: the paper's LaTeX text (a folder holding one ``*.txt``);
- ``SENSORSEL_OSM_DIR``: the folder holding the original ``helsinki.osm.pbf`` extract.

A test that needs one of them skips, with a one-line reason, when its variable is unset, and fails,
naming the folder, when the variable is set but the folder does not hold the data: asking for the
data and not getting it is an error, never a quiet skip. ``.ci/run`` sets all three (``../shared``
beside the clone), so this project's CI runs every test; a fork's CI, with nothing set, skips them.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from sensorsel.model.library import load_library
from sensorsel.model.problem import build_problem
from sensorsel.model.scenario import ScenarioSpec, load_scenario

REPO = Path(__file__).resolve().parents[1]

# Off a terminal a run writes a status line every few seconds (sensorsel.cli.progress); the tests
# compare commands' stderr and output exactly, and on a loaded machine a run may pass 5 s: no status
# lines unless a test asks for them (tests/test_progress.py sets its own interval).
os.environ.setdefault("SENSORSEL_PROGRESS_EVERY", "3600")

# variable -> (what must be inside the folder, what the data is)
OUTSIDE_DATA = {
    "SENSORSEL_KITTI_ROOT": ("poses/03.txt", "KITTI odometry ground truth and pole maps"),
    "SENSORSEL_PAPER_DIR": ("*.txt", "the paper's LaTeX text"),
    "SENSORSEL_OSM_DIR": ("helsinki.osm.pbf", "the original Helsinki OpenStreetMap extract"),
}


def outside_data(var: str) -> Path:
    """The folder ``$var`` names, checked to hold its data; skips when unset, fails when wrong."""
    inside, what = OUTSIDE_DATA[var]
    value = os.environ.get(var, "").strip()
    if not value:
        pytest.skip(f"{what} not given: set {var} to run this test")
    root = Path(value).expanduser().resolve()
    if not root.is_dir() or not any(root.glob(inside)):
        pytest.fail(f"{var}={value}: no {inside} in {root} ({what} asked for and not found)", pytrace=False)
    return root


@pytest.fixture(scope="session")
def kitti_root() -> Path:
    return outside_data("SENSORSEL_KITTI_ROOT")


@pytest.fixture(scope="session")
def paper_dir() -> Path:
    return outside_data("SENSORSEL_PAPER_DIR")


@pytest.fixture(scope="session")
def osm_dir() -> Path:
    return outside_data("SENSORSEL_OSM_DIR")


@pytest.fixture(scope="session")
def library():
    return load_library()


@pytest.fixture(scope="session")
def tiny_problem(library):
    return build_problem(library, load_scenario(ScenarioSpec(fixture="tiny")))


@pytest.fixture(scope="session")
def suburb_problem(library):
    return build_problem(library, load_scenario(ScenarioSpec()))


@pytest.fixture(scope="session")
def kitti03_problem(library, kitti_root):
    return build_problem(library, load_scenario(ScenarioSpec(seq="03", kitti_root=str(kitti_root))))
