"""The filter's floors and ceilings from a window of the route (:mod:`sensorsel.information.window_bounds`),
against the exact forward pass (itself checked against GTSAM in test_filtering.py) and against the
window's graph written out densely, factor by factor; and a route oracle deciding by them gives the
exact pass's answers."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from sensorsel.designs.requirements import checks
from sensorsel.designs.requirements.checks import RouteOracle
from sensorsel.designs.requirements.spec import Z95, Specification, covariance_verdict, preset
from sensorsel.designs.requirements.truncated import bad_keyframes, floors_to_solve, over_limits
from sensorsel.information.evaluators.fast import FastEvaluator
from sensorsel.information.filtering import forward_pass
from sensorsel.information.linearize import bearing_range_jacobians, odometry_jacobians
from sensorsel.information.window_bounds import WINDOW, WindowBounds, pass_flops
from sensorsel.model.sensing import SensorObservations

SUITES = [
    ("LRR-7", "HD2K-1"),
    ("WSC-12", "HD2K-4", "LSC-2"),
    ("LRR-7", "HD2K-12", "HD2K-1", "HD2K-2", "HD2K-4", "LSC-7"),
    ("MRL-roof",),
]


def _positions(problem, ids):
    return tuple(sorted(problem.library.position(i) for i in ids))


def _psd_gap(a: np.ndarray, b: np.ndarray) -> float:
    """The least eigenvalue of b − a over (k, 3, 3) stacks, relative to b's scale (≥ 0: a ⪯ b)."""
    return float(np.linalg.eigvalsh(b - a).min() / np.abs(b).max())


def _dense(problem, suite, k, window, map_sigma, ceiling):
    """Pose k's covariance in the window's graph, written out: every variable of the window (poses
    lo..k, the landmarks measured from them) in one dense information matrix, each factor added as
    its own Jacobian (odometry [H | I], each measurement [A | B] whitened by its σ), then inverted."""
    sc, s = problem.scenario, problem.settings
    poses, points = np.asarray(sc.keyframes.poses, float), np.asarray(sc.landmarks, float)
    lo = max(0, k - window)
    obs = [problem.observations[i] for i in suite]
    meas = [
        (int(kf), int(lm), sb, sr)
        for o in obs
        for kf, lm, sb, sr in zip(o.pose, o.landmark, o.sigma_bearing_rad, o.sigma_range_m)
        if kf <= k
    ]
    lms = sorted({lm for kf, lm, _, _ in meas if kf >= lo})
    col = {lm: 3 * (k - lo + 1) + 2 * i for i, lm in enumerate(lms)}
    n = 3 * (k - lo + 1) + 2 * len(lms)
    info = np.zeros((n, n))

    def add(jac, idx, noise_info):
        info[np.ix_(idx, idx)] += jac.T @ noise_info @ jac

    if lo == 0:
        add(np.eye(3), np.arange(3), np.diag(1 / np.asarray(s.first_pose_sigmas) ** 2))
    elif not ceiling:  # the pose before the window known: the odometry step is a prior on pose lo
        add(np.eye(3), np.arange(3), np.diag(1 / np.asarray(s.odometry_sigmas) ** 2))
    odo = odometry_jacobians(poses)
    for j in range(lo + 1, k + 1):
        add(
            np.hstack([odo[j - 1], np.eye(3)]),
            np.arange(3 * (j - 1 - lo), 3 * (j - lo) + 3),
            np.diag(1 / np.asarray(s.odometry_sigmas) ** 2),
        )
    for lm in lms:
        add(np.eye(2), np.arange(col[lm], col[lm] + 2), np.eye(2) / map_sigma**2)
    for kf, lm, sb, sr in meas:
        if lm not in col or (ceiling and kf < lo):
            continue
        jac = bearing_range_jacobians(poses[[kf]], points[[lm]])[0]
        w = np.diag([1 / sb**2, 1 / sr**2])
        if kf >= lo:
            add(jac, np.r_[3 * (kf - lo) : 3 * (kf - lo) + 3, col[lm] : col[lm] + 2], w)
        else:  # its pose known: the landmark's part alone
            add(jac[:, 3:], np.arange(col[lm], col[lm] + 2), w)
    return np.linalg.inv(info)[-3 - 2 * len(lms) : n - 2 * len(lms), -3 - 2 * len(lms) : n - 2 * len(lms)]


