"""Lazy greedy on a domain, member by member: a candidate's routes are scored one
at a time and it keeps a bound once the bound shows it cannot win. The picks and every number of
the steps must be those of the plain greedy (each candidate scored exactly on every route, every
step) and of the lazy greedy that scores whole domain evaluations, bit for bit."""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np
import pytest

from sensorsel.designs.selection import greedy
from sensorsel.information.evaluators import DomainEvaluator, Evaluator
from sensorsel.model.problem import load_domain

CITY = (
    "conditions:\n  - {name: night, night: true, share: 0.25}\n  - {name: rain, rain_mm_h: 5, share: 0.08}\n"
    "  - {name: fog, fog_visibility_m: 150, share: 0.005}\n"
)


class Recording(DomainEvaluator):
    """The domain's evaluator, counting the candidates it answered with a bound."""

    n_bounded = 0

    def scores_or_bounds(
        self, suite: Iterable[int], candidates: Sequence[int], needed: np.ndarray, **kw
    ) -> tuple[np.ndarray, np.ndarray]:
        vals, exact = super().scores_or_bounds(suite, candidates, needed, **kw)
        self.n_bounded += int(np.sum(~exact))
        return vals, exact


class WholeDomain(DomainEvaluator):
    """The domain's evaluator without per-member lazy scoring: every candidate scored on every route."""

    bounds_candidates = False

    def scores_or_bounds(
        self, suite: Iterable[int], candidates: Sequence[int], needed: np.ndarray, **kw
    ) -> tuple[np.ndarray, np.ndarray]:
        return Evaluator.scores_or_bounds(self, suite, candidates, needed)


def _steps(result):
    return [(s.pick, s.score, s.gain, s.rule_value, s.cost_usd) for s in result.steps]


def _member_evaluations(ev: DomainEvaluator) -> int:
    return sum(r.n_evaluations for r in ev.routes)


def _city(tmp_path_factory, routes: str):
    p = tmp_path_factory.mktemp("lazy") / "city.yaml"
    p.write_text(CITY + "routes:\n" + routes)
    return load_domain(p)


@pytest.fixture(scope="module")
def tiny_city(tmp_path_factory):
    """The tiny fixture route in four conditions: four members (the plain greedy's oracle is quick)."""
    return _city(tmp_path_factory, "  - {name: tiny, fixture: tiny, weight: 1}\n")


@pytest.fixture(scope="module")
def city(tmp_path_factory):
    """Two fixture routes in four conditions: eight members."""
    return _city(
        tmp_path_factory, "  - {name: suburb, fixture: suburb, weight: 2}\n  - {name: tiny, fixture: tiny, weight: 1}\n"
    )


@pytest.mark.parametrize("rule, budget", [("uniform", 110_000), ("uniform", 12_000), ("marginal", 110_000)])
def test_member_by_member_equals_plain_greedy_bit_for_bit(tiny_city, rule, budget):
    ev = Recording(tiny_city)
    lazy = greedy(ev, budget, rule)
    plain = greedy(DomainEvaluator(tiny_city), budget, rule, lazy=False)
    assert lazy.suite == plain.suite and _steps(lazy) == _steps(plain)  # ==: the same floats, not approximately
    assert lazy.score == plain.score
    assert ev.n_bounded > 0  # the path under test was taken: some candidates kept a bound instead of a score


@pytest.mark.parametrize("rule", ["uniform", "marginal"])
def test_member_by_member_equals_whole_domain_evaluations_with_fewer_route_scores(city, rule):
    new, old = Recording(city), WholeDomain(city)
    a, b = greedy(new, 110_000, rule), greedy(old, 110_000, rule)
    assert a.suite == b.suite and _steps(a) == _steps(b) and a.score == b.score
    assert new.n_bounded > 0 and _member_evaluations(new) < _member_evaluations(old)


def test_a_second_run_on_the_same_evaluator_forgets_the_first_runs_bounds(tiny_city):
    # a strategy (best-of) or a caller runs greedy again on one evaluator from the empty suite, where
    # the first run's gains at larger suites bound nothing: the second run is that of a fresh evaluator
    ev = Recording(tiny_city)
    greedy(ev, 110_000)
    for rule, budget in (("marginal", 20_000), ("uniform", 9_000)):
        again = greedy(ev, budget, rule)
        assert _steps(again) == _steps(greedy(DomainEvaluator(tiny_city), budget, rule, lazy=False))


