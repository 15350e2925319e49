"""The forward pass (the filter: the accuracy the car has as it drives), against GTSAM's Marginals on
the batch graph of the measurements up to each keyframe, against the dense inverse of the truncated
information matrix, and against the smoother (equal at the last keyframe, never better elsewhere)."""

from __future__ import annotations

import json

import gtsam
import numpy as np
import pytest
from gtsam.symbol_shorthand import L, X

from sensorsel.api import ScoreResult, score_suite
from sensorsel.errors import InputError
from sensorsel.information.evaluators import FastEvaluator
from sensorsel.information.evaluators.accuracy import route_accuracy
from sensorsel.information.filtering import ESTIMATES, FilterPass, forward_pass, keyframe_measurements
from sensorsel.information.graph import (
    MeasurementNoise,
    add_bearing_range,
    add_pose_chain,
    diagonal,
    landmark_prior,
    pose2,
    truth_steps,
)
from sensorsel.information.linearize import bearing_range_jacobians, odometry_jacobians
from sensorsel.io import results
from sensorsel.model.conditions import parse_condition
from sensorsel.model.problem import build_problem, with_condition
from sensorsel.model.scenario import Scenario

MODELS = (None, 0.05)  # the SLAM graph (weak 100 m landmark prior) and a map known to 5 cm


@pytest.fixture(scope="module")
def suburb_cut(library, suburb_problem):
    """The bundled suburb route's first 18 keyframes (its landmarks all kept)."""
    sc = suburb_problem.scenario
    cut = Scenario("suburb-cut", sc.keyframes.select(np.arange(18)), sc.landmarks, sc.landmark_source)
    return build_problem(library, cut)


def _drop_every_third(pred, meas) -> np.ndarray:
    """A ``use`` that leaves out every third measurement of each keyframe (a fixed, checkable mask)."""
    return np.arange(len(meas)) % 3 != 1


def _gtsam_marginal(problem, suite, k: int, *, map_sigma_m, with_k: bool, use=None) -> np.ndarray:
    """GTSAM's Marginals of X(k) in the batch graph of the priors, the odometry up to k and the
    (used) measurements of keyframes < k (and k's with ``with_k``): the filter's definition."""
    s = problem.settings
    poses = [pose2(q) for q in problem.scenario.keyframes.poses[: k + 1]]
    g = gtsam.NonlinearFactorGraph()
    add_pose_chain(g, poses[0], truth_steps(poses), diagonal(s.first_pose_sigmas), diagonal(s.odometry_sigmas))
    values = gtsam.Values()
    for i, p in enumerate(poses):
        values.insert(X(i), p)
    prior = gtsam.noiseModel.Isotropic.Sigma(2, s.landmark_prior_sigma_m if map_sigma_m is None else map_sigma_m)
    for j, (x, y) in enumerate(problem.scenario.landmarks):
        point = gtsam.Point2(float(x), float(y))
        g.add(landmark_prior(j, point, prior))
        values.insert(L(j), point)
    noise = MeasurementNoise()
    for m in keyframe_measurements(problem, suite)[: k + int(with_k)]:
        keep = np.ones(len(m), bool) if use is None else use(None, m)
        if keep.any():
            add_bearing_range(
                g,
                np.full(int(keep.sum()), m.keyframe),
                m.landmark[keep],
                m.bearing_rad[keep],
                m.range_m[keep],
                [noise(a, b) for a, b in zip(m.sigma_bearing_rad[keep], m.sigma_range_m[keep])],
            )
    return gtsam.Marginals(g, values).marginalCovariance(X(k))


def _check_against_gtsam(problem, suite, map_sigma_m, use=None, keyframes=None, window=None) -> FilterPass:
    fp = forward_pass(problem, suite, map_sigma_m=map_sigma_m, use=use, window=window)
    K = problem.scenario.n_poses
    for k in keyframes if keyframes is not None else range(K):
        for with_k, got in ((True, fp.filtered[k]), (False, fp.predicted[k])):
            want = _gtsam_marginal(problem, suite, k, map_sigma_m=map_sigma_m, with_k=with_k, use=use)
            np.testing.assert_allclose(
                got,
                want,
                rtol=1e-8,
                atol=1e-12 * np.abs(want).max(),
                err_msg=f"keyframe {k}, {'filtered' if with_k else 'predicted'}",
            )
    return fp


