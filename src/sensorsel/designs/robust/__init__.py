"""Robust sensor selection: the best worst case under alpha failures within a budget.

Maximise g(S) = min over F ⊆ S, |F| <= alpha, of f(S minus F) over suites with Cost(S) <= B.

* :func:`robust_select` runs several methods (plain greedy, the paper's Algorithm 2, Oblivious-Greedy,
  SATURATE, local search; :mod:`.methods` states each one's guarantee), scores every suite by its
  **exact** worst case and keeps the best: never below plain greedy's worst case nor Algorithm 2's,
  by construction.
* :func:`robust_bound` bounds the best achievable worst case from above (proof in :mod:`.bound`);
  every answer reports it and its gap.
* :func:`robust_optimum` finds the exact optimum on small libraries by branch and bound (:mod:`.exact`).
* :mod:`.family` is the max-min machinery over any finite family of monotone submodular functions
  (failure sets now; routes of a domain or periods of a route through :class:`EvaluatorFamily`).
* :func:`worst_route_select` (:mod:`.worst`) is the max-min over a domain's routes (each route's share
  of its best, under alpha failures): ``--aggregate worst``.
"""

from sensorsel.designs.robust.bound import knapsack_drop, robust_bound
from sensorsel.designs.robust.exact import robust_optimum
from sensorsel.designs.robust.family import EvaluatorFamily, FailureFamily, Family
from sensorsel.designs.robust.memo import MemoEvaluator, memoized
from sensorsel.designs.robust.methods import local_search, oblivious_greedy, saturate
from sensorsel.designs.robust.records import (
    BoundLeaf,
    Candidate,
    MemberWorst,
    RobustBound,
    RobustOptimum,
    RobustResult,
    better,
)
from sensorsel.designs.robust.select import DEFAULT_RULES, EXTRA_METHODS, robust_choice, robust_select, run_robust
from sensorsel.designs.robust.tasks import (
    ALGORITHM_2,
    MethodOutcome,
    MethodTask,
    RobustSettings,
    RobustTaskRecord,
    run_method,
)
from sensorsel.designs.robust.worst import WORST_METHODS, RouteFailureFamily, worst_route_select

__all__ = [
    "ALGORITHM_2",
    "MethodOutcome",
    "MethodTask",
    "RobustSettings",
    "RobustTaskRecord",
    "better",
    "run_method",
    "BoundLeaf",
    "Candidate",
    "DEFAULT_RULES",
    "EXTRA_METHODS",
    "EvaluatorFamily",
    "FailureFamily",
    "Family",
    "MemberWorst",
    "MemoEvaluator",
    "RouteFailureFamily",
    "WORST_METHODS",
    "worst_route_select",
    "RobustBound",
    "RobustOptimum",
    "RobustResult",
    "knapsack_drop",
    "local_search",
    "memoized",
    "oblivious_greedy",
    "robust_bound",
    "robust_choice",
    "robust_optimum",
    "robust_select",
    "run_robust",
    "saturate",
]
