"""Accepting a suite from an upper bound (:mod:`sensorsel.designs.requirements.accept`): the bound is
above the suite's own filter at every keyframe it covers (against the exact forward pass), and an
oracle that accepts by it answers every suite of a failing set's growth as the exact pass does."""

from __future__ import annotations

import numpy as np
import pytest

from sensorsel.designs.requirements import accept
from sensorsel.designs.requirements.accept import base_of, upper_bound
from sensorsel.designs.requirements.checks import RouteOracle
from sensorsel.designs.requirements.oracle import mask_of
from sensorsel.designs.requirements.spec import Specification, covariance_verdict, preset
from sensorsel.information.evaluators.fast import FastEvaluator
from sensorsel.information.filtering import forward_pass

#: a failing set met on the way by the README tour's search, and the sensors it is grown over
GROWN = ("LRR-7", "HD2K-12", "HD2K-1", "HD2K-2", "HD2K-4", "LSC-7")


def _sigmas(cov: np.ndarray) -> np.ndarray:
    return np.sqrt(np.diagonal(cov, axis1=1, axis2=2))


@pytest.mark.parametrize(
    ("base", "added", "restart"),
    [
        # a side camera that stops seeing landmarks which another camera of the suite sees later
        # (test_without_the_drop_the_bound_is_no_bound: those later measurements taken as of fresh
        # landmarks put the bound below the exact σ)
        (("WSC-12",), ("WSC-7",), 3),
        (("WSC-12",), ("WSC-6",), 6),
        (("WSC-11",), ("MRL-roof",), 6),
        (("LRR-7", "HD2K-1"), ("HD2K-5", "LSC-2"), 20),
    ],
)
def test_the_bound_is_above_the_suites_filter_and_below_its_bases(suburb_problem, base, added, restart):
    lib = suburb_problem.library
    S = tuple(sorted(lib.position(i) for i in base))
    T = tuple(sorted(S + tuple(lib.position(i) for i in added)))
    spec = Specification(lateral=0.001)  # every keyframe bad: the base's states are kept at every keyframe
    b = base_of(suburb_problem, S, mask_of(S), spec, 0.05)
    K = suburb_problem.scenario.n_poses
    bound = upper_bound(suburb_problem, b, T, 0.05, ((restart, K - 1),))
    exact = forward_pass(suburb_problem, T, map_sigma_m=0.05).filtered
    alone = forward_pass(suburb_problem, S, map_sigma_m=0.05).filtered
    # the same pass, in windows that end at the states it keeps: equal to round-off
    np.testing.assert_allclose(b.filtered, alone, rtol=0, atol=1e-12 * np.abs(alone).max())
    for k in range(restart, K):
        scale = np.abs(exact[k]).max()
        # PSD order: bound ⪰ the suite's filter (a subgraph of its graph), ⪯ the base's filter
        assert np.linalg.eigvalsh(bound[k] - exact[k]).min() >= -1e-9 * scale, k
        assert np.linalg.eigvalsh(alone[k] - bound[k]).min() >= -1e-9 * scale, k
    assert np.all(_sigmas(bound)[restart:] >= _sigmas(exact)[restart:] * (1 - 1e-12))
    # before the restart the bound is the base's own filter
    assert np.array_equal(bound[:restart], b.filtered[:restart])


def test_the_growth_of_a_failing_set_is_answered_as_the_exact_pass_answers(suburb_problem, monkeypatch):
    # the bases' bounds alone (the windows' bounds decide most of these first: test_window_bounds.py)
    monkeypatch.setattr(RouteOracle, "window_bounds", False)
    lib = suburb_problem.library
    spec = preset("local-streets")
    grown = tuple(sorted(lib.position(i) for i in GROWN))
    oracle = RouteOracle(FastEvaluator(suburb_problem), suburb_problem, "suburb", spec, 0.05, "filter")

    def exact(suite: tuple[int, ...]) -> bool:
        return covariance_verdict(forward_pass(suburb_problem, suite, map_sigma_m=0.05).filtered, spec)[0]

    assert not oracle.meets(grown) and not exact(grown)
    answers = []
    for j in range(0, len(lib.ids), 2):  # every other sensor of the library, in library order
        if j in grown:
            continue
        suite = tuple(sorted((*grown, j)))
        answers.append(oracle.meets(suite))
        assert answers[-1] == exact(suite), lib.ids[j]
    assert True in answers and False in answers, "the growth never crosses the specification"
    accepted = oracle.bases.n_accepted
    assert accepted > 0, "no suite was accepted by a bound: the rule is not exercised"
    # the base's pass is counted among the accuracy computations; the accepted suites are not
    assert oracle.n_checks <= len(answers) + 1 - accepted


