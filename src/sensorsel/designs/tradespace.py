"""The cost-performance tradespace (the paper's Section V and Fig. 4).

The greedy rules of :mod:`sensorsel.designs.selection` are run over a grid of budgets; every intermediate
architecture of every run (the suite after each pick) is recorded, identical suites are merged
(keeping which rules made them), and the Pareto front of cost against score is computed.

    result = run_tradespace(problem)                    # default budgets and rules
    result.front                                        # the non-dominated architectures, cheapest first
    result.cheapest_reaching(0.99)                      # cheapest architecture with >= 99% of the best score
    write_csv(result, "architectures.csv")

Definitions (costs in $, scores f(S) in nats, see :mod:`sensorsel.information.evaluators.base`):

* Architecture a **dominates** b when cost(a) <= cost(b) and score(a) >= score(b), with at least one of
  the two strict. Comparisons are exact on the recorded floats (no tolerance, so dominance is a strict
  partial order and the front is unambiguous). Two architectures with equal cost and equal score do
  not dominate each other: both are on the front.
* The **Pareto front** is the set of architectures no recorded architecture dominates.
* **Normalized performance** = score / the largest score recorded (so the best architecture is 1.0).
* The empty suite (cost 0, score 0) is not an architecture: the runs only record suites after a pick.

Avoiding redundant runs (exact): a greedy rule's pick depends on the budget only through which
sensors still fit. A run at a larger budget therefore makes the same picks as the run at budget B
for as long as each of its picks also fits B; from the first pick that does not, the B-run continues
on its own. :func:`tradespace` resumes each smaller budget from the longest such prefix of a run it
has already made (``share_prefix=True``) instead of starting from the empty suite. The one departure
from independent runs is theoretical: with two candidates within the rules' relative tie tolerance
(1e-9) of each other, where the better one does not fit B, the tie window can shift; the tests check
that shared and independent runs agree (``share_prefix=False`` runs every budget from scratch).

Constraints (``constraints=``, :mod:`sensorsel.model.constraints`): every run, at every budget, keeps them
(a budget sweep with the other limits fixed); an architecture's cost is what it spends of the budget
(owned required sensors count nothing). Prefix sharing stays exact when the only rows besides the
budget are capacities (mounting slots, most sensors) and required / excluded sensors: those rows do
not depend on the budget, so a pick of the larger run that fits B's budget row fits all of B's rows,
and it beat a superset of B's candidates with the same J. With a **resource limit** it does not:
the cost-aware rules' dollar-equivalent cost (price + the budget x the share of each limit) depends
on the budget, so a larger budget ranks candidates differently (and even uniform's tie-break by
cost can differ). Sharing is then switched off and every budget runs from scratch (the result's
``share_prefix`` says False).
"""

from __future__ import annotations

import csv
import io
import math
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Unpack

import numpy as np

from sensorsel.designs.inputs import result_fingerprint
from sensorsel.designs.options import RunKeywords, RunOptions
from sensorsel.designs.parts import Provenance, provenance
from sensorsel.designs.selection import RULES, GreedyResult, Rule, Step, check_budget, check_rule, greedy
from sensorsel.errors import InputError
from sensorsel.information.evaluators import Evaluator, evaluator_for
from sensorsel.information.evaluators.domain import check_aggregate
from sensorsel.information.evaluators.registry import check_engine
from sensorsel.io.files import atomic_write_text
from sensorsel.io.progress import Progress
from sensorsel.io.records import RuleBudget, SuiteScore
from sensorsel.io.results import result_kind, to_jsonable
from sensorsel.model.constraints import REL_SLACK, Constraints, feasible_set
from sensorsel.model.library import SensorLibrary
from sensorsel.model.problem import Target, TargetInfo
from sensorsel.model.recipes import EvaluatorRecipe, TargetRecipe
from sensorsel.pipeline import Executor, FileStore, InProcess, NoStore, Plan, Store, execute

#: The rules of the paper's Fig. 4 (uniform, cost-benefit) and the classic marginal rule.
DEFAULT_RULES: tuple[str, ...] = ("uniform", "cost-benefit", "marginal")
#: Budgets in the default log-spaced grid.
DEFAULT_N_BUDGETS = 14

