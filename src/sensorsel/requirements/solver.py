"""STUB (replaced at merge by the solver branch): a greedy suite, no proof."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np


@dataclass(frozen=True)
class CheapestSuite:
    suite: tuple[int, ...]
    cost: float
    lower_bound: float
    proved: bool
    gap: float
    iterations: int
    n_checks: int
    cuts: tuple[tuple[int, ...], ...]
    status: str


def cheapest_suite(feasible: Any, meets: Callable[..., Any], *, failures: int = 0, violation: Callable[..., Any] | None = None,
                   time_limit: float | None = None, progress: Any = None, **kw: Any) -> CheapestSuite:
    n = feasible.A.shape[1]
    allowed = [i for i in range(n) if i not in feasible.excluded]
    suite = list(feasible.required)
    price = feasible.A[0]
    if not meets(tuple(allowed)):
        return CheapestSuite((), math.nan, math.inf, False, math.nan, 0, 0, (), "infeasible")
    assert violation is not None
    while not meets(tuple(sorted(suite))):
        v0 = violation(tuple(sorted(suite)))
        best = max((i for i in allowed if i not in suite), key=lambda i: ((v0 - violation(tuple(sorted(suite + [i])))) / max(price[i], 1), -i))
        suite.append(best)
    s = tuple(sorted(suite))
    c = float(price[list(s)].sum())
    return CheapestSuite(s, c, 0.0, False, c, 0, 0, (), "gap")
