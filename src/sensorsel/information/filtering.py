"""The accuracy the car has as it drives: a forward pass (a filter), not the smoother's marginals.

The smoother's pose covariances (:meth:`~sensorsel.information.evaluators.base.ProblemEvaluator.pose_covariances`
with ``estimate="smoother"``) use every measurement of the route, before and after a keyframe. A car
localizing as it drives has, at keyframe k, only the measurements of keyframes 0..k. This module
computes that covariance for every keyframe in one pass over the route, exactly: ``filtered[k]`` is
GTSAM's marginal of X(k) in the graph of the priors, the odometry up to k and the (used)
measurements of keyframes ≤ k, linearized at the truth as everywhere in sensorsel.

The pass is a Kalman filter in covariance form over the joint Gaussian of (pose k's tangent, the
landmarks seen so far that the suite measures again), all at the truth (so every mean is 0 and only
the covariance P is carried). Per keyframe:

1. Prediction (odometry). The between factor's error at the truth is H δx_(k−1) + δx_k (its
   Jacobian w.r.t. pose k is the identity, :func:`~sensorsel.information.linearize.odometry_jacobians`),
   so δx_k = −H δx_(k−1) + w, w ~ N(0, Σ_odo): P_xx ← H P_xx Hᵀ + Σ_odo, P_xL ← −H P_xL
   (pose k − 1 is marginalized out: nothing later involves it).
2. Update. All measurements of one (keyframe, landmark) pair share their unit-noise Jacobian
   J = [A | B] (2×3 | 2×2, :func:`~sensorsel.information.linearize.bearing_range_jacobians`), so
   the pair's used measurements make one whitened 2-row measurement W^½ J, W = diag(Σ 1/σ_b²,
   Σ 1/σ_r²). For a landmark already in the state these rows H go into the usual update
   P ← P − U S⁻¹ Uᵀ, U = P Hᵀ, S = I + H P Hᵀ (S ⪰ I: its Cholesky never fails).
   A landmark seen for the first time is not put in the state with its prior and updated (a
   100 m prior updated by a 1 cm measurement cancels in covariance form): its factor and prior
   are split exactly into a factor on the pose alone and the landmark's conditional,

       g(δx) with information Aᵀ (I + σ_p² B Bᵀ)⁻¹ A      (the Schur complement, Woodbury form),
       δl | δx ~ N(G δx, D⁻¹),  D = I/σ_p² + BᵀB,  G = −D⁻¹ Bᵀ A,

   g joins the update as two rows on the pose, L⁻¹ A with L Lᵀ = I + σ_p² B Bᵀ, and the
   landmark enters afterwards: Cov(l, ·) = G P_x·, Cov(l, l') = G P_xx G'ᵀ + δ D⁻¹.
3. A landmark the suite never measures after keyframe k leaves the state after k's update (exact:
   marginalizing a variable no later factor touches). The state keeps its landmarks in the order
   they came, a leaving one's rows and columns taken by the last one's (:class:`_State`): joining
   and leaving cost rows and columns, not a copy of the matrix.

4. Over a window of keyframes (:class:`_Window`), the landmarks held that it does not measure are
   left out of its updates and brought back at its end from their conditional on the window's
   first state: exact, and on KITTI 00 about half the dense pass's time (where a count of flops says
   it pays; never while a hook reads the whole state).

``predicted[k]`` is P_xx after step 1, ``filtered[k]`` after step 2. A landmark outside the state is
either not yet seen (independent of everything, its prior σ_p² I) or never measured again. The cost
per keyframe is O(n² r) for n landmarks in the state and r rows measured: linear in the route's
length for a bounded number of landmarks in reach.

Why it is a filter and not the smoother: both are exact marginals of Gaussians, of different
graphs. The filtered covariance at k uses a subset of the smoother's factors, so it is ⪰ the
smoothed one (PSD order); at the last keyframe they coincide.
"""

from __future__ import annotations

import bisect
import functools
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

import numpy as np
from scipy.linalg.lapack import dpotrf, dpotrs, dpstrf, dtrtrs
from threadpoolctl import ThreadpoolController

from sensorsel.errors import InputError
from sensorsel.information.blocks import block
from sensorsel.information.linearize import bearing_range_jacobians, odometry_jacobians
from sensorsel.model.problem import Problem

__all__ = [
    "ESTIMATES",
    "KeyframeMeasurements",
    "Prediction",
    "FilterPass",
    "Use",
    "keyframe_measurements",
    "forward_pass",
]

#: the estimates an accuracy can be of: the filter's (at each keyframe from the measurements up to
#: it: what the car has as it drives) or the smoother's (from every measurement of the route)
ESTIMATES = ("filter", "smoother")


def check_estimate(estimate: str) -> str:
    """``estimate`` if it is one of :data:`ESTIMATES`, else an InputError naming --estimate."""
    if estimate not in ESTIMATES:
        raise InputError(f"--estimate {estimate!r}: must be one of {', '.join(ESTIMATES)}")
    return estimate


def check_map_sigma(map_sigma_m: float | None) -> float | None:
    """``map_sigma_m`` [m] if None (SLAM) or a positive finite number (the map model), else an
    InputError naming the value."""
    if map_sigma_m is not None and not (np.isfinite(map_sigma_m) and map_sigma_m > 0):
        raise InputError(f"map sigma must be a positive number of metres, got {map_sigma_m!r}")
    return map_sigma_m


