"""The fast engine gives the reference's numbers (issue 5).

Oracles: the GTSAM reference (build, linearize, eliminate every suite), GTSAM's own per-factor
linearization, and hand geometry for the range-bearing Jacobian. Agreement is asked to 1e-9
relative (of max(1, |value|)) on every evaluation: the empty suite, the full library, random
suites, and f(S + c) through ``scores_with``. ``jobs`` must not change a single bit.
"""

from __future__ import annotations

import gtsam
import numpy as np
import pytest

from sensorsel import fast
from sensorsel.errors import InputError
from sensorsel.fast import FastEvaluator
from sensorsel.graph import GraphBuilder, linearize_library
from sensorsel.objective import DEFAULT_ENGINE, ENGINES, ReferenceEvaluator, make_evaluator

REL = 1e-9


def close(a: float, b: float) -> bool:
    return abs(a - b) <= REL * max(1.0, abs(b))


def random_suites(n_sensors: int, count: int, seed: int) -> list[tuple[int, ...]]:
    rng = np.random.default_rng(seed)
    suites = [(), tuple(range(n_sensors))]
    for _ in range(count):
        size = int(rng.integers(1, min(12, n_sensors) + 1))
        suites.append(tuple(sorted(rng.choice(n_sensors, size=size, replace=False).tolist())))
    return suites


def assert_engines_agree(problem, suites) -> None:
    fe, re = FastEvaluator(problem), ReferenceEvaluator(problem)
    assert close(fe.baseline_logdet, re.baseline_logdet)
    for s in suites:
        lf, lr = fe.logdet(s), re.logdet(s)
        assert close(lf, lr), (s, lf, lr)
        assert close(fe.score(s), re.score(s)), (s, fe.score(s), re.score(s))
    assert fe.score(()) == 0.0


# --------------------------------------------------------------------------- linearization


def test_whitened_blocks_are_gtsams_own_linearization(tiny_problem):
    lin = linearize_library(tiny_problem)
    builder = GraphBuilder(tiny_problem)
    checked = 0
    for sensor in (0, 1, 25, 38, 50):  # LiDARs, radars, cameras (range noise growing with distance)
        graph = gtsam.NonlinearFactorGraph()
        builder.add_sensor(graph, sensor)
        if graph.size() == 0:
            continue
        gauss = graph.linearize(builder.values)
        A, B = lin.whitened_blocks(sensor)
        assert A.shape == (graph.size(), 2, 3) and B.shape == (graph.size(), 2, 2)
        for i in range(graph.size()):
            jac, _ = gauss.at(i).jacobian()  # columns: pose (3), landmark (2), rows whitened
            np.testing.assert_allclose(np.hstack([A[i], B[i]]), jac, rtol=1e-12, atol=1e-12 * np.abs(jac).max())
            checked += 1
    assert checked > 50


def test_unit_jacobian_matches_hand_geometry(suburb_problem):
    """Bearing and range of landmark l from pose (t, θ), differentiated by hand: local point
    q = R(θ)^T (l - t); pose perturbation (dx, dy, dθ) in the body frame moves q by
    (-dx + q_y dθ, -dy - q_x dθ); the landmark moves q by R(θ)^T dl."""
    lin = linearize_library(suburb_problem)
    poses, points = suburb_problem.scenario.keyframes.poses, suburb_problem.scenario.landmarks
    rng = np.random.default_rng(3)
    for p in rng.choice(len(lin.pair_pose), size=40, replace=False):
        x, y, th = poses[lin.pair_pose[p]]
        c, s = np.cos(th), np.sin(th)
        rt = np.array([[c, s], [-s, c]])
        q = rt @ (points[lin.pair_landmark[p]] - [x, y])
        r2 = q @ q
        dq_pose = np.array([[-1.0, 0.0, q[1]], [0.0, -1.0, -q[0]]])
        dbearing = np.array([-q[1], q[0]]) / r2
        drange = q / np.sqrt(r2)
        want = np.vstack([np.hstack([dbearing @ dq_pose, dbearing @ rt]), np.hstack([drange @ dq_pose, drange @ rt])])
        np.testing.assert_allclose(lin.pair_jacobian[p], want, rtol=1e-9, atol=1e-12)


def test_base_information_is_gtsams_hessian_of_the_base_graph(tiny_problem):
    lin = linearize_library(tiny_problem)
    builder = GraphBuilder(tiny_problem)
    gauss = builder.base_graph().linearize(builder.values)
    K, M = tiny_problem.scenario.n_poses, tiny_problem.scenario.n_landmarks
    pose_cols, lm_cols = {}, {}
    keys = gauss.keyVector()
    # hessian() orders variables as keyVector(); rebuild the per-variable column offsets
    off = 0
    for key in keys:
        sym = gtsam.Symbol(key)
        dim = 3 if chr(sym.chr()) == "x" else 2
        (pose_cols if dim == 3 else lm_cols)[sym.index()] = off
        off += dim
    hess, _ = gauss.hessian()
    want_pp = np.zeros((3 * K, 3 * K))
    for a in range(K):
        for b in range(K):
            want_pp[3 * a: 3 * a + 3, 3 * b: 3 * b + 3] = hess[pose_cols[a]: pose_cols[a] + 3, pose_cols[b]: pose_cols[b] + 3]
    np.testing.assert_allclose(lin.base_pose_information.toarray(), want_pp, rtol=1e-12, atol=1e-9)
    for j in range(M):
        np.testing.assert_allclose(lin.base_landmark_information[j], hess[lm_cols[j]: lm_cols[j] + 2, lm_cols[j]: lm_cols[j] + 2], rtol=1e-12)


# --------------------------------------------------------------------------- the engine


