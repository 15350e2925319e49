"""``sensorsel require``: the cheapest suite that meets a specification in metres, with a proof.

On a route or every route of a domain, a suite *meets* the requirement when each route's accuracy
(:mod:`sensorsel.information.evaluators.accuracy`, in the chosen localization model) meets that route's
:class:`~sensorsel.designs.requirements.spec.Specification`, also after any ``failures`` of its sensors
fail. Meeting is monotone in the suite, so the search of :mod:`.solver` applies: a greedy upper
bound, then an implicit hitting set whose integer programs give a lower bound on the cost of *any*
suite that meets the requirement: the answer is proved optimal or states its gap.

With ``integrity`` the requirement is accuracy AND integrity on every route
(:mod:`.integrity`): not monotone, so the solver is called with ``monotone=False``, the accuracy
check and the error-tail relaxation as the monotone necessary condition and the association floor
as the anti-monotone one; the lower bound stays valid (every cut excludes only failing suites).
"""

from __future__ import annotations

import copy
import functools
import itertools
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

from sensorsel.designs.inputs import result_fingerprint, route_entry
from sensorsel.designs.requirements.domain_checks import DomainChecks, Here
from sensorsel.designs.requirements.dominance import information_dominance
from sensorsel.designs.requirements.integrity import IntegrityRequirement
from sensorsel.designs.requirements.margin import Margin, margin_of
from sensorsel.designs.requirements.programs import Solved
from sensorsel.designs.requirements.solver import DEFAULT_TIE_PROGRAMS, cheapest_suite
from sensorsel.designs.requirements.spec import RouteRequirement, Specification
from sensorsel.errors import InputError
from sensorsel.information.evaluators import Evaluator, as_suite, evaluator_for
from sensorsel.information.evaluators.accuracy import estimate_label, model_label
from sensorsel.information.evaluators.base import ProblemEvaluator, Suite
from sensorsel.information.filtering import check_estimate
from sensorsel.information.integrity import IntegritySpec, RouteIntegrity
from sensorsel.io import results
from sensorsel.io.codec import to_jsonable
from sensorsel.io.progress import Progress
from sensorsel.io.results import result_kind
from sensorsel.model.constraints import Constraints, feasible_set
from sensorsel.model.problem import Domain, Problem, Target, TargetInfo
from sensorsel.pipeline.store import digest, load_matching

if TYPE_CHECKING:
    from sensorsel.information.evaluators.processes import CovariancesAhead

__all__ = ["RouteRequirement", "RequireResult", "RequireJournal", "journal_due", "require", "require_fingerprint"]

#: seconds between two writes of a require run's journal at the least (and once at the end)
JOURNAL_EVERY_S = 2.0
#: and at least this many times the last write's own time: the whole journal is written each time,
#: so a long run's writes would otherwise grow to most of its time (measured: 77 % of the client's
#: time on the seven KITTI routes with one failure once the journal held 22,000 answers, 3.5 MB)
JOURNAL_WAIT_PER_WRITE = 9.0


def journal_due(now: float, last_end: float, last_took: float) -> bool:
    """Whether a journal write is due at ``now`` [s], the last one having ended at ``last_end`` and
    taken ``last_took`` [s]: writes take at most a tenth of the run (:data:`JOURNAL_WAIT_PER_WRITE`),
    and come no closer than :data:`JOURNAL_EVERY_S`."""
    return now - last_end >= max(JOURNAL_EVERY_S, JOURNAL_WAIT_PER_WRITE * last_took)


