"""The public run functions: what each CLI command calls, usable as-is from scripts and notebooks.

Each takes a :class:`~sensorsel.model.problem.Problem` (one route) or, where it makes sense, a
:class:`~sensorsel.model.problem.Domain` (an operating domain of routes, one suite for all), builds the
evaluator, and records what it ran on (``target.info``). This is the top of the library's layers:
nothing below it imports it. The run functions are importable from ``sensorsel`` itself. It is also
the command line's one door to the designs and the information: the records, constants and
lower-level runs the CLI needs are re-exported here (``pyproject.toml`` forbids it any other way).

>>> from sensorsel import ScenarioSpec, load_problem, run_greedy, score_suite
>>> problem = load_problem(ScenarioSpec(fixture="tiny"))          # a bundled synthetic route
>>> res = run_greedy(problem, 5000, "uniform", certify=True)
>>> res.suite, res.cost_usd
(('MRL-roof', 'HD2K-10', 'HD2K-4'), 4898.0)
>>> round(res.score, 3), round(res.certificate.percent_of_best, 1)   # nats; at least X% of the best possible
(1560.721, 86.4)
>>> round(score_suite(problem, res.suite).score, 3)                 # a result's suite scores as ids
1560.721
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Unpack

from sensorsel.designs.certify import (
    DEFAULT_MAX_NODES,
    Certificate,
    CertifiedGreedyResult,
    OptimumResult,
    certificate,
    constraints_mismatch,
    format_certificate,
    optimal,
)

# What the command line takes from the layers below, re-exported so that it needs no other door
# (pyproject.toml: sensorsel.cli imports neither sensorsel.designs nor sensorsel.information).
from sensorsel.designs.checkpoint import checkpoint_path, remove_checkpoint
from sensorsel.designs.domain_design import DomainDesign, by_condition
from sensorsel.designs.greedy_run import GreedyKeywords, GreedyRun, domain_design, greedy_design
from sensorsel.designs.options import RunKeywords, RunOptions, ScoringKeywords
from sensorsel.designs.parts import SuiteQuality
from sensorsel.designs.requirements import FrontAcceptance, RequireResult, front_acceptance
from sensorsel.designs.requirements import require as run_require
from sensorsel.designs.requirements.design import RouteRequirement
from sensorsel.designs.requirements.integrity import integrity_preset
from sensorsel.designs.requirements.spec import (
    DEFAULT_MAP_SIGMA_M,
    PRESETS,
    Specification,
    load_specification_file,
    preset,
    specifications_for,
)
from sensorsel.designs.resilient import (
    ALGORITHM_2,
    METHODS,
    ResilientReport,
    check_alpha,
    check_period,
    recorded,
    save_grid_csv,
    split_periods,
)
from sensorsel.designs.resilient import resilient_report as _resilient_report
from sensorsel.designs.robust import (
    EXTRA_METHODS,
    WORST_METHODS,
    RobustResult,
    robust_choice,
    robust_select,
    worst_route_select,
)
from sensorsel.designs.robust import run_robust as _run_robust
from sensorsel.designs.selection import (
    RULES,
    GreedyResult,
    Progress,
    check_affordable,
    check_budget,
    check_rule,
    rules_help,
)
from sensorsel.designs.study import load_study, run_study, write_study
from sensorsel.designs.tradespace import (
    DEFAULT_RULES,
    Architecture,
    parse_budgets,
    parse_rules,
    run_tradespace,
    write_csv,
)
from sensorsel.errors import InputError
from sensorsel.information.evaluators import (
    AGGREGATES,
    ENGINES,
    DomainEvaluator,
    Evaluator,
    evaluator_for,
    make_evaluator,
)
from sensorsel.information.evaluators.accuracy import (
    RouteAccuracy,
    accuracy_from_covariances,
    estimate_label,
    model_label,
    route_accuracy,
)
from sensorsel.information.evaluators.distributed import (
    DistributedDomainEvaluator,
)  # imports no Dask: a client is handed in
from sensorsel.information.evaluators.processes import on_processes
from sensorsel.information.filtering import ESTIMATES, check_estimate, check_map_sigma
from sensorsel.information.integrity import IntegritySpec, RouteIntegrity, route_integrity
from sensorsel.information.integrity.association import gate_of
from sensorsel.information.integrity.risk import integrity_and_pass
from sensorsel.io.records import SuiteScore
from sensorsel.io.results import result_kind
from sensorsel.model.constraints import feasible_set
from sensorsel.model.problem import Domain, DomainInfo, Problem, ProblemInfo, Target, load_domain, load_problem
from sensorsel.model.recipes import RouteRecipe
from sensorsel.pipeline import LocalProcesses, Plan, execute
from sensorsel.simulation.records import SimulationResult

__all__ = [
    "RouteAccuracy",
    "suite_accuracy",
    "RouteIntegrity",
    "IntegritySpec",
    "suite_integrity",
    "with_suite_quality",
    "run_require",
    "RequireResult",
    "FrontAcceptance",
    "front_acceptance",
    "CertifiedGreedyResult",
    "DomainDesign",
    "DomainScoreResult",
    "ProblemInfo",
    "RouteScore",
    "ScoreResult",
    "certify_result",
    "design_domain",
    "load_domain",
    "load_problem",
    "resilient_report",
    "run_greedy",
    "run_robust",
    "RobustResult",
    "run_optimal",
    "run_tradespace",
    "score_domain_suite",
    "score_suite",
    "simulate",
]
#: Re-exported for the command line (above): the runs, records and constants it uses.
__all__ += [
    "AGGREGATES",
    "Architecture",
    "Certificate",
    "DEFAULT_MAP_SIGMA_M",
    "DEFAULT_MAX_NODES",
    "DEFAULT_RULES",
    "ENGINES",
    "ESTIMATES",
    "EXTRA_METHODS",
    "Evaluator",
    "GreedyResult",
    "METHODS",
    "ALGORITHM_2",
    "PRESETS",
    "RULES",
    "RouteRequirement",
    "Specification",
    "WORST_METHODS",
    "by_condition",
    "check_affordable",
    "check_alpha",
    "check_budget",
    "check_period",
    "check_rule",
    "checkpoint_path",
    "constraints_mismatch",
    "estimate_label",
    "evaluator_for",
    "format_certificate",
    "gate_of",
    "integrity_preset",
    "load_specification_file",
    "load_study",
    "model_label",
    "parse_budgets",
    "parse_rules",
    "preset",
    "remove_checkpoint",
    "rules_help",
    "run_study",
    "save_grid_csv",
    "specifications_for",
    "split_periods",
    "write_csv",
    "write_study",
]
__all__ += ["DistributedDomainEvaluator"]  # a domain's routes on a Dask cluster's workers (cli.cluster)


@result_kind("score")
@dataclass(frozen=True)
class ScoreResult(SuiteScore):
    """The score of one suite.

    Attributes:
        logdet: log det L(S) [nats].
        baseline_logdet: log det L(empty) [nats].
        n_measurements: range-bearing measurements the suite makes along the route.
        n_landmarks_seen: landmarks measured at least once.
        engine: evaluator used.
        problem: what it was computed on.
        accuracy: the suite's accuracy in metres and degrees, per keyframe (None when not asked for).
        integrity: the suite's integrity (association risk, integrity risk, protection levels), one
            per route (empty when not asked for).
    """

    logdet: float
    baseline_logdet: float
    n_measurements: int
    n_landmarks_seen: int
    engine: str
    problem: ProblemInfo
    accuracy: RouteAccuracy | None = None
    integrity: tuple[RouteIntegrity, ...] = ()


def score_suite(
    problem: Problem,
    suite: str | Iterable[str | int],
    *,
    engine: str | None = None,
    accuracy: bool = True,
    map_sigma_m: float | None = None,
    estimate: str = "filter",
) -> ScoreResult:
    """Score a suite given as comma-separated ids (``"LRL-roof,LRR-12"``), ids, or library positions;
    with ``accuracy``, also its accuracy in metres (the SLAM graph, or with ``map_sigma_m`` [m] a
    prior map; the filter's estimate as the car drives, or ``estimate="smoother"``: :func:`suite_accuracy`)."""
    lib = problem.library
    positions = lib.resolve_suite(suite)
    ev = make_evaluator(problem, engine)
    logdet = ev.logdet(positions)
    seen: set[int] = set()
    for i in positions:
        seen.update(problem.observations[i].landmark.tolist())
    return ScoreResult(
        suite=lib.suite_ids(positions),
        cost_usd=lib.cost(positions),
        score=logdet - ev.baseline_logdet,
        logdet=logdet,
        baseline_logdet=ev.baseline_logdet,
        n_measurements=sum(len(problem.observations[i]) for i in positions),
        n_landmarks_seen=len(seen),
        engine=ev.name,
        problem=problem.info,
        accuracy=route_accuracy(ev, positions, map_sigma_m=map_sigma_m, estimate=estimate) if accuracy else None,
    )


def suite_accuracy(
    target: Target,
    suite: str | Iterable[str | int],
    *,
    map_sigma_m: float | None = None,
    engine: str | None = None,
    estimate: str = "filter",
) -> tuple[RouteAccuracy, ...]:
    """The accuracy of a suite in metres and degrees on every route of ``target`` (one for a
    problem), per keyframe: :mod:`sensorsel.information.evaluators.accuracy`. ``map_sigma_m``: localizing in a
    prior map whose landmarks are known to that std [m]; None: the paper's SLAM graph. ``estimate``:
    "filter" (at each keyframe from the measurements up to it: as the car drives) or "smoother"
    (from the whole route)."""
    positions = target.library.resolve_suite(suite)
    return tuple(
        route_accuracy(
            make_evaluator(r.problem, engine), positions, map_sigma_m=map_sigma_m, route=r.name, estimate=estimate
        )
        for r in target.routes
    )


def suite_integrity(
    target: Target,
    suite: str | Iterable[str | int],
    spec: IntegritySpec | None = None,
    *,
    map_sigma_m: float | None = None,
) -> tuple[RouteIntegrity, ...]:
    """The integrity of a suite on every route of ``target`` (one for a problem), per keyframe: the
    association risk of its measurements, the integrity risk for ``spec``'s alert limits, the
    protection levels and the risk per hour (:mod:`sensorsel.information.integrity`), as the car
    drives (the filter). ``map_sigma_m``: localizing in a map known to that std [m]; None: SLAM."""
    positions = target.library.resolve_suite(suite)
    return tuple(
        route_integrity(r.problem, positions, spec, map_sigma_m=map_sigma_m, route=r.name) for r in target.routes
    )


def with_suite_quality(
    result: Any,
    target: Target,
    *,
    map_sigma_m: float | None = None,
    engine: str | None = None,
    estimate: str = "filter",
    integrity: IntegritySpec | None = None,
    jobs: int = 1,
) -> Any:
    """``result`` (a frozen record with ``suite``, ``accuracy`` and ``integrity`` fields) with its suite's
    accuracy (:func:`suite_accuracy`) and integrity (:func:`suite_integrity`) on ``target`` filled in:
    what every selecting command reports of the suite it chose. ``jobs``: worker processes for a
    domain's routes (the filter's estimate: each route's pass in a worker; the same bytes)."""
    if estimate != "filter" or (integrity is not None and integrity.max_association_risk is not None):
        return replace(
            result,
            accuracy=suite_accuracy(target, result.suite, map_sigma_m=map_sigma_m, engine=engine, estimate=estimate),
            integrity=suite_integrity(target, result.suite, integrity, map_sigma_m=map_sigma_m),
        )
    # the filter without the lever: the integrity's forward pass uses every measurement, so its
    # filtered covariances are the accuracy's (the filter is the same whatever the engine): one pass
    check_estimate(estimate)
    check_map_sigma(map_sigma_m)
    positions = target.library.resolve_suite(result.suite)
    routes = [(r.name, r.problem) for r in target.routes]
    plan = Plan(
        "route's accuracy and integrity",
        _route_quality,
        [(positions, integrity, map_sigma_m, name) for name, _ in routes],
        states=[RouteRecipe.of(name, p) for name, p in routes],
        build=RouteRecipe.build,
        state_of=list(range(len(routes))),
        local=[p for _, p in routes],
    )
    quality = execute(plan, LocalProcesses(jobs if on_processes(target, jobs) else 1))
    return replace(result, accuracy=tuple(a for a, _ in quality), integrity=tuple(i for _, i in quality))


def _route_quality(problem: Problem, task: tuple[Any, ...]) -> tuple[RouteAccuracy, RouteIntegrity]:
    """One route's accuracy and integrity of a suite from one forward pass (a plan's step: ``task``
    is (positions, integrity spec, map σ [m], route name))."""
    positions, integrity, map_sigma_m, name = task
    ri, fp = integrity_and_pass(problem, positions, integrity, map_sigma_m=map_sigma_m, route=name)
    return accuracy_from_covariances(fp.filtered, map_sigma_m=map_sigma_m, route=name, estimate="filter"), ri


def run_greedy(
    problem: Target,
    budget_usd: float,
    rule: str = "uniform",
    *,
    evaluator: Evaluator | None = None,
    **greedy: Unpack[GreedyKeywords],
) -> CertifiedGreedyResult:
    """The ``sensorsel greedy`` run (:func:`sensorsel.designs.greedy_run.greedy_design`): greedy selection
    with a fresh evaluator for a problem or a domain (its routes combined by ``aggregate``), recording
    what it ran on. The keywords: ``engine``, ``jobs``, ``aggregate``, ``lazy``, ``constraints`` (limits
    besides the budget: resources, mounting slots, required and excluded sensors, most sensors;
    :mod:`sensorsel.model.constraints`, recorded in the result) and ``progress`` (after each pick), as
    :class:`~sensorsel.designs.options.RunOptions` says; ``certify``, ``certify_progress``,
    ``checkpoint`` and ``resume``, as :class:`~sensorsel.designs.greedy_run.GreedyRun` says.

    With ``certify``, the result carries its :class:`~sensorsel.designs.certify.Certificate` (an upper bound
    on the best possible score within the budget), computed with the same evaluator: at most one sweep
    of the library per greedy step, fewer where a step provably cannot lower the bound
    (``certify_progress(done, total)`` after each); else its ``certificate`` is None.

    ``checkpoint``: a file written after each pick (:mod:`sensorsel.designs.checkpoint`); with ``resume``, an
    interrupted run's checkpoint there is read back and the run goes on from it (same result but
    timings and evaluation counts); a checkpoint of another run is not read back (a
    :class:`~sensorsel.pipeline.store.CacheWarning` names it and what differs; the run starts afresh).

    ``evaluator``: the target's evaluator already built (e.g. on a Dask cluster; ``engine``, ``jobs`` and
    ``aggregate`` are then its own); not with ``checkpoint`` (a resumable run builds its own).

    Raises:
        InputError: a bad budget or rule, or constraints the library cannot meet (before any
            evaluator is built).
        ValueError: both ``evaluator`` and ``checkpoint`` given.
    """
    if evaluator is not None and greedy.get("checkpoint") is not None:
        raise ValueError("run_greedy: a resumable run (checkpoint=) builds its own evaluator: give no evaluator=")
    return greedy_design(problem, GreedyRun.of(budget_usd, rule, **greedy), evaluator)


def design_domain(
    domain: Domain,
    budget_usd: float,
    rule: str = "uniform",
    *,
    breakdown_progress: Progress | None = None,
    evaluator: DomainEvaluator | None = None,
    **greedy: Unpack[GreedyKeywords],
) -> DomainDesign:
    """The ``sensorsel greedy --domain`` run: :func:`sensorsel.designs.greedy_run.domain_design`, greedy
    with its breakdown (one suite for every route, its certificate, each route's share of its best and
    of its own design, ``breakdown_progress(done, total)`` after each route:
    :class:`~sensorsel.designs.domain_design.DomainDesign`). The keywords, ``checkpoint`` and ``resume``
    too: as for :func:`run_greedy`; the certificate and each route's breakdown are recorded in the
    checkpoint as well. ``constraints``: limits besides the budget, for the domain suite and each
    route's own design."""
    return domain_design(domain, GreedyRun.of(budget_usd, rule, **greedy), evaluator, breakdown_progress)


@dataclass(frozen=True)
class RouteScore:
    """A suite's score on one route of a domain.

    Attributes:
        name: the route.
        weight: its normalised weight in the domain score.
        score: f_r(S) [nats].
        best_score: f_r(L), the whole library [nats].
        share_of_best: score / best_score.
    """

    name: str
    weight: float
    score: float
    best_score: float
    share_of_best: float


@result_kind("domain-score")
@dataclass(frozen=True)
class DomainScoreResult(SuiteQuality, SuiteScore):
    """The score of one suite on an operating domain, its accuracy and integrity on each route last, in
    route order (:class:`~sensorsel.designs.parts.SuiteQuality`; empty when not asked for).

    Attributes:
        aggregate: "normalised" or "raw".
        routes: each route's score.
        engine: the per-route engine.
        domain: what it was computed on.
    """

    aggregate: str
    routes: tuple[RouteScore, ...]
    engine: str
    domain: DomainInfo


def score_domain_suite(
    domain: Domain,
    suite: str | Iterable[str | int],
    *,
    engine: str | None = None,
    aggregate: str = "normalised",
    evaluator: DomainEvaluator | None = None,
) -> DomainScoreResult:
    """Score a suite on every route of ``domain`` and combine the routes (see
    :mod:`sensorsel.information.evaluators.domain`). ``evaluator``: the domain's evaluator already built (e.g. on
    a Dask cluster); ``engine`` and ``aggregate`` are then its own."""
    lib = domain.library
    positions = lib.resolve_suite(suite)
    ev = evaluator if evaluator is not None else DomainEvaluator(domain, engine, aggregate=aggregate)
    per = ev.route_scores(positions)
    routes = tuple(
        RouteScore(r.name, float(w), float(f), float(b), float(f / b))
        for r, w, f, b in zip(domain.routes, ev.weights, per, ev.best)
    )
    return DomainScoreResult(
        suite=lib.suite_ids(positions),
        cost_usd=lib.cost(positions),
        score=float(ev.combine(per)),
        aggregate=ev.aggregate,
        routes=routes,
        engine=ev.engine,
        domain=domain.info,
    )


def certify_result(
    target: Target,
    result: GreedyResult,
    *,
    progress: Progress | None = None,
    force: bool = False,
    evaluator: Evaluator | None = None,
    **scoring: Unpack[ScoringKeywords],
) -> Certificate:
    """The certificate of a greedy result on ``target`` (an upper bound on the best possible score
    within its budget; see :func:`sensorsel.designs.certify.certificate`), with a fresh evaluator of
    ``engine`` (default: the result's own), ``jobs`` and ``aggregate``
    (:class:`~sensorsel.designs.options.RunOptions`), or ``evaluator`` when given (e.g. built on a Dask
    cluster). ``progress(done, total)`` after each sweep.

    The bound respects the constraints the result records (``result.constraints``: resources,
    mounting slots, required and excluded sensors, most sensors).

    Raises:
        InputError: the result's constraints were checked against other resources or slots than
            ``target``'s library declares (``force``: certify anyway), or cannot apply to it at all.
    """
    mismatch = constraints_mismatch(result, target.library)
    if mismatch is not None and not (force and mismatch[1]):
        raise InputError(f"the greedy result: {mismatch[0]}")
    options = RunOptions(**scoring)
    if evaluator is None:
        evaluator = replace(options, engine=options.engine or _engine_of(result)).evaluator(target)
    return certificate(evaluator, result, progress=progress)


class OptimalKeywords(RunKeywords, total=False):
    """The keywords of :func:`run_optimal`: the run options (``lazy`` is not used: the search scores
    every node it opens) and the search's own (:func:`sensorsel.designs.certify.optimal`)."""

    max_nodes: int
    max_seconds: float | None
    rule: str
    checkpoint: str | Path | None
    resume: bool


def run_optimal(
    target: Target, budget_usd: float, *, evaluator: Evaluator | None = None, **search: Unpack[OptimalKeywords]
) -> OptimumResult:
    """The ``sensorsel optimal`` run: the best suite within the budget by branch and bound
    (:func:`sensorsel.designs.certify.optimal`), on a problem or a domain.

    ``constraints``: limits besides the budget (:mod:`sensorsel.model.constraints`); the optimum is the
    best suite they allow, and the result records them. ``evaluator``: the target's evaluator already
    built (e.g. on a Dask cluster; ``engine``, ``jobs`` and ``aggregate`` are then its own).
    ``max_nodes`` (default :data:`DEFAULT_MAX_NODES`), ``max_seconds``: the search's limits; ``rule``:
    the greedy rule of its starting incumbent (default "best-of"). ``checkpoint``: the search's state
    is saved there as it goes; ``resume``: go on from it.

    Raises:
        InputError: a bad budget or rule, or constraints the library cannot meet (before any
            evaluator is built).
    """
    options, own = RunOptions.split(search)
    check_budget(budget_usd)
    check_rule(own.get("rule", "best-of"))
    if options.constraints is not None:
        feasible_set(target.library, budget_usd, options.constraints)  # refuse a bad request before the evaluator
    ev = evaluator if evaluator is not None else options.evaluator(target)
    return optimal(ev, budget_usd, progress=options.progress, info=target.info, constraints=options.constraints, **own)


def _engine_of(result: GreedyResult) -> str | None:
    """The per-route engine a result was computed with ("domain[fast]" style names are not engines)."""
    return None if result.engine == DomainEvaluator.name else result.engine


#: ``method`` of :func:`resilient_report`: the paper's Algorithm 2 ("algorithm-2"), or robust selection.
RESILIENT_METHODS = METHODS
#: ``aggregate`` of :func:`run_robust`: the domain's combined scores, or its worst route.
ROBUST_AGGREGATES = ("normalised", "raw", "worst")


def run_robust(
    target: Target,
    budget_usd: float,
    alpha: int,
    *,
    aggregate: str = "normalised",
    evaluator: DomainEvaluator | None = None,
    **kwargs: Any,
) -> RobustResult:
    """The ``sensorsel robust`` run: the best worst case under ``alpha`` failures within the budget
    (:func:`sensorsel.designs.robust.run_robust`: the methods as a plan of tasks), on a problem or a domain.

    ``aggregate``: with a domain, "normalised" or "raw" robustify the combined domain score; "worst"
    maximises the worst route's share of its best under the failures
    (:func:`sensorsel.designs.robust.worst_route_select`; a domain only). ``kwargs`` go to the selector;
    ``constraints=`` (:mod:`sensorsel.model.constraints`) limits every candidate suite; ``executor=``,
    ``outdir=`` and ``resume=`` choose where the tasks run and where their outcomes are kept
    (not with ``evaluator`` nor with "worst": one run on one evaluator).
    ``engine=`` and ``jobs=`` build the evaluator; ``evaluator``: a domain's evaluator already built (e.g.
    on a Dask cluster; "worst" needs a normalised one); the engine, jobs and ``aggregate`` are then its own.

    Raises:
        InputError: bad budget, alpha or aggregate; "worst" on a single route; constraints the library
            cannot meet.
    """
    if aggregate not in ROBUST_AGGREGATES:
        raise InputError(f"unknown aggregate {aggregate!r}; available: {', '.join(ROBUST_AGGREGATES)}")
    constraints = kwargs.get("constraints")
    if constraints is not None:
        feas = feasible_set(target.library, check_budget(budget_usd), constraints)  # refuses a bad request up front
        if recorded(feas) is None:
            kwargs.pop("constraints")  # the budget alone
    if aggregate == "worst":
        if target.kind != Domain.kind:  # the kind tells the type apart (a Literal): no isinstance
            raise InputError(
                "aggregate 'worst' is the worst route of an operating domain: give a domain (--domain FILE)"
            )
        for k in ("executor", "outdir", "resume"):
            kwargs.pop(k, None)
        return worst_route_select(target, budget_usd, alpha, evaluator=evaluator, **kwargs)
    if evaluator is not None:  # one run on it, every method sharing one memo
        check_budget(budget_usd)
        for k in ("engine", "jobs"):  # the evaluator's own
            kwargs.pop(k, None)
        return robust_select(evaluator, budget_usd, alpha, info=target.info, **kwargs)
    return _run_robust(target, budget_usd, alpha, aggregate=aggregate, **kwargs)


def resilient_report(
    problem: Target, budget_usd: float, alpha: int, *, method: str = ALGORITHM_2, **kwargs
) -> ResilientReport:
    """The ``sensorsel resilient`` run (:func:`sensorsel.designs.resilient.resilient_report`): the whole-route
    comparison and the per-period selection. ``method``: "algorithm-2" (the paper's Algorithm 2, the
    default: the one the published results use) or "robust"
    (:func:`sensorsel.designs.robust.robust_select` for the whole route and each period; its worst case is
    never below greedy's nor Algorithm 2's)."""
    if method not in RESILIENT_METHODS:
        raise InputError(f"unknown method {method!r}; available: {', '.join(RESILIENT_METHODS)}")
    return _resilient_report(
        problem, budget_usd, alpha, method=method, selector=robust_choice if method == "robust" else None, **kwargs
    )


def simulate(problem: Problem, suite: str | Iterable[int], **kwargs: Any) -> SimulationResult:
    """The ``sensorsel simulate`` run: Monte-Carlo SLAM of ``suite`` on ``problem``
    (:func:`sensorsel.simulation.run.simulate`, whose keyword arguments it takes: ``failures``,
    ``runs``, ``solver``, ``seed``, ``noise_scale``, ``jobs``, ``label``, ``progress``, ``executor``,
    ``map_sigma_m``). The simulation's run module is imported here, when first called: it imports
    gtsam (~0.1-0.15 s), which scoring and selecting do not need."""
    from sensorsel.simulation.run import simulate as run

    return run(problem, suite, **kwargs)