@pytest.mark.parametrize("map_sigma_m", MODELS)
def test_filtered_and_predicted_equal_gtsam_on_tiny(tiny_problem, map_sigma_m):
    suite = tuple(range(0, tiny_problem.n_sensors, 2))
    fp = _check_against_gtsam(tiny_problem, suite, map_sigma_m)
    assert fp.n_used.sum() == fp.n_measured.sum() == sum(len(tiny_problem.observations[i]) for i in suite)


@pytest.mark.parametrize("map_sigma_m", MODELS)
def test_filtered_and_predicted_equal_gtsam_on_a_cut_of_suburb_with_measurements_left_out(suburb_cut, map_sigma_m):
    suite = tuple(range(0, suburb_cut.n_sensors, 5))
    fp = _check_against_gtsam(suburb_cut, suite, map_sigma_m, use=_drop_every_third, keyframes=range(0, 18, 3))
    # the mask was applied: a third (rounded) of each keyframe's measurements left out
    np.testing.assert_array_equal(fp.n_used, [len(np.flatnonzero(np.arange(m) % 3 != 1)) for m in fp.n_measured])
    assert fp.n_used.sum() < fp.n_measured.sum()


def test_filter_equals_gtsam_at_night(suburb_cut):
    night = with_condition(suburb_cut, parse_condition("night"))
    suite = tuple(range(0, night.n_sensors, 4))
    fp = _check_against_gtsam(night, suite, 0.05, keyframes=(0, 9, 17))
    clear = forward_pass(suburb_cut, suite, map_sigma_m=0.05)
    assert fp.n_measured.sum() != clear.n_measured.sum() or not np.allclose(fp.filtered, clear.filtered)


@pytest.mark.parametrize("map_sigma_m", MODELS)
def test_last_keyframe_is_the_smoother_and_the_filter_never_better(suburb_problem, map_sigma_m):
    ev = FastEvaluator(suburb_problem)
    suite = (0, 7, 20, 41)
    smooth = ev.pose_covariances(suite, map_sigma_m=map_sigma_m, estimate="smoother")
    filt = ev.pose_covariances(suite, map_sigma_m=map_sigma_m, estimate="filter")
    np.testing.assert_allclose(filt[-1], smooth[-1], rtol=1e-7, atol=1e-14)
    scale = np.abs(smooth).max()
    # filtered ⪰ smoothed in the PSD order at every keyframe (fewer measurements)
    gaps = np.linalg.eigvalsh(filt - smooth)
    assert gaps.min() > -1e-9 * scale
    # and strictly worse somewhere before the last keyframe (the filter is not the smoother)
    assert np.trace(filt[:-1] - smooth[:-1], axis1=1, axis2=2).max() > 1e-3 * np.trace(smooth[0])
    # the cheap floor require refutes with is under the filter's covariances too
    floor = ev.pose_covariance_floor(suite, map_sigma_m=map_sigma_m)
    assert np.linalg.eigvalsh(filt - floor).min() > -1e-9 * scale


