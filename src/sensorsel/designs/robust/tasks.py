"""Robust selection's work as tasks: one candidate method (or the bound) per task.

:func:`run_method` runs one :class:`MethodTask` on a memoizing evaluator and returns its
:class:`MethodOutcome` (the method's candidate suites, each scored by its exact worst case, or the
bound and the free candidates of its exact leaves). :func:`sensorsel.designs.robust.select.choose` orders
the tasks (greedy and Algorithm 2, the bound, the other rules and Oblivious-Greedy, SATURATE, local
search, the bound again) and keeps the best candidate; it is written once and served either by this
process with one shared memo (:func:`~.select.robust_select`) or by a plan of tasks run by any
executor and kept by any store (:func:`~.select.run_robust`: a fresh memo per task, so the bytes
do not depend on where or after what a task ran).

A task's inputs are all in the task and the :class:`RobustSettings` (a later task's inputs, e.g.
the bound's anchors or local search's start, are earlier tasks' results): a task's fingerprint is
the digest of both and the target, so a resumed run reuses a stored task only for the same inputs.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, TypedDict

import numpy as np

from sensorsel.designs.inputs import result_fingerprint
from sensorsel.designs.parts import elapsed_s
from sensorsel.designs.resilient import ALGORITHM_2, resilient_select, worst_case
from sensorsel.designs.robust.bound import DEFAULT_BOUND_NODES, robust_bound
from sensorsel.designs.robust.family import FailureFamily
from sensorsel.designs.robust.memo import MemoEvaluator
from sensorsel.designs.robust.methods import DEFAULT_SATURATE_LEVELS, local_search, oblivious_greedy, saturate
from sensorsel.designs.robust.records import Candidate, RobustBound, best_of, better
from sensorsel.designs.selection import REL_TOL, greedy
from sensorsel.information.evaluators import Evaluator, as_suite, evaluator_for
from sensorsel.io.results import result_kind
from sensorsel.model.constraints import Constraints, FeasibleSet, feasible_set
from sensorsel.model.problem import Target, TargetInfo
from sensorsel.model.recipes import EvaluatorRecipe
from sensorsel.pipeline import FileStore, NoStore, Store


@dataclass(frozen=True)
class RobustSettings:
    """What every task of one robust run shares: budget [$], alpha, the limits besides the budget
    (None: the budget alone) and the methods' limits (see :func:`~.select.robust_select`)."""

    budget: float
    alpha: int
    constraints: Constraints | None = None
    saturate_levels: int = DEFAULT_SATURATE_LEVELS
    saturate_evaluations: int | None = 2_000
    local_rounds: int = 10
    local_evaluations: int = 2_000
    bound_nodes: int = DEFAULT_BOUND_NODES


class MethodLimits(TypedDict, total=False):
    """The methods' limits a robust run takes by keyword (:class:`RobustSettings` holds their
    defaults): SATURATE's bisection levels and evaluation limit, local search's move and evaluation
    limits, the nodes of the bound's case split."""

    saturate_levels: int
    saturate_evaluations: int | None
    local_rounds: int
    local_evaluations: int
    bound_nodes: int


@dataclass(frozen=True)
class MethodTask:
    """One task of robust selection (a small picklable message).

    Attributes:
        kind: "greedy", "algorithm-2", "oblivious", "bound", "saturate" or "local-search".
        rule: with "greedy", its rule.
        anchors: with "bound", the anchor suites (library positions).
        incumbent: with "bound", the best candidate so far (its leaves compete with it); with
            "saturate" and "local-search", the best candidate (SATURATE's lower level is its worst
            case; local search starts from its suite).
        hi: with "saturate", the upper level (the bound) [nats].
        leaves: with "bound", its exact leaves become candidates (the first bound; not the last).
    """

    kind: str
    rule: str = ""
    anchors: tuple[tuple[int, ...], ...] = ()
    incumbent: Candidate | None = None
    hi: float = 0.0
    leaves: bool = True

    @property
    def name(self) -> str:
        """Its file's name in a store ("greedy-marginal", "bound", "bound-again", ...)."""
        if self.kind == "greedy":
            return f"greedy-{self.rule}"
        return self.kind if self.kind != "bound" or self.leaves else "bound-again"


@dataclass(frozen=True)
class Scored:
    """A suite (library positions) and its score f [nats], as one task passes it to the later ones."""

    suite: tuple[int, ...]
    score: float


@dataclass(frozen=True)
class MethodOutcome:
    """What one task gives: its candidates (in the order they were found), the bound ("bound"),
    why the method gave no candidate (empty: it gave some), how many suites it newly scored and
    (in a plan) those suites with their scores, which the later stages' tasks start from."""

    candidates: tuple[Candidate, ...] = ()
    bound: RobustBound | None = None
    skipped: str = ""
    n_evaluations: int = 0
    scored: tuple[Scored, ...] = ()


