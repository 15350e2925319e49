"""The risk that a measurement is associated with the wrong landmark, under gated nearest neighbour.

The associator (what cars run, stated here once and used everywhere):

- per measurement z (bearing [rad], range [m]) of one sensor at keyframe k, the candidates are the
  landmarks of the map (model ``map``) or of the filter's state (model ``slam``: the landmarks seen by
  used measurements of earlier keyframes) within ``1.25 r + 5 m`` of the car, r the measured range
  (a landmark farther out predicts a range more than 0.25 r + 5 m off: outside any gate but for
  metres of range noise; landmarks in the cone and near it, on every side, are all candidates);
  the risk's computation drops the pairs whose λ exceeds (√γ + 10)² and never considers landmarks
  beyond a widened reach (:func:`candidate_reach`): each such landmark adds FAR_TERM to the bound
  ("the far limit" below);
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
not wrong). All probabilities are over the measurement noise v ~ N(0, R) and the estimate's error
e ~ N(0, P) (P the predicted joint covariance; x̂ = x retracted by e, l̂_j = l_j + e_j).

**The model linearized at the truth.** ν_j^lin = d_ij + v − H_j e, d_ij = h(x, l_i) − h(x, l_j), so
ν_j^lin ~ N(d_ij, S_j) and NIS_j^lin ~ χ'²₂(λ_j), λ_j = d_ijᵀ S_j⁻¹ d_ij; NIS_i^lin ~ χ²₂.

**What the car's innovation adds: the Taylor remainder.** The pose's heading enters the bearing
linearly, and the pose's position and the landmark enter only through the estimated relative
position u_j + w_j, u_j = l_j − p (range r_j), w_j = e_j − R(θ) e_xy. So ν_j = ν_j^lin − ε_j(w_j), with
ε_j the remainder of polar coordinates (bearing, range) at u_j. In the line-of-sight frame,
w_j = (a, b) (a along u_j, b across): bearing = atan(b / (r_j + a)) with linear part b / r_j, range
= √((r_j + a)² + b²) with linear part r_j + a. On the box Ω_j(k) = {|a| ≤ A = kσ_a, |b| ≤ B = kσ_b}
(σ_a, σ_b the std of a and b under P), when A < r_j:

    |ε_bearing| ≤ A B / (r_j (r_j − A)) + (B / (r_j − A))³ / 3,   0 ≤ ε_range ≤ B² / (2 (r_j − A))

(|b/(r+a) − b/r| = |a b| / (r (r + a)); |atan y − y| ≤ |y|³/3; √(X² + b²) − X ≤ b²/(2X) for X > 0),
and ρ_j(k) = max ‖S_j^(−1/2) ε‖ over that box of ε (its largest corner). P(w_j ∉ Ω_j(k)) ≤ 4Φ(−k).
On Ω_j(k) the triangle inequality gives √NIS_j ≥ √NIS_j^lin − ρ_j(k) (and √NIS_i ≤ √NIS_i^lin + ρ_i(k)),
hence for any k and any level x:

    P(NIS_j ≤ x) ≤ 4Φ(−k) + F((√x + ρ_j(k))²; λ_j),   P(NIS_i > x) ≤ 4Φ(−k) + e^(−(√x − ρ_i(k))₊²/2)

F(·; λ) the CDF of χ'²₂(λ). Every term may take its own k (each is a bound on its own probability);
the gate terms take the smallest over a fixed grid of k, the thresholds t below reuse the gate's k
of each pair, and the right landmark's term the smallest over the grid at each t. Where the spread
is a small share of the range (a map: centimetres at tens of metres) ρ is small and the bound is
that of the linearized model; where a landmark's spread is metres at 9 m (SLAM's fresh stereo
landmarks) ρ is large at every useful k and the bound is loose but holds
(``tests/test_association_linearization.py``). Not covered: bearing aliases 2π apart (the
associator wraps the bearing innovation; an alias needs an error of ~π rad) and S_j evaluated at
the estimate rather than the truth (the oracles and the simulator evaluate it at the truth, as here).

**The range's bound: no box.** The box needs kσ_a < r_j; for a landmark within a few σ of the car only
small k is left and G_j would stay at 4Φ(−k) however far apart the two landmarks are. The range is
1-Lipschitz in the positions (|r̂_j − r_j| ≤ ‖w_j‖) and NIS_j ≥ ν_r² / S_rr, so NIS_j ≤ x only if
|v_r| + ‖w_j‖ ≥ |r_i − r_j| − √(x S_rr): a second bound of P(NIS_j ≤ x) from Gaussian tails alone
(:class:`_RangeSeparation`); each G_j takes the smaller. It is non-decreasing in P and R and at least
F(x; λ_j) (the linearized range innovation obeys the same inequality), so the properties below hold.

**The reach: the right landmark can be out of it.** The associator's candidates lie within
s r̂ + c of the estimated pose (s = CANDIDATE_SCALE, c = CANDIDATE_MARGIN_M), r̂ = r_i + v_r the
*measured* range: a stereo camera's range noise (metres) can make r̂ so short that landmark i itself
is out of reach, and a nearer j inside the gate is then taken though NIS_i is the smaller. The
estimated distance of i is |u_i + w_i| ≤ r_i + ‖w_i‖, so i is out of reach only if
‖w_i‖ − s v_r > D = s r_i + c − r_i (= 0.25 r_i + 5 m). ‖w_i‖ is stochastically below σ_w R (R
Rayleigh, σ_w² = σ_a² + σ_b² ≥ λmax(Cov(w_i)): P(‖w‖ ≥ t) ≤ e^(−t²/(2σ_w²))), independent of v_r, so
with τ = s σ_r and q² = σ_w² + τ²

    P(i out of reach) ≤ O_i = Φ(−D/τ) + (σ_w/q) e^(−D²/(2q²)) Φ(D σ_w/(q τ))

(the Gaussian integral of the Rayleigh tail, exact for σ_w R: :func:`_out_of_reach`). Nearly exact
where the range noise dominates (a map's centimetres of spread); looser where the spread is metres
(an error toward the car counts as one away from it). 0 in double precision for the library's LiDARs
and radars on a map (σ_r ≤ 0.084 m, σ_w decimetres, D ≥ 5 m).

**The bound** (after Duenas Arana, Joerger & Spenko's local nearest-neighbour bound, ICRA 2018): for
any threshold t ≤ γ, if i is within reach, NIS_i ≤ t and every NIS_j > t then i is the nearest and
inside the gate, so W ⊆ {i out of reach} ∪ {NIS_i > t} ∪ ⋃_j {NIS_j ≤ t}; also W ⊆ ⋃_j {NIS_j ≤ γ}
(a wrong candidate is taken only inside the gate, whether i is in reach or not). With the per-term
bounds above:

    P(W) ≤ min(1, Σ_j G_j(γ), min_t [G_i(t) + Σ_j G_j(t)])

G_j(x) the bound on P(NIS_j ≤ x), G_i(t) = O_i + the bound on P(NIS_i > t); the minimum over a fixed
grid of t in (0, γ] (any t is valid; a pair's G_j(t) ≤ G_j(γ), which a pair below TINY_TERM takes at
every t: still a bound). For a first sighting only Σ_j G_j(γ). The sums run over the
candidates kept; every other landmark of the map adds FAR_TERM to either form (next).

**The far limit.** Both forms are unions over every landmark j ≠ i that the associator could take.
The engine computes terms for the candidates it keeps; each landmark it does not keep has
P(NIS_j ≤ γ) ≤ FAR_TERM = 4Φ(−k_far) + Φ(−F) (F = FAR_SIGMAS = 10, k_far = F: 3.8e-23; the box's
k need not be on the grid), and the bound adds FAR_TERM × (N − 1 − kept), N the map's landmarks (in
SLAM the route's: the state is among them, and a landmark out of it is never taken):

- a pair dropped by the far filter has √λ_j > √γ + F + ρ_j(k_far) (λ_j from candidate j's own
  block, as every kept pair's). With x ~ N(μ, I₂) the whitened linearized innovation,
  ‖μ‖ = √λ, P(‖x‖ ≤ a) ≤ P(μ̂ᵀx ≤ a) = Φ(a − √λ); so G_j(γ) ≤ 4Φ(−k_far) + F((√γ + ρ_j(k_far))²; λ_j)
  ≤ 4Φ(−k_far) + Φ(−F);
- a landmark beyond the widened reach (r_j ≥ r + (√γ + F) √(s_bb + s_rr), so r_j > r): the range is
  convex in the relative position, r̂_j = |u_j + w_j| ≥ r_j + a_j (a_j = û_jᵀ w_j, its linear part),
  so the range innovation ν_r = r + v_r − r̂_j ≤ v_r − a_j − (r_j − r), and NIS_j ≤ γ needs
  ν_r ≥ −√(γ S_rr,j) (NIS_j ≥ ν_r²/S_rr,j). v_r − a_j is Gaussian with variance S_rr,j ≤ s_rr (the
  reach's, with the largest landmark spread), so P(NIS_j ≤ γ) ≤ Φ(√γ − (r_j − r)/√S_rr,j) ≤ Φ(−F):
  no linearization and no box, for any number of such landmarks each counted once.

Kept pairs' gate terms are floored at FAR_TERM, what they would add if dropped: as the covariance
grows a landmark moves from beyond the reach to dropped to kept, and its share never falls. At
3.8e-23 per landmark a measurement's residual is below 2.3e-20 on KITTI 00's map (598 poles): a
keyframe of a hundred measurements stays far below the ~3·10⁻¹² per keyframe that 10⁻⁸/h at 3,481
keyframes/h allows. ``MeasurementRisk.linear``
is the same bound with ρ = 0, no outside mass and no O_i (the NIS model linearized at the truth, every
landmark within reach): at most ``bound`` (term by term: ``bound`` only adds non-negative terms),
non-increasing in every λ_j, and λ_j is non-increasing when P or R grows (Loewner order): the linear
bound never falls with more noise, more landmarks, a looser prior or a looser map, which is what the
search's association floor uses. It leaves the far limit's residual out: the floor must only stay
at most ``bound`` and monotone, and a constant per landmark of the map says nothing of the suite.
O_i is left out of it on purpose: it is non-decreasing in P (σ_w)
but not in R (a larger σ_r can lower P(σ_w R + τZ > D) where σ_w R already exceeds D), and the floor
needs only ``linear`` ≤ ``bound``, which holds without it. ``bound`` itself need not be monotone (a
larger S whitens the remainder more); with ``robust_to_covariance`` the bound returned is
Σ_j max(FAR_TERM, min_k [4Φ(−k) + F((√γ + ρ'_j(k))²; λ_j)]) + the far limit's residual, with ρ'
whitened by R instead of S_j (ρ' ≥ ρ, since S_j ⪰ R): non-decreasing in P (a landmark that enters
the kept candidates as P grows never lowers its share), so at a prediction it is at least ``bound``
at any prediction with a smaller covariance (the search uses it to know a measurement no suite's
lever leaves out).

**The estimate** (calibrated, not a bound): the pairwise events, combined as independent,
P(W) ≈ 1 − Π_j (1 − p_j), p_j = min(P(NIS_j < NIS_i), F(γ; λ_j)). With D = ν_j − ν_i (the
measurement noise cancels in D), x = (ν_i, D) is Gaussian, N((0, d), [[S_i, C_iD], [C_iDᵀ, C_D]]), and
NIS_j − NIS_i = xᵀ A x is a quadratic form, A = [[S_j⁻¹ − S_i⁻¹, S_j⁻¹], [S_j⁻¹, S_j⁻¹]]: P(NIS_j < NIS_i)
is its CDF at 0, by the saddlepoint approximation (:mod:`~sensorsel.information.integrity.nearer`;
each NIS with its own S: a common S̄ = (S_i + S_j)/2, as an earlier estimate took, is off by 2-3x
where a stereo camera's S_i and S_j differ). Two landmarks at one point give
½, two far apart Φ(−½ ‖d‖_S) (the classic two-hypothesis error). First sightings: p_j = F(γ; λ_j).
Where a pair's remainder is not small against its separation (ρ(2) of either landmark above a share
of √λ_j: SLAM's fresh landmarks), p_j is instead a quadrature of the nonlinear model
(:mod:`~sensorsel.information.integrity.nonlinear`). Where the associator's reach may leave the
right landmark out (:func:`out_of_reach_estimate` above :data:`REACH_SHARE`: a stereo camera's range noise
shortens the measured range), the linearized p_j, which has no reach, is stratified on the range
noise: (1 − t) p_j + t q_j, q_j that quadrature given the noise's lower tail t (:func:`reach_tail`);
and where a farther candidate is within reach only at a long measured range, p_j = u q_j, u the
noise's upper tail (:func:`reach_upper_tail`), below which the associator never takes it
(:func:`reach_strata`).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree
from scipy.special import chndtr, ndtr

from sensorsel.information.filtering import KeyframeMeasurements, Prediction
from sensorsel.information.integrity.moments import (
    Batch,
    Candidates,
    Pairs,
    Snapshot,
    candidate_moments,
    innovation_means,
    inverse_2x2,
    noise_inverse,
    pair_moments,
)
from sensorsel.information.integrity.nearer import p_nearer_form
from sensorsel.information.integrity.nonlinear import BentPairs, bent_pairs, nonlinear_estimate, reach_tail_estimate
from sensorsel.model.problem import Problem

__all__ = [
    "ASSOCIATION_MODELS",
    "AssociationModel",
    "MeasurementRisk",
    "Pending",
    "gate_of",
    "keyframe_risk",
    "measurement_risks",
]

#: the models: a prior map (every landmark a candidate) or SLAM (the landmarks in the filter's state)
ASSOCIATION_MODELS = ("map", "slam")

#: how far a candidate may lie from the car: CANDIDATE_SCALE × the largest range measured + CANDIDATE_MARGIN_M
CANDIDATE_SCALE = 1.25
CANDIDATE_MARGIN_M = 5.0
#: pairs whose λ exceeds (√γ + FAR_SIGMAS)² are dropped, and landmarks beyond the widened reach never
#: considered: each adds at most FAR_TERM to the bound (module docstring, "the far limit")
FAR_SIGMAS = 10.0
#: a pair's estimate is the quadrature's (which keeps the reach) where the measured landmark is out of
#: the associator's reach with at least this probability (:func:`out_of_reach_estimate`)
REACH_SHARE = 1e-6
#: the tail of the range noise that holds the reach's misses: the line of sight's error up to this many σ
REACH_SIGMAS = 4.0
#: a farther candidate's pair whose linearized estimate is at most this takes min(p_j, its tail), no
#: quadrature (a keyframe's share of 10⁻⁸ per hour is ~3e-12: far below what any figure shows)
REACH_FLOOR = 1e-15
#: at most this many (measurement, candidate) pairs are computed together (memory: ~1 kB each at most)
PAIRS_PER_BATCH = 400_000
#: a pair whose gate term is below this takes it at every level t of the bound's minimum over t
#: (a bound: the term is non-decreasing in t; module docstring)
TINY_TERM = 1e-12
#: snapshots a :class:`Pending` keeps before computing their risks [bytes]
PENDING_BYTES = 64 * 2**20

_T_FRACTIONS = np.linspace(0.05, 1.0, 20)  # the bound's thresholds t, as fractions of γ
#: the region sizes k of the Taylor remainder (module docstring), and their outside masses 4Φ(−k)
_K_GRID = np.array([1.5, 2.0, 2.5, 3.0, 4.0, 5.5, 7.0, 9.0, 12.0])
_K_OUT = 4.0 * ndtr(-_K_GRID)
#: the box's k of the far filter, k_far = FAR_SIGMAS (any k bounds one probability: module docstring)
_FAR_K = np.array([FAR_SIGMAS])
#: the most a landmark left out of a measurement's kept candidates adds to its bound: a pair dropped
#: by the far filter 4Φ(−k_far) + Φ(−FAR_SIGMAS), a landmark beyond the widened reach Φ(−FAR_SIGMAS)
#: (module docstring, "the far limit"); 5Φ(−10) = 3.8e-23
FAR_TERM = float(4.0 * ndtr(-_FAR_K[0]) + ndtr(-FAR_SIGMAS))


def far_residual(n_kept: np.ndarray, n_landmarks: int) -> np.ndarray:
    """(m,) the bound's residual of each measurement for the landmarks it does not keep as candidates:
    FAR_TERM for each landmark of the ``n_landmarks`` [count] but the measured one and the ``n_kept``
    (m,) candidates kept (module docstring, "the far limit")."""
    return FAR_TERM * np.maximum(n_landmarks - 1 - np.asarray(n_kept, np.int64), 0).astype(float)


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
    return _whitened(_taylor_box(sigma_ab, rng_m, ks), s_inv[:, 0, 0], s_inv[:, 1, 1], s_inv[:, 0, 1])


def _taylor_box(sigma_ab: np.ndarray, rng_m: np.ndarray, ks: np.ndarray) -> tuple[np.ndarray, ...]:
    """(ε_b [rad], ε_r [m], ok) (n, K): :func:`_remainder`'s bearing and range remainders before
    whitening, and where kσ_a is short of the range. They depend on the spreads and the range alone,
    so a candidate's serve every measurement that has it (the far filter computes them once each)."""
    a = ks[None, :] * sigma_ab[:, :1]
    b = ks[None, :] * sigma_ab[:, 1:]
    r = rng_m[:, None]
    ok = a < r
    x = np.where(ok, r - a, 1.0)
    return a * b / (r * x) + (b / x) ** 3 / 3.0, b**2 / (2.0 * x), ok


