"""Result files: every record sensorsel writes says what it is (``kind``) and in which ``format``.

A result file is the JSON of one record (a frozen dataclass, see :mod:`sensorsel.io.codec`) with two
keys in front::

    {"kind": "greedy", "format": 1, "suite": [...], ...}

:data:`KINDS` maps each kind to its record class; each record class registers itself with the
:func:`result_kind` decorator (``@result_kind("tradespace")``), so this module depends on none of
them and the layers contract sees every dependency.

:func:`load` reads a file as the kind the caller expects and refuses anything else: a file of
another kind (the message names the file, the kind found and the kind expected), a format newer than
this sensorsel reads, or a file that does not parse. Files written before kinds existed (no
``kind`` key) are read when they parse as the expected class and have no key it lacks.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any, TypeVar, overload

from sensorsel.errors import ResultFileError
from sensorsel.io import legacy
from sensorsel.io.codec import dumps as _dumps
from sensorsel.io.codec import from_jsonable, read_json, to_jsonable
from sensorsel.io.files import atomic_write_text

__all__ = [
    "FORMAT",
    "KINDS",
    "dumps",
    "from_jsonable",
    "kind_of",
    "load",
    "record_class",
    "result_kind",
    "save",
    "to_jsonable",
]

T = TypeVar("T")

#: The result format this version writes, and the newest it reads. Bump it when a record changes in
#: a way older versions would misread (a renamed or re-typed field), not for an added field with a
#: default.
FORMAT = 1

#: kind -> record class, filled by the record classes themselves (:func:`result_kind`, as
#: ``evaluators.ENGINES`` is): this module imports none of them. Every kind is registered once the
#: package is imported (``sensorsel/__init__`` imports every module that defines one).
KINDS: dict[str, type] = {}
#: record class name -> kind (a greedy run without its certificate, ``selection.GreedyResult``, is
#: written as a "greedy" file with "certificate": null, and read as ``CertifiedGreedyResult``)
_KIND_OF_NAME: dict[str, str] = {}
_HEADER = ("kind", "format")


def result_kind(kind: str, *, read: bool = True) -> Callable[[type[T]], type[T]]:
    """Class decorator: the record class is the result kind ``kind`` (written with it, read as it).
    ``read=False``: written as ``kind`` only (another class reads it).

    Raises:
        ValueError: the kind, or the class name, is registered already for another.
    """

    def register(cls: type[T]) -> type[T]:
        if read:
            if KINDS.get(kind, cls) is not cls:
                raise ValueError(f"result kind {kind!r} is already registered ({KINDS[kind].__qualname__})")
            KINDS[kind] = cls
        if _KIND_OF_NAME.get(cls.__name__, kind) != kind:
            raise ValueError(f"record class {cls.__name__} is already the kind {_KIND_OF_NAME[cls.__name__]!r}")
        _KIND_OF_NAME[cls.__name__] = kind
        return cls

    return register


def record_class(kind: str) -> type:
    """The record class of ``kind``.

    Raises:
        KeyError: an unknown kind (names the known ones).
    """
    try:
        return KINDS[kind]
    except KeyError:
        raise KeyError(f"unknown result kind {kind!r}; known: {', '.join(KINDS)}") from None


def kind_of(obj: Any) -> str:
    """The kind of a record or record class.

    Raises:
        TypeError: not a record kind sensorsel writes.
    """
    cls = obj if isinstance(obj, type) else type(obj)
    kind = _KIND_OF_NAME.get(cls.__name__)
    if kind is None or not dataclasses.is_dataclass(cls):
        raise TypeError(f"{cls.__name__} is not a result kind sensorsel writes (kinds: {', '.join(KINDS)})")
    return kind


def dumps(obj: Any, *, compact: bool = False) -> str:
    """Deterministic JSON text of a result, with its kind and format in front (``compact``: on one
    line, :func:`~sensorsel.io.codec.dumps`)."""
    return _dumps(obj, {"kind": kind_of(obj), "format": FORMAT}, compact=compact)


def save(obj: Any, path: str | Path, *, compact: bool = False) -> Path:
    """Write a result as JSON (with its kind and format), atomically; ``compact``: on one line (a
    checkpoint rewritten while a run goes on), read back the same."""
    return atomic_write_text(path, dumps(obj, compact=compact))


Expected = type | str


def _wanted(expected: Expected | Iterable[Expected] | None) -> list[tuple[str, type | None]]:
    """[(kind, class or None when not imported yet)] of what the caller accepts."""
    if expected is None:
        return [(k, None) for k in KINDS]
    items = [expected] if isinstance(expected, (type, str)) else list(expected)
    out: list[tuple[str, type | None]] = []
    for e in items:
        if isinstance(e, str):
            if e not in KINDS:
                raise KeyError(f"unknown result kind {e!r}; known: {', '.join(KINDS)}")
            out.append((e, None))
        else:
            out.append((kind_of(e), e))
    return out


def _names(wanted: list[tuple[str, type | None]]) -> str:
    kinds = [repr(k) for k, _ in wanted]
    return kinds[0] if len(kinds) == 1 else ", ".join(kinds[:-1]) + " or " + kinds[-1]


@overload
def load(path: str | Path, expected: type[T]) -> T: ...
@overload
def load(path: str | Path, expected: str | Iterable[Expected] | None = None) -> Any: ...


def load(path: str | Path, expected: Any = None) -> Any:
    """Read the result file ``path`` as ``expected``: a record class, a kind, several of them, or
    None for any kind (the file must then say its kind). A file an older sensorsel wrote is read
    as :mod:`sensorsel.io.legacy` says (until the release it names).

    Raises:
        ResultFileError: missing or not JSON; a result of another kind (names the file, the kind
            found and the kind expected); a format newer than :data:`FORMAT`; a file without kind
            that does not parse as the expected class; a record that does not parse.
    """
    path = Path(path)
    wanted = _wanted(expected)
    data = read_json(path)
    if not isinstance(data, dict):
        raise ResultFileError(path, f"not a result file: holds a JSON {type(data).__name__}, expected an object")
    data = legacy.upgrade(data)
    if "kind" not in data:
        errors = []
        for kind, cls in wanted:
            cls = cls or record_class(kind)
            try:
                return legacy.parse_kindless(cls, data)
            except (TypeError, ValueError, KeyError) as exc:
                errors.append(f"not a {kind!r} result: {str(exc).strip(chr(34) + chr(39))}")
        raise ResultFileError(
            path, 'has no "kind" key (a file from before result kinds, or not a result) and ' + "; ".join(errors)
        )
    kind = data["kind"]
    found = dict(wanted)
    if not isinstance(kind, str) or kind not in found:
        what = (
            f"{kind!r} result"
            if isinstance(kind, str) and kind in KINDS
            else (
                f"result of kind {kind!r}, a kind this sensorsel does not know"
                if isinstance(kind, str)
                else f'file with "kind": {kind!r}'
            )
        )
        raise ResultFileError(path, f"is a {what}, expected a {_names(wanted)} result")
    fmt = data.get("format")
    if isinstance(fmt, bool) or not isinstance(fmt, int) or fmt < 1:
        raise ResultFileError(path, f'"format" must be a positive integer, got {fmt!r}')
    if fmt > FORMAT:
        raise ResultFileError(
            path,
            f"a {kind!r} result in format {fmt}, written by a newer sensorsel; this one reads "
            f"formats up to {FORMAT}: upgrade sensorsel to read it",
        )
    cls = found[kind] or record_class(kind)
    body = {k: v for k, v in data.items() if k not in _HEADER}
    try:
        return from_jsonable(cls, body)
    except (TypeError, ValueError, KeyError) as exc:
        raise ResultFileError(path, f"not a valid {kind!r} result: {str(exc).strip(chr(34) + chr(39))}") from None
