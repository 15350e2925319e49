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

import numpy as np

from .. import results
from ..errors import ResultFileError
from ..problem import Problem

#: Bumped whenever what a period file holds, or how it is computed, changes (invalidates resume).
FORMAT = 1

T = TypeVar("T")


class CacheWarning(UserWarning):
    """A stored result was found but not reused (it is recomputed and overwritten)."""


def _digest(obj: object) -> str:
    return hashlib.sha256(json.dumps(obj, sort_keys=True, allow_nan=False).encode("utf-8")).hexdigest()


def _array_digest(*arrays: np.ndarray) -> str:
    h = hashlib.sha256()
    for a in arrays:
        a = np.ascontiguousarray(a, dtype=float)
        h.update(str(a.shape).encode())
        h.update(a.tobytes())
    return h.hexdigest()


def fingerprint(problem: Problem, budget: float, alpha: int, rule: str, engine: str, lazy: bool, what: dict) -> str:
    """Digest of everything a result depends on: scenario (its provenance and actual numbers), library
    (source and content), graph settings, budget, alpha, rule, engine, and ``what`` (e.g. the period bounds)."""
    sc = problem.scenario
    info = problem.info
    return _digest({
        "format": FORMAT,
        "spec": results.to_jsonable(info.spec),
        "scenario": _array_digest(sc.keyframes.poses, sc.keyframes.times, sc.landmarks),
        "library_source": info.library,
        "library": _digest(results.to_jsonable(problem.library.sensors)),
        "settings": results.to_jsonable(info.settings),
        "budget_usd": budget, "alpha": alpha, "rule": rule, "engine": engine, "lazy": lazy,
        **what,
    })


def load_matching(cls: type[T], path: Path, fingerprint: str) -> T | None:
    """The result stored at ``path`` if it is a ``cls`` with this fingerprint, else None.

    None without a word when there is no file; with a :class:`CacheWarning` naming the file when
    there is one that cannot be reused (unreadable, or computed from other inputs).
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
        warnings.warn(f"{path}: not reused, it was computed from other inputs (scenario, library, settings, budget, "
                      f"failures, rule, engine or period); recomputing and overwriting it", CacheWarning, stacklevel=3)
        return None
    return old