@result_kind("requirement")
@dataclass(frozen=True)
class RequireResult:
    """The cheapest suite meeting a specification, and the proof of how cheap any can be.

    Attributes:
        status: "optimal" (cost = lower bound), "gap" (a suite that meets the requirement, with the
            lower bound below its cost: the search stopped at its limits) or "infeasible" (no suite
            within the limits meets it).
        suite: ids of the suite (library order); empty when infeasible.
        cost_usd: its price [$] (owned sensors count 0).
        lower_bound_usd: no suite that meets the requirement costs less [$].
        failures: α: the suite meets it after any α of its sensors fail.
        model: "map" or "slam" (:data:`sensorsel.information.evaluators.accuracy.MODELS`).
        map_sigma_m: with the map model, the std of the landmarks [m].
        estimate: the accuracy judged: "filter" (at each keyframe from the measurements up to it:
            as the car drives) or "smoother" (from the whole route); files written before
            estimates existed judged the smoother's, and load so.
        routes: each route's specification and the suite's accuracy there, all sensors working
            (infeasible: the accuracy of every allowed sensor together, the best any suite reaches;
            stopped before any suite was found: the empty suite's).
        worst_failure: with failures, the α sensors whose failure leaves the suite closest to
            missing the requirement (ids), and ``worst_failure_routes`` the accuracy after it.
        iterations: integer programs solved.
        plateau_swaps: proposals found by a swap on a plateau of one price instead of an integer
            program (:func:`~sensorsel.designs.requirements.programs.plateau_swap`).
        n_checks: accuracy computations (each about two dense Cholesky factorizations a route).
        n_refuted: (route, suite) pairs refuted without computing their marginals: by the engine's
            cheap floor under them, or (filter) by the smoother's, by a failing suite inside it
            that was over its limits before the added sensors measure anything, or by the filter's
            floors from a window of the route at that failing suite's bad keyframes.
        engine: the evaluator engine.
        budget_usd: a budget the suite had to keep to, or None.
        constraints: limits besides money, or None.
        problem: what it was computed on.
        seconds: wall time [s].
        infeasible_by: when infeasible, why: "library" (every allowed sensor together misses it),
            "failures" (they meet it, but not after the worst failures) or "limits" (no suite within
            the budget and limits does).
        stop: why the search ended, in words.
        seconds_checks: of ``seconds``, in the accuracy checks [s].
        seconds_programs: of ``seconds``, in the integer programs [s].
        ties: other suites of the same cost that also meet the requirement (ids), found on the way or
            by the tie search after the proof.
        ties_exhaustive: the tie search ran out of suites of that cost: ``ties`` are all there are.
        tie_programs: integer programs of the tie search.
        margin: the suite's smallest slack against the stated limits, where, and the binding
            keyframes (None when no suite was found).
        synthetic_landmarks: the routes whose landmarks were invented (generated), not read from a map.
        integrity: the integrity also demanded on every route, or None (accuracy alone).
        integrity_routes: with ``integrity``, the suite's integrity on each route (infeasible: that of
            the best effort, as ``routes``).
        integrity_alone: with ``integrity``, the allowed sensors (ids) that break it alone (their
            association risk floor exceeds it: in no suite that meets it), left out of the search.
        dominated: pairs (w, s) of ids where s makes every measurement w makes on every route, at
            least as precisely, costs no more and uses no more of any limit: the search held "w
            only with s" (:mod:`sensorsel.designs.requirements.dominance`; the cheapest cost is
            unchanged; where the two cost the same, a suite with w in place of s may be a tie the
            tie search does not look for).
        n_swap_inferred: answers the search inferred from such dominance (of any price) instead of
            an accuracy computation.
        n_short: of ``n_checks``, filter passes stopped after the last keyframe where a suite inside
            the one asked was seen to miss the specification (:mod:`.truncated`).
        n_accepted: (route, suite) answers proved met by an upper bound, without the suite's own
            pass: restarted from a failing suite inside it (:mod:`.accept`), or the filter's ceilings
            from a window of the route (:mod:`~sensorsel.information.window_bounds`) at that failing
            suite's bad keyframes (not in ``n_checks``; the failing suites' passes are).
        n_base_passes: of ``n_checks``, those passes of failing suites the bounds restart from or the
            windows are asked at the bad keyframes of (computations that answer no suite asked: the
            suites the search asked are ``n_checks − n_base_passes + n_refuted + n_accepted``).
        n_resumed: answers read back from an interrupted run's journal (``resume``): not computed
            again, so the counts and times above are this run's alone (0: the run started afresh).
        n_programs_resumed: integer programs (of ``iterations``, ``tie_programs`` and the failures'
            floors) whose answers were read back from that journal instead of solved again.
    """

    status: str
    suite: tuple[str, ...]
    cost_usd: float
    lower_bound_usd: float
    failures: int
    model: str
    map_sigma_m: float | None
    routes: tuple[RouteRequirement, ...]
    worst_failure: tuple[str, ...]
    worst_failure_routes: tuple[RouteRequirement, ...]
    iterations: int
    n_checks: int
    engine: str
    budget_usd: float | None
    constraints: Constraints | None
    problem: TargetInfo | None = None
    seconds: float = 0.0
    infeasible_by: str = ""
    stop: str = ""
    n_refuted: int = 0
    seconds_checks: float = 0.0
    seconds_programs: float = 0.0
    ties: tuple[tuple[str, ...], ...] = ()
    ties_exhaustive: bool = False
    tie_programs: int = 0
    margin: Margin | None = None
    synthetic_landmarks: tuple[str, ...] = ()
    estimate: str = "smoother"
    integrity: IntegritySpec | None = None
    integrity_routes: tuple[RouteIntegrity, ...] = ()
    integrity_alone: tuple[str, ...] = ()
    dominated: tuple[tuple[str, str], ...] = ()
    n_swap_inferred: int = 0
    n_short: int = 0
    n_accepted: int = 0
    n_base_passes: int = 0
    n_resumed: int = 0
    plateau_swaps: int = 0
    n_programs_resumed: int = 0

    @property
    def gap_usd(self) -> float:
        """cost − lower bound [$] (0 when proved optimal; nan when no suite was found)."""
        return self.cost_usd - self.lower_bound_usd if self.suite else math.nan

    @property
    def model_label(self) -> str:
        return f"{model_label(self.model, self.map_sigma_m)}, {estimate_label(self.estimate)}"