def test_a_pass_restarted_from_its_own_state_is_the_same_pass(suburb_problem):
    """``forward_pass(start=...)`` from a pass's own predicted state gives that pass's numbers, bit
    for bit, from there on (what the bound's restarts rest on)."""
    suite = tuple(sorted(suburb_problem.library.position(i) for i in ("LRR-7", "HD2K-4", "HD2K-9", "LSC-2")))
    states = {}
    whole = forward_pass(
        suburb_problem, suite, map_sigma_m=0.05, on_prediction=lambda p, _: states.__setitem__(p.keyframe, p)
    )
    for a in (0, 7, 30, suburb_problem.scenario.n_poses - 1):
        part = forward_pass(suburb_problem, suite, map_sigma_m=0.05, start=states[a], until=a + 12)
        assert np.array_equal(part.filtered, whole.filtered[a : a + 12])
        assert np.array_equal(part.predicted, whole.predicted[a : a + 12])


def test_without_the_drop_the_bound_is_no_bound(suburb_problem):
    """Why the bound leaves out the measurements of landmarks the base saw and no longer holds: taken
    as of fresh landmarks (the map's prior counted twice) they make the restarted pass more
    confident than the suite's own filter, at keyframes where the drop keeps it above."""
    lib = suburb_problem.library
    S = (lib.position("WSC-12"),)
    T = tuple(sorted((*S, lib.position("WSC-7"))))
    b = base_of(suburb_problem, S, mask_of(S), Specification(lateral=0.001), 0.05)
    exact = _sigmas(forward_pass(suburb_problem, T, map_sigma_m=0.05).filtered)[3:]
    fresh = _sigmas(forward_pass(suburb_problem, T, map_sigma_m=0.05, start=b.states[3]).filtered)
    K = suburb_problem.scenario.n_poses
    dropped = _sigmas(upper_bound(suburb_problem, b, T, 0.05, ((3, K - 1),)))[3:]
    assert np.any(fresh < exact * (1 - 1e-6))
    assert np.all(dropped >= exact * (1 - 1e-12))


def test_a_failing_suites_own_pass_is_the_base_of_its_growths_bounds(suburb_problem):
    """A failing suite's whole pass (its states kept) is offered as the base of the bounds its growth
    asks for: each suite of the growth gets the bound a base computed anew gives it, with no second
    pass of the failing suite. A base offered for another suite is not taken."""
    from sensorsel.designs.requirements.accept import Bases

    lib = suburb_problem.library
    spec = preset("local-streets")
    grown = tuple(sorted(lib.position(i) for i in ("LRR-7", "HD2K-1", "HD2K-8", "HD2K-12")))
    failed = mask_of(grown)
    oracle = RouteOracle(FastEvaluator(suburb_problem), suburb_problem, "suburb", spec, 0.05, "filter")
    assert not oracle._answer(grown)[0] and oracle.n_checks == 1
    offered = oracle.bases._offered
    assert offered is not None and offered.mask == failed
    alone = forward_pass(suburb_problem, grown, map_sigma_m=0.05).filtered
    # the same pass, its windows ending at the states it keeps: equal to round-off
    np.testing.assert_allclose(offered.filtered, alone, rtol=0, atol=1e-12 * np.abs(alone).max())
    fresh = base_of(suburb_problem, grown, failed, spec, 0.05)
    assert offered.windows == fresh.windows and offered.states.keys() == fresh.states.keys()
    kept, anew = [], []
    for j in (j for j in range(len(lib.ids)) if j not in grown):
        suite = tuple(sorted((*grown, j)))
        for got, bases in ((kept, oracle.bases), (anew, Bases())):
            if bases is oracle.bases:
                bases._bases, bases._offered = [], offered  # each suite from the offered base alone
            got.append(bases.accepts(suburb_problem, suite, mask_of(suite), failed, spec, 0.05))
            assert bases.n_passes == (0 if got is kept else 1)
    assert kept == anew and True in kept and False in kept
    # offered for another suite: a base of the failing set's own is computed
    other = Bases()
    other.offer(base_of(suburb_problem, grown[:-1], mask_of(grown[:-1]), spec, 0.05))
    suite = tuple(sorted((*grown, lib.position("LSC-2"))))
    other.accepts(suburb_problem, suite, mask_of(suite), failed, spec, 0.05)
    assert other.n_passes == 1 and other._bases[-1].mask == failed


