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
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any, Unpack

from sensorsel.designs.parts import provenance
from sensorsel.designs.resilient import RobustChoice, WorstCase, check_alpha, recorded, worst_case
from sensorsel.designs.resilient.records import RobustOutcome
from sensorsel.designs.robust.memo import memoized
from sensorsel.designs.robust.records import Candidate, RobustResult, best_of
from sensorsel.designs.robust.tasks import (
    ALGORITHM_2,
    MethodLimits,
    MethodOutcome,
    MethodTask,
    RobustSettings,
    Scored,
    method_step,
    run_method,
    task_key,
    task_store,
    tolerance,
)
from sensorsel.designs.selection import check_budget, check_rule
from sensorsel.errors import InputError
from sensorsel.information.evaluators import Evaluator, as_suite, evaluator_for, evaluator_name
from sensorsel.io.records import part_of
from sensorsel.model.constraints import Constraints, feasible_set
from sensorsel.model.library import SensorLibrary
from sensorsel.model.problem import Target, TargetInfo
from sensorsel.model.recipes import EvaluatorRecipe, TargetRecipe
from sensorsel.pipeline import Executor, InProcess, Plan, execute

DEFAULT_RULES = ("uniform", "marginal")
#: Methods run after the bound: all of them by default.
EXTRA_METHODS = ("oblivious", "saturate", "local-search")


def check_rules_and_methods(
    rules: Sequence[str], methods: Sequence[str], allowed: Sequence[str], what: str
) -> tuple[str, ...]:
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


#: ``run(tasks) -> outcomes``: runs a stage's tasks (independent of each other), outcomes in task order
Runner = Callable[[Sequence[MethodTask]], list[MethodOutcome]]


def robust_select(
    evaluator: Evaluator,
    budget_usd: float,
    alpha: int,
    *,
    rules: Sequence[str] = DEFAULT_RULES,
    methods: Sequence[str] = EXTRA_METHODS,
    skip_when_proved: bool = True,
    info: TargetInfo | None = None,
    constraints: Constraints | None = None,
    **limits: Unpack[MethodLimits],
) -> RobustResult:
    """The best suite within ``budget_usd`` against ``alpha`` failures among the methods' suites, in
    this process, every method sharing one memo (each suite scored once in the whole run).

    Args:
        evaluator: scores suites (wrapped in a memo if it is not one).
        rules: plain greedy rules run as candidates ("uniform" is always run: the answer's floor).
        methods: the further methods: "oblivious", "saturate", "local-search".
        skip_when_proved: skip the further methods when the bound proves a candidate optimal.
        constraints: limits besides the budget that every candidate keeps (module docstring).
        limits: the methods' limits (:class:`~.tasks.MethodLimits`): saturate_levels and
            saturate_evaluations (SATURATE's bisection levels and evaluation limit), local_rounds and
            local_evaluations (local search's move and evaluation limits), bound_nodes (nodes of the
            bound's case split); defaults: :class:`~.tasks.RobustSettings`'s.
    """
    t_start = time.perf_counter()
    budget, alpha = check_budget(budget_usd), check_alpha(alpha)
    rules = check_rules_and_methods(rules, methods, EXTRA_METHODS, "robust method")
    ev = memoized(evaluator)
    settings = RobustSettings(budget, alpha, kept_constraints(ev.library, budget, constraints), **limits)
    return choose(
        lambda tasks: [run_method(ev, settings, t) for t in tasks],
        ev.library,
        settings,
        rules,
        methods,
        skip_when_proved,
        info=info,
        engine=ev.name,
        t_start=t_start,
    )


def kept_constraints(lib: SensorLibrary, budget: float, constraints: Constraints | None) -> Constraints | None:
    """What a robust run keeps of ``constraints`` (None when the budget is the only limit: the methods
    then run as they always did); refuses a request the library cannot meet (InputError)."""
    return recorded(feasible_set(lib, budget, constraints)) if constraints is not None else None