@dataclass(frozen=True, eq=False)
class KeyframeMeasurements:
    """The suite's measurements made at one keyframe, as parallel (m,) arrays, in a fixed order
    (by sensor position in the library, then landmark index)."""

    keyframe: int
    sensor: np.ndarray  # (m,) library positions
    landmark: np.ndarray  # (m,) landmark indices (the landmark truly measured)
    bearing_rad: np.ndarray  # (m,) true bearing, car frame [rad]
    range_m: np.ndarray  # (m,) true range [m]
    sigma_bearing_rad: np.ndarray  # (m,) noise std [rad]
    sigma_range_m: np.ndarray  # (m,) noise std [m]

    def __len__(self) -> int:
        return len(self.sensor)


@dataclass(frozen=True, eq=False)
class Prediction:
    """What the car knows just before keyframe k's measurements: the filter's joint Gaussian over
    pose k's tangent (dx, dy in the keyframe's own frame [m], dθ [rad]; as Pose2 / GTSAM) and the
    landmarks held in its state ((x, y) world [m]), from the measurements of keyframes < k (used
    ones only), odometry up to k and the priors. A landmark not in ``landmarks`` is independent of
    the pose and of the others, with its prior covariance (``prior_sigma_m``² I).

    Attributes:
        keyframe: k.
        landmarks: (n,) the landmark indices held in the state, in the state's order (the order they
            came and left in: not sorted; :meth:`in_landmark_order` sorts them).
        covariance: (3 + 2n, 3 + 2n): pose first, then each landmark's (x, y) in the order of
            ``landmarks`` [m², m·rad, rad²].
        prior_sigma_m: the prior std of a landmark not in the state [m]: ``map_sigma_m`` in the
            map model, the problem's weak ``landmark_prior_sigma_m`` in SLAM.
        slot: (n_landmarks,) each of the problem's landmarks' position in ``landmarks`` (−1: not
            held), the pass's own table; None where not given (:meth:`slots_of` builds one).
    """

    keyframe: int
    landmarks: np.ndarray
    covariance: np.ndarray
    prior_sigma_m: float
    slot: np.ndarray | None = None

    @property
    def pose_covariance(self) -> np.ndarray:
        """(3, 3) the predicted covariance of pose k's tangent."""
        return self.covariance[:3, :3]

    def slots_of(self, landmarks: np.ndarray) -> np.ndarray:
        """(m,) the position of each of ``landmarks`` (m,) in :attr:`landmarks`, or −1."""
        landmarks = np.asarray(landmarks, np.int64)
        table = self.slot
        if table is None:
            held = np.asarray(self.landmarks, np.int64)
            table = _slot_table(held, int(max(held.max(initial=-1), landmarks.max(initial=-1))) + 1)
        return table[landmarks]

    def in_landmark_order(self) -> Prediction:
        """The same prediction with its landmarks sorted (a copy: the covariance's rows and columns
        permuted, the same numbers)."""
        order = np.argsort(self.landmarks, kind="stable")
        idx = np.concatenate([np.arange(3), _landmark_rows(3, order)])
        cov = np.asarray(self.covariance, float)
        return Prediction(self.keyframe, self.landmarks[order], cov[idx][:, idx], self.prior_sigma_m)


def _landmark_rows(off: int, slots: np.ndarray) -> np.ndarray:
    """(2m,) the state rows of the landmarks at ``slots`` (m,), in that order: (x, y) of each, from
    row ``off`` (3 after the pose; 6 in a window's state, :class:`_Window`)."""
    return (off + 2 * np.asarray(slots, np.int64)[:, None] + np.arange(2)).ravel()


def _slot_table(held: np.ndarray, size: int) -> np.ndarray:
    """(size,) each landmark index's position in ``held`` (n,), or −1."""
    table = np.full(size, -1, np.int64)
    table[held] = np.arange(len(held))
    return table


#: decides which of keyframe k's measurements the filter uses: returns a (m,) bool mask
Use = Callable[[Prediction, KeyframeMeasurements], np.ndarray]


@dataclass(frozen=True, eq=False)
class FilterPass:
    """The forward pass of a suite over a route.

    Attributes:
        predicted: (K, 3, 3) pose covariance before keyframe k's measurements (Pose2 tangent).
        filtered: (K, 3, 3) pose covariance after them: what the car has at k.
        n_used: (K,) measurements used at each keyframe.
        n_measured: (K,) measurements the suite made at each keyframe.
    """

    predicted: np.ndarray
    filtered: np.ndarray
    n_used: np.ndarray
    n_measured: np.ndarray
    #: keyframe -> the whole predicted state there, at the keyframes ``forward_pass`` was asked to keep
    states: dict[int, Prediction] = field(default_factory=dict)


def _suite_arrays(problem: Problem, suite: Iterable[int]) -> dict[str, np.ndarray]:
    """The suite's measurements concatenated and sorted by (keyframe, sensor, landmark)."""
    positions = sorted(set(int(i) for i in suite))
    n = problem.n_sensors
    for i in positions:
        if not 0 <= i < n:
            raise InputError(f"sensor position {i} is outside the library (0..{n - 1})")
    obs = [problem.observations[i] for i in positions]
    cols: dict[str, list[np.ndarray]] = {
        f: [] for f in ("pose", "sensor", "landmark", "bearing_rad", "range_m", "sigma_bearing_rad", "sigma_range_m")
    }
    for i, o in zip(positions, obs):
        cols["pose"].append(np.asarray(o.pose, np.int64))
        cols["sensor"].append(np.full(len(o), i, np.int64))
        cols["landmark"].append(np.asarray(o.landmark, np.int64))
        for f in ("bearing_rad", "range_m", "sigma_bearing_rad", "sigma_range_m"):
            cols[f].append(np.asarray(getattr(o, f), float))
    out = {
        f: (np.concatenate(v) if v else np.zeros(0, np.int64 if f in ("pose", "sensor", "landmark") else float))
        for f, v in cols.items()
    }
    order = _measurement_order(out["pose"], out["sensor"], out["landmark"])
    return {f: v[order] for f, v in out.items()}


