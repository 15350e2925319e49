"""Checking a suite against a specification with a filter pass that stops early: only the keyframes
where a suite it holds was seen to miss it matter.

Adding sensors only adds measurements, so for suites S ⊆ T the filter's covariance of T is ⪯ that
of S at *every* keyframe (each is the marginal of a graph with more factors), and every σ of T is at
most S's there. So a keyframe where S meets a component's limit, T meets it too: T's *bad*
keyframes for a component (those over its limit) are among S's. Knowing S's bad keyframes (or any
superset of them) per component, T's are found by a pass that stops after the last of them
(:func:`sensorsel.information.filtering.forward_pass` with ``until``: the same numbers at those
keyframes as the whole pass), and the specification's rank rule is decided exactly: a component
is met when at least ⌈at·K⌉ keyframes are within its limit.

In the growth of a failing set (the set S fails; S plus one sensor is asked, mostly met) the bad
keyframes of S are few and often early on the route: the pass of S plus a sensor stops there
instead of running the whole route.

Every comparison is the one :func:`~sensorsel.designs.requirements.spec.covariance_verdict` makes
(σ · factor / limit − 1 > 0 at a keyframe), so the answers are those of the whole pass.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from sensorsel.designs.requirements.spec import Specification, _rank, component_sigmas

__all__ = [
    "Bad",
    "BadKeyframes",
    "BadList",
    "bad_keyframes",
    "floors_to_solve",
    "mask_of_bad",
    "meets_from_bad",
    "meets_from_mask",
    "over_limits",
]

#: per component of the specification (in ``spec.bounds()`` order): the sorted bad keyframes
Bad = tuple[np.ndarray, ...]
#: the same as it travels and is journalled: per component, the bad keyframes (ascending) as integers
BadList = tuple[tuple[int, ...], ...]


def over_limits(covariances: np.ndarray, spec: Specification, slack: float = 0.0) -> np.ndarray:
    """(C, k) whether each of the (k, 3, 3) ``covariances`` exceeds each of ``spec``'s C components'
    limits (in ``spec.bounds()`` order), as
    :func:`~sensorsel.designs.requirements.spec.covariance_verdict` judges a keyframe: σ · factor /
    limit − 1 > ``slack`` (0: the verdict's own test; a bound's callers move it off 0 by its
    round-off, so that a keyframe the exact pass could judge either way is not decided by a bound)."""
    sig = component_sigmas(np.asarray(covariances, dtype=float).reshape(-1, 3, 3))
    rows = [(spec.factor * sig[comp]) / bound - 1.0 > slack for comp, bound, _ in spec.bounds()]
    return np.array(rows, dtype=bool).reshape(len(rows), len(sig["lateral"]))


def floors_to_solve(ceilings: np.ndarray, spec: Specification, slack: float) -> np.ndarray:
    """(k,) where a floor of the (k, 3, 3) ``ceilings``' keyframes can matter: some component's ceiling
    over its limit by more than ``slack`` (:func:`over_limits`). Elsewhere every floor, ⪯ its
    ceiling, is within its limits too (with slack ≥ ``slack``): it is over none of them with any
    larger slack, adds nothing to a violation (only excesses over a limit do), and a rank rule's
    order statistic keeps the same values over a limit, so a floor of 0 (the trivial one) there
    gives the same verdicts (:class:`~sensorsel.information.window_bounds.WindowBounds` solves
    only these floors)."""
    return np.asarray(over_limits(ceilings, spec, slack).any(axis=0))


def bad_keyframes(
    covariances: np.ndarray, spec: Specification, keyframes: np.ndarray | None = None, slack: float = 0.0
) -> Bad:
    """Per component of ``spec``, the keyframes (sorted) where the (k, 3, 3) ``covariances`` exceed its
    limit (:func:`over_limits`, with its ``slack``); ``keyframes``: only these of them (indices into
    ``covariances``; default all)."""
    over = over_limits(covariances, spec, slack)
    at = np.arange(over.shape[1]) if keyframes is None else np.asarray(keyframes, np.int64)
    return tuple(at[row[at]] for row in over)


def _bad_allowed(n_keyframes: int, spec: Specification) -> int:
    """How many of a route's ``n_keyframes`` a component may be over its limit at: all but the ⌈at·K⌉
    the rank rule needs within it."""
    return n_keyframes - (_rank(spec.at, n_keyframes) if n_keyframes else 0)


def meets_from_bad(bad: Bad, n_keyframes: int, spec: Specification) -> bool:
    """Whether a suite with these bad keyframes (per component) meets ``spec`` on a route of
    ``n_keyframes``: each component within its limit at ⌈at·K⌉ keyframes at least."""
    allowed = _bad_allowed(n_keyframes, spec)
    return all(len(b) <= allowed for b in bad)


def meets_from_mask(bad: np.ndarray, spec: Specification) -> bool:
    """:func:`meets_from_bad` of the bad keyframes as a (C, K) mask (K: the route's keyframes)."""
    return bool((np.count_nonzero(bad, axis=1) <= _bad_allowed(bad.shape[1], spec)).all())


def mask_of_bad(bad: Bad, n_keyframes: int) -> np.ndarray:
    """(C, K) the bad keyframes ``bad`` (per component) as a mask over the route's K keyframes."""
    out = np.zeros((len(bad), n_keyframes), bool)
    for row, b in zip(out, bad):
        row[b] = True
    return out


class BadKeyframes:
    """The bad keyframes (per component) of the suites that failed on one route, as bit masks of
    library positions; :meth:`shortest` finds, for a suite, a failing subset whose bad keyframes end
    earliest.

    ``known``: (mask, bad keyframes) recorded before, in the order they were (a journal's: a resumed
    run starts from them instead of computing those suites' passes again). What :meth:`add` records
    is also kept in order until :meth:`take_log` takes it (for the journal)."""

    def __init__(self, known: Iterable[tuple[int, BadList]] = ()) -> None:
        self._known: list[tuple[int, int, Bad]] = []  # (last bad keyframe + 1, mask, bad), kept sorted
        self._log: list[tuple[int, BadList]] = []
        for mask, bad in known:
            self._insert(mask, tuple(np.asarray(b, np.int64) for b in bad))

    def add(self, mask: int, bad: Bad) -> None:
        """Record that suite ``mask`` is over its limits exactly (or at most) at ``bad``."""
        self._insert(mask, bad)
        self._log.append((mask, tuple(tuple(int(k) for k in b) for b in bad)))

    def take_log(self) -> list[tuple[int, BadList]]:
        """(mask, bad keyframes) of what :meth:`add` recorded since the last call, in order (and forgets them)."""
        out, self._log = self._log, []
        return out

    def _insert(self, mask: int, bad: Bad) -> None:
        until = max((int(b[-1]) + 1 for b in bad if len(b)), default=0)
        self._known.append((until, mask, bad))
        self._known.sort(key=lambda e: (e[0], e[1]))

    def inside(self, mask: int) -> list[tuple[int, Bad]]:
        """(mask, bad keyframes) of every recorded suite inside ``mask``, bad keyframes ending earliest first."""
        return [(known, bad) for _, known, bad in self._known if known & ~mask == 0]

    def shortest(self, mask: int) -> tuple[int, Bad] | None:
        """(keyframes to pass, the bad keyframes) of a recorded suite inside ``mask`` whose bad
        keyframes end earliest; None when none is recorded inside it."""
        for until, known, bad in self._known:
            if known & ~mask == 0:
                return until, bad
        return None
