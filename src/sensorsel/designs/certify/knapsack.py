"""0/1 knapsacks of marginal gains: costs in units of the library's cost resolution, exact DP, exact
branch and bound with a node limit, and the fractional (LP) bound.

Knapsacks are solved exactly by dynamic programming over costs in units of the library's cost
resolution (the gcd of the costs, after scaling them to integers); when the table would be too
large, by an exact branch and bound with a node limit, whose unfinished search still gives a valid
upper bound (never below the true maximum). :func:`fractional_bound` is the LP relaxation (a valid,
looser bound) that the exact suite search falls back on. Which method was used is recorded.

With constraints besides the budget (:mod:`sensorsel.model.constraints`: resource limits, mounting slots,
a largest number of sensors) the knapsack has several rows; :func:`packing_bound` solves it with
scipy's ``milp`` (HiGHS) and always returns a valid upper bound (the proved dual bound, or the LP
relaxation when HiGHS stops at its node limit without one).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from sensorsel.errors import InputError
from sensorsel.io.files import quiet_stdout
from sensorsel.io.results import result_kind

#: Largest dynamic-programming table (items x capacity cells) solved by DP; above it, branch and bound.
MAX_DP_CELLS = 50_000_000
#: Node limit of the knapsack branch and bound used when the DP table is too large.
MAX_KNAPSACK_NODES = 200_000
#: Decimal scales tried to make costs integral ($1, 10 cents, 1 cent, ... 1 micro-dollar).
_COST_SCALES = tuple(10**k for k in range(7))


@dataclass(frozen=True)
class CostUnits:
    """Costs as integers in units of the cost resolution.

    Attributes:
        costs: (n,) integer costs [units].
        capacity: the capacity [units], rounded down (a set of items fits in the real capacity
            iff its integer cost fits in this one, when ``exact``).
        unit_usd: one unit [$] (gcd of the scaled costs / scale).
        exact: False when the costs were not decimal numbers with <= 6 digits after the point and
            were rounded *down* to micro-dollars: the knapsack is then a relaxation (its value an
            upper bound, never below the true maximum).
    """

    costs: np.ndarray
    capacity: int
    unit_usd: float
    exact: bool


def cost_units(costs: Sequence[float] | np.ndarray, capacity: float) -> CostUnits:
    """Express ``costs`` [$] and ``capacity`` [$] as integers at their resolution (gcd of the costs)."""
    c = np.asarray(costs, dtype=float).reshape(-1)
    if np.any(~np.isfinite(c)) or np.any(c < 0):
        raise InputError(f"knapsack costs must be finite and non-negative, got {c.tolist()!r}")
    if not math.isfinite(capacity) or capacity < 0:
        raise InputError(f"knapsack capacity must be finite and non-negative, got {capacity!r}")
    exact = False
    for scale in _COST_SCALES:
        scaled = c * scale
        if np.all(np.abs(scaled - np.round(scaled)) <= 1e-7 * np.maximum(1.0, scaled)):
            ints = np.round(scaled).astype(np.int64)
            exact = True
            break
    else:  # not decimal: round down, which only enlarges the feasible sets (a relaxation)
        scale = _COST_SCALES[-1]
        ints = np.floor(c * scale).astype(np.int64)
    g = int(np.gcd.reduce(ints[ints > 0])) if np.any(ints > 0) else 1
    # A tiny slack so that a budget equal to a sum of costs is not lost to float round-off.
    cap = int(math.floor(capacity * scale * (1 + 1e-12) + 1e-6)) // g
    return CostUnits(ints // g, cap, g / scale, exact)


@result_kind("knapsack")
@dataclass(frozen=True)
class KnapsackSolution:
    """A 0/1 knapsack solution.

    Attributes:
        value: the maximum of Σ values over item sets within the capacity (``exact``), or an upper
            bound on it (never below the maximum).
        chosen: positions of the items of the best set found, ascending.
        achieved: Σ values of ``chosen`` (equals ``value`` when exact).
        method: "trivial" (nothing or everything fits), "dp", "branch-and-bound", or
            "branch-and-bound (node limit: bound)" when the search stopped at its node limit.
        exact: whether ``value`` is the exact maximum.
    """

    value: float
    chosen: tuple[int, ...]
    achieved: float
    method: str
    exact: bool


def knapsack(
    values: Sequence[float] | np.ndarray,
    costs: Sequence[float] | np.ndarray,
    capacity: float,
    *,
    max_cells: int = MAX_DP_CELLS,
    max_nodes: int = MAX_KNAPSACK_NODES,
) -> KnapsackSolution:
    """max Σ_{i ∈ T} values[i] subject to Σ_{i ∈ T} costs[i] <= capacity, over sets T of items.

    Items with a value <= 0 or a cost above the capacity are never taken. Exact dynamic programming
    over costs at their resolution when items x capacity cells <= ``max_cells``; else an exact branch
    and bound (fractional bounds, items by value density), which returns a valid upper bound if it
    reaches ``max_nodes``.

    Args:
        values: (n,) item values (any unit; here nats).
        costs: (n,) item costs [$], >= 0.
        capacity: [$].
    """
    v = np.asarray(values, dtype=float).reshape(-1)
    c = np.asarray(costs, dtype=float).reshape(-1)
    if v.shape != c.shape:
        raise InputError(f"knapsack: {len(v)} values but {len(c)} costs")
    if np.any(~np.isfinite(v)):
        raise InputError(f"knapsack values must be finite, got {v.tolist()!r}")
    units = cost_units(c, capacity)
    keep = np.flatnonzero((v > 0) & (units.costs <= units.capacity))
    if len(keep) == 0:
        return KnapsackSolution(0.0, (), 0.0, "trivial", True)
    w = units.costs[keep]
    if int(w.sum()) <= units.capacity:
        total = float(v[keep].sum())
        return KnapsackSolution(total, tuple(int(i) for i in keep), total, "trivial", units.exact)
    cap = int(min(units.capacity, w.sum()))
    if len(keep) * (cap + 1) <= max_cells:
        value, chosen = _knapsack_dp(v[keep], w, cap)
        picked = tuple(int(keep[i]) for i in chosen)
        return KnapsackSolution(value, picked, float(v[list(picked)].sum()), "dp", units.exact)
    # Branch and bound on the real costs (no integer table needed).
    best, chosen, upper, done = _knapsack_bnb(v[keep], c[keep], capacity, max_nodes)
    picked = tuple(sorted(int(keep[i]) for i in chosen))
    if done:
        return KnapsackSolution(best, picked, best, "branch-and-bound", True)
    return KnapsackSolution(upper, picked, best, "branch-and-bound (node limit: bound)", False)


def _knapsack_dp(values: np.ndarray, costs: np.ndarray, capacity: int) -> tuple[float, list[int]]:
    """Exact 0/1 knapsack by DP over integer capacity 0..capacity: (max value, chosen item positions).

    dp[c] = best value with total cost <= c; one vectorised pass per item, a boolean table for the
    reconstruction. Ties keep the earlier items' solution, so the answer is deterministic.
    """
    n = len(values)
    dp = np.zeros(capacity + 1)
    take = np.zeros((n, capacity + 1), dtype=bool)
    for k in range(n):
        wk, vk = int(costs[k]), float(values[k])
        if wk == 0:
            dp += vk
            take[k, :] = True
            continue
        cand = dp[: capacity + 1 - wk] + vk
        better = cand > dp[wk:]
        take[k, wk:] = better
        dp[wk:] = np.where(better, cand, dp[wk:])
    chosen = []
    cap = capacity
    for k in range(n - 1, -1, -1):
        if take[k, cap]:
            chosen.append(k)
            cap -= int(costs[k])
    return float(dp[capacity]), sorted(chosen)


def fractional_bound(values: np.ndarray, costs: np.ndarray, capacity: float) -> float:
    """The LP relaxation of the knapsack (Dantzig): items by value density, the last one in part.

    An upper bound on the 0/1 maximum. Items must have positive values; zero-cost items are taken.
    """
    free = costs <= 0
    total = float(values[free].sum())
    v, c = values[~free], costs[~free]
    order = np.lexsort((np.arange(len(v)), -(v / c)))
    room = capacity
    for i in order:
        if c[i] <= room:
            total += float(v[i])
            room -= float(c[i])
        else:
            total += float(v[i]) * room / float(c[i])
            break
    return total


def _knapsack_bnb(
    values: np.ndarray, costs: np.ndarray, capacity: float, max_nodes: int
) -> tuple[float, list[int], float, bool]:
    """Exact 0/1 knapsack by depth-first branch and bound with fractional bounds (Horowitz-Sahni).

    Returns (best value, its items, an upper bound on the maximum, finished). When the node limit
    stops the search, the upper bound is the largest fractional bound of the unexplored nodes (or the
    best found, if larger): every unexplored set of items lies under one of them.
    """
    n = len(values)
    order = [int(i) for i in np.lexsort((np.arange(n), -(values / np.maximum(costs, 1e-300))))]
    v = values[order]
    c = costs[order]
    slack = 1e-9 * max(1.0, capacity)

    def bound(k: int, room: float, val: float) -> float:
        return val + fractional_bound(v[k:], c[k:], room) if k < n else val

    best = 0.0
    best_set: list[int] = []
    # stack of (next item, room left, value so far, items taken, bound)
    stack: list[tuple[int, float, float, tuple[int, ...], float]] = [(0, capacity, 0.0, (), bound(0, capacity, 0.0))]
    nodes = 0
    while stack:
        k, room, val, taken, ub = stack.pop()
        if ub <= best:
            continue
        if k == n:
            continue
        nodes += 1
        if nodes > max_nodes:
            stack.append((k, room, val, taken, ub))
            upper = max([best] + [s[4] for s in stack if s[4] > best])
            return best, [order[i] for i in best_set], upper, False
        # exclude item k (pushed first: explored after the include branch)
        ub_out = bound(k + 1, room, val)
        if ub_out > best:
            stack.append((k + 1, room, val, taken, ub_out))
        if c[k] <= room + slack:
            val_in = val + float(v[k])
            taken_in = taken + (k,)
            if val_in > best:
                best, best_set = val_in, list(taken_in)
            ub_in = bound(k + 1, room - float(c[k]), val_in)
            if ub_in > best:
                stack.append((k + 1, room - float(c[k]), val_in, taken_in, ub_in))
    return best, [order[i] for i in best_set], best, True


#: Node limit of HiGHS's branch and bound in :func:`packing_bound` (deterministic, unlike a time limit);
#: when it stops there, the bound is HiGHS's dual bound (still never below the maximum).
MAX_MILP_NODES = 20_000
#: Relative slack on every capacity of :func:`packing_bound` (as :data:`sensorsel.model.constraints.REL_SLACK`):
#: a set of items whose total equals a capacity fits despite round-off.
_PACKING_SLACK = 1e-9


def packing_bound(
    values: Sequence[float] | np.ndarray,
    A: np.ndarray,
    capacity: Sequence[float] | np.ndarray,
    *,
    max_nodes: int = MAX_MILP_NODES,
) -> KnapsackSolution:
    """max Σ_{i ∈ T} values[i] subject to Σ_{i ∈ T} A[:, i] <= capacity (every row), over sets T of items:
    a 0/1 multi-dimensional knapsack (several resources, mounting slots, a count), solved by
    :func:`scipy.optimize.milp` (HiGHS).

    The value is always an upper bound on the maximum (never below it): HiGHS's proved dual bound
    (with ``mip_rel_gap`` 0 it equals the optimum, up to HiGHS's absolute gap 1e-6 and feasibility
    tolerances, which can only loosen it); when HiGHS stops at ``max_nodes`` without one, the LP
    relaxation's value. ``method`` says which: "milp", "milp (node limit: dual bound)" or "lp
    relaxation" (plus "trivial" when no item fits or every positive item fits together).

    Args:
        values: (n,) item values (nats); items with a value <= 0 are never taken.
        A: (m, n) what each item uses of each row, >= 0.
        capacity: (m,) what is left of each row; an item using more than a row's capacity is never taken.
        max_nodes: HiGHS's node limit (deterministic).
    """
    v = np.asarray(values, dtype=float).reshape(-1)
    a = np.asarray(A, dtype=float).reshape(-1, len(v)) if len(v) else np.zeros((len(np.atleast_1d(capacity)), 0))
    cap = np.asarray(capacity, dtype=float).reshape(-1)
    if a.shape != (len(cap), len(v)):
        raise InputError(f"packing bound: A has shape {a.shape}, expected ({len(cap)}, {len(v)})")
    if np.any(~np.isfinite(v)) or np.any(~np.isfinite(a)) or np.any(a < 0) or np.any(np.isnan(cap)):
        raise InputError("packing bound: values and A must be finite, A >= 0")
    room = cap + _PACKING_SLACK * np.maximum(1.0, np.abs(cap))
    keep = np.flatnonzero((v > 0) & np.all(a <= room[:, None], axis=0))
    if len(keep) == 0:
        return KnapsackSolution(0.0, (), 0.0, "trivial", True)
    ak = a[:, keep]
    binding = ak.sum(axis=1) > room  # rows that every kept item together would break
    if not binding.any():
        total = float(v[keep].sum())
        return KnapsackSolution(total, tuple(int(i) for i in keep), total, "trivial", True)
    from scipy.optimize import Bounds, LinearConstraint, milp

    # rows scaled to capacity ~1 so that dollars and slot counts are alike to HiGHS's tolerances
    scale = 1.0 / np.maximum(np.abs(room[binding]), 1e-12)
    rows = ak[binding] * scale[:, None]
    cons = LinearConstraint(rows, -np.inf, np.ones(len(scale)))
    c = -v[keep]
    with quiet_stdout():
        res = milp(
            c,
            constraints=cons,
            integrality=np.ones(len(keep)),
            bounds=Bounds(0, 1),
            options={"mip_rel_gap": 0.0, "node_limit": int(max_nodes), "presolve": True, "disp": False},
        )
    chosen: tuple[int, ...] = ()
    if res.x is not None:
        pick = np.flatnonzero(res.x > 0.5)
        if np.all(ak[:, pick].sum(axis=1) <= room):  # keep only a set that truly fits (tolerances aside)
            chosen = tuple(int(keep[i]) for i in pick)
    achieved = float(v[list(chosen)].sum()) if chosen else 0.0
    dual = getattr(res, "mip_dual_bound", None)
    if dual is not None and math.isfinite(dual):
        value = max(-float(dual), achieved)
        if res.status == 0:
            return KnapsackSolution(value, chosen, achieved, "milp", True)
        return KnapsackSolution(value, chosen, achieved, "milp (node limit: dual bound)", False)
    with quiet_stdout():
        lp = milp(c, constraints=cons, integrality=np.zeros(len(keep)), bounds=Bounds(0, 1), options={"disp": False})
    if lp.status == 0 and lp.fun is not None and math.isfinite(lp.fun):
        return KnapsackSolution(max(-float(lp.fun), achieved), chosen, achieved, "lp relaxation", False)
    total = float(v[keep].sum())  # nothing solved: every item, the loosest valid bound
    return KnapsackSolution(total, chosen, achieved, "every item", False)