@pytest.mark.parametrize("ids", SUITES)
@pytest.mark.parametrize("window", [4, 16])
def test_floors_are_below_the_filter_and_ceilings_above_it(suburb_problem, ids, window):
    """At every keyframe: floor ⪯ the filter's covariance ⪯ ceiling (PSD order, to round-off), and
    where the window reaches the route's start both are the filter's."""
    suite = _positions(suburb_problem, ids)
    K = suburb_problem.scenario.n_poses
    exact = forward_pass(suburb_problem, suite, map_sigma_m=0.05).filtered
    floors, ceilings = WindowBounds(suburb_problem, 0.05, window)(suite, range(K))
    finite = np.isfinite(ceilings).all(axis=(1, 2))
    assert _psd_gap(floors, exact) >= -1e-9
    assert _psd_gap(exact[finite], ceilings[finite]) >= -1e-9
    start = slice(0, window + 1)
    np.testing.assert_allclose(floors[start], exact[start], rtol=0, atol=1e-10 * np.abs(exact).max())
    np.testing.assert_allclose(ceilings[start], exact[start], rtol=0, atol=1e-10 * np.abs(exact).max())
    # not vacuous: past the start the bounds differ from the filter, and the ceilings are finite there
    assert np.abs(floors[window + 1 :] - exact[window + 1 :]).max() > 1e-9 * np.abs(exact).max()
    assert finite[window + 1 :].mean() > 0.5


@pytest.mark.parametrize("k", [3, 20, 40])
def test_the_bounds_are_the_windows_graph_written_out(suburb_problem, k):
    """Each bound equals pose k's block of the inverse of its window's information matrix assembled
    densely, factor by factor (the floor: the poses before the window known; the ceiling: the
    window's factors alone)."""
    suite = _positions(suburb_problem, SUITES[1])
    floors, ceilings = WindowBounds(suburb_problem, 0.05, 8)(suite, [k])
    for got, ceiling in ((floors[0], False), (ceilings[0], True)):
        want = _dense(suburb_problem, suite, k, 8, 0.05, ceiling)
        np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-12 * np.abs(want).max())


def _dense_ceiling_on(problem, suite, poses, map_sigma):
    """The last of ``poses``' covariance in their subgraph, written out: those poses, the odometry
    steps between two of them that follow one another, the suite's measurements from them and their
    landmarks' priors (the first pose's prior where keyframe 0 is one), each factor its own Jacobian,
    in one dense information matrix, inverted."""
    sc, s = problem.scenario, problem.settings
    route, points = np.asarray(sc.keyframes.poses, float), np.asarray(sc.landmarks, float)
    poses = sorted(poses)
    col = {kf: 3 * i for i, kf in enumerate(poses)}
    meas = [
        (int(kf), int(lm), sb, sr)
        for o in (problem.observations[i] for i in suite)
        for kf, lm, sb, sr in zip(o.pose, o.landmark, o.sigma_bearing_rad, o.sigma_range_m)
        if int(kf) in col
    ]
    lms = sorted({lm for _, lm, _, _ in meas})
    col.update({("landmark", lm): 3 * len(poses) + 2 * i for i, lm in enumerate(lms)})
    n = 3 * len(poses) + 2 * len(lms)
    info = np.zeros((n, n))

    def add(jac, idx, noise_info):
        info[np.ix_(idx, idx)] += jac.T @ noise_info @ jac

    if poses[0] == 0:
        add(np.eye(3), np.arange(3), np.diag(1 / np.asarray(s.first_pose_sigmas) ** 2))
    odo = odometry_jacobians(route)
    for a, b in zip(poses, poses[1:]):
        if b == a + 1:
            add(
                np.hstack([odo[a], np.eye(3)]),
                np.r_[col[a] : col[a] + 3, col[b] : col[b] + 3],
                np.diag(1 / np.asarray(s.odometry_sigmas) ** 2),
            )
    for lm in lms:
        add(np.eye(2), np.arange(col[("landmark", lm)], col[("landmark", lm)] + 2), np.eye(2) / map_sigma**2)
    for kf, lm, sb, sr in meas:
        jac = bearing_range_jacobians(route[[kf]], points[[lm]])[0]
        c = col[("landmark", lm)]
        add(jac, np.r_[col[kf] : col[kf] + 3, c : c + 2], np.diag([1 / sb**2, 1 / sr**2]))
    last = col[poses[-1]]
    return np.linalg.inv(info)[last : last + 3, last : last + 3]