@result_kind("requirement-journal")
@dataclass(frozen=True)
class RequireJournal:
    """What an interrupted ``require`` had learnt: each (route, suite) asked and its answer, with the
    fingerprint of everything the answers depend on (the routes' problems, the specifications, the
    localization model, the failures, the budget and the limits). A resumed run reads the answers
    back and replays the same deterministic search without computing them again.

    Attributes:
        fingerprint: sha256 of the inputs (:func:`require_fingerprint`).
        inputs: the same inputs, in words (what the warning names when they differ).
        answers: (route index, suite, meets, violation or None when only refuted: by the floor, or
            by a filter pass stopped early).
        bad_keyframes: (route index, suite, per component of the route's specification the
            keyframes where the suite is over its limit) of the failing suites whose filter passes
            said where, each route's in the order they were found. The checks of a suite holding
            one are asked at those keyframes alone (the windows' bounds, a pass stopped early);
            from the answers alone a resumed run computed those passes again (KITTI 00 at local
            streets stopped at 25 s of a 50 s search: resumed in 38.5 s and 17 accuracy
            computations from the answers alone, 23.6 s and 11 with them;
            ``bench/require_resume.py``). Journals written before they were kept have none (nor
            programs): they resume all the same.
        programs: the integer programs solved, each with its answer (:data:`.programs.Solved`, by a
            key of all its rows), in the order they were solved: the resumed search poses them again
            and reads their answers here instead of solving them (with one failure on the seven KITTI
            routes, 325 programs took 996 s of a 1,597 s search).
    """

    fingerprint: str
    inputs: tuple[tuple[str, str], ...]
    answers: tuple[tuple[int, tuple[int, ...], bool, float | None], ...]
    bad_keyframes: tuple[tuple[int, tuple[int, ...], tuple[tuple[int, ...], ...]], ...] = ()
    programs: tuple[tuple[str, int, tuple[int, ...] | None, float | None, float | None, int], ...] = ()


#: the greedy completions of a plateau's proposals cap each candidate by the violation's floor
#: (``cheapest_suite``'s ``violation_floor``: the floor under the smoother's marginals, ~1/20 of
#: them) where the routes hold this many keyframes in all and no sensor may fail. A candidate's
#: violation costs the smoother's marginals, linear in the keyframes, while a failing one teaches the
#: search a cut whatever the route's length: on long routes the floors spare most of the
#: completions' time (side by side with the version before: KITTI 00 at local streets, 455
#: keyframes, 60.0 s and 39 accuracy computations against 98.4 s and 49; a user's drive 103.4 s
#: against 127.8 s; the seven KITTI routes 154.1 s against 185.6 s; the same suites), on short ones
#: the violations spared were cheap and taught more (the README tour, 53 keyframes: 71 integer
#: programs and 89 computations against 37 and 72). Asked in the first greedy too, they cost the
#: seven routes 409 computations against 246. Not with failures: on KITTI 00 at local streets with
#: one failure the capped completions led to 226 integer programs and 1,839 accuracy computations
#: against 164 and 1,273
#: (The same gate turns on the completions' stop, :data:`.solver.COMPLETION_GAP_SHARE`: it applies to
#: completions capped by a floor.)
GREEDY_FLOOR_KEYFRAMES = 200
#: bumped when what the journal's answers depend on, or how they are computed, changes (3: the
#: filter's state held in the order its landmarks came: its covariances equal format 2's to rounding only)
JOURNAL_FORMAT = 3


