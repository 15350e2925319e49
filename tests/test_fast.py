"""The fast engine gives the reference's numbers.

Oracles: the GTSAM reference (build, linearize, eliminate every suite), GTSAM's own per-factor
linearization, and hand geometry for the range-bearing Jacobian. Agreement is asked to 1e-9
relative (of max(1, |value|)) on every evaluation: the empty suite, the full library, random
suites, and f(S + c) through ``scores_with``. ``jobs`` must not change a single bit.
"""

from __future__ import annotations

import gtsam
import numpy as np
import pytest

from sensorsel.errors import InputError
from sensorsel.information.evaluators import (
    DEFAULT_ENGINE,
    ENGINES,
    FastEvaluator,
    ReferenceEvaluator,
    make_evaluator,
    register,
)
from sensorsel.information.evaluators.fast.blas import Blas
from sensorsel.information.evaluators.fast.front import _split_runs
from sensorsel.information.graph import GraphBuilder
from sensorsel.information.linearize import linearize_library

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


def _gtsam_pair_jacobians(problem, lin, pairs) -> np.ndarray:
    """(n, 2, 5) GTSAM's own linearization of one unit-noise BearingRangeFactor2D per pair."""
    from sensorsel.information.graph import add_bearing_range

    sc = problem.scenario
    pk, pj = lin.pair_pose[pairs], lin.pair_landmark[pairs]
    d = sc.landmarks[pj] - sc.keyframes.poses[pk, :2]
    graph = gtsam.NonlinearFactorGraph()
    add_bearing_range(
        graph,
        pk,
        pj,
        np.arctan2(d[:, 1], d[:, 0]) - sc.keyframes.poses[pk, 2],
        np.hypot(d[:, 0], d[:, 1]),
        gtsam.noiseModel.Unit.Create(2),
    )
    gauss = graph.linearize(GraphBuilder(problem).values)
    out = np.zeros((len(pairs), 2, 5))
    for i in range(gauss.size()):
        f = gauss.at(i)
        jac, _ = f.jacobian()  # columns in the factor's key order: X(k) then L(j)
        assert gtsam.Symbol(f.keys()[0]).chr() == ord("x")
        out[i] = jac
    return out


@pytest.mark.parametrize("which", ["tiny", "suburb", "kitti03"])
def test_closed_form_pair_jacobians_are_gtsams_linearization(which, tiny_problem, suburb_problem, request):
    """Every pair of the fixtures (a random 3,000 of KITTI 03's), against GTSAM's linearization of
    the pair's BearingRangeFactor2D: to 1e-12 of the row's largest entry."""
    problem = {"tiny": tiny_problem, "suburb": suburb_problem}.get(which) or request.getfixturevalue("kitti03_problem")
    lin = linearize_library(problem)
    n = len(lin.pair_pose)
    pairs = np.arange(n) if n <= 3000 else np.sort(np.random.default_rng(16).choice(n, 3000, replace=False))
    want = _gtsam_pair_jacobians(problem, lin, pairs)
    got = lin.pair_jacobian[pairs]
    scale = np.abs(want).max(axis=2, keepdims=True)
    assert np.all(np.abs(got - want) <= 1e-12 * np.maximum(scale, 1.0)), np.abs(got - want).max()
    assert len(pairs) >= min(n, 3000) > 100