def _visits(problem, suite, k, window):
    """The keyframes before the window lo..k that measure a landmark the window measures (by hand)."""
    lo = max(0, k - window)
    meas = [
        (int(kf), int(lm))
        for i in suite
        for kf, lm in zip(problem.observations[i].pose, problem.observations[i].landmark)
    ]
    seen = {lm for kf, lm in meas if lo <= kf <= k}
    return sorted({kf for kf, lm in meas if kf < lo and lm in seen})


@pytest.mark.parametrize("ids", [SUITES[0], SUITES[2]])  # (suites whose visits leave gaps)
def test_the_ceilings_with_the_earlier_visits_bound_the_filter_tighter(suburb_problem, ids):
    """With the keyframes before the window that measure its landmarks, the ceiling at every keyframe
    is pose k's block of that subgraph's dense inverse (the visits found by hand; some keyframes have
    visits apart from the window, so the odometry steps that are not there are exercised), ⪰ the
    filter's covariance (a subgraph of its graph: to round-off), and ⪯ the window's own ceiling (a
    larger subgraph), strictly somewhere."""
    suite = _positions(suburb_problem, ids)
    K, w = suburb_problem.scenario.n_poses, 3
    bounds = WindowBounds(suburb_problem, 0.05, w)
    visits = bounds.ceilings_with_visits(suite, range(K))
    _, window = bounds(suite, range(K))
    exact = forward_pass(suburb_problem, suite, map_sigma_m=0.05).filtered
    apart = 0
    for k in range(w + 1, K):
        poses = [*_visits(suburb_problem, suite, k, w), *range(k - w, k + 1)]
        apart += len(poses) < k - poses[0] + 1  # a keyframe between the first and k left out
        want = _dense_ceiling_on(suburb_problem, suite, poses, 0.05)
        np.testing.assert_allclose(visits[k], want, rtol=1e-9, atol=1e-12 * np.abs(want).max())
    assert apart, "no keyframe whose poses leave a gap: the missing odometry steps are not exercised"
    finite = np.isfinite(window).all(axis=(1, 2))
    assert np.isfinite(visits).all(axis=(1, 2))[finite].all()
    assert _psd_gap(exact, visits) >= -1e-9
    assert _psd_gap(visits[finite], window[finite]) >= -1e-9
    assert (np.trace(visits[finite], axis1=1, axis2=2) < 0.99 * np.trace(window[finite], axis1=1, axis2=2)).any()


def test_a_longer_window_is_tighter(suburb_problem):
    """The floor with a longer window is conditioned on fewer poses (⪰ the shorter one's); the
    ceiling is of a larger subgraph (⪯): both close in on the filter."""
    suite = _positions(suburb_problem, SUITES[0])
    K = suburb_problem.scenario.n_poses
    bounds = WindowBounds(suburb_problem, 0.05)
    short, long_ = bounds(suite, range(20, K), 4), bounds(suite, range(20, K), 16)
    assert _psd_gap(short[0], long_[0]) >= -1e-9
    finite = np.isfinite(short[1]).all(axis=(1, 2))
    assert _psd_gap(long_[1][finite], short[1][finite]) >= -1e-9