def _dense_information(problem, suite, k: int, map_sigma_m) -> np.ndarray:
    """The information matrix, dense, of the graph the prediction at keyframe k is of: priors,
    odometry up to k, the measurements of keyframes < k; variables poses 0..k (3 each, Pose2
    tangent) then every landmark (2 each), written from the Jacobians at the truth."""
    s = problem.settings
    sc = problem.scenario
    M = sc.n_landmarks
    n = 3 * (k + 1) + 2 * M
    lam = np.zeros((n, n))
    lam[:3, :3] = np.diag(1.0 / np.asarray(s.first_pose_sigmas) ** 2)
    odo = odometry_jacobians(sc.keyframes.poses[: k + 1])
    w = np.diag(1.0 / np.asarray(s.odometry_sigmas) ** 2)
    for i in range(1, k + 1):
        J = np.zeros((3, n))
        J[:, 3 * (i - 1) : 3 * i], J[:, 3 * i : 3 * i + 3] = odo[i - 1], np.eye(3)
        lam += J.T @ w @ J
    prior = s.landmark_prior_sigma_m if map_sigma_m is None else map_sigma_m
    lam[3 * (k + 1) :, 3 * (k + 1) :] += np.eye(2 * M) / prior**2
    for m in keyframe_measurements(problem, suite)[:k]:
        jac = bearing_range_jacobians(
            np.repeat(sc.keyframes.poses[m.keyframe][None], len(m), 0), sc.landmarks[m.landmark]
        )
        for row, j, sb, sr in zip(jac, m.landmark, m.sigma_bearing_rad, m.sigma_range_m):
            J = np.zeros((2, n))
            J[:, 3 * m.keyframe : 3 * m.keyframe + 3] = row[:, :3]
            J[:, 3 * (k + 1) + 2 * j : 3 * (k + 1) + 2 * j + 2] = row[:, 3:]
            lam += J.T @ np.diag([1 / sb**2, 1 / sr**2]) @ J
    return lam


@pytest.mark.parametrize("map_sigma_m", MODELS)
def test_prediction_joint_covariance_is_the_dense_inverse(suburb_cut, map_sigma_m):
    suite = tuple(range(0, suburb_cut.n_sensors, 5))
    preds = {}
    forward_pass(
        suburb_cut, suite, map_sigma_m=map_sigma_m, on_prediction=lambda p, m: preds.__setitem__(p.keyframe, (p, m))
    )
    assert sorted(preds) == list(range(suburb_cut.scenario.n_poses))
    prior = suburb_cut.settings.landmark_prior_sigma_m if map_sigma_m is None else map_sigma_m
    for k in (3, 10, 17):
        p, meas = preds[k]
        assert p.prior_sigma_m == prior and len(np.unique(p.landmarks)) == len(p.landmarks)
        cov = np.linalg.inv(_dense_information(suburb_cut, suite, k, map_sigma_m))
        # the state's own order (landmarks appended as they come, a leaving one's place taken by the
        # last): each block against the dense inverse's block of the same landmarks; and sorted
        for q in (p, p.in_landmark_order()):
            lm = 3 * (k + 1) + 2 * q.landmarks[:, None] + np.arange(2)
            idx = np.concatenate([np.arange(3 * k, 3 * k + 3), lm.ravel()])
            want = cov[np.ix_(idx, idx)]
            assert q.covariance.shape == (3 + 2 * len(q.landmarks),) * 2
            np.testing.assert_allclose(q.covariance, want, rtol=1e-6, atol=1e-9 * np.abs(want[:3, :3]).max())
        assert np.all(np.diff(p.in_landmark_order().landmarks) > 0)
        # a landmark measured at k that is not in the state: never measured before, so
        # independent of the pose with its prior covariance (what the docstring promises)
        outside = np.setdiff1d(meas.landmark, p.landmarks)
        for j in outside:
            b = 3 * (k + 1) + 2 * j
            np.testing.assert_allclose(cov[b : b + 2, b : b + 2], prior**2 * np.eye(2), rtol=1e-9)
            assert np.abs(cov[3 * k : 3 * k + 3, b : b + 2]).max() < 1e-9 * prior**2
        assert len(p.landmarks) > 0


