"""Does the predicted association risk come true? The stated associator run on simulated measurements.

:mod:`sensorsel.information.integrity.association` predicts, per measurement, the probability that
gated nearest neighbour on the NIS associates it with a wrong landmark. This module runs that
associator for real, keyframe by keyframe, on draws of what the car has when it associates:

- the car's pose error and its landmarks' errors, drawn jointly from the forward pass's
  :class:`~sensorsel.information.filtering.Prediction` before the keyframe's measurements (in the
  map model the map's landmarks with their σ; in SLAM the filter's landmarks, correlated with the
  pose); the estimate x̂ is the truth retracted by the pose error (Pose2, own frame), l̂ = l + e;
- each measurement of the suite: the true (bearing, range) plus the sensor's noise;
- optionally unmapped clutter objects (a Poisson number, ``clutter_per_km`` per km of the route
  within reach, each at a point of the route offset uniformly within ±W in x and y, W the largest
  distance of a map landmark from the route: clutter stands where landmarks stand), detected by each
  sensor of the suite whose cone holds them, with that sensor's noise;
- the associator as stated: per measurement, candidates the landmarks within 1.25 r + 5 m of x̂ (r
  the measured range; in SLAM only those in the filter's state), the innovation ν_j = z − h(x̂, l̂_j)
  with the nonlinear model, NIS_j = ν_jᵀ S_j⁻¹ ν_j, the gate γ = −2 ln(1 − p_G), the nearest gated
  candidate chosen. S_j = R + H_j P_j H_jᵀ is evaluated at the truth (the car evaluates it at its
  estimate: they differ by the estimate's error over the range, a few 1e-3 relative here).

A measurement is **wrongly associated** when it is matched to a landmark other than the one it
measured (in SLAM, a first sighting matched to any state landmark); a clutter detection when it is
matched to any landmark. Pairs whose λ (the predicted non-centrality) exceeds (√γ + 12)² are not
evaluated: such a candidate falls in the gate with probability below 1e-30.

**The error a wrong association causes.** Each wrong association's effect on the pose estimate is
the filter's update with the wrong landmark: the one-measurement Kalman update from the prediction
moves the pose by K_j ν_j instead of K_i ν_i (K = P Hᵀ S⁻¹, pose rows), so it shifts the estimate
by Δ = K_j ν_j − K_i ν_i (a first sighting would have added no pose information: Δ = K_j ν_j).
Why the filter's update and not a GTSAM solve per draw: the probabilities checked here need 10⁴–10⁶
draws per keyframe; the update is what the car's filter does at that keyframe, in the linearized
model every prediction of the package uses. What it leaves out: the error carried to later
keyframes, and the other measurements of the keyframe pulling the estimate back (the shift is that
of the measurement updated first, an upper figure).

**Rare events by importance sampling** (``importance``): each measurement i is simulated on its
own, its variables y (the pose error, the errors of its candidates, its noise; Gaussian, covariance
Σ_y = L Lᵀ) drawn from a defensive mixture of mean shifts: a share α = 0.2 from N(0, Σ_y), the rest
from N(μ_j, Σ_y) for a wrong candidate j drawn uniformly, μ_j the most likely y that brings the
innovation ν_j to the decision boundary in the linearized model (ν_j = d_ij + A_j y): μ_j =
−t Σ_y A_jᵀ S_j⁻¹ d_ij, t = max(½, 1 − √(γ/λ_j)) (half way to j, or onto j's gate when j is far).
Each draw is weighted by the likelihood ratio w = φ(w̃) / [α φ(w̃) + (1 − α)/J Σ_j φ(w̃ − m_j)] (w̃
the whitened draw, m_j = L⁻¹ μ_j), so E[w 1_W] = P(W_i) exactly and w ≤ 1/α. Only the shifted
directions change: the weights do not degenerate with the dimension (inflating the whole
covariance did: with a radar's dozen candidates, a scale of 2 gave weights of variance ~10⁶). The
keyframe's figure is then 1 − Π_i (1 − P̂(W_i)) (the measurements as independent, as the estimate
takes them: exact to first order where they are rare, which is where importance sampling is
for; plain Monte Carlo remains the reference where they are not), with standard error
√(Σ_i se_i²). Plain Monte Carlo runs all of a keyframe's measurements on one shared draw and
counts keyframes with at least one wrong association.

Random numbers: keyframe k draws from ``SeedSequence([seed, 3, k])``, whatever runs it, so the
result does not depend on the executor or the number of workers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sensorsel.information.linearize import bearing_range_jacobians
from sensorsel.model.angles import wrap_angle

__all__ = [
    "CANDIDATE_MARGIN_M",
    "CANDIDATE_SCALE",
    "RANGE_SIGMAS",
    "KeyframeCase",
    "KeyframeOutcome",
    "SensorCone",
    "Task",
    "associate_keyframe",
    "measure",
    "retract",
]

#: the stated candidates: landmarks within CANDIDATE_SCALE × r + CANDIDATE_MARGIN_M of the car
CANDIDATE_SCALE = 1.25
CANDIDATE_MARGIN_M = 5.0
#: a measured range lies within this many σ_r of the true one but with probability < 1e-15: the
#: associator's reach at the measured range is covered by the reach at r + RANGE_SIGMAS σ_r
RANGE_SIGMAS = 8.0
#: pairs with λ > (√γ + PRUNE_SIGMAS)² are not evaluated (gated with probability < 1e-30)
PRUNE_SIGMAS = 12.0
#: draws per block (memory: block × pairs × a few doubles)
BLOCK = 4096
#: importance sampling: the share of draws from the unshifted density (bounds every weight by 1/DEFENSIVE)
DEFENSIVE = 0.2


@dataclass(frozen=True)
class SensorCone:
    """A suite sensor as clutter sees it: library position, mount angle [rad], field of view [rad],
    range [m], bearing σ [rad], range σ = const + quad × r² [m] (stereo: quad, others: const)."""

    position: int
    mount_rad: float
    fov_rad: float
    range_m: float
    sigma_bearing_rad: float
    sigma_range_const_m: float
    sigma_range_quad_per_m: float


@dataclass(frozen=True, eq=False)
class KeyframeCase:
    """Everything one keyframe's draws need, as numbers (pickled once per worker).

    Attributes:
        keyframe: k.
        pose: (3,) the true pose (x [m], y [m], heading [rad]).
        sensor, landmark: (m,) library position and truly measured landmark of each measurement.
        bearing_rad, range_m, sigma_bearing_rad, sigma_range_m: (m,) truth and noise std.
        candidates: (C,) landmark indices the associator may match here (SLAM: those in the state).
        points: (C, 2) their true positions [m].
        right: (m,) slot in ``candidates`` of the truly measured landmark; −1: a first sighting.
        covariance: (3 + 2C, 3 + 2C) joint covariance of the pose error and the candidates' errors.
        cones: the suite's sensors (clutter detections).
        route_xy: (R, 2) the route near the car, 1 m apart (the clutter corridor).
    """

    keyframe: int
    pose: np.ndarray
    sensor: np.ndarray
    landmark: np.ndarray
    bearing_rad: np.ndarray
    range_m: np.ndarray
    sigma_bearing_rad: np.ndarray
    sigma_range_m: np.ndarray
    candidates: np.ndarray
    points: np.ndarray
    right: np.ndarray
    covariance: np.ndarray
    cones: tuple[SensorCone, ...] = ()
    route_xy: np.ndarray | None = None


@dataclass(frozen=True)
class Task:
    """One keyframe's draws: ``draws`` of them from (seed, 3, keyframe), the gate γ, whether by
    importance sampling (else plain Monte Carlo), clutter per m² within ``corridor_m`` of the route, and the alert
    limits [m, m, rad] a wrong association's shift is judged against."""

    keyframe: int
    draws: int
    seed: int
    gate: float
    importance: bool = False
    clutter_per_m2: float = 0.0
    corridor_m: float = 0.0
    alert_m_rad: tuple[float, float, float] = (0.29, 0.29, math.radians(0.5))