@pytest.mark.kitti
def test_kitti_routes_in_four_conditions_same_picks_as_whole_domain_evaluations(kitti_root, tmp_path, monkeypatch):
    monkeypatch.setenv("SENSORSEL_KITTI_ROOT", str(kitti_root))
    p = tmp_path / "k.yaml"
    p.write_text(
        CITY + "keyframe_rate_hz: 1.0\nweight_unit: km\nroutes:\n  - {name: kitti-03, seq: '03', landmarks: real}\n"
        "  - {name: kitti-04, seq: '04', landmarks: real}\n"
    )
    d = load_domain(p)
    new, old = Recording(d), WholeDomain(d)
    a, b = greedy(new, 110_000), greedy(old, 110_000)
    assert a.suite == b.suite and _steps(a) == _steps(b) and a.score == b.score
    assert new.n_bounded > 0 and _member_evaluations(new) < _member_evaluations(old)


def test_night_members_measure_lidars_and_radars_as_their_clear_member_does(city):
    # the premise of bounding a night member by its clear member while the suite has no camera:
    # night changes the cameras only (their arrays are new), every other sensor keeps its arrays
    from sensorsel.information.evaluators.domain import clear_partners

    partner, alike = clear_partners(city, len(city.library))
    cameras = np.array([s.model.type == "stereo" for s in city.library])
    assert cameras.any() and not cameras.all()
    for k, r in enumerate(city.routes):
        if r.condition == "clear":
            assert partner[k] == -1
            continue
        p = city.routes[partner[k]]
        assert p.condition == "clear" and p.route_name == r.route_name
        if r.condition == "night":
            assert np.array_equal(alike[k], ~cameras)
        # every member: "alike" only where the measurements are equal in content (the oracle: the
        # arrays; a radar whose range rain shortens past every landmark is equal but not "alike":
        # conservative, a bound unused, never a wrong one)
        for s, (a, b) in enumerate(zip(r.problem.observations, p.problem.observations)):
            same = all(
                np.array_equal(getattr(a, f), getattr(b, f))
                for f in ("pose", "landmark", "range_m", "sigma_bearing_rad", "sigma_range_m")
            )
            assert same or not alike[k, s], (r.name, city.library.ids[s])


@pytest.mark.parametrize("with_camera", [False, True])
def test_a_member_measuring_suite_and_candidate_as_its_clear_member_does_gets_its_score_copied(city, with_camera):
    # a night member with no camera in S + {c} has its clear member's information matrix: lazy greedy
    # copies the clear member's f(S + {c}) instead of evaluating it. The oracle: every member's own
    # engine (a fresh evaluator) scoring every candidate; the copies must be its numbers to the bit,
    # and a camera (which night changes) or a suite holding one must still be scored by the member
    cameras = np.array([s.model.type == "stereo" for s in city.library])
    others = np.flatnonzero(~cameras).tolist()
    S = (others[0], int(np.flatnonzero(cameras)[0])) if with_camera else (others[0],)
    cand = [c for c in range(len(city.library)) if c not in S]
    ev, ref = DomainEvaluator(city), DomainEvaluator(city)
    before = [r.n_evaluations for r in ev.routes]
    vals, exact = ev.scores_or_bounds(S, cand, np.full(len(cand), -np.inf))
    oracle = np.stack([r.scores_with(S, cand) for r in ref.routes])
    assert exact.all()
    assert ev._lazy is not None
    got = np.stack([ev._lazy.known[c] for c in cand], axis=1)
    assert np.array_equal(got, oracle)  # bit for bit, copies included
    assert np.array_equal(vals, ref.combine(oracle))
    spent = [r.n_evaluations - b for r, b in zip(ev.routes, before)]
    n_cam = int(cameras[cand].sum())
    spent = [n - 1 for n in spent]  # f_m(S) itself, scored once by every member at a new suite
    for k, r in enumerate(city.routes):
        if r.condition == "night":
            assert spent[k] == (len(cand) if with_camera else n_cam)  # copies cost no evaluation
        else:
            assert spent[k] == len(cand)  # rain and fog change the LiDARs in S: no copies


@pytest.mark.parametrize("with_camera", [False, True])
def test_members_seeing_the_suite_as_their_clear_member_does_share_its_pose_covariance_for_bounds(city, with_camera):
    # the night members' gain bounds, made with their clear member's pose covariance while S holds
    # no camera, must be those of their own engine (a fresh evaluator: its own covariance) and bound
    # every exact gain (the oracle: each member's scores); with a camera in S nothing is shared
    cameras = np.array([s.model.type == "stereo" for s in city.library])
    others = np.flatnonzero(~cameras).tolist()
    S = (others[0], int(np.flatnonzero(cameras)[0])) if with_camera else (others[0],)
    cand = [c for c in range(len(city.library)) if c not in S]
    ev, ref = DomainEvaluator(city), DomainEvaluator(city)
    st = ev._lazy_at(S)
    assert st is not None and st.as_clear.any() != with_camera
    got = ev._member_gain_bounds(S, cand, st)
    for k, r in enumerate(city.routes):
        own = ref.routes[k].gain_bounds(S, cand)
        assert (got[k] is None) == (own is None)
        if own is None:
            continue
        assert np.allclose(got[k], own, rtol=1e-9, atol=1e-12), r.name
        exact = ref.routes[k].scores_with(S, cand) - ref.routes[k].score(S)
        assert np.all(exact <= got[k] * (1 + 1e-9) + 1e-9), r.name
    assert all(got[k] is not None for k, r in enumerate(city.routes) if r.condition == "night")  # the path under test