def _measurement_order(pose: np.ndarray, sensor: np.ndarray, landmark: np.ndarray) -> np.ndarray:
    """(m,) the order of measurements by (keyframe, sensor, landmark), given them (m,) concatenated
    sensor by sensor in ascending order. Each sensor's are sorted by (keyframe, landmark) as
    :func:`~sensorsel.model.sensing.observe` makes them, so a stable sort on the keyframe alone
    gives that order, at a third of a three-key sort's cost (the README tour sorts at every pass); a
    sensor's out of that order (checked: one pass over the keys) takes the three-key sort."""
    key = pose * (int(landmark.max(initial=0)) + 1) + landmark
    within = sensor[1:] == sensor[:-1]
    if np.all(np.diff(key)[within] > 0):
        return np.argsort(pose, kind="stable")
    return np.lexsort((landmark, sensor, pose))


@dataclass(frozen=True, eq=False)
class _SuiteMeasurements:
    """A suite's measurements as sorted parallel arrays (:func:`_suite_arrays`) and where each
    keyframe's begin: ``bounds`` (K + 1,), keyframe k's rows ``bounds[k]:bounds[k + 1]``. A pass over
    a few keyframes (a bound's window) slices what it needs, not K groups."""

    arrays: dict[str, np.ndarray]
    bounds: np.ndarray
    #: (K + 1,) where each keyframe's measurements begin, those left out (:meth:`without`) included:
    #: what the suite measured (None: ``bounds``)
    measured: np.ndarray | None = None

    @classmethod
    def of(cls, problem: Problem, suite: Iterable[int]) -> _SuiteMeasurements:
        a = _suite_arrays(problem, suite)
        return cls(a, np.searchsorted(a["pose"], np.arange(problem.scenario.n_poses + 1)))

    def without(self, exclude: np.ndarray) -> _SuiteMeasurements:
        """These measurements less those of the landmarks ``exclude`` marks ((n_landmarks,) bool), in
        the same order."""
        a = self.arrays
        kept = ~exclude[a["landmark"]]
        bounds = np.searchsorted(a["pose"][kept], np.arange(len(self.bounds)))
        return _SuiteMeasurements(
            {f: v[kept] for f, v in a.items()}, bounds, self.bounds if self.measured is None else self.measured
        )

    def group(self, k: int) -> KeyframeMeasurements:
        """Keyframe ``k``'s measurements."""
        lo, hi = int(self.bounds[k]), int(self.bounds[k + 1])
        a = self.arrays
        return KeyframeMeasurements(
            k,
            *(
                a[f][lo:hi]
                for f in ("sensor", "landmark", "bearing_rad", "range_m", "sigma_bearing_rad", "sigma_range_m")
            ),
        )

    def last_keyframes(self, n_landmarks: int) -> np.ndarray:
        """(max(n_landmarks, 1),) the last keyframe at which the suite measures each landmark (−1: never)."""
        last = np.full(max(n_landmarks, 1), -1, np.int64)
        np.maximum.at(last, self.arrays["landmark"], self.arrays["pose"])
        return last


def keyframe_measurements(problem: Problem, suite: Iterable[int]) -> list[KeyframeMeasurements]:
    """The suite's measurements grouped by keyframe (K entries, possibly empty), from
    problem.observations (which already carry the problem's condition)."""
    m = _SuiteMeasurements.of(problem, suite)
    return [m.group(k) for k in range(problem.scenario.n_poses)]


@functools.cache
def blas_controller() -> ThreadpoolController:
    """The process's BLAS libraries, found once: threadpoolctl reads the loaded libraries each time
    it is asked, ~9 ms, most of a small suite's pass on the bundled route."""
    return ThreadpoolController()


