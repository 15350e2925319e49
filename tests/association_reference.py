"""The per-keyframe association risks as sensorsel computed them before they were batched over
keyframes (tests only): the reference the batched computation must equal.

A verbatim copy of ``sensorsel.information.integrity.association`` as it was when each keyframe's
risks were computed alone, during the forward pass (the formulas are that module's docstring). It
shares the filter's types and the range-bearing Jacobians with sensorsel, nothing of the batch:
no snapshot, no joined arrays, every pair's moments read from the keyframe's whole covariance.
The range term of each candidate (``_RangeSeparation``, a formula on a pair's own numbers, tested
on its own in ``test_association_range_bound.py``), the measured landmark's reach term
(``_out_of_reach``, a formula on a measurement's own numbers, tested in ``test_association_reach.py``)
the nonlinear quadrature of bent pairs (``nonlinear.py``, tested against Monte Carlo in
``test_association_linearization.py``) and its stratification where the reach may leave the right
landmark out (``test_association_reach_estimate.py``) are the engine's; the joint covariance the
quadrature reads is the oracle's assembly.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from association_oracle import joint_covariance as oracle_joint
from scipy.spatial import cKDTree
from scipy.special import chndtr, ndtr

from sensorsel.information.filtering import KeyframeMeasurements, Prediction
from sensorsel.information.integrity.association import (  # the range, reach and far terms, as the engine's
    FAR_SIGMAS,
    FAR_TERM,
    TINY_TERM,
    _out_of_reach,
    _RangeSeparation,
    far_residual,
    reach_strata,
)
from sensorsel.information.integrity.nearer import p_nearer_form  # the formula, as the engine's
from sensorsel.information.integrity.nonlinear import BentPairs, bent_pairs, nonlinear_estimate
from sensorsel.information.linearize import bearing_range_jacobians
from sensorsel.model.problem import Problem

__all__ = ["ASSOCIATION_MODELS", "AssociationModel", "MeasurementRisk", "gate_of", "keyframe_risk", "measurement_risks"]

#: the models: a prior map (every landmark a candidate) or SLAM (the landmarks in the filter's state)
ASSOCIATION_MODELS = ("map", "slam")

#: how far a candidate may lie from the car: CANDIDATE_SCALE × the largest range measured + CANDIDATE_MARGIN_M
CANDIDATE_SCALE = 1.25
CANDIDATE_MARGIN_M = 5.0

_T_FRACTIONS = np.linspace(0.05, 1.0, 20)  # the bound's thresholds t, as fractions of γ
#: the region sizes k of the Taylor remainder (module docstring), and their outside masses 4Φ(−k)
_K_GRID = np.array([1.5, 2.0, 2.5, 3.0, 4.0, 5.5, 7.0, 9.0, 12.0])
_K_OUT = 4.0 * ndtr(-_K_GRID)


def _ncx2_cdf(x: np.ndarray, lam: np.ndarray) -> np.ndarray:
    """F(x; λ), the CDF of the non-central χ² with 2 degrees of freedom (inf → 1)."""
    x = np.asarray(x, float)
    finite = np.isfinite(x)
    if finite.all():  # the common case: no region reached the range (the same numbers, fewer passes)
        return chndtr(x, 2.0, lam)
    return np.where(finite, chndtr(np.where(finite, x, 0.0), 2.0, lam), 1.0)


def _remainder(sigma_ab: np.ndarray, rng_m: np.ndarray, s_inv: np.ndarray, ks: np.ndarray = _K_GRID) -> np.ndarray:
    """(n, K) ρ(k) of each pair at each k of ``ks`` (the grid): the largest ‖S^(−1/2) ε‖ of the polar
    coordinates' Taylor remainder ε over the box |a| ≤ kσ_a, |b| ≤ kσ_b (module docstring); inf where
    kσ_a reaches the range. ``sigma_ab`` (n, 2) [m], ``rng_m`` (n,) [m], ``s_inv`` (n, 2, 2) the
    whitening (S⁻¹, or R⁻¹ for the bound robust to the covariance)."""
    a = ks[None, :] * sigma_ab[:, :1]
    b = ks[None, :] * sigma_ab[:, 1:]
    r = rng_m[:, None]
    ok = a < r
    x = np.where(ok, r - a, 1.0)
    rho_b = a * b / (r * x) + (b / x) ** 3 / 3.0
    rho_r = b**2 / (2.0 * x)
    q = (
        rho_b**2 * s_inv[:, 0, 0, None]
        + rho_r**2 * s_inv[:, 1, 1, None]
        + 2.0 * rho_b * rho_r * np.abs(s_inv[:, 0, 1, None])
    )
    return np.where(ok, np.sqrt(q), np.inf)


def gate_of(gate_probability: float) -> float:
    """γ: the χ² quantile with 2 degrees of freedom at ``gate_probability`` (= −2 ln(1 − p))."""
    return -2.0 * math.log1p(-float(gate_probability))


@dataclass(frozen=True, eq=False)
class MeasurementRisk:
    """Per measurement of one keyframe (aligned with its :class:`KeyframeMeasurements`):

    Attributes:
        estimate: (m,) calibrated estimate of P(wrong association).
        bound: (m,) upper bound on P(wrong association) under the associator (the nonlinear
            innovation: the Taylor remainder covered).
        n_candidates: (m,) competing landmarks considered (the truly measured one not counted).
        linear: (m,) the bound of the model linearized at the truth (at most ``bound``; monotone in
            the covariance and the noise).
    """

    estimate: np.ndarray
    bound: np.ndarray
    n_candidates: np.ndarray
    linear: np.ndarray


def keyframe_risk(estimate: np.ndarray, bound: np.ndarray) -> tuple[float, float]:
    """P(at least one wrong association) at a keyframe from its measurements' risks: the estimate
    1 − Π (1 − p) (independent measurements), the bound min(1, Σ p) (union bound, no assumption)."""
    with np.errstate(divide="ignore"):  # an estimate of exactly 1: log1p(-1) = -inf, and the product is 1
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
        return self._candidates(prediction, meas, candidate_reach(prediction, meas, self.gate, model=self.model))

    def _candidates(self, prediction: Prediction, meas: KeyframeMeasurements, reach_m: np.ndarray) -> np.ndarray:
        """:meth:`candidates` with each measurement's reach (m,) [m] (:func:`candidate_reach`) given."""
        if self._tree is None or len(meas.landmark) == 0:
            return np.zeros(0, np.int64)
        pose = self._poses[meas.keyframe]
        reach = float(np.max(reach_m))
        near = np.sort(np.asarray(self._tree.query_ball_point(pose[:2], reach, return_sorted=False), np.int64))
        if self.model == "slam":
            near = near[_slots(np.asarray(prediction.landmarks, np.int64), near) >= 0]
        return near

    def risks(
        self,
        prediction: Prediction,
        meas: KeyframeMeasurements,
        *,
        linear: bool = False,
        robust_to_covariance: bool = False,
        estimate: bool = True,
    ) -> MeasurementRisk:
        """The estimate and bound of P(wrong association) of each of ``meas`` at ``prediction``
        (``linear``, ``robust_to_covariance``, ``estimate``: :func:`measurement_risks`)."""
        reach = candidate_reach(prediction, meas, self.gate, model=self.model)  # once: candidates and pairs
        return measurement_risks(
            self._poses[meas.keyframe],
            self._points,
            prediction,
            meas,
            self._candidates(prediction, meas, reach),
            gate=self.gate,
            model=self.model,
            linear=linear,
            robust_to_covariance=robust_to_covariance,
            estimate=estimate,
            reach_m=reach,
        )


