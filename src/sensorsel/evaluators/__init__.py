"""Evaluators: log det engines behind one interface (:class:`Evaluator`), one registry (:data:`ENGINES`).

    reference   GTSAM graph built, linearized and eliminated per suite (the paper's method, the oracle)
    fast        the same numbers from pieces linearized once (see :mod:`sensorsel.evaluators.fast`)

Every engine gives the reference's numbers to round-off; they differ in speed only.
"""

from __future__ import annotations

from typing import TypeVar

from ..errors import InputError
from ..problem import Problem
from .base import Evaluator, Suite, as_suite
from .fast import FastEvaluator
from .reference import ReferenceEvaluator

__all__ = ["Evaluator", "Suite", "as_suite", "ENGINES", "DEFAULT_ENGINE", "register", "make_evaluator",
           "ReferenceEvaluator", "FastEvaluator"]

#: engine name -> evaluator class; classes are constructed as ``cls(problem, jobs=jobs)``
ENGINES: dict[str, type[Evaluator]] = {}
#: the engine used when none is named: the fastest registered
DEFAULT_ENGINE = "fast"

E = TypeVar("E", bound=type[Evaluator])


def register(cls: E) -> E:
    """Class decorator: add an evaluator class to :data:`ENGINES` under its ``name``."""
    if not cls.name:
        raise ValueError(f"{cls.__qualname__} has no engine name")
    if ENGINES.get(cls.name, cls) is not cls:
        raise ValueError(f"engine {cls.name!r} is already registered ({ENGINES[cls.name].__qualname__})")
    ENGINES[cls.name] = cls
    return cls


register(ReferenceEvaluator)
register(FastEvaluator)


def make_evaluator(problem: Problem, engine: str | None = None, *, jobs: int = 1) -> Evaluator:
    """An evaluator of the named engine (default :data:`DEFAULT_ENGINE`) for ``problem``.

    Raises:
        InputError: ``engine`` is not registered (the message names the available ones).
    """
    name = engine or DEFAULT_ENGINE
    if name not in ENGINES:
        raise InputError(f"unknown engine {name!r}; available: {', '.join(sorted(ENGINES))}")
    return ENGINES[name](problem, jobs=jobs)
