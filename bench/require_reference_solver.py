# The reference solver of `require` (the same implicit hitting set without the package's search
# speed-ups), kept so that bench/require.py can run both side by side (same answers; the package's
# makes fewer checks). Not imported by the package.
"""The cheapest suite that meets a monotone requirement, proved optimal by an implicit hitting set.

The problem: over the suites S a :class:`~sensorsel.model.constraints.FeasibleSet` allows
(packing rows ``A x <= b``, required sensors in, excluded ones out),

    minimise  cost(S) = Σ_{i ∈ S} price_i        (row 0 of A: the prices [$], owned sensors 0)
    such that meets(S minus F) for every F ⊆ S with |F| <= α      (α = ``failures``)

where ``meets`` is *monotone*: S ⊆ T and meets(S) imply meets(T) (a sensor added only lowers every
marginal variance). By monotonicity only the largest failure sets matter, |F| = min(α, |S|).

**Cuts.** A set M that fails (not meets(M)) rules out every suite T with |T minus M| <= α: losing
the sensors of T outside M leaves a subset of M, which fails too. So every suite that meets the
requirement after α failures satisfies the linear *cut*

    Σ_{i ∉ M} x_i >= α + 1.

The larger M, the stronger the cut: a failing set is grown to a *maximal* failing set (no sensor can
be added to it while it still fails) before it becomes a cut.

**The method** (an implicit hitting set):

1. One check of every allowed sensor together: if even that fails, no suite meets the requirement
   ("infeasible", by "library").
2. Upper bound: a greedy that adds the sensor removing the most *violation* per dollar (lazily:
   stale ratios are re-evaluated only when they come to the top) until the suite meets the
   requirement after α failures, then prunes every sensor that is not needed (most expensive
   first). Every failing suite it met is a cut.
3. Lower bound: a min-cost integer program (scipy's ``milp``, HiGHS) over the feasible set's rows
   and every cut so far. Every suite that meets the requirement satisfies all of them, so its
   optimum is a **lower bound on the cost of any suite that meets the requirement**. Its optimal
   suite is the next *proposal*: if the proposal meets the requirement after α failures it is
   optimal (its cost equals the lower bound); otherwise some S minus F fails, it is grown to a
   maximal failing set, and its cut (which the proposal violates) is added. No proposal repeats, so
   the loop ends: proved optimal when the lower bound reaches the best suite found, "infeasible"
   when the integer program has no solution (no suite within the limits meets the requirement), or
   "gap" at ``max_iterations`` / ``time_limit`` with both bounds reported.

**Checks are the expensive part** (each is a few log-det evaluations on a real route), so every
answer is cached by suite and monotonicity answers what it can without a call: a subset of a
failing set fails, a superset of a meeting set meets. Growing a failing set tries blocks of sensors
at once (halving a block that would make it meet), cheapest sensors first so that the sensors left
outside the cut are the expensive ones.

Determinism: every order is fixed (by price, then library position); HiGHS is deterministic; the
same inputs give the same answer. A ``time_limit`` makes the answer depend on the machine's speed
(use ``max_iterations`` for reproducible limits).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from itertools import combinations

import numpy as np

from sensorsel.io.files import quiet_stdout
from sensorsel.io.progress import Progress
from sensorsel.model.constraints import FeasibleSet

__all__ = [
    "DEFAULT_MAX_ITERATIONS",
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
#: meets(suite) -> bool, monotone: S ⊆ T and meets(S) imply meets(T).
Meets = Callable[[Suite], bool]
#: violation(suite) -> float >= 0, 0 exactly when meets(suite): how far the suite is from meeting.
Violation = Callable[[Suite], float]

#: the statuses of a :class:`CheapestSuite`
STATUSES = ("optimal", "gap", "infeasible")
#: integer programs solved (rounds of the hitting set) before stopping with a gap
DEFAULT_MAX_ITERATIONS = 1000
#: HiGHS's branch-and-bound node limit per integer program (deterministic, unlike a time limit)
MILP_NODE_LIMIT = 100_000
#: two costs closer than this [$] (plus a relative 1e-9) are equal: HiGHS's absolute gap is 1e-6
_COST_TOL = 1e-6
#: slack on a packing row relative to its limit, as the feasible set's (constraints.REL_SLACK)
_ROW_SLACK = 1e-9


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
        iterations: integer programs solved.
        n_checks: calls of ``meets`` or ``violation`` (each on a different suite; answers that
            monotonicity gave are not calls).
        cuts: the failing sets behind the cuts Σ_{i ∉ M} x_i >= failures + 1, maximal among those
            found (each one grown from a proposal is maximal in the library), sorted.
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
        seconds: wall time [s] (the one field that differs between identical runs).
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


class _Oracle:
    """The predicate, cached by suite, with monotone inference (suites as bit masks: bit i = position i).

    ``failing`` is an antichain of the maximal failing sets known, ``meeting`` one of the minimal
    meeting sets: a suite inside a failing set fails, a suite holding a meeting set meets.
    """

    def __init__(self, meets: Meets, violation: Violation | None) -> None:
        self._meets = meets
        self._violation = violation
        self.known: dict[int, bool] = {}
        self.viol: dict[int, float] = {}
        self.failing: list[int] = []
        self.meeting: list[int] = []
        self.n_checks = 0

    def infer(self, mask: int) -> bool | None:
        """What is known of ``mask`` without a call: True, False, or None (unknown)."""
        hit = self.known.get(mask)
        if hit is not None:
            return hit
        if any(mask & ~f == 0 for f in self.failing):
            return False
        if any(m & ~mask == 0 for m in self.meeting):
            return True
        return None

    def meets(self, mask: int) -> bool:
        known = self.infer(mask)
        if known is not None:
            return known
        self.n_checks += 1
        ok = bool(self._meets(_suite(mask)))
        self._record(mask, ok)
        return ok

    def violation(self, mask: int) -> float:
        """violation(S) (a call unless cached; 0 without a call when S is known to meet)."""
        if mask in self.viol:
            return self.viol[mask]
        if self.infer(mask) is True:
            return 0.0
        assert self._violation is not None
        self.n_checks += 1
        v = float(self._violation(_suite(mask)))
        if not math.isfinite(v) or v < 0:
            raise ValueError(f"violation{_suite(mask)} returned {v!r}: it must be a finite number >= 0")
        self.viol[mask] = v
        self._record(mask, v <= 0.0)
        return v

    def _record(self, mask: int, ok: bool) -> None:
        self.known[mask] = ok
        if ok:
            if not any(m & ~mask == 0 for m in self.meeting):
                self.meeting = [m for m in self.meeting if mask & ~m != 0] + [mask]
        elif not any(mask & ~f == 0 for f in self.failing):
            self.failing = [f for f in self.failing if f & ~mask != 0] + [mask]


def _mask(suite: Iterable[int]) -> int:
    m = 0
    for i in suite:
        m |= 1 << int(i)
    return m


def _suite(mask: int) -> Suite:
    out, i = [], 0
    while mask:
        if mask & 1:
            out.append(i)
        mask >>= 1
        i += 1
    return tuple(out)


class _Search:
    """State shared by the greedy, the growth of failing sets and the hitting-set loop."""

    def __init__(self, feasible: FeasibleSet, oracle: _Oracle, failures: int) -> None:
        self.fs = feasible
        self.oracle = oracle
        self.alpha = failures
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

    def cost(self, mask: int) -> float:
        return float(sum(self.price[i] for i in _suite(mask)))

    def fits(self, mask: int) -> bool:
        return self.fs.fits(_suite(mask))

    def failing_part(self, mask: int) -> int | None:
        """A subset S minus F (|F| = min(α, |S|)) that fails, or None when ``mask`` meets the
        requirement after any α failures. Known answers first, then calls (the most expensive
        sensors fail first: losing them is likeliest to break the requirement)."""
        if not self.oracle.meets(mask):
            return mask
        members = [i for i in self.dear_first if mask >> i & 1]
        k = min(self.alpha, len(members))
        if k == 0:
            return None
        rests = [mask & ~_mask(f) for f in combinations(members, k)]
        for rest in rests:
            if self.oracle.infer(rest) is False:
                return rest
        for rest in rests:
            if not self.oracle.meets(rest):
                return rest
        return None

    def grow(self, mask: int) -> int:
        """A maximal failing set holding the failing set ``mask``: blocks of the remaining allowed
        sensors (cheapest first) are added while the set still fails; a block that would make it
        meet is halved, down to single sensors, each of which then makes it meet (monotonicity
        keeps that true as the set grows, so the result is maximal)."""
        rest = [i for i in self.cheap_first if not mask >> i & 1]
        return self._grow(mask, rest)

    def _grow(self, mask: int, block: list[int]) -> int:
        if not block:
            return mask
        bigger = mask | _mask(block)
        if not self.oracle.meets(bigger):
            return bigger
        if len(block) == 1:
            return mask
        half = len(block) // 2
        return self._grow(self._grow(mask, block[:half]), block[half:])

    def greedy(self) -> int | None:
        """Violation removed per dollar, lazily, until the suite meets the requirement after α
        failures (each step improves the failing part S minus F); then every sensor not needed is
        pruned. None when it gets stuck (nothing fits or nothing lowers the violation)."""
        suite = self.required
        bound = {i: math.inf for i in self.allowed if not suite >> i & 1}
        while True:
            part = self.failing_part(suite)
            if part is None:
                return self.prune(suite)
            base = self.oracle.violation(part)
            used = self.fs.usage(_suite(suite))
            fits = self.fs.addable(used)
            cands = [i for i in bound if fits[i]]
            fresh: set[int] = set()
            choice = None
            while cands:
                cands.sort(key=lambda i: (-bound[i], i))
                top = cands[0]
                if top in fresh:
                    choice = top
                    break
                drop = base - self.oracle.violation(part | 1 << top)
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
    max_iterations: int = DEFAULT_MAX_ITERATIONS,
    time_limit: float | None = None,
    progress: Progress | None = None,
) -> CheapestSuite:
    """The cheapest suite of ``feasible`` that meets a monotone requirement after any ``failures``
    of its sensors fail, with a lower bound on the cost of every such suite (module docstring).

    Args:
        feasible: the suites allowed (rows ``A x <= b``, required and excluded sensors); row 0's
            prices are the cost [$] (owned sensors 0). A budget row with an infinite limit limits nothing.
        meets: meets(suite) -> bool, monotone; called on sorted tuples of library positions (the
            empty suite included), at most once per suite.
        failures: α >= 0, the sensors that may fail (any α of the suite's, required ones included).
        violation: violation(suite) -> float >= 0, 0 exactly when meets(suite) (e.g. the largest
            ratio of achieved to required error, minus 1, clipped at 0): the greedy upper bound
            needs it (without it the integer program alone finds the suites). Where the solver
            has called it, it does not call ``meets`` on that suite.
        max_iterations: integer programs solved before stopping with a gap (>= 1).
        time_limit: wall-clock seconds before stopping with a gap (None: none; makes the answer
            depend on the machine).
        progress: progress(iterations done, max_iterations) after each integer program.

    Returns:
        A :class:`CheapestSuite`.

    Raises:
        ValueError: ``failures`` < 0 or ``max_iterations`` < 1 (a caller's bug; the CLI checks
            its options first), or a violation that is negative or not finite.
    """
    if isinstance(failures, bool) or not isinstance(failures, (int, np.integer)) or failures < 0:
        raise ValueError(f"failures must be a whole number >= 0, got {failures!r}")
    if max_iterations < 1:
        raise ValueError(f"max_iterations must be >= 1, got {max_iterations!r}")
    start = time.monotonic()
    alpha = int(failures)
    oracle = _Oracle(meets, violation)
    s = _Search(feasible, oracle, alpha)

    def result(
        status: str,
        suite: int | None,
        lower: float,
        iterations: int,
        stop: str,
        *,
        by: str = "",
        best_effort: int = 0,
        lost: int = 0,
    ) -> CheapestSuite:
        cost = s.cost(suite) if suite is not None else math.inf
        proved = status != "gap"
        if status == "optimal":
            lower = cost
        gap = cost - lower if suite is not None else math.inf
        cuts = tuple(sorted(_suite(f) for f in oracle.failing))
        return CheapestSuite(
            _suite(suite) if suite is not None else None,
            cost,
            lower,
            proved,
            gap,
            iterations,
            oracle.n_checks,
            cuts,
            status,
            alpha,
            by,
            _suite(best_effort) if status == "infeasible" else (),
            _suite(lost),
            stop,
            time.monotonic() - start,
        )

    # 1. every allowed sensor together: the most any suite achieves
    if not oracle.meets(s.universe):
        return result(
            "infeasible", None, math.inf, 0, "every allowed sensor together fails", by="library", best_effort=s.universe
        )

    # 2. the greedy upper bound (its failing suites are the first cuts)
    incumbent = s.greedy() if violation is not None else None
    if incumbent is not None and not s.fits(incumbent):  # the greedy only adds what fits: a guard
        incumbent = None
    upper = s.cost(incumbent) if incumbent is not None else math.inf

    # 3. the hitting-set loop
    lower = 0.0 if not s.required else s.cost(s.required)
    nogoods: list[int] = []
    iterations = 0
    stop = ""
    while True:
        if incumbent is not None and upper - lower <= _tol(upper):
            return result(
                "optimal", incumbent, upper, iterations, "proved optimal: the lower bound reached the best suite found"
            )
        if iterations >= max_iterations:
            stop = f"iteration limit ({max_iterations} integer programs)"
            break
        left = None if time_limit is None else time_limit - (time.monotonic() - start)
        if left is not None and left <= 0:
            stop = f"time limit ({time_limit:g} s)"
            break
        solved = _propose(s, oracle.failing, nogoods, left)
        iterations += 1
        if progress is not None:
            progress(iterations, max_iterations)
        if solved is None:  # no suite within the rows satisfies every cut: none meets the requirement
            if incumbent is not None:  # cannot happen with valid cuts (the incumbent satisfies them)
                return result("optimal", incumbent, upper, iterations, "proved optimal: no cheaper suite is left")
            return _infeasible(s, oracle, result, iterations)
        bound, proposal, finished = solved
        lower = max(lower, bound)
        if proposal is None:
            stop = "the integer program stopped at its node limit without a suite"
            break
        if not s.fits(proposal):  # HiGHS's tolerances let a suite past a limit: rule out just that suite
            nogoods.append(proposal)
            continue
        part = s.failing_part(proposal)
        if part is None:
            if s.cost(proposal) < upper - _tol(upper) or incumbent is None:
                incumbent = s.prune(proposal, only_free=finished)
                upper = s.cost(incumbent)
            continue  # when the proposal is the integer program's optimum, the bounds now meet
        s.grow(part)
    if incumbent is not None and upper - lower <= _tol(upper):
        return result(
            "optimal", incumbent, upper, iterations, "proved optimal: the lower bound reached the best suite found"
        )
    return result("gap", incumbent, min(lower, upper), iterations, stop)


def _tol(cost: float) -> float:
    return _COST_TOL + 1e-9 * abs(cost) if math.isfinite(cost) else 0.0


def _infeasible(s: _Search, oracle: _Oracle, result: Callable[..., CheapestSuite], iterations: int) -> CheapestSuite:
    """The integer program has no solution: say whether the failures alone explain it (a failing
    set that misses at most α allowed sensors) or the limits do."""
    for f in sorted(oracle.failing, key=lambda m: (bin(s.universe & ~m).count("1"), _suite(m))):
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


def _propose(
    s: _Search, cuts: Sequence[int], nogoods: Sequence[int], time_left: float | None
) -> tuple[float, int | None, bool] | None:
    """min cost(x) over the feasible set's rows and every cut: (lower bound [$], the optimal suite
    or None, whether HiGHS proved it optimal), or None when no suite satisfies them all."""
    from scipy.optimize import Bounds, LinearConstraint, milp

    n, fs = s.n, s.fs
    if n == 0:
        return (0.0, 0, True) if not cuts else None
    lb = np.zeros(n)
    ub = np.zeros(n)
    ub[s.allowed] = 1.0
    lb[list(fs.required)] = 1.0
    rows = []
    finite = np.isfinite(fs.b)
    if finite.any():
        b = fs.b[finite]
        room = b + _ROW_SLACK * np.maximum(1.0, np.abs(b))
        scale = 1.0 / np.maximum(np.abs(room), 1e-12)  # rows ~1 so that dollars and counts are alike to HiGHS
        rows.append(LinearConstraint(fs.A[finite] * scale[:, None], -np.inf, room * scale))
    if cuts:
        out = np.array([[0.0 if f >> i & 1 else 1.0 for i in range(n)] for f in cuts])
        rows.append(LinearConstraint(out, s.alpha + 1, np.inf))
    for g in nogoods:  # Σ_{i ∉ g} x_i - Σ_{i ∈ g} x_i >= 1 - |g|: any suite but g
        sign = np.array([-1.0 if g >> i & 1 else 1.0 for i in range(n)])
        rows.append(LinearConstraint(sign[None, :], 1 - bin(g).count("1"), np.inf))
    options: dict[str, object] = {"node_limit": MILP_NODE_LIMIT, "mip_rel_gap": 0.0, "presolve": True, "disp": False}
    if time_left is not None:
        options["time_limit"] = max(time_left, 1e-3)
    with quiet_stdout():
        res = milp(s.price, integrality=np.ones(n), bounds=Bounds(lb, ub), constraints=rows, options=options)
    if res.status == 2:
        return None
    proposal = _mask(int(i) for i in np.flatnonzero(res.x > 0.5)) if res.x is not None else None
    dual = getattr(res, "mip_dual_bound", None)
    if res.status == 0 and res.fun is not None:
        bound = float(res.fun) if dual is None or not math.isfinite(dual) else min(float(res.fun), float(dual))
        return bound, proposal, True
    bound = float(dual) if dual is not None and math.isfinite(dual) else 0.0
    return bound, proposal, False


def meets_after_failures(meets: Meets, suites: Sequence[Iterable[int]], *, failures: int = 0) -> tuple[bool, ...]:
    """Which of ``suites`` (e.g. the suites of a Pareto front) meet a monotone requirement after any
    ``failures`` of their sensors fail, with the solver's cache and monotone inference (a suite
    holding one that meets, meets; one inside one that fails, fails), so a front of nested suites
    costs few calls.

    Args:
        meets: the monotone predicate.
        suites: suites as library positions.
        failures: α >= 0.

    Returns:
        One bool per suite, in order.
    """
    if isinstance(failures, bool) or not isinstance(failures, (int, np.integer)) or failures < 0:
        raise ValueError(f"failures must be a whole number >= 0, got {failures!r}")
    oracle = _Oracle(meets, None)
    alpha = int(failures)
    out = []
    for suite in suites:
        mask = _mask(suite)
        members = sorted(set(int(i) for i in suite))
        k = min(alpha, len(members))
        ok = oracle.meets(mask) and all(oracle.meets(mask & ~_mask(f)) for f in combinations(members, k))
        out.append(ok)
    return tuple(out)
