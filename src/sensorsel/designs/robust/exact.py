"""The exact robust optimum max { g(S) : Cost(S) <= B } by best-first branch and bound (small libraries).

Sensors are ordered by f({e}) (largest first; ties: cheaper, then library order). A node is a suite
S_in with a position k in that order: it stands for the suites S_in ∪ T, T ⊆ R, where R are the sensors
after k that fit the budget left. Expanding it:

* if all of R fits together, S_in ∪ R is the node's best suite (g is monotone, see :mod:`.bound`):
  one worst-case computation settles the node;
* else its bound is the smallest, over j = 0 .. min(alpha, |S_in|), of

      f(S_in minus F_j) + K_{alpha-j}(gains Δ(e | S_in minus F_j) over R, budget left)

  with F_j the j-subset of S_in that leaves the least, and K_m the knapsack whose m most valuable
  items count nothing (:func:`.bound.knapsack_drop`). Valid: for a completion S_in ∪ T, fail F_j
  and the alpha - j sensors of T of largest gain D; f(S_in ∪ T minus F_j minus D) <= f(S_in minus F_j)
  + Σ_{T minus D} Δ(e | S_in minus F_j) (monotone, submodular);
* the node is dropped when its bound does not beat the best worst case found by more than a relative
  1e-9; otherwise it splits on the first sensor r of R: r in (S_in + r) or r out.

Constraints (:mod:`sensorsel.model.constraints`): the root holds the required sensors, excluded ones are
never in R, and R holds only the sensors that fit every limit on top of S_in (so every node's S_in
is a feasible suite, and so is S_in ∪ R when it is tried). With rows besides the budget, the
knapsack keeps them all: an integer program over what S_in leaves of every row
(:func:`.bound.knapsack_drop_rows`); with the budget alone it is the single knapsack's dynamic program.

The best found is proved optimal when no node is left; at the node limit, the largest bound left is
an upper bound on the optimum.
"""

from __future__ import annotations

import heapq
import itertools
import math
import time
from collections.abc import Sequence

import numpy as np

from sensorsel.designs.parts import elapsed_s
from sensorsel.designs.resilient import check_alpha, worst_case
from sensorsel.designs.robust.bound import knapsack_drop, knapsack_drop_rows
from sensorsel.designs.robust.records import RobustOptimum
from sensorsel.designs.selection import REL_TOL, check_budget
from sensorsel.information.evaluators import Evaluator, as_suite
from sensorsel.model.constraints import REL_SLACK, Constraints, feasible_set, recorded

#: Default node limit of the exact search.
DEFAULT_EXACT_NODES = 20_000


