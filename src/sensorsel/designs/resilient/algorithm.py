"""The resilient selection itself: the failing set, the active set, worst cases, and greedy versus
resilient on one scenario (see the package docstring for the algorithm)."""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from sensorsel.designs.options import RunOptions
from sensorsel.designs.parts import provenance
from sensorsel.designs.resilient.cache import fingerprint, load_matching
from sensorsel.designs.resilient.records import Comparison, ResilientResult, WorstCase
from sensorsel.designs.selection import REL_TOL, check_budget, check_rule, greedy
from sensorsel.errors import InputError
from sensorsel.information.evaluators import DEFAULT_ENGINE, ENGINES, Evaluator, as_suite, evaluator_for
from sensorsel.io import results
from sensorsel.model.constraints import Constraints, FeasibleSet, feasible_set
from sensorsel.model.problem import Target, TargetInfo

#: Enumeration limit of the worst-case evaluation (failure sets scored).
MAX_FAILURE_SETS = 200_000


def check_alpha(alpha: int) -> int:
    """The number of failures as an int; refuses negatives and non-integers."""
    if isinstance(alpha, bool) or not isinstance(alpha, (int, np.integer)) or alpha < 0:
        raise InputError(f"failures (alpha) must be a non-negative integer, got {alpha!r}")
    return int(alpha)


def engine_name(engine: str | None) -> str:
    """The engine to use: ``engine`` or the default, if registered."""
    name = engine or DEFAULT_ENGINE
    if name not in ENGINES:
        raise InputError(f"unknown engine {name!r}; available: {', '.join(sorted(ENGINES))}")
    return name


def failing_set(
    evaluator: Evaluator, budget_usd: float, alpha: int, constraints: Constraints | None = None
) -> tuple[list[int], list[float], str]:
    """The alpha sensors assumed to fail: largest f({e}) first, skipping those that do not fit.

    With ``constraints``, "fits" means on top of the required sensors and the failing sensors picked
    so far, every limit kept (a required sensor always fits: it is in the suite anyway, so it may be
    the one assumed to fail); excluded sensors are never picked.

    Returns:
        (library positions in pick order, their f({e}) [nats], note: "" or why fewer than alpha).
    """
    budget = check_budget(budget_usd)
    alpha = check_alpha(alpha)
    lib = evaluator.library
    if alpha == 0:
        return [], [], ""
    feas = feasible_set(lib, budget, constraints) if constraints is not None else None
    if feas is not None and not feas.plain:
        return _failing_set_within(evaluator, feas, alpha)
    costs, ids = lib.costs, lib.ids
    singles = evaluator.scores_with((), list(range(len(lib))))
    gain_tol = REL_TOL  # f(empty) = 0: the round-off scale of a singleton's gain
    picked: list[int] = []
    spent = 0.0
    left = np.ones(len(lib), dtype=bool)
    for _ in range(alpha):
        ok = left & (costs <= budget - spent + 1e-9) & (singles > gain_tol)
        pick = _most_informative(ok, singles, costs, ids)
        if pick is None:
            break
        picked.append(pick)
        left[pick] = False
        spent += float(costs[pick])
    return _failing(picked, singles, alpha, f"the budget ${budget:,.0f}")


def _most_informative(ok: np.ndarray, singles: np.ndarray, costs: np.ndarray, ids: Sequence[str]) -> int | None:
    """The candidate (``ok``, bool (n,)) with the largest f({e}); ties within :data:`REL_TOL` go to the
    cheaper sensor, then the smaller id. None when no candidate is left."""
    if not ok.any():
        return None
    cand = np.flatnonzero(ok)
    best = singles[cand].max()
    tied = cand[singles[cand] >= best - REL_TOL * max(1.0, abs(best))]
    return int(min(tied, key=lambda i: (costs[i], ids[i])))


def _failing_set_within(evaluator: Evaluator, feas: FeasibleSet, alpha: int) -> tuple[list[int], list[float], str]:
    """:func:`failing_set` under a feasible set (see there)."""
    lib = evaluator.library
    costs, ids = feas.cost, lib.ids
    singles = evaluator.scores_with((), list(range(len(lib))))
    required = np.zeros(len(lib), dtype=bool)
    required[list(feas.required)] = True
    used = feas.usage(feas.required)
    left = np.ones(len(lib), dtype=bool)
    picked: list[int] = []
    for _ in range(alpha):
        ok = left & (feas.addable(used) | required) & (singles > REL_TOL)
        pick = _most_informative(ok, singles, costs, ids)
        if pick is None:
            break
        picked.append(pick)
        left[pick] = False
        if not required[pick]:
            used = used + feas.A[:, pick]
    return _failing(picked, singles, alpha, f"the limits ({feas.constraints.describe()}; ${feas.budget_usd:,.0f})")


