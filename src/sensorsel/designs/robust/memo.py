"""A memoizing evaluator: every suite is scored at most once per robust run.

The robust methods score many suites more than once (the greedy runs share their first sweep, the
worst case of a suite re-scores the greedy prefix it came from, the bound re-scores survivors, local
search revisits neighbours). :class:`MemoEvaluator` wraps any :class:`~sensorsel.information.evaluators.Evaluator`
and keeps f(S) for every canonical suite it has seen. Its ``n_evaluations`` counts the suites the
wrapped engine really scored; ``n_lookups`` counts every request.

Numbers: the first path that scores a suite fixes its value (``score`` and ``scores_with`` of an
engine may differ in the last bits); the order of requests is deterministic, so results are too.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np

from sensorsel.information.evaluators import Evaluator, Suite, as_suite


class MemoEvaluator(Evaluator):
    """Evaluator that caches f(S) of ``inner`` by canonical suite (same interface as any engine)."""

    def __init__(self, inner: Evaluator) -> None:
        super().__init__(inner.library, jobs=inner.jobs)
        self.inner = inner
        self.name = inner.name  # type: ignore[misc]  # the wrapped engine's name, per instance
        self.n_lookups = 0
        self._f: dict[Suite, float] = {(): 0.0}

    def score(self, suite: Iterable[int]) -> float:
        s = as_suite(suite)
        self.n_lookups += 1
        v = self._f.get(s)
        if v is None:
            n0 = self.inner.n_evaluations
            v = float(self.inner.score(s))
            self.n_evaluations += self.inner.n_evaluations - n0
            self._f[s] = v
        return v

    def scored(self) -> dict[Suite, float]:
        """Every suite scored so far (or learnt) and its f, in the order they came."""
        return dict(self._f)

    def learn(self, known: Iterable[tuple[Iterable[int], float]]) -> None:
        """Take f of suites scored elsewhere (e.g. by earlier tasks of a robust run): they are then
        not scored again (a suite already known keeps its value)."""
        for suite, value in known:
            self._f.setdefault(as_suite(suite), float(value))

    def known(self, suite: Iterable[int]) -> float | None:
        """f(S) if already scored, else None (scores nothing)."""
        return self._f.get(as_suite(suite))

    def scores_with(self, suite: Iterable[int], candidates: Sequence[int]) -> np.ndarray:
        base = as_suite(suite)
        cands = [int(c) for c in candidates]
        self.n_lookups += len(cands)
        keys = [as_suite(base + (c,)) for c in cands]
        missing = sorted({c for c, k in zip(cands, keys) if k not in self._f})
        if missing:
            inside = [c for c in missing if c in base]
            todo = [c for c in missing if c not in base]
            if inside:
                self.score(base)
            if todo:
                n0 = self.inner.n_evaluations
                vals = self.inner.scores_with(base, todo)
                self.n_evaluations += self.inner.n_evaluations - n0
                for c, v in zip(todo, vals):
                    self._f[as_suite(base + (c,))] = float(v)
        return np.array([self._f[k] for k in keys], dtype=float)

    def gain_bounds(self, suite: Iterable[int], candidates: Sequence[int]) -> np.ndarray | None:
        """The wrapped engine's bounds on the gains (bounds are not memoized: they cost no evaluation)."""
        return self.inner.gain_bounds(suite, candidates)

    def score_bounds(self, suite: Iterable[int], candidates: Sequence[int]) -> tuple[float, np.ndarray] | None:
        """The wrapped engine's cheap bounds on the scores."""
        return self.inner.score_bounds(suite, candidates)


def memoized(evaluator: Evaluator) -> MemoEvaluator:
    """``evaluator`` itself if it memoizes already, else a :class:`MemoEvaluator` around it."""
    return evaluator if isinstance(evaluator, MemoEvaluator) else MemoEvaluator(evaluator)
