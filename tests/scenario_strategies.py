"""Hypothesis strategies: small random scenarios built by hand, and small sub-libraries.

A route of 3-7 keyframes (steps of 4-15 m, turns of up to ~17 degrees a step), 2-14 landmarks
scattered within 35 m of a random keyframe, and a sub-library of 3-6 sensors of Table I that always
holds one roof LiDAR (360 degrees) so that the scores are not all zero.
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import strategies as st

from sensorsel.model.library import SensorLibrary
from sensorsel.model.problem import Problem, build_problem
from sensorsel.model.scenario import Scenario, Trajectory

ROOF_LIDARS = (0, 25)  # LRL-roof, MRL-roof in Table I's order
N_TABLE_I = 62


@st.composite
def scenarios(draw) -> Scenario:
    k = draw(st.integers(3, 7))
    x, y, h = 0.0, 0.0, draw(st.floats(-math.pi, math.pi))
    poses = [(x, y, h)]
    for _ in range(k - 1):
        step = draw(st.floats(4.0, 15.0))
        h = h + draw(st.floats(-0.3, 0.3))
        x, y = x + step * math.cos(h), y + step * math.sin(h)
        poses.append((x, y, math.atan2(math.sin(h), math.cos(h))))
    m = draw(st.integers(2, 14))
    landmarks = []
    for _ in range(m):
        anchor = poses[draw(st.integers(0, k - 1))]
        r = draw(st.floats(3.0, 35.0))
        a = draw(st.floats(-math.pi, math.pi))
        landmarks.append((anchor[0] + r * math.cos(a), anchor[1] + r * math.sin(a)))
    p = np.array(poses)
    return Scenario("hypothesis", Trajectory(p, np.arange(k, dtype=float), np.arange(k)), np.array(landmarks))


@st.composite
def sub_libraries(draw, library: SensorLibrary, min_size: int = 3, max_size: int = 6) -> SensorLibrary:
    lidar = draw(st.sampled_from(ROOF_LIDARS))
    others = draw(
        st.lists(
            st.integers(0, len(library) - 1).filter(lambda i: i != lidar),
            min_size=min_size - 1,
            max_size=max_size - 1,
            unique=True,
        )
    )
    return library.subset(sorted([lidar] + others))


@st.composite
def problems(draw, library: SensorLibrary, min_size: int = 3, max_size: int = 6) -> Problem:
    return build_problem(draw(sub_libraries(library, min_size, max_size)), draw(scenarios()))
