"""The accuracy checks of ``require``: whether a suite meets each route's specification, each
answer computed once and kept, with what answers a check cheaply (a floor under the marginals, the
smoother's marginals under the filter's, a filter pass stopped early after a failing subset's last
bad keyframe: :mod:`.truncated`)."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING, Literal

import numpy as np

from sensorsel.designs.requirements.accept import Bases, base_of
from sensorsel.designs.requirements.oracle import Antichain, mask_of, suite_of
from sensorsel.designs.requirements.smoothed import RouteEngine, SmootherFloor, route_covariances
from sensorsel.designs.requirements.spec import RouteVerdict, Specification, covariance_verdict, verdict
from sensorsel.designs.requirements.truncated import (
    BadKeyframes,
    BadList,
    bad_keyframes,
    floors_to_solve,
    mask_of_bad,
    meets_from_bad,
    meets_from_mask,
    over_limits,
)
from sensorsel.information.evaluators.accuracy import RouteAccuracy, accuracy_from_covariances
from sensorsel.information.evaluators.base import Suite
from sensorsel.information.filtering import forward_pass
from sensorsel.information.window_bounds import WindowBounds, pass_flops
from sensorsel.model.problem import Problem

if TYPE_CHECKING:
    from sensorsel.information.evaluators.processes import CovariancesAhead

__all__ = [
    "COUNTS",
    "FLOOR_KEEP_SHARE",
    "FLOOR_TRIAL",
    "RouteEngine",
    "RouteOracle",
    "route_covariances",
]


#: the cheap floor under the marginals is asked only while it refutes at least this share of the
#: suites it is asked about (after :data:`FLOOR_TRIAL` of them): on the bundled suburb route it
#: refuted 2 % of them and cost a third of a check each; in the map model on KITTI most failing suites
FLOOR_KEEP_SHARE = 0.2
FLOOR_TRIAL = 40
#: the most recent failing suites of a route looked through for a bound's base (the growth of a
#: failing set asks about the set it grows, seen last; a long search holds thousands)
RECENT_FAILED = 256


class RouteOracle:
    """Whether a suite meets one route's specification, with the answers kept (each costs an
    accuracy computation at most once). It lives beside the route's engine (in this process, on a
    worker process or on a Dask worker: :mod:`.domain_checks`), so everything it learns stays where
    the route's data is, and a route's answers and counts depend only on the questions asked of it,
    in their order, never on where it runs.

    The questions are answered from the covariances alone
    (:func:`~sensorsel.designs.requirements.spec.covariance_verdict`); the full
    :class:`RouteAccuracy` is built only for the suites a result reports.

    Before computing the route's marginals, :meth:`meets` asks the engine's cheap floor under them
    (:meth:`~sensorsel.information.evaluators.base.ProblemEvaluator.pose_covariance_floor`): every σ of the floor
    is below the true one, so a specification the floor already misses is missed (monotone in each
    keyframe's errors, whatever the share of keyframes): the suite fails without its marginals. In
    the map model the floor is ~50-90 % of the true σ (KITTI 00, 03) and refutes most failing
    suites; where it refutes few (:data:`FLOOR_KEEP_SHARE`) it is no longer asked on this route (a
    choice made from the route's counts alone, so the answers and the run stay deterministic).
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

    Before all of these (the map model, the filter's estimate), a suite holding a failing suite whose
    bad keyframes are known (or the failing suite seen last, whose pass is then computed once for
    them) is decided where it can fail only: at those keyframes, by the filter's floors and ceilings
    from a window of the route before each (:mod:`~sensorsel.information.window_bounds`, a few small
    solves instead of a pass). A floor over the limit is a bad keyframe, a ceiling within it a good
    one; with enough of either the answer is the pass's (:meth:`_window_verdict`). On the README
    tour they answered most questions of the growths, and the search took half the time.

    Attributes:
        engine: the route's engine (smoother marginals and the floor); problem: the route's problem
            (the filter's passes); name, spec: the route's name and specification.
        known: suite -> (meets, violation or None): answers read back from a journal.
        known_bad: (suite, bad keyframes) of failing suites found with them, in their order.
        bad: the bad keyframes of the suites seen to fail (a superset's pass stops after them, the
            windows are asked at them); what it records is logged for the journal (its ``take_log``).
        log: the answers given since the caller last took them (:meth:`take_log`), as
            (suite, meets, violation or None), in the order they were found: a journal's entries.
    """

    #: whether upper bounds may accept suites (the benchmark turns it off to compare, in one process)
    accept = True
    #: whether the windows' floors and ceilings may decide a suite (:meth:`_window_verdict`)
    window_bounds = True
    #: whether a failing subset's bad keyframes before the added sensors' first measurement refute a
    #: suite (:meth:`_refuted_before_seen`; a test turns it off to reach the passes stopped early)
    refute_before_seen = True
    #: whether a filter pass of :meth:`_answer` keeps its predicted states, for the bounds to start from
    #: (a test turns it off to compare)
    keep_states = True

    def __init__(
        self,
        engine: RouteEngine,
        problem: Problem,
        name: str,
        spec: Specification,
        map_sigma_m: float | None,
        estimate: str = "filter",
        known: dict[Suite, tuple[bool, float | None]] | None = None,
        known_bad: Iterable[tuple[Suite, BadList]] = (),
        ahead: CovariancesAhead | None = None,
    ) -> None:
        self.engine, self.problem, self.name, self.spec = engine, problem, name, spec
        self.map_sigma_m, self.estimate = map_sigma_m, estimate
        self.known: dict[Suite, tuple[bool, float | None]] = dict(known or {})
        self.log: list[tuple[Suite, bool, float | None]] = []
        self._answers: dict[Suite, tuple[bool, float]] = {}
        self._reports: dict[Suite, tuple[RouteAccuracy, RouteVerdict]] = {}
        #: the smoother's (meets, violation) of the suites, where the filter's is asked (its floor)
        self.smoother = SmootherFloor(engine, spec, map_sigma_m, ahead)
        self._refuted: set[Suite] = set()
        #: suite -> meets, from a pass stopped early (no violation known)
        self._short: dict[Suite, bool] = {}
        self.n_asked = 0  # questions asked (meets, violation)
        self.floor_asked = 0
        self.floor_refuted = 0  # refuted by the cheap floor (decides whether it is still asked)
        self.n_checks = 0  # marginals computed
        #: refuted without the judged marginals: by the floor, or (filter) by the smoother or a
        #: failing subset's bad keyframes
        self.n_refuted = 0
        self.n_short = 0  # of n_checks, passes stopped early
        self.n_before_seen = 0  # of n_refuted, by a failing subset's bad keyframes (_refuted_before_seen)
        self.keyframes_passed = 0  # keyframes the filter passed for the checks (all of them: n_checks · K)
        self.n_met_below = 0  # questions answered by a subset that meets the route
        self.n_window_refuted = 0  # of n_refuted, by the windows' floors (:meth:`_window_verdict`)
        self.n_window_accepted = 0  # of n_accepted, by the windows' ceilings
        self.n_visits_accepted = 0  # of those, by the ceilings with the earlier visits (the last ones asked)
        self._windows: WindowBounds | None = None  # built at its first use
        self.n_window_bases = 0  # of n_checks, failing suites' passes for the windows' keyframes
        #: suite -> the violation of a suite the windows refuted: their floors' (a lower bound on the
        #: pass's, what the solver's greedy ranks it by)
        self._window_violations: dict[Suite, float] = {}
        self.bad = BadKeyframes((mask_of(s), b) for s, b in known_bad)
        #: the minimal suites (bit masks) seen to meet the specification: a suite holding one meets
        #: it too, with no computation (:meth:`_met_below`)
        self._met = Antichain(problem.n_sensors, "min")
        #: the recent suites seen to fail (bit mask, sensors), oldest first: bases of the bounds
        self._failed: list[tuple[int, int]] = []
        #: the failing suites whose filter states the upper bounds restart from (:mod:`.accept`)
        self.bases = Bases()
        #: the first keyframe each library sensor measures anything at (K: never)
        self._first_seen: np.ndarray | None = None

    @property
    def n_accepted(self) -> int:
        """Answers proved met by an upper bound (:mod:`.accept`, or the windows' ceilings), without their pass."""
        return self.bases.n_accepted + self.n_window_accepted

    @property
    def n_base_passes(self) -> int:
        """Of ``n_checks``, the failing suites' passes later checks start from (no suite is asked by
        them): the upper bounds' states, and the bad keyframes the windows are asked at."""
        return self.bases.n_passes + self.n_window_bases

    def counts(self) -> dict[str, int]:
        """The route's counts so far, by name (:data:`COUNTS`)."""
        return {c: int(getattr(self, c)) for c in COUNTS}

    def take_log(self) -> list[tuple[Suite, bool, float | None]]:
        """The answers found since the last call (and forgets them)."""
        out, self.log = self.log, []
        return out

    def _answered(self, suite: Suite, meets: bool, violation: float | None) -> None:
        self.log.append((suite, bool(meets), None if violation is None else float(violation)))

    def _answer(self, suite: Suite) -> tuple[bool, float]:
        """(meets, violation) of ``suite``, computed once. With the filter's estimate and the upper
        bounds on, the pass runs here with its predicted states kept (:func:`.accept.base_of`: the
        same numbers as the engine's pass), and a suite that fails is offered to the route's bounds
        as their next base: the failing set a growth asks about is mostly the suite whose pass was
        computed last, and a base's pass would compute it again."""
        got = self._answers.get(suite)
        if got is None:
            base = None
            if self.estimate == "filter" and self.accept and self.keep_states:
                base = base_of(self.problem, suite, mask_of(suite), self.spec, self.map_sigma_m)
                covariances = base.filtered
            else:
                covariances = route_covariances(self.engine, suite, self.map_sigma_m, self.estimate)
            got = self._answers[suite] = covariance_verdict(covariances, self.spec)
            self.n_checks += 1
            self.keyframes_passed += len(covariances)
            if not got[0] and self.estimate == "filter":
                self.bad.add(mask_of(suite), bad_keyframes(covariances, self.spec))
                if base is not None:
                    self.bases.offer(base)
            self._answered(suite, *got)
        return got

    def _short_answer(self, suite: Suite) -> bool | None:
        """Whether ``suite`` meets the specification, by a filter pass that stops after the last bad
        keyframe of a suite inside it seen to fail (:mod:`.truncated`); None where none is known."""
        if self.estimate != "filter":
            return None
        mask = mask_of(suite)
        hit = self.bad.shortest(mask)
        if hit is None:
            return None
        until, bad = hit
        n = self.problem.scenario.n_poses
        if until > n // 2:  # little to save: the smoother refutes cheaper first
            return None
        covariances = forward_pass(self.problem, suite, map_sigma_m=self.map_sigma_m, until=until).filtered
        now = bad_keyframes(covariances, self.spec)
        still = tuple(np.intersect1d(b, n_) for b, n_ in zip(bad, now))  # good where the subset was good
        meets = meets_from_bad(still, n, self.spec)
        if not meets:
            self.bad.add(mask, still)
        self._short[suite] = meets
        self.n_checks += 1
        self.n_short += 1
        self.keyframes_passed += len(covariances)
        # a pass stopped early knows the violation only when it is 0 (the suite meets)
        self._answered(suite, meets, 0.0 if meets else None)
        return meets

    def route(self, suite: Suite) -> tuple[RouteAccuracy, RouteVerdict]:
        """The suite's accuracy and verdict on the route (for a report)."""
        got = self._reports.get(suite)
        if got is None:
            acc = accuracy_from_covariances(
                route_covariances(self.engine, suite, self.map_sigma_m, self.estimate),
                map_sigma_m=self.map_sigma_m,
                route=self.name,
                estimate=self.estimate,
            )
            got = self._reports[suite] = (acc, verdict(acc, self.spec))
            if suite not in self._answers:
                self._answers[suite] = (got[1].meets, got[1].violation)
                self.n_checks += 1
                self._answered(suite, got[1].meets, got[1].violation)
        return got

    def _met_below(self, mask: int) -> bool:
        """Whether a suite inside ``mask`` is known to meet the specification: then ``mask`` meets
        it too, and its violation is 0, with no computation.

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
        if self._met.holds_one(mask):
            self.n_met_below += 1
            return True
        return False

    def _note_met(self, mask: int) -> None:
        """Keep ``mask`` among the minimal meeting suites (dropping those holding it); its callers
        asked :meth:`_met_below` of it just before (none inside it is kept)."""
        self._met.add(mask)

    def _note_failed(self, mask: int, size: int) -> None:
        """Keep ``mask`` (``size`` sensors) among the recent failing suites (bases of bounds)."""
        self._failed.append((mask, size))
        if len(self._failed) > 2 * RECENT_FAILED:
            del self._failed[:-RECENT_FAILED]

    def _use_floor(self) -> bool:
        return self.floor_asked < FLOOR_TRIAL or self.floor_refuted >= FLOOR_KEEP_SHARE * self.floor_asked

    def meets(self, suite: Suite) -> bool:
        """Whether ``suite`` (sorted library positions) meets the route's specification."""
        self.n_asked += 1
        mask = mask_of(suite)
        if self._met_below(mask):
            return True
        ok = self._meets_asked(suite)
        if ok:
            self._note_met(mask)
        else:
            self._note_failed(mask, len(suite))
        return ok

    def _meets_asked(self, suite: Suite) -> bool:
        if suite in self._answers:
            return self._answers[suite][0]
        if suite in self._refuted:
            return False
        if suite in self.known:
            return self.known[suite][0]
        if suite in self._short:
            return self._short[suite]
        if self._refuted_before_seen(suite):
            self.n_before_seen += 1
            return self._refute(suite)
        window = self._window_verdict(suite, scope="known")
        if window is not None:
            return window
        if self._use_floor():
            floor = self.engine.pose_covariance_floor(suite, map_sigma_m=self.map_sigma_m)
            if floor is not None:
                self.floor_asked += 1
                if not covariance_verdict(floor, self.spec)[0]:
                    self.floor_refuted += 1
                    return self._refute(suite)
        if self._accepted(suite, quick=True):  # a kept base's first bound costs less than the smoother
            return True
        smoothed = self._smoother_verdict(suite)
        if smoothed is not None and not smoothed[0]:
            return False
        short = self._short_answer(suite)  # exact, and at most half a pass: before a new base's pass
        if short is not None:
            return short
        if self._accepted(suite):
            return True
        # a dear pass: the windows at every keyframe, where nothing cheaper decided (on KITTI 00, asked
        # before the short pass and the bases, they cost more than the passes they spared)
        window = self._window_verdict(suite, scope="dear")
        if window is not None:
            return window
        return self._answer(suite)[0]

    def _window_verdict(
        self, suite: Suite, rank: bool = False, scope: Literal["known", "dear"] = "known"
    ) -> bool | None:
        """Whether ``suite`` meets the specification, decided at the bad keyframes of the failing suites
        inside it (the only keyframes where it can fail: :mod:`.truncated`) by the filter's floors and
        ceilings from a short window before each (:mod:`~sensorsel.information.window_bounds`); None
        where they do not decide. Where the floors put enough of those keyframes over their limits,
        the suite fails (refuted); where the ceilings keep every one of them within, it meets
        (accepted, violation 0): its own pass would judge the same, as a keyframe within
        :data:`WINDOW_SLACK` of its limit is left to the pass. Keyframes the long window leaves
        undecided get a last ceiling, with the route's earlier visits to the window's landmarks
        (:meth:`~sensorsel.information.window_bounds.WindowBounds.ceilings_with_visits`: what the
        filter still knows of them after a loop). The map model only: in SLAM the ceilings have no
        landmark to anchor them.

        ``rank``: the solver's greedy asks for a violation to rank the suite by: a refuted suite's
        floors are computed at all its candidate keyframes (not only until they refute it), and its
        violation is their largest excess, with the long windows at its bad keyframes (a lower bound
        on its pass's, kept in ``_window_violations``; with every keyframe required only).

        ``scope``: "known", only at the bad keyframes of failing suites inside it (None where they are
        not known, or more than half the route); "dear", at every keyframe where that is so and its
        pass is dear (:meth:`_dear`), else None."""
        if self.estimate != "filter" or self.map_sigma_m is None or not self.window_bounds:
            return None
        mask = mask_of(suite)
        n = self.problem.scenario.n_poses
        known = self.bad.inside(mask)
        if not known:
            # the failing suite inside it seen last (a growth's failing set, which the growth asks with
            # one sensor more at a time): its bad keyframes from its own pass, once
            failed = next((m for m, _ in reversed(self._failed[-RECENT_FAILED:]) if not m & ~mask), None)
            if failed is not None:
                self._bad_keyframes_of(failed)
                known = self.bad.inside(mask)
        # the keyframes still in question, per component, as (C, K) masks (sets of a few keyframes
        # each, asked thousands of times: masks cost a fraction of numpy's set operations)
        if known:
            candidates = mask_of_bad(known[0][1], n)
            for _, bad in known[1:]:
                candidates &= mask_of_bad(bad, n)
            at = np.flatnonzero(candidates.any(axis=0))
        if known and len(at) <= max(WINDOW_KEYFRAMES, n // 2):
            if scope == "dear":
                return None  # asked of these keyframes already
        elif scope == "known" or not self._dear(suite):
            return None
        else:  # a dear pass (a long route, sensors that hold many landmarks): the windows at every keyframe
            at = np.arange(n)
            candidates = np.ones((len(self.spec.bounds()), n), bool)
        if self._windows is None:
            self._windows = WindowBounds(self.problem, self.map_sigma_m)
        sure = np.zeros_like(candidates)
        worst = 0.0  # the largest σ · factor / limit − 1 of a floor over its limit

        # a floor is solved only where its ceiling is over a limit: elsewhere it is within its limits
        # too, and decides nothing (:func:`.truncated.floors_to_solve`)
        def floors_wanted(ceilings: np.ndarray) -> np.ndarray:
            return floors_to_solve(ceilings, self.spec, -WINDOW_SLACK)

        # short windows first; the keyframes they leave undecided (the floor within its limit, the
        # ceiling over it) again with long ones (tighter: conditioned on fewer poses, a larger
        # subgraph). In chunks: a suite that fails is mostly refuted by its first keyframes' floors
        for window in WINDOWS:
            undecided = np.zeros_like(candidates)
            for lo in range(0, len(at), WINDOW_KEYFRAMES):
                chunk = at[lo : lo + WINDOW_KEYFRAMES]
                floors, ceilings = self._windows(suite, chunk, window, floors_wanted)
                asked = candidates[:, chunk]
                sure[:, chunk] |= over_limits(floors, self.spec, WINDOW_SLACK) & asked
                worst = max(worst, covariance_verdict(floors, self.spec)[1])
                if not meets_from_mask(sure, self.spec) and not (rank and lo + WINDOW_KEYFRAMES < len(at)):
                    self.n_window_refuted += 1
                    if not (rank and self.spec.at >= 1.0):  # a rank rule's violation is an order
                        return self._refute(suite)  # statistic over the whole route: not known from a few
                    # every keyframe required: the violation is the largest excess, at least the floors'
                    # at the bad keyframes (those of the long windows there: closer)
                    if window != WINDOWS[-1]:
                        bad_at = np.flatnonzero(sure.any(axis=0))
                        worst = covariance_verdict(self._windows(suite, bad_at, WINDOWS[-1])[0], self.spec)[1]
                    self._window_violations[suite] = worst
                    return self._refute(suite, worst)
                undecided[:, chunk] = over_limits(ceilings, self.spec, -WINDOW_SLACK) & asked & ~sure[:, chunk]
            candidates = undecided
            if meets_from_mask(sure | candidates, self.spec):
                self.n_window_accepted += 1
                return self._met_by_bound(suite)
            # the next windows only where these left a component undecided
            at = np.flatnonzero(candidates.any(axis=0))
        # where the long windows left a keyframe undecided, its ceiling again with the route's earlier
        # visits to the window's landmarks (after a loop the filter still knows them from then); not
        # where the window reaches the route's start (its ceiling is the filter's already)
        late = at[at > WINDOWS[-1]]
        if not len(late) or not self._met_with_visits(suite, late, sure, candidates):
            return None
        self.n_window_accepted += 1
        self.n_visits_accepted += 1
        return self._met_by_bound(suite)

    def _met_with_visits(self, suite: Suite, late: np.ndarray, sure: np.ndarray, candidates: np.ndarray) -> bool:
        """Whether the ceilings with the earlier visits at the keyframes ``late`` keep enough of them
        within their limits that ``suite`` meets the specification (``sure``: the keyframes known bad,
        ``candidates``: those undecided, per component, (C, K) masks). In chunks: once the keyframes
        still over their limits (those not asked yet taken as good) are enough to fail, the rest cannot
        accept it (these systems span the visits: up to a few hundred poses and a thousand landmarks on
        a user's drive, 0.2 s)."""
        assert self._windows is not None
        candidates = candidates.copy()
        for lo in range(0, len(late), WINDOW_KEYFRAMES):
            chunk, rest = late[lo : lo + WINDOW_KEYFRAMES], late[lo + WINDOW_KEYFRAMES :]
            ceilings = self._windows.ceilings_with_visits(suite, chunk, WINDOWS[-1])
            candidates[:, chunk] &= over_limits(ceilings, self.spec, -WINDOW_SLACK)
            still = sure | candidates
            still[:, rest] = sure[:, rest]
            if not meets_from_mask(still, self.spec):
                return False
        return True

    def _dear(self, suite: Suite) -> bool:
        """Whether ``suite``'s pass is dear enough (:data:`DEAR_PASS`) that the windows' bounds are
        asked at every keyframe before it."""
        return pass_flops(self.problem, suite) >= DEAR_PASS

    def _refute(self, suite: Suite, violation: float | None = None) -> bool:
        """Record ``suite`` as failing without its pass (by a cheap bound; ``violation``: a lower bound
        on its pass's where one is known) and answer False."""
        self._refuted.add(suite)
        self.n_refuted += 1
        self._answered(suite, False, violation)
        return False

    def _met_by_bound(self, suite: Suite) -> bool:
        """Record ``suite`` as meeting the specification by an upper bound (violation 0, as its pass
        gives) and answer True."""
        self._answers[suite] = (True, 0.0)
        self._answered(suite, True, 0.0)
        return True

    def _bad_keyframes_of(self, mask: int) -> None:
        """Record the bad keyframes of the failing suite ``mask`` from its filter pass (an accuracy
        computation; its answer too, where it is not known yet)."""
        suite = suite_of(mask)
        covariances = route_covariances(self.engine, suite, self.map_sigma_m, "filter")
        self.n_checks += 1
        self.n_window_bases += 1
        self.keyframes_passed += len(covariances)
        got = self._answers.setdefault(suite, covariance_verdict(covariances, self.spec))
        if not got[0]:  # (a floor that refuted it at a tie, to round-off, leaves it without bad keyframes)
            self.bad.add(mask, bad_keyframes(covariances, self.spec))

    def refuted_cheaply(self, suite: Suite) -> bool:
        """Whether ``suite`` is refuted without a filter pass: by its smoother's marginals (the
        filter's estimate only: with the smoother's, they are the check itself). The search asks
        this of every allowed sensor together before its greedy, which on a specification no suite
        meets adds sensors one by one until none helps (KITTI 00: 389 suites and 27 s before the
        library's own check said so). A refutation is an answer (counted and journalled as
        :meth:`meets` counts it); a suite not refuted leaves nothing but the smoother's cached
        verdict, so a search that goes on asks and counts exactly what it would have."""
        if suite in self._answers:
            return not self._answers[suite][0]
        if suite in self.known:
            return not self.known[suite][0]
        smoothed = self._smoother_verdict(suite)
        return smoothed is not None and not smoothed[0]

    def _refuted_before_seen(self, suite: Suite) -> bool:
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
        if self._first_seen is None:
            self._first_seen = _first_keyframes(self.problem)
        first = self._first_seen
        n = self.problem.scenario.n_poses
        mask = mask_of(suite)
        for known, bad in self.bad.inside(mask):
            f = min((int(first[i]) for i in suite if not known >> i & 1), default=n)
            if not meets_from_bad(tuple(b[b < f] for b in bad), n, self.spec):
                return True
        return False

    def _accepted(self, suite: Suite, quick: bool = False) -> bool:
        """Whether an upper bound from a failing suite inside ``suite`` proves that it meets the
        specification (:mod:`.accept`; with the filter's estimate); then recorded as met (violation
        0: the same answer its pass gives). ``quick``: only the first bound of a base already kept."""
        if not self.accept or self.estimate != "filter":
            return False
        mask = mask_of(suite)
        failed = (
            None
            if quick
            else max(
                ((n, i, m) for i, (m, n) in enumerate(self._failed[-RECENT_FAILED:]) if not m & ~mask),
                default=None,
            )
        )
        passes = self.bases.n_passes
        ok = self.bases.accepts(
            self.problem, suite, mask, None if failed is None else failed[2], self.spec, self.map_sigma_m, quick
        )
        self.n_checks += self.bases.n_passes - passes  # a base's pass is an accuracy computation
        if self.bases.n_passes > passes:  # a failing suite's whole pass: its bad keyframes, exactly
            base = self.bases.newest
            self.bad.add(base.mask, bad_keyframes(base.filtered, self.spec))
        return self._met_by_bound(suite) if ok else False

    def _smoother_verdict(self, suite: Suite) -> tuple[bool, float] | None:
        """The smoother's (meets, violation) when the filter's is asked (a floor under it: the
        class's docstring), computed once; None for the smoother's own estimate."""
        if self.estimate != "filter":
            return None
        fresh = self.smoother.known(suite) is None
        got = self.smoother.verdict(suite)
        if fresh and not got[0]:
            self.n_refuted += 1
            self._answered(suite, False, got[1])
        return got

    def look_ahead(self, suites: Sequence[Suite]) -> None:
        """Told of the suites whose violations are likely asked next, in that order: those whose
        smoother's marginals :meth:`violation` would compute are computed ahead where the route has
        workers for it (:meth:`SmootherFloor.look_ahead`). Nothing here is recorded or counted: the
        answers, and their order, are those of a run without it."""
        if self.estimate == "filter":
            self.smoother.look_ahead(
                [
                    s
                    for s in suites
                    if s not in self._answers and s not in self.known and not self._met.holds_one(mask_of(s))
                ]
            )

    def violation(self, suite: Suite) -> float:
        """How far ``suite`` misses the specification (0 exactly when it meets it)."""
        self.n_asked += 1
        mask = mask_of(suite)
        if self._met_below(mask):
            return 0.0
        v = self._violation_asked(suite)
        if v <= 0.0:
            self._note_met(mask)
        else:
            self._note_failed(mask, len(suite))
        return v

    def violation_floor(self, suite: Suite) -> float:
        """A lower bound on :meth:`violation` of ``suite`` without an accuracy computation (nothing
        is counted or recorded): its value where it is known; else the violation of the engine's floor
        under the marginals (:meth:`~sensorsel.information.evaluators.base.ProblemEvaluator.pose_covariance_floor`,
        under the smoother's and so the filter's: every value :meth:`violation` returns is the
        smoother's or the filter's violation, or 0 where the smoother meets the specification and
        so the floor does too); 0 where the engine has none. On KITTI 00 ~1/20 of the smoother's
        marginals, and within 0.3 % of their violation for one sensor alone."""
        if self._met.holds_one(mask_of(suite)):
            return 0.0
        known = self.known.get(suite)
        if known is not None and known[1] is not None and suite not in self._answers:
            return known[1]
        if suite in self._answers:
            return self._answers[suite][1]
        smoothed = self.smoother.known(suite)
        if smoothed is not None:
            return 0.0 if smoothed[0] else smoothed[1]
        floor = self.engine.pose_covariance_floor(suite, map_sigma_m=self.map_sigma_m)
        return 0.0 if floor is None else covariance_verdict(floor, self.spec)[1]

    def _violation_asked(self, suite: Suite) -> float:
        known = self.known.get(suite)
        if known is not None and known[1] is not None and suite not in self._answers:
            return known[1]
        if suite not in self._answers:
            smoothed = self._smoother_verdict(suite)
            if smoothed is not None and not smoothed[0]:
                return smoothed[1]
            got = self._window_violation(suite, "known")
            if got is not None:
                return got
            if self._accepted(suite):  # it meets: its violation is 0, exactly as its pass gives
                return 0.0
            got = self._window_violation(suite, "dear")  # a dear pass's windows at every keyframe
            if got is not None:
                return got
        return self._answer(suite)[1]

    def _window_violation(self, suite: Suite, scope: Literal["known", "dear"]) -> float | None:
        """``suite``'s violation from the windows (:meth:`_window_verdict` over ``scope``): 0 where they
        accept it (exactly as its pass gives), their floors' excess where they refute it (a lower
        bound on its pass's); None where they do not say."""
        got = self._window_violations.get(suite)
        if got is None and suite not in self._refuted:
            if self._window_verdict(suite, rank=True, scope=scope):
                return 0.0
            got = self._window_violations.get(suite)
        return got


#: the keyframes the windows' bounds are computed at together (a suite is refuted after the first
#: chunk whose floors break its specification); at most half the route's (or this many) in all:
#: beyond, its own pass costs about as much
WINDOW_KEYFRAMES = 16
#: the windows' lengths (keyframes before the one bounded), tried in turn where the one before left
#: a keyframe undecided. On the README tour's growths 16 alone decided 5 in 6 of the suites asked it
#: (9.5 s for the whole search), then 48 all but 22 of ~1,700 (6.1 s; 32 instead: 7.3 s), at about
#: 0.2 and 2 ms a keyframe for a six-sensor suite
WINDOWS = (16, 48)
#: a pass whose model (:func:`~sensorsel.information.window_bounds.pass_flops`) puts a keyframe at
#: this many flops or more is dear: where no failing suite inside it says where to look (or says: more
#: than half the route) and nothing cheaper decided it, the windows' bounds are asked at every keyframe
#: before its pass. On a user's drive (KITTI 00's ground truth, 1,614 generated landmarks) the roof
#: LiDARs alone and six radars model 0.9-3.2e8 and took 18-40 ms a keyframe, the windows of 16 0.6-1.6
#: (the long-range LiDAR, 20 s a pass, accepted by its ceilings in 1 s); suites of 10-17 sensors that
#: meet model 1-6e7 and took 1.5-5 s a pass. Below 1e7 a pass is within a few times the windows' cost
DEAR_PASS = 1e7
#: a keyframe within this share of its limit (σ · factor / limit − 1) is not decided by the windows'
#: bounds: they are computed another way than the pass (equal to round-off where the window reaches
#: the route's start), so the pass's own verdict there could go either way
WINDOW_SLACK = 1e-9

#: a route oracle's counts, as :meth:`RouteOracle.counts` gives them (summed over a domain's routes)
COUNTS = (
    "n_checks",
    "n_refuted",
    "n_short",
    "n_before_seen",
    "n_met_below",
    "keyframes_passed",
    "n_accepted",
    "n_base_passes",
)


def _first_keyframes(problem: Problem) -> np.ndarray:
    """(n_sensors,) the first keyframe at which each sensor of ``problem``'s library measures a
    landmark (the route's keyframe count where it measures none)."""
    n = problem.scenario.n_poses
    return np.array([int(np.min(o.pose)) if len(o) else n for o in problem.observations], np.int64)