def test_use_gets_the_prediction_and_a_wrong_mask_is_refused(tiny_problem):
    seen = []

    def use(pred, meas):
        seen.append((pred.keyframe, len(meas), pred.covariance.shape))
        return np.ones(len(meas), bool)

    fp = forward_pass(tiny_problem, (0, 1), use=use)
    assert [s[0] for s in seen] == list(range(tiny_problem.scenario.n_poses))
    assert [s[1] for s in seen] == fp.n_measured.tolist()
    # leaving every measurement out is odometry alone: the same as the empty suite
    none = forward_pass(tiny_problem, (0, 1), use=lambda p, m: np.zeros(len(m), bool))
    np.testing.assert_allclose(none.filtered, forward_pass(tiny_problem, ()).filtered, rtol=1e-12)
    assert none.n_used.sum() == 0
    with pytest.raises(ValueError, match="mask of shape"):
        forward_pass(tiny_problem, (0, 1), use=lambda p, m: np.ones(len(m) + 1, bool))


def test_keyframe_measurements_are_the_suites_in_a_fixed_order(suburb_problem):
    suite = (3, 11, 30)
    groups = keyframe_measurements(suburb_problem, suite)
    assert [g.keyframe for g in groups] == list(range(suburb_problem.scenario.n_poses))
    assert sum(len(g) for g in groups) == sum(len(suburb_problem.observations[i]) for i in suite)
    for g in groups:
        order = np.lexsort((g.landmark, g.sensor))
        np.testing.assert_array_equal(order, np.arange(len(g)))
        assert set(g.sensor.tolist()) <= set(suite)
    with pytest.raises(InputError, match="outside the library"):
        keyframe_measurements(suburb_problem, (10_000,))


def test_measurements_out_of_a_sensors_order_are_sorted_all_the_same(suburb_problem):
    """A sensor's measurements given out of (keyframe, landmark) order (not as observe makes them):
    the three-key sort, the same groups and the same pass as in order (the oracle: the problem as
    observe made it). Without the check of the order, the fast sort keeps the shuffled order."""
    import dataclasses

    suite = (3, 11, 30)
    rng = np.random.default_rng(5)
    observations = list(suburb_problem.observations)
    o = observations[11]
    perm = rng.permutation(len(o))
    observations[11] = dataclasses.replace(
        o, **{f.name: getattr(o, f.name)[perm] for f in dataclasses.fields(o) if f.name != "sensor"}
    )
    shuffled = dataclasses.replace(suburb_problem, observations=tuple(observations))
    for a, b in zip(keyframe_measurements(shuffled, suite), keyframe_measurements(suburb_problem, suite)):
        for f in ("sensor", "landmark", "bearing_rad", "range_m", "sigma_bearing_rad", "sigma_range_m"):
            np.testing.assert_array_equal(getattr(a, f), getattr(b, f))
    fast = forward_pass(suburb_problem, suite, map_sigma_m=0.05).filtered
    assert forward_pass(shuffled, suite, map_sigma_m=0.05).filtered.tobytes() == fast.tobytes()


def test_accuracy_says_its_estimate_and_old_files_load_as_the_smoother(suburb_problem, tmp_path):
    ev = FastEvaluator(suburb_problem)
    accs = {e: route_accuracy(ev, (0, 7), map_sigma_m=0.05, estimate=e) for e in ESTIMATES}
    assert "filter (as the car drives)" in accs["filter"].line()
    assert "smoother (whole route)" in accs["smoother"].line()
    assert accs["filter"].heading.median >= accs["smoother"].heading.median
    assert route_accuracy(ev, (0, 7), map_sigma_m=0.05).estimate == "filter"  # the default
    with pytest.raises(InputError, match="--estimate"):
        route_accuracy(ev, (0, 7), estimate="kalman")
    # recorded in results (a score's accuracy); a file written before estimates existed loads as the smoother's
    res = score_suite(suburb_problem, (0, 7), map_sigma_m=0.05)
    assert res.accuracy is not None and res.accuracy.estimate == "filter"
    path = tmp_path / "score.json"
    results.save(res, path)
    assert results.load(path, ScoreResult).accuracy.estimate == "filter"

    def strip(node):
        if isinstance(node, dict):
            return {k: strip(v) for k, v in node.items() if k != "estimate"}
        return [strip(v) for v in node] if isinstance(node, list) else node

    path.write_text(json.dumps(strip(json.loads(path.read_text()))))
    assert "estimate" not in path.read_text()
    assert results.load(path, ScoreResult).accuracy.estimate == "smoother"


