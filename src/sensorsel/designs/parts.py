"""The parts design records end with: what a run was computed on, its wall time and the limits it kept
(:class:`Provenance`), and the chosen suite's accuracy and integrity (:class:`SuiteQuality`).

They complete the parts of :mod:`sensorsel.io.records` (a suite and its cost, its score, the budget,
a worst case), which the records begin with; these hold types of the model and the information, so
they live here, below every design. A record lists them among its bases, ``SuiteQuality`` before
``Provenance`` (``class OptimumResult(SuiteQuality, Provenance, SuiteScore, Budget)``); their fields are
keyword-only and made with :func:`sensorsel.io.codec.last`, so the record's JSON is its own fields,
then ``problem, seconds, constraints``, then ``accuracy, integrity``: the bytes it had with the
fields written out. Each field is documented here once. :func:`provenance` fills a ``Provenance`` at
the end of a run and :func:`elapsed_s` is the wall time every design record gives, both written once.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import TypedDict

from sensorsel.information.evaluators.accuracy import RouteAccuracy
from sensorsel.information.integrity import RouteIntegrity
from sensorsel.io.codec import last
from sensorsel.model.constraints import Constraints
from sensorsel.model.problem import TargetInfo

__all__ = ["Provenance", "ProvenanceFields", "SuiteQuality", "elapsed_s", "provenance"]


@dataclass(frozen=True, kw_only=True)
class Provenance:
    """What a run was computed on, how long it took and the limits it kept.

    Attributes:
        problem: what it was computed on (the route's or the domain's info); None in records built
            without a target.
        seconds: wall time [s] (the only field that varies between two identical runs).
        constraints: the limits besides the budget the run kept
            (:class:`~sensorsel.model.constraints.Constraints`); None: the budget alone.
    """

    problem: TargetInfo | None = last(None)
    seconds: float = last(0.0)
    constraints: Constraints | None = last(None)


@dataclass(frozen=True, kw_only=True)
class SuiteQuality:
    """The chosen suite's accuracy and integrity on each route (one for a single route).

    Attributes:
        accuracy: its accuracy in metres and degrees, per keyframe; empty when not computed (the
            command line computes it: :func:`sensorsel.api.with_suite_quality`).
        integrity: its integrity (:mod:`sensorsel.information.integrity`); empty when not computed
            (the command line computes it).
    """

    accuracy: tuple[RouteAccuracy, ...] = last(())
    integrity: tuple[RouteIntegrity, ...] = last(())


class ProvenanceFields(TypedDict):
    """:class:`Provenance`'s fields as keywords (``Record(..., **provenance(info, t0, limits))``)."""

    problem: TargetInfo | None
    seconds: float
    constraints: Constraints | None


def elapsed_s(started: float) -> float:
    """Wall time [s] since ``started`` (a :func:`time.perf_counter` reading), to the microsecond: the
    ``seconds`` of every design record."""
    return round(time.perf_counter() - started, 6)


def provenance(problem: TargetInfo | None, started: float, constraints: Constraints | None) -> ProvenanceFields:
    """What a run that began at ``started`` (:func:`time.perf_counter`) was computed on, how long it took
    until now and the limits it kept: a :class:`Provenance`'s fields, to pass as keywords."""
    return {"problem": problem, "seconds": elapsed_s(started), "constraints": constraints}
