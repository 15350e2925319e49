"""Resume: fingerprints of a result's inputs, and reuse of a stored result whose fingerprint matches.

A stored file that exists but cannot be reused (damaged, of another kind or format, or computed
from other inputs) is never trusted and never silently replaced: :func:`load_matching` reports it
with a :class:`CacheWarning` naming the file, and the caller recomputes and overwrites it.
"""

from __future__ import annotations

import hashlib
import json
import warnings
from pathlib import Path
from typing import TypeVar

from .. import results
from ..errors import ResultFileError, SensorselWarning
from ..problem import Problem, ProblemInfo

#: Bumped whenever what a period file holds, or how it is computed, changes (invalidates resume).
FORMAT = 2  # 2: the problem by content (Problem.fingerprint), not the scenario's spec and paths

T = TypeVar("T")


class CacheWarning(SensorselWarning):
    """A stored result was found but not reused (it is recomputed and overwritten)."""


def _digest(obj: object) -> str:
    return hashlib.sha256(json.dumps(obj, sort_keys=True, allow_nan=False).encode("utf-8")).hexdigest()


def fingerprint(problem: Problem, budget: float, alpha: int, rule: str, engine: str, lazy: bool, what: dict) -> str:
    """Digest of everything a result depends on: the problem by content (library, route and keyframe
    rate, landmarks, graph settings: :attr:`Problem.fingerprint`; not the files' paths), budget,
    alpha, rule, engine, and ``what`` (e.g. the period bounds)."""
    fp = problem.fingerprint
    return _digest({
        "format": FORMAT,
        "problem": results.to_jsonable(fp),
        "budget_usd": budget, "alpha": alpha, "rule": rule, "engine": engine, "lazy": lazy,
        **what,
    })


def load_matching(cls: type[T], path: Path, fingerprint: str, problem: Problem | None = None) -> T | None:
    """The result stored at ``path`` if it is a ``cls`` with this fingerprint, else None.

    None without a word when there is no file; with a :class:`CacheWarning` naming the file when
    there is one that cannot be reused (unreadable, or computed from other inputs: with ``problem``,
    the warning says what differs when the stored result was computed on another problem). A stored
    result is never reused for another problem: resume has no ``force``.
    """
    if not path.is_file():
        return None
    try:
        old = results.load(cls, path)
    except ResultFileError as exc:
        reason = str(exc).removeprefix(f"{exc.path}: ")
        warnings.warn(f"{path}: not reused, it cannot be read as a {cls.__name__} ({reason}); recomputing and overwriting it",
                      CacheWarning, stacklevel=3)
        return None
    if getattr(old, "fingerprint", None) != fingerprint:
        recorded = _recorded_problem(old)
        if problem is not None and recorded is not None and recorded.fingerprint is not None:
            diffs = recorded.fingerprint.differences(problem.fingerprint)
            if diffs:
                warnings.warn(f"{path}: not reused, it was computed on another problem ({'; '.join(diffs)}); "
                              "recomputing and overwriting it", CacheWarning, stacklevel=3)
                return None
        warnings.warn(f"{path}: not reused, it was computed from other inputs (scenario, library, settings, budget, "
                      f"failures, rule, engine or period); recomputing and overwriting it", CacheWarning, stacklevel=3)
        return None
    return old


def _recorded_problem(old: object) -> "ProblemInfo | None":
    """The problem a stored result records (a Comparison's, or a period's resilient result's)."""
    info = getattr(old, "problem", None)
    if info is None:
        info = getattr(getattr(old, "result", None), "problem", None)
    return info if isinstance(info, ProblemInfo) else None
