"""Max-min over a finite family of monotone submodular functions: the common interface.

Robust selection maximises, within the budget, the *smallest* member of a family {f_i}:

    failure sets   f_F(S) = f(S minus F),  F ⊆ V, |F| = alpha           (:class:`FailureFamily`)
    routes         f_r(S) = f_r(S) / norm_r, one evaluator per route    (:class:`EvaluatorFamily`)
    periods        the same, one evaluator per period of a route         (:class:`EvaluatorFamily`)

Each member is monotone submodular, so every weighted sum of truncations min(f_i, c) is too, which
is all SATURATE (:mod:`.methods`) needs. A family exposes its members as *terms*: a weight and a
value, members of equal value at S merged (the failure family has C(n, alpha) members but at most
sum_j C(|S|, j) distinct values). For any function h,

    sum_i h(f_i(S)) = sum_t w_t h(v_t)          over the terms (w_t, v_t) of :meth:`Family.terms`

and the terms of S + e (:meth:`Family.terms_with`, one column per candidate e) have the same
weights for every candidate, so a greedy step can compare candidates column by column.
"""

from __future__ import annotations

import itertools
import math
from abc import ABC, abstractmethod
from collections.abc import Sequence

import numpy as np

from sensorsel.designs.resilient import worst_case
from sensorsel.information.evaluators import Evaluator, Suite, as_suite


class Family(ABC):
    """A finite family of monotone submodular set functions over one sensor library.

    Attributes:
        evaluator: scores suites of the library (the one whose ``n_evaluations`` counts the work).
        n_members: number of members (weights of the terms sum to it).
        kind: short name recorded in results ("failures", "routes", ...).
    """

    kind: str = ""
    evaluator: Evaluator
    n_members: int

    @property
    def library(self):
        return self.evaluator.library

    @property
    def n_evaluations(self) -> int:
        """Suites scored so far by the family's evaluators."""
        return self.evaluator.n_evaluations

    @abstractmethod
    def terms(self, suite: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
        """(weights (T,), values (T,)) of the members at S."""

    @abstractmethod
    def terms_with(
        self, suite: Sequence[int], candidates: Sequence[int], *, cap: float | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """(weights (T,), values (T, len(candidates))) of the members at S + e for each candidate e.

        With ``cap``, a member already >= cap at S may be reported as ``cap`` for every candidate
        without scoring (it stays >= cap by monotonicity): enough for truncated sums min(f_i, cap).
        """

    @abstractmethod
    def worst(self, suite: Sequence[int]) -> tuple[float, str]:
        """(min_i f_i(S), a description of the member attaining it)."""


class FailureFamily(Family):
    """f_F(S) = f(S minus F) for every set F of ``alpha`` library sensors (sensors that fail).

    Members are grouped by G = F ∩ S: the C(n - |S|, alpha - |G|) sets F with F ∩ S = G all have the
    value f(S minus G). At S + e, a set F containing e leaves S + e minus F = S minus (F - e), so the
    terms of S + e are f((S minus G) + e) for G ⊆ S, |G| <= alpha, weight C(n - |S| - 1, alpha - |G|),
    and f(S minus G) for |G| <= alpha - 1, weight C(n - |S| - 1, alpha - 1 - |G|). Scoring them takes
    one ``scores_with`` per G (sum_j C(|S|, j) sweeps).
    """

    kind = "failures"

    def __init__(self, evaluator: Evaluator, alpha: int) -> None:
        self.evaluator = evaluator
        self.alpha = int(alpha)
        self.n = len(evaluator.library)
        self.n_members = math.comb(self.n, self.alpha)

    def _groups(self, s: Suite, cap: int) -> list[tuple[int, ...]]:
        return [g for j in range(min(cap, len(s)) + 1) for g in itertools.combinations(s, j)]

    def terms(self, suite: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
        s = as_suite(suite)
        ev, a, rest = self.evaluator, self.alpha, self.n - len(s)
        groups = [g for g in self._groups(s, a) if math.comb(rest, a - len(g)) > 0]
        w = np.array([math.comb(rest, a - len(g)) for g in groups], dtype=float)
        v = np.array([ev.score(tuple(i for i in s if i not in g)) for g in groups], dtype=float)
        return w, v

    def terms_with(
        self, suite: Sequence[int], candidates: Sequence[int], *, cap: float | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        s = as_suite(suite)
        cands = [int(c) for c in candidates]
        ev, a, rest = self.evaluator, self.alpha, self.n - len(s) - 1
        ws, rows = [], []
        for g in self._groups(s, a):  # F ∌ e
            w = math.comb(rest, a - len(g))
            if w > 0:
                ws.append(w)
                base = tuple(i for i in s if i not in g)
                if cap is not None and ev.score(base) >= cap:
                    rows.append(np.full(len(cands), float(cap)))
                else:
                    rows.append(ev.scores_with(base, cands))
        for g in self._groups(s, a - 1):  # F ∋ e: e is lost, S minus G stays
            w = math.comb(rest, a - 1 - len(g))
            if w > 0:
                ws.append(w)
                rows.append(np.full(len(cands), ev.score(tuple(i for i in s if i not in g))))
        return np.array(ws, dtype=float), np.array(rows, dtype=float).reshape(len(ws), len(cands))

    def worst(self, suite: Sequence[int]) -> tuple[float, str]:
        w = worst_case(self.evaluator, as_suite(suite), self.alpha)
        return w.score, ",".join(w.failures)


class EvaluatorFamily(Family):
    """One member per evaluator (a route of a domain, a period of a route): f_i(S) = score_i(S) / norm_i.

    All evaluators must score the same library (same sensors in the same order). ``norms`` (default
    1) make members comparable, e.g. each route's best achievable score, for "worst normalised route".
    ``evaluator`` (the first member) is the one the greedy machinery reads the library from; the work
    of every member is summed in :attr:`n_evaluations`.
    """

    kind = "members"

    def __init__(
        self, evaluators: Sequence[Evaluator], labels: Sequence[str], norms: Sequence[float] | None = None
    ) -> None:
        if not evaluators or len(evaluators) != len(labels):
            raise ValueError("one label per evaluator, at least one evaluator")
        ids = evaluators[0].library.ids
        if any(e.library.ids != ids for e in evaluators):
            raise ValueError("every member must score the same library")
        self.members = list(evaluators)
        self.labels = list(labels)
        self.norms = np.ones(len(evaluators)) if norms is None else np.asarray(norms, dtype=float)
        self.evaluator = evaluators[0]
        self.n_members = len(evaluators)

    @property
    def n_evaluations(self) -> int:
        return sum(e.n_evaluations for e in self.members)

    def terms(self, suite: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
        s = as_suite(suite)
        return np.ones(self.n_members), np.array([e.score(s) / n for e, n in zip(self.members, self.norms)])

    def terms_with(
        self, suite: Sequence[int], candidates: Sequence[int], *, cap: float | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        s = as_suite(suite)
        rows = []
        for e, n in zip(self.members, self.norms):
            if cap is not None and e.score(s) / n >= cap:
                rows.append(np.full(len(candidates), float(cap)))
            else:
                rows.append(e.scores_with(s, list(candidates)) / n)
        return np.ones(self.n_members), np.array(rows, dtype=float).reshape(self.n_members, len(candidates))

    def worst(self, suite: Sequence[int]) -> tuple[float, str]:
        _, v = self.terms(suite)
        k = int(np.argmin(v))
        return float(v[k]), self.labels[k]
