"""Resilient sensor selection against alpha failures (the paper's Section VI, Algorithm 2).

After Tzoumas, Jadbabaie & Pappas, "Resilient Non-Submodular Maximization over Matroid
Constraints" (arXiv 1804.01013), Algorithm 1, with the matroid replaced by the cost budget:

1. **Failing set.** The alpha sensors with the largest individual scores f({e}) are bought and
   assumed to fail. They are picked greedily by f({e}): at each of alpha steps, among the sensors not
   yet picked that are *affordable* (the failing set's total cost stays within the budget once the
   sensor is added) and *informative* (f({e}) above round-off), the one with the largest f({e}) is
   picked; ties (relative 1e-9, as in :mod:`sensorsel.designs.selection`) go to the cheaper sensor, then
   the smaller id. A sensor that does not fit is skipped and the next one is tried, as Tzoumas et
   al. skip an element that would leave the matroid. Fewer than alpha sensors are picked only when
   fewer are informative and fit (the result says so).
2. **Active set.** The rest of the budget (budget minus the failing set's cost) is spent by greedy
   selection (:func:`sensorsel.designs.selection.greedy`, the uniform rule by default) on the library
   without the failing sensors, starting from the empty suite.

The resilient suite is the union; alpha = 0 is plain greedy selection.

**Worst case** of any suite S: min over F subset of S, |F| = alpha of f(S minus F), computed exactly
by enumerating the C(|S|, alpha) failure sets (one evaluation each; |S| for alpha = 1). A suite of
alpha sensors or fewer loses all of them (worst case 0).

**Per period.** The route is split into periods of ``period_s`` seconds of the keyframe
timestamps; each period gets its own scenario (its keyframes, the first one anchored by the
first-pose prior, and the landmarks any library sensor sees from them) and its own resilient
selection. The resulting grid of failed / active sensors is the paper's Fig. 5. Each period's result
is written to its own file as it completes, stamped with a fingerprint of its inputs, so an
interrupted run resumes where it stopped and ends with the same result as an uninterrupted one.
A period file that exists but cannot be reused (damaged, or computed from other inputs) is reported
with a :class:`CacheWarning` naming it, then recomputed and overwritten.

**Nothing fits.** The library functions answer what they are asked: a budget below the cheapest
sensor gives empty suites with the greedy stop reason, and fewer than alpha affordable informative
sensors give a failing set that says so (``failure_note``); a per-period run or a budget sweep may
ask for that. A command's request that cannot buy more sensors than alpha is refused up front by
:func:`sensorsel.designs.selection.check_affordable` (exit 2, naming ``--budget`` or ``--failures``).

Modules: :mod:`.records` (result records), :mod:`.algorithm` (failing set, resilient selection,
worst case, whole-route comparison), :mod:`.periods` (periods, their run, the grid) and
:mod:`.cache` (fingerprints and resume).
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any, Unpack

from sensorsel.designs.parts import elapsed_s
from sensorsel.designs.resilient.algorithm import (
    MAX_FAILURE_SETS,
    check_alpha,
    check_rule,
    compare,
    failing_set,
    recorded,
    resilient_select,
    worst_case,
)
from sensorsel.designs.resilient.cache import CacheWarning
from sensorsel.designs.resilient.periods import (
    DEFAULT_PERIOD_S,
    ResilientKeywords,
    ResilientRun,
    Selector,
    check_method,
    check_period,
    make_grid,
    period_file,
    period_scenario,
    periods_of,
    run_periods,
    save_grid_csv,
    split_periods,
)
from sensorsel.designs.resilient.records import (
    ACTIVE,
    ALGORITHM_2,
    FAILED,
    METHODS,
    UNUSED,
    Comparison,
    PeriodResult,
    PeriodSpan,
    PerPeriodResult,
    ResilientReport,
    ResilientResult,
    RobustChoice,
    SelectionGrid,
    WorstCase,
)
from sensorsel.designs.selection import check_budget
from sensorsel.errors import InputError
from sensorsel.io.progress import Progress
from sensorsel.model.constraints import feasible_set
from sensorsel.model.problem import Target

__all__ = [
    "ACTIVE",
    "ALGORITHM_2",
    "DEFAULT_PERIOD_S",
    "FAILED",
    "MAX_FAILURE_SETS",
    "METHODS",
    "RobustChoice",
    "Selector",
    "UNUSED",
    "check_method",
    "CacheWarning",
    "Comparison",
    "PerPeriodResult",
    "PeriodResult",
    "PeriodSpan",
    "Progress",
    "ResilientReport",
    "ResilientKeywords",
    "ResilientResult",
    "ResilientRun",
    "SelectionGrid",
    "WorstCase",
    "check_alpha",
    "check_rule",
    "check_period",
    "compare",
    "failing_set",
    "make_grid",
    "period_file",
    "period_scenario",
    "resilient_report",
    "resilient_select",
    "run_periods",
    "save_grid_csv",
    "split_periods",
    "worst_case",
]


def resilient_report(
    problem: Target,
    budget_usd: float,
    alpha: int,
    *,
    period_s: float | None = DEFAULT_PERIOD_S,
    **run: Unpack[ResilientKeywords],
) -> ResilientReport:
    """The whole-route comparison and (unless ``period_s`` is None) the per-period selection; the
    keywords: :class:`~.periods.ResilientRun` (rule, run options, outdir, resume, method, selector,
    executor).

    With ``outdir``, the comparison is cached in ``outdir/periods/route.json`` and each period in
    ``outdir/periods/period-NNNN.json``; ``resume`` reuses those whose inputs match (and warns about the others).
    On a :class:`~sensorsel.model.problem.Domain` the comparison is on the domain's score and there are no
    periods (a period is a stretch of one route's time line): ``period_s`` must then be None.

    ``method="robust"`` chooses the whole route's suite and each period's with ``selector`` (robust
    selection, see :data:`~.periods.Selector`; :func:`sensorsel.api.resilient_report` passes it) instead
    of Algorithm 2; the greedy / Algorithm 2 comparison of the whole route is kept beside it.

    ``constraints``: limits besides the budget (:mod:`sensorsel.model.constraints`) that every suite of the
    report keeps: greedy's, Algorithm 2's (failing and active set together), the robust choice's and
    every period's; recorded in the report and in every cached file's fingerprint.

    ``executor``: where the periods run (:mod:`sensorsel.pipeline`: in this process by default, or
    on a Dask cluster); the whole route is compared here. Same result either way, timings aside.
    """
    t0 = time.perf_counter()
    r = ResilientRun.of(**run)
    budget, alpha, rule = check_budget(budget_usd), check_alpha(alpha), check_rule(r.rule)
    method = check_method(r.method, r.selector)
    if period_s is not None:
        check_period(period_s)
    route = problem.time_line
    if period_s is not None and route is None:
        raise InputError("a per-period selection runs on one route, not on a domain: give no period (period_s=None)")
    o = r.options
    cache = Path(r.outdir) / "periods" / "route.json" if r.outdir is not None else None
    feas = feasible_set(problem.library, budget, o.constraints) if o.constraints is not None else None  # refuses
    cmp_ = compare(problem, budget, alpha, rule, o, cache=cache, resume=r.resume)
    choice = None
    if method == "robust":
        assert r.selector is not None
        extra: dict[str, Any] = {} if o.constraints is None else {"constraints": o.constraints}
        choice, _ = r.selector(o.evaluator(problem), budget, alpha, problem.info, **extra)
    per = periods_of(route, budget, alpha, period_s, r) if period_s is not None and route is not None else None
    return ResilientReport(
        suite=choice.suite if choice else cmp_.resilient.suite,
        failed=() if choice else cmp_.resilient.failed,
        alpha=alpha,
        budget_usd=budget,
        rule=rule,
        engine=cmp_.engine,
        comparison=cmp_,
        per_period=per,
        seconds=elapsed_s(t0),
        method=method,
        robust=choice,
        constraints=recorded(feas),
    )