def _spreads(prediction: Prediction, *, with_prior: bool = True) -> tuple[float, float, float]:
    """(sd_xy, sd_th, sd_lm): the predicted pose's position [m] and heading [rad] spreads and the
    largest landmark spread [m] (the prior's where that is larger, ``with_prior``: a candidate out of
    the state has it): what bounds every pair's S_j."""
    cov = np.asarray(prediction.covariance, float)
    lm_tr = np.diagonal(cov)[3:].reshape(-1, 2).sum(axis=1) if cov.shape[0] > 3 else np.zeros(0)
    prior = 2.0 * float(prediction.prior_sigma_m) ** 2 if with_prior else 0.0
    sd_lm = math.sqrt(max(float(lm_tr.max(initial=0.0)), prior))
    return math.sqrt(cov[0, 0] + cov[1, 1]), math.sqrt(cov[2, 2]), sd_lm


def candidate_reach(
    prediction: Prediction, meas: KeyframeMeasurements, gate: float, *, model: str = "map"
) -> np.ndarray:
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
    s_bb = r**2 * np.asarray(meas.sigma_bearing_rad, float) ** 2 + (sd_xy + sd_lm + r * sd_th) ** 2
    s_rr = np.asarray(meas.sigma_range_m, float) ** 2 + (sd_xy + sd_lm) ** 2
    wide = r + (math.sqrt(gate) + FAR_SIGMAS) * np.sqrt(s_bb + s_rr)
    return np.maximum(CANDIDATE_SCALE * r + CANDIDATE_MARGIN_M, wide)


