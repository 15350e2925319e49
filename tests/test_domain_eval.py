"""The score of an operating domain, against each route scored on its own, and greedy on it."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from sensorsel.designs.selection import greedy
from sensorsel.errors import InputError
from sensorsel.information.evaluators import DomainEvaluator, make_evaluator
from sensorsel.model.problem import Domain, DomainRoute, build_problem, load_domain
from sensorsel.model.scenario import ScenarioSpec, load_scenario

MIXED = ("LRL-roof", "MRL-roof", "LRR-12", "LRR-3", "MRR-6", "WSC-9", "HD2K-4", "HD2K-10", "LSC-2", "WSC-3")
SAME_COST = tuple(f"HD2K-{k}" for k in range(1, 13))  # twelve identical cameras: a budget is a cardinality


def _domain(library, ids, weights=(3.0, 1.0, 0.5)):
    lib = library.subset([library.position(i) for i in ids])
    specs = [
        ScenarioSpec(fixture="tiny"),
        ScenarioSpec(fixture="tiny", landmarks="synthetic", landmark_seed=3),
        ScenarioSpec(fixture="tiny", landmarks="synthetic", landmark_seed=7, keyframe_rate_hz=2.0),
    ]
    routes = tuple(
        DomainRoute(f"r{k}", build_problem(lib, load_scenario(s), spec=s), w)
        for k, (s, w) in enumerate(zip(specs, weights))
    )
    return Domain(routes[: len(weights)], "test")


@pytest.fixture(scope="module")
def mixed_domain(library):
    return _domain(library, MIXED)


def test_domain_score_is_the_weighted_sum_of_routes_scored_on_their_own(mixed_domain):
    dom = DomainEvaluator(mixed_domain, "fast")
    raw = DomainEvaluator(mixed_domain, "fast", aggregate="raw")
    # the oracle: a fresh reference (GTSAM) evaluator per route, each route scored alone
    refs = [make_evaluator(r.problem, "reference") for r in mixed_domain.routes]
    w = np.array([r.weight for r in mixed_domain.routes])
    w = w / w.sum()
    n = mixed_domain.n_sensors
    best = [ev.score(range(n)) for ev in refs]
    rng = np.random.default_rng(0)
    suites = [(), tuple(range(n))] + [tuple(sorted(rng.choice(n, size=k, replace=False))) for k in (1, 2, 3, 5, 7)]
    for s in suites:
        per = [ev.score(s) for ev in refs]
        want_norm = sum(wk * fk / bk for wk, fk, bk in zip(w, per, best))
        want_raw = sum(wk * fk for wk, fk in zip(w, per))
        assert dom.score(s) == pytest.approx(want_norm, rel=1e-9, abs=1e-12)
        assert raw.score(s) == pytest.approx(want_raw, rel=1e-9, abs=1e-9)
    assert dom.score(range(n)) == pytest.approx(1.0, rel=1e-12)


def test_scores_with_matches_one_suite_at_a_time(mixed_domain):
    dom = DomainEvaluator(mixed_domain, "fast")
    base = (0, 4)
    cands = [i for i in range(mixed_domain.n_sensors) if i not in base]
    batch = dom.scores_with(base, cands)
    one = [dom.score(base + (c,)) for c in cands]
    np.testing.assert_allclose(batch, one, rtol=1e-12)


def test_scores_with_counts_each_candidate_once_and_checks_every_position(mixed_domain):
    # the oracle: one evaluation a candidate, as len(candidates) single scores would count
    dom = DomainEvaluator(mixed_domain, "fast")
    before = dom.n_evaluations
    dom.scores_with((0, 4), [1, 2, 3])
    assert dom.n_evaluations == before + 3
    assert len(dom.scores_with((0,), [])) == 0 and dom.n_evaluations == before + 3
    with pytest.raises(InputError, match="outside the library"):
        dom.scores_with((0,), [mixed_domain.n_sensors])
    with pytest.raises(InputError, match="outside the library"):
        dom.scores_with((mixed_domain.n_sensors,), [1])


def test_one_route_domain_gives_exactly_the_single_route_answer(library):
    dom = _domain(library, MIXED, weights=(2.5,))
    prob = dom.routes[0].problem
    for rule in ("uniform", "cost-benefit", "marginal", "best-of"):
        alone = greedy(make_evaluator(prob, "fast"), 9000.0, rule)
        norm = greedy(DomainEvaluator(dom, "fast"), 9000.0, rule)
        raw = greedy(DomainEvaluator(dom, "fast", aggregate="raw"), 9000.0, rule)
        assert norm.suite == alone.suite == raw.suite, rule
        assert raw.score == alone.score  # raw with one route: the same number, bit for bit
        f_all = make_evaluator(prob, "fast").score(range(prob.n_sensors))
        assert norm.score == pytest.approx(alone.score / f_all, rel=1e-12)


def _brute_force_optimum(ev, costs, budget):
    n = len(costs)
    best = 0.0
    for k in range(n + 1):
        for c in itertools.combinations(range(n), k):
            if sum(costs[i] for i in c) <= budget + 1e-9:
                best = max(best, ev.score(c))
    return best


def test_domain_greedy_keeps_the_budget_and_the_cardinality_guarantee(library):
    dom = _domain(library, SAME_COST)
    ev = DomainEvaluator(dom, "fast")
    cost = float(dom.library.costs[0])
    assert np.all(dom.library.costs == cost)
    for k in (1, 2, 3, 4):
        budget = k * cost
        res = greedy(ev, budget, "uniform")
        assert res.cost_usd <= budget and len(res.suite) <= k
        opt = _brute_force_optimum(ev, dom.library.costs, budget)
        assert res.score >= (1 - 1 / math.e) * opt - 1e-12
        assert res.score <= opt + 1e-12


def test_domain_best_of_keeps_the_budgeted_guarantee(mixed_domain):
    ev = DomainEvaluator(mixed_domain, "fast")
    costs = mixed_domain.library.costs
    for budget in (1500.0, 5000.0, 12000.0):
        res = greedy(ev, budget, "best-of")
        assert res.cost_usd <= budget
        opt = _brute_force_optimum(ev, costs, budget)
        assert (1 - 1 / math.e) / 2 * opt - 1e-12 <= res.score <= opt + 1e-12


def test_domain_refuses_bad_routes(library, mixed_domain):
    r = mixed_domain.routes[0]
    with pytest.raises(InputError, match="used twice"):
        Domain((r, r), "x.yaml")
    with pytest.raises(InputError, match="weight"):
        Domain((DomainRoute("a", r.problem, 0.0),), "x.yaml")
    other = build_problem(library, r.problem.scenario)
    with pytest.raises(InputError, match="another sensor library"):
        Domain((r, DomainRoute("b", other, 1.0)), "x.yaml")
    with pytest.raises(InputError, match="aggregate"):
        DomainEvaluator(mixed_domain, "fast", aggregate="mean")


def test_a_route_no_sensor_can_see_is_refused(library):
    tiny = load_scenario(ScenarioSpec(fixture="tiny"))
    from sensorsel.model.scenario import Scenario

    far = Scenario("far", tiny.keyframes, tiny.landmarks + 1e5, "shifted")
    lib = library.subset([library.position(i) for i in MIXED])
    dom = Domain(
        (DomainRoute("near", build_problem(lib, tiny), 1.0), DomainRoute("far", build_problem(lib, far), 1.0)), "d.yaml"
    )
    with pytest.raises(InputError, match="'far'.*no sensor"):
        DomainEvaluator(dom, "fast")


def test_the_bundled_fixture_domain_loads_and_scores(library):
    dom = load_domain(_fixture_domain_path())
    assert [r.name for r in dom.routes] == ["suburb", "tiny"]
    ev = DomainEvaluator(dom)
    assert 0.0 < ev.score([library.position("MRL-roof")]) < 1.0


def _fixture_domain_path():
    from pathlib import Path

    return Path(__file__).resolve().parents[1] / "configs" / "domain_fixtures.yaml"


# ------------------------------------------------------------------------------------------- CLI


def _cli(*args):
    from click.testing import CliRunner

    from sensorsel.cli import cli

    return CliRunner().invoke(cli, list(args), catch_exceptions=False)


def test_cli_greedy_on_a_domain_writes_the_design_breakdown_and_plot(tmp_path):
    from sensorsel.designs.domain_design import DomainDesign
    from sensorsel.io import results

    domain = str(_fixture_domain_path())
    out, plot = tmp_path / "d.json", tmp_path / "d.png"
    r = _cli("greedy", "--domain", domain, "--budget", "8,000", "-o", str(out), "--plot", str(plot), "-q")
    assert r.exit_code == 0, r.output
    assert "per route" in r.output and "worst route" in r.output
    design = results.load(out, DomainDesign)
    assert [x.name for x in design.routes] == ["suburb", "tiny"] and plot.stat().st_size > 0
    # the breakdown against an independent oracle: each route scored alone, and its own greedy design
    dom = load_domain(_fixture_domain_path())
    for route, share in zip(dom.routes, design.routes):
        ev = make_evaluator(route.problem)
        f = ev.score(dom.library.resolve_suite(design.greedy.suite))
        own = greedy(make_evaluator(route.problem), 8000.0, "uniform")
        assert share.score == pytest.approx(f, rel=1e-12)
        assert share.own_suite == own.suite and share.share_of_own == pytest.approx(f / own.score, rel=1e-12)
    assert design.greedy.certificate is not None and design.greedy.certificate.bound >= design.greedy.score


@pytest.mark.parametrize(
    "command, extra",
    [
        ("score", ["--suite", "MRL-roof,HD2K-4"]),
        ("pareto", ["--budgets", "3000,9000", "--output-dir", "{tmp}/p"]),
        ("resilient", ["--budget", "9000", "--output-dir", "{tmp}/r"]),
        ("optimal", ["--budget", "1500", "--library", "configs/reduced_library.yaml"]),
        ("certify", ["--budget", "3000"]),
    ],
)
def test_every_selection_command_takes_a_domain(tmp_path, command, extra):
    repo = _fixture_domain_path().parents[1]
    args = [a.replace("{tmp}", str(tmp_path)).replace("configs/", f"{repo}/configs/") for a in extra]
    r = _cli(
        command, "--domain", str(_fixture_domain_path()), "--json", "-q" if command != "score" else "--json", *args
    )
    assert r.exit_code == 0, r.output
    assert '"routes"' in r.output and "suburb" in r.output


def test_a_domain_with_a_route_option_is_a_usage_error():
    r = _cli("greedy", "--domain", str(_fixture_domain_path()), "--seq", "03", "--budget", "5000")
    assert r.exit_code == 2 and "--seq" in r.output and "Traceback" not in r.output
    r = _cli("greedy", "--fixture", "tiny", "--budget", "5000", "--plot", "x.png")
    assert r.exit_code == 2 and "--plot" in r.output


def test_domain_bounds_combine_the_routes_and_leave_the_picks_alone(mixed_domain):
    """The domain's bounds are its routes' bounds combined with F's factors (each route's bound
    computed on its own as the oracle); they bound F; the lazy greedy that uses them picks what
    the one without bounds picks, with fewer evaluations."""
    from sensorsel.designs.selection.greedy import Selector
    from sensorsel.designs.selection.registry import RULES

    ev = DomainEvaluator(mixed_domain, "fast")
    n = len(mixed_domain.library)
    for suite in [(), (0,), (2, 5, 7)]:
        own, each = ev.score_bounds(suite, list(range(n)))
        scores = ev.scores_with(suite, list(range(n)))
        alone = [make_evaluator(r.problem, "fast").score_bounds(suite, list(range(n))) for r in mixed_domain.routes]
        assert own == pytest.approx(sum(s * a[0] for s, a in zip(ev.scale, alone)), rel=1e-12, abs=1e-15)
        np.testing.assert_allclose(each, sum(s * a[1] for s, a in zip(ev.scale, alone)), rtol=1e-12)
        assert own >= ev.score(suite) and np.all(each >= scores)
        gains = ev.gain_bounds(suite, list(range(n)))
        if gains is not None:
            assert np.all(gains >= scores - ev.score(suite) - 1e-9)
    runs = []
    for bound_from in (0, 4):
        e = DomainEvaluator(mixed_domain, "fast")
        runs.append(Selector(e, RULES["uniform"], bound_from=bound_from).select(60_000.0))
    plain, bounded = runs
    assert bounded.suite == plain.suite and bounded.score == plain.score
    assert [s.score for s in bounded.steps] == [s.score for s in plain.steps]
    assert bounded.n_evaluations < plain.n_evaluations
