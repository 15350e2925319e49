"""Solving one run: the factor graph of a draw (built by :mod:`sensorsel.information.graph`), batch
Levenberg-Marquardt or incremental iSAM2, both started from dead reckoning (never from the truth).

One factor per measured (keyframe, landmark) pair: the suite's sensors often measure the same
landmark from the same keyframe (on KITTI 00 the $110,000 greedy suite makes 84,332 measurements of
49,272 pairs). Measurements z_i = h(x) + n_i of one pair share h, and their noise is independent and
diagonal, so per component Σ_i (h − z_i)² / σ_i² = (h − z̄)² / σ̄² + Σ_i (z_i − z̄)² / σ_i² with
1/σ̄² = Σ_i 1/σ_i² and z̄ = σ̄² Σ_i z_i / σ_i²: one factor at z̄ with σ̄ has the same minimiser and
the same information at every linearization point (the bearing's residual wraps at ±π: exact while
the measurements of a pair and the estimate's bearing lie within π of each other, i.e. always but
for a bearing wrong by ~180°). The constant is added back to the reported final error. GTSAM's
elimination cost grows with the factors: on 00 it was ~1.5 s of each ~1.6 s LM iteration.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import gtsam
import numpy as np
from gtsam.symbol_shorthand import L, X

from sensorsel.information.graph import (
    MeasurementNoise,
    add_bearing_range,
    add_pose_chain,
    bearing_range_factor,
    diagonal,
    first_pose_prior,
    landmark_prior,
    odometry_factor,
)
from sensorsel.model.angles import wrap_angle
from sensorsel.model.sensing import Measurements
from sensorsel.simulation.noise import Draw, Payload, draw

SOLVERS = ("lm", "isam2")
DEFAULT_SOLVER = "lm"
LM_MAX_ITERATIONS = 100
ISAM2_MAX_FINAL_UPDATES = 20


@dataclass(frozen=True, eq=False)
class Pairs(Measurements):
    """A draw's kept measurements combined into one per (keyframe, landmark) pair (see the module):
    m :class:`~sensorsel.model.sensing.Measurements`, sorted by keyframe then landmark, each pair's
    bearing and range the information-weighted mean of its measurements, its std their combined one
    (1/σ̄² = Σ 1/σ_i²).

    Attributes:
        first: (m,) payload index of each pair's first measurement (in :meth:`Payload.order`).
        constant: Σ_i (z_i − z̄)² / (2 σ_i²) over every pair and component: the error the
            combination leaves out (0.5 × whitened squared residuals, as ``graph.error``).
    """

    first: np.ndarray
    constant: float


def pairs(p: Payload, d: Draw) -> Pairs:
    """The kept measurements of draw ``d`` combined per (keyframe, landmark) pair."""
    idx = p.order()
    key = p.pose[idx].astype(np.int64) * max(len(p.landmarks), 1) + p.landmark[idx]
    _, first, group = np.unique(key, return_index=True, return_inverse=True)
    group = group.reshape(-1)
    n = len(first)

    def combine(z: np.ndarray, sigma: np.ndarray, wrap: bool) -> tuple[np.ndarray, np.ndarray, float]:
        w = 1.0 / sigma**2
        ref = z[first]
        dev = z - ref[group]
        if wrap:
            dev = wrap_angle(dev)
        wsum = np.bincount(group, weights=w, minlength=n)
        mean_dev = np.bincount(group, weights=w * dev, minlength=n) / wsum
        rest = dev - mean_dev[group]
        return ref + mean_dev, 1.0 / np.sqrt(wsum), float(0.5 * np.sum(w * rest * rest))

    b, sb, cb = combine(d.bearing_rad[idx], p.sigma_bearing_rad[idx], True)
    r, sr, cr = combine(d.range_m[idx], p.sigma_range_m[idx], False)
    return Pairs(
        pose=p.pose[idx][first],
        landmark=p.landmark[idx][first],
        bearing_rad=wrap_angle(b),
        range_m=r,
        sigma_bearing_rad=sb,
        sigma_range_m=sr,
        first=idx[first],
        constant=cb + cr,
    )


class Noise:
    """A payload's noise models: first-pose prior, odometry, and one per distinct measurement sigmas."""

    def __init__(self, p: Payload) -> None:
        self.prior = diagonal(p.first_pose_sigmas)
        self.odometry = diagonal(p.odometry_sigmas)
        self.map = None if p.map_sigma_m is None else diagonal([p.map_sigma_m, p.map_sigma_m])
        self._p = p
        self._models = MeasurementNoise()

    def measurement(self, i: int) -> gtsam.noiseModel.Base:
        """The model of measurement ``i`` of the payload."""
        return self._models(self._p.sigma_bearing_rad[i], self._p.sigma_range_m[i])

    def map_prior(self, j: int, point: np.ndarray) -> gtsam.NonlinearFactor:
        """The map model's prior on landmark ``j`` at its map position ``point`` [m]."""
        if self.map is None:
            raise ValueError("a landmark prior needs the map model (a payload with map_sigma_m)")
        return landmark_prior(j, point, self.map)

    def pair(self, q: Pairs, i: int) -> gtsam.noiseModel.Base:
        """The model of combined pair ``i`` of ``q``."""
        return self._models(q.sigma_bearing_rad[i], q.sigma_range_m[i])