def test_closed_form_jacobians_hold_at_every_heading_and_range():
    """Random geometry through the ±π seam of the heading and the bearing, 1 m to 2 km away."""
    from sensorsel.information.linearize import bearing_range_jacobians

    rng = np.random.default_rng(7)
    n = 400
    poses = np.column_stack(
        [
            rng.uniform(-500, 500, n),
            rng.uniform(-500, 500, n),
            np.r_[rng.uniform(-np.pi, np.pi, n - 4), [np.pi, -np.pi, np.nextafter(np.pi, 0), 0.0]],
        ]
    )
    dist = np.exp(rng.uniform(0.0, np.log(2000.0), n))
    angle = np.r_[rng.uniform(-np.pi, np.pi, n - 4), [np.pi, -np.pi, np.pi / 2, 0.0]]
    points = poses[:, :2] + dist[:, None] * np.column_stack([np.cos(angle), np.sin(angle)])
    got = bearing_range_jacobians(poses, points)
    for i in range(n):
        pose = gtsam.Pose2(*poses[i])
        point = gtsam.Point2(*points[i])
        local = pose.transformTo(point)
        f = gtsam.BearingRangeFactor2D(
            gtsam.symbol("x", 0),
            gtsam.symbol("l", 0),
            gtsam.Rot2(np.arctan2(local[1], local[0])),
            float(np.hypot(*local)),
            gtsam.noiseModel.Unit.Create(2),
        )
        values = gtsam.Values()
        values.insert(gtsam.symbol("x", 0), pose)
        values.insert(gtsam.symbol("l", 0), point)
        jac, _ = f.linearize(values).jacobian()
        np.testing.assert_allclose(got[i], jac, rtol=0, atol=1e-12 * max(1.0, np.abs(jac).max()))


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


@pytest.mark.parametrize("which", ["tiny", "suburb", "kitti03"])
def test_base_information_is_gtsams_hessian_of_the_base_graph(which, request):
    """The closed-form base information (first-pose prior, odometry, landmark priors) against the
    Hessian of the base graph GTSAM builds and linearizes: routes that turn both ways (KITTI 03)."""
    problem = request.getfixturevalue(f"{which}_problem")
    lin = linearize_library(problem)
    builder = GraphBuilder(problem)
    gauss = builder.base_graph().linearize(builder.values)
    K, M = problem.scenario.n_poses, problem.scenario.n_landmarks
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
            want_pp[3 * a : 3 * a + 3, 3 * b : 3 * b + 3] = hess[
                pose_cols[a] : pose_cols[a] + 3, pose_cols[b] : pose_cols[b] + 3
            ]
    np.testing.assert_allclose(lin.base_pose_information.toarray(), want_pp, rtol=1e-12, atol=1e-9)
    for j in range(M):
        np.testing.assert_allclose(
            lin.base_landmark_information[j], hess[lm_cols[j] : lm_cols[j] + 2, lm_cols[j] : lm_cols[j] + 2], rtol=1e-12
        )


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
@pytest.mark.parametrize("inplace", [True, False])
def test_every_factorization_path_agrees_with_the_reference(suburb_problem, sparse_below, inplace):
    """Dense (Cholesky) and sparse (LU) factorizations, Schur products by in-place BLAS or numpy: same numbers."""
    fe = FastEvaluator(suburb_problem, sparse_below=sparse_below, front_below=0.0, inplace_blas=inplace)
    re = ReferenceEvaluator(suburb_problem)
    lib = suburb_problem.library
    for s in [
        (),
        lib.parse_suite("LRR-12"),
        lib.parse_suite("LRL-roof,WSC-3,HD2K-9"),
        tuple(range(suburb_problem.n_sensors)),
    ]:
        assert close(fe.logdet(s), re.logdet(s)), s
    base = lib.parse_suite("LRL-roof")
    for c, v in zip([1, 30, 50], fe.scores_with(base, [1, 30, 50])):
        assert close(v, re.score(base + (c,)))
    counts = fe.kernel.counts
    assert counts["splu" if sparse_below > 1 else "potrf"] > 0 and counts["potrf" if sparse_below > 1 else "splu"] == 0
    if inplace:
        assert counts["syrk"] > 0 and counts["gemm"] > 0 and counts["numpy"] == 0
    else:
        assert counts["numpy"] > 0 and counts["syrk"] == counts["gemm"] == 0


