"""The covariance the car has as it drives: a filter over the route, one keyframe at a time.

A dense, exact forward pass with the interface the package's callers code against. Its state is
pose k and the landmarks seen so far, a Kalman filter in covariance form: each step updates with
keyframe k's used measurements, then moves the pose by the odometry to k + 1 (which marginalizes
pose k out). In the linear-Gaussian model at the truth (the graph linearized at the ground truth, as
every evaluator of the package) this is exact: the filtered covariance at k equals the marginal of
X(k) in the batch graph of the priors, odometry up to k and the used measurements of keyframes
<= k. Each keyframe costs O(n² m) for n landmarks seen so far and m measurements: dense, for routes
of hundreds of keyframes and landmarks.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Iterable

import numpy as np

from sensorsel.information.linearize import bearing_range_jacobians, odometry_jacobians
from sensorsel.model.problem import Problem

__all__ = ["FilterPass", "KeyframeMeasurements", "Prediction", "Use", "forward_pass", "keyframe_measurements"]


@dataclass(frozen=True, eq=False)
class KeyframeMeasurements:
    """The suite's measurements made at one keyframe, as parallel (m,) arrays, in a fixed order
    (by sensor position in the library, then landmark index)."""

    keyframe: int
    sensor: np.ndarray
    landmark: np.ndarray
    bearing_rad: np.ndarray
    range_m: np.ndarray
    sigma_bearing_rad: np.ndarray
    sigma_range_m: np.ndarray

    def __len__(self) -> int:
        return len(self.sensor)


@dataclass(frozen=True, eq=False)
class Prediction:
    """What the car knows just before keyframe k's measurements: the joint Gaussian over pose k's
    tangent (dx, dy in the keyframe's own frame [m], dθ [rad]) and the landmarks held in the state
    ((x, y) world [m]), from the used measurements of keyframes < k, odometry up to k and the priors.
    A landmark not in ``landmarks`` is independent of the pose and of the others, with its prior
    covariance (``prior_sigma_m``² I).

    Attributes:
        keyframe: k.
        landmarks: (n,) sorted landmark indices held in the state.
        covariance: (3 + 2n, 3 + 2n): pose first, then each landmark's (x, y).
        prior_sigma_m: the prior std [m] of a landmark not in the state.
    """

    keyframe: int
    landmarks: np.ndarray
    covariance: np.ndarray
    prior_sigma_m: float


#: decides which of keyframe k's measurements the filter uses: returns a (m,) bool mask
Use = Callable[[Prediction, KeyframeMeasurements], np.ndarray]


@dataclass(frozen=True, eq=False)
class FilterPass:
    """A forward pass: (K, 3, 3) pose covariances before and after each keyframe's measurements,
    and (K,) counts of the measurements used and made."""

    predicted: np.ndarray
    filtered: np.ndarray
    n_used: np.ndarray
    n_measured: np.ndarray


def keyframe_measurements(problem: Problem, suite: Iterable[int]) -> list[KeyframeMeasurements]:
    """The suite's measurements grouped by keyframe (K entries, possibly empty), from
    ``problem.observations`` (which already carry the problem's condition)."""
    n_poses = problem.scenario.n_poses
    parts = [problem.observations[i] for i in sorted(set(int(s) for s in suite))]
    cols = {name: np.concatenate([np.asarray(getattr(o, attr)) for o in parts]) if parts else np.zeros(0)
            for name, attr in (("pose", "pose"), ("landmark", "landmark"), ("bearing_rad", "bearing_rad"),
                               ("range_m", "range_m"), ("sigma_bearing_rad", "sigma_bearing_rad"),
                               ("sigma_range_m", "sigma_range_m"))}
    sensor = np.concatenate([np.full(len(o), o.sensor, np.int64) for o in parts]) if parts else np.zeros(0, np.int64)
    pose = cols["pose"].astype(np.int64)
    landmark = cols["landmark"].astype(np.int64)
    order = np.lexsort((landmark, sensor, pose))
    bounds = np.searchsorted(pose[order], np.arange(n_poses + 1))
    out = []
    for k in range(n_poses):
        idx = order[bounds[k]:bounds[k + 1]]
        out.append(KeyframeMeasurements(
            keyframe=k, sensor=sensor[idx], landmark=landmark[idx], bearing_rad=cols["bearing_rad"][idx].astype(float),
            range_m=cols["range_m"][idx].astype(float), sigma_bearing_rad=cols["sigma_bearing_rad"][idx].astype(float),
            sigma_range_m=cols["sigma_range_m"][idx].astype(float)))
    return out


def forward_pass(problem: Problem, suite: Iterable[int], *, map_sigma_m: float | None = None, use: Use | None = None,
                 on_prediction: Callable[[Prediction, KeyframeMeasurements], None] | None = None) -> FilterPass:
    """One forward pass over the route, exact: ``filtered[k]`` equals GTSAM's marginal of X(k) in the
    graph of the priors, odometry up to k and the used measurements of keyframes <= k;
    ``predicted[k]`` the same without keyframe k's measurements. ``map_sigma_m``: every landmark's
    prior std [m] (a prior map); None: the problem's weak prior (SLAM). ``use`` (default: all) is
    called once per keyframe, before its update; ``on_prediction`` too (for callers that only observe).

    A Kalman filter in covariance form over (pose k, landmarks seen so far), at the truth: a landmark
    enters the state with its prior at its first used measurement; each keyframe's used measurements
    update it (Σ ← Σ − Σ Jᵀ (J Σ Jᵀ + I)⁻¹ J Σ, J whitened); the odometry to k + 1 moves the pose
    (δx_{k+1} = −H δx_k + w: Σ_pp ← H Σ_pp Hᵀ + Ω⁻¹, Σ_pl ← −H Σ_pl), which marginalizes pose k out.
    """
    sc, s = problem.scenario, problem.settings
    poses = np.asarray(sc.keyframes.poses, float)
    points = np.asarray(sc.landmarks, float)
    n_poses = len(poses)
    prior_sigma = float(s.landmark_prior_sigma_m if map_sigma_m is None else map_sigma_m)
    odo_cov = np.diag(np.asarray(s.odometry_sigmas, float) ** 2)
    odo_jac = odometry_jacobians(poses) if n_poses > 1 else np.zeros((0, 3, 3))
    groups = keyframe_measurements(problem, suite)
    state: list[int] = []  # landmark indices in the state, in the order they entered
    slot: dict[int, int] = {}
    cov = np.diag(np.asarray(s.first_pose_sigmas, float) ** 2)
    predicted = np.zeros((n_poses, 3, 3))
    filtered = np.zeros((n_poses, 3, 3))
    n_used = np.zeros(n_poses, np.int64)
    n_measured = np.zeros(n_poses, np.int64)
    for k in range(n_poses):
        meas = groups[k]
        predicted[k] = cov[:3, :3]
        mask = np.ones(len(meas), bool)
        if use is not None or on_prediction is not None:
            pred = _prediction(k, cov, state, prior_sigma)
            if on_prediction is not None:
                on_prediction(pred, meas)
            if use is not None:
                mask = np.asarray(use(pred, meas), bool)
        n_measured[k] = len(meas)
        n_used[k] = int(mask.sum())
        if n_used[k]:
            lms = meas.landmark[mask]
            new = [j for j in dict.fromkeys(lms.tolist()) if j not in slot]
            if new:
                for j in new:
                    slot[j] = len(state)
                    state.append(j)
                n = cov.shape[0]
                grown = np.zeros((n + 2 * len(new), n + 2 * len(new)))
                grown[:n, :n] = cov
                grown[n:, n:] = np.eye(2 * len(new)) * prior_sigma ** 2
                cov = grown
            jac = bearing_range_jacobians(np.repeat(poses[k][None], len(lms), 0), points[lms])
            jac = jac / np.column_stack([meas.sigma_bearing_rad[mask], meas.sigma_range_m[mask]])[:, :, None]
            big = np.zeros((2 * len(lms), cov.shape[0]))
            for r, (a, j) in enumerate(zip(jac, lms.tolist())):
                big[2 * r:2 * r + 2, :3] = a[:, :3]
                big[2 * r:2 * r + 2, 3 + 2 * slot[j]:5 + 2 * slot[j]] = a[:, 3:]
            sj = cov @ big.T  # Σ Jᵀ
            chol = np.linalg.cholesky(big @ sj + np.eye(len(big)))
            w = np.linalg.solve(chol, sj.T)  # L⁻¹ J Σ
            cov = cov - w.T @ w
            cov = 0.5 * (cov + cov.T)
        filtered[k] = cov[:3, :3]
        if k + 1 < n_poses:
            h = odo_jac[k]
            cov = cov.copy()
            cov[:3, 3:] = -h @ cov[:3, 3:]
            cov[3:, :3] = cov[:3, 3:].T
            cov[:3, :3] = h @ cov[:3, :3] @ h.T + odo_cov
    return FilterPass(predicted=predicted, filtered=filtered, n_used=n_used, n_measured=n_measured)


def _prediction(k: int, cov: np.ndarray, state: list[int], prior_sigma: float) -> Prediction:
    order = np.argsort(np.asarray(state, np.int64), kind="stable")
    idx = np.r_[0:3, (3 + 2 * order[:, None] + np.arange(2)).ravel()].astype(np.int64)
    return Prediction(keyframe=k, landmarks=np.asarray(state, np.int64)[order],
                      covariance=cov[np.ix_(idx, idx)], prior_sigma_m=prior_sigma)