def forward_pass(
    problem: Problem,
    suite: Iterable[int],
    *,
    map_sigma_m: float | None = None,
    use: Use | None = None,
    on_prediction: Callable[[Prediction, KeyframeMeasurements], None] | None = None,
    until: int | None = None,
    start: Prediction | None = None,
    exclude: np.ndarray | None = None,
    window: int | None = None,
    keep_states: Iterable[int] = (),
    keep_horizon: int | None = None,
) -> FilterPass:
    """One forward pass over the route (linear in its length), exact: filtered[k] equals GTSAM's
    marginal of X(k) in the graph of the priors, odometry up to k and the used measurements of
    keyframes <= k; predicted[k] the same without keyframe k's measurements. ``use`` (default: all)
    is called once per keyframe, before its update; ``on_prediction`` too (for callers that only observe).
    The prediction ``use`` gets is read-only and valid during the call only (the pass's own state,
    updated in place afterwards: a hook that keeps it copies it); ``on_prediction``'s is a copy.

    ``map_sigma_m``: None for the SLAM model (each landmark's weak prior of the problem's
    ``landmark_prior_sigma_m``), or the std [m] of a prior map's landmarks. Method: the module's
    docstring.

    ``until``: stop after keyframe ``until`` − 1 (the arrays then hold the first ``until``
    keyframes, the same numbers as the whole pass's: a keyframe's covariance depends only on the
    measurements up to it, and which landmarks are held is still decided by the whole route's).

    ``start``: begin at keyframe ``start.keyframe`` from that predicted state (its pose covariance and
    landmarks held, e.g. another suite's, kept by an ``on_prediction`` hook) instead of the priors at
    keyframe 0; the arrays then hold keyframes ``start.keyframe`` .. ``until`` − 1 only. A landmark
    outside ``start.landmarks`` enters as never seen (its prior alone): the pass is exact for the graph
    of ``start``'s past and this suite's (used) measurements from ``start.keyframe`` on, which is what a
    caller bounding another suite's covariance from above relies on (``use`` drops the measurements of
    landmarks that past saw but no longer holds).

    ``exclude``: (n_landmarks,) bool, the landmarks whose measurements are not used at any keyframe: a
    ``use`` fixed before the pass (the same numbers as a hook that drops them), without a call and a
    keyframe's pairs computed again at every keyframe.

    ``window``: how the landmarks held but not measured for a while are carried (:class:`_Window`;
    the same covariances to round-off): None (default) in windows of :data:`WINDOW_KEYFRAMES` where
    its cost model says a window is cheaper than the dense update, 0 never, a positive number in
    windows of that many keyframes wherever a landmark is held and not measured (for tests and
    benches). Without a hook only: ``use`` and ``on_prediction`` are given the whole state.

    ``keep_states``: keyframes whose whole predicted state the result keeps (:attr:`FilterPass.states`,
    copies; a window ends at each, so they do not stop the windows that ``on_prediction`` would).
    ``keep_horizon``: keep of the state at k only the pose and the landmarks some library sensor
    measures at keyframes k .. k + ``keep_horizon`` (:meth:`~sensorsel.model.problem.Problem.measured_within`):
    the others are measured by no suite before then, so a pass started there (``start``) that stops
    by then (``until``) gives the same covariances from either (a marginal, exactly); None: all.
    """
    check_map_sigma(map_sigma_m)
    s = problem.settings
    prior_sigma = float(s.landmark_prior_sigma_m if map_sigma_m is None else map_sigma_m)
    sc = problem.scenario
    poses = np.asarray(sc.keyframes.poses, float)
    K = len(poses)
    measurements = _SuiteMeasurements.of(problem, suite)
    # the last keyframe at which the suite measures each landmark: after it the landmark leaves the state
    last = measurements.last_keyframes(sc.n_landmarks)
    odo = odometry_jacobians(poses) if K > 1 else np.zeros((0, 3, 3))
    odo_cov = np.diag(np.asarray(s.odometry_sigmas, float) ** 2)

    # one BLAS thread: the pass is a sequence of small and mid-sized products, where threads were
    # measured slower (a 300² Cholesky and a 1100²·300 product on 2 busy cores: 10x and 1.2x slower
    # on two; a 4-sensor suite's pass on the bundled route 30x slower)
    with blas_controller().limit(limits=1, user_api="blas"):
        stop = K if until is None else max(0, min(int(until), K))
        if exclude is not None:
            # which landmarks leave the state stays the whole suite's (as with a ``use`` hook): an
            # excluded landmark never enters it
            measurements = measurements.without(np.asarray(exclude, bool))
        return _pass(
            problem,
            measurements,
            stop,
            last,
            odo,
            odo_cov,
            prior_sigma,
            use,
            on_prediction,
            start,
            window,
            sorted(set(int(k) for k in keep_states)),
            keep_horizon,
        )


@dataclass(frozen=True, eq=False)
class _Pairs:
    """The used measurements of keyframes, combined per (keyframe, landmark) pair, with what the
    update needs of each pair (everything that does not depend on the state), as parallel arrays.

    keyframe, landmark: (p,) the pair; A (p, 2, 3), B (p, 2, 2): its whitened Jacobian (the pair's
    measurements' 1/σ² summed); rows (p, 2, 3): L⁻¹ A with L Lᵀ = I + σ_p² B Bᵀ, the factor on the pose
    a first sighting leaves once its landmark is marginalized (rowsᵀ rows = Aᵀ (I + σ_p² B Bᵀ)⁻¹ A);
    G (p, 2, 3) and Dinv (p, 2, 2): the landmark's conditional on the pose at a first sighting,
    δl = G δx + w, w ~ N(0, D⁻¹), D = I/σ_p² + BᵀB.
    """

    keyframe: np.ndarray
    landmark: np.ndarray
    A: np.ndarray
    B: np.ndarray
    rows: np.ndarray
    G: np.ndarray
    Dinv: np.ndarray


def _pairs(
    poses: np.ndarray,
    points: np.ndarray,
    keyframe: np.ndarray,
    landmark: np.ndarray,
    sigma_b: np.ndarray,
    sigma_r: np.ndarray,
    prior_sigma: float,
) -> _Pairs:
    """:class:`_Pairs` of measurements (keyframe, landmark, noise std (m,) each), vectorized."""
    n_lm = max(len(points), 1)
    uniq, inv = np.unique(keyframe * n_lm + landmark, return_inverse=True)
    pk, pl = uniq // n_lm, uniq % n_lm
    info = np.column_stack(
        [np.bincount(inv, 1.0 / sigma_b**2, len(uniq)), np.bincount(inv, 1.0 / sigma_r**2, len(uniq))]
    )
    jac = bearing_range_jacobians(poses[pk], points[pl]) * np.sqrt(info)[:, :, None]
    A, B = jac[:, :, :3], jac[:, :, 3:]
    Bt = np.transpose(B, (0, 2, 1))
    s2 = prior_sigma**2
    chol = np.linalg.cholesky(np.eye(2) + s2 * B @ Bt)
    Dinv = np.linalg.inv(np.eye(2) / s2 + Bt @ B)
    return _Pairs(pk, pl, A, B, np.linalg.solve(chol, A), -Dinv @ Bt @ A, Dinv)


