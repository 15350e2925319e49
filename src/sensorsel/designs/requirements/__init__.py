"""Requirements in metres: a localization specification (lateral, longitudinal, heading), whether a
suite's accuracy meets it, and the cheapest suite that does, with a lower bound on any suite's cost.

    spec      Specification, the presets (Reid et al. 2019), specification files, verdicts
    solver    the cheapest suite meeting a monotone predicate: greedy upper bound, implicit hitting set
    design    ``require``: the two put together on a route or a domain
"""

from __future__ import annotations

from sensorsel.designs.requirements.design import RequireResult, RouteRequirement, require
from sensorsel.designs.requirements.front import FrontAcceptance, FrontPoint, front_acceptance
from sensorsel.designs.requirements.solver import CheapestSuite, cheapest_suite, meets_after_failures
from sensorsel.designs.requirements.spec import (
    DEFAULT_MAP_SIGMA_M,
    PRESETS,
    RouteVerdict,
    Specification,
    SpecificationError,
    load_specification_file,
    preset,
    verdict,
)

__all__ = [
    "CheapestSuite",
    "DEFAULT_MAP_SIGMA_M",
    "FrontAcceptance",
    "FrontPoint",
    "PRESETS",
    "RequireResult",
    "RouteRequirement",
    "RouteVerdict",
    "Specification",
    "SpecificationError",
    "cheapest_suite",
    "front_acceptance",
    "load_specification_file",
    "meets_after_failures",
    "preset",
    "require",
    "verdict",
]
