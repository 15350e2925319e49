"""Atomic file output: a crash never leaves a half-written result behind; and the
one guard that keeps HiGHS's stray prints off standard output (quiet_stdout)."""

from __future__ import annotations

import contextlib
import os
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

from sensorsel.errors import OutputError


def atomic_write_bytes(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` via a temporary file in the same folder and an atomic rename.

    Missing parent folders are created. Raises :class:`OutputError` (naming the path and the
    system's reason) when the file cannot be written; the old file, if any, is then left untouched.
    """
    path = Path(path)
    if path.is_dir():
        raise OutputError(path, "it is a folder, expected a file name")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    except OSError as exc:
        raise OutputError(path, exc.strerror or str(exc)) from None
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException as exc:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        if isinstance(exc, OSError):
            raise OutputError(path, exc.strerror or str(exc)) from None
        raise
    return path


def atomic_write_text(path: str | Path, text: str) -> Path:
    """Write UTF-8 ``text`` to ``path`` atomically."""
    return atomic_write_bytes(path, text.encode("utf-8"))


def output_dir(path: str | Path) -> Path:
    """Create the output folder ``path`` (and its parents) now, before a long run fills it.

    Raises :class:`OutputError` when it cannot be made (a file is in the way, no permission, ...).
    """
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise OutputError(path, "exists and is not a folder")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(path, exc.strerror or str(exc)) from None
    if not os.access(path, os.W_OK | os.X_OK):
        raise OutputError(path, "the folder is not writable")
    return path


def output_file(path: str | Path) -> Path:
    """Check, before a long run, that the file ``path`` can be written later (its folder is made now).

    Raises :class:`OutputError` when ``path`` is a folder or its folder cannot be made or written.
    """
    path = Path(path)
    if path.is_dir():
        raise OutputError(path, "it is a folder, expected a file name")
    try:
        output_dir(path.parent)
    except OutputError as exc:  # name the file the user gave, and why its folder fails
        raise OutputError(path, f"its folder {exc.path}: {exc.reason}") from None
    return path


@contextlib.contextmanager
def quiet_stdout() -> Iterator[None]:
    """Send file descriptor 1 to the null device for the duration (every HiGHS call of the package
    goes through this one guard: certify's knapsack, robust's bound, require's solver).

    Why: HiGHS (scipy 1.17's copy) prints a debug line, "HighsMipSolverData::transformNewIntegerFeasibleSolution
    tmpSolver.run();", straight to the C stdout whatever ``disp`` says (ERGO-Code/HiGHS#2783), which
    would corrupt a command's ``--json`` output. Python-level output is flushed first, so nothing
    of ours is lost; progress bars write to stderr.
    """
    try:
        sys.stdout.flush()
        saved = os.dup(1)
    except (OSError, ValueError, AttributeError):  # no real fd 1 (embedded): nothing to protect
        yield
        return
    try:
        with open(os.devnull, "wb") as null:
            os.dup2(null.fileno(), 1)
        yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)