def kept_feasible(ev: Evaluator, s: RobustSettings) -> FeasibleSet | None:
    """The feasible set of the settings' limits (None: the budget alone)."""
    return None if s.constraints is None else feasible_set(ev.library, s.budget, s.constraints)


def candidate(
    ev: MemoEvaluator,
    s: RobustSettings,
    feas: FeasibleSet | None,
    method: str,
    suite: Sequence[int],
    note: str,
    n0: int,
    t0: float,
) -> Candidate:
    """A method's suite as a candidate: its exact worst case, cost, the evaluations since ``n0`` and
    the seconds since ``t0``. A suite that breaks the limits is a method's bug (AssertionError)."""
    lib = ev.library
    x = as_suite(suite)
    if feas is not None and not feas.fits(x):  # a method's bug, never the user's input
        raise AssertionError(f"robust method {method} returned a suite that breaks the limits: {feas.violations(x)}")
    w = worst_case(ev, x, s.alpha)
    return Candidate(
        method=method,
        suite=lib.suite_ids(x),
        cost_usd=lib.cost(x) if feas is None else float(feas.usage(x)[0]),
        nominal_score=w.nominal_score,
        worst_score=w.score,
        failures=w.failures,
        note=note,
        n_evaluations=ev.n_evaluations - n0,
        seconds=elapsed_s(t0),
    )


def tolerance(x: float) -> float:
    """Two worst cases within this of ``x`` are a tie (relative :data:`~sensorsel.designs.selection.REL_TOL`)."""
    return REL_TOL * max(1.0, abs(x))


def run_method(ev: MemoEvaluator, s: RobustSettings, task: MethodTask) -> MethodOutcome:
    """One task on ``ev`` (a memo: every suite scored once within it)."""
    n0 = ev.n_evaluations
    out = _run(ev, s, task)
    return replace(out, n_evaluations=ev.n_evaluations - n0)


def _run(ev: MemoEvaluator, s: RobustSettings, task: MethodTask) -> MethodOutcome:
    lib = ev.library
    feas = kept_feasible(ev, s)
    n0, t0 = ev.n_evaluations, time.perf_counter()

    def one(method: str, suite: Sequence[int], note: str) -> MethodOutcome:
        return MethodOutcome((candidate(ev, s, feas, method, suite, note, n0, t0),))

    if task.kind == "greedy":
        g = greedy(ev, s.budget, task.rule, constraints=s.constraints)
        return one(f"greedy-{task.rule}", [lib.position(i) for i in g.suite], g.stop_reason)
    if task.kind == ALGORITHM_2:
        a2 = resilient_select(ev, s.budget, s.alpha, constraints=s.constraints)
        return one(
            ALGORITHM_2,
            [lib.position(i) for i in a2.suite],
            f"failing set {','.join(a2.failed)}" + (f"; {a2.failure_note}" if a2.failure_note else ""),
        )
    if task.kind == "oblivious":
        x, note = oblivious_greedy(ev, s.budget, s.alpha, eta=2.0, constraints=s.constraints)
        return one("oblivious-eta2", x, note)
    assert task.incumbent is not None, f"robust task {task.kind} needs the best candidate so far"
    best = task.incumbent
    if task.kind == "bound":
        bnd = robust_bound(
            ev,
            s.budget,
            s.alpha,
            anchors=list(task.anchors),
            incumbent=best.worst_score,
            max_nodes=s.bound_nodes,
            constraints=s.constraints,
        )
        return MethodOutcome(leaf_candidates(ev, s, feas, bnd, best) if task.leaves else (), bnd)
    if task.kind == "saturate":
        levels, note = saturate(
            FailureFamily(ev, s.alpha),
            s.budget,
            best.worst_score,
            task.hi,
            levels=s.saturate_levels,
            max_evaluations=s.saturate_evaluations,
            feasible=feas,
        )
        tried = [x for _, _, x in levels]
        if not tried:
            return MethodOutcome(skipped="saturate: no level between the best worst case and the bound")
        covered = [c for c, ok, _ in levels if ok]
        note = f"{note}; covered levels: {', '.join(f'{c:.3f}' for c in covered) or 'none'}"
        sub = []
        for x in dict.fromkeys(tried):  # every level's suite is scored; the best is the method's candidate
            sub.append(candidate(ev, s, feas, "saturate", x, note, n0, t0))
            n0 = ev.n_evaluations
        return MethodOutcome((best_of(sub),))
    if task.kind == "local-search":
        x, note = local_search(
            ev,
            [lib.position(i) for i in best.suite],
            s.budget,
            s.alpha,
            max_rounds=s.local_rounds,
            max_evaluations=s.local_evaluations,
            feasible=feas,
        )
        return one("local-search", x, f"from {best.method}; {note}")
    raise ValueError(f"unknown robust task {task.kind!r}")


