"""The registry of per-problem engines: name -> class, and the factory that builds one."""

from __future__ import annotations

from typing import TypeVar

from sensorsel.errors import InputError
from sensorsel.information.evaluators.base import ProblemEvaluator
from sensorsel.information.evaluators.fast import FastEvaluator
from sensorsel.information.evaluators.reference import ReferenceEvaluator
from sensorsel.model.problem import Problem

#: engine name -> evaluator class; classes are constructed as ``cls(problem, jobs=jobs)``
ENGINES: dict[str, type[ProblemEvaluator]] = {}
#: the engine used when none is named: the fastest registered
DEFAULT_ENGINE = "fast"

E = TypeVar("E", bound=type[ProblemEvaluator])


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


def check_engine(engine: str | None) -> str:
    """The engine's registered name (``None``: :data:`DEFAULT_ENGINE`).

    Raises:
        InputError: ``engine`` is not registered (the message names the available ones).
    """
    name = engine or DEFAULT_ENGINE
    if name not in ENGINES:
        raise InputError(f"unknown engine {name!r}; available: {', '.join(sorted(ENGINES))}")
    return name


def make_evaluator(problem: Problem, engine: str | None = None, *, jobs: int = 1) -> ProblemEvaluator:
    """An evaluator of the named engine (default :data:`DEFAULT_ENGINE`) for ``problem``.

    Raises:
        InputError: ``engine`` is not registered (the message names the available ones).
    """
    return ENGINES[check_engine(engine)](problem, jobs=jobs)