def measurement_risks(
    pose: np.ndarray,
    points: np.ndarray,
    prediction: Prediction,
    meas: KeyframeMeasurements,
    candidates: np.ndarray,
    *,
    gate: float,
    model: str,
    linear: bool = False,
    robust_to_covariance: bool = False,
    estimate: bool = True,
    reach_m: np.ndarray | None = None,
) -> MeasurementRisk:
    """The estimate and bound of P(wrong association) of each measurement of ``meas``, made from
    ``pose`` (x [m], y [m], heading [rad]: the truth) of landmarks ``points`` (M, 2) [m], against
    ``candidates`` (landmark indices; the truly measured one is skipped), the gate γ and the model
    (``"map"``: the truly measured landmark is always a candidate; ``"slam"``: only when it is in
    the prediction's state, else the measurement is a first sighting). ``linear``: also the bound of
    the model linearized at the truth (``MeasurementRisk.linear``; else zeros). ``robust_to_covariance``:
    ``bound`` is the gate-sum bound with the remainder whitened by R (module docstring). ``reach_m``:
    :func:`candidate_reach` of ``meas`` at ``prediction`` where the caller has it (computed else)."""
    m = len(meas.landmark)
    est, ncand, lin = np.zeros(m), np.zeros(m, np.int64), np.zeros(m)
    # with no candidate kept, the bound is every other landmark's far residual (module docstring)
    bnd = np.minimum(1.0, far_residual(ncand, len(points)))
    near = np.asarray(candidates, np.int64)
    if m == 0 or near.size == 0:
        return MeasurementRisk(est, bnd, ncand, lin)
    state = np.asarray(prediction.landmarks, np.int64)
    has_right = np.ones(m, bool) if model == "map" else _slots(state, meas.landmark) >= 0
    # all (measurement, candidate) pairs but the truly measured landmark
    mi = np.repeat(np.arange(m), near.size)
    cj = np.tile(near, m)
    # a candidate is another landmark within the measurement's reach (candidate_reach: its own range,
    # noise and the covariance), so a measurement's risk depends on its own geometry and the
    # covariance only, never on which other measurements the suite makes (distances and state
    # slots are the candidates', computed once each)
    near_dist = np.hypot(*(points[near] - pose[:2]).T)
    near_slot = _slots(state, near)
    reach = (candidate_reach(prediction, meas, gate, model=model) if reach_m is None else reach_m)[mi]
    if model == "slam":  # candidates out of the state (a caller's choice) keep the stated reach
        in_state = np.tile(near_slot >= 0, m)
        reach = np.where(in_state, reach, CANDIDATE_SCALE * meas.range_m[mi] + CANDIDATE_MARGIN_M)
    keep = (cj != meas.landmark[mi]) & (np.tile(near_dist, m) <= reach)
    slot_j = np.tile(near_slot, m)[keep]
    near_at = np.tile(np.arange(near.size), m)[keep]  # each pair's candidate, as a position in ``near``
    mi, cj = mi[keep], cj[keep]
    # a pair whose λ is surely past the far limit is dropped before its moments (it would be after):
    # λ is invariant under d → T d, S → T S Tᵀ; with T = diag(r_i, 1) (bearing in metres),
    # λ ≥ |T d|² / tr(T S_j T), and each row h of H_j has hᵀ E h ≤ (Σ_blocks ‖h_b‖ √λmax(E_bb))²
    # (Cauchy–Schwarz, E ⪰ 0), the blocks being the position (‖h‖ ≤ 1/r_j bearing, 1 range), the
    # heading (1, 0) and the landmark (1/r_j, 1); λmax(E_bb) ≤ its trace. The far limit is widened by
    # the remainder at k = FAR_SIGMAS, taken at its largest (σ_a, σ_b ≤ sd_xy + sd_lj, whitened by R ⪯ S);
    # sd_lj the candidate's own spread (the trace of its block; the prior's out of the state)
    d = _innovation_means(pose, points, meas, mi, near, near_at)
    sd_xy, sd_th, _ = _spreads(prediction, with_prior=False)
    cov = np.asarray(prediction.covariance, float)
    diag = np.diagonal(cov)
    inside = np.maximum(slot_j, 0)
    sd_lj = np.where(
        slot_j >= 0,
        np.sqrt(np.maximum(diag[3 + 2 * inside] + diag[4 + 2 * inside], 0.0)) if len(diag) > 3 else 0.0,
        math.sqrt(2.0) * float(prediction.prior_sigma_m),
    )
    r_i = meas.range_m[mi]
    r_j = np.maximum(near_dist[near_at], 1e-9)
    s_bb = r_i**2 * (meas.sigma_bearing_rad[mi] ** 2 + ((sd_xy + sd_lj) / r_j + sd_th) ** 2)
    s_rr = meas.sigma_range_m[mi] ** 2 + (sd_xy + sd_lj) ** 2
    far_k = np.array([FAR_SIGMAS])  # the box's k of the far filters
    sd_w = (sd_xy + sd_lj)[:, None] * np.ones(2)
    rho_up = _remainder(sd_w, r_j, _noise_inverse(meas, mi), far_k)[:, 0]
    lam_low = ((r_i * d[:, 0]) ** 2 + d[:, 1] ** 2) / (s_bb + s_rr)
    keep = np.sqrt(lam_low) <= math.sqrt(gate) + FAR_SIGMAS + rho_up
    mi, cj, slot_j = mi[keep], cj[keep], slot_j[keep]
    if len(mi) == 0:  # no pair left: no risk (and none of the moments below to compute)
        return MeasurementRisk(est, bnd, ncand, lin)
    # which pairs are near enough, from candidate j's moments alone (its 5 × 5 block: cheap), then
    # the full moments of those only
    s_j, lam, sigma_j, range_j, s_inv, jac_j, e_j = _candidate_moments(
        pose, points, prediction, meas, mi, near, near_slot, near_at[keep], d[keep]
    )
    whiten_j = _noise_inverse(meas, mi) if robust_to_covariance else s_inv
    close = np.sqrt(lam) <= math.sqrt(gate) + FAR_SIGMAS + _remainder(sigma_j, range_j, whiten_j, far_k)[:, 0]
    mi, cj, slot_j = mi[close], cj[close], slot_j[close]
    if len(mi) == 0:
        return MeasurementRisk(est, bnd, ncand, lin)
    rho_j = _remainder(sigma_j[close], range_j[close], whiten_j[close])  # (n, K)
    by_range = _RangeSeparation(
        np.abs(d[keep][close, 1]), s_j[close, 1, 1], meas.sigma_range_m[mi], np.hypot(*sigma_j[close].T)
    )
    li = meas.landmark[mi]
    pair = _pair_moments(
        pose, points, prediction, meas, mi, li, cj, _slots(state, li), slot_j, jac_j[close], e_j[close]
    )
    p_out_bound = _out_of_reach(meas.range_m[mi], pair.range_i, np.hypot(*pair.sigma_i.T), meas.sigma_range_m[mi])
    ncand = np.bincount(mi, minlength=m).astype(np.int64)
    lam = pair.lam
    root_g = math.sqrt(gate)
    # the gate terms G_j(γ): the smallest over the grid of k
    g_gate = _K_OUT[None, :] + _ncx2_cdf((root_g + rho_j) ** 2, lam[:, None])  # (n, K)
    k_best = np.argmin(g_gate, axis=1)
    at_gate = np.minimum(g_gate.min(axis=1), by_range.bound(np.array([gate]))[:, 0])
    g_min = np.maximum(at_gate, FAR_TERM)
    bnd = np.minimum(1.0, np.bincount(mi, weights=np.minimum(1.0, g_min), minlength=m))
    f_gate = _ncx2_cdf(np.full(len(lam), gate), lam)
    ts = gate * _T_FRACTIONS
    # with the right landmark a candidate, also min_t G_i(t) + Σ_j G_j(t) (each pair at its gate's k);
    # G_i(t) ≥ e^(−γ/2) for every t ≤ γ, so only a gate sum above that can be lowered by it
    lower = has_right & (bnd > math.exp(-gate / 2.0)) & (not robust_to_covariance)
    sel = lower[mi]
    if sel.any():
        g_t = _gate_terms(ts, sel, at_gate, lam, rho_j, k_best, by_range)  # every term, as the engine's rule
        sums = np.zeros((m, len(ts)))
        np.add.at(sums, mi[sel], g_t)
        ps = pair if sel.all() else pair.select(sel)
        rho_i = _remainder(ps.sigma_i, ps.range_i, np.linalg.inv(ps.s_i))  # (n', K): equal within a measurement
        short = np.maximum(np.sqrt(ts)[None, :, None] - rho_i[:, None, :], 0.0)  # (n', T, K)
        g_i = np.ones((m, len(ts)))
        g_i[mi[sel]] = np.min(_K_OUT[None, None, :] + np.exp(-0.5 * short**2), axis=2) + p_out_bound[sel, None]
        lnn = np.min(g_i + sums, axis=1)
        bnd = np.where(lower, np.minimum(bnd, lnn), bnd)
    bnd = np.minimum(1.0, bnd + far_residual(ncand, len(points)))
    if linear:  # the same with ρ = 0 and no outside mass
        lin = np.minimum(1.0, np.bincount(mi, weights=f_gate, minlength=m))
        f_t = _ncx2_cdf(ts[None, :], lam[:, None])
        sums = np.zeros((m, len(ts)))
        np.add.at(sums, mi, f_t)
        lin = np.where(has_right, np.minimum(lin, np.min(np.exp(-ts / 2.0)[None, :] + sums, axis=1)), lin)
    if not estimate:  # the caller reads the bounds only
        return MeasurementRisk(np.zeros(m), np.minimum(bnd, 1.0), ncand, np.minimum(lin, 1.0))
    # the estimate: pairwise nearest-neighbour probability, capped by the gate's
    right = has_right[mi]
    p = f_gate.copy()
    if right.any():
        pr = pair if right.all() else pair.select(right)
        p[right] = np.minimum(p_nearer_form(pr.s_i, pr.s_j, pr.c_id, pr.c_d, pr.d), f_gate[right])
    # where the linearization fails: the engine's nonlinear quadrature, on the joint covariance the
    # independent oracle assembles from the prediction (not the batch's)
    rho2_i = np.where(right, _remainder(pair.sigma_i, pair.range_i, _inverse_2x2(pair.s_i), _K_GRID[1:2])[:, 0], 0.0)
    bent = bent_pairs(rho2_i, _remainder(sigma_j[close], range_j[close], s_inv[close], _K_GRID[1:2])[:, 0], lam)
    if bent.any():
        pairs = _quadrature_pairs(np.flatnonzero(bent), pose, points, prediction, state, meas, mi, li, cj, right)
        one_keyframe = np.zeros(len(p), np.int64)
        p = nonlinear_estimate(p, bent, one_keyframe, g_min, pairs, gate, (CANDIDATE_SCALE, CANDIDATE_MARGIN_M))
    # where the associator's reach changes a pair (the right landmark out of it, or a farther
    # candidate within it only at a long measured range): the engine's stratification on the range
    # noise, on the oracle's joint covariance
    st = reach_strata(pair, ~bent, right, meas.range_m[mi], meas.sigma_range_m[mi], range_j[close], sigma_j[close, 0])
    p = st.estimate(
        p,
        np.zeros(len(p), np.int64),
        lambda sel: _quadrature_pairs(np.flatnonzero(sel), pose, points, prediction, state, meas, mi, li, cj, right),
        gate,
    )
    # bincount sums each measurement's terms in order from 0, as np.add.at into zeros did
    logq = np.bincount(mi, weights=np.log1p(-np.clip(p, 0.0, 1.0 - 1e-16)), minlength=m)
    est = np.maximum(-np.expm1(logq), 0.0)
    return MeasurementRisk(est, np.minimum(bnd, 1.0), ncand, np.minimum(lin, 1.0))


