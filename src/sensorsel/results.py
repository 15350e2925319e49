"""Result files: every record sensorsel writes says what it is (``kind``) and in which ``format``.

A result file is the JSON of one record (a frozen dataclass, see :mod:`sensorsel.codec`) with two
keys in front::

    {"kind": "greedy", "format": 1, "suite": [...], ...}

:data:`KINDS` maps each kind to its record class as ``"module:Class"`` (relative to the package),
imported only when a file of that kind is loaded: the record classes do not import this module, and
this module imports no record class until it needs one.

:func:`load` reads a file as the kind the caller expects and refuses anything else: a file of
another kind (the message names the file, the kind found and the kind expected), a format newer than
this sensorsel reads, or a file that does not parse. Files written before kinds existed (no
``kind`` key) are read when they parse as the expected class and have no key it lacks.
"""

from __future__ import annotations

import dataclasses
import importlib
from pathlib import Path
from typing import Any, Iterable, TypeVar, overload

from .codec import dumps as _dumps
from .codec import from_jsonable, read_json, to_jsonable
from .errors import ResultFileError
from .fileio import atomic_write_text

__all__ = ["FORMAT", "KINDS", "dumps", "from_jsonable", "kind_of", "load", "record_class", "save", "to_jsonable"]

T = TypeVar("T")

#: The result format this version writes, and the newest it reads. Bump it when a record changes in
#: a way older versions would misread (a renamed or re-typed field), not for an added field with a
#: default.
FORMAT = 1

#: kind -> "module:Class" (module relative to the sensorsel package). Class names are unique.
KINDS: dict[str, str] = {
    "score": "api:ScoreResult",
    "greedy": "certify:CertifiedGreedyResult",
    "certificate": "certify:Certificate",
    "optimum": "certify:OptimumResult",
    "suite-bound": "certify:SuiteBound",
    "knapsack": "certify:KnapsackSolution",
    "tradespace": "tradespace:TradespaceResult",
    "resilient": "resilient:ResilientReport",
    "resilient-comparison": "resilient:Comparison",
    "resilient-selection": "resilient:ResilientResult",
    "resilient-worst-case": "resilient:WorstCase",
    "resilient-period": "resilient:PeriodResult",
    "resilient-periods": "resilient:PerPeriodResult",
    "resilient-grid": "resilient:SelectionGrid",
    "simulation": "simulate:SimulationReport",
    "simulation-suite": "simulate:SimulationResult",
    "domain-design": "domain_design:DomainDesign",
    "greedy-checkpoint": "checkpoint:GreedyCheckpoint",
    "study": "study:StudyResult",
    "study-cell": "study:StudyCellRecord",
    "domain-score": "api:DomainScoreResult",
    "robust": "robust:RobustResult",
    "robust-optimum": "robust:RobustOptimum",
    "requirement": "requirements:RequireResult",
    "front-acceptance": "requirements:FrontAcceptance",
}

_KIND_OF_NAME = {target.partition(":")[2]: kind for kind, target in KINDS.items()}
assert len(_KIND_OF_NAME) == len(KINDS), "two kinds name the same class"
# a greedy run without its certificate (selection.GreedyResult, the base of CertifiedGreedyResult) is
# written and read as the same kind: its file is a "greedy" file with "certificate": null
_KIND_OF_NAME["GreedyResult"] = "greedy"
_HEADER = ("kind", "format")


def record_class(kind: str) -> type:
    """The record class of ``kind`` (imports its module).

    Raises:
        KeyError: an unknown kind (names the known ones).
    """
    try:
        target = KINDS[kind]
    except KeyError:
        raise KeyError(f"unknown result kind {kind!r}; known: {', '.join(KINDS)}") from None
    module, _, name = target.partition(":")
    cls = getattr(importlib.import_module(f"{__package__}.{module}"), name)
    assert isinstance(cls, type)
    return cls


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


def dumps(obj: Any) -> str:
    """Deterministic JSON text of a result, with its kind and format in front."""
    return _dumps(obj, {"kind": kind_of(obj), "format": FORMAT})


def save(obj: Any, path: str | Path) -> Path:
    """Write a result as JSON (with its kind and format), atomically."""
    return atomic_write_text(path, dumps(obj))


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


def _parse_legacy(cls: type[T], data: dict[str, Any]) -> T:
    """``cls`` from a file without a kind: every key must be a field of ``cls`` (strict, since
    classes whose fields all have defaults would otherwise accept any object)."""
    extra = sorted(set(data) - {f.name for f in dataclasses.fields(cls)})  # type: ignore[arg-type]
    if extra:
        raise KeyError(f"{cls.__name__} has no field {', '.join(map(repr, extra))}")
    return from_jsonable(cls, data)


@overload
def load(path: type[T], expected: str | Path) -> T: ...  # the order before kinds: load(cls, path)
@overload
def load(path: str | Path, expected: type[T]) -> T: ...
@overload
def load(path: str | Path, expected: str | Iterable[Expected] | None = None) -> Any: ...


def load(path: Any, expected: Any = None) -> Any:
    """Read the result file ``path`` as ``expected``: a record class, a kind, several of them, or
    None for any kind (the file must then say its kind).

    ``load(cls, path)``, the order before kinds existed, is accepted too.

    Raises:
        ResultFileError: missing or not JSON; a result of another kind (names the file, the kind
            found and the kind expected); a format newer than :data:`FORMAT`; a file without kind
            that does not parse as the expected class; a record that does not parse.
    """
    if isinstance(path, type):
        path, expected = expected, path
    path = Path(path)
    wanted = _wanted(expected)
    data = read_json(path)
    if not isinstance(data, dict):
        raise ResultFileError(path, f"not a result file: holds a JSON {type(data).__name__}, expected an object")
    if "kind" not in data:
        errors = []
        for kind, cls in wanted:
            cls = cls or record_class(kind)
            try:
                return _parse_legacy(cls, data)
            except (TypeError, ValueError, KeyError) as exc:
                errors.append(f"not a {kind!r} result: {str(exc).strip(chr(34) + chr(39))}")
        raise ResultFileError(path, "has no \"kind\" key (a file from before result kinds, or not a result) and "
                                    + "; ".join(errors))
    kind = data["kind"]
    found = dict(wanted)
    if not isinstance(kind, str) or kind not in found:
        what = f"{kind!r} result" if isinstance(kind, str) and kind in KINDS else (
            f"result of kind {kind!r}, a kind this sensorsel does not know" if isinstance(kind, str) else f"file with \"kind\": {kind!r}")
        raise ResultFileError(path, f"is a {what}, expected a {_names(wanted)} result")
    fmt = data.get("format")
    if isinstance(fmt, bool) or not isinstance(fmt, int) or fmt < 1:
        raise ResultFileError(path, f"\"format\" must be a positive integer, got {fmt!r}")
    if fmt > FORMAT:
        raise ResultFileError(path, f"a {kind!r} result in format {fmt}, written by a newer sensorsel; this one reads "
                                    f"formats up to {FORMAT}: upgrade sensorsel to read it")
    cls = found[kind] or record_class(kind)
    body = {k: v for k, v in data.items() if k not in _HEADER}
    try:
        return from_jsonable(cls, body)
    except (TypeError, ValueError, KeyError) as exc:
        raise ResultFileError(path, f"not a valid {kind!r} result: {str(exc).strip(chr(34) + chr(39))}") from None
