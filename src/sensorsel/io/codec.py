"""JSON of frozen dataclasses (base layer: imports only errors and files).

:func:`to_jsonable` / :func:`from_jsonable` convert any (nested) frozen dataclass of numbers,
strings, tuples, ``None`` and dataclasses to plain JSON values and back, by the dataclass's type
hints. :func:`dumps` is deterministic (fixed key order, ``repr`` floats), so the same result gives
the same bytes. :func:`read_json` reads a file as JSON, every failure a :class:`ResultFileError`.

A JSON object has its dataclass's fields in order, except the fields made with :func:`last`: they
come after the others (in their own order). A part every record ends with (the target a run was
computed on, its wall time, ...) is then a base class, whose fields a dataclass puts first, and still
the end of each record's JSON.

Result *files* (with their ``kind`` and ``format`` keys) are :mod:`sensorsel.io.results`.
"""

from __future__ import annotations

import dataclasses
import json
import math
import types
import typing
from collections.abc import Mapping
from pathlib import Path
from typing import Any, TypeVar, cast

from sensorsel.errors import ResultFileError
from sensorsel.io.files import atomic_write_text

T = TypeVar("T")

#: the metadata of a field made with :func:`last`
LAST: Mapping[str, Any] = types.MappingProxyType({"json": "last"})


def last(default: T) -> T:
    """A keyword-only field with ``default``, written after its record's other fields (:func:`json_fields`).

    Keyword-only, so that a part of such fields may be a base of records whose own fields have no
    default; typed as its default, as a dataclass's ``field()`` is to mypy."""
    return dataclasses.field(default=default, kw_only=True, metadata=LAST)


def json_fields(obj: Any) -> tuple[dataclasses.Field[Any], ...]:
    """The fields of a dataclass (or an instance) in the order its JSON object has them: in order, those
    made with :func:`last` after the others."""
    every = dataclasses.fields(obj)
    written_last = [f.metadata.get("json") == "last" for f in every]
    return tuple(f for f, w in zip(every, written_last) if not w) + tuple(f for f, w in zip(every, written_last) if w)


def to_jsonable(obj: Any) -> Any:
    """Plain JSON value of a dataclass / tuple / list / dict / scalar (NaN and inf become strings)."""
    # the leaves and sequences of large files first, by exact type: a journal of 25,000 answers is
    # ~400,000 of them, and asking each whether it is a dataclass took as long as writing the JSON
    t = type(obj)
    if t is int or t is str or t is bool or obj is None:
        return obj
    if t is float:
        return obj if math.isfinite(obj) else repr(obj)
    if t is tuple or t is list:
        return [to_jsonable(v) for v in obj]
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {f.name: to_jsonable(getattr(obj, f.name)) for f in json_fields(obj)}
    if isinstance(obj, (tuple, list)):
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, dict):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else repr(obj)
    if hasattr(obj, "item") and callable(obj.item):  # numpy scalar
        return to_jsonable(obj.item())
    return obj


def _convert(value: Any, hint: Any) -> Any:
    origin = typing.get_origin(hint)
    args = typing.get_args(hint)
    if hint is Any:
        return value
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        for a in args:
            if a is type(None):
                continue
            try:
                return _convert(value, a)
            except (TypeError, ValueError, KeyError):
                continue
        raise ValueError(f"{value!r} matches none of {hint}")
    if isinstance(hint, type) and dataclasses.is_dataclass(hint):
        return from_jsonable(cast(type, hint), value)
    if origin is tuple:
        if not isinstance(value, list):
            raise TypeError(f"expected a list, got {value!r}")
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_convert(v, args[0]) for v in value)
        return tuple(_convert(v, a) for v, a in zip(value, args, strict=True))
    if origin is list:
        return [_convert(v, args[0]) for v in value]
    if origin is dict:
        return {_convert(k, args[0]): _convert(v, args[1]) for k, v in value.items()}
    if hint is float:
        if isinstance(value, str) and value in ("nan", "inf", "-inf"):
            return float(value)
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise TypeError(f"expected a number, got {value!r}")
        return float(value)
    if hint is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise TypeError(f"expected an integer, got {value!r}")
        return value
    if hint is str:
        if not isinstance(value, str):
            raise TypeError(f"expected a string, got {value!r}")
        return value
    if hint is bool:
        if not isinstance(value, bool):
            raise TypeError(f"expected true/false, got {value!r}")
        return value
    return value


def from_jsonable(cls: type[T], data: Any) -> T:
    """Rebuild a dataclass ``cls`` from :func:`to_jsonable` output (checks types as it goes)."""
    if not isinstance(data, dict):
        raise TypeError(f"expected an object for {cls.__name__}, got {type(data).__name__}")
    hints = typing.get_type_hints(cls)
    kwargs = {}
    for f in dataclasses.fields(cast(Any, cls)):
        if f.name not in data:
            if f.default is not dataclasses.MISSING or f.default_factory is not dataclasses.MISSING:
                continue
            raise KeyError(f"{cls.__name__}.{f.name} is missing")
        kwargs[f.name] = _convert(data[f.name], hints[f.name])
    return cls(**kwargs)


def dumps(obj: Any, header: Mapping[str, Any] | None = None, *, compact: bool = False) -> str:
    """Deterministic JSON text of ``obj``; ``header`` keys (e.g. kind, format) come first.

    ``compact``: on one line, for files a program rereads (a checkpoint rewritten every few seconds):
    Python's JSON encoder indents in Python, ~5x slower than its C encoder writes one line."""
    data = to_jsonable(obj)
    if header:
        if not isinstance(data, dict):
            raise TypeError(f"a header needs an object, not {type(obj).__name__}")
        clash = sorted(set(header) & set(data))
        if clash:
            raise TypeError(f"{type(obj).__name__} has fields named like header keys: {', '.join(clash)}")
        data = {**to_jsonable(dict(header)), **data}
    if compact:
        return json.dumps(data, separators=(",", ":"), allow_nan=False) + "\n"
    return json.dumps(data, indent=2, allow_nan=False) + "\n"


def save(obj: Any, path: str | Path, header: Mapping[str, Any] | None = None) -> Path:
    """Write :func:`dumps` of ``obj`` to ``path``, atomically."""
    return atomic_write_text(path, dumps(obj, header))


def read_json(path: str | Path) -> Any:
    """The JSON value in the file ``path``.

    Raises:
        ResultFileError: missing file, unreadable, or not JSON (names the file).
    """
    path = Path(path)
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ResultFileError(path, "file not found") from None
    except IsADirectoryError:
        raise ResultFileError(path, "is a folder, expected a result file") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ResultFileError(path, f"not a JSON file sensorsel wrote: {exc}") from None