def _whitened(box: tuple[np.ndarray, ...], s_bb: np.ndarray, s_rr: np.ndarray, s_br: np.ndarray | None) -> np.ndarray:
    """(n, K) ρ(k) from :func:`_taylor_box`'s ``box`` and the whitening's entries (0, 0), (1, 1) and
    (0, 1) (n,) (``s_br`` None: a diagonal whitening, whose cross term adds +0 to each sum)."""
    rho_b, rho_r, ok = box
    q = rho_b**2 * s_bb[:, None] + rho_r**2 * s_rr[:, None]
    if s_br is not None:
        q += 2.0 * rho_b * rho_r * np.abs(s_br)[:, None]
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


_RISK_FIELDS = ("estimate", "bound", "n_candidates", "linear")


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
        b = self._batch([Snapshot.of(prediction, meas)])
        return self._candidates(b, _reach(b, self.gate, self.model))[0]

    def _batch(self, snapshots: Sequence[Snapshot]) -> Batch:
        return Batch.of(self._poses[[s.keyframe for s in snapshots]], snapshots)

    def _candidates(self, b: Batch, reach_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(near, near_at): every keyframe's candidates (sorted landmark indices) joined, and the
        keyframe of the batch of each (sorted); ``reach_m`` (M,) [m] each measurement's
        :func:`candidate_reach`. A keyframe's candidates lie within its measurements' largest reach."""
        n_meas = np.diff(b.meas_off)
        some = np.flatnonzero(n_meas > 0)
        if self._tree is None or len(some) == 0:
            return np.zeros(0, np.int64), np.zeros(0, np.int64)
        radius = np.maximum.reduceat(reach_m, b.meas_off[some])  # each keyframe's largest (exact)
        if self.model == "slam":
            # the state's landmarks within the radius: a few hundred distances a keyframe, where the
            # tree's query returns the map's and most are dropped
            n_held = np.diff(b.held_off)[some]
            at = np.repeat(some, n_held)
            first = np.cumsum(n_held) - n_held  # where each keyframe's run starts among those taken
            state = b.held[np.repeat(b.held_off[some] - first, n_held) + np.arange(int(n_held.sum()))]
            dist = np.hypot(*(self._points[state] - b.poses[at, :2]).T)
            inside = dist <= np.repeat(radius, n_held)
            # a state is in the pass's order: sorted by keyframe, then landmark, as the map's are
            key = np.sort(at[inside] * len(self._points) + state[inside])
            return key % len(self._points), key // len(self._points)
        found = self._tree.query_ball_point(b.poses[some, :2], radius, return_sorted=False)
        counts = np.array([len(x) for x in found], np.int64)
        near = np.fromiter(itertools.chain.from_iterable(found), np.int64, count=int(counts.sum()))
        # sorted by keyframe, then landmark: one sort of an integer key (each pair once)
        key = np.sort(np.repeat(some, counts) * len(self._points) + near)
        return key % len(self._points), key // len(self._points)

    def snapshot(self, prediction: Prediction, meas: KeyframeMeasurements) -> Snapshot:
        """What :meth:`risks_of` needs of ``prediction`` for ``meas``, copied (a forward pass's ``use``
        hook takes it: the pass updates its state after the hook returns)."""
        return Snapshot.of(prediction, meas)

    def risks_of(
        self,
        snapshots: Sequence[Snapshot],
        *,
        linear: bool = False,
        robust_to_covariance: bool = False,
        estimate: bool = True,
    ) -> MeasurementRisk:
        """The estimate and bound of P(wrong association) of every measurement of the ``snapshots``'
        keyframes (any number), computed together: arrays joined in the order of the snapshots, each
        measurement's numbers those of its keyframe alone (:meth:`risks`). Keyframes
        go through in consecutive groups of at most :data:`PAIRS_PER_BATCH` (measurement, candidate)
        pairs (a whole library's measurements at once would hold gigabytes). ``estimate``: False
        for callers that read the bounds only: no estimate is computed (zeros; its pairwise terms and
        the nonlinear quadrature are most of the cost)."""
        b = self._batch(snapshots)
        reach = _reach(b, self.gate, self.model)  # once: candidates and pairs
        near, near_at = self._candidates(b, reach)

        def run(part: Batch, near: np.ndarray, near_at: np.ndarray, reach: np.ndarray) -> MeasurementRisk:
            return _risks(
                part,
                self._points,
                near,
                near_at,
                gate=self.gate,
                model=self.model,
                linear=linear,
                robust_to_covariance=robust_to_covariance,
                estimate=estimate,
                reach_m=reach,
            )

        pairs = np.diff(b.meas_off) * np.bincount(near_at, minlength=len(snapshots))
        if int(pairs.sum()) <= PAIRS_PER_BATCH:
            return run(b, near, near_at, reach)
        # consecutive groups of keyframes (each at least one), the batch's parts
        groups, lo, total = [], 0, 0
        for k, n in enumerate(pairs.tolist()):
            if k > lo and total + n > PAIRS_PER_BATCH:
                groups.append((lo, k))
                lo, total = k, 0
            total += n
        groups.append((lo, len(snapshots)))
        near_off = np.searchsorted(near_at, np.arange(len(snapshots) + 1))
        parts = [
            run(
                b.part(lo, hi),
                near[near_off[lo] : near_off[hi]],
                near_at[near_off[lo] : near_off[hi]] - lo,
                reach[b.meas_off[lo] : b.meas_off[hi]],
            )
            for lo, hi in groups
        ]
        return MeasurementRisk(*(np.concatenate([getattr(r, f) for r in parts]) for f in _RISK_FIELDS))

    def risks(self, prediction: Prediction, meas: KeyframeMeasurements, **options: bool) -> MeasurementRisk:
        """The estimate and bound of P(wrong association) of each of ``meas`` at ``prediction``: one
        keyframe's :meth:`risks_of` (``options``: its ``linear``, ``robust_to_covariance``)."""
        return self.risks_of([Snapshot.of(prediction, meas)], **options)


class Pending:
    """The risks of a forward pass's keyframes whose predictions do not depend on them (every
    measurement used): each keyframe's snapshot is kept by :meth:`add` (a ``use`` hook's call), and
    their risks are computed together whenever the snapshots kept reach :data:`PENDING_BYTES` and at
    :meth:`result` (the same numbers, memory bounded).

    Args:
        model: the association model.
        options: :meth:`AssociationModel.risks_of`'s (``linear``, ``robust_to_covariance``, ``estimate``).
    """

    def __init__(self, model: AssociationModel, **options: bool) -> None:
        self.model, self.options = model, options
        self.meas: list[KeyframeMeasurements] = []
        self._snapshots: list[Snapshot] = []
        self._bytes = 0
        self._done: list[MeasurementRisk] = []

    def add(self, prediction: Prediction, meas: KeyframeMeasurements) -> None:
        """Keep keyframe ``meas.keyframe``'s snapshot (none where it measures nothing)."""
        if len(meas.landmark) == 0:
            return
        snap = self.model.snapshot(prediction, meas)
        self.meas.append(meas)
        self._snapshots.append(snap)
        self._bytes += snap.rows.nbytes + snap.blocks.nbytes
        if self._bytes > PENDING_BYTES:
            self._flush()

    def _flush(self) -> None:
        if self._snapshots:
            self._done.append(self.model.risks_of(self._snapshots, **self.options))
        self._snapshots, self._bytes = [], 0

    def result(self) -> MeasurementRisk:
        """Every kept keyframe's risks, joined in the order of :attr:`meas`."""
        self._flush()
        if not self._done:
            return MeasurementRisk(np.zeros(0), np.zeros(0), np.zeros(0, np.int64), np.zeros(0))
        return MeasurementRisk(*(np.concatenate([getattr(r, f) for r in self._done]) for f in _RISK_FIELDS))


def _reach(b: Batch, gate: float, model: str) -> np.ndarray:
    """(M,) :func:`candidate_reach` of every measurement of the batch."""
    sd_xy, sd_th, sd_lm = (x[b.at] for x in b.spreads(with_prior=model != "slam"))
    r = np.asarray(b.meas["range_m"], float)
    s_bb = r**2 * np.asarray(b.meas["sigma_bearing_rad"], float) ** 2 + (sd_xy + sd_lm + r * sd_th) ** 2
    s_rr = np.asarray(b.meas["sigma_range_m"], float) ** 2 + (sd_xy + sd_lm) ** 2
    wide = r + (math.sqrt(gate) + FAR_SIGMAS) * np.sqrt(s_bb + s_rr)
    return np.maximum(CANDIDATE_SCALE * r + CANDIDATE_MARGIN_M, wide)


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
    pairs the far-pair filter drops anyway: the reach loses nothing that filter keeps, and each
    landmark beyond it is taken with probability at most Φ(−F) ≤ FAR_TERM, which the bound adds
    (module docstring, "the far limit"). In SLAM
    (``model="slam"``) the candidates are the state's landmarks, whose spreads the state holds: the
    weak prior of the landmarks out of it (100 m) would make every landmark of the route a candidate."""
    snap = Snapshot.of(prediction, meas)
    return _reach(Batch.of(np.zeros((1, 3)), [snap]), gate, model)


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
    b = Batch.of(np.asarray(pose, float)[None, :], [Snapshot.of(prediction, meas)])
    near = np.asarray(candidates, np.int64)
    return _risks(
        b,
        np.asarray(points, float),
        near,
        np.zeros(len(near), np.int64),
        gate=gate,
        model=model,
        linear=linear,
        robust_to_covariance=robust_to_covariance,
        reach_m=_reach(b, gate, model) if reach_m is None else np.asarray(reach_m, float),
    )


def _risks(
    b: Batch,
    points: np.ndarray,
    near: np.ndarray,
    near_at: np.ndarray,
    *,
    gate: float,
    model: str,
    linear: bool,
    robust_to_covariance: bool,
    estimate: bool = True,
    reach_m: np.ndarray,
) -> MeasurementRisk:
    """:func:`measurement_risks` of every measurement of the batch, against the candidates ``near``
    of the batch's keyframes ``near_at`` (sorted), each measurement's reach ``reach_m`` (M,) [m]."""
    m = len(b.at)
    est, ncand, lin = np.zeros(m), np.zeros(m, np.int64), np.zeros(m)
    # with no candidate kept, the bound is every other landmark's far residual (module docstring)
    bnd = np.minimum(1.0, far_residual(ncand, len(points)))
    if m == 0 or near.size == 0:
        return MeasurementRisk(est, bnd, ncand, lin)
    has_right = np.ones(m, bool) if model == "map" else b.slot >= 0
    # all (measurement, candidate of its keyframe) pairs but the truly measured landmark, measurement
    # by measurement; ``pick``: each pair's candidate as a position in ``near``
    near_off = np.searchsorted(near_at, np.arange(len(b.poses) + 1))
    n_c = np.diff(near_off)[b.at]
    mi = np.repeat(np.arange(m), n_c)
    pick = np.repeat(near_off[b.at], n_c) + np.arange(len(mi)) - np.repeat(np.cumsum(n_c) - n_c, n_c)
    cj = near[pick]
    # a candidate is another landmark within the measurement's reach (candidate_reach: its own range,
    # noise and the covariance), so a measurement's risk depends on its own geometry and the
    # covariance only, never on which other measurements the suite makes (distances and state
    # slots are the candidates', computed once each)
    near_dist = np.hypot(*(points[near] - b.poses[near_at, :2]).T)
    near_slot = b.slots(near_at, near)
    reach = reach_m[mi]
    if model == "slam" and (near_slot < 0).any():  # out of the state (a caller's choice): the stated reach
        in_state = near_slot[pick] >= 0
        reach = np.where(in_state, reach, CANDIDATE_SCALE * b.meas["range_m"][mi] + CANDIDATE_MARGIN_M)
    keep = (cj != b.meas["landmark"][mi]) & (near_dist[pick] <= reach)
    # each stage carries the pairs' candidates as positions in ``near`` (``pick``) only: the landmark
    # and its slot are gathered for the few pairs left at the end
    pick, mi = pick[keep], mi[keep]
    d = innovation_means(b, points, mi, near, near_at, pick)
    far_k = _FAR_K
    # first, with no candidate's moments, the pairs surely past the far limit: λ = dᵀ S_j⁻¹ d ≥
    # max(d_b² / S_bb, d_r² / S_rr) (Cauchy–Schwarz), and the predicted bearing's error is
    # u⊥·w_j / r_j − dθ, the range's u·w_j, so S_bb ≤ σ_b² + (σ_across/r_j + σ_θ)² and S_rr = σ_r² +
    # σ_along², σ_along and σ_across w_j's spreads along and across the line of sight, bounded once per
    # (keyframe, candidate) from the state's 2 × 2 blocks (Batch.line_of_sight_bounds: the pose's and
    # the landmark's errors correlated, a stereo landmark's running along the line of sight); the far
    # limit widened by the remainder at k_far with those spreads, whitened by R ⪰ S, and by a relative
    # 1e-9 over the rounding of either side. It drops only pairs the test of λ below drops (KITTI 00's
    # stereo suite: 494k pairs to 7k on a prior map, 432k to 36k in SLAM, where √tr Cov(w) left 173k)
    present = np.bincount(pick, minlength=len(near)) > 0
    sd_ab = np.zeros((len(near), 2))  # bounds of (σ_a, σ_b) along and across the line of sight
    sd_ab[present] = b.line_of_sight_bounds(near_at[present], near_slot[present], points[near[present]])
    # what depends on the measurement alone or on the candidate alone is computed once each and
    # gathered per pair (the same operations on the same numbers: the same bits as per pair)
    r_c = np.maximum(near_dist, 1e-9)
    sd_th = np.sqrt(b.pose_cov[:, 2, 2])[b.at][mi]
    var_b, var_r = (b.meas["sigma_bearing_rad"] ** 2)[mi], (b.meas["sigma_range_m"] ** 2)[mi]
    s_bb = var_b + ((sd_ab[:, 1] / r_c)[pick] + sd_th) ** 2  # σ_b² + (σ_across/r_j + σ_θ)²
    s_rr = var_r + (sd_ab[:, 0] ** 2)[pick]  # σ_r² + σ_along²
    # the remainder at those bounds of σ_a, σ_b, whitened by R (diagonal: :func:`_whitened` with no cross
    # term), its box and squares once per candidate
    rho_b, rho_r, within = _taylor_box(sd_ab, r_c, far_k)
    inv_r = (1.0 / b.meas["sigma_bearing_rad"] ** 2, 1.0 / b.meas["sigma_range_m"] ** 2)
    q = (rho_b[:, 0] ** 2)[pick] * inv_r[0][mi] + (rho_r[:, 0] ** 2)[pick] * inv_r[1][mi]
    rho_up = np.where(within[pick, 0], np.sqrt(q), np.inf)
    box = (rho_b, rho_r, within)
    rough = np.sqrt(np.maximum(d[:, 0] ** 2 / s_bb, d[:, 1] ** 2 / s_rr)) <= (math.sqrt(gate) + FAR_SIGMAS + rho_up) * (
        1.0 + 1e-9
    )
    pick, mi, d = pick[rough], mi[rough], d[rough]
    # then from candidate j's moments alone: H_j P H_jᵀ once per (keyframe, candidate), each pair's
    # S_j and λ (cheap: 2 × 2); the test of λ first with the remainder at those bounds of σ_a, σ_b (the
    # same λ and whitening, and the remainder's arithmetic non-decreasing in σ: it drops only pairs the
    # test at the candidate's own spreads drops), then at the spreads, computed for the candidates
    # left only; the full moments of those only
    present = np.bincount(pick, minlength=len(near)) > 0
    cand = Candidates.of(b, points, near[present], near_at[present], near_slot[present])
    back = (np.cumsum(present) - 1)[pick]
    s_j, lam, s_inv = candidate_moments(b, mi, cand, back, d)
    whiten_j = noise_inverse(b, mi) if robust_to_covariance else s_inv
    root_lam = np.sqrt(lam)
    near_enough = (
        root_lam
        <= math.sqrt(gate)
        + FAR_SIGMAS
        + _whitened(tuple(t[pick] for t in box), whiten_j[:, 0, 0], whiten_j[:, 1, 1], whiten_j[:, 0, 1])[:, 0]
    )
    pick, mi, back, d = pick[near_enough], mi[near_enough], back[near_enough], d[near_enough]
    s_j, s_inv, whiten_j, root_lam = s_j[near_enough], s_inv[near_enough], whiten_j[near_enough], root_lam[near_enough]
    sigma_j, range_j = cand.spread(back)
    close = root_lam <= math.sqrt(gate) + FAR_SIGMAS + _remainder(sigma_j, range_j, whiten_j, far_k)[:, 0]
    pick, mi = pick[close], mi[close]
    cj, slot_j = near[pick], near_slot[pick]
    if len(mi) == 0:
        return MeasurementRisk(est, bnd, ncand, lin)
    rho_j = _remainder(sigma_j[close], range_j[close], whiten_j[close])  # (n, K)
    # the range's own bound (no box: the range is 1-Lipschitz in the positions), for pairs the box
    # cannot cover (a landmark nearer the car than a few σ of the estimate)
    by_range = _RangeSeparation(
        np.abs(d[close, 1]), s_j[close, 1, 1], b.meas["sigma_range_m"][mi], np.hypot(*sigma_j[close].T)
    )
    pair = pair_moments(b, points, mi, cj, slot_j, cand.jac[back[close]], cand.e[back[close]])
    # the measured landmark's own term: the associator's reach, judged at the measured range, can
    # leave it out (equal within a measurement: its range, noise and w_i's spread)
    p_out_bound = _out_of_reach(
        b.meas["range_m"][mi], pair.range_i, np.hypot(*pair.sigma_i.T), b.meas["sigma_range_m"][mi]
    )
    # which pairs the linearization fails (the estimate then integrates the nonlinear model)
    right = has_right[mi]
    rho2_i = np.where(right, _remainder(pair.sigma_i, pair.range_i, inverse_2x2(pair.s_i), _K_GRID[1:2])[:, 0], 0.0)
    bent = bent_pairs(rho2_i, _remainder(sigma_j[close], range_j[close], s_inv[close], _K_GRID[1:2])[:, 0], pair.lam)
    # where the right landmark may fall out of the associator's reach (a stereo camera's range noise
    # shortens the measured range), the linearized estimate, which has no reach, is stratified on the
    # range noise (nonlinear.reach_tail_estimate); the bent pairs' quadrature keeps the reach already
    strata = reach_strata(
        pair,
        ~bent,
        right,
        b.meas["range_m"][mi],
        b.meas["sigma_range_m"][mi],
        range_j[close],
        sigma_j[close, 0],
    )
    return _bounds(
        pair,
        mi,
        b.at[mi],
        rho_j,
        by_range,
        p_out_bound,
        _Bent(bent, b, points, cj, strata),
        has_right,
        n_landmarks=len(points),
        gate=gate,
        linear=linear,
        robust_to_covariance=robust_to_covariance,
        estimate=estimate,
    )


@dataclass(frozen=True, eq=False)
class ReachStrata:
    """The pairs whose linearized estimate is stratified on the range noise, because the associator's
    reach, judged at the measured range, can change them (:func:`reach_strata`). Per pair (n,):

    Attributes:
        mask: bool, the pairs stratified.
        upper: bool, of those, the farther candidates: within reach only in the range noise's upper
            tail; else the right landmark may fall out of reach in its lower tail.
        tail: the probability of that tail (0 where not stratified).
    """

    mask: np.ndarray
    upper: np.ndarray
    tail: np.ndarray

    def estimate(
        self, p: np.ndarray, keyframe: np.ndarray, pairs_of: Callable[[np.ndarray], BentPairs], gate: float
    ) -> np.ndarray:
        """(n,) the pairs' estimates ``p`` (n,) stratified (:func:`.nonlinear.reach_tail_estimate`), the
        pairs' keyframes ``keyframe`` (n,); ``pairs_of(mask)``: the quadrature's pairs of a mask. A
        farther candidate whose linearized estimate is at most :data:`REACH_FLOOR` (or its tail below
        1e-250, where the tail's points would underflow) takes min(p_j, t) instead (p_j = t q_j ≤ t):
        no quadrature for what no figure shows."""
        small = self.upper & ((p <= REACH_FLOOR) | (self.tail < 1e-250))
        p = np.where(small, np.minimum(p, self.tail), p)
        sel = self.mask & ~small
        if not sel.any():
            return p
        reach = (CANDIDATE_SCALE, CANDIDATE_MARGIN_M)
        return reach_tail_estimate(p, sel, keyframe, self.tail[sel], self.upper[sel], pairs_of(sel), gate, reach)


def reach_strata(
    pair: Pairs,
    eligible: np.ndarray,
    right: np.ndarray,
    range_m: np.ndarray,
    sigma_range_m: np.ndarray,
    range_j_m: np.ndarray,
    sigma_along_j_m: np.ndarray,
) -> ReachStrata:
    """The pairs among ``eligible`` (n,) (not bent: the quadrature keeps the reach already) whose
    estimate the reach changes, the measurement's true range ``range_m`` (n,) [m] and noise
    ``sigma_range_m`` (n,) [m], the candidate's true distance ``range_j_m`` (n,) [m] and its error
    along the line of sight ``sigma_along_j_m`` (n,) [m]:

    - a nearer candidate, the right landmark a candidate (``right`` (n,)): the measured landmark out
      of reach with probability above :data:`REACH_SHARE` (:func:`out_of_reach_estimate`), and the
      candidate nearer the car than it beyond REACH_SIGMAS of both estimates' errors along the line
      of sight (a farther candidate is out of reach whenever the right one is; d's range part is
      r_i − r_j); its stratum is the lower tail of :func:`reach_tail`;
    - a farther candidate, out of reach at the true range even REACH_SIGMAS σ nearer: within it only
      where the measured range is long, the upper tail of :func:`reach_upper_tail` (below it the
      associator never takes it; the linearized estimate, which has no reach, counts it there: on
      KITTI 03 a pole 33 m beyond a stereo camera's measured one, 12x the observed rate)."""
    near = eligible & right & (out_of_reach_estimate(pair.range_i, pair.sigma_i[:, 0], sigma_range_m) > REACH_SHARE)
    near &= pair.d[:, 1] > -REACH_SIGMAS * (pair.sigma_i[:, 0] + sigma_along_j_m)
    upper_tail = reach_upper_tail(range_m, sigma_range_m, range_j_m, sigma_along_j_m)
    far = eligible & ~near & (upper_tail < 0.5)
    tail = np.where(far, upper_tail, np.where(near, reach_tail(pair.range_i, pair.sigma_i[:, 0], sigma_range_m), 0.0))
    return ReachStrata(near | far, far, tail)


def reach_upper_tail(
    range_m: np.ndarray, sigma_range_m: np.ndarray, range_j_m: np.ndarray, sigma_along_j_m: np.ndarray
) -> np.ndarray:
    """(n,) the probability of the range noise's upper tail above which a candidate at ``range_j_m``
    [m] from the car (its error along the line of sight up to REACH_SIGMAS × ``sigma_along_j_m``) can be
    within the associator's reach of a measurement of true range ``range_m`` [m], noise
    ``sigma_range_m`` [m]: CANDIDATE_SCALE (r + v_r) + CANDIDATE_MARGIN_M ≥ r_j − REACH_SIGMAS σ_a,j."""
    v_min = (range_j_m - REACH_SIGMAS * sigma_along_j_m - CANDIDATE_MARGIN_M) / CANDIDATE_SCALE - range_m
    return ndtr(-v_min / np.maximum(sigma_range_m, 1e-300))


def out_of_reach_estimate(range_m: np.ndarray, sigma_along_m: np.ndarray, sigma_range_m: np.ndarray) -> np.ndarray:
    """(n,) the probability, to first order, that the associator's reach leaves the measured landmark
    out: its estimated distance r + w_a (w_a its error along the line of sight, std
    ``sigma_along_m``) exceeds CANDIDATE_SCALE (r + v_r) + CANDIDATE_MARGIN_M, v_r the range noise
    (std ``sigma_range_m``), r the true range ``range_m`` [m]. An estimate, not a bound."""
    room = (CANDIDATE_SCALE - 1.0) * range_m + CANDIDATE_MARGIN_M
    return ndtr(-room / np.hypot(sigma_along_m, CANDIDATE_SCALE * sigma_range_m))


def reach_tail(range_m: np.ndarray, sigma_along_m: np.ndarray, sigma_range_m: np.ndarray) -> np.ndarray:
    """(n,) the probability of the range noise's lower tail below which the reach may leave the
    measured landmark out (:func:`out_of_reach_estimate`), its error along the line of sight taken up to
    REACH_SIGMAS σ: v_r < (REACH_SIGMAS σ_a − (CANDIDATE_SCALE − 1) r − CANDIDATE_MARGIN_M) / CANDIDATE_SCALE."""
    room = (CANDIDATE_SCALE - 1.0) * range_m + CANDIDATE_MARGIN_M
    return ndtr((REACH_SIGMAS * sigma_along_m - room) / (CANDIDATE_SCALE * np.maximum(sigma_range_m, 1e-300)))


def _bounds(
    pair: Pairs,
    mi: np.ndarray,
    at: np.ndarray,
    rho_j: np.ndarray,
    by_range: _RangeSeparation,
    p_out: np.ndarray,
    bent: _Bent,
    has_right: np.ndarray,
    *,
    n_landmarks: int,
    gate: float,
    linear: bool,
    robust_to_covariance: bool,
    estimate: bool = True,
) -> MeasurementRisk:
    """The bound, its linearized form and the estimate of each of the m measurements
    (``has_right`` (m,)) from its pairs' moments (``mi``, ``at`` (n,) the pairs' measurements and
    keyframes, ``rho_j``
    (n, K) their remainders over the grid of k, ``by_range`` their range terms, ``p_out`` (n,)
    the bound of P(the measured landmark is out of the associator's reach), equal within a
    measurement), ``n_landmarks`` the landmarks of the map (each one not kept adds FAR_TERM): the
    module docstring's formulas."""
    m = len(has_right)
    lin = np.zeros(m)
    ncand = np.bincount(mi, minlength=m).astype(np.int64)
    lam = pair.lam
    root_g = math.sqrt(gate)
    # the gate terms G_j(γ): the smallest over the grid of k
    g_gate = _gate_grid(root_g, rho_j, lam)  # (n, K)
    k_best = np.argmin(g_gate, axis=1)
    # each kept pair's term floored at FAR_TERM, what it would add if dropped: a pair moving from
    # dropped to kept as the covariance grows never lowers the bound (robust_to_covariance's property)
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
        ps = pair if sel.all() else pair.select(sel)
        rho_i = _remainder(ps.sigma_i, ps.range_i, np.linalg.inv(ps.s_i))  # (n', K): equal within a measurement
        short = np.maximum(np.sqrt(ts)[None, :, None] - rho_i[:, None, :], 0.0)  # (n', T, K)
        g_i = np.ones((m, len(ts)))
        # G_i(t): NIS_i > t, or the measured landmark out of reach (then a candidate in the gate is taken)
        g_i[mi[sel]] = np.min(_K_OUT[None, None, :] + np.exp(-0.5 * short**2), axis=2) + p_out[sel, None]
        sums = _gate_sums(ts, sel, mi[sel], g_i, bnd, at_gate, lam, rho_j, k_best, by_range)
        lnn = np.min(g_i + sums, axis=1)
        bnd = np.where(lower, np.minimum(bnd, lnn), bnd)
    # the landmarks not kept (dropped by the far filter, or beyond the widened reach): both forms of
    # the bound are unions over every landmark, so their residual adds to either
    bnd = np.minimum(1.0, bnd + far_residual(ncand, n_landmarks))
    if linear:  # the same with ρ = 0 and no outside mass
        lin = np.minimum(1.0, np.bincount(mi, weights=f_gate, minlength=m))
        f_t = _ncx2_cdf(ts[None, :], lam[:, None])
        sums = np.zeros((m, len(ts)))
        np.add.at(sums, mi, f_t)
        lin = np.where(has_right, np.minimum(lin, np.min(np.exp(-ts / 2.0)[None, :] + sums, axis=1)), lin)
    # the estimate: pairwise nearest-neighbour probability, capped by the gate's
    if not estimate:  # the caller reads the bounds only
        return MeasurementRisk(np.zeros(m), np.minimum(bnd, 1.0), ncand, np.minimum(lin, 1.0))
    right = has_right[mi]
    p = f_gate.copy()
    if right.any():
        pr = pair if right.all() else pair.select(right)
        p[right] = np.minimum(p_nearer_form(pr.s_i, pr.s_j, pr.c_id, pr.c_d, pr.d), f_gate[right])
    p = bent.estimate(p, pair, mi, at, g_min, right, gate)
    # bincount sums each measurement's terms in order from 0, as np.add.at into zeros did
    logq = np.bincount(mi, weights=np.log1p(-np.clip(p, 0.0, 1.0 - 1e-16)), minlength=m)
    est = np.maximum(-np.expm1(logq), 0.0)
    return MeasurementRisk(est, np.minimum(bnd, 1.0), ncand, np.minimum(lin, 1.0))


def _gate_grid(root_g: float, rho_j: np.ndarray, lam: np.ndarray) -> np.ndarray:
    """(n, K) 4Φ(−k) + F((√γ + ρ_j(k))²; λ_j) of each pair at each k of the grid (``root_g`` √γ,
    ``rho_j`` (n, K), ``lam`` (n,)), where it can be the pair's smallest, else inf: the grid from
    its largest k down, a k skipped once 4Φ(−k) alone exceeds the pair's smallest so far (F ≥ 0, and
    4Φ(−k) grows as k falls: every smaller k is skipped too). The smallest and its first k are those
    of the whole grid (the same numbers where computed; a skipped one is above the smallest)."""
    out, best = np.full(rho_j.shape, np.inf), np.full(len(lam), np.inf)
    for k in range(len(_K_GRID) - 1, -1, -1):
        idx = np.flatnonzero(_K_OUT[k] <= best)
        if len(idx) == 0:
            break
        out[idx, k] = _K_OUT[k] + _ncx2_cdf((root_g + rho_j[idx, k]) ** 2, lam[idx])
        best = np.minimum(best, out[:, k])
    return out


def _gate_sums(
    ts: np.ndarray,
    sel: np.ndarray,
    mi_sel: np.ndarray,
    g_i: np.ndarray,
    level: np.ndarray,
    at_gate: np.ndarray,
    lam: np.ndarray,
    rho_j: np.ndarray,
    k_best: np.ndarray,
    by_range: _RangeSeparation,
) -> np.ndarray:
    """(m, T) Σ_j G_j(t) over each measurement's pairs of ``sel`` (n,) (their measurements ``mi_sel``)
    at each level of ``ts`` (T,), each pair at its gate's k (``k_best``; G_j(t) ≤ G_j(γ) = ``at_gate``,
    which a pair below TINY_TERM takes at every t), exact wherever G_i(t) + the sum can fall
    below the measurement's gate sum ``level`` (m,) (``g_i`` (m, T) its G_i(t)), else a lower bound:
    each term at least min(4Φ(−k), its range term) (F ≥ 0; summed in the same order, so no larger).
    The bound takes min(level, min_t [G_i(t) + Σ_j G_j(t)]): a level where the lower bound already
    reaches ``level`` cannot lower it, and needs no χ'² evaluation (the same bound, bit for bit)."""
    live = sel & (at_gate >= TINY_TERM)
    terms = np.repeat(at_gate[sel][:, None], len(ts), axis=1)
    kb, on = k_best[live], live[sel]
    near = by_range.select(live).bound(ts)
    low = np.minimum(_K_OUT[kb][:, None], near)
    terms[on] = low
    sums = np.zeros(g_i.shape)
    np.add.at(sums, mi_sel, terms)
    r, c = np.nonzero((g_i + sums < level[:, None])[mi_sel[on]])
    if len(r) == 0:
        return sums
    x = (np.sqrt(ts)[c] + rho_j[live][r, kb[r]]) ** 2
    low[r, c] = np.minimum(_K_OUT[kb[r]] + _ncx2_cdf(x, lam[live][r]), near[r, c])
    terms[on] = low
    sums = np.zeros(g_i.shape)
    np.add.at(sums, mi_sel, terms)
    return sums


@dataclass(frozen=True)
class _RangeSeparation:
    """A bound of P(NIS_j ≤ x) for each pair from the range alone, with no box (module docstring,
    "the range's bound"): NIS_j ≥ ν_r² / S_rr (the smallest νᵀS⁻¹ν with a given range component), and
    ν_r = z_r − r̂_j with |r̂_j − r_j| ≤ ‖w_j‖ (the range is 1-Lipschitz in the positions), so
    NIS_j ≤ x only if |v_r| + ‖w_j‖ ≥ D(x) = |r_i − r_j| − √(x S_rr); hence for D > 0, split as
    D = s + t in proportion to σ_r and σ_w,

        P(NIS_j ≤ x) ≤ 2Φ(−s/σ_r) + exp(−t² / (2 σ_w²)),

    σ_w² = σ_a² + σ_b² ≥ the largest eigenvalue of Cov(w_j) (P(‖w‖ ≥ t) ≤ exp(−t²/(2 λ_max)) for a
    2-D Gaussian); 1 where D ≤ 0. Per pair (n,): ``sep_m`` |r_i − r_j| [m], ``s_rr`` S_j's range
    variance [m²], ``sigma_r`` the range noise [m], ``sigma_w`` [m]."""

    sep_m: np.ndarray
    s_rr: np.ndarray
    sigma_r: np.ndarray
    sigma_w: np.ndarray

    def select(self, mask: np.ndarray) -> _RangeSeparation:
        """The pairs of ``mask``."""
        return _RangeSeparation(self.sep_m[mask], self.s_rr[mask], self.sigma_r[mask], self.sigma_w[mask])

    def bound(self, xs: np.ndarray) -> np.ndarray:
        """(n, T) the bound at each level of ``xs`` (T,)."""
        room = self.sep_m[:, None] - np.sqrt(xs[None, :] * self.s_rr[:, None])  # D(x)
        scale = (self.sigma_r + self.sigma_w)[:, None]
        z = np.maximum(room, 0.0) / np.where(scale > 0, scale, 1.0)  # s/σ_r = t/σ_w = D/(σ_r + σ_w)
        out = 2.0 * ndtr(-z) + np.exp(-0.5 * z**2)
        return np.where(room > 0, np.minimum(out, 1.0), 1.0)


def _out_of_reach(range_m: np.ndarray, distance_m: np.ndarray, sigma_w: np.ndarray, sigma_r: np.ndarray) -> np.ndarray:
    """(n,) a bound of P(the measured landmark i is out of the associator's reach) for each of n
    measurements (module docstring, "the reach"): ``range_m`` the true range r [m] the measurement
    is drawn about (r̂ = r + v_r, v_r ~ N(0, σ_r²)), ``distance_m`` the true distance |u_i| of the
    landmark from the car [m], ``sigma_w`` σ_w ≥ √λmax(Cov(w_i)) [m], ``sigma_r`` σ_r [m].

    The estimated distance is |u_i + w_i| ≤ |u_i| + ‖w_i‖, so i is out of reach (beyond
    s r̂ + c) only if ‖w_i‖ − s v_r > D = s r + c − |u_i|. ‖w_i‖ is below σ_w R in distribution
    (R Rayleigh: P(‖w‖ ≥ t) ≤ e^(−t²/(2λmax))), independent of v_r; with τ = s σ_r, q² = σ_w² + τ²,

        P(σ_w R + τ Z > D) = Φ(−D/τ) + (σ_w/q) e^(−D²/(2q²)) Φ(D σ_w/(q τ))   (D > 0; 1 else),

    exact for σ_w R (the Gaussian integral of the Rayleigh tail)."""
    d = CANDIDATE_SCALE * np.asarray(range_m, float) + CANDIDATE_MARGIN_M - np.asarray(distance_m, float)
    sw = np.asarray(sigma_w, float)
    tau = CANDIDATE_SCALE * np.asarray(sigma_r, float)
    q = np.hypot(sw, tau)
    pos = (d > 0) & (q > 0)
    room = np.where(pos, d, 1.0)
    tau_s, q_s = np.where(pos, tau, 1.0), np.where(pos, q, 1.0)
    with np.errstate(divide="ignore"):  # τ = 0 (no range noise): Φ(−∞) = 0, Φ(+∞) = 1
        out = ndtr(-room / tau_s) + sw / q_s * np.exp(-0.5 * (room / q_s) ** 2) * ndtr(room * sw / (q_s * tau_s))
    return np.where(pos, np.minimum(out, 1.0), np.where(d > 0, 0.0, 1.0))


@dataclass(frozen=True, eq=False)
class _Bent:
    """The pairs (``mask`` (n,) bool) whose estimate is the nonlinear model's, and what it reads of
    the batch: the truth of each pair's keyframe, the landmarks, the candidates ``cj`` (n,), and
    the pairs stratified on the range noise (:func:`reach_strata`)."""

    mask: np.ndarray
    batch: Batch
    points: np.ndarray
    cj: np.ndarray
    strata: ReachStrata

    def estimate(
        self,
        p: np.ndarray,
        pair: Pairs,
        mi: np.ndarray,
        at: np.ndarray,
        g_gate: np.ndarray,
        right: np.ndarray,
        gate: float,
    ) -> np.ndarray:
        """(n,) ``p`` with the bent pairs' replaced by the nonlinear model's and the reach pairs'
        stratified on their range noise (:mod:`.nonlinear`), the pairs' measurements ``mi``,
        keyframes ``at`` and bound's gate terms ``g_gate`` (n,) G_j(γ)."""
        reach = (CANDIDATE_SCALE, CANDIDATE_MARGIN_M)
        if self.mask.any():
            sel = self.mask
            p = nonlinear_estimate(p, sel, at, g_gate, self._pairs(pair, mi, right, sel), gate, reach)
        return self.strata.estimate(p, at, lambda sel: self._pairs(pair, mi, right, sel), gate)

    def _pairs(self, pair: Pairs, mi: np.ndarray, right: np.ndarray, sel: np.ndarray) -> BentPairs:
        """What the quadrature reads of the pairs of ``sel``: the truth, both landmarks, the
        noise-free measurement, its noise std, the joint covariance and whether the measured
        landmark is a candidate."""
        b, mb = self.batch, mi[sel]
        z = np.column_stack([b.meas["bearing_rad"][mb], b.meas["range_m"][mb]])
        sd = np.column_stack([b.meas["sigma_bearing_rad"][mb], b.meas["sigma_range_m"][mb]])
        return BentPairs(
            b.poses[b.at[mb]],
            self.points[b.meas["landmark"][mb]],
            self.points[self.cj[sel]],
            z,
            sd,
            pair.joint[sel],
            right[sel],
        )
