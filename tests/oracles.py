"""Brute-force oracles shared by the tests."""

from __future__ import annotations

import itertools

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