def build_graph(p: Payload, noise: Noise, d: Draw, q: Pairs | None = None) -> gtsam.NonlinearFactorGraph:
    """Prior, odometry, then the kept measurements combined per pair (``q``, default
    :func:`pairs` of ``d``) in keyframe order, holding the values of ``d``; in the map model a prior
    on each measured landmark at the run's map position.

    In SLAM no landmark prior (a car has none; at the true position it would leak the truth). The
    map model's prior sits at the drawn map position (the truth off by the map's error), never at
    the truth."""
    g = gtsam.NonlinearFactorGraph()
    add_pose_chain(g, d.prior, d.odometry, noise.prior, noise.odometry)
    q = pairs(p, d) if q is None else q
    add_bearing_range(g, q.pose, q.landmark, q.bearing_rad, q.range_m, [noise.pair(q, i) for i in range(len(q.pose))])
    if d.map_points is not None:
        for j in p.measured_landmarks():
            g.add(noise.map_prior(int(j), d.map_points[j]))
    return g


def _landmark_start(d: Draw, j: int, pose: gtsam.Pose2, i: int) -> np.ndarray:
    """Where landmark ``j`` starts: its map position (map model: what a car localizing in a map
    knows), else its first measurement ``i`` seen from ``pose`` (the pose's own starting value)."""
    if d.map_points is not None:
        return np.array(d.map_points[j], dtype=float)
    return landmark_from(pose, float(d.bearing_rad[i]), float(d.range_m[i]))


def landmark_from(pose: gtsam.Pose2, bearing: float, rng_m: float) -> np.ndarray:
    """The point at ``bearing`` [rad] and ``rng_m`` [m] from ``pose``."""
    return pose.transformFrom(gtsam.Point2(rng_m * math.cos(bearing), rng_m * math.sin(bearing)))


def pose_array(values: gtsam.Values, n: int) -> np.ndarray:
    """(n, 3) poses X(0..n-1) of ``values`` as (x, y, heading)."""
    out = np.empty((n, 3))
    for k in range(n):
        q = values.atPose2(X(k))
        out[k] = q.x(), q.y(), q.theta()
    return out


def _flat(values: gtsam.Values) -> np.ndarray:
    """All poses and points of ``values`` as one vector (to see when iSAM2 stops moving)."""
    return np.concatenate([gtsam.utilities.extractPose2(values).ravel(), gtsam.utilities.extractPoint2(values).ravel()])