@pytest.mark.parametrize("fixture", ["tiny", "suburb"])
@pytest.mark.parametrize("chunk_poses", [1, 3, 32])
def test_the_frontal_path_agrees_with_the_reference(fixture, chunk_poses, request):
    """The frontal elimination of the whole information matrix, forced on every suite,
    at chunk sizes from one keyframe (every carry path) to many: the reference's numbers."""
    problem = request.getfixturevalue(f"{fixture}_problem")
    fe = FastEvaluator(problem, front_below=1e9, chunk_poses=chunk_poses)
    re = ReferenceEvaluator(problem)
    lib = problem.library
    for s in random_suites(problem.n_sensors, 6, seed=chunk_poses)[:8] + [lib.parse_suite("LRL-roof,WSC-3,HD2K-9")]:
        assert close(fe.logdet(s), re.logdet(s)), s
    base = lib.parse_suite("LRL-roof")
    cands = [1, 25, 30, 50, 61]
    for c, v in zip(cands, fe.scores_with(base, cands)):
        assert close(v, re.score(base + (c,))), c
    assert fe.kernel.counts["front"] > 0 and fe.kernel.counts["potrf"] == fe.kernel.counts["splu"] == 0
    # every candidate keyframe order (route, sweeps, RCM) on its own: the same numbers
    orders = dict(fe.kernel.pose_orders)
    assert set(orders) == {"route", "sweep-x", "sweep-y", "rcm"}
    for name, order in orders.items():
        one = FastEvaluator(problem, front_below=1e9, chunk_poses=chunk_poses)
        one.kernel.pose_orders = {name: order}
        for s in [lib.parse_suite("LRL-roof,WSC-3,HD2K-9"), tuple(range(problem.n_sensors))]:
            assert close(one.logdet(s), re.logdet(s)), (name, s)
    # jobs change no bit on this path either
    two = FastEvaluator(problem, jobs=2, threads_from_keyframes=0, front_below=1e9, chunk_poses=chunk_poses)
    assert fe.scores_with(base, cands).tobytes() == two.scores_with(base, cands).tobytes()


@pytest.mark.kitti
def test_the_frontal_path_on_kitti03_and_its_choice(kitti03_problem):
    """On KITTI 03 the forced frontal path gives the reference's numbers; by default the kernel
    takes it where its predicted flops are below FRONT_BELOW of the dense Cholesky's."""
    from sensorsel.information.evaluators.fast.kernel import FRONT_BELOW

    fe, re = FastEvaluator(kitti03_problem, front_below=1e9), ReferenceEvaluator(kitti03_problem)
    lib = kitti03_problem.library
    for s in [
        (),
        lib.parse_suite("HD2K-4"),
        lib.parse_suite("LRL-roof,HD2K-4,LRR-6"),
        tuple(range(kitti03_problem.n_sensors)),
    ]:
        assert close(fe.logdet(s), re.logdet(s)), s
    default = FastEvaluator(kitti03_problem)
    for s in [lib.parse_suite("HD2K-4"), tuple(range(kitti03_problem.n_sensors))]:
        layout = default._base_for(s).layout
        name, flops = default.kernel.front_choice(layout, kitti03_problem.scenario.n_landmarks)
        plan = default.kernel.front_plan(layout, kitti03_problem.scenario.n_landmarks)
        assert plan.order_name == name and abs(plan.flops - flops) <= 1e-9 * flops  # the quick prediction is the plan's
        want = flops < FRONT_BELOW * default.kernel.n**3 / 3
        assert default.kernel.uses_front(layout, kitti03_problem.scenario.n_landmarks) == want
        assert close(default.logdet(s), fe.logdet(s))


def test_the_in_place_blas_path_is_the_default_and_is_taken(suburb_problem):
    """By default the Schur products go through scipy's BLAS function pointers (syrk on a tile's
    diagonal blocks, gemm off it) and the dense pose matrix through dpotrf, and they give numpy's numbers."""
    fe = FastEvaluator(suburb_problem, sparse_below=0.0, front_below=0.0)
    plain = FastEvaluator(suburb_problem, sparse_below=0.0, front_below=0.0, inplace_blas=False)
    suite = tuple(range(suburb_problem.n_sensors))
    got, want = fe.logdet(suite), plain.logdet(suite)
    layout = fe._base_for(suite).layout
    n_same = sum(1 for call in layout.calls if call[-1])
    assert n_same > 0 and len(layout.calls) - n_same > 0
    assert fe.kernel.counts == {"syrk": n_same, "gemm": len(layout.calls) - n_same, "potrf": 1}
    assert abs(got - want) <= 1e-12 * abs(want)
    # the default engine of the registry is this one
    assert make_evaluator(suburb_problem).kernel.inplace