@dataclass(frozen=True)
class KeyframeOutcome:
    """What one keyframe's draws observed (weighted by the likelihood ratio when importance sampled).

    Attributes:
        keyframe: k.
        draws: the draws (per measurement when importance sampled).
        wrong_draws: plain Monte Carlo: draws with at least one wrong association of a mapped
            landmark's measurement (an integer count); importance sampling: −1.
        p_wrong: observed P(at least one wrong association) (importance sampling: 1 − Π_i (1 − P̂(W_i))).
        standard_error: its standard error (plain: binomial; importance sampling: of the weights).
        p_wrong_clutter: observed P(a clutter detection is matched to a landmark) (plain only).
        clutter_draws: draws with a clutter detection matched.
        wrong_per_sensor: (position, expected wrong associations per keyframe) for each suite sensor.
        shift_lateral_m, shift_longitudinal_m, shift_heading_deg: mean, over draws with a wrong
            association, of the largest |shift| it causes (nan when none).
        p_beyond_alert: P(a wrong association shifts the estimate beyond an alert limit).
    """

    keyframe: int
    draws: int
    wrong_draws: int
    p_wrong: float
    standard_error: float
    p_wrong_clutter: float
    clutter_draws: int
    wrong_per_sensor: tuple[tuple[int, float], ...]
    shift_lateral_m: float
    shift_longitudinal_m: float
    shift_heading_deg: float
    p_beyond_alert: float


