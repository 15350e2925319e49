"""Robust selection: run the candidate methods, score each by its exact worst case, keep the best.

Order of work (each suite is scored at most once: the evaluator is memoized):

1. plain greedy with the uniform rule (the paper's Algorithm 1: the answer's floor);
2. the paper's Algorithm 2 (:func:`sensorsel.designs.resilient.resilient_select`);
3. the upper bound (:func:`.bound.robust_bound`) anchored at the candidates' worst-case survivors.
   Its "exact" leaves with no sensor assumed failed are suites within the budget whose worst case it
   has computed: each becomes a candidate ("bound-leaf", free: memoized). When the bound equals the
   best candidate's worst case, that candidate is optimal and the remaining work is skipped
   (``skip_when_proved``; it could not do better);
4. plain greedy with the other rules of ``rules`` (default: marginal);
5. Oblivious-Greedy (eta = 2), SATURATE between the best worst case and the bound, and local search
   from the best candidate;
6. the bound again, anchored at the new best, if it changed and nothing is proved yet.

The answer is the candidate with the highest exact worst case; ties (relative 1e-9) go to the higher
nominal score, then the lower cost, then the smaller ids in library order. Since the uniform greedy
suite and Algorithm 2's suite are candidates scored with the same exact :func:`~sensorsel.designs.resilient.worst_case`,
**the answer's worst case is never below greedy's nor below Algorithm 2's**, and never above the bound.

Constraints (``constraints=``, :mod:`sensorsel.model.constraints`): every method runs within them (greedy,
Algorithm 2, Oblivious-Greedy, SATURATE, local search; see :mod:`.methods`), a bound leaf becomes a
candidate only when its suite keeps every limit, and every candidate is checked against the feasible
set before it is scored: no answer ever breaks a limit. The bound keeps every limit in its
knapsacks (integer programs, :mod:`.bound`, fact (5)).
"""

from __future__ import annotations

import time
from dataclasses import replace
from typing import Any, Sequence

import numpy as np

from sensorsel.designs.resilient import RobustChoice, WorstCase, check_alpha, recorded, resilient_select, worst_case
from sensorsel.designs.robust.bound import DEFAULT_BOUND_NODES, robust_bound
from sensorsel.designs.robust.family import FailureFamily
from sensorsel.designs.robust.memo import memoized
from sensorsel.designs.robust.methods import DEFAULT_SATURATE_LEVELS, local_search, oblivious_greedy, saturate
from sensorsel.designs.robust.records import Candidate, RobustResult
from sensorsel.designs.selection import REL_TOL, check_budget, check_rule, greedy
from sensorsel.errors import InputError
from sensorsel.information.evaluators import Evaluator, as_suite, evaluator_for
from sensorsel.model.constraints import Constraints, feasible_set
from sensorsel.model.problem import Target, TargetInfo

DEFAULT_RULES = ("uniform", "marginal")
#: Methods run after the bound: all of them by default.
EXTRA_METHODS = ("oblivious", "saturate", "local-search")


def _better(a: Candidate, b: Candidate, lib) -> bool:
    """True when ``a`` beats ``b``: worst case, then nominal, then cheaper, then ids."""
    tol = REL_TOL * max(1.0, abs(a.worst_score), abs(b.worst_score))
    if abs(a.worst_score - b.worst_score) > tol:
        return a.worst_score > b.worst_score
    tol = REL_TOL * max(1.0, abs(a.nominal_score), abs(b.nominal_score))
    if abs(a.nominal_score - b.nominal_score) > tol:
        return a.nominal_score > b.nominal_score
    if a.cost_usd != b.cost_usd:
        return a.cost_usd < b.cost_usd
    return a.suite < b.suite


def check_rules_and_methods(rules: Sequence[str], methods: Sequence[str], allowed: Sequence[str], what: str) -> tuple[str, ...]:
    """The greedy rules to run as candidates, "uniform" first (it is the answer's floor), after
    checking every rule against the registry and every method against ``allowed``.

    Raises:
        InputError: an unknown rule or method (naming the choices).
    """
    for r in rules:
        check_rule(r)
    for m in methods:
        if m not in allowed:
            raise InputError(f"unknown {what} {m!r}; available: {', '.join(allowed)}")
    return ("uniform",) + tuple(r for r in rules if r != "uniform")


