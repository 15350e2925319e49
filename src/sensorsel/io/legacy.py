"""What result files written by an older sensorsel need to be read: the one place it is done.

:func:`sensorsel.io.results.load` calls these, and nothing else in sensorsel knows an older file:

- a file without ``"kind"`` (written before result kinds): :func:`parse_kindless` reads it as the
  class the caller expects, strictly (every key a field of that class);
- ``"method": "paper"``, a second name older files give the paper's Algorithm 2
  (resilient results, their periods and grids): :func:`upgrade` reads it as ``"algorithm-2"``.

Both go away in sensorsel :data:`REMOVED_IN`: a file of either kind is then refused as any file
that is not a result (rewrite it by running its command again). The command line and the library
take only today's names (``--method algorithm-2``).
"""

from __future__ import annotations

import dataclasses
from typing import Any, TypeVar

from sensorsel.io.codec import from_jsonable

__all__ = ["REMOVED_IN", "RENAMED_VALUES", "parse_kindless", "upgrade"]

T = TypeVar("T")

#: the release in which files written before result kinds, or naming a method by its old name, stop being read
REMOVED_IN = "0.2.0"

#: key -> {old value: value today}, wherever the key appears in a result file
RENAMED_VALUES: dict[str, dict[str, str]] = {"method": {"paper": "algorithm-2"}}


def upgrade(data: Any) -> Any:
    """``data`` (a result file's JSON) with every old value of :data:`RENAMED_VALUES` by its name today."""
    if isinstance(data, dict):
        out = {}
        for k, v in data.items():
            renamed = RENAMED_VALUES.get(k)
            out[k] = renamed.get(v, v) if renamed is not None and isinstance(v, str) else upgrade(v)
        return out
    if isinstance(data, list):
        return [upgrade(v) for v in data]
    return data


def parse_kindless(cls: type[T], data: dict[str, Any]) -> T:
    """``cls`` from a file without a kind: every key must be a field of ``cls`` (strict, since
    classes whose fields all have defaults would otherwise accept any object).

    Raises:
        KeyError, TypeError, ValueError: the file does not parse as ``cls``.
    """
    extra = sorted(set(data) - {f.name for f in dataclasses.fields(cls)})  # type: ignore[arg-type]
    if extra:
        raise KeyError(f"{cls.__name__} has no field {', '.join(map(repr, extra))}")
    return from_jsonable(cls, data)