def measure(pose: np.ndarray, point: np.ndarray) -> np.ndarray:
    """(..., 2) bearing [rad] and range [m] of ``point`` (..., 2) from ``pose`` (..., 3)."""
    dx, dy = point[..., 0] - pose[..., 0], point[..., 1] - pose[..., 1]
    c, s = np.cos(pose[..., 2]), np.sin(pose[..., 2])
    return np.stack([np.arctan2(c * dy - s * dx, c * dx + s * dy), np.hypot(dx, dy)], -1)


def retract(pose: np.ndarray, delta: np.ndarray) -> np.ndarray:
    """(B, 3) the pose (3,) moved by ``delta`` (B, 3) (dx, dy in its own frame [m], dθ [rad]), to first order."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return np.stack(
        [
            pose[0] + c * delta[:, 0] - s * delta[:, 1],
            pose[1] + s * delta[:, 0] + c * delta[:, 1],
            pose[2] + delta[:, 2],
        ],
        -1,
    )


@dataclass(frozen=True, eq=False)
class _Pairs:
    """The evaluated (measurement, candidate) pairs of a keyframe, in measurement order: the
    measurement ``mi``, candidate slot ``cj``, S⁻¹ (P, 2, 2) and the pose gain K (P, 3, 2) at the truth."""

    mi: np.ndarray
    cj: np.ndarray
    s_inv: np.ndarray
    gain: np.ndarray


def _pair_blocks(
    case: KeyframeCase, slots: np.ndarray, sig_b: np.ndarray, sig_r: np.ndarray, *, with_gain: bool = True
) -> tuple[np.ndarray, np.ndarray]:
    """S (n, 2, 2) and the pose rows of the gain K (n, 3, 2) for candidate ``slots`` (n,) measured
    with noise std ``sig_b``, ``sig_r`` (n,), at the truth."""
    cov = case.covariance
    n = len(slots)
    jac = bearing_range_jacobians(np.broadcast_to(case.pose, (n, 3)), case.points[slots])  # (n, 2, 5)
    idx = np.concatenate([np.broadcast_to(np.arange(3), (n, 3)), 3 + 2 * slots[:, None] + np.arange(2)], axis=1)
    p = cov[idx[:, :, None], idx[:, None, :]]  # (n, 5, 5)
    hp = jac @ p  # (n, 2, 5)
    s = hp @ np.transpose(jac, (0, 2, 1))
    s[:, 0, 0] += sig_b**2
    s[:, 1, 1] += sig_r**2
    if not with_gain:
        return s, np.zeros((n, 3, 2))
    gain = np.transpose(hp[:, :, :3], (0, 2, 1)) @ np.linalg.inv(s)  # (n, 3, 2): P_pose,· Hᵀ S⁻¹
    return s, gain


def _pairs(case: KeyframeCase, gate: float) -> _Pairs:
    """The pairs worth evaluating: each measurement's right landmark, and every candidate within the
    stated reach whose λ at the truth is below (√γ + PRUNE_SIGMAS)²."""
    m, c = len(case.landmark), len(case.candidates)
    if m == 0 or c == 0:
        z = np.zeros(0, np.int64)
        return _Pairs(z, z, np.zeros((0, 2, 2)), np.zeros((0, 3, 2)))
    mi = np.repeat(np.arange(m), c)
    cj = np.tile(np.arange(c), m)
    # + slack: the reach is judged at x̂ and r̂; r̂ lies within RANGE_SIGMAS σ_r of r but with
    # probability < 1e-15 (a stereo camera's σ_r is metres at 20 m: its reach at r̂ passes 1.25 r + 15 m)
    reach = CANDIDATE_SCALE * (case.range_m[mi] + RANGE_SIGMAS * case.sigma_range_m[mi]) + CANDIDATE_MARGIN_M + 10.0
    far = np.hypot(*(case.points[cj] - case.pose[:2]).T) > reach
    right = case.right[mi] == cj
    keep = right | ~far
    mi, cj = mi[keep], cj[keep]
    s, gain = _pair_blocks(case, cj, case.sigma_bearing_rad[mi], case.sigma_range_m[mi])
    z_true = np.column_stack([case.bearing_rad[mi], case.range_m[mi]])
    d = z_true - measure(case.pose, case.points[cj])
    d[:, 0] = wrap_angle(d[:, 0])
    s_inv = np.linalg.inv(s)
    lam = np.einsum("ni,nij,nj->n", d, s_inv, d)
    keep = (case.right[mi] == cj) | (lam <= (math.sqrt(gate) + PRUNE_SIGMAS) ** 2)
    return _Pairs(mi[keep], cj[keep], s_inv[keep], gain[keep])


def _associate(
    case: KeyframeCase,
    pairs: _Pairs,
    meas: np.ndarray,
    pose_err: np.ndarray,
    lm_err: np.ndarray,
    noise: np.ndarray,
    gate: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Run gated nearest neighbour on B draws for the measurements ``meas`` (m',) of ``pairs`` (all
    pairs of those measurements, grouped by measurement).

    Args:
        pose_err: (B, 3) pose errors; lm_err: (B, C, 2) candidate errors [m]; noise: (B, m', 2).
    Returns:
        wrong (B, m') bool, and the shift (B, m', 3) a wrong association causes (0 where right).
    """
    b = len(pose_err)
    x_hat = retract(case.pose, pose_err)  # (B, 3)
    z = np.column_stack([case.bearing_rad[meas], case.range_m[meas]])[None] + noise  # (B, m', 2)
    local = np.searchsorted(meas, pairs.mi)  # pair -> column of meas
    l_hat = case.points[pairs.cj][None] + lm_err[:, pairs.cj]  # (B, P, 2)
    nu = z[:, local] - measure(x_hat[:, None, :], l_hat)
    nu[..., 0] = wrap_angle(nu[..., 0])
    nis = np.einsum("bpi,pij,bpj->bp", nu, pairs.s_inv, nu)
    dist = np.hypot(l_hat[..., 0] - x_hat[:, None, 0], l_hat[..., 1] - x_hat[:, None, 1])
    ok = (nis <= gate) & (dist <= CANDIDATE_SCALE * z[:, local, 1] + CANDIDATE_MARGIN_M)
    score = np.where(ok, nis, np.inf)
    # per measurement: the smallest gated NIS (pairs are grouped by measurement: reduceat)
    starts = np.searchsorted(local, np.arange(len(meas)))
    has = np.diff(np.append(starts, len(local))) > 0
    mp = len(meas)
    wrong = np.zeros((b, mp), bool)
    shift = np.zeros((b, mp, 3))
    if not has.any():
        return wrong, shift
    best = np.full((b, mp), np.inf)
    best[:, has] = np.minimum.reduceat(score, starts[has], axis=1)
    gated_best = (score == best[:, local]) & np.isfinite(score)
    # the chosen pair of each measurement (the first of equal NIS: ties have probability 0)
    big = len(local)
    first = np.where(gated_best, np.arange(big)[None, :], big)
    chosen = np.full((b, mp), big)
    chosen[:, has] = np.minimum.reduceat(first, starts[has], axis=1)
    chosen = np.where(chosen == big, -1, chosen)
    right_pair = np.full(mp, -1)
    is_right = case.right[pairs.mi] == pairs.cj
    right_pair[local[is_right]] = np.nonzero(is_right)[0]
    wrong = (chosen >= 0) & (chosen != right_pair[None, :])
    if wrong.any():
        bi, mj = np.nonzero(wrong)
        pc = chosen[bi, mj]
        delta = np.einsum("nij,nj->ni", pairs.gain[pc], nu[bi, pc])
        pr = right_pair[mj]
        has_r = pr >= 0
        delta[has_r] -= np.einsum("nij,nj->ni", pairs.gain[pr[has_r]], nu[bi[has_r], pr[has_r]])
        shift[bi, mj] = delta
    return wrong, shift