def _quadrature_pairs(
    at: np.ndarray,
    pose: np.ndarray,
    points: np.ndarray,
    prediction: Prediction,
    state: np.ndarray,
    meas: KeyframeMeasurements,
    mi: np.ndarray,
    li: np.ndarray,
    cj: np.ndarray,
    right: np.ndarray,
) -> BentPairs:
    """The pairs ``at`` as the engine's quadrature takes them, on the joint covariance the independent
    oracle assembles from the prediction (not the batch's)."""
    cov = np.asarray(prediction.covariance, float)
    joint = np.stack([oracle_joint(state, cov, float(prediction.prior_sigma_m), [int(li[a]), int(cj[a])]) for a in at])
    return BentPairs(
        np.broadcast_to(np.asarray(pose, float), (len(at), 3)),
        points[li[at]],
        points[cj[at]],
        np.column_stack([meas.bearing_rad[mi[at]], meas.range_m[mi[at]]]),
        np.column_stack([meas.sigma_bearing_rad[mi[at]], meas.sigma_range_m[mi[at]]]),
        joint,
        right[at],
    )


def _noise_inverse(meas: KeyframeMeasurements, mi: np.ndarray) -> np.ndarray:
    """(n, 2, 2) R⁻¹ of each pair's measurement."""
    out = np.zeros((len(mi), 2, 2))
    out[:, 0, 0] = 1.0 / meas.sigma_bearing_rad[mi] ** 2
    out[:, 1, 1] = 1.0 / meas.sigma_range_m[mi] ** 2
    return out