#: progress(done, total): called after each (rule, budget) run.
#: a single rule's runs: budget -> (the run with all its steps, picks shared from a larger budget's run)
RuleRuns = dict[float, tuple[GreedyResult, int]]
RULE_FORMAT = 1  # bumped when a rule's file (OUTDIR/runs/rule-NAME.json) or how it is computed changes


@dataclass(frozen=True)
class Architecture(SuiteScore):
    """One suite the greedy runs produced (identical suites merged).

    Attributes:
        normalized: score / the best score of the tradespace (1.0 for the best).
        rules: the rules whose runs produced this suite, in the tradespace's rule order.
        on_front: True when no recorded architecture dominates it.
    """

    normalized: float
    rules: tuple[str, ...]
    on_front: bool

    @property
    def n_sensors(self) -> int:
        return len(self.suite)


@dataclass(frozen=True)
class TradespaceRun(SuiteScore, RuleBudget):
    """Summary of one greedy run of the tradespace (its architectures are in ``architectures``).

    Attributes:
        n_steps: picks made (intermediate architectures).
        shared_steps: leading picks taken from an earlier run at a larger budget (not recomputed).
        stop_reason: why selection stopped.
        n_evaluations: suites scored by this run (0 for a strategy such as best-of: it reuses its
            component rules' runs).
        winning_rule: for a strategy, the component run it kept; else the rule.
    """

    n_steps: int
    shared_steps: int
    stop_reason: str
    n_evaluations: int
    winning_rule: str


@result_kind("tradespace")
@dataclass(frozen=True)
class TradespaceResult(Provenance):
    """Every architecture of the greedy runs over a grid of budgets, and the Pareto front.

    Attributes:
        budgets_usd: the budgets [$], ascending.
        rules: the rules run, in the order given.
        architectures: unique suites, sorted by cost (ascending), then score (descending), then ids.
        runs: one summary per (rule, budget), rules in order, budgets ascending.
        best_score: the largest score recorded [nats] (0.0 when nothing was bought).
        engine: the evaluator used.
        lazy: whether lazy (Minoux) evaluation was used where the rule allows it.
        share_prefix: whether smaller budgets resumed from larger budgets' runs.
        n_evaluations: suites scored in total.
        constraints: the limits every run kept, the same at every budget (as ``problem`` and
            ``seconds``, documented in :class:`~sensorsel.designs.parts.Provenance`).
    """

    budgets_usd: tuple[float, ...]
    rules: tuple[str, ...]
    architectures: tuple[Architecture, ...]
    runs: tuple[TradespaceRun, ...]
    best_score: float
    engine: str
    lazy: bool
    share_prefix: bool
    n_evaluations: int

    @property
    def front(self) -> tuple[Architecture, ...]:
        """The Pareto front, cheapest first (ties: higher score first, then ids)."""
        return tuple(a for a in self.architectures if a.on_front)

    @property
    def best(self) -> Architecture | None:
        """The architecture with the best score (ties: the cheapest), or None when there are none."""
        return self.cheapest_reaching(1.0) if self.architectures else None

    def cheapest_reaching(self, fraction: float) -> Architecture | None:
        """The cheapest architecture whose score is at least ``fraction`` of the best score.

        ``score >= fraction * best_score`` is tested on the recorded floats. Among equally cheap
        ones, the higher score wins (then ids), so the answer is always on the front.

        Args:
            fraction: in (0, 1], e.g. 0.99.
        Returns:
            The architecture, or None when the tradespace is empty.
        Raises:
            InputError: a fraction outside (0, 1].
        """
        if isinstance(fraction, bool) or not isinstance(fraction, (int, float)) or not 0.0 < float(fraction) <= 1.0:
            raise InputError(f"fraction of the best score must be in (0, 1], got {fraction!r}")
        threshold = float(fraction) * self.best_score
        for a in self.architectures:  # sorted by cost, then score descending
            if a.score >= threshold:
                return a
        return None