def require_fingerprint(
    problems: Sequence[Problem],
    specs: Sequence[Specification],
    map_sigma_m: float | None,
    failures: int,
    budget_usd: float | None,
    constraints: Constraints | None,
    estimate: str = "filter",
    engine: str = "",
    integrity: IntegritySpec | None = None,
) -> tuple[str, tuple[tuple[str, str], ...]]:
    """(sha256, the inputs in words) of what a require run's answers depend on (``estimate``: filter or
    smoother; ``engine``: the engine that computes them: another one's answers agree only to rounding;
    ``integrity``: the integrity also demanded, or None: then it adds nothing to the
    fingerprint)."""
    inputs = (
        ("routes", ", ".join(f"{p.scenario.name} {digest(to_jsonable(p.fingerprint))[:12]}" for p in problems)),
        ("specification", "; ".join(s.describe() for s in specs)),
        ("model", model_label("slam" if map_sigma_m is None else "map", map_sigma_m)),
        ("estimate", estimate_label(estimate)),
        ("failures", str(failures)),
        ("budget", "none" if budget_usd is None else f"${budget_usd:,.2f}"),
        ("limits", "none" if constraints is None else constraints.describe()),
        ("engine", engine or "?"),
    ) + ((("integrity", _integrity_words(integrity)),) if integrity is not None else ())
    extra = {"integrity": integrity} if integrity is not None else {}
    routes = [route_entry(p.scenario.name, 1.0, "", p.fingerprint) for p in problems]
    fp = result_fingerprint(
        "require-journal",
        JOURNAL_FORMAT,
        routes,
        specifications=list(specs),
        model="slam" if map_sigma_m is None else "map",
        map_sigma_m=map_sigma_m,
        failures=failures,
        # a budget of 50000 and of 50000.0 is one budget (the command line's is a float, a caller's
        # may be an int): hashed as a float, or a resume would be refused its own journal
        budget_usd=None if budget_usd is None else float(budget_usd),
        constraints=constraints,
        estimate=estimate,
        engine=engine,
        **extra,
    )
    return fp, inputs


def _integrity_words(spec: IntegritySpec) -> str:
    return (
        f"{spec.integrity_risk:g}/h beyond {spec.alert_lateral_m:g} m lateral, {spec.alert_longitudinal_m:g} m "
        f"longitudinal, {spec.alert_heading_deg:g} deg (gate {spec.gate_probability:g})"
    )


def _read_journal(path: Path, fingerprint: str, inputs: tuple[tuple[str, str], ...]) -> RequireJournal | None:
    """The journal at ``path`` when this very run wrote it; None when there is none, or (as every store:
    :func:`sensorsel.pipeline.store.load_matching`, warned, naming what differs) when it cannot be read
    or holds the answers of other inputs: the run starts afresh and overwrites it."""

    def differences(j: RequireJournal) -> list[str]:
        was = dict(j.inputs)
        return [f"{k} {was.get(k, '?')} (this run: {v})" for k, v in inputs if was.get(k) != v]

    return load_matching(RequireJournal, path, fingerprint, differences, "another require run")