def _slice(p: _Pairs, lo: int, hi: int) -> _Pairs:
    return _Pairs(*(getattr(p, f)[lo:hi] for f in ("keyframe", "landmark", "A", "B", "rows", "G", "Dinv")))


def _pass(
    problem: Problem,
    measurements: _SuiteMeasurements,
    stop: int,
    last: np.ndarray,
    odo: np.ndarray,
    odo_cov: np.ndarray,
    prior_sigma: float,
    use: Use | None,
    on_prediction: Callable[[Prediction, KeyframeMeasurements], None] | None,
    start: Prediction | None = None,
    window: int | None = None,
    keep: list[int] | None = None,
    keep_horizon: int | None = None,
) -> FilterPass:
    s = problem.settings
    first = 0 if start is None else int(start.keyframe)
    poses = np.asarray(problem.scenario.keyframes.poses, float)
    points = np.asarray(problem.scenario.landmarks, float)
    K = max(stop - first, 0)  # the keyframes passed: the route's, or its first ones (forward_pass's until)
    predicted, filtered = np.zeros((K, 3, 3)), np.zeros((K, 3, 3))
    n_used = np.zeros(K, np.int64)
    measured = measurements.bounds if measurements.measured is None else measurements.measured
    n_measured = np.diff(measured[first : first + K + 1]).astype(np.int64)
    # every keyframe's pairs at once, with every measurement used: what the pass updates with where
    # ``use`` keeps all of a keyframe's measurements (always without ``use``), so a hook costs the
    # pass only its call and, where it leaves measurements out, that keyframe's pairs (the same
    # batched algebra per pair: the same numbers)
    rows = slice(int(measurements.bounds[first]), int(measurements.bounds[first + K])) if K else slice(0, 0)
    a = measurements.arrays
    every = _pairs(
        poses,
        points,
        a["pose"][rows],
        a["landmark"][rows],
        a["sigma_bearing_rad"][rows],
        a["sigma_range_m"][rows],
        prior_sigma,
    )
    bounds = np.searchsorted(every.keyframe, np.arange(first, first + K + 1))
    if use is None:
        n_used = np.diff(measurements.bounds[first : first + K + 1]).astype(np.int64)
    if start is None:
        state = _State(np.diag(np.asarray(s.first_pose_sigmas, float) ** 2), np.zeros(0, np.int64), len(points))
    else:  # another pass's predicted state at keyframe ``first``
        state = _State(np.asarray(start.covariance, float), np.asarray(start.landmarks, np.int64), len(points))
    # windows (:class:`_Window`) only where no hook sees the state: a hook is given the whole of it.
    # A window opens after a keyframe's prediction and closes before one's: the states kept are whole
    windowed = window != 0 and use is None and on_prediction is None
    span = WINDOW_KEYFRAMES if window is None else int(window)
    keep = keep or []
    states: dict[int, Prediction] = {}
    open_at, win, win_last = first, None, last
    for i in range(K):  # i: the row of the arrays; k: the keyframe
        k = first + i
        if win is not None and k == win.end:
            state, win, win_last = win.close(state, last), None, last
        P = state.P
        if i > 0:  # odometry: pose k − 1 replaced by pose k
            h = odo[k - 1]
            P[:3, 3:] = -h @ P[:3, 3:]
            P[3:, :3] = P[:3, 3:].T
            P[:3, :3] = h @ P[:3, :3] @ h.T + odo_cov
        predicted[i] = P[:3, :3]
        at = bisect.bisect_right(keep, k)
        if at and keep[at - 1] == k:
            states[k] = _kept(problem, state, k, keep_horizon, prior_sigma, last)
        if windowed and win is None and k >= open_at:
            end = min(k + span, first + K, *keep[at : at + 1])
            lo, hi = int(measurements.bounds[k]), int(measurements.bounds[end])
            opened = _Window.open(
                state,
                end,
                measurements.arrays["landmark"][lo:hi],
                2 * int(bounds[end - first] - bounds[i]),
                last,
                keyframes=end - k,
                force=window is not None,
            )
            if opened is not None:
                win, state = opened
                win_last = win.last
            open_at = end
        pairs = _slice(every, bounds[i], bounds[i + 1])
        if on_prediction is not None or use is not None:
            g = measurements.group(k)  # built for a hook only
            if on_prediction is not None:
                pred = Prediction(k, state.held.copy(), P.copy(), prior_sigma, state.slot.copy())
                on_prediction(pred, g)
            elif use is not None:  # valid during the call only (no copy: P is updated in place afterwards)
                view = P.view()
                view.flags.writeable = False
                pred = Prediction(k, state.held, view, prior_sigma, state.slot)
            if use is not None:
                mask = np.asarray(use(pred, g), bool)
                if mask.shape != (len(g),):
                    raise ValueError(
                        f"use returned a mask of shape {mask.shape} for {len(g)} measurements at keyframe {k}"
                    )
                n_used[i] = int(mask.sum())
                if n_used[i] < len(g):
                    pairs = _pairs(
                        poses,
                        points,
                        np.full(n_used[i], k),
                        g.landmark[mask],
                        g.sigma_bearing_rad[mask],
                        g.sigma_range_m[mask],
                        prior_sigma,
                    )
        # landmarks measured for the last time leave the state after this update
        _update(state, pairs, win_last, k)
        filtered[i] = state.P[:3, :3]
    return FilterPass(predicted, filtered, n_used, n_measured, states)


