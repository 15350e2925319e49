"""Accepting a suite without its whole filter pass: an upper bound on its filter's covariances from a
failing suite it holds (the dual of the floor that refutes), restarted at that suite's bad keyframes.

**The property the proof uses.** Let S ⊆ T be two suites and a a keyframe. Take the graph G′ of the
priors, the odometry, S's measurements of keyframes < a and T's measurements of keyframes ≥ a,
except those of the landmarks D that S measured before a and never again. For every keyframe
k ≥ a, G′ up to k is a subgraph of T's graph up to k (S's measurements are T's), so its marginal
covariance at k is ⪰ the covariance T's filter has there (fewer factors, less information) and each
σ of it is an upper bound on T's. G′ up to k also holds S's graph up to k (S measures no landmark of
D from a on), so the bound is ⪯ S's own filter there: below S's where S is worse.

The marginal of G′ at k ≥ a is one filter pass from S's predicted state at a (the joint Gaussian of
pose a and the landmarks S holds there: those it saw and measures again) over T's measurements from
a on (:func:`~sensorsel.information.filtering.forward_pass` with ``start``), dropping the
measurements of D: S's pass marginalized those landmarks out once it stopped measuring them, so
their correlation with the pose is gone from its state, and a measurement of one taken as of a
fresh landmark (its prior alone) would count its prior twice: no longer a subgraph.

**How a suite is accepted.** T meets the specification wherever S does (every σ of T ≤ S's: the
monotonicity the search rests on). At S's bad keyframes, T's σ is bounded by G′'s, from a few
keyframes (:data:`WINDOWS`) before each run of bad keyframes. With every keyframe's σ bounded (S's
where S meets, G′'s at S's bad keyframes) and the rank rule monotone in each σ, T meets when the
bounds meet: accepted, exactly as its own pass would have judged it (violation 0). When they do not,
nothing is concluded and T's own pass decides.

In the growth of a failing set M (M plus one sensor asked at a time, most of them meeting), the base
is M itself: one pass of M, its predicted states kept, then a few keyframes per sensor tried instead
of the whole route.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from sensorsel.designs.requirements.spec import Specification, covariance_verdict
from sensorsel.designs.requirements.truncated import bad_keyframes
from sensorsel.information.evaluators.base import Suite
from sensorsel.information.filtering import Prediction, forward_pass
from sensorsel.model.problem import Problem

__all__ = ["WINDOWS", "Base", "Bases", "base_of", "upper_bound"]

#: keyframes before a run of bad keyframes where the bound restarts from the base's state, tried in
#: turn: the longer, the more of the suite's own measurements it holds (tighter) and the more
#: keyframes it passes. On the README tour's growths (measured once while choosing these), a restart
#: at the run itself accepted about 1 in 4 of the suites that meet, 4 keyframes before about 3 in 4,
#: 12 before about 9 in 10; (3, 10) and (6, 20) passed about as many keyframes in all as (4, 16).
WINDOWS = (4, 16)
#: bytes of predicted states a base keeps (beyond this, only every 2nd, 4th, ... keyframe's)
STATE_BYTES = 32 << 20
#: keyframes a kept state serves: it holds the pose and the landmarks the library measures within
#: this many keyframes after it (forward_pass's ``keep_horizon``), and a bound restarted there stops
#: by then. The landmarks held for a loop's return are left out: a user's drive (KITTI 00's ground
#: truth, 1,614 generated landmarks, up to ~1,350 held) kept no state but the first within
#: :data:`STATE_BYTES`, so no bound could restart near a bad keyframe
HORIZON = 64
#: bases kept per route (the most recent)
KEEP = 4


@dataclass(eq=False)
class Base:
    """A suite that failed on a route, with what a bound from it needs.

    Attributes:
        mask: the suite (bit mask of library positions).
        filtered: (K, 3, 3) its filter's pose covariances.
        last: (n_landmarks,) the last keyframe at which it measures each landmark (−1: never).
        states: keyframe -> its predicted state there (every ``stride``-th keyframe).
        windows: per entry of :data:`WINDOWS`, the (first, last) keyframes of the bound's restarts,
            covering every bad keyframe.
    """

    mask: int
    filtered: np.ndarray
    last: np.ndarray
    states: dict[int, Prediction] = field(default_factory=dict)
    windows: tuple[tuple[tuple[int, int], ...], ...] = ()


def _windows(bad: np.ndarray, states: dict[int, Prediction], window: int) -> tuple[tuple[int, int], ...]:
    """(restart keyframe, last bad keyframe) per run of ``bad`` keyframes: each restart the latest kept
    state at least ``window`` keyframes before the run; runs whose windows meet are merged."""
    out: list[tuple[int, int]] = []
    kept = sorted(states)
    for k in bad.tolist():
        a = max((s for s in kept if s <= k - window), default=kept[0])
        if out and a <= out[-1][1] + 1:
            out[-1] = (out[-1][0], k)
        else:
            out.append((a, k))
    return tuple(out)


def base_of(problem: Problem, suite: Suite, mask: int, spec: Specification, map_sigma_m: float | None) -> Base:
    """One filter pass of the failing ``suite`` with its predicted states kept (at most
    :data:`STATE_BYTES` of them: every keyframe's, or every 2nd, 4th, ...: :func:`_stride`), each
    over the landmarks the library measures within :data:`HORIZON` keyframes (the bounds restarted
    from it stop by then)."""
    last = np.full(max(problem.scenario.n_landmarks, 1), -1, np.int64)
    first = np.full(len(last), len(problem.scenario.keyframes.poses), np.int64)
    for i in suite:
        o = problem.observations[i]
        if len(o):
            np.maximum.at(last, np.asarray(o.landmark, np.int64), np.asarray(o.pose, np.int64))
            np.minimum.at(first, np.asarray(o.landmark, np.int64), np.asarray(o.pose, np.int64))
    n_keyframes = len(problem.scenario.keyframes.poses)
    # the states to keep are known before the pass: it runs in windows between them
    stride = _stride(problem, first, last, n_keyframes)
    got = forward_pass(
        problem, suite, map_sigma_m=map_sigma_m, keep_states=range(0, n_keyframes, stride), keep_horizon=HORIZON
    )
    states = got.states
    bad = np.unique(np.concatenate(bad_keyframes(got.filtered, spec)))
    return Base(mask, got.filtered, last, states, tuple(_windows(bad, states, w) for w in WINDOWS) if len(bad) else ())


def _stride(problem: Problem, first: np.ndarray, last: np.ndarray, n_keyframes: int) -> int:
    """The least power of 2 (below ``n_keyframes``, or the first at or above it) such that the
    predicted states of every stride-th keyframe take at most :data:`STATE_BYTES`: the state kept at
    k holds the landmarks first measured before k and measured again at k or later (``first``,
    ``last``: (n_landmarks,) keyframes; a landmark never measured has first ≥ K) that the library
    measures within :data:`HORIZON` keyframes of k."""
    k = np.arange(n_keyframes)
    seen = np.flatnonzero(last >= 0)
    # first with every landmark the pass holds at k (first < k <= last), a bound on what the horizon
    # keeps: where every state fits so, each keyframe's is kept, without a look-up per keyframe (the
    # README tour's bases: a thousand look-ups a second)
    step = np.zeros(n_keyframes + 1, np.int64)
    np.add.at(step, np.minimum(first[seen] + 1, n_keyframes), 1)
    np.add.at(step, np.minimum(last[seen] + 1, n_keyframes), -1)
    if (((3 + 2 * np.cumsum(step[:n_keyframes])) ** 2) * 8).sum() <= STATE_BYTES:
        return 1
    nbytes = (3 + 2 * held_within_horizon(problem, first, last, n_keyframes)) ** 2 * 8
    stride = 1
    while nbytes[k % stride == 0].sum() > STATE_BYTES and stride < n_keyframes:
        stride *= 2
    return stride


def held_within_horizon(problem: Problem, first: np.ndarray, last: np.ndarray, n_keyframes: int) -> np.ndarray:
    """(n_keyframes,) how many landmarks the state kept at each keyframe j holds: those first measured by
    the suite before j and again at j or later (``first`` < j <= ``last``, (n_landmarks,) keyframes; a
    landmark never measured has ``last`` = -1) that some library sensor measures at a keyframe in
    j .. j + :data:`HORIZON` (:meth:`~sensorsel.model.problem.Problem.measured_within`, asked of every
    keyframe at once).

    Each (landmark, keyframe t) the library measures makes the keyframes j in [t - HORIZON, t] count
    that landmark; taken in the order of t, the part of that span the landmark's measurement before it
    does not already cover is [max(t - HORIZON, t_before + 1), t], so the spans are disjoint and each
    (j, landmark) is counted once: a count by intervals, in integers (a look-up per keyframe was 9 s of
    a 241 s search on a user's drive with a loop, profiled)."""
    n = problem.scenario.n_poses
    keys = problem.measured_pairs  # sorted landmark * n + keyframe
    landmark, t = keys // n, keys % n
    before = np.full(len(keys), -(HORIZON + 2), np.int64)  # no measurement before: nothing covered
    same = landmark[1:] == landmark[:-1]
    before[1:][same] = t[:-1][same]
    lo = np.maximum(np.maximum(t - HORIZON, before + 1), first[landmark] + 1)
    hi = np.minimum(t, last[landmark])
    ok = lo <= hi
    step = np.zeros(n_keyframes + 1, np.int64)
    np.add.at(step, lo[ok], 1)
    np.add.at(step, hi[ok] + 1, -1)
    return np.cumsum(step[:n_keyframes])


def upper_bound(
    problem: Problem, base: Base, suite: Suite, map_sigma_m: float | None, windows: tuple[tuple[int, int], ...]
) -> np.ndarray:
    """(K, 3, 3) covariances each ⪰ the filter's of ``suite`` (which holds ``base``'s suite) at its
    keyframe (module docstring): the base's, and G′'s over each of ``windows`` (restart, last keyframe)."""
    cov = base.filtered.copy()
    for a, b in windows:
        if b - a > HORIZON:  # its kept state holds only what the library measures by a + HORIZON
            raise ValueError(f"a bound from keyframe {a} to {b}: past the kept states' horizon ({HORIZON})")
        gone = (base.last >= 0) & (base.last < a)  # D: seen by the base before a, never again
        got = forward_pass(problem, suite, map_sigma_m=map_sigma_m, start=base.states[a], until=b + 1, exclude=gone)
        cov[a : b + 1] = got.filtered
    return cov


def _measures_within(problem: Problem, sensors: list[int], windows: tuple[tuple[int, int], ...]) -> bool:
    """Whether any of ``sensors`` (library positions) measures a landmark at a keyframe of one of
    ``windows`` ((first, last) keyframes, inclusive)."""
    for i in sensors:
        pose = np.asarray(problem.observations[i].pose)
        if any(np.any((pose >= a) & (pose <= b)) for a, b in windows):
            return True
    return False


class Bases:
    """The bases of one route (the :data:`KEEP` most recent), and the suites they accept."""

    def __init__(self) -> None:
        self._bases: list[Base] = []
        self.n_passes = 0  # base passes computed
        self.n_accepted = 0  # suites accepted by a bound
        self.n_empty = 0  # bounds not passed: no added sensor measures within their windows
        self.keyframes_passed = 0
        self._quick: tuple[int, Base | None] | None = None  # (suite, base) of the last quick bound
        self._offered: Base | None = None  # the last failing suite's pass, computed elsewhere (offer)

    @property
    def newest(self) -> Base:
        """The base kept last."""
        return self._bases[-1]

    def offer(self, base: Base) -> None:
        """Keep ``base`` (a failing suite's pass with its states, computed by the caller) to stand for
        that suite's own base pass if the next base asked for is that suite's (the last one offered
        only: it is dropped at the next base asked for, whichever suite's)."""
        self._offered = base

    def accepts(
        self,
        problem: Problem,
        suite: Suite,
        mask: int,
        failed: int | None,
        spec: Specification,
        map_sigma_m: float | None,
        quick: bool = False,
    ) -> bool:
        """Whether a bound proves that ``suite`` meets ``spec`` (False: not proved, not refuted): from
        the largest kept base inside it, then from ``failed`` (a failing suite inside it, of one or two
        sensors fewer: the growth of a failing set; its pass computed now and kept). ``quick``: only
        the kept base's first windows (a bound cheaper than the smoother's check, asked before it);
        after a quick one, the rest."""
        inside = [b for b in self._bases if not b.mask & ~mask]
        base = max(inside, key=lambda b: bin(b.mask).count("1"), default=None)
        if quick:
            self._quick = (mask, base)
            return base is not None and self._bound_meets(problem, base, suite, spec, map_sigma_m, 0, 1)
        skip = 1 if self._quick is not None and self._quick[0] == mask and self._quick[1] is base else 0
        if base is not None and self._bound_meets(problem, base, suite, spec, map_sigma_m, skip, None):
            return True
        size = bin(mask).count("1")
        if failed is None or size - bin(failed).count("1") > 2 or (base is not None and not failed & ~base.mask):
            return False
        offered, self._offered = self._offered, None  # taken now or never (a growth asks for it at once)
        if offered is not None and offered.mask == failed:
            base = offered  # its pass already computed (and counted) by the caller
        else:
            base = base_of(problem, tuple(i for i in suite if failed >> i & 1), failed, spec, map_sigma_m)
            self.n_passes += 1
            self.keyframes_passed += len(base.filtered)
        self._bases = [*self._bases[-(KEEP - 1) :], base]
        return self._bound_meets(problem, base, suite, spec, map_sigma_m, 0, None)

    def _bound_meets(
        self,
        problem: Problem,
        base: Base,
        suite: Suite,
        spec: Specification,
        map_sigma_m: float | None,
        first: int,
        stop: int | None,
    ) -> bool:
        added = [i for i in suite if not base.mask >> i & 1]
        for windows in base.windows[first:stop]:
            # a bound over half the route or more costs about what the suite's own pass does
            passed = sum(b - a + 1 for a, b in windows)
            if 2 * passed > len(base.filtered):
                return False
            if any(b - a > HORIZON for a, b in windows):  # past what its kept states hold
                continue
            if not _measures_within(problem, added, windows):
                # no added measurement in the windows: the bound there is the base's own filter
                # (the same measurements from the same state), which fails the specification at
                # the bad keyframes the windows cover: a pass that cannot accept
                self.n_empty += 1
                continue
            self.keyframes_passed += passed
            if covariance_verdict(upper_bound(problem, base, suite, map_sigma_m, windows), spec)[0]:
                self.n_accepted += 1
                return True
        return False