# Long on purpose (~80 lines): the candidates come in one fixed order (greedy and Algorithm 2, the
# bound's exact leaves, then the further methods unless the bound already proves one), each scored
# by its exact worst case; the best so far and the bound pass from one stage to the next.
def choose(
    run: Runner,
    lib: SensorLibrary,
    s: RobustSettings,
    rules: Sequence[str],
    methods: Sequence[str],
    skip_when_proved: bool,
    *,
    info: TargetInfo | None,
    engine: str,
    t_start: float,
) -> RobustResult:
    """Robust selection's stages, each a list of independent tasks handed to ``run`` (this process
    with one memo, or a plan on any executor and store): see the module docstring. ``rules``: checked,
    "uniform" first."""
    cands: list[Candidate] = []
    skipped: list[str] = []
    work = [0]

    def take(tasks: Sequence[MethodTask]) -> list[MethodOutcome]:
        outs = run(tasks)
        for o in outs:
            cands.extend(o.candidates)
            skipped.extend([o.skipped] if o.skipped else [])
            work[0] += o.n_evaluations
        return outs

    def best() -> Candidate:
        return best_of(cands)

    def anchors() -> tuple[tuple[int, ...], ...]:
        ranked = sorted(cands, key=lambda c: (-c.worst_score, -c.nominal_score, c.cost_usd, c.suite))
        out: list[tuple[int, ...]] = []
        for c in ranked:
            x = as_suite(lib.position(i) for i in c.suite if i not in c.failures)
            if x not in out:
                out.append(x)
        return tuple(out)

    def reached(bound: float) -> bool:
        return bound <= best().worst_score + tolerance(best().worst_score)

    take([MethodTask("greedy", rule="uniform"), MethodTask(ALGORITHM_2)])
    greedy_worst, a2c = cands[0].worst_score, cands[1]
    bnd = take([MethodTask("bound", anchors=anchors(), incumbent=best())])[0].bound
    assert bnd is not None
    proved = bnd.proved
    if not proved and reached(bnd.bound):
        proved = True
        bnd = replace(bnd, proved=True)
    n_before = len(cands)
    # the other greedy rules and a first Oblivious-Greedy depend on nothing but the inputs: one stage
    # (skipped too when the bound already proves a candidate optimal)
    first = [MethodTask("greedy", rule=r) for r in rules[1:]]
    rest = list(methods)
    if rest and rest[0] == "oblivious":
        first.append(MethodTask("oblivious"))
        rest = rest[1:]
    if proved and skip_when_proved:
        skipped.extend(
            f"{t.name if t.kind == 'greedy' else t.kind}: the bound proves the best candidate optimal" for t in first
        )
    elif first:
        take(first)
        if first[-1].kind == "oblivious" and reached(bnd.bound):
            proved = True
    for m in rest:
        if proved and skip_when_proved:
            skipped.append(f"{m}: the bound proves the best candidate optimal")
            continue
        task = MethodTask(m) if m == "oblivious" else MethodTask(m, incumbent=best(), hi=bnd.bound)
        if take([task])[0].skipped:
            continue
        if not proved and reached(bnd.bound):
            proved = True
    win = best()
    if proved and not bnd.proved:
        bnd = replace(bnd, proved=True)
    if not proved and len(cands) > n_before:
        # new suites: their survivors are new anchors, and a better incumbent settles more leaves
        again = take([MethodTask("bound", anchors=anchors(), incumbent=win, leaves=False)])[0].bound
        assert again is not None
        bnd = again
    return RobustResult.of(
        win,
        bnd,
        cands,
        skipped,
        alpha=s.alpha,
        budget_usd=s.budget,
        greedy_worst_score=greedy_worst,
        algorithm2_worst_score=a2c.worst_score,
        n_evaluations=work[0],
        engine=engine,
        **provenance(info, t_start, s.constraints),
    )


def run_robust(
    problem: Target,
    budget_usd: float,
    alpha: int,
    *,
    engine: str | None = None,
    jobs: int = 1,
    aggregate: str = "normalised",
    executor: Executor | None = None,
    outdir: str | Path | None = None,
    resume: bool = False,
    rules: Sequence[str] = DEFAULT_RULES,
    methods: Sequence[str] = EXTRA_METHODS,
    skip_when_proved: bool = True,
    constraints: Constraints | None = None,
    **limits: Unpack[MethodLimits],
) -> RobustResult:
    """:func:`robust_select` on a problem or a domain as a plan of tasks (:mod:`sensorsel.pipeline`):
    each stage's methods are tasks run by ``executor`` (default: this process), each on its own memo
    over the target's evaluator of ``engine`` (built once where the tasks run), so the answer is the
    same bytes wherever they ran, timings aside. Each task's memo starts from the suites the earlier
    stages scored (passed with the task), so only the methods of one stage score a suite twice.
    ``outdir``: each task's outcome is kept there as it
    arrives (``NN-METHOD.json``, with the fingerprint of its inputs); ``resume`` reads back those whose
    inputs match. ``limits``: the methods' limits of :func:`robust_select` (saturate_levels, ...).

    Its numbers may differ from :func:`robust_select` on one shared memo in the last bits (a suite's
    score can depend on the path that first scored it) and in ``n_evaluations`` (the methods of one
    stage share no suite)."""
    t_start = time.perf_counter()
    budget, alpha = check_budget(budget_usd), check_alpha(alpha)
    rules = check_rules_and_methods(rules, methods, EXTRA_METHODS, "robust method")
    settings = RobustSettings(budget, alpha, kept_constraints(problem.library, budget, constraints), **limits)
    name = evaluator_name(problem, engine)
    recipe = EvaluatorRecipe(TargetRecipe.of(problem), engine, jobs, aggregate)
    local = None
    if executor is None or isinstance(executor, InProcess):  # the tasks run here: one evaluator for all of them
        local = ((problem, evaluator_for(problem, engine, jobs=jobs, aggregate=aggregate)),)
    key = task_key(problem.info, name, aggregate, settings, rules, methods, skip_when_proved)
    stage = [0]
    known: dict[tuple[int, ...], Scored] = {}  # what earlier stages scored (first stage, first task first)

    def run(tasks: Sequence[MethodTask]) -> list[MethodOutcome]:
        stage[0] += 1
        seen = tuple(known.values())
        plan: Plan[MethodOutcome] = Plan(
            "robust method",
            method_step,
            tuple((settings, t, seen) for t in tasks),
            states=(recipe,),
            build=EvaluatorRecipe.build,
            local=local,
        )
        outs = execute(plan, executor, task_store(outdir, resume, key, stage[0], tasks))
        for o in outs:
            for k in o.scored:
                known.setdefault(k.suite, k)
        return outs

    return choose(
        run,
        problem.library,
        settings,
        rules,
        methods,
        skip_when_proved,
        info=problem.info,
        engine=name,
        t_start=t_start,
    )


def robust_choice(
    evaluator: Evaluator, budget_usd: float, alpha: int, info: TargetInfo | None = None, **kwargs: Any
) -> tuple[RobustChoice, WorstCase]:
    """:func:`robust_select` in the shape ``sensorsel resilient --method robust`` records (whole route and
    each period): the choice in short and its exact worst case (scored with the same memo: no re-scoring)."""
    ev = memoized(evaluator)
    r = robust_select(ev, budget_usd, alpha, info=info, **kwargs)
    w = worst_case(ev, [ev.library.position(i) for i in r.suite], r.alpha)
    return RobustChoice(**part_of(r, RobustOutcome), n_evaluations=r.n_evaluations, seconds=r.seconds), w
