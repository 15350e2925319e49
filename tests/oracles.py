"""Brute-force oracles shared by the tests."""

from __future__ import annotations

import itertools
from collections.abc import Callable, Sequence
from typing import Any

from sensorsel.information.evaluators import Evaluator


def every_suite_score(evaluator: Evaluator) -> dict[tuple[int, ...], float]:
    """f of every suite of the evaluator's library (sorted positions -> nats), each scored once, as an
    extension of its prefix without its last sensor. For libraries of about a dozen sensors at most."""
    n = len(evaluator.library)
    out = {(): 0.0}
    for r in range(n):
        for s in itertools.combinations(range(n), r):
            cands = [c for c in range(n) if c > (s[-1] if s else -1)]
            for c, v in zip(cands, evaluator.scores_with(s, cands)):
                out[s + (c,)] = float(v)
    return out


def cheapest_by_brute_force(
    feas: Any, meets: Callable[[tuple[int, ...]], bool], alpha: int, positions: Sequence[int]
) -> float | None:
    """The least cost [$] of a suite of ``positions`` that ``feas`` allows and that meets ``meets``
    after any ``alpha`` of its sensors fail (every subset enumerated); None where none does."""
    best = None
    for k in range(len(positions) + 1):
        for combo in itertools.combinations(positions, k):
            if not feas.fits(combo) or (alpha and len(combo) <= alpha):
                continue
            if all(meets(tuple(sorted(set(combo) - set(f)))) for f in itertools.combinations(combo, alpha)):
                cost = float(feas.A[0, list(combo)].sum())
                best = cost if best is None or cost < best - 1e-9 else best
    return best