# ----------------------------------------------------------------------------------------- budgets


def default_budgets(library: SensorLibrary, n: int = DEFAULT_N_BUDGETS) -> tuple[float, ...]:
    """``n`` log-spaced budgets [$] from the cheapest sensor to the whole library's cost.

    Inner budgets are rounded to whole dollars; the ends are exact.
    """
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise InputError(f"number of budgets must be a positive integer, got {n!r}")
    costs = library.costs
    lo, hi = float(costs.min()), float(costs.sum())
    if n == 1 or hi <= lo:
        return (hi,)
    grid = [float(round(b)) for b in np.geomspace(lo, hi, n)]
    grid[0], grid[-1] = lo, hi
    return tuple(sorted(set(grid)))


def parse_budgets(text: str, name: str = "--budgets") -> tuple[float, ...]:
    """Budgets [$] from comma-separated numbers (``"5000,27000,110000"``; ``$`` and ``_`` allowed).

    Returns them sorted, duplicates removed. Raises InputError naming ``name`` and the bad item.
    """
    items = [t.strip() for t in str(text).split(",")]
    if not any(items):
        raise InputError(f"{name}: expected comma-separated budgets in dollars, got {text!r}")
    out = []
    for t in items:
        if not t:
            raise InputError(f"{name}: empty item in {text!r}")
        try:
            v = float(t.replace("$", "").replace("_", ""))
        except ValueError:
            raise InputError(f"{name}: {t!r} is not a number of dollars") from None
        try:
            out.append(check_budget(v))
        except InputError:
            raise InputError(f"{name}: {t!r} is not a finite, non-negative number of dollars") from None
    return tuple(sorted(set(out)))


def parse_rules(text: str | Iterable[str], name: str = "--rules") -> tuple[str, ...]:
    """Rule names from ``"uniform,cost-benefit"`` or a sequence; order kept, duplicates dropped."""
    items = [t.strip() for t in text.split(",")] if isinstance(text, str) else [str(t).strip() for t in text]
    items = [t for t in items if t]
    if not items:
        raise InputError(f"{name}: no rule given; available: {', '.join(RULES)}")
    for t in items:
        try:
            check_rule(t)
        except InputError as exc:
            raise InputError(f"{name}: {exc}") from None
    return tuple(dict.fromkeys(items))


# ------------------------------------------------------------------------------------ Pareto front


def dominates(cost_a: float, score_a: float, cost_b: float, score_b: float) -> bool:
    """True when (cost_a, score_a) dominates (cost_b, score_b): no worse in both, better in one."""
    return cost_a <= cost_b and score_a >= score_b and (cost_a < cost_b or score_a > score_b)


def pareto_mask(costs: Sequence[float], scores: Sequence[float]) -> np.ndarray:
    """Which points are on the Pareto front (lower cost, higher score), shape (n,) of bool.

    O(n log n): sweep the points by cost; within one cost only the highest score can be on the front,
    and it is when it beats the best score of every strictly cheaper point.
    """
    c = np.asarray(costs, dtype=float)
    s = np.asarray(scores, dtype=float)
    if c.shape != s.shape or c.ndim != 1:
        raise InputError(f"pareto_mask: costs and scores must be 1-D of equal length, got {c.shape} and {s.shape}")
    if not (np.all(np.isfinite(c)) and np.all(np.isfinite(s))):
        raise InputError("pareto_mask: costs and scores must be finite")
    mask = np.zeros(len(c), dtype=bool)
    order = np.lexsort((-s, c))  # by cost, then score descending
    best_cheaper = -math.inf
    i = 0
    while i < len(order):
        j = i
        while j < len(order) and c[order[j]] == c[order[i]]:
            j += 1
        group = order[i:j]
        top = s[group[0]]
        if top > best_cheaper:
            mask[group[s[group] == top]] = True
        best_cheaper = max(best_cheaper, top)
        i = j
    return mask


# -------------------------------------------------------------------------------------- the runs


