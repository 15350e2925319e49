"""The risk that a measurement is associated with the wrong landmark, under gated nearest neighbour.

The associator (what cars run, stated here once and used everywhere):

- per measurement z (bearing [rad], range [m]) of one sensor at keyframe k, the candidates are the
  landmarks of the map (model ``map``) or of the filter's state (model ``slam``: the landmarks seen by
  used measurements of earlier keyframes) within ``1.25 r + 5 m`` of the car, r the measured range
  (a landmark farther out predicts a range more than 0.25 r + 5 m off: outside any gate but for
  metres of range noise; landmarks in the cone and near it, on every side, are all candidates);
  pairs whose λ exceeds (√γ + 8)² are dropped (their terms are below 1e-14);
- each candidate j has the innovation ν_j = z − h(x̂_k, l̂_j) and the normalised innovation squared
  NIS_j = ν_jᵀ S_j⁻¹ ν_j, S_j = R + H_j P_j H_jᵀ (R the measurement's noise, H_j the Jacobian of the
  range-bearing model at the prediction, P_j the predicted joint covariance of pose k and landmark j:
  the :class:`~sensorsel.information.filtering.Prediction` before keyframe k's measurements);
- the gate is γ = χ²₂ quantile at the gate probability p_G (γ = −2 ln(1 − p_G));
- z is associated with the candidate of smallest NIS among those with NIS ≤ γ; with none inside the
  gate it is not associated (a new landmark in SLAM, dropped in a map). Each measurement is
  associated on its own (no exclusivity between the measurements of a keyframe).
- first sightings (SLAM): a measurement of a landmark not in the state is right when it gates with
  none; it is wrong when any state landmark falls inside the gate.

A measurement of landmark i is **wrongly associated** (event W) when some j ≠ i has NIS_j ≤ γ and
NIS_j < NIS_i. A correct measurement outside the gate with no other inside is not W (it is lost,
not wrong). All probabilities are over the measurement noise and the estimate's error, Gaussian
with the predicted covariance, in the model linearized at the truth (as every figure of the package).

Given the truth, ν_j ~ N(d_ij, S_j), d_ij = h(x, l_i) − h(x, l_j) (the measurement noise is the
measurement's own, so the covariance of ν_j is exactly S_j), hence NIS_j ~ χ'²₂(λ_j), λ_j = d_ijᵀ S_j⁻¹ d_ij.

**The bound** (after Duenas Arana, Joerger & Spenko's local nearest-neighbour bound, ICRA 2018): for
any threshold t ≤ γ, if NIS_i ≤ t and every NIS_j > t then i is the nearest and inside the gate, so
W ⊆ {NIS_i > t} ∪ ⋃_j {NIS_j ≤ t}; also W ⊆ ⋃_j {NIS_j ≤ γ}. With NIS_i ~ χ²₂ (P(NIS_i > t) = e^(−t/2)):

    P(W) ≤ min(1, Σ_j F(γ; λ_j), min_t [e^(−t/2) + Σ_j F(t; λ_j)])

F(·; λ) the CDF of χ'²₂(λ), the minimum over a fixed grid of t in (0, γ] (any t is valid). For a
first sighting only Σ_j F(γ; λ_j). Each term is non-increasing in λ_j, and λ_j is non-increasing when
P or R grows (Loewner order): the bound never falls with more noise, more landmarks, a looser prior
or a looser map.

The bound is one of the model linearized at the truth. Where a landmark's predicted spread is a
sizeable share of its range (SLAM's freshly initialized stereo landmarks: metres at 9 m) the car's
nonlinear innovation can gate a candidate whose linearized λ puts it out of reach, and the bound is
then below the associator's true probability (``tests/test_association_linearization.py``, an
expected failure until the bound covers the Taylor remainder).

**The estimate** (calibrated, not a bound): the pairwise events, combined as independent,
P(W) ≈ 1 − Π_j (1 − p_j), p_j = min(P(NIS_j < NIS_i), F(γ; λ_j)). For P(NIS_j < NIS_i) both NIS use
S̄ = (S_i + S_j)/2; then with D = ν_j − ν_i (the measurement noise cancels in D; the pose error nearly
does for near landmarks), NIS_j < NIS_i ⇔ Dᵀ S̄⁻¹ ν_i < −½ Dᵀ S̄⁻¹ D, and ν_i | D is Gaussian
(mean K (D − d), covariance V, from the joint covariance of (ν_i, D)), so

    P(NIS_j < NIS_i | D) = Φ((−½ Dᵀ S̄⁻¹ D − Dᵀ S̄⁻¹ K (D − d)) / √(Dᵀ S̄⁻¹ V S̄⁻¹ D)),

averaged over D ~ N(d, C_D) by a fixed 10 × 10 Gauss–Hermite rule. Two landmarks at one point give
½, two far apart Φ(−½ ‖d‖_S̄) (the classic two-hypothesis error). First sightings: p_j = F(γ; λ_j).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree
from scipy.special import ndtr
from scipy.stats import ncx2

from sensorsel.information.filtering import KeyframeMeasurements, Prediction
from sensorsel.information.linearize import bearing_range_jacobians
from sensorsel.model.problem import Problem

__all__ = ["ASSOCIATION_MODELS", "AssociationModel", "MeasurementRisk", "gate_of", "keyframe_risk", "measurement_risks"]

#: the models: a prior map (every landmark a candidate) or SLAM (the landmarks in the filter's state)
ASSOCIATION_MODELS = ("map", "slam")

#: how far a candidate may lie from the car: CANDIDATE_SCALE × the largest range measured + CANDIDATE_MARGIN_M
CANDIDATE_SCALE = 1.25
CANDIDATE_MARGIN_M = 5.0
#: pairs whose λ exceeds (√γ + FAR_SIGMAS)² are dropped (their F(γ; λ) < 1e-14)
FAR_SIGMAS = 8.0

_GH_X, _GH_W = np.polynomial.hermite_e.hermegauss(10)
_GH_W = _GH_W / _GH_W.sum()
_T_FRACTIONS = np.linspace(0.05, 1.0, 20)  # the bound's thresholds t, as fractions of γ


def gate_of(gate_probability: float) -> float:
    """γ: the χ² quantile with 2 degrees of freedom at ``gate_probability`` (= −2 ln(1 − p))."""
    return -2.0 * math.log1p(-float(gate_probability))


@dataclass(frozen=True, eq=False)
class MeasurementRisk:
    """Per measurement of one keyframe (aligned with its :class:`KeyframeMeasurements`):

    Attributes:
        estimate: (m,) calibrated estimate of P(wrong association).
        bound: (m,) upper bound on P(wrong association).
        n_candidates: (m,) competing landmarks considered (the truly measured one not counted).
    """

    estimate: np.ndarray
    bound: np.ndarray
    n_candidates: np.ndarray


def keyframe_risk(estimate: np.ndarray, bound: np.ndarray) -> tuple[float, float]:
    """P(at least one wrong association) at a keyframe from its measurements' risks: the estimate
    1 − Π (1 − p) (independent measurements), the bound min(1, Σ p) (union bound, no assumption)."""
    est = max(0.0, float(-np.expm1(np.sum(np.log1p(-np.clip(estimate, 0.0, 1.0)))))) if len(estimate) else 0.0
    return est, float(min(1.0, np.sum(bound))) if len(bound) else 0.0


class AssociationModel:
    """The association risks of a problem's measurements (one per route), for either model.

    Args:
        problem: the route, its landmarks and library.
        model: ``"map"`` (every landmark of the map a candidate) or ``"slam"`` (the state's only).
        gate_probability: p_G in (0, 1).
    """

    def __init__(self, problem: Problem, *, model: str = "map", gate_probability: float = 0.9999) -> None:
        if model not in ASSOCIATION_MODELS:
            raise ValueError(f"association model must be one of {ASSOCIATION_MODELS}, got {model!r}")
        if not 0.0 < gate_probability < 1.0:
            raise ValueError(f"gate probability must be in (0, 1), got {gate_probability!r}")
        self.problem = problem
        self.model = model
        self.gate = gate_of(gate_probability)
        self._poses = np.asarray(problem.scenario.keyframes.poses, float)
        self._points = np.asarray(problem.scenario.landmarks, float)
        self._tree = cKDTree(self._points) if len(self._points) else None

    def candidates(self, prediction: Prediction, meas: KeyframeMeasurements) -> np.ndarray:
        """Sorted landmark indices the associator considers at this keyframe (module docstring)."""
        if self._tree is None or len(meas.landmark) == 0:
            return np.zeros(0, np.int64)
        pose = self._poses[meas.keyframe]
        reach = float(np.max(candidate_reach(prediction, meas, self.gate, model=self.model)))
        near = np.asarray(sorted(self._tree.query_ball_point(pose[:2], reach)), np.int64)
        if self.model == "slam":
            near = near[np.isin(near, np.asarray(prediction.landmarks, np.int64))]
        return near

    def risks(self, prediction: Prediction, meas: KeyframeMeasurements) -> MeasurementRisk:
        """The estimate and bound of P(wrong association) of each of ``meas`` at ``prediction``."""
        return measurement_risks(self._poses[meas.keyframe], self._points, prediction, meas,
                                 self.candidates(prediction, meas), gate=self.gate, model=self.model)


def _spreads(prediction: Prediction, *, with_prior: bool = True) -> tuple[float, float, float]:
    """(sd_xy, sd_th, sd_lm): the predicted pose's position [m] and heading [rad] spreads and the
    largest landmark spread [m] (the prior's where that is larger, ``with_prior``: a candidate out of
    the state has it): what bounds every pair's S_j."""
    cov = np.asarray(prediction.covariance, float)
    lm_tr = np.diagonal(cov)[3:].reshape(-1, 2).sum(axis=1) if cov.shape[0] > 3 else np.zeros(0)
    prior = 2.0 * float(prediction.prior_sigma_m) ** 2 if with_prior else 0.0
    sd_lm = math.sqrt(max(float(lm_tr.max(initial=0.0)), prior))
    return math.sqrt(cov[0, 0] + cov[1, 1]), math.sqrt(cov[2, 2]), sd_lm


def candidate_reach(prediction: Prediction, meas: KeyframeMeasurements, gate: float, *, model: str = "map") -> np.ndarray:
    """(m,) how far from the car [m] a candidate of each measurement may lie: CANDIDATE_SCALE r +
    CANDIDATE_MARGIN_M (the associator's stated reach at the true range r), widened to
    r + (√γ + FAR_SIGMAS) √(s_bb + s_rr) where the measurement's range noise is large.

    The associator judges its reach at the *measured* range r̂, which a stereo camera's range
    noise (metres at 20 m) carries well past r: a landmark beyond 1.25 r + 5 m can then be inside the
    gate and nearer. The widened reach is rigorous: a landmark at r_j ≥ r + (√γ + F) √(s_bb + s_rr)
    (s_bb taken at r_j = r, its largest over r_j ≥ r) has λ ≥ (r_j − r)² / (s_bb + s_rr) ≥ (√γ + F)², the
    pairs the far-pair filter drops anyway: the reach loses nothing that filter keeps. In SLAM
    (``model="slam"``) the candidates are the state's landmarks, whose spreads the state holds: the
    weak prior of the landmarks out of it (100 m) would make every landmark of the route a candidate."""
    sd_xy, sd_th, sd_lm = _spreads(prediction, with_prior=model != "slam")
    r = np.asarray(meas.range_m, float)
    s_bb = r ** 2 * np.asarray(meas.sigma_bearing_rad, float) ** 2 + (sd_xy + sd_lm + r * sd_th) ** 2
    s_rr = np.asarray(meas.sigma_range_m, float) ** 2 + (sd_xy + sd_lm) ** 2
    wide = r + (math.sqrt(gate) + FAR_SIGMAS) * np.sqrt(s_bb + s_rr)
    return np.maximum(CANDIDATE_SCALE * r + CANDIDATE_MARGIN_M, wide)


def measurement_risks(pose: np.ndarray, points: np.ndarray, prediction: Prediction, meas: KeyframeMeasurements,
                      candidates: np.ndarray, *, gate: float, model: str) -> MeasurementRisk:
    """The estimate and bound of P(wrong association) of each measurement of ``meas``, made from
    ``pose`` (x [m], y [m], heading [rad]: the truth) of landmarks ``points`` (M, 2) [m], against
    ``candidates`` (landmark indices; the truly measured one is skipped), the gate γ and the model
    (``"map"``: the truly measured landmark is always a candidate; ``"slam"``: only when it is in
    the prediction's state, else the measurement is a first sighting)."""
    m = len(meas.landmark)
    est, bnd, ncand = np.zeros(m), np.zeros(m), np.zeros(m, np.int64)
    near = np.asarray(candidates, np.int64)
    if m == 0 or near.size == 0:
        return MeasurementRisk(est, bnd, ncand)
    state = np.asarray(prediction.landmarks, np.int64)
    has_right = np.ones(m, bool) if model == "map" else np.isin(meas.landmark, state)
    # all (measurement, candidate) pairs but the truly measured landmark
    mi = np.repeat(np.arange(m), near.size)
    cj = np.tile(near, m)
    # a candidate is another landmark within the measurement's reach (candidate_reach: its own range,
    # noise and the covariance), so a measurement's risk depends on its own geometry and the
    # covariance only, never on which other measurements the suite makes
    reach = candidate_reach(prediction, meas, gate, model=model)[mi]
    if model == "slam":  # candidates out of the state (a caller's choice) keep the stated reach
        reach = np.where(np.isin(cj, state), reach, CANDIDATE_SCALE * meas.range_m[mi] + CANDIDATE_MARGIN_M)
    keep = (cj != meas.landmark[mi]) & (np.hypot(*(points[cj] - pose[:2]).T) <= reach)
    mi, cj = mi[keep], cj[keep]
    # a pair whose λ is surely past the far limit is dropped before its moments (it would be after):
    # λ is invariant under d → T d, S → T S Tᵀ; with T = diag(r_i, 1) (bearing in metres),
    # λ ≥ |T d|² / tr(T S_j T), and each row h of H_j has hᵀ E h ≤ (Σ_blocks ‖h_b‖ √λmax(E_bb))²
    # (Cauchy–Schwarz, E ⪰ 0), the blocks being the position (‖h‖ ≤ 1/r_j bearing, 1 range), the
    # heading (1, 0) and the landmark (1/r_j, 1); λmax(E_bb) ≤ its trace: the same pairs, fewer computed
    d = _innovation_means(pose, points, meas, mi, cj)
    sd_xy, sd_th, sd_lm = _spreads(prediction)
    r_i = meas.range_m[mi]
    r_j = np.maximum(np.hypot(*(points[cj] - pose[:2]).T), 1e-9)
    s_bb = r_i ** 2 * (meas.sigma_bearing_rad[mi] ** 2 + ((sd_xy + sd_lm) / r_j + sd_th) ** 2)
    s_rr = meas.sigma_range_m[mi] ** 2 + (sd_xy + sd_lm) ** 2
    keep = ((r_i * d[:, 0]) ** 2 + d[:, 1] ** 2) / (s_bb + s_rr) <= (math.sqrt(gate) + FAR_SIGMAS) ** 2
    mi, cj = mi[keep], cj[keep]
    li = meas.landmark[mi]
    pair = _pair_moments(pose, points, prediction, meas, mi, li, cj, _slots(state, li), _slots(state, cj))
    close = pair.lam <= (math.sqrt(gate) + FAR_SIGMAS) ** 2
    mi, pair = mi[close], pair.select(close)
    ncand = np.bincount(mi, minlength=m).astype(np.int64)
    if len(mi) == 0:
        return MeasurementRisk(est, bnd, ncand)
    lam = pair.lam
    f_gate = ncx2.cdf(gate, 2, lam)
    # the bound: Σ F(γ) always; with the right landmark a candidate, also min_t e^(−t/2) + Σ F(t)
    bnd = np.minimum(1.0, np.bincount(mi, weights=f_gate, minlength=m))
    ts = gate * _T_FRACTIONS
    f_t = ncx2.cdf(ts[None, :], 2, lam[:, None])  # (pairs, T)
    sums = np.zeros((m, len(ts)))
    np.add.at(sums, mi, f_t)
    lnn = np.min(np.exp(-ts / 2.0)[None, :] + sums, axis=1)
    bnd = np.where(has_right, np.minimum(bnd, lnn), bnd)
    # the estimate: pairwise nearest-neighbour probability, capped by the gate's
    right = has_right[mi]
    p = f_gate.copy()
    if right.any():
        p[right] = np.minimum(_p_nearer(pair.select(right)), f_gate[right])
    logq = np.zeros(m)
    np.add.at(logq, mi, np.log1p(-np.clip(p, 0.0, 1.0 - 1e-16)))
    est = np.maximum(-np.expm1(logq), 0.0)
    return MeasurementRisk(est, np.minimum(bnd, 1.0), ncand)


def _slots(state: np.ndarray, landmarks: np.ndarray) -> np.ndarray:
    """Position of each landmark in the sorted state, or −1."""
    if state.size == 0:
        return np.full(len(landmarks), -1, np.int64)
    pos = np.searchsorted(state, landmarks)
    pos = np.minimum(pos, len(state) - 1)
    return np.where(state[pos] == landmarks, pos, -1).astype(np.int64)


@dataclass(frozen=True, eq=False)
class _Pairs:
    """Per (measurement, candidate) pair: d (n, 2), S_i, S_j, C_D (n, 2, 2), Cov(ν_i, D) (n, 2, 2), λ (n,)."""

    d: np.ndarray
    s_i: np.ndarray
    s_j: np.ndarray
    c_d: np.ndarray
    c_id: np.ndarray
    lam: np.ndarray

    def select(self, mask: np.ndarray) -> "_Pairs":
        return _Pairs(self.d[mask], self.s_i[mask], self.s_j[mask], self.c_d[mask], self.c_id[mask], self.lam[mask])


def _landmark_blocks(cov: np.ndarray, a: np.ndarray, b: np.ndarray, prior_var: float) -> np.ndarray:
    """(n, 2, 2) covariance between landmarks at state slots a and b (−1: not in the state)."""
    out = np.zeros((len(a), 2, 2))
    both = (a >= 0) & (b >= 0)
    ia = 3 + 2 * a[both][:, None] + np.arange(2)
    ib = 3 + 2 * b[both][:, None] + np.arange(2)
    out[both] = cov[ia[:, :, None], ib[:, None, :]]
    same_out = (a < 0) & (a == b)
    out[same_out] = prior_var * np.eye(2)
    return out


def _pose_landmark(cov: np.ndarray, a: np.ndarray) -> np.ndarray:
    """(n, 3, 2) covariance between the pose and the landmark at slot a (0 when not in the state)."""
    out = np.zeros((len(a), 3, 2))
    inside = a >= 0
    ia = 3 + 2 * a[inside][:, None] + np.arange(2)
    out[inside] = cov[np.arange(3)[None, :, None], ia[:, None, :]]
    return out


def _pair_moments(pose: np.ndarray, points: np.ndarray, prediction: Prediction, meas: KeyframeMeasurements,
                  mi: np.ndarray, li: np.ndarray, cj: np.ndarray, slot_i: np.ndarray, slot_j: np.ndarray) -> _Pairs:
    cov = np.asarray(prediction.covariance, float)
    prior_var = float(prediction.prior_sigma_m) ** 2
    n = len(mi)
    # the 7 × 7 covariance of (δpose, δl_i, δl_j)
    e = np.zeros((n, 7, 7))
    e[:, :3, :3] = cov[:3, :3]
    pi, pj = _pose_landmark(cov, slot_i), _pose_landmark(cov, slot_j)
    e[:, :3, 3:5], e[:, :3, 5:7] = pi, pj
    e[:, 3:5, :3], e[:, 5:7, :3] = np.transpose(pi, (0, 2, 1)), np.transpose(pj, (0, 2, 1))
    e[:, 3:5, 3:5] = _landmark_blocks(cov, slot_i, slot_i, prior_var)
    e[:, 5:7, 5:7] = _landmark_blocks(cov, slot_j, slot_j, prior_var)
    ij = _landmark_blocks(cov, slot_i, slot_j, prior_var)
    e[:, 3:5, 5:7], e[:, 5:7, 3:5] = ij, np.transpose(ij, (0, 2, 1))
    poses = np.broadcast_to(pose, (n, 3))
    jac_i = bearing_range_jacobians(poses, points[li])  # (n, 2, 5)
    jac_j = bearing_range_jacobians(poses, points[cj])
    b = np.zeros((n, 2, 7))
    b[:, :, :5] = jac_i
    c = np.zeros((n, 2, 7))
    c[:, :, :3], c[:, :, 5:7] = jac_j[:, :, :3], jac_j[:, :, 3:]
    r = np.zeros((n, 2, 2))
    r[:, 0, 0], r[:, 1, 1] = meas.sigma_bearing_rad[mi] ** 2, meas.sigma_range_m[mi] ** 2
    s_i = r + b @ e @ np.transpose(b, (0, 2, 1))
    s_j = r + c @ e @ np.transpose(c, (0, 2, 1))
    a = c - b
    c_d = a @ e @ np.transpose(a, (0, 2, 1))
    c_id = b @ e @ np.transpose(a, (0, 2, 1))
    d = _innovation_means(pose, points, meas, mi, cj)
    lam = np.einsum("ni,ni->n", d, np.linalg.solve(s_j, d[:, :, None])[:, :, 0])
    return _Pairs(d=d, s_i=s_i, s_j=s_j, c_d=c_d, c_id=c_id, lam=lam)


def _innovation_means(pose: np.ndarray, points: np.ndarray, meas: KeyframeMeasurements, mi: np.ndarray,
                      cj: np.ndarray) -> np.ndarray:
    """(n, 2) d: the true measurement of each pair's measurement minus candidate j's (bearing wrapped)."""
    ci, si = math.cos(pose[2]), math.sin(pose[2])
    rel_j = points[cj] - pose[:2]
    bj = np.arctan2(ci * rel_j[:, 1] - si * rel_j[:, 0], ci * rel_j[:, 0] + si * rel_j[:, 1])
    rj = np.hypot(rel_j[:, 0], rel_j[:, 1])
    db = (meas.bearing_rad[mi] - bj + np.pi) % (2.0 * np.pi) - np.pi
    return np.column_stack([db, meas.range_m[mi] - rj])


def _p_nearer(pair: _Pairs, chunk: int = 20000) -> np.ndarray:
    """P(NIS_j < NIS_i) of each pair (both NIS with S̄), by Gauss–Hermite over D (module docstring)."""
    out = np.zeros(len(pair.d))
    for lo in range(0, len(out), chunk):
        p = pair.select(np.arange(lo, min(lo + chunk, len(out))))
        s_bar = 0.5 * (p.s_i + p.s_j)
        s_inv = np.linalg.inv(s_bar)
        scale = np.trace(s_bar, axis1=1, axis2=2)[:, None, None]
        c_d = p.c_d + 1e-12 * scale * np.eye(2)
        k_gain = p.c_id @ np.linalg.inv(c_d)  # (n, 2, 2)
        v = p.s_i - k_gain @ np.transpose(p.c_id, (0, 2, 1))
        v = 0.5 * (v + np.transpose(v, (0, 2, 1))) + 1e-12 * scale * np.eye(2)
        chol = np.linalg.cholesky(c_d)
        xi = np.stack(np.meshgrid(_GH_X, _GH_X, indexing="ij"), -1).reshape(-1, 2)  # (Q, 2)
        w = np.outer(_GH_W, _GH_W).ravel()
        dd = p.d[:, None, :] + np.einsum("nab,qb->nqa", chol, xi)  # (n, Q, 2) samples of D
        sd = np.einsum("nab,nqb->nqa", s_inv, dd)  # S̄⁻¹ D
        quad = np.einsum("nqa,nqa->nq", dd, sd)
        mean = np.einsum("nqa,nab,nqb->nq", sd, k_gain, dd - p.d[:, None, :])
        var = np.einsum("nqa,nab,nqb->nq", sd, v, sd)
        z = (-0.5 * quad - mean) / np.sqrt(np.maximum(var, 1e-300))
        out[lo:lo + chunk] = np.clip(ndtr(z) @ w, 0.0, 1.0)
    return out