def test_the_floors_are_solved_only_where_wanted(suburb_problem):
    """With ``floors_wanted``, each keyframe's ceiling is the bytes of the call without it, and so is
    its floor where the callback (given those ceilings) wants it; the others' floors are 0."""
    suite = _positions(suburb_problem, SUITES[2])
    K = suburb_problem.scenario.n_poses
    bounds = WindowBounds(suburb_problem, 0.05)
    full_floors, full_ceilings = bounds(suite, range(K))
    seen = []

    def every_third(ceilings: np.ndarray) -> np.ndarray:
        seen.append(ceilings.copy())
        return np.arange(len(ceilings)) % 3 == 0

    floors, ceilings = bounds(suite, range(K), floors_wanted=every_third)
    assert np.array_equal(ceilings, full_ceilings) and np.array_equal(seen[0], full_ceilings)
    wanted = np.arange(K) % 3 == 0
    assert np.array_equal(floors[wanted], full_floors[wanted])
    assert not floors[~wanted].any() and full_floors[~wanted].any()


@pytest.mark.parametrize("keyframes", [[30, 31], [45], [10, 12, 14], [3], [10, 30], [40, 8, 12]])
def test_the_bounds_from_the_windows_measurements_alone_are_the_routes(suburb_problem, keyframes):
    """Asked at a few keyframes, the ceilings and the floors are computed from the measurements of the
    windows alone (the keyframes of the windows gathered, not the route's before or between them; a
    floor's measurements before its window read sensor by sensor), and are the bytes of the calls that
    read the route up to them, with the floors left to a callback and without."""
    suite = _positions(suburb_problem, SUITES[2])
    assert len(suite) > 2  # several sensors: a keyframe's measurements in the suite's order
    w = 4
    windows = np.zeros(suburb_problem.scenario.n_poses + 1, bool)
    for k in keyframes:
        windows[max(0, k - w) : k + 1] = True
    route = WindowBounds(suburb_problem, 0.05, w)
    route._gathered(tuple(sorted(suite)), ((0, max(keyframes) + 1),))  # the route up to them, kept
    floors, ceilings = route(suite, keyframes)
    assert route._last is not None and route._last[1][: max(keyframes) + 1].all()
    for wanted in (None, lambda c: np.zeros(len(c), bool), lambda c: np.ones(len(c), bool)):
        near = WindowBounds(suburb_problem, 0.05, w)
        got_floors, got = near(suite, keyframes, floors_wanted=wanted)
        assert near._last is not None and np.array_equal(near._last[1], windows)
        assert np.array_equal(got, ceilings)
        assert np.array_equal(
            got_floors, np.zeros_like(floors) if wanted is not None and not wanted([0]).all() else floors
        )
    assert floors.any()
    for asked in (near, WindowBounds(suburb_problem, 0.05, w)):  # no keyframe: nothing (after others or first)
        none_floors, none_ceilings = asked(suite, [])
        assert none_floors.shape == none_ceilings.shape == (0, 3, 3)
        assert np.array_equal(asked(suite, keyframes)[1], ceilings)


@pytest.mark.parametrize("at", [1.0, 0.9])
@pytest.mark.parametrize("window", [4, 16])
def test_the_floors_left_unsolved_change_no_verdict(suburb_problem, at, window):
    """The floors ``floors_to_solve`` leaves unsolved (0) give every verdict the solved ones give: the
    keyframes over their limits (with the slack the oracle refutes by, and none), a rank rule's
    verdict and the violation. On growths of failing suites at limits scaled so that floors fall on
    both sides of them (not vacuous: some floors are over, some are skipped; a rule that skips them
    all fails here)."""
    lib = suburb_problem.library
    K = suburb_problem.scenario.n_poses
    bounds = WindowBounds(suburb_problem, 0.05, window)
    base = _positions(suburb_problem, ("LRR-7", "HD2K-1"))
    suites = [base] + [tuple(sorted((*base, j))) for j in range(0, len(lib.ids), 5) if j not in base]
    n_skipped = n_over = 0
    for scale in (0.6, 1.0):
        spec = replace(preset("local-streets"), at=at)
        spec = replace(spec, **{c: getattr(spec, c) * scale for c in ("lateral", "longitudinal", "heading")})
        for suite in suites:
            floors, ceilings = bounds(suite, range(K))
            wanted = floors_to_solve(ceilings, spec, -checks.WINDOW_SLACK)
            kept = np.where(wanted[:, None, None], floors, 0.0)
            for slack in (checks.WINDOW_SLACK, 0.0):
                assert np.array_equal(over_limits(kept, spec, slack), over_limits(floors, spec, slack))
            assert covariance_verdict(kept, spec) == covariance_verdict(floors, spec)
            n_skipped += int((~wanted).sum())
            n_over += int(over_limits(floors, spec, checks.WINDOW_SLACK).any(axis=0).sum())
    assert n_skipped > 0 and n_over > 0