# Long on purpose (~125 lines): the candidates run in one fixed order (greedy rules, Algorithm 2, the
# bound's exact leaf, then the further methods unless the bound already proves one), each scored by
# its exact worst case; splitting the stages apart would pass the memo, bound and tie-break around.
def robust_select(evaluator: Evaluator, budget_usd: float, alpha: int, *, rules: Sequence[str] = DEFAULT_RULES,
                  methods: Sequence[str] = EXTRA_METHODS, skip_when_proved: bool = True,
                  saturate_levels: int = DEFAULT_SATURATE_LEVELS, saturate_evaluations: int | None = 2_000,
                  local_rounds: int = 10, local_evaluations: int = 2_000, bound_nodes: int = DEFAULT_BOUND_NODES,
                  info: TargetInfo | None = None, constraints: Constraints | None = None) -> RobustResult:
    """The best suite within ``budget_usd`` against ``alpha`` failures among the methods' suites.

    Args:
        evaluator: scores suites (wrapped in a memo if it is not one).
        rules: plain greedy rules run as candidates ("uniform" is always run: the answer's floor).
        methods: the further methods: "oblivious", "saturate", "local-search".
        skip_when_proved: skip the further methods when the bound proves a candidate optimal.
        saturate_levels, saturate_evaluations: SATURATE's bisection levels and evaluation limit.
        local_rounds, local_evaluations: local search's move and evaluation limits.
        bound_nodes: nodes of the bound's case split.
        constraints: limits besides the budget that every candidate keeps (module docstring).
    """
    t_start = time.perf_counter()
    budget, alpha = check_budget(budget_usd), check_alpha(alpha)
    rules = check_rules_and_methods(rules, methods, EXTRA_METHODS, "robust method")
    ev = memoized(evaluator)
    lib = ev.library
    feas = feasible_set(lib, budget, constraints) if constraints is not None else None
    kept = recorded(feas)  # None when the budget is the only limit: the methods then run as they always did
    feas = feas if kept is not None else None
    n_start = ev.n_evaluations
    cands: list[Candidate] = []
    skipped: list[str] = []

    def add(method: str, suite: Sequence[int], note: str, n0: int, t0: float) -> Candidate:
        s = as_suite(suite)
        if feas is not None and not feas.fits(s):  # a method's bug, never the user's input
            raise AssertionError(f"robust method {method} returned a suite that breaks the limits: {feas.violations(s)}")
        w = worst_case(ev, s, alpha)
        c = Candidate(method=method, suite=lib.suite_ids(s), cost_usd=lib.cost(s) if feas is None else float(feas.usage(s)[0]), nominal_score=w.nominal_score,
                      worst_score=w.score, failures=w.failures, note=note, n_evaluations=ev.n_evaluations - n0,
                      seconds=round(time.perf_counter() - t0, 6))
        cands.append(c)
        return c

    def best() -> Candidate:
        b = cands[0]
        for c in cands[1:]:
            if _better(c, b, lib):
                b = c
        return b

    def anchors() -> list[tuple[int, ...]]:
        ranked = sorted(cands, key=lambda c: (-c.worst_score, -c.nominal_score, c.cost_usd, c.suite))
        out: list[tuple[int, ...]] = []
        for c in ranked:
            x = as_suite(lib.position(i) for i in c.suite if i not in c.failures)
            if x not in out:
                out.append(x)
        return out

    def run_rule(r: str) -> None:
        n0, t0 = ev.n_evaluations, time.perf_counter()
        g = greedy(ev, budget, r, constraints=kept)
        add(f"greedy-{r}", [lib.position(i) for i in g.suite], g.stop_reason, n0, t0)

    def tol_of(x: float) -> float:
        return REL_TOL * max(1.0, abs(x))

    run_rule("uniform")
    greedy_worst = cands[0].worst_score
    n0, t0 = ev.n_evaluations, time.perf_counter()
    a2 = resilient_select(ev, budget, alpha, constraints=kept)
    a2c = add("algorithm-2", [lib.position(i) for i in a2.suite], f"failing set {','.join(a2.failed)}" + (f"; {a2.failure_note}" if a2.failure_note else ""), n0, t0)
    bnd = robust_bound(ev, budget, alpha, anchors=anchors(), incumbent=best().worst_score, max_nodes=bound_nodes,
                       constraints=kept)
    # an "exact" leaf with no sensor assumed failed is a feasible suite (the whole leaf library fits
    # the budget) whose worst case the bound has just computed: a free candidate
    for leaf in bnd.leaves:
        if leaf.how == "exact" and not leaf.failed and leaf.bound > best().worst_score + tol_of(best().worst_score):
            n0, t0 = ev.n_evaluations, time.perf_counter()
            gone = set(leaf.removed)
            if feas is None:
                leaf_suite = [i for i in range(len(lib)) if lib.ids[i] not in gone and lib.costs[i] <= leaf.budget_usd + 1e-9]
            else:  # the sensors that fit every limit on their own (what the bound's leaf held)
                fit = feas.addable(np.zeros(len(feas.b)))
                leaf_suite = [i for i in range(len(lib)) if lib.ids[i] not in gone and fit[i]]
            if feas is not None and not feas.fits(leaf_suite):
                continue  # the leaf breaks a limit (all of its sensors do not fit together): not a candidate
            add("bound-leaf", leaf_suite, f"the bound's exact leaf without {','.join(leaf.removed) or 'nothing'}", n0, t0)
    proved = bnd.proved
    if not proved and bnd.bound <= best().worst_score + tol_of(best().worst_score):
        proved = True
        bnd = replace(bnd, proved=True)
    n_before = len(cands)
    # the other greedy rules: skipped too when the bound already proves a candidate optimal
    for r in rules[1:]:
        if proved and skip_when_proved:
            skipped.append(f"greedy-{r}: the bound proves the best candidate optimal")
        else:
            run_rule(r)

    for m in methods:
        if proved and skip_when_proved:
            skipped.append(f"{m}: the bound proves the best candidate optimal")
            continue
        n0, t0 = ev.n_evaluations, time.perf_counter()
        if m == "oblivious":
            s, note = oblivious_greedy(ev, budget, alpha, eta=2.0, constraints=kept)
            add("oblivious-eta2", s, note, n0, t0)
        elif m == "saturate":
            lo = best().worst_score
            levels, note = saturate(FailureFamily(ev, alpha), budget, lo, bnd.bound, levels=saturate_levels,
                                    max_evaluations=saturate_evaluations, feasible=feas)
            tried = [s for _, _, s in levels]
            if not tried:
                skipped.append("saturate: no level between the best worst case and the bound")
                continue
            covered = [c for c, ok, _ in levels if ok]
            note = f"{note}; covered levels: {', '.join(f'{c:.3f}' for c in covered) or 'none'}"
            # every level's suite is scored; the best is the method's candidate
            sub = []
            for s in dict.fromkeys(tried):
                sub.append(add("saturate", s, note, n0, t0))
                n0 = ev.n_evaluations
            keep = sub[0]
            for c in sub[1:]:
                if _better(c, keep, lib):
                    keep = c
            for c in sub:
                if c is not keep:
                    cands.remove(c)
        elif m == "local-search":
            start = best()
            s, note = local_search(ev, [lib.position(i) for i in start.suite], budget, alpha, max_rounds=local_rounds,
                                   max_evaluations=local_evaluations, feasible=feas)
            add("local-search", s, f"from {start.method}; {note}", n0, t0)
        if not proved and bnd.bound <= best().worst_score + tol_of(best().worst_score):
            proved = True
    win = best()
    if proved and not bnd.proved:
        bnd = replace(bnd, proved=True)
    if not proved and len(cands) > n_before:
        # new suites: their survivors are new anchors, and a better incumbent settles more leaves
        bnd = robust_bound(ev, budget, alpha, anchors=anchors(), incumbent=win.worst_score, max_nodes=bound_nodes,
                           constraints=kept)
    bound = max(bnd.bound, win.worst_score)
    return RobustResult(
        alpha=alpha, budget_usd=budget, method=win.method, suite=win.suite, cost_usd=win.cost_usd,
        nominal_score=win.nominal_score, worst_score=win.worst_score, failures=win.failures,
        greedy_worst_score=greedy_worst, algorithm2_worst_score=a2c.worst_score, bound=bound,
        gap_percent=100.0 * (bound - win.worst_score) / bound if bound > 0 else 0.0, candidates=tuple(cands),
        skipped=tuple(skipped), bound_detail=bnd, n_evaluations=ev.n_evaluations - n_start, engine=ev.name, problem=info,
        seconds=round(time.perf_counter() - t_start, 6), constraints=kept,
    )