def _clutter(
    case: KeyframeCase, task: Task, rng: np.random.Generator, x_hat: np.ndarray, lm_err: np.ndarray, s_base: np.ndarray
) -> np.ndarray:
    """(B,) whether a clutter detection was matched to a landmark in each draw. Clutter: a Poisson
    number of objects, ``task.clutter_per_m2`` × 2W per metre of the route within reach of the car
    (``case.route_xy``, points 1 m apart), each at a route point drawn uniformly, offset uniformly
    within ±W in x and y (W = ``task.corridor_m``); each suite sensor detects those in its cone."""
    b = len(x_hat)
    out = np.zeros(b, bool)
    if task.clutter_per_m2 <= 0 or not case.cones or case.route_xy is None or len(case.route_xy) == 0:
        return out
    w = task.corridor_m
    counts = rng.poisson(task.clutter_per_m2 * 2.0 * w * len(case.route_xy), size=b)
    total = int(counts.sum())
    xy = case.route_xy[rng.integers(0, len(case.route_xy), size=total)] + rng.uniform(-w, w, size=(total, 2))
    draw = np.repeat(np.arange(b), counts)
    if len(xy) == 0 or len(case.candidates) == 0:
        return out
    z_true = measure(case.pose, xy)  # (n, 2)
    for cone in case.cones:
        off = np.abs(wrap_angle(z_true[:, 0] - cone.mount_rad))
        seen = (z_true[:, 1] <= cone.range_m) & (z_true[:, 1] >= 1.0) & (off <= 0.5 * cone.fov_rad + 1e-12)
        if not seen.any():
            continue
        zt, dr = z_true[seen], draw[seen]
        sr = cone.sigma_range_const_m + cone.sigma_range_quad_per_m * zt[:, 1] ** 2
        z = zt + rng.standard_normal(zt.shape) * np.column_stack([np.full(len(zt), cone.sigma_bearing_rad), sr])
        l_hat = case.points[None] + lm_err[dr]  # (n, C, 2)
        nu = z[:, None, :] - measure(x_hat[dr][:, None, :], l_hat)
        nu[..., 0] = wrap_angle(nu[..., 0])
        s = np.broadcast_to(s_base, (len(zt),) + s_base.shape).copy()
        s[..., 0, 0] += cone.sigma_bearing_rad**2
        s[..., 1, 1] += (sr**2)[:, None]
        nis = np.einsum("nci,nci->nc", nu, np.linalg.solve(s, nu[..., None])[..., 0])
        dist = np.hypot(l_hat[..., 0] - x_hat[dr][:, None, 0], l_hat[..., 1] - x_hat[dr][:, None, 1])
        hit = ((nis <= task.gate) & (dist <= CANDIDATE_SCALE * z[:, 1:2] + CANDIDATE_MARGIN_M)).any(axis=1)
        out[dr[hit]] = True
    return out