# Long on purpose (~70 lines): one best-first branch and bound loop (expand, bound, prune, incumbent)
# whose state is local to the loop.
def robust_optimum(
    evaluator: Evaluator,
    budget_usd: float,
    alpha: int,
    *,
    incumbent: Sequence[int] = (),
    max_nodes: int = DEFAULT_EXACT_NODES,
    constraints: Constraints | None = None,
) -> RobustOptimum:
    """Best worst case within the budget (see the module docstring).

    Args:
        incumbent: a suite to start from (e.g. the robust selection's answer); the search only has
            to rule out better ones.
        max_nodes: nodes expanded at most.
        constraints: limits besides the budget; only suites that keep them all are explored.
    """
    t0 = time.perf_counter()
    budget, alpha = check_budget(budget_usd), check_alpha(alpha)
    ev = evaluator
    lib = ev.library
    ids, n = lib.ids, len(lib)
    feas = feasible_set(lib, budget, recorded(constraints))
    costs = feas.A[0]  # the price; 0 for owned required sensors (they are in every suite)
    n0 = ev.n_evaluations
    singles = ev.scores_with((), list(range(n)))
    root = as_suite(feas.required)
    order = sorted(
        (i for i in range(n) if i not in feas.excluded and i not in root), key=lambda i: (-singles[i], costs[i], ids[i])
    )
    n_order = len(order)
    rows = not feas.only_budget  # limits besides the budget: the knapsacks keep them all
    slack = REL_SLACK * np.maximum(1.0, np.abs(feas.b))

    def gval(s: tuple[int, ...]) -> float:
        return worst_case(ev, s, alpha).score if s else 0.0

    best_s: tuple[int, ...] = as_suite(incumbent) if incumbent and feas.fits(incumbent) else root
    best_g = gval(best_s)

    def offer(s: tuple[int, ...], g: float) -> None:
        nonlocal best_s, best_g
        s = as_suite(s)
        tol = REL_TOL * max(1.0, abs(best_g))
        if g > best_g + tol or (
            abs(g - best_g) <= tol and (lib.cost(s), lib.suite_ids(s)) < (lib.cost(best_s), lib.suite_ids(best_s))
        ):
            best_s, best_g = s, g

    heap: list[tuple[float, int, tuple[int, ...], int, float]] = [
        (-math.inf, 0, root, 0, budget - float(feas.usage(root)[0]))
    ]
    counter = nodes = pruned = 0
    stop = ""
    while heap:
        neg, _, s, k, left = heap[0]
        if -neg <= best_g + REL_TOL * max(1.0, abs(best_g)):
            pruned += len(heap)
            heap.clear()
            break
        if nodes >= max_nodes:
            stop = f"node limit ({max_nodes:,}) reached"
            break
        heapq.heappop(heap)
        nodes += 1
        fit = feas.addable(feas.usage(s))
        rest = [order[j] for j in range(k, n_order) if fit[order[j]]]
        if feas.fits(s + tuple(rest)):
            full = as_suite(s + tuple(rest))
            offer(full, gval(full))
            continue
        ub = -neg
        for j in range(min(alpha, len(s)) + 1):
            fails = {
                f: ev.score(tuple(i for i in s if i not in f)) if j < len(s) else 0.0
                for f in itertools.combinations(s, j)
            }
            fj = min(fails, key=lambda f: (fails[f], f))
            base = tuple(i for i in s if i not in fj)
            f_base = fails[fj]
            if j == min(alpha, len(s)) and len(s) > 0:
                offer(s, f_base)
            gains = np.maximum(ev.scores_with(base, rest) - f_base, 0.0)
            if rows:  # every limit: the integer program over what s leaves of each row
                ub = min(
                    ub,
                    f_base
                    + knapsack_drop_rows(gains, feas.A[:, rest], feas.b - feas.usage(s), alpha - j, slack=slack)[0],
                )
            else:
                ub = min(ub, f_base + knapsack_drop(gains, costs[rest], left, alpha - j))
        if ub <= best_g + REL_TOL * max(1.0, abs(best_g)):
            pruned += 1
            continue
        r = rest[0]
        nxt = order.index(r) + 1
        counter += 1
        heapq.heappush(heap, (-ub, counter, s + (r,), nxt, left - float(costs[r])))
        counter += 1
        heapq.heappush(heap, (-ub, counter, s, nxt, left))
    proved = not heap
    upper = best_g if proved else max(best_g, -heap[0][0])
    if proved:
        stop = "every other suite ruled out by its bound"
    w = worst_case(ev, best_s, alpha) if best_s else None
    return RobustOptimum(
        alpha=alpha,
        budget_usd=budget,
        suite=lib.suite_ids(best_s),
        cost_usd=lib.cost(best_s),
        nominal_score=w.nominal_score if w else 0.0,
        worst_score=best_g,
        failures=w.failures if w else (),
        proved_optimal=proved,
        upper_bound=float(upper),
        gap_percent=100.0 * (upper - best_g) / upper if upper > 0 else 0.0,
        n_nodes=nodes,
        n_pruned=pruned,
        n_evaluations=ev.n_evaluations - n0,
        stop_reason=stop,
        seconds=elapsed_s(t0),
        constraints=feas.record,
    )
