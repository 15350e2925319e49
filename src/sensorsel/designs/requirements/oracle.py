"""The predicates of the requirement solver, each asked at most once per suite, with what its
structure tells without a call (suites as bit masks: bit i is library position i).

    Monotone       S ⊆ T and passes(S) imply passes(T): a suite inside a failing set fails, a
                   suite holding a passing set passes (accuracy: a sensor added only lowers σ)
    AntiMonotone   S ⊆ T and passes(T) imply passes(S): a suite holding a failing set fails, a suite
                   inside a passing set passes (e.g. "no measurement is risky": a sensor added can
                   only add risky measurements)
    Exact          nothing is inferred: each suite is asked (a requirement that is neither)

Each keeps the antichains of what it knows (the maximal failing and minimal passing sets of a
monotone predicate; the minimal failing and maximal passing ones of an anti-monotone one) as
arrays of 64-bit words, so that asking whether a suite lies inside or holds one of thousands of
known sets is one vectorised comparison, not a Python loop. Every call is timed (``seconds``).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable
from typing import TypeVar

import numpy as np

__all__ = ["Antichain", "AntiMonotone", "Exact", "Monotone", "mask_of", "suite_of"]

Suite = tuple[int, ...]
_WORD = (1 << 64) - 1
T = TypeVar("T")
#: a violation floor is lowered by this share of 1 + it before it bounds anything: it is computed
#: another way than the violation (on KITTI 00 it is within 0.3 % of it for one sensor alone), and
#: round-off must not lift it above the value it bounds
FLOOR_SLACK = 1e-9


def mask_of(suite: Iterable[int]) -> int:
    """The bit mask of library positions ``suite``."""
    m = 0
    for i in suite:
        m |= 1 << int(i)
    return m


def suite_of(mask: int) -> Suite:
    """The sorted library positions of bit mask ``mask``."""
    out, i = [], 0
    while mask:
        if mask & 1:
            out.append(i)
        mask >>= 1
        i += 1
    return tuple(out)


class Antichain:
    """Sets (bit masks over ``n`` positions) of which none holds another, with vectorised tests.

    ``keep="max"`` keeps the maximal sets (a set added removes those inside it), ``keep="min"`` the
    minimal ones (a set added removes those holding it)."""

    def __init__(self, n: int, keep: str) -> None:
        self.words = max(1, (n + 63) // 64)
        self.keep = keep
        self.masks: list[int] = []
        self._rows = np.zeros((16, self.words), dtype=np.uint64)

    def as_words(self) -> np.ndarray:
        """(len(masks), words) the sets as 64-bit words, word k holding positions 64k..64k+63
        (a view: valid until the next :meth:`add`)."""
        return self._rows[: len(self.masks)]

    def _w(self, mask: int) -> np.ndarray:
        return np.array([(mask >> (64 * k)) & _WORD for k in range(self.words)], dtype=np.uint64)

    def inside_one(self, mask: int) -> bool:
        """``mask`` ⊆ some set of the antichain."""
        if not self.masks:
            return False
        q = self._w(mask)
        return bool(np.any(np.all((q & ~self._rows[: len(self.masks)]) == 0, axis=1)))

    def _many(self, masks: list[int]) -> np.ndarray:
        return np.array([[(m >> (64 * k)) & _WORD for k in range(self.words)] for m in masks], dtype=np.uint64)

    def inside_any(self, masks: list[int]) -> bool:
        """Some mask of ``masks`` ⊆ some set of the antichain (one vectorised comparison)."""
        if not self.masks or not masks:
            return False
        q = self._many(masks)[:, None, :]
        return bool(np.any(np.all((q & ~self._rows[None, : len(self.masks)]) == 0, axis=2)))

    def holds_any(self, masks: list[int]) -> bool:
        """Some set of the antichain ⊆ some mask of ``masks``."""
        if not self.masks or not masks:
            return False
        q = self._many(masks)[:, None, :]
        return bool(np.any(np.all((self._rows[None, : len(self.masks)] & ~q) == 0, axis=2)))

    def holds_one(self, mask: int) -> bool:
        """some set of the antichain ⊆ ``mask``."""
        if not self.masks:
            return False
        q = self._w(mask)
        return bool(np.any(np.all((self._rows[: len(self.masks)] & ~q) == 0, axis=1)))

    def covers(self, mask: int) -> bool:
        """``mask`` is settled by the antichain: inside one of its sets (``keep="max"``) or holding
        one (``keep="min"``)."""
        return self.inside_one(mask) if self.keep == "max" else self.holds_one(mask)

    def add(self, mask: int) -> None:
        """Add ``mask`` (the caller knows it is not dominated), dropping the sets it dominates."""
        m, q = len(self.masks), self._w(mask)
        if m:
            rows = self._rows[:m]
            gone = np.all(((rows & ~q) if self.keep == "max" else (q & ~rows)) == 0, axis=1)
            if gone.any():
                stay = np.flatnonzero(~gone)
                self.masks = [self.masks[i] for i in stay]
                self._rows[: len(stay)] = rows[stay]
        m = len(self.masks)
        if m == len(self._rows):
            self._rows = np.concatenate([self._rows, np.zeros_like(self._rows)])
        self._rows[m] = q
        self.masks.append(mask)


class _Cached:
    """A predicate asked at most once per suite; ``calls`` and ``seconds`` count what it cost."""

    def __init__(self, n: int, passes: Callable[[Suite], bool]) -> None:
        self._passes = passes
        self.n = n
        self.known: dict[int, bool] = {}
        self.calls = 0
        self.seconds = 0.0
        #: called before each call of the predicate (the solver's clock: it raises once the time
        #: limit is spent, so that no search step runs past it); None: nothing
        self.before_call: Callable[[], None] | None = None

    def infer(self, mask: int) -> bool | None:
        return self.known.get(mask)

    def passes(self, mask: int) -> bool:
        known = self.infer(mask)
        if known is not None:
            return known
        ok = bool(self._call(self._passes, mask))
        self.record(mask, ok)
        return ok

    def _call(self, predicate: Callable[[Suite], T], mask: int) -> T:
        """``predicate`` of the suite ``mask``, counted and timed (the clock read before it)."""
        if self.before_call is not None:
            self.before_call()
        t = time.perf_counter()
        out = predicate(suite_of(mask))
        self.seconds += time.perf_counter() - t
        self.calls += 1
        return out

    def record(self, mask: int, ok: bool) -> None:
        self.known[mask] = ok


class _Antichains(_Cached):
    """A predicate whose answers settle others: ``failing`` and ``passing`` keep what it knows as
    antichains (:meth:`Antichain.covers` says whether a suite is settled by one)."""

    def __init__(self, n: int, passes: Callable[[Suite], bool], failing: Antichain, passing: Antichain) -> None:
        super().__init__(n, passes)
        self.failing, self.passing = failing, passing

    def infer(self, mask: int) -> bool | None:
        hit = super().infer(mask)
        if hit is not None:
            return hit
        if self.failing.covers(mask):
            return False
        if self.passing.covers(mask):
            return True
        return None

    def record(self, mask: int, ok: bool) -> None:
        self.known[mask] = ok
        kept = self.passing if ok else self.failing
        if not kept.covers(mask):
            kept.add(mask)


class Exact(_Cached):
    """A predicate with no structure: only the suites asked are known."""


class Monotone(_Antichains):
    """A monotone predicate (S ⊆ T, passes(S) ⇒ passes(T)), with an optional ``violation``
    (>= 0, 0 exactly when it passes) that the greedy upper bound uses.

    ``failing``: the maximal failing sets known (each one is a cut); ``meeting``: the minimal
    passing sets known.

    ``floor``: floor(suite) -> float >= 0, a cheaper lower bound on ``violation`` (<= it at every
    suite), or None: what the greedy caps its lazy bounds by (:meth:`violation_floor`).

    ``swaps``: pairs (w, s) of positions where replacing w by s never makes a suite fail
    (:mod:`sensorsel.designs.requirements.dominance`): a suite holding s but not w passes when the
    suite with w in place of s is known to pass, one holding w but not s fails when the suite with
    s in place of w is known to fail (one swap at a time; ``swap_inferred`` counts the answers so
    given)."""

    def __init__(
        self,
        n: int,
        passes: Callable[[Suite], bool],
        violation: Callable[[Suite], float] | None = None,
        swaps: Iterable[tuple[int, int]] = (),
        floor: Callable[[Suite], float] | None = None,
        look_ahead: Callable[[list[Suite]], None] | None = None,
    ) -> None:
        super().__init__(n, passes, Antichain(n, "max"), Antichain(n, "min"))
        self.meeting = self.passing
        self._violation = violation
        self._look_ahead = look_ahead
        self._floor = floor  # its time is in ``seconds``; a floor is not a check (``calls``)
        self.viol: dict[int, float] = {}
        self.swaps = tuple((1 << int(w), 1 << int(s)) for w, s in swaps)
        self.swap_inferred = 0

    def infer(self, mask: int) -> bool | None:
        hit = super().infer(mask)
        if hit is not None:
            return hit
        if self.swaps:
            weaker = [mask & ~s | w for w, s in self.swaps if mask & s and not mask & w]
            if self.meeting.holds_any(weaker):
                self.swap_inferred += 1
                self.record(mask, True)  # known from now on, and a passing set later swaps start from
                return True
            stronger = [mask & ~w | s for w, s in self.swaps if mask & w and not mask & s]
            if self.failing.inside_any(stronger):
                self.swap_inferred += 1
                self.record(mask, False)
                return False
        return None

    def violation(self, mask: int) -> float:
        """violation(S) (a call unless cached; 0 without a call when S is known to pass)."""
        if mask in self.viol:
            return self.viol[mask]
        if self.infer(mask) is True:
            return 0.0
        assert self._violation is not None
        v = float(self._call(self._violation, mask))
        if not math.isfinite(v) or v < 0:
            raise ValueError(f"violation{suite_of(mask)} returned {v!r}: it must be a finite number >= 0")
        self.viol[mask] = v
        self.record(mask, v <= 0.0)
        return v

    def look_ahead(self, masks: Iterable[int]) -> None:
        """Tell the caller's ``look_ahead`` of the suites among ``masks`` whose violations
        :meth:`violation` would compute (not cached, not known to pass), in their order: the
        violations likely asked next. Nothing is recorded or counted (its time is in ``seconds``)."""
        if self._look_ahead is None:
            return
        todo = [suite_of(m) for m in masks if m not in self.viol and not self.passing.covers(m)]
        if todo:
            t = time.perf_counter()
            self._look_ahead(todo)
            self.seconds += time.perf_counter() - t

    @property
    def has_floor(self) -> bool:
        return self._floor is not None

    def violation_floor(self, mask: int) -> float:
        """A lower bound on violation(S), with no check: the value itself where it is known (cached,
        or 0 for a suite known to pass), else the floor's, lowered by :data:`FLOOR_SLACK` of 1 + it
        (the floor is computed another way than the violation: where the two are equal, round-off
        must not put the floor above it). 0 without a floor."""
        if mask in self.viol:
            return self.viol[mask]
        if self._floor is None or self.infer(mask) is True:
            return 0.0
        t = time.perf_counter()
        v = float(self._floor(suite_of(mask)))
        self.seconds += time.perf_counter() - t
        if not math.isfinite(v) or v < 0:
            raise ValueError(f"violation floor{suite_of(mask)} returned {v!r}: it must be a finite number >= 0")
        v = max(0.0, v - FLOOR_SLACK * (1.0 + v))
        if v > 0.0:  # the suite fails: known from now on (a failing set, as its check would have said)
            self.record(mask, False)
        return v


class AntiMonotone(_Antichains):
    """An anti-monotone predicate (S ⊆ T, passes(T) ⇒ passes(S)).

    ``failing``: the minimal failing sets known (each one is a cut Σ_{i∈m} x_i <= |m| - 1);
    ``passing``: the maximal passing sets known."""

    def __init__(self, n: int, passes: Callable[[Suite], bool]) -> None:
        super().__init__(n, passes, Antichain(n, "min"), Antichain(n, "max"))