@pytest.mark.parametrize(
    ("n_held", "n_drop", "n_new"),
    [
        (250, 0, 0),
        (250, 1, 0),
        (250, 5, 3),
        (250, 40, 10),
        (250, 200, 0),
        (250, 0, 50),
        (20, 2, 3),
        (90, 0, 4),
        (3, 3, 0),
    ],
)
def test_the_state_kept_is_its_landmarks_rows_and_columns_bit_for_bit(n_held, n_drop, n_new):
    """The filter's state (_State) over three rounds of landmarks joining then leaving, against the
    oracle of a dense matrix indexed by landmark (each block written where its landmark's rows are):
    after each round the state is that matrix's rows and columns of the landmarks it holds, in its
    order, to the bit; each landmark's slot is its place; the buffer grows past its size."""
    from sensorsel.information.filtering import _State

    n_ids = 1000
    rng = np.random.default_rng(n_drop + 7 * n_new + n_held)
    ids = rng.permutation(n_ids)
    taken = n_held

    def rows(ls):
        return np.concatenate([np.arange(3), (3 + 2 * np.asarray(ls, np.int64)[:, None] + np.arange(2)).ravel()])

    n = 3 + 2 * n_held
    P = rng.standard_normal((n, n))
    state = _State(P + P.T, ids[:n_held], n_ids)
    full = np.full((3 + 2 * n_ids,) * 2, np.nan)
    full[np.ix_(rows(ids[:n_held]), rows(ids[:n_held]))] = P + P.T
    for _ in range(3):
        if n_new:
            new = ids[taken : taken + n_new]
            taken += n_new
            was = state.held.copy()
            cross = rng.standard_normal((2 * n_new, 3 + 2 * len(was)))
            ll = rng.standard_normal((2 * n_new,) * 2)
            state.grow(cross, ll + ll.T, new)
            r_new = rows(new)[3:]
            full[np.ix_(r_new, rows(was))], full[np.ix_(rows(was), r_new)] = cross, cross.T
            full[np.ix_(r_new, r_new)] = ll + ll.T
        gone = np.zeros(len(state.held), bool)
        gone[rng.choice(len(state.held), min(n_drop, len(state.held)), replace=False)] = True
        kept = state.held[~gone]
        state.remove(gone)
        assert sorted(state.held.tolist()) == sorted(kept.tolist())
        assert state.P.tobytes() == np.ascontiguousarray(full[np.ix_(rows(state.held), rows(state.held))]).tobytes()
        assert (state.slot[state.held] == np.arange(len(state.held))).all()
        assert (state.slot >= 0).sum() == len(state.held)