def associate_keyframe(case: KeyframeCase, task: Task) -> KeyframeOutcome:
    """Run the associator on ``task.draws`` draws at one keyframe (module docstring); deterministic
    in (seed, keyframe)."""
    rng = np.random.default_rng(np.random.SeedSequence([task.seed, 3, task.keyframe]))
    pairs = _pairs(case, task.gate)
    m = len(case.landmark)
    n_cand = len(case.candidates)
    # sample only the candidates some pair (or, with clutter, any detection) can match
    used = np.arange(n_cand) if task.clutter_per_m2 > 0 else np.unique(pairs.cj)
    idx = np.concatenate([np.arange(3), (3 + 2 * used[:, None] + np.arange(2)).ravel()]).astype(np.int64)
    sub_cov = case.covariance[np.ix_(idx, idx)]
    dim = len(idx)
    chol = np.linalg.cholesky(sub_cov + 1e-15 * max(1.0, float(np.trace(sub_cov))) * np.eye(dim))
    sig = np.column_stack([case.sigma_bearing_rad, case.sigma_range_m])  # (m, 2)
    alert = np.asarray(task.alert_m_rad)
    positions = sorted({int(s) for s in case.sensor.tolist()} | {c.position for c in case.cones})
    per_sensor = {p: 0.0 for p in positions}
    w_sum = w2_sum = beyond = 0.0
    shift_sum = np.zeros(3)
    shift_w = 0.0
    wrong_draws = clutter_draws = 0
    if not task.importance:
        s_base = None
        if task.clutter_per_m2 > 0 and len(case.candidates):
            # H P Hᵀ of every candidate at the truth (clutter detections add their own R)
            cs = np.arange(len(case.candidates))
            s_base = _pair_blocks(case, cs, np.zeros(len(cs)), np.zeros(len(cs)), with_gain=False)[0]
        meas = np.arange(m)
        for lo in range(0, task.draws, BLOCK):
            b = min(BLOCK, task.draws - lo)
            u = rng.standard_normal((b, dim)) @ chol.T
            noise = rng.standard_normal((b, m, 2)) * sig[None]
            lm_err = np.zeros((b, n_cand, 2))
            lm_err[:, used] = u[:, 3:].reshape(b, -1, 2)
            if len(pairs.mi):
                wrong, shift = _associate(case, pairs, meas, u[:, :3], lm_err, noise, task.gate)
            else:
                wrong, shift = np.zeros((b, m), bool), np.zeros((b, m, 3))
            anyw: np.ndarray = np.asarray(wrong.any(axis=1), bool)
            wrong_draws += int(anyw.sum())
            for p in positions:
                per_sensor[p] += float(wrong[:, case.sensor == p].sum())
            big = np.abs(shift).max(
                axis=1, initial=0.0
            )  # (B, 3) the largest shift of each component in the draw (0: no measurement)
            shift_sum += big[anyw].sum(axis=0)
            shift_w += float(anyw.sum())
            beyond += float(((big > alert[None, [1, 0, 2]]) & anyw[:, None]).any(axis=1).sum())
            if s_base is not None:
                clutter_draws += int(_clutter(case, task, rng, retract(case.pose, u[:, :3]), lm_err, s_base).sum())
        n = task.draws
        p_hat = wrong_draws / n
        se = math.sqrt(max(p_hat * (1 - p_hat), 0.0) / n)
        return _outcome(
            task,
            n,
            wrong_draws,
            p_hat,
            se,
            clutter_draws / n,
            clutter_draws,
            {p: v / n for p, v in per_sensor.items()},
            shift_sum,
            shift_w,
            beyond / n,
        )
    # importance sampling: each measurement on its own, from a defensive mixture of mean shifts
    log_q = 0.0  # Σ log(1 − P̂_i): the keyframe's figure 1 − Π (1 − P̂_i)
    var_total = 0.0
    for i in range(m):
        sel = np.flatnonzero(pairs.mi == i)
        if sel.size == 0:
            continue
        sub = _Pairs(np.zeros(sel.size, np.int64), pairs.cj[sel], pairs.s_inv[sel], pairs.gain[sel])
        slots = np.unique(sub.cj)
        idx = np.concatenate([np.arange(3), (3 + 2 * slots[:, None] + np.arange(2)).ravel()])
        n_y = len(idx) + 2  # (pose, the candidates' landmarks, the measurement's noise)
        cov_y = np.zeros((n_y, n_y))
        cov_y[:-2, :-2] = case.covariance[np.ix_(idx, idx)]
        cov_y[-2:, -2:] = np.diag(sig[i] ** 2)
        chol_y = np.linalg.cholesky(cov_y + 1e-15 * max(1.0, float(np.trace(cov_y))) * np.eye(n_y))
        shifts = _mean_shifts(case, i, sub, slots, chol_y, task.gate)  # (J, n_y) in whitened coordinates
        one = _case_row(case, i)
        n_mix = len(shifts)
        w_sum = w2_sum = 0.0
        for lo in range(0, task.draws, BLOCK):
            b = min(BLOCK, task.draws - lo)
            g = rng.standard_normal((b, n_y))
            if n_mix:
                # a share DEFENSIVE unshifted, the rest shifted by one m_j each, j uniform
                comp = rng.integers(0, n_mix, size=b)
                shifted = rng.random(b) >= DEFENSIVE
                w_white = g + np.where(shifted[:, None], shifts[comp], 0.0)
                # the likelihood ratio φ(w) / [α φ(w) + (1 − α)/J Σ_j φ(w − m_j)]
                expo = w_white @ shifts.T - 0.5 * np.einsum("ji,ji->j", shifts, shifts)[None, :]
                top = np.max(expo, axis=1, initial=0.0)
                mix = DEFENSIVE * np.exp(-top) + (1.0 - DEFENSIVE) / n_mix * np.exp(expo - top[:, None]).sum(axis=1)
                w = np.exp(-top) / mix
            else:
                w_white, w = g, np.ones(b)
            y = w_white @ chol_y.T
            lm_err = np.zeros((b, n_cand, 2))
            lm_err[:, slots] = y[:, 3:-2].reshape(b, -1, 2)
            wrong, shift = _associate(one, sub, np.zeros(1, np.int64), y[:, :3], lm_err, y[:, None, -2:], task.gate)
            ww = w * wrong[:, 0]
            w_sum += float(ww.sum())
            w2_sum += float((ww * ww).sum())
            big = np.abs(shift[:, 0])
            shift_sum += (ww[:, None] * big).sum(axis=0)
            shift_w += float(ww.sum())
            beyond += float((ww * (big > alert[None, [1, 0, 2]]).any(axis=1)).sum())
        n = task.draws
        p_i = min(w_sum / n, 1.0)
        log_q += math.log1p(-min(p_i, 1.0 - 1e-16))
        var_total += max(w2_sum / n - p_i * p_i, 0.0) / n
        per_sensor[int(case.sensor[i])] += p_i
    return _outcome(
        task,
        task.draws,
        -1,
        -math.expm1(log_q),
        math.sqrt(var_total),
        math.nan,
        -1,
        per_sensor,
        shift_sum,
        shift_w,
        beyond / task.draws,
    )


