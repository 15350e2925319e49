"""The accuracy checks of ``require`` on a domain: each route's :class:`~.checks.RouteOracle` lives
beside the route's engine, and a question about a suite is one round, one message per place the
routes live (this process, worker processes, Dask workers), all routes answering at once.

    checks = DomainChecks(host, names, specs, map_sigma_m, "filter")
    checks.meets(suite)      # every route at once: all of them meet it
    checks.violation(suite)  # every route at once: the largest
    checks.violation_floor(suite)  # a lower bound on it, without an accuracy computation
    checks.report(suite)     # every route's accuracy and verdict
    checks.close()           # the routes' oracles dropped where they live

``host`` is whatever holds the routes' engines and runs work beside them,
:meth:`~sensorsel.information.evaluators.domain.DomainEvaluator.apply_routes` (a domain's evaluator
on threads, on worker processes or on a Dask cluster), or :class:`Here` for engines of this process.
Each route oracle is kept in its engine's ``kept`` under this run's key, so what a route learns
(answers, failing sets, filter states for the upper bounds) stays with the route's data and never
travels: a round sends a suite and gets back verdicts, the new answers (for the journal) and counts.

**Every route is asked every question.** Asking the routes one at a time and stopping at the first
that fails (the route that failed last asked first) asks fewer questions per suite but teaches each
route less: a route that never hears of a suite cannot answer its supersets from it (a subset that
meets, a failing subset's bad keyframes, a kept filter state to bound from). Measured on 2 cores,
one process: the two fixture routes, local-streets, 4,357 accuracy computations and 125 s one at a
time against 1,796 and 77 s all at once; KITTI 03, 04, 06 and 10, freeway, 1,486 and 40.1 s against
1,153 and 32.6 s (same suites, same proofs).

**The same answers and counts wherever the routes live.** A route's answers depend only on the
questions asked of it, in their order, and every route is asked every question, so one thread, N
threads, N processes and a cluster give the same bytes. How much faster more places make it is
bounded by the slowest route of each question: on KITTI 03, 04, 06 and 10, route 10 took 17.9 of the
checks' 30.8 s, and each question's slowest route summed to 25.5 s (at most 1.21x, however many).
"""

from __future__ import annotations

import uuid
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any, Protocol

from sensorsel.designs.requirements.checks import COUNTS, RouteOracle
from sensorsel.designs.requirements.oracle import suite_of
from sensorsel.designs.requirements.spec import RouteRequirement, Specification
from sensorsel.designs.requirements.truncated import BadList
from sensorsel.information.evaluators.base import ProblemEvaluator, Suite, as_suite

if TYPE_CHECKING:
    from sensorsel.information.evaluators.processes import CovariancesAhead

__all__ = ["DomainChecks", "Here", "RouteHost"]

#: a round's reply for a route whose oracle is not where it was opened (its worker was lost and the
#: route rebuilt elsewhere): it is opened again there from the answers found so far
LOST = "lost"


class RouteHost(Protocol):
    """What holds a domain's route engines and runs work beside them (a domain evaluator)."""

    def apply_routes(self, fn: Any, args: dict[int, tuple[Any, ...]]) -> dict[int, Any]: ...


class Here:
    """Engines of this process as a :class:`RouteHost`: ``fn(engine, *args)`` route after route."""

    def __init__(self, engines: Sequence[ProblemEvaluator]) -> None:
        self.routes = list(engines)

    def apply_routes(self, fn: Any, args: dict[int, tuple[Any, ...]]) -> dict[int, Any]:
        return {k: fn(self.routes[k], *a) for k, a in args.items()}


def open_route(engine: ProblemEvaluator, key: str, how: tuple[Any, ...]) -> None:
    """Keep a :class:`RouteOracle` of ``engine``'s route under ``key`` (``how``: its name,
    specification, map σ, estimate, known answers, the bad keyframes known with them, and the
    route's :class:`~sensorsel.information.evaluators.processes.CovariancesAhead` or None)."""
    name, spec, map_sigma_m, estimate, known, known_bad, ahead = how
    engine.kept[key] = RouteOracle(
        engine, engine.problem, name, spec, map_sigma_m, estimate, known, known_bad, ahead=ahead
    )


