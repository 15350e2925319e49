"""The score against an independent oracle: the whitened Jacobian J of the whole factor graph, built
in numpy from the geometry alone, and slogdet(JᵀJ) compared with GTSAM's elimination.

Tangent conventions (GTSAM's): a Pose2 T = (x, y, theta) is perturbed as T * Exp(xi) with
xi = (dx, dy, dtheta) in the *body* frame, so to first order the position moves by R(theta) (dx, dy)
and the heading by dtheta; a Point2 is perturbed by plain addition.

    bearing-range to landmark l from pose T:  d = l - t, r = |d|, b = atan2(d_y, d_x) - theta
        db/dl = (-d_y, d_x) / r^2          db/d(dx, dy) = -(db/dl) R(theta)      db/d(dtheta) = -1
        dr/dl = d / r                       dr/d(dx, dy) = -(dr/dl) R(theta)      dr/d(dtheta) = 0
    odometry, error Log(Z^-1 * T1^-1 T2) with Z = T1^-1 T2 (the truth):
        d/d xi2 = I,     d/d xi1 = -Ad(T12^-1),   Ad(T) = [[R, (t_y, -t_x)^T], [0, 0, 1]]
    priors: identity.
Every row is divided by its sigma (whitening); log det Λ = slogdet(JᵀJ).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sensorsel.api import score_suite
from sensorsel.errors import InputError
from sensorsel.information.evaluators import ReferenceEvaluator, make_evaluator
from sensorsel.model.problem import GraphSettings, build_problem
from sensorsel.model.scenario import Scenario, Trajectory

REL_TOL = 1e-9


def _rot(theta: float) -> np.ndarray:
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s], [s, c]])


def _adjoint(x: float, y: float, theta: float) -> np.ndarray:
    """Adjoint of a Pose2 in GTSAM's (x, y, theta) ordering."""
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s, y], [s, c, -x], [0.0, 0.0, 1.0]])


