"""Shared fixtures. KITTI ground truth is read from $SENSORSEL_KITTI_ROOT or ../shared/kitti.

Under CI (CI=true) a test that needs KITTI fails when the data is missing; elsewhere it skips.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from sensorsel.model.library import load_library
from sensorsel.model.problem import build_problem
from sensorsel.model.scenario import ScenarioSpec, load_scenario

REPO = Path(__file__).resolve().parents[1]


def _kitti_root() -> Path | None:
    for cand in (os.environ.get("SENSORSEL_KITTI_ROOT"), REPO.parent / "shared" / "kitti"):
        if cand and (Path(cand) / "poses" / "03.txt").is_file():
            return Path(cand)
    return None


@pytest.fixture(scope="session")
def kitti_root() -> Path:
    root = _kitti_root()
    if root is None:
        msg = "KITTI ground truth not found: set SENSORSEL_KITTI_ROOT or put it at ../shared/kitti"
        if os.environ.get("CI", "").lower() == "true":
            pytest.fail(msg)
        pytest.skip(msg)
    return root


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