def test_blas_function_pointers_against_numpy():
    """syrk/gemm on row-major sub-blocks with a leading dimension, and dpotrf, through the Fortran pointers."""
    blas = Blas()
    rng = np.random.default_rng(1)
    a, b = rng.standard_normal((7, 5)), rng.standard_normal((4, 5))
    dims = np.array([7, 4, 5, 12], dtype=np.intc)  # m, n, k, ldc
    pd = dims.ctypes.data
    c = rng.standard_normal((10, 12))
    want = c.copy()
    blas.syrk_sub(c.ctypes.data + 8 * (1 * 12 + 2), pd + 12, a.ctypes.data, pd, pd + 8)
    block = want[1:8, 2:9]
    block[np.tril_indices(7)] -= (a @ a.T)[np.tril_indices(7)]  # lower triangle only; the rest untouched
    np.testing.assert_allclose(c, want, rtol=0, atol=1e-13)
    blas.gemm_sub(c.ctypes.data + 8 * (2 * 12 + 3), pd + 12, a.ctypes.data, b.ctypes.data, pd, pd + 4, pd + 8)
    want[2:9, 3:7] -= a @ b.T
    np.testing.assert_allclose(c, want, rtol=0, atol=1e-13)
    spd = a.T @ a + np.eye(5)
    assert abs(blas.cholesky_logdet(np.tril(spd).copy()) - np.linalg.slogdet(spd)[1]) <= 1e-12 * 10
    with pytest.raises(np.linalg.LinAlgError):
        blas.cholesky_logdet(-np.eye(3))


@pytest.mark.parametrize("n", [1, 5, 63, 64, 65, 200])
@pytest.mark.parametrize("block", [0, 1, 7, 64])
def test_blocked_cholesky_gives_numpys_log_det_at_every_panel_width(n, block):
    """The panels (dpotrf, dtrtri and dtrmm on the panel, dsyrk on the trailing matrix) against numpy's
    slogdet, widths that
    divide n, do not, and exceed it; the factor's lower triangle is numpy's Cholesky factor."""
    rng = np.random.default_rng(n + block)
    x = rng.standard_normal((n, n + 3))
    spd = x @ x.T + 0.1 * np.eye(n)
    p = np.tril(spd).copy()
    got = Blas().cholesky_logdet(p, block)
    want = np.linalg.slogdet(spd)[1]
    assert abs(got - want) <= 1e-11 * max(1.0, abs(want))
    np.testing.assert_allclose(np.tril(p), np.linalg.cholesky(spd), rtol=0, atol=1e-9 * np.abs(spd).max())


@pytest.mark.parametrize("condition", [1e4, 1e8, 1e11])
def test_blocked_cholesky_is_accurate_on_ill_conditioned_matrices(condition):
    """Oracle: a matrix built from known eigenvalues (log det = their log sum), condition numbers
    up to 1e11; the panels' inverted diagonal blocks lose no more than a plain dpotrf."""
    rng = np.random.default_rng(int(np.log10(condition)))
    n = 300
    q, _ = np.linalg.qr(rng.standard_normal((n, n)))
    eig = np.logspace(0.0, np.log10(condition), n)
    spd = (q * eig) @ q.T
    spd = 0.5 * (spd + spd.T)
    want = float(np.sum(np.log(eig)))
    blocked = Blas().cholesky_logdet(np.tril(spd).copy(), 64)
    whole = Blas().cholesky_logdet(np.tril(spd).copy(), 0)  # one dpotrf
    # within a small multiple of one dpotrf's error (or of round-off), and of the usual bound
    assert abs(blocked - want) <= 10.0 * abs(whole - want) + 1e-13 * abs(want)
    assert abs(blocked - want) <= 1e-16 * condition * n * abs(want) + 1e-13 * abs(want)


