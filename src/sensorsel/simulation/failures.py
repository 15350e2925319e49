"""Sensor failures of a simulation: parsing ``ID[@FROM-TO],...`` and checking them against the route."""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from sensorsel.errors import InputError
from sensorsel.model.problem import Problem
from sensorsel.simulation.records import Failure


def parse_failures(text: str, problem: Problem) -> tuple[Failure, ...]:
    """Failures from ``ID[@FROM-TO],...``: the whole route, keyframes FROM..TO-1, or seconds ``@30s-60s``.

    A period in seconds counts from the first keyframe's time and covers the keyframes with
    FROM <= t < TO. The same sensor may be listed with several periods.

    Raises:
        InputError: an unknown id, a malformed period, or one outside the route (names the item).
    """
    lib = problem.library
    out = []
    for item in (t.strip() for t in text.split(",")):
        if not item:
            continue
        sid, _, period = item.partition("@")
        sensor = lib[lib.position(sid.strip())].id
        out.append(_parse_period(item, sensor, period, problem) if period else Failure(sensor))
    for f in out:
        check_failure(f, problem)
    return tuple(out)


def _parse_period(item: str, sensor: str, period: str, problem: Problem) -> Failure:
    """The failure of ``sensor`` over ``period`` (``FROM-TO`` keyframes or ``FROMs-TOs`` seconds)."""
    kf = problem.scenario.keyframes
    lo, sep, hi = period.partition("-")
    seconds = lo.strip().endswith("s") and hi.strip().endswith("s")
    try:
        if not sep:
            raise ValueError
        a, b = (float(v.strip().rstrip("s")) for v in (lo, hi))
    except ValueError:
        raise InputError(
            f"failure {item!r}: expected ID, ID@FROM-TO (keyframe indices, TO excluded) or ID@FROMs-TOs (seconds)"
        ) from None
    if seconds:
        t = kf.times - kf.times[0]
        idx = np.nonzero((t >= a) & (t < b))[0]
        if b <= a or len(idx) == 0:
            raise InputError(f"failure {item!r}: no keyframe in [{a:g} s, {b:g} s) (route lasts {t[-1]:g} s)")
        return Failure(sensor, int(idx[0]), int(idx[-1]) + 1)
    if a != int(a) or b != int(b):
        raise InputError(f"failure {item!r}: keyframe indices must be integers (add 's' for seconds: @{lo}s-{hi}s)")
    return Failure(sensor, int(a), int(b))


def check_failure(f: Failure, problem: Problem) -> Failure:
    """``f`` with its stop resolved (None: the route's end), if it lies inside the route.

    Raises:
        InputError: keyframes outside 0..K-1 or an empty range.
    """
    k = problem.scenario.n_poses
    stop = k if f.stop is None else f.stop
    if not (0 <= f.start < stop <= k):
        raise InputError(
            f"failure {f.describe()!r}: keyframes {f.start}..{stop - 1} are not inside the route (0..{k - 1})"
        )
    return Failure(f.sensor, f.start, stop)


def resolve_failures(failures: Iterable[Failure], problem: Problem, suite: tuple[int, ...]) -> tuple[Failure, ...]:
    """Failures of sensors of ``suite`` (library positions), checked and with their stops resolved.

    Raises:
        InputError: a failed sensor not in the suite, or a range outside the route.
    """
    lib = problem.library
    ids = set(lib.suite_ids(suite))
    resolved = []
    for f in failures:
        if f.sensor not in ids:
            raise InputError(
                f"failed sensor {f.sensor!r} is not in the suite {','.join(lib.suite_ids(suite)) or '(empty)'}"
            )
        resolved.append(check_failure(f, problem))
    return tuple(resolved)
