"""The accuracy checks of ``require``: whether a suite meets each route's specification, each
answer computed once and kept, with what answers a check cheaply (a floor under the marginals, the
smoother's marginals under the filter's, a filter pass stopped early after a failing subset's last
bad keyframe: :mod:`.truncated`)."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from sensorsel.designs.requirements.accept import Bases, base_of
from sensorsel.designs.requirements.oracle import mask_of
from sensorsel.designs.requirements.spec import RouteVerdict, Specification, covariance_verdict, verdict
from sensorsel.designs.requirements.truncated import BadKeyframes, bad_keyframes, meets_from_bad
from sensorsel.information.evaluators import as_suite
from sensorsel.information.evaluators.accuracy import RouteAccuracy, accuracy_from_covariances
from sensorsel.information.evaluators.base import Suite
from sensorsel.information.filtering import forward_pass
from sensorsel.model.problem import Problem

__all__ = ["FLOOR_KEEP_SHARE", "FLOOR_TRIAL", "RouteEngine", "RouteRequirement", "route_covariances"]


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


class RouteEngine(Protocol):
    """What require asks of a route's engine: its pose marginals and their cheap floor (a
    :class:`~sensorsel.information.evaluators.base.ProblemEvaluator`, or a route held by a Dask actor)."""

    @property
    def name(self) -> str: ...

    def pose_covariances(
        self, suite: Iterable[int], *, map_sigma_m: float | None = None, estimate: str = "smoother"
    ) -> np.ndarray: ...

    def pose_covariance_floor(self, suite: Iterable[int], *, map_sigma_m: float | None = None) -> np.ndarray | None: ...


#: the cheap floor under the marginals is asked only while it refutes at least this share of the
#: suites it is asked about (after :data:`FLOOR_TRIAL` of them): on the bundled suburb route it
#: refuted 2 % of them and cost a third of a check each; in the map model on KITTI most failing suites
FLOOR_KEEP_SHARE = 0.2
FLOOR_TRIAL = 40
#: the most recent failing suites of a route looked through for a bound's base (the growth of a
#: failing set asks about the set it grows, seen last; a long search holds thousands)
RECENT_FAILED = 256


def route_covariances(engine: RouteEngine, suite: Suite, map_sigma_m: float | None, estimate: str) -> np.ndarray:
    """The (K, 3, 3) pose covariances ``require`` judges a suite by on one route (the filter's or the
    smoother's ``estimate``): the one place where it asks a route's engine for them."""
    return engine.pose_covariances(suite, map_sigma_m=map_sigma_m, estimate=estimate)


class _Oracle:
    """Whether a suite meets the requirement on every route, with the answers kept (each costs an
    accuracy computation per route asked); routes are asked in :attr:`route_order` (the last to
    fail a suite first) and the first failing one ends the question (the caching keeps the answer
    the same whichever path asked first).

    The solver's questions are answered from the covariances alone
    (:func:`~sensorsel.designs.requirements.spec.covariance_verdict`); the full
    :class:`RouteAccuracy` is built only for the suites a result reports.

    Before computing a route's marginals, :meth:`meets` asks the engine's cheap floor under them
    (:meth:`~sensorsel.information.evaluators.base.ProblemEvaluator.pose_covariance_floor`): every σ of the floor
    is below the true one, so a specification the floor already misses is missed (monotone in each
    keyframe's errors, whatever the share of keyframes): the suite fails without its marginals. In
    the map model the floor is ~50-90 % of the true σ (KITTI 00, 03) and refutes most failing
    suites; where it refutes few (:data:`FLOOR_KEEP_SHARE`) it is no longer asked (a choice made
    from the counts alone, so the answers and the run stay deterministic).
    The floor is under the smoother's marginals, and so under the filter's (which use fewer
    measurements: ⪰ the smoother's at every keyframe): it refutes for either ``estimate``.

    With the filter's estimate, the smoother's marginals are themselves a floor under it, exact
    and ~1/20-1/50 of its cost: a suite whose smoothed accuracy misses the specification misses
    it as the car drives, refuted without the forward pass (counted with :attr:`n_refuted`). The
    violation the solver's greedy ranks by is then the smoother's where that already fails
    (> 0, as the filter's is), else the filter's: still 0 exactly when the suite meets it.

    With the filter's estimate, a suite the smoother does not refute is then offered to an upper
    bound (:mod:`.accept`): from a failing suite inside it (the largest seen, one or two sensors
    fewer: the growth of a failing set), restarted a few keyframes before each run of that suite's
    bad keyframes. Every σ of the bound is above the suite's own, so a bound that meets the
    specification proves the suite meets it (violation 0, the answer its pass gives); else its own
    pass decides. A base already kept is tried first, before the smoother (its shortest bound costs
    about as much); a new base's pass only where no filter pass stopped early (:mod:`.truncated`)
    answers: that is exact and passes half the route at most.
    """

    #: whether upper bounds may accept suites (the benchmark turns it off to compare, in one process)
    accept = True
    #: whether a failing subset's bad keyframes before the added sensors' first measurement refute a
    #: suite (:meth:`_refuted_before_seen`; a test turns it off to reach the passes stopped early)
    refute_before_seen = True
    #: whether a filter pass of :meth:`_answer` keeps its predicted states, for the bounds to start from
    #: (a test turns it off to compare)
    keep_states = True

    def __init__(
        self,
        evaluators: Sequence[RouteEngine],
        names: Sequence[str],
        specs: Sequence[Specification],
        map_sigma_m: float | None,
        estimate: str = "filter",
        *,
        problems: Sequence[Problem],
    ) -> None:
        self.evaluators, self.names, self.specs, self.map_sigma_m = (
            list(evaluators),
            list(names),
            list(specs),
            map_sigma_m,
        )
        #: each route's problem, in this process whatever engine answers its checks (a cluster's
        #: worker or here): the passes stopped early and the upper bounds run here, so a run asks and
        #: counts the same checks on any executor
        self.problems = list(problems)
        self._answers: dict[tuple[int, Suite], tuple[bool, float]] = {}
        self._reports: dict[tuple[int, Suite], tuple[RouteAccuracy, RouteVerdict]] = {}
        self.estimate = estimate
        #: (route, suite) -> the smoother's (meets, violation), where the filter's is asked (its floor)
        self._smoothed: dict[tuple[int, Suite], tuple[bool, float]] = {}
        self.floor_refuted = 0  # (route, suite) refuted by the cheap floor (decides whether it is still asked)
        self._refuted: set[tuple[int, Suite]] = set()
        #: (route, suite) -> (meets, violation or None): answers read back from a journal
        self.known: dict[tuple[int, Suite], tuple[bool, float | None]] = {}
        self.n_checks = 0  # marginals computed (route, suite)
        #: (route, suite) refuted without the judged marginals: by the floor, or (filter) by the smoother
        #: or a failing subset's bad keyframes
        self.n_refuted = 0
        self.floor_asked = 0
        self.on_answer: Callable[[], None] | None = None  # called after each new answer (the journal's writer)
        #: per route, the bad keyframes of the suites seen to fail there (a superset's pass stops after them)
        self._bad = [BadKeyframes() for _ in self.evaluators]
        #: the order routes are asked in by :meth:`meets` (the last to fail a suite first)
        self.route_order = list(range(len(self.evaluators)))
        #: (route, suite) -> meets, from a pass stopped early (no violation known)
        self._short: dict[tuple[int, Suite], bool] = {}
        self.n_short = 0  # of n_checks, passes stopped early
        self.n_before_seen = 0  # of n_refuted, by a failing subset's bad keyframes (_refuted_before_seen)
        self.keyframes_passed = 0  # keyframes the filter passed for the checks (all of them: n_checks · K)
        #: per route, the minimal suites (bit masks) seen to meet its specification: a suite holding
        #: one meets it too, with no computation (:meth:`_met_below`)
        self._met: list[list[int]] = [[] for _ in self.evaluators]
        self.n_met_below = 0  # (route, suite) questions answered by a subset that meets the route
        #: per route, the recent suites seen to fail it (bit mask, sensors), oldest first: bases of the bounds
        self._failed: list[list[tuple[int, int]]] = [[] for _ in self.evaluators]
        #: per route, the failing suites whose filter states the upper bounds restart from (:mod:`.accept`)
        self._bases = [Bases() for _ in self.evaluators]
        #: per route, the first keyframe each library sensor measures anything at (K: never)
        self._first_seen: dict[int, np.ndarray] = {}

    @property
    def n_accepted(self) -> int:
        """(route, suite) answers proved met by an upper bound (:mod:`.accept`), without their pass."""
        return sum(b.n_accepted for b in self._bases)

    @property
    def n_base_passes(self) -> int:
        """Of ``n_checks``, the failing suites' passes the upper bounds restart from (no suite is asked by them)."""
        return sum(b.n_passes for b in self._bases)

    def answers(self) -> tuple[tuple[int, Suite, bool, float | None], ...]:
        """Every answer so far, (route, suite, meets, violation or None), in a fixed order."""
        out: dict[tuple[int, Suite], tuple[bool, float | None]] = dict(self.known)
        out.update({k: (False, None) for k in self._refuted})
        out.update({k: (False, v) for k, (m, v) in self._smoothed.items() if not m})
        # a pass stopped early knows the violation only when it is 0 (the suite meets)
        out.update({k: (m, 0.0 if m else None) for k, m in self._short.items()})
        out.update({k: (m, v) for k, (m, v) in self._answers.items()})
        return tuple((r, s, m, v) for (r, s), (m, v) in sorted(out.items()))

    def _answered(self) -> None:
        if self.on_answer is not None:
            self.on_answer()

    def _answer(self, r: int, suite: Suite) -> tuple[bool, float]:
        """(meets, violation) of ``suite`` on route ``r``, computed once. With the filter's estimate
        and the upper bounds on, the pass runs here with its predicted states kept (:func:`.accept.base_of`:
        the same numbers as the engine's pass), and a suite that fails is offered to the route's
        bounds as their next base: the failing set a growth asks about is mostly the suite whose
        pass was computed last, and a base's pass would compute it again."""
        key = (r, suite)
        got = self._answers.get(key)
        if got is None:
            base = None
            if self.estimate == "filter" and self.accept and self.keep_states:
                base = base_of(self.problems[r], suite, mask_of(suite), self.specs[r], self.map_sigma_m)
                covariances = base.filtered
            else:
                covariances = route_covariances(self.evaluators[r], suite, self.map_sigma_m, self.estimate)
            got = self._answers[key] = covariance_verdict(covariances, self.specs[r])
            self.n_checks += 1
            self.keyframes_passed += len(covariances)
            if not got[0] and self.estimate == "filter":
                self._bad[r].add(mask_of(suite), bad_keyframes(covariances, self.specs[r]))
                if base is not None:
                    self._bases[r].offer(base)
            self._answered()
        return got

    def _short_answer(self, r: int, suite: Suite) -> bool | None:
        """Whether ``suite`` meets route ``r``'s specification, by a filter pass that stops after the
        last bad keyframe of a suite inside it seen to fail (:mod:`.truncated`); None where none is
        known."""
        if self.estimate != "filter":
            return None
        problem = self.problems[r]
        mask = mask_of(suite)
        hit = self._bad[r].shortest(mask)
        if hit is None:
            return None
        until, bad = hit
        if until > problem.scenario.n_poses // 2:  # little to save: the smoother refutes cheaper first
            return None
        covariances = forward_pass(problem, suite, map_sigma_m=self.map_sigma_m, until=until).filtered
        now = bad_keyframes(covariances, self.specs[r])
        still = tuple(np.intersect1d(b, n) for b, n in zip(bad, now))  # good where the subset was good
        meets = meets_from_bad(still, problem.scenario.n_poses, self.specs[r])
        if not meets:
            self._bad[r].add(mask, still)
        self._short[(r, suite)] = meets
        self.n_checks += 1
        self.n_short += 1
        self.keyframes_passed += len(covariances)
        self._answered()
        return meets

    def route(self, r: int, suite: Suite) -> tuple[RouteAccuracy, RouteVerdict]:
        """The suite's accuracy and verdict on route ``r`` (for a report)."""
        key = (r, suite)
        got = self._reports.get(key)
        if got is None:
            acc = accuracy_from_covariances(
                route_covariances(self.evaluators[r], suite, self.map_sigma_m, self.estimate),
                map_sigma_m=self.map_sigma_m,
                route=self.names[r],
                estimate=self.estimate,
            )
            got = self._reports[key] = (acc, verdict(acc, self.specs[r]))
            if key not in self._answers:
                self._answers[key] = (got[1].meets, got[1].violation)
                self.n_checks += 1
                self._answered()
        return got

    def _met_below(self, r: int, mask: int) -> bool:
        """Whether a suite inside ``mask`` is known to meet route ``r``'s specification: then
        ``mask`` meets it too, and its violation there is 0, with no computation.

        Why this is the same answer as computing it: a sensor added to a suite only adds
        measurements (factors) to the route's problem, so its information matrix grows in the
        positive semidefinite order and every keyframe's marginal covariance shrinks, for the
        smoother and for the filter alike (each keyframe's filtered estimate is the smoother's of
        the measurements up to it). Each σ the specification bounds (the square root of a diagonal
        entry, times a positive factor) is then no larger, and so is its order statistic at the
        share ``at`` (each keyframe's σ no larger: every rank no larger). A suite that meets every
        bound therefore leaves every superset meeting it: violation 0, exactly what
        :func:`~sensorsel.designs.requirements.spec.covariance_verdict` would return. The solver's
        own inferences rest on the same monotonicity, over the whole domain; this one is per route,
        so a suite that fails the domain still answers, for its supersets, every route it met."""
        if any(not m & ~mask for m in self._met[r]):
            self.n_met_below += 1
            return True
        return False

    def _note_met(self, r: int, mask: int) -> None:
        """Keep ``mask`` among route ``r``'s minimal meeting suites (dropping those holding it)."""
        kept = self._met[r]
        if any(not m & ~mask for m in kept):
            return
        self._met[r] = [m for m in kept if m & ~mask] + [mask]

    def _note_failed(self, r: int, mask: int, size: int) -> None:
        """Keep ``mask`` (``size`` sensors) among route ``r``'s recent failing suites (bases of bounds)."""
        kept = self._failed[r]
        kept.append((mask, size))
        if len(kept) > 2 * RECENT_FAILED:
            del kept[:-RECENT_FAILED]

    def _use_floor(self) -> bool:
        return self.floor_asked < FLOOR_TRIAL or self.floor_refuted >= FLOOR_KEEP_SHARE * self.floor_asked

    def _route_meets(self, r: int, suite: Suite) -> bool:
        mask = mask_of(suite)
        if self._met_below(r, mask):
            return True
        ok = self._route_meets_asked(r, suite)
        if ok:
            self._note_met(r, mask)
        else:
            self._note_failed(r, mask, len(suite))
        return ok

    def _route_meets_asked(self, r: int, suite: Suite) -> bool:
        key = (r, suite)
        if key in self._answers:
            return self._answers[key][0]
        if key in self._refuted:
            return False
        if key in self.known:
            return self.known[key][0]
        if key in self._short:
            return self._short[key]
        if self._refuted_before_seen(r, suite):
            self._refuted.add(key)
            self.n_refuted += 1
            self.n_before_seen += 1
            self._answered()
            return False
        if self._use_floor():
            floor = self.evaluators[r].pose_covariance_floor(suite, map_sigma_m=self.map_sigma_m)
            if floor is not None:
                self.floor_asked += 1
                if not covariance_verdict(floor, self.specs[r])[0]:
                    self._refuted.add(key)
                    self.n_refuted += 1
                    self.floor_refuted += 1
                    self._answered()
                    return False
        if self._accepted(r, suite, quick=True):  # a kept base's first bound costs less than the smoother
            return True
        smoothed = self._smoother_verdict(r, suite)
        if smoothed is not None and not smoothed[0]:
            return False
        short = self._short_answer(r, suite)  # exact, and at most half a pass: before a new base's pass
        if short is not None:
            return short
        if self._accepted(r, suite):
            return True
        return self._answer(r, suite)[0]

    def _refuted_before_seen(self, r: int, suite: Suite) -> bool:
        """Whether a failing suite S inside ``suite`` (T) is over its limits, before the first keyframe
        at which a sensor of T not in S measures anything, at enough keyframes that T fails too (the
        filter's estimate only; no computation).

        Why this is T's own answer: the filter's estimate at keyframe k holds the measurements of
        keyframes up to k only. Before that first keyframe f, T's measurements are S's, in the same
        order (a suite's measurements are sorted by keyframe, stably), so T's covariances there are
        S's, and T is bad at each keyframe < f where S was judged bad. Those keyframes alone already
        break the rank rule (:func:`.truncated.meets_from_bad`): T fails. (Computed, the two passes
        agree to rounding, not always to the bit: T's state may still hold landmarks S had marginalized
        out, which T measures again later, and the state's rows then fall elsewhere in the products;
        ~1e-14 relative on the README tour, far inside the filter's own rounding. A verdict that
        rounding could turn is a tie of the specification at that keyframe, which the answer's margin
        line shows.)"""
        if self.estimate != "filter" or not self.refute_before_seen:
            return False
        problem = self.problems[r]
        first = self._first_seen.get(r)
        if first is None:
            first = self._first_seen[r] = _first_keyframes(problem)
        n = problem.scenario.n_poses
        mask = mask_of(suite)
        for known, bad in self._bad[r].inside(mask):
            f = min((int(first[i]) for i in suite if not known >> i & 1), default=n)
            if not meets_from_bad(tuple(b[b < f] for b in bad), n, self.specs[r]):
                return True
        return False

    def _accepted(self, r: int, suite: Suite, quick: bool = False) -> bool:
        """Whether an upper bound from a failing suite inside ``suite`` proves that it meets route
        ``r``'s specification (:mod:`.accept`; with the filter's estimate, on a route whose problem
        is here); then recorded as met (violation 0: the same answer its pass gives). ``quick``:
        only the first bound of a base already kept."""
        problem = self.problems[r]
        if not self.accept or self.estimate != "filter":
            return False
        mask = mask_of(suite)
        failed = (
            None
            if quick
            else max(
                ((n, i, m) for i, (m, n) in enumerate(self._failed[r][-RECENT_FAILED:]) if not m & ~mask),
                default=None,
            )
        )
        bases = self._bases[r]
        passes = bases.n_passes
        ok = bases.accepts(
            problem, suite, mask, None if failed is None else failed[2], self.specs[r], self.map_sigma_m, quick
        )
        self.n_checks += bases.n_passes - passes  # a base's pass is an accuracy computation
        if ok:
            self._answers[(r, suite)] = (True, 0.0)
            self._answered()
        return ok

    def _smoother_verdict(self, r: int, suite: Suite) -> tuple[bool, float] | None:
        """The smoother's (meets, violation) on (route, suite) when the filter's is asked (a floor
        under it: the class's docstring), computed once; None for the smoother's own estimate."""
        if self.estimate != "filter":
            return None
        key = (r, suite)
        got = self._smoothed.get(key)
        if got is None:
            got = self._smoothed[key] = covariance_verdict(
                route_covariances(self.evaluators[r], suite, self.map_sigma_m, "smoother"), self.specs[r]
            )
            if not got[0]:
                self.n_refuted += 1
                self._answered()
        return got

    def meets(self, suite: Suite) -> bool:
        """Whether ``suite`` meets every route's specification. The routes are asked in
        :attr:`route_order`: the route that last failed a suite first (a suite that fails a domain
        mostly fails where the previous one did, and the routes it meets before that cost a check
        each). The order follows the answers alone, so a run and its resumption ask the same."""
        s = as_suite(suite)
        for r in list(self.route_order):
            if not self._route_meets(r, s):
                if self.route_order[0] != r:
                    self.route_order.remove(r)
                    self.route_order.insert(0, r)
                return False
        return True

    def _route_violation(self, r: int, suite: Suite) -> float:
        mask = mask_of(suite)
        if self._met_below(r, mask):
            return 0.0
        v = self._route_violation_asked(r, suite)
        if v <= 0.0:
            self._note_met(r, mask)
        else:
            self._note_failed(r, mask, len(suite))
        return v

    def _route_violation_asked(self, r: int, suite: Suite) -> float:
        known = self.known.get((r, suite))
        if known is not None and known[1] is not None and (r, suite) not in self._answers:
            return known[1]
        if (r, suite) not in self._answers:
            smoothed = self._smoother_verdict(r, suite)
            if smoothed is not None and not smoothed[0]:
                return smoothed[1]
            if self._accepted(r, suite):  # it meets: its violation is 0, exactly as its pass gives
                return 0.0
        return self._answer(r, suite)[1]

    def violation(self, suite: Suite) -> float:
        s = as_suite(suite)
        return max(self._route_violation(r, s) for r in range(len(self.evaluators)))

    def report(self, suite: Suite) -> tuple[RouteRequirement, ...]:
        s = as_suite(suite)
        return tuple(
            RouteRequirement(self.names[r], self.specs[r], *self.route(r, s)) for r in range(len(self.evaluators))
        )


def _first_keyframes(problem: Problem) -> np.ndarray:
    """(n_sensors,) the first keyframe at which each sensor of ``problem``'s library measures a
    landmark (the route's keyframe count where it measures none)."""
    n = problem.scenario.n_poses
    return np.array([int(np.min(o.pose)) if len(o) else n for o in problem.observations], np.int64)
