"""Dominance among the sensors of a library: a sensor whose measurements another one also makes, at
least as precisely, on every route. What ``require`` infers from it without an accuracy check, and
the order it adds to its integer programs.

**Information dominance.** Sensor w is *dominated* by sensor s (w ⪯ s) when, on every route, every
(keyframe, landmark) pair w measures is measured by s too, with at least w's information in bearing
and in range (Σ 1/σ_b² and Σ 1/σ_r² of the sensor's measurements of that pair; the noise the route's
condition gives). Every factor of the SLAM graph of a (keyframe, landmark) pair is J_kᵀ W J_k with
the pair's unit-noise Jacobian J_k (the same whichever sensor measures) and W = diag(Σ 1/σ_b²,
Σ 1/σ_r²) summed over the suite's sensors. So for a suite T holding w but not s, the graph of
T′ = T − w + s has, pair by pair, W′ ⪰ W, plus any pairs s measures and w does not: its information
matrix is ⪰ that of T on every route, whatever the landmark prior (map or SLAM), up to every
keyframe (the filter's graphs) and over the whole route (the smoother's). Its pose marginals are
therefore ⪯ T's at every keyframe, each σ is no larger, and an accuracy requirement T meets, T′
meets (the rank rule of a specification is monotone in each keyframe's σ). After failures too: a
failure set F′ of T′ maps to the failure set F of T with s replaced by w, and T′ − F′ ⪰ T − F.

**What the solver infers** (:class:`~sensorsel.designs.requirements.oracle.Monotone` with swaps):
a suite holding s but not w passes when the suite with s replaced by w is known to pass; a suite
holding w but not s fails when the suite with w replaced by s is known to fail. Neither needs the
prices: it is about accuracy alone.

**The order in the integer programs** (:func:`dominance_order`). When moreover s costs no more than
w and uses no more of any limit (every row of the feasible set: price, resources, slots, the sensor
count), w is not required and neither is excluded, every suite T that meets the requirement after
α failures and holds w but not s can be swapped to T′ = T − w + s: no dearer, within every limit
T keeps to, and meeting it (above). Take the pairs (w, s) whose two sensors are equivalent in both
information and rows only with s before w in the library (a tie broken by position): the relation
is then acyclic (a cycle would be of mutually equivalent sensors, each before the next). So a
topological order exists where every s follows its w, and each swap raises the sum of the suite's
ranks in that order: from any T that meets the requirement, swaps end, after finitely many, at a
suite T* with no pair w ∈ T*, s ∉ T* — i.e. T* satisfies x_w ≤ x_s for every pair — that meets it,
fits, and costs no more than T. Adding the rows x_w − x_s ≤ 0 to every integer program therefore
leaves the cheapest cost, and every lower bound, as they are (each bound is still the least cost of
a set holding a cheapest suite that meets it).

**Ties.** Where s and w cost the same, suites with w in place of s may meet the requirement at the
optimal cost too; the integer programs, which require x_w ≤ x_s, do not propose them. ``require``
reports the pairs it ordered (``dominated``), and the tie search is not called exhaustive while
any ordered pair has equal prices.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from sensorsel.model.constraints import FeasibleSet
from sensorsel.model.problem import Problem

__all__ = ["information_dominance", "dominance_order"]

#: relative slack when comparing two information sums [1/m², 1/rad²]: the same model's noise at one
#: position is the same float, but summed in another order it may differ in the last bits
_REL = 1e-12


def _pair_information(problem: Problem, i: int) -> tuple[np.ndarray, np.ndarray]:
    """(keys (p,) sorted, info (p, 2)) of sensor i on ``problem``: each (keyframe, landmark) pair it
    measures, as keyframe · n_landmarks + landmark, with Σ 1/σ_b² and Σ 1/σ_r² of its measurements."""
    o = problem.observations[i]
    n_lm = max(problem.scenario.n_landmarks, 1)
    keys = np.asarray(o.pose, np.int64) * n_lm + np.asarray(o.landmark, np.int64)
    if not len(keys):
        return np.zeros(0, np.int64), np.zeros((0, 2))
    uniq, inv = np.unique(keys, return_inverse=True)
    info = np.column_stack(
        [
            np.bincount(inv, 1.0 / np.asarray(o.sigma_bearing_rad, float) ** 2, len(uniq)),
            np.bincount(inv, 1.0 / np.asarray(o.sigma_range_m, float) ** 2, len(uniq)),
        ]
    )
    return uniq, info


def _dominated(weak: tuple[np.ndarray, np.ndarray], strong: tuple[np.ndarray, np.ndarray]) -> bool:
    """Every pair ``weak`` measures, ``strong`` measures with at least its information."""
    kw, iw = weak
    ks, is_ = strong
    if not len(kw):
        return True
    if len(ks) < len(kw):
        return False
    at = np.searchsorted(ks, kw)
    if np.any(at >= len(ks)):
        return False
    if not np.array_equal(ks[at], kw):
        return False
    return bool(np.all(is_[at] >= iw * (1.0 - _REL)))


def information_dominance(
    problems: Sequence[Problem], candidates: Sequence[int] | None = None
) -> tuple[tuple[int, int], ...]:
    """The pairs (w, s) of library positions, w ≠ s, with w ⪯ s on every route of ``problems``
    (module docstring), sorted; ``candidates``: only among these positions (default: all).

    Mutually dominant sensors (the same measurements, equally precise) give both (w, s) and (s, w).
    A sensor that measures nothing on any route is dominated by every sensor.
    """
    if not problems:
        return ()
    n = problems[0].n_sensors
    pos = list(range(n)) if candidates is None else sorted(set(int(i) for i in candidates))
    pairs = [(w, s) for w in pos for s in pos if w != s]
    for problem in problems:
        if not pairs:
            break
        info = {i: _pair_information(problem, i) for i in pos}
        pairs = [(w, s) for w, s in pairs if _dominated(info[w], info[s])]
    return tuple(sorted(pairs))


def dominance_order(feasible: FeasibleSet, pairs: Sequence[tuple[int, int]]) -> tuple[tuple[int, int], ...]:
    """Of the dominance ``pairs`` (w, s), those whose row x_w ≤ x_s the integer programs may hold
    (module docstring): s uses no more than w of every row of ``feasible`` (its price included), w is
    not required, neither is excluded; of two sensors equivalent in information and rows, only the
    pair with s before w. Sorted; acyclic."""
    info_pairs = set(pairs)
    A = feasible.A
    required, excluded = set(feasible.required), feasible.excluded
    out = []
    for w, s in pairs:
        if w in required or w in excluded or s in excluded:
            continue
        if not np.all(A[:, s] <= A[:, w]):
            continue
        equivalent = (s, w) in info_pairs and np.array_equal(A[:, s], A[:, w])
        if equivalent and s > w:
            continue
        out.append((w, s))
    return tuple(sorted(out))
