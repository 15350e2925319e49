"""Input files: the one way every parser reads and checks a YAML file (the library, the operating
domain, the specification and the study files).

- :class:`StrictLoader`: PyYAML's safe loader (libyaml's where PyYAML has it) that refuses a key
  repeated in one mapping and reads ``1e-3`` as a number (YAML 1.2), plain data only;
- :func:`read_yaml`: a file's document with each mapping's and item's line kept (:class:`Map`,
  :class:`Seq`), every failure (missing, unreadable, malformed YAML) one error naming the file and line;
- :class:`Checker`: the checks of a value under a key path (known keys, numbers, strings, files and
  folders relative to the file), each failure one error naming the file, the key and the line.

Each parser gives its own error class (``error(path, key, message, line)``: e.g.
:class:`~sensorsel.model.domain.DomainError`), so its messages name its kind of file.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any, NoReturn

import yaml

__all__ = ["Checker", "FileError", "Map", "Seq", "StrictLoader", "is_number_text", "read_yaml"]

#: how a parser reports a problem in its file: ``error(path, key path, message, line or None)``
FileError = Callable[[Path, str, str, "int | None"], Exception]


def is_number_text(text: str) -> bool:
    """Whether ``text`` reads as a number (``float(text)`` succeeds): the one check the file readers use."""
    try:
        float(text)
        return True
    except ValueError:
        return False


class StrictLoader(getattr(yaml, "CSafeLoader", yaml.SafeLoader)):  # type: ignore[misc]
    """SafeLoader that refuses a key repeated in one mapping (PyYAML silently keeps the last one,
    so an edited copy of the library could carry two ``range_m`` and use the one not meant).

    On libyaml's parser where PyYAML has it (``CSafeLoader``: the same safe constructors and
    resolvers; the library file took ~60 ms to parse in pure Python, a sixth of loading KITTI 00)."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        seen: dict[Any, int] = {}
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=deep)
            try:
                hash(key)
            except TypeError:
                continue  # the base class reports unhashable keys with their line
            if key in seen:
                raise yaml.constructor.ConstructorError(
                    "while constructing a mapping",
                    node.start_mark,
                    f"key {key!r} repeated (first on line {seen[key]})",
                    key_node.start_mark,
                )
            seen[key] = key_node.start_mark.line + 1
        return super().construct_mapping(node, deep=deep)


# PyYAML follows YAML 1.1, where 1e-3 and 2.5e3 (no dot, or no exponent sign) are text; read them as
# numbers as YAML 1.2 (and every user) does.
StrictLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?[0-9][0-9_]*(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"),
    list("-+0123456789"),
)


class Map(dict):  # type: ignore[type-arg]
    """A mapping read from a file: ``line`` (its first line) and ``lines`` (each key's line)."""

    line: int = 0
    lines: dict[Any, int]


class Seq(list):  # type: ignore[type-arg]
    """A list read from a file: ``line`` (its first line) and ``lines`` (each item's line)."""

    line: int = 0
    lines: list[int]


class LineLoader(StrictLoader):
    """The strict safe loader, keeping each mapping's and item's line (:class:`Map`, :class:`Seq`)."""


def _construct_map(loader: LineLoader, node: yaml.MappingNode) -> Map:
    m = Map(loader.construct_mapping(node, deep=True))
    m.line = node.start_mark.line + 1
    m.lines = {loader.construct_object(k, deep=True): k.start_mark.line + 1 for k, _ in node.value}
    return m


def _construct_seq(loader: LineLoader, node: yaml.SequenceNode) -> Seq:
    s = Seq(loader.construct_sequence(node, deep=True))
    s.line = node.start_mark.line + 1
    s.lines = [child.start_mark.line + 1 for child in node.value]
    return s


LineLoader.add_constructor("tag:yaml.org,2002:map", _construct_map)
LineLoader.add_constructor("tag:yaml.org,2002:seq", _construct_seq)


def read_yaml(path: Path, error: FileError, what: str) -> Any:
    """The YAML document of ``path`` with its lines kept (:class:`Map`, :class:`Seq`); every failure an
    ``error`` naming the file (``what``: the kind of file, for "... not found") and, for malformed
    YAML, the line."""
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise error(path, "", f"{what} not found", None) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise error(path, "", f"cannot read: {exc}", None) from None
    try:
        return yaml.load(text, Loader=LineLoader)  # a SafeLoader: plain data only
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        line = mark.line + 1 if mark is not None else None
        problem = getattr(exc, "problem", None) or str(exc)
        raise error(path, "", "malformed YAML: " + " ".join(str(problem).split()), line) from None


class Checker:
    """The checks of one file's values: each failure an ``error(path, key, message, line)``.

    Args:
        path: the file (paths in it are relative to its folder).
        error: the parser's error class (or any callable of those arguments).
    """

    def __init__(self, path: Path, error: FileError) -> None:
        self.path = path
        self.folder = path.resolve().parent
        self.error = error

    def fail(self, key: str, message: str, line: int | None) -> NoReturn:
        raise self.error(self.path, key, message, line)

    def keys(self, m: Map, key: str, allowed: tuple[str, ...]) -> None:
        """Every key of ``m`` (under the key path ``key``) is one of ``allowed``."""
        for k in m:
            if k not in allowed:
                self.fail(
                    f"{key}.{k}" if key else str(k),
                    f"unknown key; allowed: {', '.join(allowed)}",
                    m.lines.get(k, m.line),
                )

    def number(self, value: Any, key: str, line: int | None, *, minimum: float = 0.0, strict: bool = True) -> float:
        """``value`` as a finite float above ``minimum`` (at least ``minimum`` when not ``strict``)."""
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            hint = (
                " (a number in quotes is text: remove the quotes)"
                if isinstance(value, str) and is_number_text(value)
                else ""
            )
            self.fail(key, f"expected a number, got {value!r}{hint}", line)
        v = float(value)
        if not math.isfinite(v) or v < minimum or (strict and v <= minimum):
            self.fail(key, f"expected a finite number {'>' if strict else '>='} {minimum:g}, got {value!r}", line)
        return v

    def string(self, value: Any, key: str, line: int | None, what: str = "a non-empty string") -> str:
        """``value`` as a non-empty string, stripped."""
        if not isinstance(value, str) or not value.strip():
            self.fail(key, f"expected {what}, got {value!r}", line)
        return value.strip()

    def file(self, value: Any, key: str, line: int | None, *, folder: bool = False) -> str:
        """``value`` as the path of an existing file (or folder), relative to the file's folder or ``~``."""
        text = self.string(value, key, line, "a path")
        p = Path(os.path.expanduser(text))
        p = p if p.is_absolute() else self.folder / p
        if not (p.is_dir() if folder else p.is_file()):
            self.fail(key, f"{'folder' if folder else 'file'} not found: {p}", line)
        return str(p)

    def kitti_root(self, value: Any, key: str, line: int | None) -> str:
        """``value`` as a KITTI odometry dataset folder (one with ``poses/``)."""
        root = self.file(value, key, line, folder=True)
        if not (Path(root) / "poses").is_dir():
            self.fail(
                key, f"{root} is not a KITTI odometry dataset folder (expected {Path(root) / 'poses'}/NN.txt)", line
            )
        return root
