"""Stores: where a run's results are kept as they arrive, and the one rule by which ``--resume`` reads them back.

:class:`NoStore` keeps nothing; :class:`FileStore` writes one fingerprinted file per task (atomically);
a run that keeps its state in one file (the greedy and optimal checkpoints, the ``require`` journal)
writes it with :func:`sensorsel.io.results.save`. Every one of them reads back through
:func:`load_matching`, so every design run resumes the same way:

- a stored result whose fingerprint matches this run's inputs is read back, not recomputed;
- one that does not (computed from other inputs, damaged, another kind or format) is never trusted
  and never fatal: a :class:`CacheWarning` names the file (and, where the store knows, what differs),
  the result is recomputed and the file overwritten.

Why recompute rather than refuse: a stored result of other inputs cannot give this run's answer,
and the same command without ``--resume`` would overwrite the same files anyway; a store of many
files (a study's cells, a tradespace's rules, a route's periods) keeps the results whose inputs did
not change, which a refusal would throw away with the rest; and the warning, printed as the run
starts, names what was not reused, so a mistaken option is seen at once.
"""

from __future__ import annotations

import hashlib
import json
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, Generic, Protocol, TypeVar

from sensorsel.errors import ResultFileError, SensorselWarning
from sensorsel.io import results

R = TypeVar("R")
#: a file's record, as :mod:`sensorsel.io.results` saves it
F = TypeVar("F")


class CacheWarning(SensorselWarning):
    """A stored result was found but not reused (it is recomputed and overwritten)."""


def digest(obj: object) -> str:
    """SHA-256 of ``obj`` as canonical JSON (sorted keys, no NaN): a fingerprint of a task's inputs."""
    return hashlib.sha256(json.dumps(obj, sort_keys=True, allow_nan=False).encode("utf-8")).hexdigest()


class Store(Protocol[R]):
    """Results of a plan's tasks by task index: ``get`` (None: not held) and ``put``."""

    def get(self, i: int) -> R | None: ...

    def put(self, i: int, result: R) -> None: ...


class NoStore(Generic[R]):
    """Keeps nothing: every task runs."""

    def get(self, i: int) -> R | None:
        return None

    def put(self, i: int, result: R) -> None:
        return None


class FileStore(Generic[R, F]):
    """One file per task: ``paths[i]`` holds task i's result with its inputs' fingerprint ``fingerprints[i]``.

    Args:
        paths: each task's file.
        fingerprints: each task's fingerprint (:func:`digest` of everything its result depends on).
        record: the file's record class (a :mod:`sensorsel.io.results` kind).
        wrap: ``wrap(i, result) -> record`` (the fingerprint inside it).
        unwrap: ``unwrap(record) -> result``.
        resume: read back matching files (else every task runs and its file is overwritten).
        differences: ``differences(i, record)``: how a non-matching file's inputs differ, in words,
            for its warning (empty: unknown).
        what: the inputs a warning names when the differences are unknown.

    A file that exists but cannot be reused (damaged, another kind or format, or computed from other
    inputs) is never trusted: a :class:`CacheWarning` names it, the task runs and its file is overwritten.
    """

    def __init__(
        self,
        paths: Sequence[Path],
        fingerprints: Sequence[str],
        record: type[F],
        wrap: Callable[[int, R], F],
        unwrap: Callable[[F], R],
        *,
        resume: bool,
        differences: Callable[[int, Any], list[str]] | None = None,
        what: str = "other inputs",
    ) -> None:
        if len(paths) != len(fingerprints):
            raise ValueError("one fingerprint per file")
        self.paths, self.fingerprints = [Path(p) for p in paths], list(fingerprints)
        self.record, self.wrap, self.unwrap, self.resume = record, wrap, unwrap, resume
        self.differences, self.what = differences, what

    def get(self, i: int) -> R | None:
        if not self.resume:
            return None
        diff = self.differences
        rec = load_matching(
            self.record,
            self.paths[i],
            self.fingerprints[i],
            None if diff is None else (lambda old: diff(i, old)),
            self.what,
        )
        return None if rec is None else self.unwrap(rec)

    def put(self, i: int, result: R) -> None:
        results.save(self.wrap(i, result), self.paths[i])


def load_matching(
    cls: type[F],
    path: Path,
    fingerprint: str,
    differences: Callable[[Any], list[str]] | None = None,
    what: str = "other inputs",
) -> F | None:
    """The record stored at ``path`` if it is a ``cls`` with this fingerprint, else None.

    None without a word when there is no file; with a :class:`CacheWarning` naming the file when one
    cannot be reused. ``differences(record)``: what differs, in words, for the warning (empty: unknown);
    ``what``: the inputs named when it is unknown.
    """
    if not path.is_file():
        return None
    try:
        old = results.load(path, cls)
    except ResultFileError as exc:
        reason = str(exc).removeprefix(f"{exc.path}: ")
        warnings.warn(
            f"{path}: not reused, it cannot be read as a {cls.__name__} ({reason}); recomputing and overwriting it",
            CacheWarning,
            stacklevel=3,
        )
        return None
    if getattr(old, "fingerprint", None) != fingerprint:
        diffs = differences(old) if differences is not None else []
        if diffs:
            warnings.warn(
                f"{path}: not reused, it was computed from other inputs ({'; '.join(diffs)}); "
                "recomputing and overwriting it",
                CacheWarning,
                stacklevel=3,
            )
        else:
            warnings.warn(
                f"{path}: not reused, it was computed from {what}; recomputing and overwriting it",
                CacheWarning,
                stacklevel=3,
            )
        return None
    return old