@pytest.mark.parametrize(
    "runs",
    [
        ((0, 400),),  # one stretch
        ((10, 300), (301, 302), (500, 900)),  # a few, one of a single index
        ((700, 900), (5, 200)),  # out of order: a stretch of higher indices first
        tuple((3 * i, 3 * i + 2) for i in range(200)),  # too many pieces: the takes
        ((0, 2), (7, 9)),  # small: the takes
    ],
)
def test_a_block_copied_by_stretches_is_numpys_block_bit_for_bit(runs):
    """The filter's block copy (blocks.block) against numpy's P[np.ix_(rows, cols)] on a random matrix, to the
    bit: rows and columns that run in stretches (copied as slices), in many (copied by takes), and a
    block too small to look for them; the columns with another set of stretches than the rows."""
    from sensorsel.information.blocks import BLOCK_PIECES, BLOCK_SLICED_FROM, block, stretches

    rng = np.random.default_rng(len(runs))
    P = rng.standard_normal((1000, 1000))
    rows = np.concatenate([np.arange(a, b) for a, b in runs])
    cols = np.concatenate([rows[len(rows) // 3 :], np.arange(950, 1000)])
    got = block(P, rows, cols)
    assert got.shape == (len(rows), len(cols)) and got.flags.c_contiguous
    assert got.tobytes() == np.ascontiguousarray(P[np.ix_(rows, cols)]).tobytes()
    assert [(lo, hi) for _, lo, hi in stretches(rows)] == [(a, b) for a, b in runs if b > a] or len(runs) > 100
    sliced = len(rows) * len(cols) >= BLOCK_SLICED_FROM and len(stretches(rows)) * len(stretches(cols)) <= BLOCK_PIECES
    assert sliced == (len(runs) <= 3 and len(rows) > 100)  # each way is taken by some case


@pytest.mark.parametrize("map_sigma_m", MODELS)
def test_excluded_landmarks_are_the_hook_that_drops_them_bit_for_bit(suburb_problem, map_sigma_m):
    """``exclude`` (a fixed set of landmarks left out, as the upper bounds of ``require`` leave out
    those their base stopped holding) gives the numbers of a ``use`` hook that drops the same
    landmarks' measurements at each keyframe, to the bit: from the priors and from another pass's
    predicted state, over a whole route and a window of it; the counts of measurements made and used
    too. The oracle is the hook, the pass's older and independent path (its pairs computed again at
    every keyframe where it drops anything)."""
    suite = (3, 11, 30, 60)
    n = suburb_problem.scenario.n_landmarks
    gone = np.zeros(n, bool)
    gone[np.random.default_rng(3).choice(n, n // 3, replace=False)] = True

    def drop(pred, meas):
        return ~gone[meas.landmark]

    kept = {}
    forward_pass(
        suburb_problem, (3,), map_sigma_m=map_sigma_m, on_prediction=lambda p, m: kept.__setitem__(p.keyframe, p)
    )
    for start, until in ((None, None), (kept[20], 35)):
        hooked = forward_pass(suburb_problem, suite, map_sigma_m=map_sigma_m, use=drop, start=start, until=until)
        fixed = forward_pass(
            suburb_problem, suite, map_sigma_m=map_sigma_m, exclude=gone, start=start, until=until, window=0
        )
        assert hooked.n_used.sum() < hooked.n_measured.sum()  # the set drops measurements: not a vacuous test
        for f in ("predicted", "filtered", "n_used", "n_measured"):
            np.testing.assert_array_equal(getattr(fixed, f), getattr(hooked, f), err_msg=f)


def test_a_predictions_slots_are_where_its_landmarks_stand(suburb_problem):
    """Prediction.slots_of (the pass's own table, and the table built where a prediction has none)
    against a search of each landmark in ``landmarks`` (the oracle), at every keyframe of a pass
    whose landmarks come and leave: held ones at their place, others (never seen, or gone) −1."""
    from sensorsel.information.filtering import Prediction

    preds = []
    forward_pass(suburb_problem, (3, 11, 30, 60), map_sigma_m=0.05, on_prediction=lambda p, m: preds.append(p))
    every = np.arange(suburb_problem.scenario.n_landmarks)
    moved = 0
    for p in preds:
        want = np.array([np.flatnonzero(p.landmarks == j)[0] if j in p.landmarks else -1 for j in every])
        bare = Prediction(p.keyframe, p.landmarks, p.covariance, p.prior_sigma_m)
        assert p.slot is not None and bare.slot is None
        np.testing.assert_array_equal(p.slots_of(every), want)
        np.testing.assert_array_equal(bare.slots_of(every), want)
        moved += int(np.any(np.diff(p.landmarks) < 0))
    assert moved > 0  # some state out of landmark order: the look-up cannot lean on a sorted state


def _dormant_spans(problem, suite, span: int) -> int:
    """How many (window, landmark) the windows of ``span`` keyframes from keyframe 0 leave dormant:
    measured by the suite before the window and after it, not within (from the observations alone)."""
    seen: dict[int, set[int]] = {}
    for i in suite:
        o = problem.observations[i]
        for k, j in zip(o.pose, o.landmark):
            seen.setdefault(int(j), set()).add(int(k))
    count = 0
    for t0 in range(0, problem.scenario.n_poses, span):
        for ks in seen.values():
            if min(ks) < t0 and max(ks) >= t0 + span and not any(t0 <= k < t0 + span for k in ks):
                count += 1
    return count


@pytest.mark.parametrize("map_sigma_m", MODELS)
@pytest.mark.parametrize("span", [1, 3, 7])
def test_windows_give_the_dense_passes_covariances(suburb_problem, map_sigma_m, span):
    """The pass in windows (the landmarks held but not measured left out of a window's updates and
    brought back by their conditional on the window's first pose and landmarks) against the dense
    pass, which updates every landmark held at every keyframe (the oracle): the same predicted and
    filtered covariances to round-off, over the whole route and from another pass's state with
    landmarks excluded. The windows leave landmarks dormant (counted from the observations: not a
    vacuous test), and those come back measured."""
    kept = {}
    forward_pass(
        suburb_problem, (3,), map_sigma_m=map_sigma_m, on_prediction=lambda p, m: kept.__setitem__(p.keyframe, p)
    )
    gone = np.zeros(suburb_problem.scenario.n_landmarks, bool)
    gone[::4] = True
    suites = ((3, 11, 30, 60), (7, 20, 41), (0, 5, 14, 33, 49))
    assert sum(_dormant_spans(suburb_problem, suite, span) for suite in suites) > 0
    for suite in suites:
        for start, until, exclude in ((None, None, None), (kept[20], 40, gone)):
            args = dict(map_sigma_m=map_sigma_m, start=start, until=until, exclude=exclude)
            dense = forward_pass(suburb_problem, suite, window=0, **args)
            windowed = forward_pass(suburb_problem, suite, window=span, **args)
            for f in ("predicted", "filtered"):
                want = getattr(dense, f)
                np.testing.assert_allclose(
                    getattr(windowed, f), want, rtol=0, atol=1e-11 * np.abs(want).max(), err_msg=f
                )
            for f in ("n_used", "n_measured"):
                np.testing.assert_array_equal(getattr(windowed, f), getattr(dense, f))


def test_windows_equal_gtsam_on_a_cut_of_suburb(suburb_cut):
    """The pass in windows of 2 keyframes against GTSAM's Marginals on the batch graph (the oracle
    independent of both passes)."""
    suite = (7, 20, 41)
    assert _dormant_spans(suburb_cut, suite, 2) > 0
    _check_against_gtsam(suburb_cut, suite, 0.05, keyframes=range(0, 18, 2), window=2)


@pytest.mark.parametrize("span", [None, 3])
def test_states_kept_are_the_whole_predictions_of_the_dense_pass(suburb_problem, span):
    """``keep_states``: the whole predicted state at each keyframe asked (its landmarks and their
    covariance, pose included) against the dense pass's prediction there, given to an
    ``on_prediction`` hook (the oracle): the same landmarks held, the same covariance to round-off,
    with windows between the keyframes kept; the pose covariances as the pass without states."""
    suite = (7, 20, 41)
    seen = {}
    forward_pass(suburb_problem, suite, map_sigma_m=0.05, on_prediction=lambda p, m: seen.__setitem__(p.keyframe, p))
    asked = (0, 5, 6, 19, 40, 52)
    got = forward_pass(suburb_problem, suite, map_sigma_m=0.05, window=span, keep_states=asked)
    assert sorted(got.states) == list(asked)
    for k in asked:
        want, have = seen[k].in_landmark_order(), got.states[k].in_landmark_order()
        np.testing.assert_array_equal(have.landmarks, want.landmarks)
        np.testing.assert_allclose(have.covariance, want.covariance, rtol=0, atol=1e-12 * np.abs(want.covariance).max())
    plain = forward_pass(suburb_problem, suite, map_sigma_m=0.05, window=span)
    np.testing.assert_allclose(got.filtered, plain.filtered, rtol=0, atol=1e-12 * np.abs(plain.filtered).max())