def _kept(
    problem: Problem, state: _State, k: int, horizon: int | None, prior_sigma: float, last: np.ndarray
) -> Prediction:
    """The whole predicted ``state`` at keyframe ``k`` (not in a window), copied; with ``horizon``,
    its marginal over the pose and the landmarks the library measures within it (forward_pass's
    ``keep_horizon``). ``last``: (n_landmarks,) the pass's last keyframe of each landmark."""
    assert state.off == 3, "a kept state is whole: no window is open at a kept keyframe"
    held = state.held
    if horizon is None:
        return Prediction(k, held.copy(), state.P.copy(), prior_sigma)
    # a landmark held at k whose last measurement by the suite is within the horizon is measured by the
    # library there (the suite's sensors are the library's): only the others are looked up. Near the
    # route's end (or on a short route) all are near, and the state is copied whole (a bound's base
    # keeps every keyframe's state there: the index copies were most of its cost on the README tour)
    at = last[held]
    near = (at >= k) & (at <= k + horizon)
    far = np.flatnonzero(~near)
    if len(far):
        near[far] = problem.measured_within(held[far], k, k + horizon)
    if near.all():
        return Prediction(k, held.copy(), state.P.copy(), prior_sigma)
    rows = np.concatenate([np.arange(3), _landmark_rows(3, np.flatnonzero(near))])
    return Prediction(k, held[near], block(state.P, rows, rows), prior_sigma)


class _State:
    """The filter's joint covariance over (pose, the landmarks held), in the top-left corner of a
    larger buffer, so that a landmark joining or leaving the state costs rows and columns, not a copy
    of the whole matrix (re-sorted at nearly every keyframe, the copies were a fifth of a pass over a
    user's drive with ~1,700 state rows; on KITTI 00 the update's own product dominates).

    The landmarks are held in the order they came and left: a new one is appended; one that leaves
    is replaced by the last one held (its rows and columns moved over). The order is a fixed function
    of the measurements, so a pass is deterministic; it is not sorted (:class:`Prediction`).

    Attributes:
        buf: (C, C) the buffer, C ≥ 3 + 2n; only :attr:`P` is meaningful.
        held: (n,) the landmark indices held, in the state's order.
        slot: (n_landmarks,) each landmark's position in ``held``, or −1.
    """

    def __init__(self, P: np.ndarray, held: np.ndarray, n_landmarks: int, off: int = 3, copy: bool = True) -> None:
        self.buf = np.array(P, float) if copy else P
        self.held = held.copy()
        self.slot = _slot_table(self.held, max(n_landmarks, 1))
        #: the first landmark row: 3 (after the pose), or 6 in a window (after the pose and the
        #: window's first pose, :class:`_Window`)
        self.off = off

    @property
    def P(self) -> np.ndarray:
        """(off + 2n, off + 2n) the joint covariance: a view of the buffer, updated in place."""
        n = self.off + 2 * len(self.held)
        return self.buf[:n, :n]

    def grow(self, cross: np.ndarray, ll: np.ndarray, landmarks: np.ndarray) -> None:
        """Append ``landmarks`` (q,) with their covariance ``ll`` (2q, 2q) and with the state ``cross``
        (2q, 3 + 2n)."""
        n, q2 = cross.shape[1], cross.shape[0]
        m = n + q2
        if m > self.buf.shape[0]:  # doubled: amortized, a copy per doubling
            bigger = np.empty((max(m, 2 * self.buf.shape[0]),) * 2)
            bigger[:n, :n] = self.buf[:n, :n]
            self.buf = bigger
        b = self.buf
        b[n:m, :n], b[:n, n:m], b[n:m, n:m] = cross, cross.T, ll
        self.slot[landmarks] = len(self.held) + np.arange(len(landmarks))
        self.held = np.concatenate([self.held, landmarks])

    def remove(self, gone: np.ndarray) -> None:
        """Marginalize out the landmarks held at positions ``gone`` ((n,) bool over ``held``): each
        hole below the new size takes the rows and columns of a landmark kept above it (exact: a
        marginal is the covariance's rows and columns kept, in any order)."""
        n_kept = len(self.held) - int(gone.sum())
        holes = np.flatnonzero(gone[:n_kept])
        movers = n_kept + np.flatnonzero(~gone[n_kept:])  # as many as holes
        self.slot[self.held[gone]] = -1
        if len(holes):
            n, m = self.off + 2 * len(self.held), self.off + 2 * n_kept
            to = _landmark_rows(self.off, holes)
            src = _landmark_rows(self.off, movers)
            b = self.buf
            b[to, :n] = b[src, :n]
            b[:m, to] = b[:m, src]
            self.held[holes] = self.held[movers]
            self.slot[self.held[holes]] = holes
        self.held = self.held[:n_kept]