def test_a_window_that_measures_too_little_has_no_ceiling(suburb_problem):
    """A ceiling without the route before its window rests on the landmarks the window measures:
    with none (a suite that measures nothing there) its system is singular and the ceiling +inf; the
    floor (its first pose conditioned on the one before) stays finite and below the filter."""
    suite = _positions(suburb_problem, ("LRR-6",))  # a side radar: keyframes 2-6 see nothing
    K = suburb_problem.scenario.n_poses
    measured = np.zeros(K, bool)
    measured[np.asarray(suburb_problem.observations[suite[0]].pose)] = True
    ks = [k for k in range(3, K) if not measured[k - 2 : k + 1].any()]  # past the first pose's prior
    assert ks, "the radar measures something in every window: nothing to check"
    floors, ceilings = WindowBounds(suburb_problem, 0.05, 2)(suite, ks)
    assert np.isinf(ceilings).all() and np.isfinite(floors).all()
    exact = forward_pass(suburb_problem, suite, map_sigma_m=0.05).filtered[ks]
    assert _psd_gap(floors, exact) >= -1e-9


def _growth(problem, spec):
    """A failing set and the suites of its growth (one sensor more each), as the search asks them."""
    lib = problem.library
    grown = _positions(problem, ("LRR-7", "HD2K-1", "HD2K-8", "HD2K-12"))
    assert not covariance_verdict(forward_pass(problem, grown, map_sigma_m=0.05).filtered, spec)[0]
    return grown, [tuple(sorted((*grown, j))) for j in range(len(lib.ids)) if j not in grown]


@pytest.mark.parametrize("windows", [checks.WINDOWS, (2, 4)])
def test_an_oracle_deciding_by_the_windows_answers_as_the_pass(suburb_problem, monkeypatch, windows):
    """Every suite of a failing set's growth gets the exact pass's answer from an oracle that decides
    by the windows' bounds; most are decided by them (not vacuous), some each way. With windows too
    short to decide (2 and 4 keyframes) the ceilings with the earlier visits accept some the windows
    leave undecided."""
    monkeypatch.setattr(checks, "WINDOWS", windows)
    spec = preset("local-streets")
    grown, suites = _growth(suburb_problem, spec)
    oracle = RouteOracle(FastEvaluator(suburb_problem), suburb_problem, "suburb", spec, 0.05, "filter")
    assert not oracle.meets(grown)
    for suite in suites:
        exact = covariance_verdict(forward_pass(suburb_problem, suite, map_sigma_m=0.05).filtered, spec)[0]
        assert oracle.meets(suite) == exact, suburb_problem.library.suite_ids(suite)
    assert oracle.n_window_accepted > 0 and oracle.n_window_refuted > 0
    if windows == (2, 4):
        assert oracle.n_visits_accepted > 0


def _tie(problem):
    """A failing sensor S, a suite T = S + one, and a specification (lateral, every keyframe) whose
    limit is T's largest σ, at a keyframe k the window reaches from the route's start, where T's
    floor there is above its exact σ by round-off alone (the same value computed two ways) and S is
    over the limit: (S, T, k, spec). None where no pair of sensors gives one."""
    lib = problem.library
    bounds = WindowBounds(problem, 0.05)
    S = (lib.position("MRR-1"),)
    S_lat = np.sqrt(forward_pass(problem, S, map_sigma_m=0.05).filtered[:, 1, 1])
    for j in range(len(lib.ids)):
        if j == S[0]:
            continue
        T = tuple(sorted((*S, j)))
        exact = forward_pass(problem, T, map_sigma_m=0.05).filtered
        lat = np.sqrt(exact[:, 1, 1])
        k = int(np.argmax(lat))
        if not 0 < k <= WINDOW or S_lat[k] <= lat[k]:
            continue
        spec = Specification(lateral=float(Z95 * lat[k]))
        while not covariance_verdict(exact, spec)[0]:  # the limit's own rounding: up an ulp at a time
            spec = Specification(lateral=float(np.nextafter(spec.lateral, np.inf)))
        floor = bounds(T, [k])[0]
        if len(bad_keyframes(floor, spec)[0]):  # over the limit at the tie, by round-off
            return S, T, k, spec
    return None