def _shared_prefix(steps: tuple[Step, ...], budget: float, start_cost: float = 0.0) -> int:
    """How many leading picks of ``steps`` also fit ``budget`` (same feasibility test as the greedy
    engine's budget row; ``start_cost``: what the sensors in the suite before the first pick spend)."""
    prev = start_cost
    slack = REL_SLACK * max(1.0, abs(budget))
    for k, st in enumerate(steps):
        if not st.sensor_cost_usd <= budget + slack - prev:
            return k
        prev = st.cost_usd
    return len(steps)


def prefix_sharing_exact(constraints: Constraints | None) -> bool:
    """Whether a run at a larger budget is exactly a prefix source under ``constraints`` (module
    docstring): yes unless there is a resource limit (its dollar-equivalent cost depends on the budget)."""
    return constraints is None or not constraints.limits


def rule_runs(
    evaluator: Evaluator,
    rule: str,
    budgets_desc: Sequence[float],
    *,
    lazy: bool,
    share_prefix: bool,
    tick: Callable[[], None] = lambda: None,
    constraints: Constraints | None = None,
) -> RuleRuns:
    """Runs of one rule at every budget (largest first): budget -> (result with all steps, shared steps)."""
    lib = evaluator.library
    done: dict[float, tuple[GreedyResult, int]] = {}
    share_prefix = share_prefix and prefix_sharing_exact(constraints)
    for b in budgets_desc:
        k, src = 0, None
        if share_prefix:
            fb = feasible_set(lib, b, constraints) if constraints is not None else None
            start_cost = float(fb.usage(fb.required)[0]) if fb is not None else 0.0
            for run, _ in done.values():  # largest budgets first: the first longest prefix wins
                n = _shared_prefix(run.steps, b, start_cost)
                if n > k:
                    k, src = n, run
        prefix = src.steps[:k] if src is not None else ()
        start = tuple(lib.position(i) for i in prefix[-1].suite) if prefix else ()
        cont = greedy(evaluator, b, rule, lazy=lazy, start=start, constraints=constraints)
        steps = tuple(prefix) + cont.steps
        full = GreedyResult(
            rule=rule,
            budget_usd=cont.budget_usd,
            suite=steps[-1].suite if steps else (),
            cost_usd=steps[-1].cost_usd if steps else 0.0,
            score=steps[-1].score if steps else 0.0,
            steps=steps,
            stop_reason=cont.stop_reason,
            n_evaluations=cont.n_evaluations,
            engine=cont.engine,
            lazy=cont.lazy,
            winning_rule=rule,
            constraints=cont.constraints,
        )
        done[b] = (full, k)
        tick()
    return done


@dataclass(frozen=True)
class RuleTask:
    """One single rule's chain of budgets (a plan's task), largest first, sharing prefixes as in-process.
    ``first``: whether it counts the problem's baseline log det (as one in-process evaluator: once)."""

    rule: str
    budgets_desc: tuple[float, ...]
    lazy: bool
    share_prefix: bool
    first: bool
    constraints: Constraints | None = None


def rule_step(state: Evaluator | tuple[Target, EvaluatorRecipe], task: RuleTask) -> tuple[RuleRuns, int]:
    """One rule's runs and the suites it scored: on the caller's evaluator (in-process, shared by the
    rules), or on a fresh one built from the target a worker holds."""
    if isinstance(state, Evaluator):
        ev = state
    else:
        target, recipe = state
        ev = evaluator_for(target, recipe.engine, jobs=recipe.jobs, aggregate=recipe.aggregate)
    if not task.first:  # a route's baseline is counted by the first rule only, as by one evaluator in one
        ev.prime()  # run (also when the first rule's runs were read back)
    n0 = ev.n_evaluations
    runs = rule_runs(
        ev, task.rule, task.budgets_desc, lazy=task.lazy, share_prefix=task.share_prefix, constraints=task.constraints
    )
    return runs, ev.n_evaluations - n0


@result_kind("tradespace-rule-runs")
@dataclass(frozen=True)
class RuleRunsRecord:
    """A finished rule's runs in ``OUTDIR/runs/rule-NAME.json`` (``--resume``): its inputs' fingerprint, the rule,
    the budgets (largest first), each budget's run (all steps), the picks it shared, the suites scored."""

    fingerprint: str
    rule: str
    budgets_usd: tuple[float, ...]
    runs: tuple[GreedyResult, ...]
    shared: tuple[int, ...]
    n_evaluations: int