@pytest.mark.parametrize("n", [1, 5, 70])
def test_inverse_from_the_blocked_cholesky_is_numpys_inverse(n):
    """dpotri through its function pointer after the blocked Cholesky: the lower triangle holds
    numpy's inverse of the matrix, the upper triangle is not written; and scipy's own wrapper of
    dpotri (what the gain bounds called before) gives the same bits on the same factor."""
    from scipy.linalg import lapack

    rng = np.random.default_rng(n)
    x = rng.standard_normal((n, n + 2))
    spd = x @ x.T + 0.5 * np.eye(n)
    p = np.tril(spd).copy()
    blas = Blas()
    blas.cholesky_logdet(p, 64)
    factor = p.copy()
    p[np.triu_indices(n, 1)] = 7.0  # the upper triangle must come back untouched
    blas.inverse_from_cholesky(p)
    low = np.tril_indices(n)
    np.testing.assert_allclose(p[low], np.linalg.inv(spd)[low], rtol=1e-9, atol=1e-12)
    assert np.all(p[np.triu_indices(n, 1)] == 7.0)
    theirs, info = lapack.dpotri(factor.T, lower=0, overwrite_c=0)
    assert info == 0 and np.array_equal(np.tril(theirs.T), np.tril(p))


def test_inverse_from_a_singular_factor_names_dpotri():
    p = np.eye(4)
    p[2, 2] = 0.0  # a zero on the factor's diagonal
    with pytest.raises(np.linalg.LinAlgError, match="dpotri info 3"):
        Blas().inverse_from_cholesky(p)


def test_blocked_cholesky_names_the_failing_pivot_past_the_first_panel():
    spd = np.eye(100)
    spd[70, 70] = -1.0
    with pytest.raises(np.linalg.LinAlgError, match="info 71"):
        Blas().cholesky_logdet(spd.copy(), 64)