def _failing(picked: list[int], singles: np.ndarray, alpha: int, within: str) -> tuple[list[int], list[float], str]:
    """:func:`failing_set`'s answer: the picks, their f({e}) [nats] and, when fewer than ``alpha``, why
    (what they had to fit ``within``, in words)."""
    note = ""
    if len(picked) < alpha:
        note = f"only {len(picked)} informative sensor(s) fit {within} as failing sensors; {alpha} requested"
    return picked, [float(singles[i]) for i in picked], note


def resilient_select(
    evaluator: Evaluator,
    budget_usd: float,
    alpha: int,
    rule: str = "uniform",
    *,
    lazy: bool = True,
    info: TargetInfo | None = None,
    constraints: Constraints | None = None,
) -> ResilientResult:
    """Resilient selection for ``alpha`` failures under ``budget_usd`` (see the module docstring).

    Args:
        evaluator: scores suites of the problem.
        budget_usd: total budget [$], the failing sensors included.
        alpha: number of failures (0: plain greedy).
        rule: greedy rule of the active set (see :data:`sensorsel.designs.selection.RULES`).
        lazy: lazy (Minoux) evaluation in the greedy run (same picks).
        info: what the problem is, recorded in the result.
        constraints: limits besides the budget (:mod:`sensorsel.model.constraints`): the failing set and the
            active set *together* keep every limit (the active greedy run sees the failing set's use of
            each limit as already spent); required sensors are in the suite (in the failing set or the
            active set); excluded ones never. None: the budget alone (the paper's algorithm, unchanged).
    """
    t0 = time.perf_counter()
    budget = check_budget(budget_usd)
    alpha = check_alpha(alpha)
    check_rule(rule)
    n0 = evaluator.n_evaluations
    lib = evaluator.library
    failed, failed_scores, note = failing_set(evaluator, budget, alpha, constraints)
    feas = feasible_set(lib, budget, constraints) if constraints is not None else None
    if feas is None or feas.plain:  # the budget alone: the paper's algorithm, as it always ran
        failed_cost = lib.cost(failed)
        rest = max(0.0, budget - failed_cost)  # never negative: the failing set fits by construction
        run = greedy(evaluator, rest, rule, lazy=lazy, exclude=frozenset(failed), start=(), info=info)
    else:
        failed_cost = float(feas.usage(failed)[0])
        run = greedy(
            evaluator,
            budget,
            rule,
            lazy=lazy,
            exclude=frozenset(failed),
            info=info,
            constraints=constraints,
            reserved=tuple(failed),
        )
    active = [lib.position(s) for s in run.suite]
    suite = failed + active
    score = evaluator.score(suite) if failed else run.score
    cost = lib.cost(suite) if feas is None or feas.plain else float(feas.usage(suite)[0])
    return ResilientResult(
        alpha=alpha,
        budget_usd=budget,
        rule=rule,
        suite=lib.suite_ids(suite),
        failed=lib.suite_ids(failed),
        failed_scores=tuple(failed_scores),
        failure_note=note,
        active=run.suite,
        failed_cost_usd=failed_cost,
        cost_usd=cost,
        score=float(score),
        active_score=run.score,
        greedy=run,
        n_evaluations=evaluator.n_evaluations - n0,
        engine=evaluator.name,
        **provenance(info, t0, recorded(feas)),
    )


def recorded(feas: FeasibleSet | None) -> Constraints | None:
    """What a result records of its feasible set (:attr:`FeasibleSet.record`; None without one)."""
    return None if feas is None else feas.record


def constraints_key(feas: FeasibleSet | None) -> dict[str, Any]:
    """The constraints' part of a cache fingerprint: nothing when the budget is the only limit (so
    files written before constraints existed are still reused), else the constraints with the digest
    of the library's resources and slots (so a resume never mixes runs under other limits)."""
    return {} if feas is None or feas.plain else {"constraints": results.to_jsonable(feas.constraints)}