def _mean_shifts(
    case: KeyframeCase, i: int, sub: _Pairs, slots: np.ndarray, chol_y: np.ndarray, gate: float
) -> np.ndarray:
    """(J, n_y) the mixture's mean shifts, whitened, one per wrong candidate j of measurement i: the
    most likely y (pose, candidates, noise) that brings ν_j to the decision boundary, in the
    linearized model ν_j = d_ij + A_j y, A_j y = v − J_j (e_pose, e_j): μ_j = −t Σ A_jᵀ S_j⁻¹ d_ij with
    t = max(½, 1 − √(γ/λ_j)) (half way to j, or onto j's gate when it is far), whitened by L⁻¹ (so
    L⁻¹ Σ = Lᵀ: m_j = −t Lᵀ A_jᵀ S_j⁻¹ d_ij)."""
    wrong = sub.cj != case.right[i]
    cj = sub.cj[wrong]
    if cj.size == 0:
        return np.zeros((0, len(chol_y)))
    n_y = len(chol_y)
    jac = bearing_range_jacobians(np.broadcast_to(case.pose, (len(cj), 3)), case.points[cj])  # (J, 2, 5)
    a = np.zeros((len(cj), 2, n_y))
    a[:, :, :3] = -jac[:, :, :3]
    col = 3 + 2 * np.searchsorted(slots, cj)
    for q in range(2):
        a[np.arange(len(cj)), :, col + q] = -jac[:, :, 3 + q]
    a[:, 0, -2] = 1.0
    a[:, 1, -1] = 1.0
    d = np.column_stack([np.full(len(cj), case.bearing_rad[i]), np.full(len(cj), case.range_m[i])]) - measure(
        case.pose, case.points[cj]
    )
    d[:, 0] = wrap_angle(d[:, 0])
    s_inv = sub.s_inv[wrong]
    sd = np.einsum("jab,jb->ja", s_inv, d)
    lam = np.einsum("ja,ja->j", d, sd)
    t = np.maximum(0.5, 1.0 - np.sqrt(gate / np.maximum(lam, 1e-300)))
    # m_j = −t Lᵀ A_jᵀ S_j⁻¹ d
    return -t[:, None] * np.einsum("ba,jcb,jc->ja", chol_y, a, sd)