#: the keyframes of a window (:class:`_Window`). KITTI 00 at 1 Hz, map model, CPU of one pass (dense:
#: 3.1 s, 0.25 s, 4.5 s): the long-range LiDAR (~380 landmarks held, ~95 measured per keyframe) 1.42 s
#: in windows of 8, 1.32-1.34 s in 12-32, 1.61 s in 48; a 4-sensor suite 0.20 / 0.15-0.17 / 0.18 s;
#: every third sensor 2.5 / 2.4-3.0 / 3.4 s
WINDOW_KEYFRAMES = 16
#: a window is opened where its cost model (flops, :data:`WINDOW_TOUCH`, :data:`WINDOW_FIXED`) is
#: below this share of the dense update's (the margin for what the model leaves out). Measured on
#: KITTI 00 and the bundled route (5 suites each, CPU of one pass): at 0.6 and no touch a 10-sensor
#: suite on 00 took 1.16 s, at 0.8 and 16 0.73-0.77 s (the no-LiDAR suite 3.09 -> 2.67-2.73 s); at 1.0
#: windows opened on the bundled route and made two of its passes 1.4-1.5x slower
WINDOW_WORTH = 0.8
#: what an update costs per element of the state beyond its flops, in flops (the product's
#: temporary and the subtraction: with few rows measured the update is bound by memory, not flops;
#: an update's time is this model's count at roughly 3e10 a second on the 2-core machine)
WINDOW_TOUCH = 16
#: what opening and closing a window costs beyond its products, in the same units: ~250 µs of index
#: copies and small calls (the README tour opened 3,167 windows, 1.1 s in all, and ran 4-5 % slower
#: than dense)
WINDOW_FIXED = 8e6


@dataclass(frozen=True, eq=False)
class _Window:
    """Keyframes over which the landmarks held but not measured (the dormant ones, D) are left out
    of the updates, exactly (the compressed filter of Guivant and Nebot, IEEE T-RA 2001, in its
    conditional form).

    At the window's first keyframe the state is split into a₀ = (the pose, the landmarks held that
    the window measures) and D. No factor of the window involves D, so D given a₀ is what it was:
    D = M a₀ + e, M = C₀ᵀ P₀⁻¹ (P₀ = Cov(a₀), C₀ = Cov(a₀, D) at the start), e independent of the
    window's measurements. The window's filter runs on the active part alone, with a copy of the
    first pose kept beside it (rows 3..5 of its state: the pose of a₀ once the odometry has moved
    on) and a₀'s landmarks held to its end, so that Σ = Cov(a₀ | the window's measurements) and
    Cov(state, a₀ | ...) are read off at the end (:meth:`close`):

        Cov(state, D) = Cov(state, a₀) P₀⁻¹ C₀,   Cov(D) = Cov₀(D) − C₀ᵀ P₀⁻¹ (P₀ − Σ) P₀⁻¹ C₀.

    Per keyframe the update costs (active rows)² instead of (all rows)²; the close costs a product
    over the dormant rows once. Exact (the same marginals as the dense pass, to round-off).

    Attributes:
        end: the first keyframe after the window.
        active: (a,) the landmarks of a₀ (held at the start and measured in the window).
        dormant: (d,) the others held at the start.
        prior: (3 + 2a, 3 + 2a) Cov(a₀) at the start; cross: (3 + 2a, 2d) Cov(a₀, D);
            dormant_cov: (2d, 2d) Cov(D).
        last: (n_landmarks,) the pass's last keyframes with a₀'s raised to ``end`` (held to the end).
    """

    end: int
    active: np.ndarray
    dormant: np.ndarray
    prior: np.ndarray
    cross: np.ndarray
    dormant_cov: np.ndarray
    last: np.ndarray

    @classmethod
    def open(
        cls,
        state: _State,
        end: int,
        measured: np.ndarray,
        rows: int,
        last: np.ndarray,
        *,
        keyframes: int = 1,
        force: bool = False,
    ) -> tuple[_Window, _State] | None:
        """The window ending at ``end`` on the full ``state`` (the landmarks ``measured`` in it,
        ``rows`` measurement rows in all), and the active state to run it on; None when no landmark
        is dormant, or (unless ``force``) where the dense update costs less (:data:`WINDOW_WORTH`)."""
        held = state.held
        n = state.off + 2 * len(held)
        per = rows + WINDOW_TOUCH * keyframes
        if not force and WINDOW_WORTH * n * n * per <= WINDOW_FIXED:  # not even a window of no cost pays
            return None
        seen = np.zeros(len(last), bool)
        seen[measured] = True
        active = seen[held]
        n_active = int(active.sum())
        if n_active == len(held):  # nothing dormant
            return None
        a, d = 3 + 2 * n_active, 2 * (len(held) - n_active)
        sub = a + 3 + 2 * (int(seen.sum()) - n_active)  # with the copy and the new landmarks
        windowed = sub * sub * per + 2 * a * a * d + sub * a * d + d * d * a + a**3 / 3 + WINDOW_FIXED
        if not force and windowed > WINDOW_WORTH * n * n * per:
            return None
        at = np.flatnonzero(active)
        idx = np.concatenate([np.arange(3), _landmark_rows(state.off, at)])
        out = _landmark_rows(state.off, np.flatnonzero(~active))
        P = state.P
        copy = np.concatenate([np.arange(3), idx])  # the pose twice: the second is the window's first pose
        win_last = last.copy()
        win_last[held[at]] = np.maximum(last[held[at]], end)
        win = cls(end, held[at], held[~active], block(P, idx, idx), block(P, idx, out), block(P, out, out), win_last)
        return win, _State(block(P, copy, copy), held[at], len(last), off=6)

    def close(self, state: _State, last: np.ndarray) -> _State:
        """The full state at :attr:`end` from the window's active ``state`` (class docstring); the
        landmarks the pass's ``last`` says leave before ``end`` leave."""
        P = state.P
        a0 = np.concatenate([np.arange(3, 6), _landmark_rows(6, state.slot[self.active])])
        kept = state.held[last[state.held] >= self.end]
        rows = np.concatenate([np.arange(3), _landmark_rows(6, state.slot[kept])])
        factor, info = dpotrf(self.prior, lower=1, clean=1)
        if info != 0:
            raise np.linalg.LinAlgError(f"the covariance at keyframe {self.end} is not positive definite ({info})")
        gain, info = dpotrs(factor, self.cross, lower=1)  # P₀⁻¹ C₀ (3 + 2a, 2d)
        if info != 0:
            raise np.linalg.LinAlgError(f"a singular covariance factor at keyframe {self.end} ({info})")
        # P₀ − Σ ⪰ 0 (the window's measurements only take uncertainty away) as R Rᵀ, R of its rank
        # (LAPACK's pivoted Cholesky; what is left below its tolerance, n ε max diag, is round-off),
        # so that C₀ᵀ P₀⁻¹ (P₀ − Σ) P₀⁻¹ C₀ = X Xᵀ with X = gainᵀ R: a product with its own
        # transpose (half the flops of two general products, and exactly symmetric: the dormant
        # block, the largest of the state, stays as symmetric as the state was, with no averaging pass)
        # (info > 0 only says that the rank is below the size; row piv[i] − 1 of R is L's row i)
        reduced, piv, rank, _ = dpstrf(self.prior - block(P, a0, a0), lower=1)
        R = np.tril(reduced[:, :rank])[np.argsort(piv)]
        X = gain.T @ R  # (2d, rank)
        n, d = len(rows), len(self.cross[0])
        full = np.empty((n + d, n + d))
        full[:n, :n] = block(P, rows, rows)
        full[:n, n:] = block(P, rows, a0) @ gain
        full[n:, :n] = full[:n, n:].T
        np.subtract(self.dormant_cov, X @ X.T, out=full[n:, n:])
        return _State(full, np.concatenate([kept, self.dormant]), len(last), copy=False)