def test_blas_runs_on_one_thread_while_scoring_and_is_restored(tiny_problem):
    from threadpoolctl import threadpool_info

    fe = FastEvaluator(tiny_problem)
    before = [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]
    with fe.kernel.blas.single_thread():
        assert all(i["num_threads"] == 1 for i in threadpool_info() if i["user_api"] == "blas")
    assert [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"] == before


def test_logdet_and_scores_with_do_not_mutate_their_inputs(suburb_problem):
    """Neither the kernel's inputs (the shared base state) nor the callers' arrays are written to."""
    lib = suburb_problem.library
    fe = FastEvaluator(suburb_problem, sparse_below=0.0, front_below=0.0)
    base = np.array(lib.parse_suite("LRL-roof,LRR-12"))
    cands = np.arange(suburb_problem.n_sensors)
    base0, cands0 = base.copy(), cands.copy()
    first = fe.scores_with(base, cands)
    state = fe._base_for(tuple(base.tolist()))
    snapshot = {k: getattr(state, k).copy() for k in ("w", "d", "a", "wpl")}
    assert np.array_equal(fe.scores_with(base, cands), first)  # same state reused: same bits
    assert fe._base_for(tuple(base.tolist())) is state
    for k, v in snapshot.items():
        assert np.array_equal(getattr(state, k), v), k
    np.testing.assert_array_equal(base, base0)
    np.testing.assert_array_equal(cands, cands0)
    # the kernel directly: its array arguments come back unchanged, and it can be called twice
    args = (state.wpl, state.d, state.a)
    copies = [x.copy() for x in args]
    with fe.kernel.blas.single_thread():  # as the evaluator calls it (the same bits)
        one = fe.kernel.logdet(*args, state.layout)
        assert fe.kernel.logdet(*args, state.layout) == one
    for x, y in zip(args, copies):
        assert np.array_equal(x, y)
    assert one == fe.logdet(base)


def test_registry_holds_classes_and_names_unknown_engines(tiny_problem):
    assert ENGINES == {"reference": ReferenceEvaluator, "fast": FastEvaluator}
    assert all(isinstance(cls, type) for cls in ENGINES.values())
    with pytest.raises(InputError, match=r"unknown engine 'nope'; available: fast, reference"):
        make_evaluator(tiny_problem, "nope")
    with pytest.raises(ValueError, match="already registered"):

        @register
        class Other(ReferenceEvaluator):
            name = "fast"

    assert ENGINES["fast"] is FastEvaluator


def test_a_sensor_that_sees_nothing_adds_exactly_nothing(tiny_problem):
    from sensorsel.model.problem import build_problem
    from sensorsel.model.scenario import Scenario

    sc = tiny_problem.scenario
    far = Scenario(name="far", keyframes=sc.keyframes, landmarks=sc.landmarks + 1e5, landmark_source="moved")
    problem = build_problem(tiny_problem.library, far)
    assert all(len(o) == 0 for o in problem.observations)
    ev = FastEvaluator(problem)
    assert ev.logdet(()) == ev.logdet(tuple(range(problem.n_sensors)))
    assert np.all(ev.scores_with((), [0, 1, 2]) == 0.0)
    assert close(ev.baseline_logdet, ReferenceEvaluator(problem).baseline_logdet)


def test_a_grown_layout_answers_the_sparse_test_from_its_base_without_its_own_pattern(suburb_problem):
    """A candidate measuring pairs its base does not gets a layout of its own; its pose-block pattern
    holds the base's, so where the base is already too dense for the sparse path the candidate's
    answer is taken from it (no pattern built), and it is the answer its own pattern gives."""
    from sensorsel.information.evaluators.fast.kernel import SPARSE_BELOW

    fe = FastEvaluator(suburb_problem)
    lib = suburb_problem.library
    base = fe._states.base((lib.position("LRL-roof"),))
    grown = [x.layout for c in range(len(lib)) if (x := fe._states.candidate(base, c)).layout is not base.layout]
    assert grown and all(g.grown_from is base.layout for g in grown)
    assert base.layout.density >= SPARSE_BELOW
    for g in grown:
        assert not g.density_below(SPARSE_BELOW) and "pattern" not in g.__dict__
        assert (
            np.all(g.pattern[base.layout.pattern]) and g.density >= base.layout.density
        )  # a superset, built on demand
        for limit in (0.0, base.layout.density, g.density, 1.01):
            assert g.density_below(limit) == (g.density < limit)


def test_bases_measuring_the_same_pairs_share_their_layouts_and_give_the_same_bits(suburb_problem):
    """A step that buys a sensor adding no pair (a camera inside the LiDAR's range) keeps the base's
    layout and the layouts its candidates grew; every score is the bits a fresh engine computes."""
    lib = suburb_problem.library
    lidar = lib.position("LRL-roof")
    fe = FastEvaluator(suburb_problem)
    cands = list(range(len(lib)))
    first = fe.scores_with((lidar,), cands)
    adds_none = [
        c
        for c in cands
        if c != lidar and fe._states.candidate(fe._base_for((lidar,)), c).layout is fe._base_for((lidar,)).layout
    ]
    grown = [
        c for c in cands if fe._states.candidate(fe._base_for((lidar,)), c).layout is not fe._base_for((lidar,)).layout
    ]
    assert adds_none and grown
    b1 = fe._base_for((lidar,))
    grown_before = {c: fe._states.candidate(b1, c).layout for c in grown}
    s2 = tuple(sorted((lidar, adds_none[0])))
    second = fe.scores_with(s2, cands)
    b2 = fe._base_for(s2)
    assert b2.layout is b1.layout  # same pairs: the same layout object
    assert sum(fe._states.candidate(b2, c).layout is grown_before[c] for c in grown) >= 1
    fresh1, fresh2 = FastEvaluator(suburb_problem), FastEvaluator(suburb_problem)
    assert first.tobytes() == fresh1.scores_with((lidar,), cands).tobytes()
    assert second.tobytes() == fresh2.scores_with(s2, cands).tobytes()


def test_a_carried_run_is_cut_where_the_eliminated_variables_end():
    """The backward pass copies each carried run from the quadrant of Σ it lies in: a run over front
    positions 5..14 with 8 variables eliminated is copied as 5..7 (eliminated) and 8..14 (carried),
    its old positions cut alike; runs on one side stay whole (worked by hand)."""
    assert _split_runs([(0, 5, 10)], 8) == [(0, 5, 3), (3, 8, 7)]
    assert _split_runs([(0, 0, 3), (3, 8, 2), (5, 4, 4)], 8) == [(0, 0, 3), (3, 8, 2), (5, 4, 4)]
    assert _split_runs([(2, 7, 2)], 8) == [(2, 7, 1), (3, 8, 1)]