def solve_lm(
    p: Payload, noise: Noise, d: Draw, dead: list[gtsam.Pose2], q: Pairs
) -> tuple[gtsam.Values, int, gtsam.NonlinearFactorGraph]:
    """Batch Levenberg-Marquardt from dead reckoning; each landmark starts at its first measurement
    (map model: its map position) seen from the dead-reckoned pose. Returns (estimate, iterations, graph)."""
    graph = build_graph(p, noise, d, q)
    initial = gtsam.Values()
    for k, pose in enumerate(dead):
        initial.insert(X(k), pose)
    for i in q.first.tolist():  # pairs in keyframe order: a landmark's first pair holds its first measurement
        j = int(p.landmark[i])
        if not initial.exists(L(j)):
            initial.insert(L(j), _landmark_start(d, j, dead[int(p.pose[i])], i))
    params = gtsam.LevenbergMarquardtParams()
    params.setMaxIterations(LM_MAX_ITERATIONS)
    params.setRelativeErrorTol(1e-10)
    params.setAbsoluteErrorTol(1e-12)
    opt = gtsam.LevenbergMarquardtOptimizer(graph, initial, params)
    estimate = opt.optimize()
    return estimate, int(opt.iterations()), graph


def solve_isam2(p: Payload, noise: Noise, d: Draw, q: Pairs) -> tuple[gtsam.Values, int, gtsam.NonlinearFactorGraph]:
    """Keyframes in order, as a car would: each new pose starts at the current estimate of the previous
    one composed with the odometry, each new landmark at its first measurement from that pose.
    Returns (estimate, updates, every factor added)."""
    params = gtsam.ISAM2Params()
    params.setRelinearizeThreshold(0.01)
    params.relinearizeSkip = 1
    isam = gtsam.ISAM2(params)
    full = gtsam.NonlinearFactorGraph()
    by_pose = np.split(np.arange(len(q.pose)), np.searchsorted(q.pose, np.arange(1, len(p.poses))))
    seen: set[int] = set()
    updates = 0
    for k, meas in enumerate(by_pose):
        g, v = gtsam.NonlinearFactorGraph(), gtsam.Values()
        if k == 0:
            g.add(first_pose_prior(d.prior, noise.prior))
            start = d.prior
        else:
            g.add(odometry_factor(k, d.odometry[k - 1], noise.odometry))
            start = isam.calculateEstimatePose2(X(k - 1)).compose(d.odometry[k - 1])
        v.insert(X(k), start)
        for c in meas:
            j = int(q.landmark[c])
            g.add(bearing_range_factor(k, j, float(q.bearing_rad[c]), float(q.range_m[c]), noise.pair(q, c)))
            if j not in seen:
                seen.add(j)
                v.insert(L(j), _landmark_start(d, j, start, int(q.first[c])))
                if d.map_points is not None:
                    g.add(noise.map_prior(j, d.map_points[j]))
        isam.update(g, v)
        full.push_back(g)
        updates += 1
    updates += _settle(isam)
    return isam.calculateEstimate(), updates, full


def _settle(isam: gtsam.ISAM2) -> int:
    """A few more updates relinearize what moved since it was last linearized (the last keyframes);
    stops when nothing moves by 1e-10. Returns the updates made."""
    updates = 0
    last = _flat(isam.calculateEstimate())
    for _ in range(ISAM2_MAX_FINAL_UPDATES):
        isam.update()
        updates += 1
        now = _flat(isam.calculateEstimate())
        done = np.max(np.abs(now - last)) < 1e-10
        last = now
        if done:
            break
    return updates


def solve_run(p: Payload, run: int) -> dict[str, np.ndarray | float | int]:
    """Draw, initialise, solve one run. Returns numbers only (estimates; errors are computed by the caller)."""
    d = draw(p, run)
    noise = Noise(p)
    dead = d.dead_reckoning()
    q = pairs(p, d)
    if p.solver == "lm":
        estimate, iterations, graph = solve_lm(p, noise, d, dead, q)
    else:
        estimate, iterations, graph = solve_isam2(p, noise, d, q)
    lm_est = np.full((len(p.landmarks), 2), np.nan)
    for j in np.unique(p.landmark[p.order()]):
        lm_est[j] = estimate.atPoint2(L(int(j)))
    return {
        "poses": pose_array(estimate, len(p.poses)),
        "landmarks": lm_est,
        "dead_reckoning": np.array([[q.x(), q.y(), q.theta()] for q in dead]),
        "iterations": iterations,
        "final_error": float(graph.error(estimate)) + q.constant,  # the error of the graph of every measurement
    }
