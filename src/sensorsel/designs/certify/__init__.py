"""How far from the best possible suite? A certificate for every greedy answer, and the exact optimum.

Modules: :mod:`.knapsack` (cost units, exact DP, branch and bound, the fractional bound, and the
multi-row :func:`packing_bound` by ``milp`` for constraints besides the budget),
:mod:`.certificate` (the submodular upper bound U(S), :func:`certificate` of a greedy run,
:class:`Certificate`, :class:`CertifiedGreedyResult`), :mod:`.exact` (:func:`optimal`, the exact
best suite by branch and bound). Builds on :mod:`sensorsel.designs.selection`, never the other way round.

Everything here is deterministic for a deterministic evaluator: same inputs, same bytes out (the
wall time sits in a separate ``seconds`` field). Numbers are exact up to floating-point round-off of
the scores (relative ~1e-12); a gain below round-off counts as zero.
"""

from __future__ import annotations

from sensorsel.designs.certify.certificate import (
    Certificate,
    CertifiedGreedyResult,
    SuiteBound,
    certificate,
    certify_greedy,
    constraints_mismatch,
    format_certificate,
    suite_bound,
)
from sensorsel.designs.certify.exact import DEFAULT_MAX_NODES, OptimumResult, optimal
from sensorsel.designs.certify.knapsack import (
    MAX_DP_CELLS,
    MAX_KNAPSACK_NODES,
    MAX_MILP_NODES,
    CostUnits,
    KnapsackSolution,
    cost_units,
    fractional_bound,
    knapsack,
    packing_bound,
    quiet_stdout,
)

__all__ = [
    "DEFAULT_MAX_NODES",
    "MAX_DP_CELLS",
    "MAX_KNAPSACK_NODES",
    "MAX_MILP_NODES",
    "Certificate",
    "CertifiedGreedyResult",
    "CostUnits",
    "KnapsackSolution",
    "OptimumResult",
    "SuiteBound",
    "certificate",
    "certify_greedy",
    "constraints_mismatch",
    "cost_units",
    "format_certificate",
    "fractional_bound",
    "knapsack",
    "optimal",
    "packing_bound",
    "quiet_stdout",
    "suite_bound",
]
