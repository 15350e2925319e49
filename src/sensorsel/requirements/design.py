"""``sensorsel require``: the cheapest suite that meets a specification in metres, with a proof.

On a route or every route of a domain, a suite *meets* the requirement when each route's accuracy
(:mod:`sensorsel.evaluators.accuracy`, in the chosen localization model) meets that route's
:class:`~sensorsel.requirements.spec.Specification`, also after any ``failures`` of its sensors
fail. Meeting is monotone in the suite, so the search of :mod:`.solver` applies: a greedy upper
bound, then an implicit hitting set whose integer programs give a lower bound on the cost of *any*
suite that meets the requirement: the answer is proved optimal or states its gap.
"""

from __future__ import annotations

import itertools
import math
import time
from dataclasses import dataclass
from typing import Callable, Sequence

from ..constraints import Constraints, feasible_set
from ..errors import InputError
from ..evaluators import as_suite, make_evaluator
from ..evaluators.accuracy import RouteAccuracy, accuracy_from_covariances, model_label, route_accuracy
from ..evaluators.base import ProblemEvaluator, Suite
from ..problem import Domain, Problem, Target, TargetInfo
from .solver import cheapest_suite
from .spec import RouteVerdict, Specification, verdict

__all__ = ["RouteRequirement", "RequireResult", "require"]

Progress = Callable[[int, int], None]


@dataclass(frozen=True)
class RouteRequirement:
    """One route's specification and how a suite stands against it.

    Attributes:
        route: the route's name.
        specification: what the route requires.
        accuracy: the suite's accuracy there (per keyframe, 1σ).
        verdict: whether it meets the specification, by how much it misses, where.
    """

    route: str
    specification: Specification
    accuracy: RouteAccuracy
    verdict: RouteVerdict


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
        model: "map" or "slam" (:data:`sensorsel.evaluators.accuracy.MODELS`).
        map_sigma_m: with the map model, the std of the landmarks [m].
        routes: each route's specification and the suite's accuracy there, all sensors working
            (infeasible: the accuracy of every allowed sensor together, the best any suite reaches).
        worst_failure: with failures, the α sensors whose failure leaves the suite closest to
            missing the requirement (ids), and ``worst_failure_routes`` the accuracy after it.
        iterations: integer programs solved.
        n_checks: accuracy computations (each about two dense Cholesky factorizations a route).
        n_refuted: (route, suite) pairs refuted by the engine's cheap floor under the marginals,
            without computing them.
        engine: the evaluator engine.
        budget_usd: a budget the suite had to keep to, or None.
        constraints: limits besides money, or None.
        problem: what it was computed on.
        seconds: wall time [s].
        infeasible_by: when infeasible, why: "library" (every allowed sensor together misses it),
            "failures" (they meet it, but not after the worst failures) or "limits" (no suite within
            the budget and limits does).
        stop: why the search ended, in words.
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

    @property
    def gap_usd(self) -> float:
        """cost − lower bound [$] (0 when proved optimal; nan when no suite was found)."""
        return self.cost_usd - self.lower_bound_usd if self.suite else math.nan

    @property
    def model_label(self) -> str:
        return model_label(self.model, self.map_sigma_m)


class _Oracle:
    """Whether a suite meets the requirement on every route, with the answers kept (each costs an
    accuracy computation per route asked); routes are asked in order and the first failing one
    ends the question (the caching keeps the answer the same whichever path asked first).

    Before computing a route's marginals, :meth:`meets` asks the engine's cheap floor under them
    (:meth:`~sensorsel.evaluators.base.ProblemEvaluator.pose_covariance_floor`): every σ of the floor
    is below the true one, so a specification the floor already misses is missed (monotone in each
    keyframe's errors, whatever the share of keyframes): the suite fails without its marginals. In
    the map model the floor is ~50-90 % of the true σ (KITTI 00, 03) and refutes most failing suites.
    """

    def __init__(self, evaluators: Sequence[ProblemEvaluator], names: Sequence[str], specs: Sequence[Specification],
                 map_sigma_m: float | None) -> None:
        self.evaluators, self.names, self.specs, self.map_sigma_m = list(evaluators), list(names), list(specs), map_sigma_m
        self._verdicts: dict[tuple[int, Suite], tuple[RouteAccuracy, RouteVerdict]] = {}
        self._refuted: set[tuple[int, Suite]] = set()
        self.n_checks = 0  # marginals computed (route, suite)
        self.n_refuted = 0  # (route, suite) refuted by the floor alone

    def route(self, r: int, suite: Suite) -> tuple[RouteAccuracy, RouteVerdict]:
        key = (r, suite)
        got = self._verdicts.get(key)
        if got is None:
            acc = route_accuracy(self.evaluators[r], suite, map_sigma_m=self.map_sigma_m, route=self.names[r])
            got = self._verdicts[key] = (acc, verdict(acc, self.specs[r]))
            self.n_checks += 1
        return got

    def _route_meets(self, r: int, suite: Suite) -> bool:
        key = (r, suite)
        if key in self._verdicts:
            return self._verdicts[key][1].meets
        if key in self._refuted:
            return False
        floor = self.evaluators[r].pose_covariance_floor(suite, map_sigma_m=self.map_sigma_m)
        if floor is not None and not verdict(accuracy_from_covariances(floor, map_sigma_m=self.map_sigma_m),
                                             self.specs[r]).meets:
            self._refuted.add(key)
            self.n_refuted += 1
            return False
        return self.route(r, suite)[1].meets

    def meets(self, suite: Suite) -> bool:
        s = as_suite(suite)
        return all(self._route_meets(r, s) for r in range(len(self.evaluators)))

    def violation(self, suite: Suite) -> float:
        s = as_suite(suite)
        return max(self.route(r, s)[1].violation for r in range(len(self.evaluators)))

    def report(self, suite: Suite) -> tuple[RouteRequirement, ...]:
        s = as_suite(suite)
        return tuple(RouteRequirement(self.names[r], self.specs[r], *self.route(r, s)) for r in range(len(self.evaluators)))


