"""Resume: fingerprints of a result's inputs, and reuse of a stored result whose fingerprint matches.

A stored file that exists but cannot be reused (damaged, of another kind or format, or computed
from other inputs) is never trusted and never silently replaced: :func:`load_matching` reports it
with a :class:`CacheWarning` naming the file, and the caller recomputes and overwrites it.
"""

from __future__ import annotations

from pathlib import Path
from typing import TypeVar

from sensorsel.designs.inputs import result_fingerprint
from sensorsel.model.problem import Fingerprint, Problem, ProblemInfo
from sensorsel.pipeline.store import CacheWarning
from sensorsel.pipeline.store import load_matching as load_record

#: Bumped whenever what a period file holds, or how it is computed, changes (invalidates resume).
FORMAT = 3  # 2: the problem by content (Problem.fingerprint), not the scenario's spec and paths;
#            3: built by designs.inputs (a period's with the route's condition)

T = TypeVar("T")

__all__ = ["CacheWarning", "FORMAT", "fingerprint", "load_matching"]


def fingerprint(
    problem: Problem | Fingerprint, budget: float, alpha: int, rule: str, engine: str, lazy: bool, what: dict
) -> str:
    """Digest of everything a result depends on (:func:`sensorsel.designs.inputs.result_fingerprint`):
    the problem by content (library, route and keyframe rate, landmarks, graph settings, condition:
    :attr:`Problem.fingerprint`, or that fingerprint itself, a period's from
    :meth:`Problem.fingerprint_on`; not the files' paths), budget, alpha, rule, engine, and ``what``
    (e.g. the period bounds)."""
    return result_fingerprint(
        "resilient", FORMAT, problem, budget_usd=budget, alpha=alpha, rule=rule, engine=engine, lazy=lazy, **what
    )


def load_matching(cls: type[T], path: Path, fingerprint: str, ours: Fingerprint | None = None) -> T | None:
    """The result stored at ``path`` if it is a ``cls`` with this fingerprint, else None.

    None without a word when there is no file; with a :class:`CacheWarning` naming the file when
    there is one that cannot be reused (unreadable, or computed from other inputs: with ``ours``, this
    run's problem's fingerprint, the warning says what differs when the stored result was computed on
    another problem). A stored result is never reused for another problem: resume has no ``force``.
    """

    def differences(old: object) -> list[str]:
        rec = _recorded_problem(old)
        if ours is None or rec is None or rec.fingerprint is None:
            return []
        return rec.fingerprint.differences(ours)

    return load_record(
        cls,
        path,
        fingerprint,
        differences,
        "other inputs (scenario, library, settings, budget, failures, rule, engine or period)",
    )


def _recorded_problem(old: object) -> ProblemInfo | None:
    """The route a stored result records (a Comparison's, or a period's resilient result's); None
    when it records none, or a domain (whose comparison is never stored)."""
    info = getattr(old, "problem", None)
    if info is None:
        info = getattr(getattr(old, "result", None), "problem", None)
    return info if getattr(info, "kind", None) == ProblemInfo.kind else None
