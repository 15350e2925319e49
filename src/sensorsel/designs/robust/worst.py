"""The worst route of an operating domain: max-min over the routes' normalised scores.

For a domain with routes r = 1..R (evaluators f_r, normalisers b_r = f_r(L), the whole library's
score on route r, as in the normalised domain score) and alpha failures, maximise within the budget

    h(S) = min over routes r and failure sets F ⊆ S, |F| = alpha, of f_r(S minus F) / b_r

(alpha = 0: the worst route's share of its best). Every member f_r(S minus F) / b_r is monotone
submodular, so this is a max-min over a finite family (:class:`RouteFailureFamily`, one
:class:`~.family.FailureFamily` per route, scaled by 1 / b_r) and SATURATE applies unchanged.

Candidates (each scored by its **exact** h, the minimum over every route's exact worst case):

* greedy with each rule on the domain's normalised average (:class:`~sensorsel.information.evaluators.DomainEvaluator`);
* the paper's Algorithm 2 on that average;
* SATURATE over the route-and-failure family, between the best h found and the bound;
* local search (add one sensor, or swap one out and one in, when h rises; first improvement).

Upper bound: h(S) <= g_r(S) / b_r for every route, so max h <= min over r of (route r's robust bound
:func:`~.bound.robust_bound`) / b_r. The answer is never below greedy's h nor Algorithm 2's (both are
candidates, scored the same exact way); ties as in :func:`~.select.robust_select`.

Constraints (resource limits, slots, most sensors, required / owned and excluded sensors): greedy,
Algorithm 2, SATURATE's covers and local search all move within them, every candidate is checked
against them, and each route's bound keeps them (:mod:`.bound`, fact (5)).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Unpack, cast

import numpy as np

from sensorsel.designs.parts import elapsed_s
from sensorsel.designs.resilient import check_alpha, recorded, resilient_select, worst_case
from sensorsel.designs.robust.bound import robust_bound
from sensorsel.designs.robust.family import FailureFamily, Family
from sensorsel.designs.robust.memo import MemoEvaluator, memoized
from sensorsel.designs.robust.methods import Improves, first_improvement, saturate
from sensorsel.designs.robust.records import Candidate, MemberWorst, RobustBound, RobustResult, best_of
from sensorsel.designs.robust.select import check_rules_and_methods
from sensorsel.designs.robust.tasks import ALGORITHM_2, MethodLimits, RobustSettings
from sensorsel.designs.selection import REL_TOL, check_budget, greedy
from sensorsel.information.evaluators import DomainEvaluator, Evaluator, as_suite, evaluator_for
from sensorsel.model.constraints import Constraints, FeasibleSet, feasible_set
from sensorsel.model.problem import Domain

#: Methods run after the bound on the worst route.
WORST_METHODS = ("saturate", "local-search")


class RouteFailureFamily(Family):
    """Members f_r(S minus F) / b_r for every route r and every alpha-set F (:class:`FailureFamily` per route)."""

    kind = "routes-failures"

    def __init__(
        self, evaluators: Sequence[Evaluator], labels: Sequence[str], norms: Sequence[float] | np.ndarray, alpha: int
    ) -> None:
        self.parts = [FailureFamily(e, alpha) for e in evaluators]
        self.labels = list(labels)
        self.norms = np.asarray(norms, dtype=float)
        self.alpha = int(alpha)
        self.evaluator = evaluators[0]
        self.n_members = sum(p.n_members for p in self.parts)

    @property
    def n_evaluations(self) -> int:
        return sum(p.evaluator.n_evaluations for p in self.parts)

    def terms(self, suite: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
        ws, vs = [], []
        for p, b in zip(self.parts, self.norms):
            w, v = p.terms(suite)
            ws.append(w)
            vs.append(v / b)
        return np.concatenate(ws), np.concatenate(vs)

    def terms_with(
        self, suite: Sequence[int], candidates: Sequence[int], *, cap: float | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        ws, vs = [], []
        for p, b in zip(self.parts, self.norms):
            w, v = p.terms_with(suite, candidates, cap=None if cap is None else cap * b)
            ws.append(w)
            vs.append(v / b)
        return np.concatenate(ws), np.concatenate(vs, axis=0).reshape(-1, len(candidates))

    def route_worst(self, suite: Sequence[int]) -> list[tuple[float, float, tuple[str, ...]]]:
        """Per route: (nominal share, exact worst share, the failure set attaining it)."""
        s = as_suite(suite)
        out = []
        for p, b in zip(self.parts, self.norms):
            w = worst_case(p.evaluator, s, self.alpha)
            out.append((w.nominal_score / b, w.score / b, w.failures))
        return out

    def worst(self, suite: Sequence[int]) -> tuple[float, str]:
        per = self.route_worst(suite)
        k = min(range(len(per)), key=lambda i: per[i][1])  # first route among ties
        return per[k][1], self.labels[k]


def _local_search(
    fam: RouteFailureFamily,
    start: Sequence[int],
    budget: float,
    max_rounds: int,
    max_evaluations: int,
    feasible: FeasibleSet | None = None,
) -> tuple[tuple[int, ...], str]:
    """Add / swap moves raising the exact h; first improvement in library order; bounded
    (:func:`~.methods.first_improvement`). ``feasible``: only its suites are moved to (None: the budget alone)."""
    n = len(fam.library)

    def round_of(s: tuple[int, ...]) -> tuple[list[int], list[int], Improves]:
        h = fam.worst(s)[0]

        def improves(a: int | None, b: int, s2: tuple[int, ...]) -> bool:
            return fam.worst(s2)[0] > h + REL_TOL * max(1.0, abs(h))

        return list(s), [b for b in range(n) if b not in s], improves

    return first_improvement(
        fam.library,
        start,
        budget,
        round_of,
        lambda: fam.n_evaluations,
        max_rounds=max_rounds,
        max_evaluations=max_evaluations,
        feasible=feasible,
    )


# Long on purpose (~110 lines): as robust_select, for the worst route of a domain: candidates in one
# fixed order, each scored by its exact worst route.
def worst_route_select(
    domain: Domain,
    budget_usd: float,
    alpha: int,
    *,
    engine: str | None = None,
    jobs: int = 1,
    rules: Sequence[str] = ("uniform", "marginal"),
    methods: Sequence[str] = WORST_METHODS,
    skip_when_proved: bool = True,
    evaluator: DomainEvaluator | None = None,
    constraints: Constraints | None = None,
    **limits: Unpack[MethodLimits],
) -> RobustResult:
    """The suite within ``budget_usd`` maximising the worst route's share of its best under ``alpha``
    failures (see the module docstring); a :class:`RobustResult` with ``aggregate="worst"``.
    ``evaluator``: the domain's normalised evaluator already built (e.g. on a Dask cluster).

    ``constraints``: limits besides the budget (:mod:`sensorsel.model.constraints`) that every candidate
    keeps (checked before it is scored); the bound keeps them too (each route's :func:`robust_bound`).
    The shares' normalisers b_r stay f_r(L), the whole library's score, as in the domain score.
    ``limits``: the methods' limits, as :func:`~.select.robust_select`'s."""
    t_start = time.perf_counter()
    budget, alpha = check_budget(budget_usd), check_alpha(alpha)
    rules = check_rules_and_methods(rules, methods, WORST_METHODS, "method for the worst route")
    dev = (
        evaluator
        if evaluator is not None
        else cast(DomainEvaluator, evaluator_for(domain, engine, jobs=jobs, aggregate="normalised"))
    )
    n_start = sum(e.n_evaluations for e in dev.routes)
    routes: list[MemoEvaluator] = [memoized(e) for e in dev.routes]
    names = [r.name for r in domain.routes]
    fam = RouteFailureFamily(routes, names, dev.best, alpha)
    avg = memoized(dev)
    lib = dev.library
    feas = feasible_set(lib, budget, constraints) if constraints is not None else None
    kept = recorded(feas)  # None when the budget is the only limit: every method runs as it always did
    feas = feas if kept is not None else None
    lim = RobustSettings(budget, alpha, kept, **limits)  # the methods' limits, their defaults filled in
    cands: list[Candidate] = []
    skipped: list[str] = []

    def work() -> int:
        return sum(e.n_evaluations for e in dev.routes)

    def add(method: str, suite: Sequence[int], note: str, n0: int, t0: float) -> Candidate:
        s = as_suite(suite)
        if feas is not None and not feas.fits(s):  # a method's bug, never the user's input
            raise AssertionError(
                f"worst-route method {method} returned a suite that breaks the limits: {feas.violations(s)}"
            )
        per = fam.route_worst(s)
        k = min(range(len(per)), key=lambda i: per[i][1])
        cost = lib.cost(s) if feas is None else float(feas.usage(s)[0])
        c = Candidate(
            method=method,
            suite=lib.suite_ids(s),
            cost_usd=cost,
            nominal_score=min(p[0] for p in per),
            worst_score=per[k][1],
            failures=per[k][2],
            note=note,
            n_evaluations=work() - n0,
            seconds=elapsed_s(t0),
            worst_member=names[k],
        )
        cands.append(c)
        return c

    def best() -> Candidate:
        return best_of(cands)

    for r in rules:
        n0, t0 = work(), time.perf_counter()
        g = greedy(avg, budget, r, constraints=kept)
        add(
            f"greedy-{r}",
            [lib.position(i) for i in g.suite],
            f"on the domain's normalised average; {g.stop_reason}",
            n0,
            t0,
        )
    greedy_worst = cands[0].worst_score
    n0, t0 = work(), time.perf_counter()
    a2 = resilient_select(avg, budget, alpha, constraints=kept)
    a2c = add(
        ALGORITHM_2,
        [lib.position(i) for i in a2.suite],
        f"on the domain's normalised average; failing set {','.join(a2.failed)}",
        n0,
        t0,
    )

    def bound_now() -> RobustBound:
        t0, n0 = time.perf_counter(), work()
        inc = best()
        x = as_suite(lib.position(i) for i in inc.suite)
        per_route, nodes, sweeps = [], 0, 0
        for ev, b in zip(routes, fam.norms):
            w = worst_case(ev, x, alpha)
            surv = as_suite(lib.position(i) for i in w.survivors)
            rb = robust_bound(
                ev,
                budget,
                alpha,
                anchors=[surv],
                incumbent=inc.worst_score * b,
                max_nodes=lim.bound_nodes,
                constraints=kept,
            )
            per_route.append(rb.bound / b)
            nodes += rb.n_nodes
            sweeps += rb.n_sweeps
        value = max(min(per_route), inc.worst_score)
        tol = REL_TOL * max(1.0, abs(inc.worst_score))
        return RobustBound(
            bound=float(value),
            leaves=(),
            n_nodes=nodes,
            n_sweeps=sweeps,
            proved=bool(value <= inc.worst_score + tol),
            n_evaluations=work() - n0,
            seconds=elapsed_s(t0),
        )

    bnd = bound_now()
    n_before = len(cands)
    for m in methods:
        if bnd.proved and skip_when_proved:
            skipped.append(f"{m}: the bound proves the best candidate optimal")
            continue
        n0, t0 = work(), time.perf_counter()
        if m == "saturate":
            levels, note = saturate(
                fam,
                budget,
                best().worst_score,
                bnd.bound,
                levels=lim.saturate_levels,
                max_evaluations=lim.saturate_evaluations,
                feasible=feas,
            )
            if not levels:
                skipped.append("saturate: no level between the best worst case and the bound")
                continue
            covered = [c for c, ok, _ in levels if ok]
            note = f"{note}; covered levels: {', '.join(f'{c:.6f}' for c in covered) or 'none'}"
            sub = []
            for s in dict.fromkeys(s for _, _, s in levels):
                sub.append(add("saturate", s, note, n0, t0))
                n0 = work()
            keep = best_of(sub)
            for c in sub:
                if c is not keep:
                    cands.remove(c)
        elif m == "local-search":
            start = best()
            s, note = _local_search(
                fam,
                [lib.position(i) for i in start.suite],
                budget,
                lim.local_rounds,
                lim.local_evaluations,
                feasible=feas,
            )
            add("local-search", s, f"from {start.method}; {note}", n0, t0)
    win = best()
    if len(cands) > n_before and not bnd.proved:
        bnd = bound_now()
    x = as_suite(lib.position(i) for i in win.suite)
    members = tuple(
        MemberWorst(name=nm, best_score=float(b), nominal_share=float(nom), worst_share=float(w), failures=f)
        for nm, b, (nom, w, f) in zip(names, fam.norms, fam.route_worst(x))
    )
    return RobustResult.of(
        win,
        bnd,
        cands,
        skipped,
        alpha=alpha,
        budget_usd=budget,
        greedy_worst_score=greedy_worst,
        algorithm2_worst_score=a2c.worst_score,
        n_evaluations=work() - n_start,
        engine=dev.engine,
        problem=domain.info,
        seconds=elapsed_s(t_start),
        aggregate="worst",
        worst_member=win.worst_member,
        members=members,
        constraints=kept,
    )
