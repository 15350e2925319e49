"""Atomic file output: a crash never leaves a half-written result behind; and the
one guard that keeps HiGHS's stray prints off standard output (quiet_stdout)."""

from __future__ import annotations

import contextlib
import os
import stat
import sys
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
        fd, tmp = _temporary_beside(path)
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


#: how many random names :func:`_temporary_beside` tries before giving up (a name is refused only when
#: a file of that very name exists: one try in practice)
_TEMPORARY_TRIES = 100


def _temporary_beside(path: Path) -> tuple[int, str]:
    """A new, empty file in ``path``'s folder, open for writing (its descriptor and name), with the
    permissions the result should get: ``path``'s own where it exists (a result written again keeps
    them, as ``open(path, "w")`` would), else read-write for all less the process's umask (what
    ``open`` gives a new file: 0o644 under the usual umask 022). ``tempfile.mkstemp`` would make it
    0o600 whatever the umask, so a result shared with a group, or served from a folder, could not be
    read by the others."""
    try:
        keep: int | None = stat.S_IMODE(path.stat().st_mode)
    except FileNotFoundError:
        keep = None
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0)
    for _ in range(_TEMPORARY_TRIES):
        tmp = path.parent / f".{path.name}.{os.urandom(6).hex()}.tmp"
        try:
            fd = os.open(tmp, flags, 0o666)  # the umask applies, as for open()
        except FileExistsError:
            continue
        if keep is not None:
            try:
                os.chmod(tmp, keep)
            except BaseException:
                os.close(fd)
                os.unlink(tmp)
                raise
        return fd, str(tmp)
    raise FileExistsError(f"no free temporary name beside {path} after {_TEMPORARY_TRIES} tries")


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