def _slots(state: np.ndarray, landmarks: np.ndarray) -> np.ndarray:
    """Position of each landmark in the state (its landmarks in the pass's order), or −1."""
    if state.size == 0:
        return np.full(len(landmarks), -1, np.int64)
    order = np.argsort(state, kind="stable")
    pos = np.minimum(np.searchsorted(state[order], landmarks), len(state) - 1)
    return np.where(state[order[pos]] == landmarks, order[pos], -1).astype(np.int64)


@dataclass(frozen=True, eq=False)
class _Pairs:
    """Per (measurement, candidate) pair: d (n, 2), S_i, S_j, C_D (n, 2, 2), Cov(ν_i, D) (n, 2, 2), λ (n,);
    the std (σ_a, σ_b) (n, 2) [m] of w along and across the line of sight and the true range (n,) [m]
    of the measured landmark i (the candidate's: :func:`_candidate_moments`)."""

    d: np.ndarray
    s_i: np.ndarray
    s_j: np.ndarray
    c_d: np.ndarray
    c_id: np.ndarray
    lam: np.ndarray
    sigma_i: np.ndarray
    range_i: np.ndarray

    def select(self, mask: np.ndarray) -> _Pairs:
        return _Pairs(
            self.d[mask],
            self.s_i[mask],
            self.s_j[mask],
            self.c_d[mask],
            self.c_id[mask],
            self.lam[mask],
            self.sigma_i[mask],
            self.range_i[mask],
        )