def run_robust(problem: Target, budget_usd: float, alpha: int, *, engine: str | None = None, jobs: int = 1,
               aggregate: str = "normalised", **kwargs: Any) -> RobustResult:
    """:func:`robust_select` with a fresh evaluator of ``engine`` for a problem or a domain."""
    check_budget(budget_usd)
    check_alpha(alpha)
    if kwargs.get("constraints") is not None:
        feasible_set(problem.library, budget_usd, kwargs["constraints"])  # refuse a bad request before the evaluator
    ev = evaluator_for(problem, engine, jobs=jobs, aggregate=aggregate)
    return robust_select(ev, budget_usd, alpha, info=problem.info, **kwargs)


def robust_choice(evaluator: Evaluator, budget_usd: float, alpha: int, info: TargetInfo | None = None,
                  **kwargs: Any) -> tuple[RobustChoice, WorstCase]:
    """:func:`robust_select` in the shape ``sensorsel resilient --method robust`` records (whole route and
    each period): the choice in short and its exact worst case (scored with the same memo: no re-scoring)."""
    ev = memoized(evaluator)
    r = robust_select(ev, budget_usd, alpha, info=info, **kwargs)
    w = worst_case(ev, [ev.library.position(i) for i in r.suite], r.alpha)
    return RobustChoice(method=r.method, suite=r.suite, cost_usd=r.cost_usd, nominal_score=r.nominal_score,
                        worst_score=r.worst_score, failures=r.failures, greedy_worst_score=r.greedy_worst_score,
                        algorithm2_worst_score=r.algorithm2_worst_score, bound=r.bound, gap_percent=r.gap_percent,
                        n_evaluations=r.n_evaluations, seconds=r.seconds), w