def rule_fingerprint(
    info: TargetInfo | None, engine: str, aggregate: str, task: RuleTask, limits: Constraints | None = None
) -> str:
    """Digest of what a rule's runs depend on: each route by content with its weight, the engine, the
    aggregate, every field of ``task`` and ``limits`` (as recorded: with the library's resources' digest)."""
    return result_fingerprint(
        "tradespace-rule", RULE_FORMAT, info, engine=engine, aggregate=aggregate, limits=limits, **to_jsonable(task)
    )


def rule_store(
    tasks: Sequence[RuleTask],
    info: TargetInfo | None,
    engine: str,
    aggregate: str,
    outdir: str | Path | None,
    resume: bool,
    limits: Constraints | None = None,
) -> Store[tuple[RuleRuns, int]]:
    """Where the rules' runs are kept: ``OUTDIR/runs/rule-NAME.json`` (none without ``outdir``)."""
    if outdir is None:
        return NoStore()
    fps = [rule_fingerprint(info, engine, aggregate, t, limits) for t in tasks]

    def wrap(i: int, got: tuple[RuleRuns, int]) -> RuleRunsRecord:
        runs, n = got
        return RuleRunsRecord(
            fps[i],
            tasks[i].rule,
            tuple(runs),
            tuple(v[0] for v in runs.values()),
            tuple(v[1] for v in runs.values()),
            n,
        )

    def unwrap(rec: RuleRunsRecord) -> tuple[RuleRuns, int]:
        return {b: (r, k) for b, r, k in zip(rec.budgets_usd, rec.runs, rec.shared)}, rec.n_evaluations

    return FileStore(
        [Path(outdir) / "runs" / f"rule-{t.rule}.json" for t in tasks],
        fps,
        RuleRunsRecord,
        wrap,
        unwrap,
        resume=resume,
        what="other inputs (target, budgets, rule, engine, laziness, aggregate or limits)",
    )