def _case_row(case: KeyframeCase, i: int) -> KeyframeCase:
    """The case restricted to measurement ``i`` (its pairs then refer to measurement 0)."""
    sl = slice(i, i + 1)
    return KeyframeCase(
        case.keyframe,
        case.pose,
        case.sensor[sl],
        case.landmark[sl],
        case.bearing_rad[sl],
        case.range_m[sl],
        case.sigma_bearing_rad[sl],
        case.sigma_range_m[sl],
        case.candidates,
        case.points,
        case.right[sl],
        case.covariance,
    )


def _outcome(
    task: Task,
    n: int,
    wrong_draws: int,
    p: float,
    se: float,
    p_clutter: float,
    clutter_draws: int,
    per_sensor: dict[int, float],
    shift_sum: np.ndarray,
    shift_w: float,
    p_beyond: float,
) -> KeyframeOutcome:
    mean = shift_sum / shift_w if shift_w > 0 else np.full(3, math.nan)
    return KeyframeOutcome(
        keyframe=task.keyframe,
        draws=n,
        wrong_draws=wrong_draws,
        p_wrong=float(p),
        standard_error=float(se),
        p_wrong_clutter=float(p_clutter),
        clutter_draws=clutter_draws,
        wrong_per_sensor=tuple((int(k), float(v)) for k, v in sorted(per_sensor.items())),
        shift_lateral_m=float(mean[1]),
        shift_longitudinal_m=float(mean[0]),
        shift_heading_deg=float(math.degrees(mean[2])),
        p_beyond_alert=float(p_beyond),
    )