def leaf_candidates(
    ev: MemoEvaluator, s: RobustSettings, feas: FeasibleSet | None, bnd: RobustBound, best: Candidate
) -> tuple[Candidate, ...]:
    """The bound's "exact" leaves with no sensor assumed failed, as candidates: each is a suite within
    the limits (the whole leaf library fits) whose worst case the bound has just computed (free:
    memoized). Only leaves above the best candidate so far are kept (which each new one may raise)."""
    lib = ev.library
    out: list[Candidate] = []
    for leaf in bnd.leaves:
        if leaf.how == "exact" and not leaf.failed and leaf.bound > best.worst_score + tolerance(best.worst_score):
            n0, t0 = ev.n_evaluations, time.perf_counter()
            gone = set(leaf.removed)
            if feas is None:
                suite = [
                    i for i in range(len(lib)) if lib.ids[i] not in gone and lib.costs[i] <= leaf.budget_usd + 1e-9
                ]
            else:  # the sensors that fit every limit on their own (what the bound's leaf held)
                fit = feas.addable(np.zeros(len(feas.b)))
                suite = [i for i in range(len(lib)) if lib.ids[i] not in gone and fit[i]]
            if feas is not None and not feas.fits(suite):
                continue  # the leaf breaks a limit (all of its sensors do not fit together): not a candidate
            c = candidate(
                ev,
                s,
                feas,
                "bound-leaf",
                suite,
                f"the bound's exact leaf without {','.join(leaf.removed) or 'nothing'}",
                n0,
                t0,
            )
            out.append(c)
            if better(c, best):
                best = c
    return tuple(out)


def method_step(
    state: tuple[Target, Evaluator | EvaluatorRecipe], job: tuple[RobustSettings, MethodTask, tuple[Scored, ...]]
) -> MethodOutcome:
    """One task of a robust plan, on a fresh memo that knows what the earlier stages scored (the
    job's third part, the same wherever the task runs): over the caller's evaluator (in-process,
    shared by the tasks: an engine's score does not depend on what it scored before) or over one
    built from the target a worker holds. The baseline is scored before the memo starts counting,
    so a task's evaluations do not depend on whether its evaluator was fresh. The outcome carries
    the suites the task scored, for the later stages."""
    target, held = state
    ev = (
        held
        if isinstance(held, Evaluator)
        else evaluator_for(target, held.engine, jobs=held.jobs, aggregate=held.aggregate)
    )
    ev.prime()  # a route's baseline computed (and counted) before the memo starts
    settings, task, known = job
    memo = MemoEvaluator(ev)
    memo.learn((k.suite, k.score) for k in known)
    before = set(memo.scored())
    out = run_method(memo, settings, task)
    return replace(out, scored=tuple(Scored(s, v) for s, v in memo.scored().items() if s not in before))


#: the format of a robust task's fingerprint (bump it when what a task computes changes)
TASK_FORMAT = 1


def task_key(
    info: TargetInfo | None,
    engine: str,
    aggregate: str,
    s: RobustSettings,
    rules: Sequence[str],
    methods: Sequence[str],
    skip_when_proved: bool,
) -> dict[str, Any]:
    """What every task of a robust run depends on besides the task itself: each route by content with
    its weight, the engine, the aggregate, the settings (budget, alpha, limits with the library's
    resources' digest, the methods' limits) and, conservatively, the run's rules and methods (a
    resume with other rules or methods recomputes every task: it never reuses one by mistake)."""
    return {
        "target": info,
        "engine": engine,
        "aggregate": aggregate,
        "settings": s,
        "rules": list(rules),
        "methods": list(methods),
        "skip_when_proved": skip_when_proved,
    }


@result_kind("robust-task")
@dataclass(frozen=True)
class RobustTaskRecord:
    """One robust task's outcome as kept under ``-o``'s ``.tasks`` folder: read back by ``--resume``
    only when ``fingerprint`` (the digest of the target, settings and the task's own inputs) matches."""

    fingerprint: str
    task: str
    outcome: MethodOutcome


def task_store(
    outdir: str | Path | None, resume: bool, key: dict[str, Any], stage: int, tasks: Sequence[MethodTask]
) -> Store[MethodOutcome]:
    """Where a stage's outcomes are kept: ``OUTDIR/SS-NAME.json`` (SS the stage; none without ``outdir``)."""
    if outdir is None:
        return NoStore()
    fps = [result_fingerprint("robust-task", TASK_FORMAT, **key, stage=stage, task=t) for t in tasks]
    return FileStore(
        [Path(outdir) / f"{stage:02d}-{t.name}.json" for t in tasks],
        fps,
        RobustTaskRecord,
        lambda i, o: RobustTaskRecord(fps[i], tasks[i].name, o),
        lambda r: r.outcome,
        resume=resume,
        what="other inputs (target, budget, failures, engine, aggregate, limits, rules or methods)",
    )
