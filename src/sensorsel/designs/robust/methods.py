"""The candidate methods of robust selection and their guarantees.

Every method returns a suite; :mod:`.select` scores each by its exact worst case and keeps the best.
Notation: V the library (n sensors), B the budget, alpha the failures, g(S) = min over F ⊆ S,
|F| = alpha of f(S minus F), OPT_r = max g(S) over Cost(S) <= B.

``greedy-<rule>``  plain greedy (:func:`sensorsel.designs.selection.greedy`) with the rule. Nominal
                   guarantees only ((1 - 1/e)/2 for best-of); no robust guarantee.
``algorithm-2``    the paper's Algorithm 2 (:func:`sensorsel.designs.resilient.resilient_select`, after
                   Tzoumas, Jadbabaie & Pappas): the alpha best singletons, then greedy on the rest.
                   Its proved bound (curvature-dependent) is for matroid constraints; under a knapsack
                   budget it is a heuristic.
``oblivious-eta<k>``  Oblivious-Greedy of Bogunovic, Mitrović, Scarlett & Cevher (ICML 2017), knapsack
                   variant: buy the ceil(eta * alpha) sensors of largest f({e}) that fit (as the failing
                   set of Algorithm 2, which is the eta = 1 case), then greedy on the rest of the budget
                   over the other sensors, from the empty suite. Their constant-factor guarantee is for a
                   cardinality constraint k with alpha = o(k); none is claimed under a knapsack.
``saturate``       SATURATE of Krause, McMahan, Guestrin & Gupta (JMLR 2008) over a :class:`~.family.Family`:
                   bisection on a level c; at each level, cost-effective greedy (largest gain per dollar,
                   lazily) on the truncated sum F_c(S) = Σ_i min(f_i(S), c) until full coverage
                   F_c(S) = m c (then min_i f_i(S) >= c) or nothing affordable adds coverage. F_c is
                   monotone submodular for each c. Guarantee kept under a knapsack: by Wolsey's (1982)
                   analysis of cost-effective greedy for submodular cover, when some suite of cost
                   <= B / beta reaches level c, greedy reaches it within cost B, beta = 1 + ln(m c / δ)
                   (δ the smallest positive coverage increment); so the answer is >= OPT_r at budget
                   B / beta, a bicriteria guarantee, and a posteriori min_i f_i(S) >= the best covered
                   level. No constant factor at budget B is possible in general (Krause et al. show
                   the max-min problem inapproximable without relaxing the budget).
``local-search``   from the best candidate: add a sensor, or swap one out and one in, when it raises the
                   exact worst case and stays in budget; first improvement in a fixed order; at most
                   ``max_rounds`` moves and ``max_evaluations`` suites scored. Only ever improves g.

Constraints (:mod:`sensorsel.model.constraints`, a ``feasible`` set): every method returns a suite of
it. Oblivious-Greedy's oblivious part and its greedy run keep every limit together (as Algorithm 2);
SATURATE's cover starts from the required sensors and adds only sensors that fit every limit on top
of the suite, its cost-effectiveness measured in the dollar-equivalent cost of the cost-aware rules;
local search moves only to suites that fit (required sensors are never swapped out).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence

import numpy as np

from sensorsel.designs.resilient import failing_set
from sensorsel.designs.robust.family import Family
from sensorsel.designs.selection import REL_TOL, greedy
from sensorsel.information.evaluators import Evaluator, as_suite
from sensorsel.model.constraints import Constraints, FeasibleSet
from sensorsel.model.library import SensorLibrary

#: Bisection levels of SATURATE.
DEFAULT_SATURATE_LEVELS = 5
#: Candidates refreshed together in SATURATE's lazy greedy.
SATURATE_BATCH = 4


def _fits(cost: float, budget: float) -> bool:
    return cost <= budget + 1e-9


def oblivious_greedy(
    evaluator: Evaluator,
    budget: float,
    alpha: int,
    *,
    eta: float = 2.0,
    rule: str = "uniform",
    constraints: Constraints | None = None,
) -> tuple[tuple[int, ...], str]:
    """Oblivious-Greedy (knapsack variant, see the module docstring): (suite, note). With
    ``constraints``, the oblivious part and the greedy run keep every limit together."""
    k = int(math.ceil(eta * alpha))
    lib = evaluator.library
    picked, _, note = failing_set(evaluator, budget, k, constraints)
    if constraints is None:
        rest = max(0.0, budget - lib.cost(picked))
        run = greedy(evaluator, rest, rule, exclude=frozenset(picked))
        what = f"greedy {rule} on ${rest:,.0f}"
    else:  # the oblivious sensors use their share of every limit; greedy keeps what is left
        run = greedy(
            evaluator, budget, rule, exclude=frozenset(picked), constraints=constraints, reserved=tuple(picked)
        )
        what = f"greedy {rule} on what the limits leave"
    suite = tuple(picked) + tuple(lib.position(s) for s in run.suite)
    return suite, f"{len(picked)} bought obliviously ({','.join(lib.suite_ids(picked))}); " + (note or what)


def saturate(
    family: Family,
    budget: float,
    lo: float,
    hi: float,
    *,
    levels: int = DEFAULT_SATURATE_LEVELS,
    max_evaluations: int | None = None,
    feasible: FeasibleSet | None = None,
) -> tuple[list[tuple[float, bool, tuple[int, ...]]], str]:
    """SATURATE's bisection between ``lo`` (a level known reachable) and ``hi`` (an upper bound).

    Returns every level's suite as (level c, fully covered, suite) and a note. A level whose greedy
    run hits ``max_evaluations`` (counted by ``family.n_evaluations``) ends the bisection.
    ``feasible``: every level's suite is one of its suites (None: the budget alone).
    """
    n0 = family.n_evaluations
    out: list[tuple[float, bool, tuple[int, ...]]] = []
    note = ""
    for _ in range(levels):
        if hi - lo <= REL_TOL * max(1.0, abs(hi)):
            break
        c = 0.5 * (lo + hi)
        covered, suite, done = _cover(
            family, budget, c, None if max_evaluations is None else n0 + max_evaluations, feasible
        )
        out.append((c, covered, suite))
        if not done:
            note = f"evaluation limit ({max_evaluations:,}) reached at level {c:.3f}"
            break
        if covered:
            lo = c
        else:
            hi = c
    return out, note or f"{len(out)} levels, last bracket [{lo:.3f}, {hi:.3f}]"


def _cover(
    family: Family, budget: float, c: float, stop_at: int | None, feasible: FeasibleSet | None = None
) -> tuple[bool, tuple[int, ...], bool]:
    """Cost-effective lazy greedy on F_c until full coverage: (covered, suite, finished within the limit).
    With ``feasible``: from its required sensors, adding only sensors that fit every limit."""
    lib = family.library
    ids, n = lib.ids, len(lib)
    costs = lib.costs if feasible is None else feasible.cost
    suite: list[int] = [] if feasible is None else list(feasible.required)
    used = np.zeros(0) if feasible is None else feasible.usage(suite)
    spent = 0.0
    w, v = family.terms(tuple(suite))
    total = float(w.sum()) * c
    cur = float(np.dot(w, np.minimum(v, c)))
    bound = np.full(n, np.inf)  # upper bounds on each candidate's coverage gain (submodularity)
    while True:
        if cur >= total * (1 - 1e-9):
            return True, as_suite(suite), True
        if stop_at is not None and family.n_evaluations > stop_at:
            return False, as_suite(suite), False
        if feasible is None:
            feas = [i for i in range(n) if i not in suite and _fits(spent + costs[i], budget) and bound[i] > 0]
        else:
            ok = feasible.addable(used)
            feas = [i for i in range(n) if i not in suite and ok[i] and bound[i] > 0]
        if not feas:
            return False, as_suite(suite), True
        fresh: dict[int, float] = {}
        gain_tol = REL_TOL * max(1.0, total)
        while True:
            best = max((fresh[i] / costs[i] for i in fresh if fresh[i] > gain_tol), default=-np.inf)
            stale = [i for i in feas if i not in fresh and bound[i] / costs[i] >= best - REL_TOL * max(1.0, abs(best))]
            if not stale:
                break
            stale.sort(key=lambda i: (-bound[i] / costs[i], costs[i], ids[i]))
            batch = stale[:SATURATE_BATCH]
            wt, vals = family.terms_with(tuple(suite), batch, cap=c)
            gains = wt @ np.minimum(vals, c) - cur
            for i, g in zip(batch, gains):
                fresh[i] = float(g)
                bound[i] = max(float(g), 0.0)
        good = [i for i in fresh if fresh[i] > gain_tol]
        if not good:
            return False, as_suite(suite), True
        r = max(fresh[i] / costs[i] for i in good)
        pick = min(
            (i for i in good if fresh[i] / costs[i] >= r - REL_TOL * max(1.0, abs(r))), key=lambda i: (costs[i], ids[i])
        )
        suite.append(pick)
        spent += float(costs[pick])
        if feasible is not None:
            used = used + feasible.A[:, pick]
        cur += fresh[pick]


def _failure_values(ev: Evaluator, s: tuple[int, ...], alpha: int) -> dict[tuple[int, ...], float]:
    k = min(alpha, len(s))
    return {
        f: (ev.score(tuple(i for i in s if i not in f)) if k < len(s) else 0.0) for f in itertools.combinations(s, k)
    }


def _worst_above(ev: Evaluator, s: tuple[int, ...], alpha: int, level: float, order_hint: dict) -> float | None:
    """g(S) if it is above ``level`` (by more than the tie tolerance), else None; stops at the first
    failure set at or below the level, trying first those the hint ranks lowest."""
    k = min(alpha, len(s))
    sets = list(itertools.combinations(s, k))
    sets.sort(key=lambda f: (order_hint.get(f, math.inf), f))
    tol = REL_TOL * max(1.0, abs(level))
    lo = math.inf
    for f in sets:
        val = ev.score(tuple(i for i in s if i not in f)) if k < len(s) else 0.0
        if val <= level + tol:
            return None
        lo = min(lo, val)
    return lo


def local_search(
    evaluator: Evaluator,
    start: Sequence[int],
    budget: float,
    alpha: int,
    *,
    max_rounds: int = 10,
    max_evaluations: int = 2_000,
    feasible: FeasibleSet | None = None,
) -> tuple[tuple[int, ...], str]:
    """Add / swap local search on the exact worst case (see the module docstring): (suite, note).

    A swap S - a + b keeps every failure set that holds b as a failure set of S that holds a
    (S - a + b minus F = S minus (F - b + a)), so it can only help when every failure set of S holding
    a leaves more than g(S): other sensors a are never tried. The failure sets of a neighbour are
    scored in order of how bad they were for S, and scoring stops at the first one at or below g(S).
    ``feasible``: only suites of it are moved to (None: the budget alone).
    """
    ev = evaluator
    lib = ev.library
    costs, ids, n = lib.costs, lib.ids, len(lib)

    def round_of(s: tuple[int, ...]) -> tuple[list[int], list[int], Improves]:
        vals = _failure_values(ev, s, alpha)
        g = min(vals.values()) if vals else 0.0
        worst = min(vals, key=lambda f: (vals[f], f)) if vals else ()
        outside = [i for i in range(n) if i not in s]
        # in-sensors ordered by what they add to the worst case's survivors
        surv = tuple(i for i in s if i not in worst)
        help_ = dict(zip(outside, ev.scores_with(surv, outside))) if outside else {}
        ins = sorted(outside, key=lambda b: (-help_[b], costs[b], ids[b]))
        # out-sensors: only those whose every failure set leaves more than g
        m_a = {a: min((v for f, v in vals.items() if a in f), default=math.inf) for a in s}
        outs = sorted(
            [a for a in s if m_a[a] > g + REL_TOL * max(1.0, abs(g))], key=lambda a: (-m_a[a], -costs[a], ids[a])
        )

        def improves(a: int | None, b: int, s2: tuple[int, ...]) -> bool:
            hint2 = {}
            for f in itertools.combinations(s2, min(alpha, len(s2))):
                if b not in f:  # S2 minus f = (S - a minus f) + b: f was this bad for S
                    hint2[f] = vals.get(f, math.inf)
                elif a is not None:  # S2 minus f = S minus (f - b + a): known exactly
                    hint2[f] = vals.get(as_suite([x for x in f if x != b] + [a]), math.inf)
            return _worst_above(ev, s2, alpha, g, hint2) is not None

        return outs, ins, improves

    return first_improvement(
        lib,
        start,
        budget,
        round_of,
        lambda: ev.n_evaluations,
        max_rounds=max_rounds,
        max_evaluations=max_evaluations,
        feasible=feasible,
    )


#: ``improves(a, b, S - a + b)``: whether the move (a None: add b) raises the objective
Improves = Callable[[int | None, int, tuple[int, ...]], bool]


def first_improvement(
    lib: SensorLibrary,
    start: Sequence[int],
    budget: float,
    round_of: Callable[[tuple[int, ...]], tuple[list[int], list[int], Improves]],
    work: Callable[[], int],
    *,
    max_rounds: int,
    max_evaluations: int,
    feasible: FeasibleSet | None = None,
) -> tuple[tuple[int, ...], str]:
    """The one add / swap local search of robust selection (failure sets here, a domain's routes in
    :mod:`.worst`): from ``start``, each round takes the first move that improves: add a sensor b, or
    swap a out for b, ``round_of(S)`` giving the sensors a to try swapping out, the sensors b to try
    in (in order) and the test of a move. Moves stay in budget (or, with ``feasible``, in its suites);
    at most ``max_rounds`` moves, and no new move once ``work()`` (suites scored) has grown by more
    than ``max_evaluations``. Returns (suite, a note of the moves and why it stopped)."""
    costs, ids = lib.costs, lib.ids
    n0 = work()
    s = as_suite(start)
    moves: list[str] = []
    stop = "no improving move"
    for _ in range(max_rounds):
        outs, ins, improves = round_of(s)
        cost = lib.cost(s)
        found = None
        for a in [None, *outs]:
            for b in ins:
                if work() - n0 > max_evaluations:
                    stop = f"evaluation limit ({max_evaluations:,}) reached"
                    break
                if feasible is None and not _fits(cost + costs[b] - (costs[a] if a is not None else 0.0), budget):
                    continue
                s2 = as_suite([i for i in s if i != a] + [b])
                if feasible is not None and not feasible.fits(s2):
                    continue
                if improves(a, b, s2):
                    found = (a, b, s2)
                    break
            if found or stop.startswith("evaluation"):
                break
        if not found:
            break
        a, b, s = found
        moves.append(f"+{ids[b]}" if a is None else f"{ids[a]}->{ids[b]}")
    else:
        stop = f"round limit ({max_rounds}) reached"
    return s, (f"moves: {' '.join(moves)}; " if moves else "no move; ") + stop