def test_a_keyframe_at_its_limit_is_left_to_the_pass(suburb_problem, monkeypatch):
    """Where a suite's σ is exactly at its limit at a keyframe the window reaches from the route's
    start, the window's floor equals it only to round-off: a floor a hair above the limit would
    refute a suite its own pass says meets. The slack leaves that keyframe to the pass (the exact
    answer); without it the oracle answers wrongly (the guard is exercised: checked below)."""
    found = _tie(suburb_problem)
    assert found, "no keyframe where the floor's round-off is above the pass's: nothing to guard"
    S, T, k, spec = found

    def answer() -> bool:
        oracle = RouteOracle(FastEvaluator(suburb_problem), suburb_problem, "suburb", spec, 0.05, "filter")
        assert not oracle.meets(S)  # its bad keyframes: k among them
        return oracle.meets(T)

    assert answer()
    monkeypatch.setattr(checks, "WINDOW_SLACK", 0.0)
    assert not answer(), "without the slack the round-off decides: the guard is not exercised"


def test_the_windows_decide_nothing_in_slam(suburb_problem):
    """In the SLAM graph the ceilings have no map to anchor them: the oracle does not ask the windows
    (their floors stay valid, below the filter)."""
    spec = preset("local-streets")
    grown, suites = _growth(suburb_problem, spec)
    oracle = RouteOracle(FastEvaluator(suburb_problem), suburb_problem, "suburb", spec, None, "filter")
    oracle.meets(grown)
    for suite in suites[:5]:
        oracle.meets(suite)
    assert oracle.n_window_accepted == oracle.n_window_refuted == 0
    suite = suites[0]
    K = suburb_problem.scenario.n_poses
    floors, _ = WindowBounds(suburb_problem, None)(suite, range(K))
    assert _psd_gap(floors, forward_pass(suburb_problem, suite, map_sigma_m=None).filtered) >= -1e-9


def test_a_growth_with_the_windows_asks_fewer_passes(suburb_problem, monkeypatch):
    """The same answers with the windows off; with them on, fewer accuracy computations."""
    spec = preset("local-streets")
    grown, suites = _growth(suburb_problem, spec)
    runs = {}
    for on in (True, False):
        monkeypatch.setattr(RouteOracle, "window_bounds", on)
        oracle = RouteOracle(FastEvaluator(suburb_problem), suburb_problem, "suburb", spec, 0.05, "filter")
        runs[on] = ([oracle.meets(grown)] + [oracle.meets(s) for s in suites], oracle.n_checks)
    assert runs[True][0] == runs[False][0]
    assert runs[True][1] < runs[False][1]


def test_the_violation_the_greedy_ranks_by_is_zero_exactly_when_the_pass_meets(suburb_problem):
    """Asked for a violation (the solver's greedy), the oracle answers 0 exactly for a suite that
    meets, and for one that fails a positive number no larger than its pass's (the smoother's, or the
    windows' floors' at its bad keyframes: lower bounds), some of them from the windows."""
    spec = preset("local-streets")
    grown, suites = _growth(suburb_problem, spec)
    oracle = RouteOracle(FastEvaluator(suburb_problem), suburb_problem, "suburb", spec, 0.05, "filter")
    assert oracle.violation(grown) > 0
    for suite in suites:
        meets, exact = covariance_verdict(forward_pass(suburb_problem, suite, map_sigma_m=0.05).filtered, spec)
        got = oracle.violation(suite)
        if meets:
            assert got == 0.0, suburb_problem.library.suite_ids(suite)
        else:
            assert 0.0 < got <= exact + 1e-12, suburb_problem.library.suite_ids(suite)  # (a ratio: round-off)
    assert oracle._window_violations and oracle.n_window_accepted > 0