def test_a_bound_whose_windows_hold_no_added_measurement_is_not_passed(suburb_problem):
    """A sensor added to the base that measures nothing within a bound's windows leaves the bound
    there equal to the base's own filter, bit for bit (the same measurements from the same states):
    it cannot accept, so :class:`~sensorsel.designs.requirements.accept.Bases` skips that pass (counted
    in ``n_empty``) and still accepts through the next, longer windows where they hold one."""
    from sensorsel.designs.requirements.accept import Bases, _measures_within

    lib = suburb_problem.library
    spec = preset("local-streets")
    grown = tuple(sorted(lib.position(i) for i in GROWN))
    b = base_of(suburb_problem, grown, mask_of(grown), spec, 0.05)
    assert b.windows, "the base meets the specification: no windows"
    silent = [
        j for j in range(len(lib.ids)) if j not in grown and not _measures_within(suburb_problem, [j], b.windows[0])
    ]
    assert silent, "every sensor measures within the first windows: the skip is not exercised"
    for j in silent:
        suite = tuple(sorted((*grown, j)))
        bound = upper_bound(suburb_problem, b, suite, 0.05, b.windows[0])
        assert np.array_equal(bound, b.filtered), lib.ids[j]
    # the skip: no pass for the first windows of a silent sensor's suite, and no wrong acceptance
    bases = Bases()
    bases._bases = [b]
    for j in silent:
        suite = tuple(sorted((*grown, j)))
        exact = covariance_verdict(forward_pass(suburb_problem, suite, map_sigma_m=0.05).filtered, spec)[0]
        assert not bases.accepts(suburb_problem, suite, mask_of(suite), None, spec, 0.05) or exact, lib.ids[j]
    assert bases.n_empty >= len(silent)


@pytest.mark.parametrize("budget", [0, 1 << 20, 4 << 20, 1 << 40])
def test_the_states_kept_are_those_the_byte_budget_allows(suburb_problem, monkeypatch, budget):
    """The stride of a base's kept states, from the landmarks' first and last keyframes before the
    pass, against the rule applied to the states a dense pass holds (the oracle: every keyframe's
    predicted state, its bytes; stride doubled from 1 while every stride-th keyframe's take more than
    the budget and the stride is below the route's length)."""
    monkeypatch.setattr(accept, "STATE_BYTES", budget)
    monkeypatch.setattr(accept, "HORIZON", 8)  # shorter than the route: states keep fewer landmarks
    lib = suburb_problem.library
    S = tuple(sorted(lib.position(i) for i in ("LRR-7", "HD2K-4", "HD2K-9", "LSC-2")))
    # (landmark, keyframe) some library sensor measures, from the observations themselves
    measured = {(int(l_), int(k)) for o in suburb_problem.observations for l_, k in zip(o.landmark, o.pose)}
    nbytes = {}

    def kept_bytes(p, m) -> None:  # the state's marginal over the landmarks measured within the horizon
        near = [
            l_ for l_ in p.landmarks.tolist() if any((l_, j) in measured for j in range(p.keyframe, p.keyframe + 9))
        ]
        nbytes[p.keyframe] = (3 + 2 * len(near)) ** 2 * 8

    forward_pass(suburb_problem, S, map_sigma_m=0.05, on_prediction=kept_bytes)
    K = suburb_problem.scenario.n_poses
    stride = 1
    while sum(b for k, b in nbytes.items() if k % stride == 0) > budget and stride < K:
        stride *= 2
    b = base_of(suburb_problem, S, mask_of(S), Specification(lateral=0.001), 0.05)
    assert sorted(b.states) == list(range(0, K, stride))
    assert sum(s.covariance.nbytes for s in b.states.values()) <= budget or stride >= K


@pytest.mark.parametrize("horizon", [2, 6, 12])
def test_a_state_kept_within_a_horizon_restarts_a_pass_as_the_whole_state_does(suburb_problem, horizon):
    """A kept state holds only the landmarks some library sensor measures within the horizon after
    it: no suite measures the others before then, so a pass of a larger suite restarted from it and
    stopped by then has the whole state's covariances (the marginal is exact), though it holds fewer
    landmarks (the test is not vacuous)."""
    lib = suburb_problem.library
    S = tuple(sorted(lib.position(i) for i in ("LRR-7", "HD2K-1")))
    T = tuple(sorted(S + tuple(lib.position(i) for i in ("HD2K-5", "LSC-2", "WSC-6"))))
    K = suburb_problem.scenario.n_poses
    keep = range(4, K - horizon, 5)
    whole = forward_pass(suburb_problem, S, map_sigma_m=0.05, keep_states=keep).states
    near = forward_pass(suburb_problem, S, map_sigma_m=0.05, keep_states=keep, keep_horizon=horizon).states
    dropped = 0
    for a in keep:
        dropped += len(whole[a].landmarks) - len(near[a].landmarks)
        assert set(near[a].landmarks.tolist()) <= set(whole[a].landmarks.tolist())
        got = [
            forward_pass(suburb_problem, T, map_sigma_m=0.05, start=s[a], until=a + horizon + 1).filtered
            for s in (whole, near)
        ]
        np.testing.assert_allclose(got[1], got[0], rtol=0, atol=1e-12 * np.abs(got[0]).max())
    assert dropped > 0


