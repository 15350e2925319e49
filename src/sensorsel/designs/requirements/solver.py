"""The cheapest suite that meets a requirement, proved optimal by an implicit hitting set.

The problem: over the suites S a :class:`~sensorsel.model.constraints.FeasibleSet` allows
(packing rows ``A x <= b``, required sensors in, excluded ones out),

    minimise  cost(S) = Σ_{i ∈ S} price_i        (row 0 of A: the prices [$], owned sensors 0)
    such that meets(S minus F) for every F ⊆ S with |F| <= α      (α = ``failures``)

**Monotone requirements** (accuracy: a sensor added only lowers every marginal variance, so
S ⊆ T and meets(S) imply meets(T)). Only the largest failure sets matter, |F| = min(α, |S|). A
set M that fails rules out every suite T with |T minus M| <= α (losing the sensors of T outside M
leaves a subset of M, which fails too), so every suite that meets the requirement after α failures
satisfies the linear *cut*

    Σ_{i ∉ M} x_i >= α + 1.

The larger M, the stronger the cut: a failing set is grown to a *maximal* failing set (no sensor
can be added to it while it still fails) before it becomes a cut.

**Requirements that are not monotone** (integrity: a sensor added brings measurements that can be
associated with the wrong landmark). The requirement is a full check ``meets(S)`` with no
structure, plus optional *relaxations*, necessary conditions of it (meets(S) implies each):

- a *monotone* one, ``down`` (if S fails it, every subset of S fails it): a set M that fails it
  gives the cut Σ_{i ∉ M} x_i >= α + 1 as above (a suite T with |T minus M| <= α loses T minus M
  and keeps T ∩ M ⊆ M, which fails ``down`` and so fails ``meets``); M is grown to a maximal
  failing set of ``down``;
- an *anti-monotone* one, ``up`` (if S fails it, every superset of S fails it): a set m that
  fails it gives the cut Σ_{i ∈ m} x_i <= |m| - 1 (a suite T ⊇ m fails ``up`` with no sensor
  lost, so it fails ``meets``); m is shrunk to a minimal failing set of ``up``;
- a suite that passes both but fails ``meets`` (itself, or after some |F| <= α failures, every
  such F is checked, none skipped: losing a sensor may *help* a requirement that is not monotone)
  gets a *no-good*: Σ_{i ∈ S} x_i - Σ_{i ∉ S} x_i <= |S| - 1, excluding exactly that suite.

**The property the proof uses**: every suite that meets the requirement after α failures
satisfies every cut and every no-good (each excludes only suites shown to fail). So the optimum of
the integer program over the feasible set's rows and all cuts is a lower bound on the cost of any
suite that meets the requirement, whatever its structure; monotonicity only makes the cuts strong.

**The method** (an implicit hitting set):

1. One check of every allowed sensor together: if even that fails (``meets``, or ``down`` when the
   requirement is not monotone), no suite meets the requirement ("infeasible", by "library").
   First a cheap bound (``refute``: the smoother's marginals, under the filter's) is asked of
   them, before step 2: where it refutes them, the search ends there, without the greedy's
   suites. The check itself is asked after step 2, and only where it found no suite (a suite
   that meets the requirement shows that every allowed sensor together does: monotonicity).
2. Upper bound (monotone requirements with a ``violation``): a greedy that adds the sensor
   removing the most violation per dollar (lazily) until the suite meets the requirement after α
   failures, then prunes every sensor that is not needed (most expensive first).
3. Lower bound: a min-cost integer program (scipy's ``milp``, HiGHS) over the feasible set's rows
   and every cut so far; its optimum is a lower bound, its optimal suite the next *proposal*: if
   the proposal meets the requirement after α failures it is optimal (its cost equals the lower
   bound); otherwise a cut (or no-good) that the proposal violates is added. No proposal repeats,
   so the loop ends: proved optimal, "infeasible" when the integer program has no solution, or
   "gap" at ``max_iterations`` / ``time_limit`` with both bounds reported.
4. When the integer program proposes a second failing suite of one cost (a plateau: many suites of
   sensors of one price), that proposal is completed greedily, for a suite near the lower bound
   early (so the search ends when the bound reaches it, not after every suite of that cost).
   With a ``violation_floor`` (a cheaper lower bound on the violation), such a completion caps a
   candidate's lazy bound by its floor before computing its violation, and a suite whose floor is
   above 0 is known to fail, and it stops (no suite) once its suite, still failing, costs at least
   the lower bound plus :data:`COMPLETION_GAP_SHARE` of the gap to the upper bound: a completion
   that ends above that closes little of the gap, and its last steps are its dearest (on KITTI 00 at
   local streets, four completions asked 215 violations, 41 s, for suites of $7,319-8,816 against
   an answer of $4,000). The first greedy asks every candidate's violation: what it learns
   (the failing suites, each a cut) is what the first integer programs stand on.
   Once a suite of cost c is known, a sensor that alone with the required ones costs more than c
   is fixed out of the integer programs and of the growth of failing sets (no suite cheaper than
   c holds it): fewer checks per cut, smaller programs; the lower bound stays valid for every
   suite cheaper than c, which is all the proof needs.
   On such a plateau, once programs are dear (with failures, or once one needed branch and bound),
   the next proposal is first sought without a program: the last failing proposal with one sensor
   swapped for one of the same price outside it, if every row allows the result
   (:func:`.programs.plateau_swap`). Its cost is the lower bound proved on rows the next program's
   only add to, so it is an optimum of that program: the bound and the proof are unchanged, only
   which suite of that cost is checked next (measured: the fixtures' domain, local streets, 77 -> 56 s;
   the tour with one failure 41 -> 22 s). Where programs are cheap and no failure is allowed, HiGHS's
   own optimum was measured to lead to fewer checks (the tour: 374 against 732), so none is sought.
   Once a program needs branch and bound (:data:`.programs.FLOOR_AFTER_NODES` nodes), every later
   one carries the lower bound proved so far as a row, cost(x) >= lower: each program's rows only
   add to the last one's, so the row removes no suite any of them allows, and on a plateau HiGHS
   stops at the first suite it finds of that cost instead of proving it again.

**With failures** (α >= 1) every check of a suite is α + 1 or more, so the search asks fewer:

- *The floor without a sensor.* A suite S that meets the requirement after α failures and holds
  sensor i keeps, once i and α - 1 others fail, a suite without i that passes ``down`` (neither
  the feasible set's rows nor its required sensors bind what is left). So cost(S) >= price_i +
  f_i, where f_i, the *floor* without i, is the optimum of the integer program min cost(x) such
  that Σ_{j ∉ M} x_j >= 1 for every failing set M known, x_i = 0 and the sensors fixed out at 0
  (a lower bound on any suite that passes ``down`` without them; its dual bound where HiGHS stops
  at its node limit). A sensor with price_i + f_i above c is fixed out as above, with no check.
  One program gives f_i for every sensor outside its optimal suite, one more each for those
  inside; a sensor that a known passing set without it already caps costs none; they are
  recomputed when c or the sensors fixed out change or the failing sets known grow by a quarter.
- *Growth within the gap.* A failing set is grown only over the sensors no dearer than the gap
  between the best suite found and the lower bound: the cut of a failing set that is not maximal
  is still valid (the property below needs only that M fails), weaker only in sensors whose
  price alone closes the gap, and each sensor left out of the growth is a check saved (the
  checks of growth are of the largest suites, the dearest).
- *Several cuts per integer program.* When a proposal fails, every part of it left after α
  failures that is not known (neither inside a failing set known, nor holding a passing one) is
  checked, and each that fails is grown into a cut too: fewer programs, and the parts that pass
  become passing sets known (which answer later checks and cap the floors).
5. Ties: once proved, integer programs capped at the optimal cost and excluding the suites found
   look for other suites of that cost that meet it (at most ``max_tie_programs`` programs): the
   answer lists them, and says whether that search was exhaustive (the program ran out of suites).

**Checks are the expensive part** (each is a marginal computation per route), so every answer is
cached by suite and what a predicate's structure tells is inferred without a call
(:mod:`.oracle`). Growing a failing set tries blocks of sensors at once (halving a block that would
make it meet), cheapest sensors first so that the sensors left outside the cut are the expensive ones.

Determinism: every order is fixed (by price, then library position); HiGHS is deterministic; the
same inputs give the same answer. A ``time_limit`` makes the answer depend on the machine's speed
(use ``max_iterations`` for reproducible limits).
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from itertools import combinations

import numpy as np

from sensorsel.designs.requirements.dominance import dominance_order
from sensorsel.designs.requirements.failures import floors as _floors
from sensorsel.designs.requirements.failures import meets_after_failures
from sensorsel.designs.requirements.failures import more_cuts as _more_cuts
from sensorsel.designs.requirements.oracle import AntiMonotone, Exact, Monotone, mask_of, suite_of
from sensorsel.designs.requirements.programs import MILP_NODE_LIMIT, Solved
from sensorsel.designs.requirements.programs import plateau_swap as _plateau_swap
from sensorsel.designs.requirements.programs import propose as _propose
from sensorsel.designs.requirements.programs import tol as _tol
from sensorsel.io.progress import Progress, report
from sensorsel.model.constraints import FeasibleSet

__all__ = [
    "DEFAULT_MAX_ITERATIONS",
    "DEFAULT_TIE_PROGRAMS",
    "MILP_NODE_LIMIT",
    "STATUSES",
    "CheapestSuite",
    "Meets",
    "Suite",
    "Violation",
    "cheapest_suite",
    "meets_after_failures",
]

#: a canonical suite: sorted tuple of unique library positions (the same alias as
#: ``sensorsel.information.evaluators.Suite``; the solver needs no evaluator, only a predicate).
Suite = tuple[int, ...]
#: meets(suite) -> bool.
Meets = Callable[[Suite], bool]
#: violation(suite) -> float >= 0, 0 exactly when meets(suite): how far the suite is from meeting.
Violation = Callable[[Suite], float]
#: status(text): the search in words after each integer program (cost interval, checks, time)
Status = Callable[[str], None]

#: the statuses of a :class:`CheapestSuite`
STATUSES = ("optimal", "gap", "infeasible")
#: integer programs solved (rounds of the hitting set) before stopping with a gap
DEFAULT_MAX_ITERATIONS = 1000

#: a completion capped by a violation floor stops once its failing suite costs at least the lower
#: bound plus this share of the gap to the upper bound (module docstring, step 4). Measured against
#: no such stop (accuracy computations, each search proved the same cost): KITTI 00 local streets
#: 39 -> 19 (and its completions' violations 41 s -> 11 s), freeway 120 -> 110; the seven KITTI
#: routes 227 -> 197 (local streets) and 144 -> 130 (freeway); Helsinki 377 -> 382 and the user's
#: drive 174 -> 198, which the completions' learning served. At the upper bound itself (a completion
#: stopped only where it cannot beat the incumbent before its pruning): 29, 201, 382 and 174, but
#: KITTI 00's completions still took 30 s (docs/guide-requirements.md).
COMPLETION_GAP_SHARE = 0.5
#: integer programs spent looking for other suites of the optimal cost once it is proved
DEFAULT_TIE_PROGRAMS = 4
#: the greedy tells ``look_ahead`` of the candidate it asks and this many of the next ones of its
#: lazy queue (the caller gives out as many as it has idle places for)
LOOK_AHEAD = 8

_mask, _suite = mask_of, suite_of


class _OutOfTime(Exception):
    """The time limit is spent: raised before a check, so that no step of the search (the greedy,
    the growth of a failing set, the parts checked after failures) runs past it."""


@dataclass(frozen=True)
class CheapestSuite:
    """The cheapest suite that meets a requirement after ``failures`` sensor failures.

    Attributes:
        suite: the cheapest suite found that meets it after any ``failures`` sensors fail (sorted
            library positions); None when none was found (status "infeasible", or "gap" with no
            suite found before the limits).
        cost: its cost [$] (prices of row 0 of the feasible set: owned sensors count 0); inf when
            ``suite`` is None.
        lower_bound: no suite the feasible set allows meets the requirement for less [$]; equals
            ``cost`` when proved optimal, inf when proved infeasible.
        proved: the answer is proved: optimal (``cost == lower_bound``) or infeasible.
        gap: ``cost - lower_bound`` [$] (0 when proved, inf when no suite was found).
        iterations: integer programs solved (the search; the tie search's are ``tie_programs``).
        plateau_swaps: proposals found by a swap on a plateau instead of an integer program
            (:func:`~sensorsel.designs.requirements.programs.plateau_swap`).
        n_checks: calls of the predicates (each on a different suite; answers their structure
            gave are not calls).
        cuts: the failing sets behind the cuts Σ_{i ∉ M} x_i >= failures + 1, maximal among those
            found (with failures, grown over the sensors within the gap only), sorted.
        status: "optimal" (proved), "gap" (stopped at a limit: ``suite`` is the best found and
            ``lower_bound`` what was proved) or "infeasible" (proved: no suite meets it).
        failures: α, the failures the suite withstands.
        infeasible_by: for "infeasible", why: "library" (every allowed sensor together fails),
            "failures" (every allowed sensor meets it, but not after the sensors ``lost`` fail) or
            "limits" (no suite within the feasible set's rows meets it after the failures); "" otherwise.
        best_effort: for "infeasible", the suite whose accuracy shows by how much the requirement
            is missed: every allowed sensor ("library", "limits") or what is left of them after
            ``lost`` fail ("failures"); () otherwise.
        lost: for "infeasible" by "failures", the failing sensors (at most α); () otherwise.
        stop: why the search ended, in words.
        seconds: wall time [s] (the one field, with the two below, that differs between identical runs).
        seconds_checks: of which in the predicates [s].
        seconds_programs: of which in the integer programs [s].
        cuts_in: the failing sets m behind the cuts Σ_{i ∈ m} x_i <= |m| - 1 (anti-monotone
            relaxation), minimal among those found, sorted.
        nogoods: suites excluded one by one (they passed the relaxations and failed the full check).
        ties: other suites of the same cost that meet the requirement after the failures (found on
            the way or by the tie search), sorted.
        ties_exhaustive: the tie search ran out of suites of that cost: ``ties`` are all there are.
        tie_programs: integer programs of the tie search.
        fixed_out: sensors left out of the programs because with the required ones (with failures:
            or with the floor of the suites without them) they cost more than the best suite found.
        ordered: the dominance pairs (w, s) held as x_w <= x_s in the integer programs
            (:func:`~sensorsel.designs.requirements.dominance.dominance_order`), sorted.
        swap_inferred: answers inferred from a dominance swap instead of a call.
        programs_resumed: integer programs (of ``iterations``, the tie search's and the floors')
            whose answers were read back from ``programs_solved`` as an earlier run left them, not
            solved again.
    """

    suite: Suite | None
    cost: float
    lower_bound: float
    proved: bool
    gap: float
    iterations: int
    n_checks: int
    cuts: tuple[Suite, ...]
    status: str
    failures: int = 0
    infeasible_by: str = ""
    best_effort: Suite = ()
    lost: Suite = ()
    stop: str = ""
    seconds: float = 0.0
    seconds_checks: float = 0.0
    seconds_programs: float = 0.0
    cuts_in: tuple[Suite, ...] = ()
    nogoods: tuple[Suite, ...] = ()
    ties: tuple[Suite, ...] = ()
    ties_exhaustive: bool = False
    tie_programs: int = 0
    fixed_out: int = 0
    ordered: tuple[tuple[int, int], ...] = ()
    swap_inferred: int = 0
    plateau_swaps: int = 0
    programs_resumed: int = 0


class _Search:
    """The predicates, the feasible set and the state shared by the greedy, the growth of failing
    sets and the hitting-set loop.

    ``down`` is the monotone predicate (the requirement itself when it is monotone, else its
    monotone relaxation or None), ``up`` the anti-monotone relaxation or None, ``full`` the full
    check when the requirement is not monotone (None when it is: then ``down`` is the requirement)."""

    def __init__(
        self, feasible: FeasibleSet, alpha: int, down: Monotone | None, up: AntiMonotone | None, full: Exact | None
    ) -> None:
        self.fs = feasible
        self.alpha = alpha
        self.down, self.up, self.full = down, up, full
        n = len(feasible.library)
        self.n = n
        self.price = np.asarray(feasible.A[0], dtype=float) if n else np.zeros(0)
        self.required = _mask(feasible.required)
        self.allowed = [i for i in range(n) if i not in feasible.excluded]
        self.universe = _mask(self.allowed)
        # fixed orders: cheapest first for growing failing sets (the expensive sensors stay outside
        # the cut, which raises the lower bound most), most expensive first for failures and pruning
        self.cheap_first = sorted(self.allowed, key=lambda i: (self.price[i], i))
        self.dear_first = sorted(self.allowed, key=lambda i: (-self.price[i], i))
        self.fixed_out = 0  # sensors no suite cheaper than the best found holds
        self.floors_from: tuple[float, int, int] = (math.nan, 0, 0)  # what the floors were last computed from
        self.floor_values: dict[int, float] = {}  # sensor -> floor of the suites without it [$] (failures)
        self.lower, self.upper = 0.0, math.inf  # the bounds [$] at the last program: failing sets grow within the gap
        self.nogoods: list[int] = []
        self.met: dict[int, float] = {}  # suites shown to meet the requirement after the failures: cost
        self.orders: tuple[tuple[int, int], ...] = ()  # (w, s): x_w <= x_s in the integer programs (dominance)
        #: an integer program needed branch and bound (programs.FLOOR_AFTER_NODES): the later ones carry
        #: the proved lower bound as a row
        self.hard = False
        #: called before each floor's integer program (raises once the time limit is spent)
        self.before_program: Callable[[], None] = _nothing
        #: the integer programs' answers by key (:func:`.programs._solve`), those of ``resumed_from``
        #: read back from a journal, ``programs_resumed`` of them used so far
        self.solved: dict[str, Solved] = {}
        self.resumed_from: frozenset[str] = frozenset()
        self.programs_resumed = 0

    @property
    def monotone(self) -> bool:
        return self.full is None

    def predicates(self) -> list[Monotone | AntiMonotone | Exact]:
        return [p for p in (self.down, self.up, self.full) if p is not None]

    def n_checks(self) -> int:
        return sum(p.calls for p in self.predicates())

    def seconds_checks(self) -> float:
        return sum(p.seconds for p in self.predicates())

    def cost(self, mask: int) -> float:
        return float(sum(self.price[i] for i in _suite(mask)))

    def fits(self, mask: int) -> bool:
        return self.fs.fits(_suite(mask))

    def fix_above(self, upper: float, programs: list[float] | None = None) -> None:
        """Fix out every sensor that no suite of cost ``upper`` [$] or less holds: with the required
        ones it costs more than ``upper``; with failures (α >= 1, ``programs`` given), also one
        whose price plus the floor of the suites without it costs more (module docstring, step 4)."""
        base = self.cost(self.required)
        floors = _floors(self, upper, programs) if self.alpha and programs is not None else {}
        for i in self.allowed:
            if not self.required >> i & 1 and max(base, floors.get(i, -math.inf)) + self.price[i] > upper + _tol(upper):
                self.fixed_out |= 1 << i

    def _fails(self, rest: int) -> bool:
        """``rest`` fails the requirement (monotone: ``down``; else a relaxation or the full check)."""
        if self.monotone:
            assert self.down is not None
            return not self.down.passes(rest)
        return any(not p.passes(rest) for p in self.predicates())

    def failing_part(self, mask: int) -> int | None:
        """A subset S minus F (|F| <= α) that fails, or None when ``mask`` meets the requirement
        after any α failures (then recorded in ``met``). Monotone: only |F| = min(α, |S|), known
        answers first, then calls (the most expensive sensors fail first: losing them is likeliest
        to break the requirement). Otherwise every F, smallest first."""
        found = self._failing_part(mask)
        if found is None:
            self.met[mask] = self.cost(mask)
        return found

    def _failing_part(self, mask: int) -> int | None:
        members = [i for i in self.dear_first if mask >> i & 1]
        if not self.monotone:
            for k in range(min(self.alpha, len(members)) + 1):
                for f in combinations(members, k):
                    rest = mask & ~_mask(f)
                    if self._fails(rest):
                        return rest
            return None
        assert self.down is not None
        if not self.down.passes(mask):
            return mask
        k = min(self.alpha, len(members))
        if k == 0:
            return None
        rests = [mask & ~_mask(f) for f in combinations(members, k)]
        for rest in rests:
            if self.down.infer(rest) is False:
                return rest
        for rest in rests:
            if not self.down.passes(rest):
                return rest
        return None

    def cut(self, proposal: int, part: int) -> None:
        """Add what rules out ``proposal``, whose part ``part`` failed: a grown cut when a
        relaxation (or the monotone requirement) fails, else a no-good of the proposal."""
        if self.down is not None and self.down.infer(part) is False:
            self.grow(part)
        elif self.up is not None and self.up.infer(part) is False:
            self.shrink(part)
        else:
            self.nogoods.append(proposal)

    def grow(self, mask: int) -> int:
        """A maximal failing set of ``down`` holding its failing set ``mask`` (among the sensors not
        fixed out), by galloping over the remaining sensors, cheapest first: a block that keeps the
        set failing is added and the next block is twice as long; a block that makes it pass is
        tried again from its first sensor alone, and a single sensor that makes it pass stays out
        (monotonicity keeps it so as the set grows: the result is maximal). Mostly sensors that
        make it pass cost one check each; long runs that keep it failing, a logarithmic number."""
        assert self.down is not None
        rest = [i for i in self.cheap_first if not mask >> i & 1 and not self.fixed_out >> i & 1]
        if self.alpha and math.isfinite(self.upper):  # failures: only over the sensors that fit in the gap
            rest = [i for i in rest if self.price[i] <= self.upper - self.lower + _tol(self.upper)]
        at, size = 0, 1
        while at < len(rest):
            block = _mask(rest[at : at + size])
            if not self.down.passes(mask | block):
                mask |= block
                at += size
                size *= 2
            elif size == 1:
                at += 1
            else:
                size = 1
        return mask

    def shrink(self, mask: int) -> int:
        """A minimal failing set of ``up`` inside its failing set ``mask``: each sensor (most
        expensive first) is dropped while the rest still fails (anti-monotonicity keeps a sensor
        that was needed needed as the set shrinks, so the result is minimal)."""
        assert self.up is not None
        for i in self.dear_first:
            if mask >> i & 1 and not self.up.passes(mask & ~(1 << i)):
                mask &= ~(1 << i)
        return mask

    def refuted_cheaply(self, refute: Callable[[Suite], bool], mask: int) -> bool:
        """Whether ``refute`` (a cheap bound: :func:`cheapest_suite`) shows that ``mask`` fails the
        monotone requirement ``down``: then recorded as its answer and counted as a call; where it
        shows nothing, only its time is counted (the search goes on as without it)."""
        down = self.down
        if not self.monotone or down is None:
            return False
        if down.before_call is not None:  # the solver's clock, read before every check
            down.before_call()
        t = time.perf_counter()
        refuted = bool(refute(_suite(mask)))
        down.seconds += time.perf_counter() - t
        if refuted:
            down.calls += 1
            down.record(mask, False)
        return refuted

    def greedy(self, start: int | None = None, capped: bool = False, limit: float = math.inf) -> int | None:
        """Violation removed per dollar, lazily, from ``start`` (the required sensors when None)
        until the suite meets the requirement after α failures (each step improves the failing part
        S minus F); then every sensor not needed is pruned. None when it gets stuck (nothing fits
        or nothing lowers the violation). ``capped`` (with a violation floor): a candidate's lazy
        bound is capped by its floor before its violation is asked, and the violation is asked only
        where the cap leaves it on top. ``limit`` [$]: None too once the suite, still failing, costs
        that much (before the step's violations are asked)."""
        assert self.down is not None
        suite = self.required if start is None else start
        bound = {i: math.inf for i in self.allowed if not suite >> i & 1 and not self.fixed_out >> i & 1}
        while True:
            part = self.failing_part(suite)
            if part is None:
                return self.prune(suite)
            if math.isfinite(limit) and self.cost(suite) >= limit - _tol(limit):
                return None  # it could not close enough of the gap: not worth its violations
            base = self.down.violation(part)
            used = self.fs.usage(_suite(suite))
            fits = self.fs.addable(used)
            cands = [i for i in bound if fits[i]]
            fresh: set[int] = set()
            # this step's upper bounds on a candidate's ratio from the violation's floor: from the same
            # lazy bounds, the step chooses what it would without them, asking fewer violations (a
            # stale bound below the true ratio stays the key); the bounds it hands to the next step
            # are then fewer refreshed, so later choices can differ
            cap: dict[int, float] = {}
            choice = None
            while cands:
                cands.sort(key=functools.partial(_lazy_key, bound, fresh, cap))
                top = cands[0]
                if top in fresh:
                    choice = top
                    break
                if capped and top not in cap and self.down.has_floor:
                    cap[top] = _ratio(base - self.down.violation_floor(part | 1 << top), float(self.price[top]))
                    if cap[top] < bound[top]:
                        continue
                # this violation and the next candidates', likely asked after it: those after it
                # computed meanwhile where the caller has places to spare (the same answers, asked
                # in the same order)
                self.down.look_ahead(part | 1 << c for c in cands[: 1 + LOOK_AHEAD] if c not in fresh)
                drop = base - self.down.violation(part | 1 << top)
                bound[top] = _ratio(drop, float(self.price[top]))
                fresh.add(top)
            if choice is None or bound[choice] <= 0:
                return None
            suite |= 1 << choice
            del bound[choice]

    def prune(self, mask: int, only_free: bool = False) -> int:
        """Drop every sensor (most expensive first; required ones stay) whose loss still leaves a
        suite that meets the requirement after α failures; ``only_free``: only sensors that cost 0."""
        for i in self.dear_first:
            if not mask >> i & 1 or self.required >> i & 1 or (only_free and self.price[i] > 0):
                continue
            if self.failing_part(mask & ~(1 << i)) is None:
                mask &= ~(1 << i)
        return mask


def _nothing() -> None:
    pass


def _lazy_key(bound: dict[int, float], fresh: set[int], cap: dict[int, float], i: int) -> tuple[float, int]:
    """The greedy's order of candidate ``i``: its ratio where computed this step, else the least of
    its lazy bound and its floor's cap; the first in library order among ties."""
    return (-(bound[i] if i in fresh else min(bound[i], cap.get(i, math.inf))), i)


def _ratio(drop: float, price: float) -> float:
    if drop <= 0:
        return 0.0
    return math.inf if price <= 0 else drop / price


def cheapest_suite(
    feasible: FeasibleSet,
    meets: Meets,
    *,
    failures: int = 0,
    violation: Violation | None = None,
    violation_floor: Violation | None = None,
    monotone: bool = True,
    necessary_monotone: Meets | None = None,
    necessary_antimonotone: Meets | None = None,
    max_iterations: int = DEFAULT_MAX_ITERATIONS,
    time_limit: float | None = None,
    progress: Progress | None = None,
    max_tie_programs: int = DEFAULT_TIE_PROGRAMS,
    dominance: Sequence[tuple[int, int]] = (),
    refute: Callable[[Suite], bool] | None = None,
    clock: Callable[[], float] = time.monotonic,
    programs_solved: dict[str, Solved] | None = None,
    look_ahead: Callable[[list[Suite]], None] | None = None,
) -> CheapestSuite:
    """The cheapest suite of ``feasible`` that meets a requirement after any ``failures`` of its
    sensors fail, with a lower bound on the cost of every such suite (module docstring).

    Args:
        feasible: the suites allowed (rows ``A x <= b``, required and excluded sensors); row 0's
            prices are the cost [$] (owned sensors 0). A budget row with an infinite limit limits nothing.
        meets: meets(suite) -> bool; called on sorted tuples of library positions (the empty
            suite included), at most once per suite.
        failures: α >= 0, the sensors that may fail (any α of the suite's, required ones included).
        violation: with a monotone ``meets``: violation(suite) -> float >= 0, 0 exactly when
            meets(suite): the greedy upper bound needs it (without it the integer program alone
            finds the suites). Where the solver has called it, it does not call ``meets`` on that suite.
        violation_floor: with ``violation``: a lower bound on it (<= violation(suite) at every suite)
            that costs less, or None. The greedy completions of a plateau's proposals (step 4) ask it
            of a candidate before its violation and skip the candidates whose floor shows they cannot
            be the step's choice: fewer violations computed.
        monotone: ``meets`` is monotone (S ⊆ T and meets(S) imply meets(T)). False: nothing is
            inferred from its answers; give the relaxations below to make the cuts strong.
        necessary_monotone: with ``monotone=False``, a monotone necessary condition of ``meets``
            (meets(S) implies it; if S fails it every subset does), or None.
        necessary_antimonotone: with ``monotone=False``, an anti-monotone necessary condition of
            ``meets`` (meets(S) implies it; if S fails it every superset does), or None.
        max_iterations: integer programs solved before stopping with a gap (>= 1).
        time_limit: wall-clock seconds before stopping with a gap (None: none; makes the answer
            depend on the machine). The clock is read before every check and every integer program
            (the greedy and the growth of failing sets included): the search stops, with the best
            suite shown to meet and the lower bound proved so far, within one check of the limit.
        progress: progress(iterations done, max_iterations) before each integer program, told where
            the search stands (:func:`sensorsel.io.progress.report`): the cost interval [lower
            bound, best found] closing, integer programs solved, suites checked.
        max_tie_programs: integer programs spent, once the answer is proved, looking for other
            suites of the same cost (0: none; ties found on the way are still reported).
        dominance: with a monotone ``meets``, pairs (w, s) of positions where a suite with s in
            place of w meets the requirement whenever the suite with w does
            (:mod:`~sensorsel.designs.requirements.dominance`): answers are inferred from them, and
            the pairs :func:`~sensorsel.designs.requirements.dominance.dominance_order` keeps become
            rows x_w <= x_s of the integer programs (the cheapest cost unchanged; ties among them
            are then not searched exhaustively).
        refute: with a monotone ``meets``: refute(suite) -> True where a cheap bound shows that
            the suite fails ``meets`` (False: not shown), asked of every allowed sensor together
            before the greedy: a requirement nothing meets is then answered without the greedy's
            suites (its answer is the library's check's: infeasible). Not counted as a call where it
            refutes nothing, so a search that goes on is the search without it.
        clock: the clock ``time_limit`` is measured on [s] (``time.monotonic``; a test passes one
            that advances per reading, so that the limit falls after a known number of checks).
        look_ahead: with ``violation``: look_ahead(suites), told before a violation is computed of
            that suite and of those whose violations the greedy likely asks next, in order (the
            next candidates of its lazy queue), so that a caller with places to spare computes the
            later ones meanwhile. It must not change any answer (nothing is recorded of it); None:
            nothing told.
        programs_solved: the integer programs' answers by key (:data:`~.programs.Solved`), shared with the
            caller: what it holds on entry (a resumed run's journal) answers those programs when the
            search poses them again, and every program solved is added (the journal's next write).

    Returns:
        A :class:`CheapestSuite`.

    Raises:
        ValueError: ``failures`` < 0 or ``max_iterations`` < 1 (a caller's bug; the CLI checks
            its options first), relaxations given for a monotone requirement, or a violation that
            is negative or not finite.
    """
    if isinstance(failures, bool) or not isinstance(failures, (int, np.integer)) or failures < 0:
        raise ValueError(f"failures must be a whole number >= 0, got {failures!r}")
    if max_iterations < 1:
        raise ValueError(f"max_iterations must be >= 1, got {max_iterations!r}")
    if monotone and (necessary_monotone is not None or necessary_antimonotone is not None):
        raise ValueError("relaxations are for a requirement that is not monotone: pass monotone=False")
    if dominance and not monotone:
        raise ValueError("dominance is for a monotone requirement")
    if violation_floor is not None and violation is None:
        raise ValueError("a violation floor bounds a violation: pass violation too")
    start = clock()
    alpha = int(failures)
    n = len(feasible.library)
    if monotone:
        s = _Search(
            feasible,
            alpha,
            Monotone(n, meets, violation, swaps=dominance, floor=violation_floor, look_ahead=look_ahead),
            None,
            None,
        )
        s.orders = dominance_order(feasible, dominance)
    else:
        s = _Search(
            feasible,
            alpha,
            None if necessary_monotone is None else Monotone(n, necessary_monotone),
            None if necessary_antimonotone is None else AntiMonotone(n, necessary_antimonotone),
            Exact(n, meets),
        )
    if programs_solved is not None:  # shared with the caller (its journal), and what it holds read back
        s.solved, s.resumed_from = programs_solved, frozenset(programs_solved)
    programs = [0.0, 0]  # seconds in integer programs, tie programs
    if time_limit is not None:
        seconds = float(time_limit)

        def before_call() -> None:
            if clock() - start >= seconds:
                raise _OutOfTime

        for p in s.predicates():
            p.before_call = before_call
        s.before_program = before_call

    def result(
        status_: str,
        suite: int | None,
        lower: float,
        iterations: int,
        stop: str,
        *,
        by: str = "",
        best_effort: int = 0,
        lost: int = 0,
        ties: Sequence[int] = (),
        exhaustive: bool = False,
    ) -> CheapestSuite:
        cost = s.cost(suite) if suite is not None else math.inf
        proved = status_ != "gap"
        if status_ == "optimal":
            lower = cost
        gap = cost - lower if suite is not None else math.inf
        cuts = tuple(sorted(_suite(f) for f in s.down.failing.masks)) if s.down is not None else ()
        cuts_in = tuple(sorted(_suite(f) for f in s.up.failing.masks)) if s.up is not None else ()
        return CheapestSuite(
            _suite(suite) if suite is not None else None,
            cost,
            lower,
            proved,
            gap,
            iterations,
            s.n_checks(),
            cuts,
            status_,
            alpha,
            by,
            _suite(best_effort) if status_ == "infeasible" else (),
            _suite(lost),
            stop,
            clock() - start,
            s.seconds_checks(),
            programs[0],
            cuts_in,
            tuple(sorted(_suite(g) for g in s.nogoods)),
            tuple(sorted(_suite(t) for t in ties)),
            exhaustive and not tied_orders,
            int(programs[1]),
            bin(s.fixed_out).count("1"),
            s.orders,
            s.down.swap_inferred if s.down is not None else 0,
            swaps_used,
            s.programs_resumed,
        )

    # a tie search under rows x_w <= x_s cannot see suites with w in place of an equally priced s
    tied_orders = any(abs(s.price[w] - s.price[v]) <= _tol(s.price[w]) for w, v in s.orders)

    incumbent: int | None = None
    upper = math.inf
    lower = 0.0 if not s.required else s.cost(s.required)
    iterations = 0
    plateau: dict[float, int] = {}  # failing proposals per cost [$]
    last: int | None = None  # the last proposal, failed
    swaps_used = 0
    stop = ""
    try:
        # 1a. every allowed sensor together, where a cheap bound refutes it: no greedy over a
        # requirement no suite meets (on KITTI 00 it grew 389 suites, 27 s, before step 1 said so)
        hopeless = refute is not None and s.refuted_cheaply(refute, s.universe)
        # 2. the greedy upper bound (its failing suites are the first cuts)
        if violation is not None and s.monotone and not hopeless:
            incumbent = s.greedy()
        if incumbent is not None and not s.fits(incumbent):  # the greedy only adds what fits: a guard
            incumbent = None
        # 1. every allowed sensor together: the most any suite achieves (monotone, or its monotone
        # relaxation). Asked only where the greedy found no suite: a suite that meets the
        # requirement after α failures passes ``down``, and so does every suite holding it (a
        # pass of every sensor on every route was ~a tenth of the Helsinki sample's run)
        if hopeless or (incumbent is None and s.down is not None and not s.down.passes(s.universe)):
            return result(
                "infeasible",
                None,
                math.inf,
                0,
                "every allowed sensor together fails",
                by="library",
                best_effort=s.universe,
            )
        upper = s.cost(incumbent) if incumbent is not None else math.inf
        if incumbent is not None:
            s.fix_above(upper)

        # 3. the hitting-set loop
        while True:
            report(progress, iterations, max_iterations, _status_text(lower, upper, iterations, s.n_checks()))
            if incumbent is not None and upper - lower <= _tol(upper):
                return _ties(s, incumbent, iterations, max_tie_programs, programs, start, time_limit, result, clock)
            if iterations >= max_iterations:
                stop = f"iteration limit ({max_iterations} integer programs)"
                break
            left = None if time_limit is None else time_limit - (clock() - start)
            if left is not None and left <= 0:
                stop = f"time limit ({time_limit:g} s)"
                break
            if s.alpha and incumbent is not None:
                s.fix_above(upper, programs)  # the floor rises with the cuts: fewer sensors to grow over
            # on a plateau, where programs are dear (failures, or branch and bound needed), a swap of
            # the last failing proposal that every row allows is an optimum of the next program
            swapped = _plateau_swap(s, last, lower) if last is not None and (s.alpha or s.hard) else None
            if swapped is not None:
                solved: tuple[float, int | None, bool] | None = (lower, swapped, True)
                swaps_used += 1
            else:
                solved = _propose(s, left, programs, floor=lower)
                iterations += 1
            if solved is None:  # no suite within the rows satisfies every cut: none meets the requirement
                if incumbent is not None:  # every suite cheaper than the incumbent is ruled out
                    return _ties(s, incumbent, iterations, max_tie_programs, programs, start, time_limit, result, clock)
                return _infeasible(s, result, iterations)
            bound, proposal, finished = solved
            lower = max(lower, bound)
            s.lower, s.upper = lower, upper
            if proposal is None:
                stop = "the integer program stopped at its node limit without a suite"
                break
            if not s.fits(proposal):  # HiGHS's tolerances let a suite past a limit: rule out just that suite
                s.nogoods.append(proposal)
                continue
            part = s.failing_part(proposal)
            if part is None:
                if s.cost(proposal) < upper - _tol(upper) or incumbent is None:
                    incumbent = s.prune(proposal, only_free=finished)
                    upper = s.cost(incumbent)
                    s.fix_above(upper)
                continue  # when the proposal is the integer program's optimum, the bounds now meet
            s.cut(proposal, part)
            last = proposal
            if s.alpha and s.monotone:
                _more_cuts(s, proposal)
            c = round(s.cost(proposal), 6)
            plateau[c] = plateau.get(c, 0) + 1
            if violation is not None and s.monotone and plateau[c] == 2 and c < upper - _tol(upper):
                # a second failing suite of the same cost: the lower bound is on a plateau of suites of
                # one price (sensors of one model); complete this one greedily, for a suite close to it
                give_up = (
                    lower + COMPLETION_GAP_SHARE * (upper - lower)
                    if s.down is not None and s.down.has_floor
                    else math.inf
                )
                done = s.greedy(proposal, capped=True, limit=give_up)
                if done is not None and s.fits(done) and s.cost(done) < upper - _tol(upper):
                    incumbent, upper = done, s.cost(done)
                    s.fix_above(upper)
    except _OutOfTime:  # a check was due past the limit: the best suite shown to meet so far
        stop = f"time limit ({time_limit:g} s)"
        shown = sorted((c, _suite(m), m) for m, c in s.met.items() if s.fits(m))
        if shown and (incumbent is None or shown[0][0] < upper - _tol(upper)):
            upper, _, incumbent = shown[0]
    if incumbent is not None and upper - lower <= _tol(upper):
        return _ties(s, incumbent, iterations, max_tie_programs, programs, start, time_limit, result, clock)
    return result(
        "gap",
        incumbent,
        min(lower, upper),
        iterations,
        stop,
        ties=[
            m for m, c in s.met.items() if m != incumbent and incumbent is not None and abs(c - upper) <= _tol(upper)
        ],
    )


def _status_text(lower: float, upper: float, iterations: int, checks: int) -> str:
    """Where the search stands, in words: the interval the cheapest suite's cost [$] lies in (the
    progress display adds the time)."""
    interval = (
        f"cost in [${lower:,.0f}, ${upper:,.0f}]"
        if math.isfinite(upper)
        else f"cost >= ${lower:,.0f}, no suite found yet"
    )
    return f"{interval}; {iterations:,} integer programs, {checks:,} suites checked"


def _ties(
    s: _Search,
    incumbent: int,
    iterations: int,
    max_programs: int,
    programs: list[float],
    start: float,
    time_limit: float | None,
    result: Callable[..., CheapestSuite],
    clock: Callable[[], float],
) -> CheapestSuite:
    """The proved answer, with the other suites of its cost that meet the requirement: those met on
    the way, then those the integer program capped at that cost proposes (each proposal that fails
    gets its cut as in the search, and a no-good), until it has none left (exhaustive) or
    ``max_programs`` programs."""
    opt = s.cost(incumbent)
    ties = {m for m, c in s.met.items() if m != incumbent and abs(c - opt) <= _tol(opt) and s.fits(m)}
    exhaustive = False
    extra: list[int] = []
    while programs[1] < max_programs:
        left = None if time_limit is None else time_limit - (clock() - start)
        if left is not None and left <= 0:
            break
        solved = _propose(s, left, programs, cap=opt, exclude=[incumbent, *sorted(ties), *extra])
        programs[1] += 1
        if solved is None:
            exhaustive = True
            break
        proposal = solved[1]
        if proposal is None:
            break
        extra.append(proposal)
        try:
            if s.fits(proposal) and s.failing_part(proposal) is None:
                ties.add(proposal)
        except _OutOfTime:  # proved already: the tie search just ends, not exhaustive
            break
    return result(
        "optimal",
        incumbent,
        opt,
        iterations,
        "proved optimal: the lower bound reached the best suite found",
        ties=sorted(ties),
        exhaustive=exhaustive,
    )


def _infeasible(s: _Search, result: Callable[..., CheapestSuite], iterations: int) -> CheapestSuite:
    """The integer program has no solution: say whether the failures alone explain it (a failing
    set that misses at most α allowed sensors) or the limits do."""
    failing = s.down.failing.masks if s.down is not None else []
    for f in sorted(failing, key=lambda m: (bin(s.universe & ~m).count("1"), _suite(m))):
        lost = s.universe & ~f
        if bin(lost).count("1") <= s.alpha:
            return result(
                "infeasible",
                None,
                math.inf,
                iterations,
                f"every allowed sensor meets it, but not after {len(_suite(lost))} of them fail",
                by="failures",
                best_effort=f,
                lost=lost,
            )
    return result(
        "infeasible",
        None,
        math.inf,
        iterations,
        "no suite within the limits meets it" + (f" after {s.alpha} failure(s)" if s.alpha else ""),
        by="limits",
        best_effort=s.universe,
    )