def tradespace(
    evaluator: Evaluator,
    budgets: Iterable[float] | None = None,
    rules: Iterable[str] = DEFAULT_RULES,
    *,
    lazy: bool = True,
    share_prefix: bool = True,
    progress: Progress | None = None,
    info: TargetInfo | None = None,
    constraints: Constraints | None = None,
    executor: Executor | None = None,
    recipe: EvaluatorRecipe | None = None,
    outdir: str | Path | None = None,
    resume: bool = False,
) -> TradespaceResult:
    """Run each rule at each budget and collect the architectures and the Pareto front.

    Args:
        evaluator: scores suites of one problem.
        budgets: budgets [$] (default: :func:`default_budgets` of the problem's library).
        rules: names of :data:`sensorsel.designs.selection.RULES`. A strategy (best-of) is assembled from its
            component rules' runs at the same budget (run for it if not requested).
        lazy: lazy (Minoux) evaluation where the rule allows it (same picks, fewer evaluations).
        share_prefix: resume smaller budgets from larger budgets' runs (see the module docstring).
        progress: called as progress(done, total) after each (single rule, budget) run.
        info: what the problem is (recorded in the result).
        constraints: limits besides the budget, kept by every run at every budget (module docstring).
        executor: where each rule's chain of budgets runs, one task per rule (:mod:`sensorsel.pipeline`;
            default here, on ``evaluator``; elsewhere on the target rebuilt from ``recipe``): same result.
        outdir, resume: each rule's runs go to ``OUTDIR/runs/rule-NAME.json`` as they finish; ``resume``
            reads back those whose inputs match. Returns the :class:`TradespaceResult`.
    """
    t0 = time.perf_counter()
    lib = evaluator.library
    sel = parse_rules(rules, "rules")
    grid = default_budgets(lib) if budgets is None else tuple(sorted({check_budget(b) for b in budgets}))
    if budgets is None and constraints is not None and constraints.require:
        # the default grid starts at the cheapest sensor: keep the budgets that pay for the required ones
        whole = feasible_set(lib, grid[-1], constraints)
        grid = tuple(b for b in grid if b >= float(whole.usage(whole.required)[0])) or grid[-1:]
    if not grid:
        raise InputError("the tradespace needs at least one budget")
    feas = {b: feasible_set(lib, b, constraints) for b in grid} if constraints is not None else {}
    top = feas[grid[-1]] if feas else None
    if top is not None and top.plain:
        constraints, feas, top = None, {}, None  # the budget alone: the paper's tradespace, unchanged
    share_prefix = share_prefix and prefix_sharing_exact(constraints)
    singles = _single_rules(sel)
    total = len(singles) * len(grid)
    count = [0]

    def tick(i: int, got: tuple[RuleRuns, int], reused: bool) -> None:  # once per (rule, budget) run
        for _ in got[0]:
            count[0] += 1
            if progress:
                progress(count[0], total)

    if (outdir is not None or resume) and (outdir is None or info is None or recipe is None):
        raise InputError(
            "a tradespace stored in (or resumed from) a folder needs outdir, info and recipe: use run_tradespace"
        )
    if recipe is None and executor is not None and not isinstance(executor, InProcess):
        raise InputError("a tradespace run elsewhere rebuilds its target from a recipe: use run_tradespace")
    tasks = tuple(
        RuleTask(r, tuple(sorted(grid, reverse=True)), lazy, share_prefix, k == 0, constraints)
        for k, r in enumerate(singles)
    )
    plan: Plan[tuple[RuleRuns, int]] = Plan(
        "tradespace rule", rule_step, tasks, states=(recipe,), build=EvaluatorRecipe.build, local=(evaluator,)
    )
    eng_agg = ("", "") if recipe is None else (str(recipe.engine), recipe.aggregate)
    store = rule_store(tasks, info, *eng_agg, outdir, resume, None if top is None else top.constraints)
    got = execute(plan, executor, store, on_result=tick)
    per_rule = {r: got[k][0] for k, r in enumerate(singles)}
    n_evals = sum(n for _, n in got)
    for r in singles:  # no run, here or elsewhere, may leave the feasible set
        for b, (run, _) in per_rule[r].items():
            bad = feas[b].violations(lib.resolve_suite(run.suite)) if feas else []
            if bad or (feas and run.constraints is None):
                raise InputError(
                    f"the tradespace run {r} at ${b:,.0f} was not made under the limits "
                    f"({constraints.describe() if constraints else ''}): {'; '.join(bad) or 'it records none'}"
                )

    runs: list[TradespaceRun] = []
    found: dict[frozenset[int], tuple[float, set[str]]] = {}  # suite -> (score as first recorded, rules)
    for name in sel:
        entry = RULES[name]
        for b in grid:
            if isinstance(entry, Rule):
                res, shared = per_rule[name][b]
                evals = res.n_evaluations
            else:  # a strategy: the run it keeps among its components' runs, which scored the suites
                res, shared, evals = entry.keep([per_rule[c][b][0] for c in entry.component_rules]), 0, 0
            runs.append(
                TradespaceRun(
                    name,
                    b,
                    res.suite,
                    res.cost_usd,
                    res.score,
                    len(res.steps),
                    shared,
                    res.stop_reason,
                    evals,
                    res.winning_rule,
                )
            )
            for st in res.steps:
                key = frozenset(lib.position(i) for i in st.suite)
                if key not in found:
                    found[key] = (st.score, set())
                found[key][1].add(name)

    rows = _architectures(lib, sel, found, None if top is None else top.A[0])
    best = max((score for _, _, score, _ in rows), default=0.0)
    on_front = pareto_mask([cost for _, cost, _, _ in rows], [score for _, _, score, _ in rows])
    archs = tuple(
        Architecture(ids, cost, score, score / best if best > 0 else 0.0, made_by, bool(f))
        for (ids, cost, score, made_by), f in zip(rows, on_front)
    )
    return TradespaceResult(
        budgets_usd=grid,
        rules=sel,
        architectures=archs,
        runs=tuple(runs),
        best_score=best,
        engine=evaluator.name,
        lazy=lazy,
        share_prefix=share_prefix,
        n_evaluations=n_evals,
        **provenance(info, t0, None if top is None else top.constraints),
    )