def _landmark_blocks(cov: np.ndarray, a: np.ndarray, b: np.ndarray, prior_var: float) -> np.ndarray:
    """(n, 2, 2) covariance of a landmark at state slot a with itself (b = a), or between two
    distinct landmarks at slots a and b (−1: not in the state; two distinct landmarks out of the
    state are independent: each carries its own prior error)."""
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


def _pair_moments(
    pose: np.ndarray,
    points: np.ndarray,
    prediction: Prediction,
    meas: KeyframeMeasurements,
    mi: np.ndarray,
    li: np.ndarray,
    cj: np.ndarray,
    slot_i: np.ndarray,
    slot_j: np.ndarray,
    jac_j: np.ndarray,
    e_j: np.ndarray,
) -> _Pairs:
    """The moments of each (measurement, candidate) pair; ``jac_j`` (n, 2, 5) and ``e_j`` (n, 5, 5)
    candidate j's Jacobian and (pose, l_j) covariance block (:func:`_candidate_moments`)."""
    cov = np.asarray(prediction.covariance, float)
    prior_var = float(prediction.prior_sigma_m) ** 2
    n = len(mi)
    # the 7 × 7 covariance of (δpose, δl_i, δl_j)
    e = np.zeros((n, 7, 7))
    e[:, :3, :3] = cov[:3, :3]
    pi = _pose_landmark(cov, slot_i)
    e[:, :3, 3:5], e[:, :3, 5:7] = pi, e_j[:, :3, 3:]
    e[:, 3:5, :3], e[:, 5:7, :3] = np.transpose(pi, (0, 2, 1)), e_j[:, 3:, :3]
    e[:, 3:5, 3:5] = _landmark_blocks(cov, slot_i, slot_i, prior_var)
    e[:, 5:7, 5:7] = e_j[:, 3:, 3:]
    ij = _landmark_blocks(cov, slot_i, slot_j, 0.0)  # i ≠ j: no prior term between them
    e[:, 3:5, 5:7], e[:, 5:7, 3:5] = ij, np.transpose(ij, (0, 2, 1))
    poses = np.broadcast_to(pose, (n, 3))
    jac_i = bearing_range_jacobians(poses, points[li])  # (n, 2, 5)
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
    sigma_i, range_i = _line_of_sight_spread(pose, points[li], e, 3)
    return _Pairs(d=d, s_i=s_i, s_j=s_j, c_d=c_d, c_id=c_id, lam=lam, sigma_i=sigma_i, range_i=range_i)