def require(
    target: Target,
    specifications: Specification | Sequence[Specification],
    *,
    map_sigma_m: float | None,
    failures: int = 0,
    budget_usd: float | None = None,
    constraints: Constraints | None = None,
    engine: str | None = None,
    jobs: int = 1,
    time_limit_s: float | None = None,
    progress: Progress | None = None,
    checkpoint: str | Path | None = None,
    resume: bool = False,
    conditions: Sequence[str] | None = None,
    evaluator: Evaluator | None = None,
    max_tie_programs: int = DEFAULT_TIE_PROGRAMS,
    estimate: str = "filter",
    integrity: IntegritySpec | None = None,
) -> RequireResult:
    """The cheapest suite meeting ``specifications`` on ``target`` (a route, or every route of a
    domain: one specification for all, or one per route in the domain's order).

    Args:
        map_sigma_m: localize in a prior map whose landmarks are known to this std [m]; None: the
            paper's SLAM graph.
        estimate: the accuracy demanded is the filter's ("filter", the default: at each keyframe
            from the measurements up to it, what the car has as it drives) or the smoother's
            ("smoother": from the whole route, optimistic before the last keyframe).
        failures: α ≥ 0: still met after any α sensors of the suite fail.
        budget_usd: an upper limit on the price, or None.
        constraints: limits besides money (resources, slots, required / owned / excluded, most sensors).
        time_limit_s: stop the exact search after this long, with the gap (None: run to the proof).
        evaluator: a domain's evaluator already built, whose ``routes`` answer the accuracy checks
            (e.g. on a Dask cluster: :class:`sensorsel.information.evaluators.distributed.DistributedDomainEvaluator`);
            None: one engine per route here.
        conditions: with a domain of (route, condition) members, demand the specification only in
            these conditions (names as the domain file gives them, e.g. ("clear", "rain")); None: in all.
        max_tie_programs: integer programs spent after the proof looking for other suites of the
            same cost (0: only those met on the way are reported).
        checkpoint: a file where the answers are journalled as they come (:func:`journal_due`,
            and at the end: a :class:`RequireJournal`); with ``resume`` an
            interrupted run's journal there is read back (when its inputs differ: warned, and the run starts afresh).
        integrity: also demand this integrity on every route (module docstring), or None. Its lever
            (``max_association_risk``) is refused: the accuracy judged uses every measurement.

    Raises:
        InputError: bad failures, a specification count that does not match the routes, limits
            the library cannot meet.
    """
    t0 = time.perf_counter()
    n_resumed = 0
    solved: dict[str, Solved] = {}  # the integer programs' answers: journalled, and read back by a resumed run
    check_estimate(estimate)
    if isinstance(failures, bool) or not isinstance(failures, int) or failures < 0:
        raise InputError(f"--failures must be a whole number >= 0, got {failures!r}")
    if budget_usd is not None and not (math.isfinite(budget_usd) and budget_usd > 0):
        raise InputError(f"--budget must be a positive number of dollars, got {budget_usd!r}")
    members = list(target.routes)
    problems: list[tuple[str, Problem]] = [(r.name, r.problem) for r in members]
    specs = [specifications] * len(problems) if isinstance(specifications, Specification) else list(specifications)
    if len(specs) != len(problems):
        raise InputError(f"{len(specs)} specifications for {len(problems)} routes")
    if conditions is not None:
        known = sorted({r.condition for r in members if r.condition})
        if not known:
            raise InputError("--in names conditions: give a domain file with conditions: (see the conditions guide)")
        unknown = sorted(set(conditions) - set(known))
        if unknown:
            raise InputError(f"--in: unknown condition(s) {', '.join(unknown)}; the domain has: {', '.join(known)}")
        keep = [i for i, r in enumerate(members) if r.condition in set(conditions)]
        problems, specs = [problems[i] for i in keep], [specs[i] for i in keep]
    library = target.library
    feas = feasible_set(library, math.inf if budget_usd is None else budget_usd, constraints)
    # the routes' engines, and each route's checks beside its engine (:mod:`.domain_checks`): here,
    # on worker processes (``jobs`` on a domain large enough) or on a cluster's workers (``evaluator``,
    # which holds every member: those kept by ``conditions`` are found by their place in it)
    own: Evaluator | None = None
    host: Any = evaluator
    where = keep if conditions is not None else None
    if evaluator is None:
        # only the members asked about get an engine
        kept = (
            target
            if conditions is None
            else Domain(tuple(members[i] for i in keep), source=str(getattr(target, "source", "<memory>")))
        )
        own, where = evaluator_for(kept, engine, jobs=jobs), None
        host = own if kept.kind == "domain" else Here([cast(ProblemEvaluator, own)])
    engine_name = str(getattr(host, "engine", None) or host.routes[0].name)
    ahead = _covariances_ahead(host, problems, jobs, engine_name, map_sigma_m, estimate, integrity)
    oracle = DomainChecks(host, [n for n, _ in problems], specs, map_sigma_m, estimate, where=where, ahead=ahead)
    try:
        integ: IntegrityRequirement | None = None
        alone: frozenset[int] = frozenset()
        if integrity is not None:
            if integrity.max_association_risk is not None:
                raise InputError(
                    "--max-association-risk: require judges accuracy with every measurement; "
                    "the lever is not available with require --integrity"
                )
            integ = IntegrityRequirement(
                [p for _, p in problems],
                [n for n, _ in problems],
                [i for i in range(len(library)) if i not in feas.excluded],
                integrity,
                map_sigma_m,
            )
        if checkpoint is not None:
            path = Path(checkpoint)
            fp, inputs = require_fingerprint(
                [p for _, p in problems],
                specs,
                map_sigma_m,
                failures,
                budget_usd,
                feas.record,
                estimate,
                engine_name,
                integrity,
            )
            old = _read_journal(path, fp, inputs) if resume else None
            if old is not None:
                n_resumed = len(old.answers)
                oracle.resume({(r, tuple(s_)): (m, v) for r, s_, m, v in old.answers}, old.bad_keyframes)
                solved.update((p[0], p) for p in old.programs)
            last = [time.monotonic(), 0.0]  # when the last write ended, and what it took [s]

            def write(force: bool = False) -> None:
                t = time.monotonic()
                if force or journal_due(t, *last):
                    results.save(
                        RequireJournal(fp, inputs, oracle.answers(), oracle.bad_keyframes(), tuple(solved.values())),
                        path,
                        compact=True,
                    )
                    done = time.monotonic()
                    last[:] = [done, done - t]

            oracle.on_answer = write
        # the search's settings, whichever predicates it is given
        search = functools.partial(
            cheapest_suite,
            failures=failures,
            time_limit=time_limit_s,
            progress=progress,
            max_tie_programs=max_tie_programs,
            programs_solved=solved,
        )
        try:
            if integ is None:
                # accuracy alone is monotone in each sensor's information: dominance among sensors holds
                dominance = information_dominance(
                    [p for _, p in problems], [i for i in range(len(library)) if i not in feas.excluded]
                )
                capped = failures == 0 and sum(p.scenario.n_poses for _, p in problems) >= GREEDY_FLOOR_KEYFRAMES
                found = search(
                    feas,
                    oracle.meets,
                    violation=oracle.violation,
                    violation_floor=oracle.violation_floor if capped else None,
                    dominance=dominance,
                    refute=oracle.refuted_cheaply,
                    look_ahead=oracle.look_ahead if ahead is not None else None,
                )
            else:
                checks = integ
                # monotone: accuracy, and the error tail with every measurement used; then integrity itself
                down, whole = checks.with_accuracy(oracle.meets)
                # a sensor whose association floor alone exceeds the requirement is in no suite that meets it
                # (the floor is anti-monotone): fixed out first, so that no failing set is grown over it
                alone = frozenset(
                    i
                    for i in range(len(library))
                    if i not in feas.excluded and i not in feas.required and not checks.floor_met((i,))
                )
                searched = copy.copy(feas)
                searched.excluded = feas.excluded | alone
                found = search(
                    searched, whole, monotone=False, necessary_monotone=down, necessary_antimonotone=checks.floor_met
                )
        finally:  # interrupted too (Ctrl-C): nothing learnt is lost
            if checkpoint is not None:
                oracle.on_answer = None
                write(force=True)
        worst: tuple[int, ...] = ()
        worst_routes: tuple[RouteRequirement, ...] = ()
        if found.suite is None:
            # infeasible: the accuracy of the best any suite reaches (every allowed sensor, or what is
            # left of them after the failures the solver names). Stopped before finding a suite: the
            # empty suite's (the one reported), not a pass of every sensor that nothing prints (on a
            # user's drive, 78 s after a 30 s --time-limit)
            best: Suite = ()
            if found.status == "infeasible":
                best = found.best_effort or tuple(
                    i for i in range(len(library)) if i not in feas.excluded and i not in alone
                )
            routes = oracle.report(best)
            integrity_routes = integ.report(as_suite(best)) if integ is not None else ()
            suite: Suite = ()
        else:
            suite = as_suite(found.suite)
            routes = oracle.report(suite)
            integrity_routes = integ.report(suite) if integ is not None else ()
            worst = _worst_failure(oracle, suite, failures)
            worst_routes = oracle.report(tuple(i for i in suite if i not in worst)) if worst else ()
        margin = (
            margin_of([(r.route, r.specification, r.accuracy) for r in routes]) if found.suite is not None else None
        )
        synthetic = tuple(name for name, p in problems if p.scenario.landmark_source.startswith("generated"))
        result = RequireResult(
            status=found.status,
            suite=library.suite_ids(suite),
            cost_usd=float(feas.A[0, list(suite)].sum()) if suite else 0.0,
            lower_bound_usd=float(found.lower_bound),
            infeasible_by=found.infeasible_by,
            stop=found.stop,
            failures=failures,
            model="slam" if map_sigma_m is None else "map",
            map_sigma_m=map_sigma_m,
            estimate=estimate,
            routes=routes,
            worst_failure=library.suite_ids(worst),
            worst_failure_routes=worst_routes,
            iterations=int(found.iterations),
            plateau_swaps=int(found.plateau_swaps),
            n_checks=oracle.count("n_checks"),
            n_refuted=oracle.count("n_refuted"),
            engine=engine_name,
            budget_usd=budget_usd,
            constraints=feas.record,
            problem=target.info,
            seconds=time.perf_counter() - t0,
            seconds_checks=found.seconds_checks,
            seconds_programs=found.seconds_programs,
            ties=tuple(library.suite_ids(t) for t in found.ties),
            ties_exhaustive=found.ties_exhaustive,
            tie_programs=found.tie_programs,
            margin=margin,
            synthetic_landmarks=synthetic,
            integrity=integrity,
            integrity_routes=integrity_routes,
            integrity_alone=library.suite_ids(tuple(sorted(alone))),
            dominated=tuple((library.ids[w], library.ids[s_]) for w, s_ in found.ordered),
            n_swap_inferred=found.swap_inferred,
            n_short=oracle.count("n_short"),
            n_accepted=oracle.count("n_accepted"),
            n_base_passes=oracle.count("n_base_passes"),
            n_resumed=n_resumed,
            n_programs_resumed=found.programs_resumed,
        )
    except Exception:
        oracle.close()  # an error's rounds were answered: the routes' checks can be dropped where they live
        raise
    else:
        oracle.close()
    finally:
        # interrupted (Ctrl-C), a round's reply may still be on its way: the evaluator this run built
        # is closed with its workers; a caller's keeps the checks under this run's key until it closes
        close = getattr(own, "close", None)
        if close is not None:
            close()
        if ahead is not None:
            ahead.close()
    return result