def worst_case(
    evaluator: Evaluator, suite: Sequence[int] | str, alpha: int, *, max_failure_sets: int = MAX_FAILURE_SETS
) -> WorstCase:
    """Exact worst case of a suite under ``alpha`` failures, by enumeration of the failure sets.

    Args:
        evaluator: scores suites of the problem.
        suite: library positions, or comma-separated ids.
        alpha: failures (a suite of alpha sensors or fewer loses them all).
        max_failure_sets: refuse to enumerate more failure sets than this.
    Raises:
        InputError: negative alpha, or C(|S|, alpha) above ``max_failure_sets``.
    """
    alpha = check_alpha(alpha)
    lib = evaluator.library
    s = lib.parse_suite(suite) if isinstance(suite, str) else as_suite(suite)
    k = min(alpha, len(s))
    n_sets = math.comb(len(s), k)
    if n_sets > max_failure_sets:
        raise InputError(
            f"worst case of a {len(s)}-sensor suite with {alpha} failures needs {n_sets:,} evaluations "
            f"(limit {max_failure_sets:,}); use fewer failures"
        )
    n0 = evaluator.n_evaluations
    nominal = evaluator.score(s)
    # combinations() of a sorted tuple come in lexicographic order of library positions
    sets = list(itertools.combinations(s, k))
    vals = np.array([evaluator.score(tuple(i for i in s if i not in f)) if k < len(s) else 0.0 for f in sets])
    lo = vals.min()
    tied = np.flatnonzero(vals <= lo + REL_TOL * max(1.0, abs(lo)))
    worst = sets[int(tied[0])]
    return WorstCase(
        suite=lib.suite_ids(s),
        alpha=alpha,
        nominal_score=float(nominal),
        score=float(vals[tied[0]]),
        failures=lib.suite_ids(worst),
        survivors=lib.suite_ids(i for i in s if i not in worst),
        n_failure_sets=n_sets,
        n_evaluations=evaluator.n_evaluations - n0,
    )


def compare(
    target: Target,
    budget_usd: float,
    alpha: int,
    rule: str = "uniform",
    options: RunOptions | None = None,
    *,
    cache: str | Path | None = None,
    resume: bool = False,
) -> Comparison:
    """Greedy and resilient selection at the same budget, with the worst case of each suite, on one
    route or on a domain (the domain's score, combined by the options' aggregate).

    Args:
        options: engine, jobs, aggregate, laziness and the limits besides the budget, respected by both
            selections (recorded, and part of the cache's fingerprint); its ``progress`` is not called
            (one comparison). None: the defaults.
        cache: a file to save the result in (atomically); with ``resume``, reused when its inputs match
            (one route only: a domain's comparison is not cached, and records no fingerprint).
    """
    t0 = time.perf_counter()
    budget, alpha, rule = check_budget(budget_usd), check_alpha(alpha), check_rule(rule)
    o = options if options is not None else RunOptions()
    name, constraints = engine_name(o.engine), o.constraints
    feas = feasible_set(target.library, budget, constraints) if constraints is not None else None
    fp, route = "", target.time_line
    if route is not None:
        fp = fingerprint(route, budget, alpha, rule, name, o.lazy, {"what": "whole route", **constraints_key(feas)})
        if cache is not None and resume:
            old = load_matching(Comparison, Path(cache), fp, route.fingerprint)
            if old is not None:
                return old
    ev = evaluator_for(target, name, jobs=o.jobs, aggregate=o.aggregate)
    info = target.info
    g = greedy(ev, budget, rule, lazy=o.lazy, info=info, constraints=constraints)
    r = resilient_select(ev, budget, alpha, rule, lazy=o.lazy, info=info, constraints=constraints)
    lib = target.library
    gw = worst_case(ev, [lib.position(s) for s in g.suite], alpha)
    rw = worst_case(ev, [lib.position(s) for s in r.suite], alpha)
    out = Comparison(
        alpha=alpha,
        budget_usd=budget,
        rule=rule,
        greedy=g,
        resilient=r,
        greedy_worst=gw,
        resilient_worst=rw,
        engine=ev.name,
        fingerprint=fp,
        **provenance(info, t0, recorded(feas)),
    )
    if cache is not None and route is not None:
        results.save(out, cache)
    return out