def _candidate_moments(
    pose: np.ndarray,
    points: np.ndarray,
    prediction: Prediction,
    meas: KeyframeMeasurements,
    mi: np.ndarray,
    near: np.ndarray,
    near_slot: np.ndarray,
    near_at: np.ndarray,
    d: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """What the far-pair filter needs of each pair, from the (pose, l_j) 5 × 5 block alone: S_j
    (n, 2, 2), λ (n,), the line-of-sight spreads (n, 2) [m] and ranges (n,) [m] of candidate j
    (the same as :func:`_pair_moments`' for those pairs), S_j⁻¹ (n, 2, 2), and what
    :func:`_pair_moments` reuses: candidate j's Jacobian H_j (n, 2, 5) and (pose, l_j) block (n, 5, 5).
    Pair p's candidate is ``near[near_at[p]]`` (``near`` sorted, ``near_slot`` their state slots);
    ``d`` (n, 2) the pairs' innovation means. H_j P H_jᵀ and the spreads depend on the candidate only:
    computed once per candidate (a keyframe's measurements share them), then the measurement's noise
    added."""
    cov = np.asarray(prediction.covariance, float)
    # the distinct candidates, sorted (``near`` is): np.unique of the pairs' without sorting them
    present = np.zeros(len(near), bool)
    present[near_at] = True
    back = (np.cumsum(present) - 1)[near_at]
    uniq, slots = near[present], near_slot[present]
    n = len(uniq)
    e = np.zeros((n, 5, 5))
    e[:, :3, :3] = cov[:3, :3]
    pj = _pose_landmark(cov, slots)
    e[:, :3, 3:], e[:, 3:, :3] = pj, np.transpose(pj, (0, 2, 1))
    e[:, 3:, 3:] = _landmark_blocks(cov, slots, slots, float(prediction.prior_sigma_m) ** 2)
    jac = bearing_range_jacobians(np.broadcast_to(pose, (n, 3)), points[uniq])  # (n, 2, 5)
    s_j = (jac @ e @ np.transpose(jac, (0, 2, 1)))[back]
    s_j[:, 0, 0] += meas.sigma_bearing_rad[mi] ** 2
    s_j[:, 1, 1] += meas.sigma_range_m[mi] ** 2
    inv = _inverse_2x2(s_j)
    lam = np.einsum("ni,nij,nj->n", d, inv, d)
    sigma, rng = _line_of_sight_spread(pose, points[uniq], e, 3)
    return s_j, lam, sigma[back], rng[back], inv, jac[back], e[back]


def _inverse_2x2(a: np.ndarray) -> np.ndarray:
    """(n, 2, 2) inverses of symmetric positive definite (n, 2, 2) matrices, in closed form."""
    det = a[:, 0, 0] * a[:, 1, 1] - a[:, 0, 1] * a[:, 1, 0]
    out = np.empty_like(a)
    out[:, 0, 0], out[:, 1, 1] = a[:, 1, 1] / det, a[:, 0, 0] / det
    out[:, 0, 1], out[:, 1, 0] = -a[:, 0, 1] / det, -a[:, 1, 0] / det
    return out


def _line_of_sight_spread(
    pose: np.ndarray, points: np.ndarray, e: np.ndarray, col: int
) -> tuple[np.ndarray, np.ndarray]:
    """(σ_a, σ_b) (n, 2) [m] of w = e_l − R(θ) e_xy along and across the line of sight to ``points``
    (n, 2), the landmark's error at columns ``col``, ``col + 1`` of the (n, q, q) covariance ``e``
    (the pose's position error in its own frame at columns 0, 1); and the true ranges (n,) [m]."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    rel = points - pose[:2]
    rng = np.maximum(np.hypot(rel[:, 0], rel[:, 1]), 1e-9)
    ux, uy = rel[:, 0] / rng, rel[:, 1] / rng
    # Cov(w) = E_ll + M E_pp Mᵀ − E_lp Mᵀ − M E_pl, M = R(θ) (2 × 2 blocks: cheap elementwise)
    rot = np.array([[c, -s], [s, c]])
    e_lp = e[:, col : col + 2, :2] @ rot.T
    cw = e[:, col : col + 2, col : col + 2] + rot @ e[:, :2, :2] @ rot.T - e_lp - np.transpose(e_lp, (0, 2, 1))
    var_a = ux * ux * cw[:, 0, 0] + 2.0 * ux * uy * cw[:, 0, 1] + uy * uy * cw[:, 1, 1]
    var_b = uy * uy * cw[:, 0, 0] - 2.0 * ux * uy * cw[:, 0, 1] + ux * ux * cw[:, 1, 1]
    return np.sqrt(np.maximum(np.column_stack([var_a, var_b]), 0.0)), rng


def _innovation_means(
    pose: np.ndarray,
    points: np.ndarray,
    meas: KeyframeMeasurements,
    mi: np.ndarray,
    cj: np.ndarray,
    at: np.ndarray | None = None,
) -> np.ndarray:
    """(n, 2) d: the true measurement of each pair's measurement minus candidate j's (bearing wrapped).
    With ``at``, ``cj`` are distinct candidates and pair p's is ``cj[at[p]]`` (each predicted once)."""
    ci, si = math.cos(pose[2]), math.sin(pose[2])
    rel_j = points[cj] - pose[:2]
    bj = np.arctan2(ci * rel_j[:, 1] - si * rel_j[:, 0], ci * rel_j[:, 0] + si * rel_j[:, 1])
    rj = np.hypot(rel_j[:, 0], rel_j[:, 1])
    if at is not None:
        bj, rj = bj[at], rj[at]
    db = (meas.bearing_rad[mi] - bj + np.pi) % (2.0 * np.pi) - np.pi
    return np.column_stack([db, meas.range_m[mi] - rj])


def _gate_terms(
    ts: np.ndarray,
    sel: np.ndarray,
    at_gate: np.ndarray,
    lam: np.ndarray,
    rho_j: np.ndarray,
    k_best: np.ndarray,
    by_range: _RangeSeparation,
) -> np.ndarray:
    """(s, T) G_j(t) of the pairs of ``sel`` (n,) bool, every one evaluated (the engine's
    ``_gate_sums`` evaluates only the levels that can lower the bound: this is its oracle), at each
    level ``ts`` (T,) of the bound's minimum over t, each pair at its gate's k (``k_best`` (n,);
    ``lam`` (n,) λ_j, ``rho_j`` (n, K) the remainders over the grid of k, ``by_range`` the range
    terms), and ``at_gate`` (n,) its term at γ. G_j(t) is non-decreasing in t, so G_j(γ) bounds it at
    every t: a pair whose G_j(γ) is below TINY_TERM takes it at every t (a bound still, looser by less
    than TINY_TERM a pair against a sum above e^(−γ/2)), without its χ'² evaluations."""
    live = sel & (at_gate >= TINY_TERM)
    out = np.repeat(at_gate[sel][:, None], len(ts), axis=1)
    if live.any():
        kb = k_best[live]
        rho_k = rho_j[live][np.arange(len(kb)), kb]
        g = _K_OUT[kb][:, None] + _ncx2_cdf((np.sqrt(ts)[None, :] + rho_k[:, None]) ** 2, lam[live][:, None])
        out[live[sel]] = np.minimum(g, by_range.select(live).bound(ts))
    return out