def test_fast_is_registered_and_the_default(tiny_problem):
    assert "fast" in ENGINES and DEFAULT_ENGINE == "fast"
    ev = make_evaluator(tiny_problem)
    assert isinstance(ev, FastEvaluator) and ev.name == "fast"
    assert make_evaluator(tiny_problem, "fast", jobs=3).jobs == 3


@pytest.mark.parametrize("fixture", ["tiny", "suburb"])
def test_fast_agrees_with_the_reference_on_random_suites(fixture, request):
    problem = request.getfixturevalue(f"{fixture}_problem")
    assert_engines_agree(problem, random_suites(problem.n_sensors, 25, seed=5))


@pytest.mark.kitti
def test_fast_agrees_with_the_reference_on_kitti03(kitti03_problem):
    # the full library, the empty suite and a handful of random ones (the reference takes ~0.05-0.3 s each)
    assert_engines_agree(kitti03_problem, random_suites(kitti03_problem.n_sensors, 4, seed=11))
    fe, re = FastEvaluator(kitti03_problem, jobs=2, threads_from_keyframes=0), ReferenceEvaluator(kitti03_problem)
    base = kitti03_problem.library.parse_suite("LRL-roof,HD2K-4")
    cands = [0, 3, 17, 30, 45, 61]
    got = fe.scores_with(base, cands)
    for c, v in zip(cands, got):
        assert close(v, re.score(base + (c,))), (c, v)
    assert np.array_equal(got, FastEvaluator(kitti03_problem, jobs=1).scores_with(base, cands))


@pytest.mark.parametrize("fixture", ["tiny", "suburb"])
def test_scores_with_agrees_with_score_and_with_the_reference(fixture, request):
    problem = request.getfixturevalue(f"{fixture}_problem")
    fe, re = FastEvaluator(problem), ReferenceEvaluator(problem)
    lib = problem.library
    for base in [(), lib.parse_suite("LRL-roof"), lib.parse_suite("LRR-12,WSC-3,HD2K-9")]:
        cands = list(range(problem.n_sensors))  # members of the base included: f(S + c) = f(S)
        got = fe.scores_with(base, cands)
        assert got.shape == (len(cands),)
        for c, v in zip(cands, got):
            assert close(v, fe.score(base + (c,))), (base, c)
        for c in (0, 1, 25, 30, 50, 61):
            assert close(got[c], re.score(base + (c,))), (base, c)


def test_jobs_do_not_change_a_bit(suburb_problem):
    lib = suburb_problem.library
    cands = list(range(suburb_problem.n_sensors))
    for base in [(), lib.parse_suite("LRL-roof,LRR-12")]:
        one = FastEvaluator(suburb_problem, jobs=1).scores_with(base, cands)
        # threads from any size: the threaded path itself must not change a bit
        two = FastEvaluator(suburb_problem, jobs=2, threads_from_keyframes=0).scores_with(base, cands)
        assert np.array_equal(one, two) and one.tobytes() == two.tobytes()


def test_n_evaluations_counts_every_suite_scored(tiny_problem):
    ev = FastEvaluator(tiny_problem, jobs=2, threads_from_keyframes=0)
    ev.logdet([0])
    assert ev.n_evaluations == 1
    ev.scores_with([0], [1, 2, 3])
    assert ev.n_evaluations == 1 + 1 + 3  # + the baseline (empty suite), scored once
    ev.scores_with([0, 1], [5])
    assert ev.n_evaluations == 6


def test_bad_sensor_positions_are_input_errors(tiny_problem):
    ev = FastEvaluator(tiny_problem)
    with pytest.raises(InputError, match="62"):
        ev.scores_with([0], [62])
    with pytest.raises(InputError, match="-1"):
        ev.scores_with([-1], [0])
    with pytest.raises(InputError, match="99"):
        ev.logdet([99])


@pytest.mark.parametrize("sparse_below", [0.0, 1.1])
@pytest.mark.parametrize("use_blas", [True, False])
def test_every_factorization_path_agrees_with_the_reference(suburb_problem, monkeypatch, sparse_below, use_blas):
    """Dense (in-place BLAS or numpy) and sparse factorizations of the pose matrix: same numbers."""
    monkeypatch.setattr(fast, "SPARSE_BELOW", sparse_below)
    fe, re = FastEvaluator(suburb_problem), ReferenceEvaluator(suburb_problem)
    if not use_blas:
        fe._s.blas.available = False
    lib = suburb_problem.library
    for s in [(), lib.parse_suite("LRR-12"), lib.parse_suite("LRL-roof,WSC-3,HD2K-9"), tuple(range(suburb_problem.n_sensors))]:
        assert close(fe.logdet(s), re.logdet(s)), s
    base = lib.parse_suite("LRL-roof")
    for c, v in zip([1, 30, 50], fe.scores_with(base, [1, 30, 50])):
        assert close(v, re.score(base + (c,)))


def test_a_sensor_that_sees_nothing_adds_exactly_nothing(tiny_problem):
    from sensorsel.problem import build_problem
    from sensorsel.scenario import Scenario

    sc = tiny_problem.scenario
    far = Scenario(name="far", keyframes=sc.keyframes, landmarks=sc.landmarks + 1e5, landmark_source="moved")
    problem = build_problem(tiny_problem.library, far)
    assert all(len(o) == 0 for o in problem.observations)
    ev = FastEvaluator(problem)
    assert ev.logdet(()) == ev.logdet(tuple(range(problem.n_sensors)))
    assert np.all(ev.scores_with((), [0, 1, 2]) == 0.0)
    assert close(ev.baseline_logdet, ReferenceEvaluator(problem).baseline_logdet)