@pytest.mark.parametrize("horizon", [0, 3, 10, 64])
def test_a_state_kept_within_a_horizon_is_the_whole_states_rows_of_the_landmarks_measured_within_it(
    suburb_problem, horizon
):
    """Each kept state holds, of the whole predicted state, exactly the rows and columns of the pose and
    of the landmarks some library sensor measures at keyframes k .. k + horizon (the oracle: the
    observations themselves), bit for bit, in the whole state's order: whether a landmark's next
    measurement by the suite already says so or the library's are looked up (a horizon past the
    route's end keeps the whole state; 0 keeps the landmarks measured at k only)."""
    lib = suburb_problem.library
    S = tuple(sorted(lib.position(i) for i in ("LRR-7", "HD2K-1", "WSC-6", "LSC-2")))
    K = suburb_problem.scenario.n_poses
    measured = {(int(l_), int(k)) for o in suburb_problem.observations for l_, k in zip(o.landmark, o.pose)}
    whole = forward_pass(suburb_problem, S, map_sigma_m=0.05, keep_states=range(K)).states
    kept = forward_pass(suburb_problem, S, map_sigma_m=0.05, keep_states=range(K), keep_horizon=horizon).states
    left_out = 0
    for k in range(K):
        w = whole[k]
        near = [
            i
            for i, l_ in enumerate(w.landmarks.tolist())
            if any((l_, j) in measured for j in range(k, k + horizon + 1))
        ]
        rows = np.concatenate([np.arange(3), 3 + 2 * np.repeat(near, 2) + np.tile([0, 1], len(near))]).astype(int)
        assert kept[k].landmarks.tolist() == w.landmarks[near].tolist(), k
        assert np.array_equal(kept[k].covariance, w.covariance[np.ix_(rows, rows)]), k
        left_out += len(w.landmarks) - len(near)
    assert (left_out == 0) == (horizon >= K)


def test_a_bound_past_the_kept_states_horizon_is_refused(suburb_problem):
    """A bound over more keyframes than the kept states serve would take the landmarks they left out
    as fresh ones (below the suite's own σ): refused, not computed."""
    lib = suburb_problem.library
    S = (lib.position("WSC-12"),)
    b = base_of(suburb_problem, S, mask_of(S), Specification(lateral=0.001), 0.05)
    with pytest.raises(ValueError, match="horizon"):
        upper_bound(suburb_problem, b, S, 0.05, ((0, accept.HORIZON + 1),))


@pytest.mark.parametrize("horizon", [0, 3, 10, 64, 10_000])
def test_the_landmarks_a_kept_state_holds_are_counted_as_the_observations_say(suburb_problem, monkeypatch, horizon):
    """The count by intervals behind a base's stride (how many landmarks the state kept at keyframe j
    holds) equals, at every keyframe, the count from the observations themselves: the landmarks the
    suite measured before j and measures again at j or later, that some library sensor measures at a
    keyframe in j .. j + horizon (several suites, horizons from none to past the route's end)."""
    monkeypatch.setattr(accept, "HORIZON", horizon)
    lib = suburb_problem.library
    K = suburb_problem.scenario.n_poses
    measured = {(int(l_), int(k)) for o in suburb_problem.observations for l_, k in zip(o.landmark, o.pose)}
    counted = 0
    for ids in (("LRR-7", "HD2K-1", "WSC-6", "LSC-2"), ("WSC-12",), ("LRL-roof", "MRR-3"), ("HD2K-4", "HD2K-5")):
        suite = [lib.position(i) for i in ids]
        pairs = {
            (int(l_), int(k))
            for i in suite
            for l_, k in zip(suburb_problem.observations[i].landmark, suburb_problem.observations[i].pose)
        }
        first = np.full(suburb_problem.scenario.n_landmarks, K, np.int64)
        last = np.full(suburb_problem.scenario.n_landmarks, -1, np.int64)
        for l_, k in pairs:
            first[l_], last[l_] = min(first[l_], k), max(last[l_], k)
        oracle = [
            sum(
                1
                for l_ in range(len(last))
                if first[l_] < j <= last[l_] and any((l_, t) in measured for t in range(j, j + horizon + 1))
            )
            for j in range(K)
        ]
        got = accept.held_within_horizon(suburb_problem, first, last, K)
        assert got.tolist() == oracle, ids
        counted += sum(oracle)
    assert counted > 0