def test_shared_pair_quadratics_are_used_only_where_they_hold_every_pair(city):
    # a member's bounds from another engine's pair quadratics: looked up by (keyframe, landmark);
    # a pair they do not hold must not be read as another's (the lookup gives up: computed afresh)
    ev = DomainEvaluator(city)
    clear = ev.routes[0]
    S = (0,)
    from sensorsel.information.evaluators.fast import bound

    states, b = clear._states, clear._base_for(S)  # type: ignore[attr-defined]
    held = bound.quadratics(clear.kernel, states, clear._planner, b, [1], bound.pose_covariance(clear.kernel, b))  # type: ignore[attr-defined]
    own = np.asarray(states.sensor_pairs[1])
    assert held.lookup(states, own) is not None
    other = next(c for c in range(2, len(city.library)) if np.setdiff1d(states.sensor_pairs[c], own).size)
    assert held.lookup(states, np.asarray(states.sensor_pairs[other])) is None
    full = clear.gain_bounds(S, [other], force=True)
    assert np.allclose(
        clear.gain_bounds(S, [other], force=True, shared=held), full, rtol=1e-12, atol=0
    )  # computed afresh


def test_members_scored_on_two_threads_give_blas_its_thread_count_back(city):
    """BLAS's thread count is the process's. Two members scored at once each hold it at one thread
    (the fast engine's ``single_thread``); interleaved as A in, B in, A out, B out on the pool's
    threads, B put back the one thread it found, and BLAS stayed on one thread for good after
    ``pareto --domain`` (numpy's own products then changed their last bits: a later test's oracle
    failed). The interleaving is forced here with events; the count must come back."""
    import threading

    from threadpoolctl import threadpool_info

    def blas_threads() -> list[int]:
        return [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]

    before = blas_threads()
    if not before or max(before) < 2:  # (a limit set by the test itself would change how BLAS behaves)
        pytest.skip("BLAS runs one thread on this machine: nothing to give back")
    ev = DomainEvaluator(city, jobs=2)
    a_in, b_in, a_out = threading.Event(), threading.Event(), threading.Event()

    def one(k: int) -> int:
        with ev.routes[k].kernel.blas.single_thread():  # what each member's scoring does
            if k == 0:
                a_in.set()
                assert b_in.wait(10)
            else:
                assert a_in.wait(10)
                b_in.set()
                assert a_out.wait(10)
        if k == 0:
            a_out.set()
        return k

    assert ev._on_threads(one, [0, 1]) == {0: 0, 1: 1}
    assert blas_threads() == before


def test_members_started_dearest_first_are_answered_by_member_in_the_order_asked(city):
    """The pool starts the members by their work, largest first (a speed matter); the answers must
    still be each member's own, in the order the members were asked, on one thread and on two."""
    for jobs in (1, 2):
        ev = DomainEvaluator(city, jobs=jobs)
        members = [2, 0, 3, 1]
        work = {0: 1.0, 1: 4.0, 2: 2.0, 3: 3.0}
        got = ev._on_threads(lambda k: 10 * k, members, work)
        assert list(got) == members and got == {k: 10 * k for k in members}


def test_scores_are_copied_only_between_members_whose_engines_planned_alike(city):
    # the fast engine plans its tiles from every landmark the library measures: a member copies its
    # clear member's scores only where that set agrees (the oracle: the sets, computed here)
    from sensorsel.information.evaluators.domain import clear_partners, planned_alike

    partner, _ = clear_partners(city, len(city.library))
    got = planned_alike(city, partner)
    for k, r in enumerate(city.routes):
        if partner[k] < 0:
            assert not got[k]
            continue
        seen = [
            np.unique(np.concatenate([o.landmark for o in city.routes[j].problem.observations]))
            for j in (k, partner[k])
        ]
        assert got[k] == np.array_equal(*seen), r.name
    assert got.any()  # the fixtures' night members see every landmark their clear members do