def _update(state: _State, pairs: _Pairs, last: np.ndarray, k: int) -> None:
    """The measurement update of keyframe k (step 2 of the module's docstring), then step 3, on ``state``."""
    if len(pairs.landmark):
        P = state.P
        slot = state.slot[pairs.landmark]  # where each pair's landmark is in the state (−1: new)
        old = slot >= 0
        new = ~old
        any_new = bool(new.any())
        # the rows of the update: old landmarks' measurements, then the new landmarks' factors on the pose
        if any_new:
            Ao, Bo, so = pairs.A[old], pairs.B[old], slot[old]
            Ax = np.concatenate([Ao.reshape(-1, 3), pairs.rows[new].reshape(-1, 3)])  # (r, 3) pose part of every row
        else:  # every landmark held (most keyframes): the same rows without the masks' copies
            Ao, Bo, so = pairs.A, pairs.B, slot
            Ax = Ao.reshape(-1, 3)
        r_old = 2 * len(Ao)
        r = len(Ax)
        n_state = P.shape[0]
        cols = state.off + 2 * so[:, None] + np.arange(2)  # (o, 2) state columns of each old landmark
        U = P[:, :3] @ Ax.T  # (N, r) = P Hᵀ
        if r_old:
            # landmark part: U[:, 2i + a] += Σ_b P[:, cols[i, b]] B[i, a, b]
            U[:, :r_old] += np.einsum("nib,iab->nia", P[:, cols], Bo).reshape(n_state, r_old)
        HU = Ax @ U[:3]  # (r, r) = H P Hᵀ, pose part
        if r_old:
            HU[:r_old] += np.einsum("iab,ibr->iar", Bo, U[cols]).reshape(r_old, r)
        S = np.eye(r) + 0.5 * (HU + HU.T)
        # LAPACK itself, as scipy.linalg.cholesky and solve_triangular call it (the same numbers),
        # without their wrappers' checks: a tenth of a small update's time
        L, info = dpotrf(S, lower=1, clean=1)
        if info != 0:
            raise np.linalg.LinAlgError(f"the innovation covariance at keyframe {k} is not positive definite ({info})")
        V, info = dtrtrs(L, U.T, lower=1)  # (r, N)
        if info != 0:
            raise np.linalg.LinAlgError(f"a singular innovation factor at keyframe {k} ({info})")
        # numpy computes Vᵀ V by dsyrk (a product with its own transpose): exactly symmetric
        P -= V.T @ V
        if any_new:
            # the new landmarks join the state: Cov(l, ·) = G P_x·, Cov(l, l') = G P_xx G'ᵀ + δ D⁻¹
            q = int(new.sum())
            G = pairs.G[new].reshape(2 * q, 3)
            cross = G @ P[:3, :]  # (2q, N)
            ll = G @ P[:3, :3] @ G.T
            diagonal = ll.reshape(q, 2, q, 2)  # a view: [i, :, i, :] is new landmark i's own 2 x 2 block
            at = np.arange(q)
            diagonal[at, :, at, :] += pairs.Dinv[new]
            state.grow(cross, ll, pairs.landmark[new])
    keep = last[state.held] > k
    if not keep.all():
        state.remove(~keep)
