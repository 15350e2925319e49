"""A limit met exactly by fractional resources: 3 x 0.19 kg under a 0.57 kg limit is 0.5700000000000001
in floating point. The three sensors fit (by hand: 3 x 0.19 = 0.57 exactly); without the round-off
slack of ``FeasibleSet.addable`` (REL_SLACK) the third would be dropped."""

from __future__ import annotations

from sensorsel.api import run_greedy
from sensorsel.model.constraints import Constraints, feasible_set
from sensorsel.model.problem import build_problem
from sensorsel.model.scenario import ScenarioSpec, load_scenario

RADARS = ("MRR-12", "MRR-3", "MRR-6", "MRR-9")  # the stock library's mid-range radar: 0.19 kg each


def test_three_sensors_of_0_19_kg_fit_a_0_57_kg_limit(library):
    lib = library.subset([library.position(i) for i in RADARS])
    assert all(dict(s.model.resources)["mass_kg"] == 0.19 for s in lib)
    assert 0.19 + 0.19 + 0.19 > 0.57  # the round-off the slack is for
    problem = build_problem(lib, load_scenario(ScenarioSpec(fixture="tiny")))
    limit = Constraints.of(limits={"mass_kg": 0.57})
    res = run_greedy(problem, 1e6, "uniform", constraints=limit)  # the budget does not bind: 4 radars cost $11,320
    assert len(res.suite) == 3  # by hand: 3 x 0.19 = 0.57 kg meets the limit, a 4th (0.76 kg) does not
    assert "mass_kg" in res.stop_reason
    feas = feasible_set(lib, 1e6, limit)
    assert feas.violations(lib.resolve_suite(res.suite)) == []
    assert feas.violations(range(len(lib))) != []  # all four break it