def require(target: Target, specifications: Specification | Sequence[Specification], *, map_sigma_m: float | None,
            failures: int = 0, budget_usd: float | None = None, constraints: Constraints | None = None,
            engine: str | None = None, jobs: int = 1, time_limit_s: float | None = None,
            progress: Progress | None = None) -> RequireResult:
    """The cheapest suite meeting ``specifications`` on ``target`` (a route, or every route of a
    domain: one specification for all, or one per route in the domain's order).

    Args:
        map_sigma_m: localize in a prior map whose landmarks are known to this std [m]; None: the
            paper's SLAM graph.
        failures: α ≥ 0: still met after any α sensors of the suite fail.
        budget_usd: an upper limit on the price, or None.
        constraints: limits besides money (resources, slots, required / owned / excluded, most sensors).
        time_limit_s: stop the exact search after this long, with the gap (None: run to the proof).

    Raises:
        InputError: bad failures, a specification count that does not match the routes, limits
            the library cannot meet.
    """
    t0 = time.perf_counter()
    if isinstance(failures, bool) or not isinstance(failures, int) or failures < 0:
        raise InputError(f"--failures must be a whole number >= 0, got {failures!r}")
    if budget_usd is not None and not (math.isfinite(budget_usd) and budget_usd > 0):
        raise InputError(f"--budget must be a positive number of dollars, got {budget_usd!r}")
    problems: list[tuple[str, Problem]] = ([(r.name, r.problem) for r in target.routes] if isinstance(target, Domain)
                                          else [(target.scenario.name, target)])
    specs = [specifications] * len(problems) if isinstance(specifications, Specification) else list(specifications)
    if len(specs) != len(problems):
        raise InputError(f"{len(specs)} specifications for {len(problems)} routes")
    library = target.library
    feas = feasible_set(library, math.inf if budget_usd is None else budget_usd, constraints)
    evaluators = [make_evaluator(p, engine, jobs=jobs) for _, p in problems]
    oracle = _Oracle(evaluators, [n for n, _ in problems], specs, map_sigma_m)
    found = cheapest_suite(feas, oracle.meets, failures=failures, violation=oracle.violation,
                           time_limit=time_limit_s, progress=progress)
    worst: tuple[int, ...] = ()
    worst_routes: tuple[RouteRequirement, ...] = ()
    if found.suite is None:
        # no suite: the accuracy of the best any suite reaches (every allowed sensor, or what is
        # left of them after the failures the solver names)
        best = found.best_effort or tuple(i for i in range(len(library)) if i not in feas.excluded)
        routes = oracle.report(best)
        suite: Suite = ()
    else:
        suite = as_suite(found.suite)
        routes = oracle.report(suite)
        worst = _worst_failure(oracle, suite, failures)
        worst_routes = oracle.report(tuple(i for i in suite if i not in worst)) if worst else ()
    return RequireResult(
        status=found.status, suite=library.suite_ids(suite), cost_usd=float(feas.A[0, list(suite)].sum()) if suite else 0.0,
        lower_bound_usd=float(found.lower_bound), infeasible_by=found.infeasible_by, stop=found.stop,
        failures=failures, model="slam" if map_sigma_m is None else "map",
        map_sigma_m=map_sigma_m, routes=routes, worst_failure=library.suite_ids(worst), worst_failure_routes=worst_routes,
        iterations=int(found.iterations), n_checks=oracle.n_checks, n_refuted=oracle.n_refuted, engine=evaluators[0].name, budget_usd=budget_usd,
        constraints=feas.record, problem=target.info, seconds=time.perf_counter() - t0)


def _worst_failure(oracle: _Oracle, suite: Suite, failures: int) -> tuple[int, ...]:
    """The ``failures`` sensors of ``suite`` whose loss leaves the largest error relative to the
    bounds (ties: the first in library order); () without failures."""
    if failures <= 0 or len(suite) <= failures:
        return ()
    best: tuple[float, tuple[int, ...]] | None = None
    for lost in itertools.combinations(suite, failures):
        rest = tuple(i for i in suite if i not in lost)
        margin = max(max(err / bound for _, err, bound, _ in oracle.route(r, rest)[1].worst)
                     for r in range(len(oracle.evaluators)))
        if best is None or margin > best[0]:
            best = (margin, lost)
    return best[1] if best else ()
