"""Typed exceptions. Every message names the file, line or key at fault and the bad value.

The CLI turns any :class:`SensorselError` into one line on stderr and exit code 2; anything else is
a bug and keeps its traceback.
"""

from __future__ import annotations

from pathlib import Path


class SensorselError(Exception):
    """Base class of every error sensorsel raises for bad input."""


class LibraryError(SensorselError):
    """The sensor library file is malformed: names the file and the key path, e.g. ``models[2].range_m``."""

    def __init__(self, path: str | Path, key: str, message: str) -> None:
        self.path = str(path)
        self.key = key
        super().__init__(f"{path}: {key}: {message}" if key else f"{path}: {message}")


class ScenarioError(SensorselError):
    """A trajectory, timestamp or landmark file is missing or malformed: names the file and line."""

    def __init__(self, path: str | Path, message: str, line: int | None = None) -> None:
        self.path = str(path)
        self.line = line
        where = f"{path}:{line}" if line is not None else f"{path}"
        super().__init__(f"{where}: {message}")


class InputError(SensorselError):
    """A bad argument (budget, suite id, option value): names the argument and the value."""


class ResultFileError(SensorselError):
    """A result JSON file is missing or is not what sensorsel wrote."""

    def __init__(self, path: str | Path, message: str) -> None:
        self.path = str(path)
        self.reason = message
        super().__init__(f"{path}: {message}")


class OutputError(SensorselError):
    """An output file or folder cannot be written (no such folder, not a folder, no permission, disk full)."""

    def __init__(self, path: str | Path, message: str) -> None:
        self.path = str(path)
        self.reason = message
        super().__init__(f"{path}: cannot write: {message}")


class SensorselWarning(UserWarning):
    """Base class of the warnings sensorsel gives about input it still uses (the CLI prints them as
    one line ``sensorsel: warning: ...`` on stderr, exit status unchanged)."""
