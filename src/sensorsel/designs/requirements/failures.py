"""Failures in the requirement solver (:mod:`.solver`, whose docstring gives the method and the
property the proof keeps): the floors that fix sensors out with no check, several cuts per
integer program, and which suites meet a monotone requirement after failures."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from itertools import combinations
from typing import Any

import numpy as np

from sensorsel.designs.requirements.oracle import Monotone
from sensorsel.designs.requirements.oracle import mask_of as _mask
from sensorsel.designs.requirements.programs import floor_cost
from sensorsel.designs.requirements.programs import tol as _tol

__all__ = ["floors", "meets_after_failures", "more_cuts"]

#: meets(suite) -> bool on sorted tuples of library positions
Meets = Callable[[tuple[int, ...]], bool]


def floors(s: Any, upper: float, programs: list[float]) -> dict[int, float]:
    """For each sensor i not fixed out that costs something: a lower bound [$] on the cost of a
    suite that passes ``down`` without i and without the sensors fixed out
    (:func:`.programs.floor_cost`). What is left of a suite that holds i after i and α - 1
    other sensors fail is such a suite, so a suite that meets the requirement after α failures
    and holds i costs at least price_i plus it. One program for all the sensors outside its
    optimal suite, one more for each sensor inside; none when the cuts are as last time."""
    if s.down is None or not math.isfinite(upper):
        return {}
    # recomputed when the best suite or the sensors left change, or the failing sets known grow
    # by a quarter: each costs programs, and the floors move slowly with the cuts
    cuts = len(s.down.failing.masks)
    was_upper, was_fixed, was_cuts = s.floors_from
    if (upper, s.fixed_out) == (was_upper, was_fixed) and cuts < 1.25 * was_cuts:
        return s.floor_values
    s.floors_from = (upper, s.fixed_out, cuts)
    # a passing set known without i caps its floor: a sensor whose price plus that cap is within
    # ``upper`` cannot be fixed out, and costs no program
    passing = [(s.cost(m), m) for m in s.down.meeting.masks if not m & s.fixed_out]
    left = [
        i
        for i in s.allowed
        if not (s.required | s.fixed_out) >> i & 1
        and s.price[i] > 0
        and s.price[i] + min((c for c, m in passing if not m >> i & 1), default=math.inf) > upper + _tol(upper)
    ]
    if not left:
        s.floor_values = {}
        return s.floor_values
    s.before_program()  # one program per sensor inside: the time limit is read before each
    floor, best = floor_cost(s, programs)
    out = {i: floor for i in left}
    for i in left:
        if best is None or best >> i & 1:
            s.before_program()
            out[i] = max(floor, floor_cost(s, programs, without=1 << i)[0])
    s.floor_values = {i: f - _tol(f) for i, f in out.items()}
    return s.floor_values


def more_cuts(s: Any, proposal: int) -> None:
    """With failures: every other part of a failing proposal that fails (losing α of its
    sensors) grown into a cut too, several cuts per integer program. Parts known to fail (inside
    a cut already) or to pass cost nothing."""
    assert s.down is not None
    members = [i for i in s.dear_first if proposal >> i & 1]
    for f in combinations(members, min(s.alpha, len(members))):
        rest = proposal & ~_mask(f)
        if s.down.infer(rest) is None and not s.down.passes(rest):
            s.grow(rest)


def meets_after_failures(meets: Meets, suites: Sequence[Iterable[int]], *, failures: int = 0) -> tuple[bool, ...]:
    """Which of ``suites`` (e.g. the suites of a Pareto front) meet a monotone requirement after any
    ``failures`` of their sensors fail, with the solver's cache and monotone inference (a suite
    holding one that meets, meets; one inside one that fails, fails), so a front of nested suites
    costs few calls.

    Args:
        meets: the monotone predicate.
        suites: suites as library positions.
        failures: α >= 0.

    Returns:
        One bool per suite, in order.
    """
    if isinstance(failures, bool) or not isinstance(failures, (int, np.integer)) or failures < 0:
        raise ValueError(f"failures must be a whole number >= 0, got {failures!r}")
    oracle = Monotone(max([int(i) + 1 for s_ in suites for i in s_], default=1), meets)
    alpha = int(failures)
    out = []
    for suite in suites:
        mask = _mask(suite)
        members = sorted(set(int(i) for i in suite))
        k = min(alpha, len(members))
        ok = oracle.passes(mask) and all(oracle.passes(mask & ~_mask(f)) for f in combinations(members, k))
        out.append(ok)
    return tuple(out)