def _single_rules(names: tuple[str, ...]) -> list[str]:
    """The single rules to run: those named, in order, then the components of the strategies named."""
    singles = [r for r in names if isinstance(RULES[r], Rule)]
    for r in names:
        singles += [c for c in RULES[r].component_rules if c not in singles]
    return singles


def _architectures(
    lib: SensorLibrary,
    sel: tuple[str, ...],
    found: dict[frozenset[int], tuple[float, set[str]]],
    price: np.ndarray | None = None,
) -> list[tuple[tuple[str, ...], float, float, tuple[str, ...]]]:
    """(ids in library order, cost, score, rules) per unique suite, sorted by cost, -score, ids.
    ``price``: (n,) what each sensor spends of the budget (owned sensors 0); default the library's costs."""
    rows = []
    for key, (score, made_by) in found.items():
        pos = sorted(key)
        cost = lib.cost(pos) if price is None else float(sum(float(price[i]) for i in pos))
        rows.append((lib.suite_ids(pos), cost, float(score), tuple(s for s in sel if s in made_by)))
    rows.sort(key=lambda r: (r[1], -r[2], r[0]))
    return rows


def run_tradespace(
    target: Target,
    budgets: Iterable[float] | None = None,
    rules: Iterable[str] = DEFAULT_RULES,
    *,
    share_prefix: bool = True,
    executor: Executor | None = None,
    outdir: str | Path | None = None,
    resume: bool = False,
    **options: Unpack[RunKeywords],
) -> TradespaceResult:
    """``sensorsel pareto``: :func:`tradespace` with a fresh evaluator for a problem or a domain; the
    keywords: the run options (:class:`~sensorsel.designs.options.RunOptions`: ``engine``, ``jobs``,
    ``aggregate``, how a domain combines its routes, ``lazy``, ``constraints``, ``progress``) and the
    other arguments of :func:`tradespace`."""
    o = RunOptions(**options)
    sel = parse_rules(rules, "rules")  # bad input fails before the evaluator is built
    grid = None if budgets is None else tuple(check_budget(b) for b in budgets)
    eng, agg = check_engine(o.engine), check_aggregate(o.aggregate)
    if o.constraints is not None:
        for b in grid or (float(target.library.costs.sum()),):
            feasible_set(target.library, b, o.constraints)  # refuses a bad request (at every budget) up front
    ev = o.evaluator(target)
    return tradespace(
        ev,
        grid,
        sel,
        lazy=o.lazy,
        share_prefix=share_prefix,
        progress=o.progress,
        info=target.info,
        constraints=o.constraints,
        executor=executor,
        recipe=EvaluatorRecipe(TargetRecipe.of(target), eng, o.jobs, agg),
        outdir=outdir,
        resume=resume,
    )


# ------------------------------------------------------------------------------------------ output

CSV_COLUMNS = ("cost_usd", "score", "normalized_score", "on_front", "n_sensors", "rules", "suite")


def csv_text(result: TradespaceResult) -> str:
    """The architectures as CSV: one row each, in the result's order.

    Columns: cost_usd, score (nats), normalized_score, on_front (1/0), n_sensors, rules
    (``+``-separated), suite (comma-separated ids, quoted; paste into ``sensorsel score --suite``).
    """
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(CSV_COLUMNS)
    for a in result.architectures:
        w.writerow(
            [
                f"{a.cost_usd:.2f}",
                repr(a.score),
                repr(a.normalized),
                int(a.on_front),
                a.n_sensors,
                "+".join(a.rules),
                ",".join(a.suite),
            ]
        )
    return buf.getvalue()


def write_csv(result: TradespaceResult, path: str | Path) -> Path:
    """Write :func:`csv_text` to ``path`` atomically."""
    return atomic_write_text(path, csv_text(result))