def look_ahead_route(engine: ProblemEvaluator, key: str, suites: list[Suite]) -> None:
    """:meth:`~.checks.RouteOracle.look_ahead` of the route oracle kept under ``key`` (if it is)."""
    oracle = engine.kept.get(key)
    if oracle is not None:
        oracle.look_ahead(suites)


def ask_route(engine: ProblemEvaluator, key: str, method: str, suite: Suite) -> Any:
    """``method(suite)`` of the route oracle kept under ``key`` (meets, violation or route), with the
    answers it found on the way, its counts and the failing suites' bad keyframes it found;
    :data:`LOST` where it is not kept here."""
    oracle = engine.kept.get(key)
    if oracle is None:
        return LOST
    value = getattr(oracle, method)(suite)
    return value, oracle.take_log(), oracle.counts(), [(suite_of(m), b) for m, b in oracle.bad.take_log()]


def close_route(engine: ProblemEvaluator, key: str) -> None:
    """Drop the route oracle kept under ``key``."""
    engine.kept.pop(key, None)


class DomainChecks:
    """Whether a suite meets the specification on every route of a domain (module docstring).

    Attributes:
        names, specs: the routes' names and specifications, in the domain's order.
        on_answer: called after each round that found answers (the journal's writer).
    """

    def __init__(
        self,
        host: RouteHost,
        names: Sequence[str],
        specs: Sequence[Specification],
        map_sigma_m: float | None,
        estimate: str = "filter",
        *,
        where: Sequence[int] | None = None,
        ahead: CovariancesAhead | None = None,
    ) -> None:
        if ahead is not None and (len(names) != 1 or not isinstance(host, Here)):
            raise ValueError("covariances computed ahead are for one route's engine in this process")
        self.host, self.names, self.specs = host, list(names), list(specs)
        #: the one route's covariances computed ahead on worker processes (a route of this process)
        self.ahead = ahead
        self.map_sigma_m, self.estimate = map_sigma_m, estimate
        #: each route's index in ``host`` (a domain's members kept by ``--in``: a subset of its routes)
        self.where = list(range(len(self.names))) if where is None else [int(w) for w in where]
        self.on_answer: Callable[[], None] | None = None
        self._key = f"require-{uuid.uuid4().hex}"
        #: every answer so far, (route, suite) -> (meets, violation or None): the journal's entries
        self._answers: dict[tuple[int, Suite], tuple[bool, float | None]] = {}
        #: per route, the failing suites' bad keyframes found so far, in the order they were found
        #: (journalled beside the answers: a route opened again starts from them)
        self._bad: list[list[tuple[Suite, BadList]]] = [[] for _ in self.names]
        self._counts: list[dict[str, int]] = [dict.fromkeys(COUNTS, 0) for _ in self.names]
        #: per route, the counts of the oracles it had before one was lost
        self._before: list[dict[str, int]] = [dict.fromkeys(COUNTS, 0) for _ in self.names]
        self._opened: set[int] = set()

    def resume(
        self,
        known: dict[tuple[int, Suite], tuple[bool, float | None]],
        known_bad: Sequence[tuple[int, Suite, BadList]] = (),
    ) -> None:
        """Start from answers read back from a journal, (route, suite) -> (meets, violation or None),
        and the failing suites' bad keyframes found with them, (route, suite, bad keyframes) in the
        order they were found, before the first question: each route's checks open with its own."""
        if self._opened:
            raise RuntimeError("resume: the routes' checks have started already")
        self._answers.update(known)
        for r, s, bad in known_bad:
            self._bad[r].append((s, bad))

    def _open(self, routes: list[int]) -> None:
        """Open the oracles of ``routes`` where they live, with every answer known of each."""
        how = {
            r: (
                self.names[r],
                self.specs[r],
                self.map_sigma_m,
                self.estimate,
                self._known_of(r),
                list(self._bad[r]),
                self.ahead,
            )
            for r in routes
        }
        self.host.apply_routes(open_route, {self.where[r]: (self._key, how[r]) for r in routes})
        self._opened.update(routes)

    def _known_of(self, r: int) -> dict[Suite, tuple[bool, float | None]]:
        return {s: a for (q, s), a in self._answers.items() if q == r}

    def _round(self, method: str, suite: Suite, routes: list[int]) -> dict[int, Any]:
        """``method(suite)`` on each of ``routes``, all at once; their answers joined in route order."""
        if not self._opened:  # opened at the first question: a journal's answers are known by then
            self._open(list(range(len(self.names))))
        out: dict[int, Any] = {}
        todo = list(routes)
        for _ in range(2):
            got = self.host.apply_routes(ask_route, {self.where[r]: (self._key, method, suite) for r in todo})
            lost = [r for r in todo if got[self.where[r]] == LOST]
            found = False
            for r in todo:
                reply = got[self.where[r]]
                if reply == LOST:
                    continue
                value, log, counts, bad = reply
                out[r] = value
                # a route opened again after a lost worker counts afresh: its earlier counts stay
                self._counts[r] = {c: self._before[r][c] + counts[c] for c in COUNTS}
                for s, m, v in log:
                    self._answers[(r, s)] = (m, v)
                self._bad[r].extend(bad)
                found = found or bool(log) or bool(bad)
            if found and self.on_answer is not None:
                self.on_answer()
            if not lost:
                return out
            for r in lost:
                self._before[r] = dict(self._counts[r])
            self._open(lost)
            todo = lost
        raise RuntimeError(f"the route oracles of {[self.names[r] for r in todo]} were lost twice in one round")

    def meets(self, suite: Suite) -> bool:
        """Whether ``suite`` meets every route's specification, every route asked at once."""
        s = as_suite(suite)
        got = self._round("meets", s, list(range(len(self.names))))
        return all(got[r] for r in range(len(self.names)))

    def refuted_cheaply(self, suite: Suite) -> bool:
        """Whether some route refutes ``suite`` without a filter pass
        (:meth:`~.checks.RouteOracle.refuted_cheaply`), every route asked at once."""
        s = as_suite(suite)
        got = self._round("refuted_cheaply", s, list(range(len(self.names))))
        return any(got[r] for r in range(len(self.names)))

    def violation(self, suite: Suite) -> float:
        """How far ``suite`` misses the specification: the largest route's violation (0 when met)."""
        s = as_suite(suite)
        got = self._round("violation", s, list(range(len(self.names))))
        return max(float(got[r]) for r in range(len(self.names)))

    def look_ahead(self, suites: Sequence[Suite]) -> None:
        """Told of the suites whose violations are likely asked next, in that order (the solver's
        greedy): with :attr:`ahead`, the route computes what it can of them on its workers
        meanwhile (:meth:`~.checks.RouteOracle.look_ahead`); the answers are the same either way."""
        if self.ahead is None or not self._opened:
            return
        self.host.apply_routes(look_ahead_route, {self.where[0]: (self._key, [as_suite(s) for s in suites])})

    def violation_floor(self, suite: Suite) -> float:
        """A lower bound on :meth:`violation` without an accuracy computation: the largest route's
        (:meth:`~.checks.RouteOracle.violation_floor`), every route asked at once."""
        s = as_suite(suite)
        got = self._round("violation_floor", s, list(range(len(self.names))))
        return max(float(got[r]) for r in range(len(self.names)))

    def report(self, suite: Suite) -> tuple[RouteRequirement, ...]:
        """Each route's specification, the suite's accuracy there and its verdict, in route order."""
        s = as_suite(suite)
        got = self._round("route", s, list(range(len(self.names))))
        return tuple(RouteRequirement(self.names[r], self.specs[r], *got[r]) for r in range(len(self.names)))

    def answers(self) -> tuple[tuple[int, Suite, bool, float | None], ...]:
        """Every answer so far, (route, suite, meets, violation or None), in a fixed order."""
        return tuple((r, s, m, v) for (r, s), (m, v) in sorted(self._answers.items()))

    def bad_keyframes(self) -> tuple[tuple[int, Suite, BadList], ...]:
        """The failing suites' bad keyframes found so far, (route, suite, bad keyframes per
        component), route after route, each route's in the order they were found."""
        return tuple((r, s, bad) for r, found in enumerate(self._bad) for s, bad in found)

    def count(self, name: str) -> int:
        """A count of :data:`~.checks.COUNTS` summed over the routes."""
        return sum(c[name] for c in self._counts)

    def close(self) -> None:
        """Drop the routes' oracles where they live (their answers stay in :meth:`answers`)."""
        opened, self._opened = sorted(self._opened), set()
        if opened:
            self.host.apply_routes(close_route, {self.where[r]: (self._key,) for r in opened})