def test_a_dear_suite_is_decided_by_the_windows_at_every_keyframe(suburb_problem, monkeypatch):
    """A suite asked first (no failing suite inside it says where it can fail) whose pass is dear is
    decided by the windows' bounds at every keyframe: where they decide, the exact pass's answer, both
    ways among a growth's suites; at the default threshold the bundled route's suites are not dear
    (their passes are cheap) and the windows are not asked of them there."""
    spec = preset("local-streets")
    grown, suites = _growth(suburb_problem, spec)
    suites = [grown, *suites]

    def verdicts() -> list[bool | None]:
        # a new oracle each: nothing learnt from the suites before (no failing suite inside is known)
        return [
            RouteOracle(FastEvaluator(suburb_problem), suburb_problem, "suburb", spec, 0.05, "filter")._window_verdict(
                s, scope="dear"
            )
            for s in suites
        ]

    assert all(pass_flops(suburb_problem, s) < checks.DEAR_PASS for s in suites)
    assert verdicts() == [None] * len(suites)
    monkeypatch.setattr(checks, "DEAR_PASS", 0.0)
    got = verdicts()
    for s, g in zip(suites, got):
        if g is not None:
            exact = covariance_verdict(forward_pass(suburb_problem, s, map_sigma_m=0.05).filtered, spec)[0]
            assert g == exact, suburb_problem.library.suite_ids(s)
    assert got.count(True) > 0 and got.count(False) > 0


def test_the_pass_model_counts_a_hand_worked_route(suburb_problem):
    """pass_flops on one sensor's hand-made measurements: landmark 0 at keyframes 0, 1, 2 and landmark 1
    at keyframes 0 and 40 (two runs: 40 apart is past a window). Active a (runs covering k): 2 at 0,
    1 at 1, 2 and 40; held h (first to last): 2 at 0-2, 1 at 3-40; rows r: 4 at 0, 2 at 1, 2, 40.
    Updates (3 + 2a)² r: 49·4 + 25·2 · 3 = 346; closes (2(h − a))² 2a / 16: 4·2/16 at keyframes 1
    and 2 = 1; per keyframe of the route: 347 / K."""
    pose, landmark = np.array([0, 1, 2, 0, 40]), np.array([0, 0, 0, 1, 1])
    one = SensorObservations(pose, landmark, *(np.ones(5) for _ in range(4)), sensor=0)
    empty = SensorObservations(*(np.zeros(0, np.int64) for _ in range(2)), *(np.zeros(0) for _ in range(4)), sensor=1)
    n = suburb_problem.n_sensors
    problem = replace(suburb_problem, observations=(one, *(replace(empty, sensor=i) for i in range(1, n))))
    K = problem.scenario.n_poses
    assert K > 40
    assert pass_flops(problem, [0]) == pytest.approx(347 / K, rel=1e-12)
    assert pass_flops(problem, [1]) == pass_flops(problem, []) == 0.0


def test_a_floor_whose_window_reaches_the_start_is_its_ceiling_solved_again(suburb_problem):
    """Where the window reaches the route's start (k <= w) nothing lies before it, and the floor given
    is the ceiling; solving the floor's own system there (the odometry prior replaced by the first
    pose's, no measurement before the window) gives the same bytes, so the shortcut changes nothing.
    Past the start the floor is solved, below the ceiling."""
    suite = _positions(suburb_problem, SUITES[2])
    w = 6
    bounds = WindowBounds(suburb_problem, 0.05, w)
    floors, ceilings = bounds(suite, range(12))
    terms = bounds._gathered(tuple(sorted(suite)), ((0, 12),))
    starts = np.searchsorted(terms[0], np.arange(13))
    for k in range(w + 1):
        solved = bounds._floor(bounds._system(k, w, *terms, starts), tuple(sorted(suite)), 0)
        assert np.array_equal(solved, ceilings[k]) and np.array_equal(floors[k], ceilings[k])
    assert all(not np.array_equal(floors[k], ceilings[k]) for k in range(w + 1, 12))