def odometry_jacobians(p1: np.ndarray, p2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Jacobians of Log(Z^-1 T1^-1 T2) w.r.t. xi1, xi2 at the truth (body-frame perturbations)."""
    # T12^-1 = T2^-1 T1: rotation -(th2 - th1), translation -R(th12)^T t12
    t12 = _rot(p1[2]).T @ (p2[:2] - p1[:2])
    th12 = p2[2] - p1[2]
    t_inv = -_rot(th12).T @ t12
    return -_adjoint(t_inv[0], t_inv[1], -th12), np.eye(3)


def bearing_range_jacobians(pose: np.ndarray, lm: np.ndarray, *, body_frame: bool = True):
    """Rows (bearing, range) w.r.t. pose (dx, dy, dtheta) and landmark (x, y)."""
    d = lm - pose[:2]
    q = float(d @ d)
    r = math.sqrt(q)
    db_dl = np.array([-d[1], d[0]]) / q
    dr_dl = d / r
    rot = _rot(pose[2]) if body_frame else np.eye(2)
    jp = np.array([[*(-db_dl @ rot), -1.0], [*(-dr_dl @ rot), 0.0]])
    jl = np.vstack([db_dl, dr_dl])
    return jp, jl


def whitened_jacobian(problem, suite, *, body_frame: bool = True, odometry_x1=None) -> np.ndarray:
    """The whole graph's whitened Jacobian, dense: poses first (3 each), then landmarks (2 each)."""
    sc, st = problem.scenario, problem.settings
    poses, lms = sc.keyframes.poses, sc.landmarks
    k_n, m_n = len(poses), len(lms)
    n = 3 * k_n + 2 * m_n
    blocks = []

    def add(rows_by_var: dict[int, np.ndarray], sigmas) -> None:
        sig = np.asarray(sigmas, float)
        rows = np.zeros((len(sig), n))
        for col, jac in rows_by_var.items():
            rows[:, col : col + jac.shape[1]] = jac
        blocks.append(rows / sig[:, None])

    add({0: np.eye(3)}, st.first_pose_sigmas)
    for k in range(1, k_n):
        j1, j2 = odometry_jacobians(poses[k - 1], poses[k])
        if odometry_x1 is not None:
            j1 = odometry_x1(poses[k - 1], poses[k])
        add({3 * (k - 1): j1, 3 * k: j2}, st.odometry_sigmas)
    for j in range(m_n):
        add({3 * k_n + 2 * j: np.eye(2)}, [st.landmark_prior_sigma_m] * 2)
    for i in suite:
        o = problem.observations[i]
        for k, j, sb, sr in zip(o.pose, o.landmark, o.sigma_bearing_rad, o.sigma_range_m):
            jp, jl = bearing_range_jacobians(poses[k], lms[j], body_frame=body_frame)
            add({3 * int(k): jp, 3 * k_n + 2 * int(j): jl}, [sb, sr])
    return np.vstack(blocks)


def dense_logdet(jac: np.ndarray) -> float:
    sign, logdet = np.linalg.slogdet(jac.T @ jac)
    assert sign == 1.0
    return float(logdet)


def scene(poses, landmarks, name="hand") -> Scenario:
    poses = np.asarray(poses, float)
    return Scenario(
        name, Trajectory(poses, np.arange(len(poses), dtype=float), np.arange(len(poses))), np.asarray(landmarks, float)
    )


def circle_scenario() -> Scenario:
    """12 keyframes around a circle of radius 30 m (headings through +-pi), landmarks in and out."""
    a = np.linspace(0, 1.9 * np.pi, 12)
    poses = np.column_stack([30 * np.cos(a), 30 * np.sin(a), a + np.pi / 2])
    rng = np.random.default_rng(21)
    ang, rad = rng.uniform(0, 2 * np.pi, 25), rng.uniform(5, 70, 25)
    return scene(poses, np.column_stack([rad * np.cos(ang), rad * np.sin(ang)]), "circle")


def westward_scenario() -> Scenario:
    """A car driving west (heading ~pi) past a few landmarks, with a slight weave."""
    x = -np.arange(0, 60.0, 7.5)
    th = np.pi + 0.05 * np.sin(np.arange(len(x)))
    poses = np.column_stack([x, 0.4 * np.sin(np.arange(len(x))), th])
    lm = [[-20.0, 8.0], [-35.0, -6.0], [-70.0, 1.0], [10.0, 3.0], [-50.0, 30.0]]
    return scene(poses, lm, "west")


SUITES = [
    "",
    "LRL-roof",
    "LRR-12",
    "LRR-12,LRR-3,LRR-6,LRR-9",
    "WSC-12,HD2K-3,LSC-9",
    "MRL-roof,MRR-1,WSC-6",
    "LRL-roof,MRL-roof,WSC-12,WSC-3,WSC-6,WSC-9,HD2K-1,LSC-7",
]


def _check(problem, suite_text: str, **settings) -> None:
    suite = problem.library.parse_suite(suite_text)
    ev = ReferenceEvaluator(problem)
    gtsam_logdet = ev.logdet(suite)
    oracle = dense_logdet(whitened_jacobian(problem, suite))
    assert abs(oracle - gtsam_logdet) <= REL_TOL * abs(gtsam_logdet), (suite_text, oracle, gtsam_logdet)


@pytest.mark.parametrize("suite_text", SUITES)
def test_gtsam_logdet_equals_dense_oracle_on_tiny(tiny_problem, suite_text):
    _check(tiny_problem, suite_text)


def test_gtsam_logdet_equals_dense_oracle_on_tiny_all_62(tiny_problem):
    suite = tuple(range(62))
    gtsam_logdet = ReferenceEvaluator(tiny_problem).logdet(suite)
    oracle = dense_logdet(whitened_jacobian(tiny_problem, suite))
    assert abs(oracle - gtsam_logdet) <= REL_TOL * abs(gtsam_logdet)


@pytest.mark.parametrize("suite_text", ["LRL-roof", "LRR-12,LRR-3,LRR-6,LRR-9", "WSC-12,HD2K-3,LSC-9"])
def test_gtsam_logdet_equals_dense_oracle_on_suburb(suburb_problem, suite_text):
    _check(suburb_problem, suite_text)


@pytest.mark.parametrize("make", [circle_scenario, westward_scenario])
@pytest.mark.parametrize("suite_text", ["", "LRL-roof", "WSC-12,WSC-3,LRR-9", "HD2K-12,HD2K-6,MRR-2,LSC-4,MRL-roof"])
def test_gtsam_logdet_equals_dense_oracle_on_hand_built_scenarios(library, make, suite_text):
    settings = GraphSettings(
        odometry_sigmas=(0.3, 0.05, 0.02), first_pose_sigmas=(0.1, 0.2, 0.01), landmark_prior_sigma_m=50.0
    )
    problem = build_problem(library, make(), settings)
    suite = library.parse_suite(suite_text)
    if suite_text:
        assert sum(len(problem.observations[i]) for i in suite) > 0  # the suite measures something here
    _check(problem, suite_text)


def test_oracle_detects_a_wrong_tangent_convention(library):
    """The comparison has teeth: world-frame pose Jacobians in the bearing-range rows, or a plain -I
    odometry Jacobian, give a different log det (so agreement above is not an accident)."""
    problem = build_problem(library, circle_scenario())
    suite = library.parse_suite("LRL-roof,WSC-12")
    ref = ReferenceEvaluator(problem).logdet(suite)
    world = dense_logdet(whitened_jacobian(problem, suite, body_frame=False))
    naive = dense_logdet(whitened_jacobian(problem, suite, odometry_x1=lambda p1, p2: -np.eye(3)))
    # both miss by far more than the tolerance of the comparison
    assert abs(world - ref) > 1e3 * REL_TOL * abs(ref)
    assert abs(naive - ref) > 1e3 * REL_TOL * abs(ref)


def _numeric_jacobian(f, x0: np.ndarray, eps: float = 1e-6) -> np.ndarray:
    cols = []
    for a in range(len(x0)):
        e = np.zeros(len(x0))
        e[a] = eps
        cols.append((f(x0 + e) - f(x0 - e)) / (2 * eps))
    return np.column_stack(cols)


def _retract(pose: np.ndarray, xi: np.ndarray) -> np.ndarray:
    """T * Exp(xi) to first order in xi: the first derivative at xi = 0, all the test needs, is exact."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return np.array([pose[0] + c * xi[0] - s * xi[1], pose[1] + s * xi[0] + c * xi[1], pose[2] + xi[2]])


def _between(p1: np.ndarray, p2: np.ndarray) -> np.ndarray:
    t = _rot(p1[2]).T @ (p2[:2] - p1[:2])
    return np.array([t[0], t[1], p2[2] - p1[2]])


def _local(z: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Log(Z^-1 P) to first order near identity (the coordinates of between(Z, P))."""
    b = _between(z, p)
    return np.array([b[0], b[1], (b[2] + math.pi) % (2 * math.pi) - math.pi])


def test_oracle_jacobians_match_finite_differences():
    """The analytic Jacobians of the oracle against central differences of numpy's own Pose2 algebra."""
    rng = np.random.default_rng(5)
    for _ in range(5):
        p1 = np.array([*rng.uniform(-20, 20, 2), rng.uniform(-np.pi, np.pi)])
        p2 = np.array([*rng.uniform(-20, 20, 2), rng.uniform(-np.pi, np.pi)])
        z = _between(p1, p2)  # the odometry measurement at the truth

        def err(x1, x2):
            return _local(z, _between(x1, x2))

        j1, j2 = odometry_jacobians(p1, p2)
        np.testing.assert_allclose(_numeric_jacobian(lambda xi: err(_retract(p1, xi), p2), np.zeros(3)), j1, atol=1e-6)
        np.testing.assert_allclose(_numeric_jacobian(lambda xi: err(p1, _retract(p2, xi)), np.zeros(3)), j2, atol=1e-6)

        lm = rng.uniform(-40, 40, 2)

        def br(pose, point):
            d = point - pose[:2]
            return np.array([math.atan2(d[1], d[0]) - pose[2], math.hypot(d[0], d[1])])

        jp, jl = bearing_range_jacobians(p1, lm)
        np.testing.assert_allclose(_numeric_jacobian(lambda xi: br(_retract(p1, xi), lm), np.zeros(3)), jp, atol=1e-6)
        np.testing.assert_allclose(_numeric_jacobian(lambda dl: br(p1, lm + dl), np.zeros(2)), jl, atol=1e-6)


# ------------------------------------------------------------------------------- score properties


def test_empty_suite_scores_zero(suburb_problem):
    ev = make_evaluator(suburb_problem, "reference")
    assert ev.score(()) == 0.0
    assert ev.baseline_logdet == ev.logdet(())
    # the baseline is the odometry + priors graph: the oracle with no measurement rows
    ref = dense_logdet(whitened_jacobian(suburb_problem, ()))
    assert abs(ev.baseline_logdet - ref) <= REL_TOL * abs(ref)


def test_adding_a_sensor_never_lowers_the_score(suburb_problem):
    ev = ReferenceEvaluator(suburb_problem)
    rng = np.random.default_rng(2024)
    increments = []
    for _ in range(3):
        chain = rng.permutation(62)[:7]
        prev = 0.0
        for t in range(1, len(chain) + 1):
            f = ev.score(chain[:t])
            assert f >= prev - 1e-9 * abs(ev.baseline_logdet), (chain[:t], f, prev)
            increments.append(f - prev)
            prev = f
    assert max(increments) > 1.0  # the chains do add information


def test_a_sensor_that_sees_nothing_adds_exactly_zero(library):
    # every landmark ahead of a car driving along +x: the rear radar sees none of them
    x = np.arange(0.0, 50.0, 10.0)
    sc = scene(np.column_stack([x, np.zeros_like(x), np.zeros_like(x)]), [[150.0, 1.0], [180.0, -2.0], [200.0, 0.5]])
    problem = build_problem(library, sc)
    rear, front = library.position("LRR-6"), library.position("LRR-12")
    assert len(problem.observations[rear]) == 0 and len(problem.observations[front]) > 0
    ev = ReferenceEvaluator(problem)
    assert ev.score([rear]) == 0.0
    assert ev.score([front, rear]) == ev.score([front])
    assert ev.score([front]) > 0.0


def test_unseen_landmark_prior_cancels_in_the_score(library):
    """A landmark no sensor of the suite sees changes log det (its prior) but not the score."""
    base = westward_scenario()
    far = scene(base.keyframes.poses, np.vstack([base.landmarks, [[5000.0, 5000.0]]]))
    suite = library.parse_suite("LRL-roof,WSC-12")
    ev_a, ev_b = ReferenceEvaluator(build_problem(library, base)), ReferenceEvaluator(build_problem(library, far))
    assert ev_a.logdet(suite) != ev_b.logdet(suite)
    assert ev_b.score(suite) == pytest.approx(ev_a.score(suite), rel=1e-12, abs=1e-9)


def test_score_suite_reports_what_the_evaluator_computes(tiny_problem):
    res = score_suite(tiny_problem, "LRR-12,LRL-roof", engine="reference")
    suite = tiny_problem.library.parse_suite("LRR-12,LRL-roof")
    ev = ReferenceEvaluator(tiny_problem)
    assert res.suite == ("LRL-roof", "LRR-12") and res.cost_usd == 101_493
    assert res.logdet == ev.logdet(suite) and res.baseline_logdet == ev.baseline_logdet
    assert res.score == res.logdet - res.baseline_logdet > 0
    obs = [tiny_problem.observations[i] for i in suite]
    assert res.n_measurements == sum(len(o) for o in obs)
    assert res.n_landmarks_seen == len(set().union(*(o.landmark.tolist() for o in obs)))
    assert res.engine == "reference"


def test_evaluator_input_checks(tiny_problem):
    ev = make_evaluator(tiny_problem, "reference")
    with pytest.raises(InputError, match="62"):
        ev.logdet([62])
    with pytest.raises(InputError, match="unknown engine 'nope'"):
        make_evaluator(tiny_problem, "nope")
    before = ev.n_evaluations
    np.testing.assert_array_equal(ev.scores_with((0,), [3, 30]), [ev.score((0, 3)), ev.score((0, 30))])
    assert ev.n_evaluations > before