def _covariances_ahead(
    host: Any,
    problems: Sequence[tuple[str, Problem]],
    jobs: int,
    engine: str,
    map_sigma_m: float | None,
    estimate: str,
    integrity: IntegritySpec | None,
) -> CovariancesAhead | None:
    """Worker processes computing the smoother's covariances the greedy likely asks next
    (:class:`~sensorsel.information.evaluators.processes.CovariancesAhead`: ``jobs`` − 1 of them),
    for one route of this process with :data:`~sensorsel.information.evaluators.processes.AHEAD_FROM_KEYFRAMES`
    keyframes or more, judged by the filter (the smoother's marginals are its floor) on accuracy alone
    (integrity's search has no greedy); None elsewhere. A choice of speed alone: the same bytes."""
    if jobs < 2 or not isinstance(host, Here) or len(problems) != 1 or estimate != "filter" or integrity is not None:
        return None
    # imported here: a run that starts no process imports no multiprocessing machinery
    from sensorsel.information.evaluators.processes import AHEAD_FROM_KEYFRAMES, CovariancesAhead

    name, problem = problems[0]
    if problem.scenario.n_poses < AHEAD_FROM_KEYFRAMES:
        return None
    from sensorsel.model.recipes import RouteRecipe

    return CovariancesAhead(RouteRecipe.of(name, problem), engine, jobs - 1, map_sigma_m=map_sigma_m)


def _worst_failure(oracle: DomainChecks, suite: Suite, failures: int) -> tuple[int, ...]:
    """The ``failures`` sensors of ``suite`` whose loss leaves the largest error relative to the
    bounds (ties: the first in library order); () without failures."""
    if failures <= 0 or len(suite) <= failures:
        return ()
    best: tuple[float, tuple[int, ...]] | None = None
    for lost in itertools.combinations(suite, failures):
        rest = tuple(i for i in suite if i not in lost)
        margin = max(max(err / bound for _, err, bound, _ in route.verdict.worst) for route in oracle.report(rest))
        if best is None or margin > best[0]:
            best = (margin, lost)
    return best[1] if best else ()
