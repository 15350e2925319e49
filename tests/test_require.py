"""``sensorsel require`` and the accuracy options of the other commands: end to end on the
fixtures, the answer against brute force on a small library, bad input one line and exit 2."""

from __future__ import annotations

import dataclasses
import itertools
import json

import numpy as np
import pytest
from click.testing import CliRunner

from sensorsel.cli import cli
from sensorsel.designs.requirements import Specification, preset, require, verdict
from sensorsel.information.evaluators import FastEvaluator
from sensorsel.information.evaluators.accuracy import route_accuracy
from sensorsel.io import results
from sensorsel.model.constraints import Constraints

T = ["--fixture", "tiny"]
E = ["--engine", "fast", "--jobs", "1", "-q"]
#: ten sensors of the library, one or two of each model (the rest excluded): 1,024 suites to brute-force
SMALL = ("LRL-roof", "MRL-roof", "LRR-12", "LRR-6", "MRR-12", "WSC-12", "HD2K-12", "HD2K-6", "LSC-12", "HD2K-3")


def _invoke(args):
    return CliRunner().invoke(cli, [str(a) for a in args])


def _all_but(library, kept) -> tuple[str, ...]:
    """The library's ids but ``kept``: what a Constraints excludes to keep those alone."""
    return tuple(sorted(set(library.ids) - set(kept)))


def _small(library) -> Constraints:
    return Constraints(exclude=_all_but(library, SMALL))


def _brute_force(
    problem, spec: Specification, map_sigma, failures: int = 0, max_sensors: int | None = None, estimate: str = "filter"
):
    """The cheapest suite of SMALL meeting ``spec`` after any ``failures`` failures, by enumeration
    (the accuracy of ``estimate``: the filter's, as require judges by default, or the smoother's)."""
    lib = problem.library
    ev = FastEvaluator(problem)
    pos = [lib.position(i) for i in SMALL]
    memo: dict[tuple[int, ...], bool] = {}

    def meets(s: tuple[int, ...]) -> bool:
        if s not in memo:
            memo[s] = verdict(route_accuracy(ev, s, map_sigma_m=map_sigma, estimate=estimate), spec).meets
        return memo[s]

    best = None
    for k in range(len(pos) + 1):
        if max_sensors is not None and k > max_sensors:
            break
        for combo in itertools.combinations(pos, k):
            s = tuple(sorted(combo))
            if len(s) < failures + (0 if failures == 0 else 1):
                continue
            if all(meets(tuple(sorted(set(s) - set(f)))) for f in itertools.combinations(s, failures)):
                cost = float(lib.costs[list(s)].sum())
                if best is None or cost < best[0] - 1e-9:
                    best = (cost, s)
    return best


@pytest.mark.parametrize("failures", [0, 1])
@pytest.mark.parametrize(
    "map_sigma, spec",
    [(0.05, Specification(lateral=0.06, heading=0.1)), (None, Specification(lateral=0.6, longitudinal=0.4, at=0.9))],
)
def test_require_is_the_brute_force_cheapest(tiny_problem, failures, map_sigma, spec):
    """On ten sensors, with and without a failure, in both models: the answer costs what the
    cheapest feasible suite found by enumeration costs, and the lower bound is never above it."""
    want = _brute_force(tiny_problem, spec, map_sigma, failures)
    res = require(
        tiny_problem, spec, map_sigma_m=map_sigma, failures=failures, constraints=_small(tiny_problem.library)
    )
    if want is None:
        assert res.status == "infeasible"
        return
    assert res.status == "optimal", res
    assert res.cost_usd == pytest.approx(want[0])
    assert res.lower_bound_usd <= want[0] + 1e-6
    assert all(r.verdict.meets for r in res.routes)


def test_require_of_either_estimate_is_its_brute_force_cheapest(tiny_problem):
    """require judges the filter's accuracy by default (refuting first with the smoother's, a floor
    under it) and the smoother's on request: each answer is its own estimate's brute-force
    cheapest, and the filter's (as the car drives) never costs less than the smoother's."""
    spec = Specification(lateral=0.05, heading=0.08)
    got = {}
    for estimate in ("filter", "smoother"):
        want = _brute_force(tiny_problem, spec, 0.05, estimate=estimate)
        res = require(tiny_problem, spec, map_sigma_m=0.05, constraints=_small(tiny_problem.library), estimate=estimate)
        assert want is not None and res.status == "optimal" and res.estimate == estimate
        assert res.cost_usd == pytest.approx(want[0])
        assert all(r.accuracy.estimate == estimate for r in res.routes)
        got[estimate] = res
    # never less; here more (a suite the smoother accepts misses it as the car drives)
    assert got["filter"].cost_usd > got["smoother"].cost_usd
    assert "filter (as the car drives)" in got["filter"].model_label


def test_require_with_a_limit_equals_brute_force(tiny_problem):
    spec = Specification(lateral=0.06, heading=0.1)
    want = _brute_force(tiny_problem, spec, 0.05, 0, max_sensors=2)
    c = Constraints(exclude=_small(tiny_problem.library).exclude, max_sensors=2)
    res = require(tiny_problem, spec, map_sigma_m=0.05, constraints=c)
    if want is None:
        assert res.status == "infeasible"
    else:
        assert res.status == "optimal" and res.cost_usd == pytest.approx(want[0]) and len(res.suite) <= 2


def test_a_search_stopped_before_any_suite_reports_the_empty_suites_accuracy(tiny_problem):
    """A time limit that stops the search before it finds a suite: no suite, and the routes' accuracy
    is the empty suite's (the one reported), computed on its own; not a pass of every sensor, which
    nothing prints and which on a long drive cost more than the limit."""
    spec = Specification(lateral=0.06, heading=0.1)
    res = require(tiny_problem, spec, map_sigma_m=0.05, time_limit_s=1e-9)
    assert res.suite == () and res.status != "infeasible" and res.stop
    want = route_accuracy(FastEvaluator(tiny_problem), (), map_sigma_m=0.05, estimate="filter")
    got = res.routes[0].accuracy
    assert got.lateral_sigma_m == pytest.approx(want.lateral_sigma_m, rel=1e-12)
    assert got.heading_sigma_deg == pytest.approx(want.heading_sigma_deg, rel=1e-12)
    every = route_accuracy(FastEvaluator(tiny_problem), range(len(tiny_problem.library)), map_sigma_m=0.05)
    assert max(every.lateral_sigma_m) < max(got.lateral_sigma_m)  # (the two differ: the test tells them apart)


def test_require_cli_end_to_end_and_deterministic(tmp_path):
    out1, out2 = tmp_path / "a.json", tmp_path / "b.json"
    args = ["require", *T, *E, "--preset", "freeway", "--exclude", ",".join(sorted(set(_all_ids()) - set(SMALL)))]
    r1 = _invoke(args + ["-o", out1])
    assert r1.exit_code == 0, r1.output
    assert "proved the cheapest" in r1.output and "prior map (landmarks known to 0.05 m)" in r1.output
    r2 = _invoke(args + ["-o", out2])
    assert r2.exit_code == 0, r2.output
    a, b = json.loads(out1.read_text()), json.loads(out2.read_text())
    for key in ("seconds", "seconds_checks", "seconds_programs"):  # wall times: the only fields that differ
        a.pop(key), b.pop(key)
    assert a == b
    rec = results.load(out1, "requirement")
    assert rec.status == "optimal" and rec.routes[0].accuracy.n_keyframes > 0
    assert len(rec.routes[0].accuracy.lateral_sigma_m) == rec.routes[0].accuracy.n_keyframes


def _all_ids():
    from sensorsel.model.library import load_library

    return load_library().ids


def test_infeasible_specification_exits_2_naming_what_fails(tmp_path):
    out = tmp_path / "r.json"
    r = _invoke(["require", *T, *E, "--lateral", "0.0001", "--json", "-o", out])
    assert r.exit_code == 2
    err = [line for line in r.stderr.splitlines() if line.startswith("sensorsel: error:")]
    assert len(err) == 1 and "route tiny: lateral" in err[0] and "keyframes" in err[0]
    rec = results.load(out, "requirement")  # the diagnosis is still written
    assert rec.status == "infeasible" and not rec.suite and not rec.routes[0].verdict.meets
    assert json.loads(r.stdout)["status"] == "infeasible"


@pytest.mark.parametrize("failures", [0, 1])
def test_a_specification_nothing_meets_is_answered_from_the_whole_librarys_smoother(suburb_problem, failures):
    """With the filter's estimate, every sensor together is refuted by its smoother's marginals (a
    floor under the filter's) before any greedy: one suite refuted, none computed but the report's
    pass, where the greedy would first grow suites until none helped. The answer is what the
    filter itself says of every sensor together: it fails at some keyframe."""
    spec = Specification(lateral=0.002)
    res = require(suburb_problem, spec, map_sigma_m=0.05, failures=failures)
    assert res.status == "infeasible" and res.infeasible_by == "library" and not res.suite
    assert res.n_refuted == 1 and res.iterations == 0
    from sensorsel.information.filtering import forward_pass

    lateral_sigma = np.sqrt(
        forward_pass(suburb_problem, range(len(suburb_problem.library)), map_sigma_m=0.05).filtered[:, 1, 1]
    )
    assert lateral_sigma.min() > 0.002  # every keyframe's lateral error misses 2 mm, at 1σ already


@pytest.mark.parametrize(
    "args, culprit",
    [
        (["--lateral", "-0.1"], "--lateral"),
        (["--lateral", "0"], "--lateral"),
        (["--heading", "nan"], "--heading"),
        (["--longitudinal", "inf"], "--longitudinal"),
        (["--preset", "freeway", "--at", "0"], "--at"),
        (["--preset", "freeway", "--at", "101"], "--at"),
        (["--preset", "city"], "--preset"),
        ([], "no requirement"),
        (["--preset", "freeway", "--map-sigma", "-0.1"], "--map-sigma"),
        (["--preset", "freeway", "--map-sigma", "0"], "--map-sigma"),
    ],
)
def test_bad_requirements_one_line_exit_2(args, culprit):
    r = _invoke(["require", *T, *E, *args])
    assert r.exit_code == 2, r.output
    assert "Traceback" not in r.output
    lines = [line for line in r.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and culprit in lines[0], r.stderr


@pytest.mark.parametrize(
    "text, culprit", [("- 1\n", "expected a mapping"), ("preset: freeway\nroad: x\n", "road: unknown key")]
)
def test_bad_spec_file_one_line_exit_2(tmp_path, text, culprit):
    f = tmp_path / "spec.yaml"
    f.write_text(text)
    r = _invoke(["require", *T, *E, "--spec", f])
    assert r.exit_code == 2
    lines = [line for line in r.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and str(f) in lines[0] and culprit in lines[0], r.stderr


@pytest.mark.parametrize("command", [["score", "--suite", "LRL-roof"], ["greedy", "--budget", "5000"]])
def test_accuracy_lines_and_bad_map_sigma(command):
    r = _invoke([*command, *T, "--engine", "fast", "--jobs", "1"] + (["-q"] if command[0] == "greedy" else []))
    assert r.exit_code == 0 and "accuracy   SLAM (landmarks unknown)" in r.output
    r = _invoke([*command, *T, "--map-sigma", "0.05"] + (["-q"] if command[0] == "greedy" else []))
    assert r.exit_code == 0 and "prior map (landmarks known to 0.05 m)" in r.output
    r = _invoke([*command, *T, "--map-sigma", "-1"])
    assert r.exit_code == 2 and "--map-sigma" in r.stderr


def test_score_json_carries_the_per_keyframe_arrays(tiny_problem):
    r = _invoke(["score", *T, "--suite", "LRL-roof", "--json", "--map-sigma", "0.1"])
    data = json.loads(r.stdout)
    acc = data["accuracy"]
    ev = FastEvaluator(tiny_problem)
    want = route_accuracy(ev, (tiny_problem.library.position("LRL-roof"),), map_sigma_m=0.1)
    assert acc["model"] == "map" and acc["map_sigma_m"] == 0.1
    assert acc["lateral_sigma_m"] == pytest.approx(want.lateral_sigma_m, rel=1e-12)
    assert len(acc["heading_sigma_deg"]) == tiny_problem.scenario.n_poses


def test_pareto_marks_the_acceptable_front(tmp_path):
    r = _invoke(
        [
            "pareto",
            *T,
            *E,
            "--budgets",
            "2000,20000",
            "--output-dir",
            tmp_path,
            "--preset",
            "freeway",
            "--map-sigma",
            "0.05",
        ]
    )
    assert r.exit_code == 0, r.output
    acc = results.load(tmp_path / "accuracy.json", "front-acceptance")
    assert acc.specifications and all(p.meets is not None for p in acc.points)
    best = acc.cheapest_meeting
    assert best is not None and best.meets  # freeway is met on the tiny route: the check below is not vacuous
    cheaper = [p for p in acc.points if p.cost_usd < best.cost_usd]
    assert cheaper and not any(p.meets for p in cheaper)
    assert (tmp_path / "pareto-accuracy.png").is_file() and "acceptable" in r.output


class _Interrupt(KeyboardInterrupt):
    pass


def _stop_after(n: int):
    def progress(done: int, total: int) -> None:
        if done >= n:
            raise _Interrupt()

    return progress


def test_interrupted_require_resumes_to_the_same_answer_without_recomputing(tiny_problem, tmp_path):
    spec = Specification(lateral=0.06, heading=0.1)
    c = _small(tiny_problem.library)
    want = require(tiny_problem, spec, map_sigma_m=0.05, failures=1, constraints=c)
    ck = tmp_path / "r.json.checkpoint"
    with pytest.raises(_Interrupt):
        require(tiny_problem, spec, map_sigma_m=0.05, failures=1, constraints=c, checkpoint=ck, progress=_stop_after(1))
    journal = results.load(ck, "requirement-journal")
    assert journal.answers  # what the interrupted run learnt was written
    got = require(tiny_problem, spec, map_sigma_m=0.05, failures=1, constraints=c, checkpoint=ck, resume=True)
    assert (got.status, got.suite, got.cost_usd, got.lower_bound_usd) == (
        want.status,
        want.suite,
        want.cost_usd,
        want.lower_bound_usd,
    )
    assert got.n_checks + got.n_refuted < want.n_checks + want.n_refuted  # the journal's answers were not recomputed
    # and the result says so: its counts are this run's, the journal's answers counted apart
    assert (want.n_resumed, got.n_resumed) == (0, len(journal.answers))
    # the integer programs the interrupted run solved are read back, not solved again
    assert journal.programs and got.n_programs_resumed >= len(journal.programs) > want.n_programs_resumed == 0


def test_a_run_resumed_with_the_journals_bad_keyframes_computes_fewer_passes(tiny_problem, tmp_path):
    """Where a failing suite's filter pass is over a limit is journalled beside the answers; a run
    resumed with it computes fewer passes than one resumed from the answers alone (which computes
    them again for the windows' bounds), to the same answer."""
    spec = Specification(lateral=0.06, heading=0.1)
    kw = {"map_sigma_m": 0.05, "failures": 1, "constraints": _small(tiny_problem.library)}
    want = require(tiny_problem, spec, **kw)
    ck = tmp_path / "r.json.checkpoint"
    with pytest.raises(_Interrupt):
        require(tiny_problem, spec, checkpoint=ck, progress=_stop_after(1), **kw)
    journal = results.load(ck, "requirement-journal")
    assert journal.bad_keyframes
    bare = tmp_path / "answers-alone.checkpoint"  # as a journal written before the bad keyframes were kept
    results.save(dataclasses.replace(journal, bad_keyframes=()), bare, compact=True)
    got = require(tiny_problem, spec, checkpoint=ck, resume=True, **kw)
    alone = require(tiny_problem, spec, checkpoint=bare, resume=True, **kw)
    for r in (got, alone):
        assert (r.status, r.suite, r.cost_usd, r.lower_bound_usd) == (
            want.status,
            want.suite,
            want.cost_usd,
            want.lower_bound_usd,
        )
        assert r.n_resumed == len(journal.answers)
    assert got.n_checks < alone.n_checks


def test_the_journals_bad_keyframes_are_where_each_suites_own_accuracy_is_over_a_limit(suburb_problem, tmp_path):
    """Every failing suite's bad keyframes the journal holds (whichever check found them: a whole
    pass, a pass stopped early, a bound's base) are the keyframes its own accuracy's verdict finds
    over each limit, in the specification's order."""
    spec = preset("local-streets")
    kept = [i for i in suburb_problem.library.ids if i.startswith(("HD2K", "WSC"))]
    ck = tmp_path / "r.json.checkpoint"
    require(
        suburb_problem,
        spec,
        map_sigma_m=0.05,
        constraints=Constraints(exclude=_all_but(suburb_problem.library, kept)),
        checkpoint=ck,
    )
    entries = results.load(ck, "requirement-journal").bad_keyframes
    assert len(entries) >= 10
    ev = FastEvaluator(suburb_problem)
    names = [c for c, _, _ in spec.bounds()]
    for route, suite, bad in entries:
        v = verdict(route_accuracy(ev, suite, map_sigma_m=0.05), spec)
        assert route == 0 and not v.meets
        over = {c: b for c, _, _, b in v.worst}
        assert bad == tuple(over[c] for c in names)


def test_a_journal_write_waits_nine_times_what_the_last_one_took():
    """The whole journal is written each time: a write that took 1 s is not repeated for 9 s (a long
    run's writes stay a tenth of it), and quick writes are 2 s apart, not closer."""
    from sensorsel.designs.requirements.design import JOURNAL_EVERY_S, journal_due

    assert JOURNAL_EVERY_S == 2.0
    assert not journal_due(100.0 + 8.9, 100.0, 1.0) and journal_due(100.0 + 9.0, 100.0, 1.0)
    assert not journal_due(100.0 + 1.9, 100.0, 0.01) and journal_due(100.0 + 2.0, 100.0, 0.01)


@pytest.mark.parametrize("change", ["failures", "map", "spec", "budget", "limits", "route", "estimate"])
def test_resume_with_any_other_input_is_warned_and_starts_afresh(tiny_problem, suburb_problem, tmp_path, change):
    """Each input the answers depend on is in the journal's fingerprint: a resume after changing any
    one of them warns, naming it, never reuses the answers (the same answer as a fresh run)."""
    from sensorsel.pipeline.store import CacheWarning

    spec = Specification(lateral=0.06, heading=0.1)
    c = _small(tiny_problem.library)
    ck = tmp_path / "r.json.checkpoint"
    base = dict(map_sigma_m=0.05, failures=0, constraints=c, budget_usd=None)
    require(tiny_problem, spec, checkpoint=ck, **base)
    other = dict(base)
    target, spec2 = tiny_problem, spec
    if change == "failures":
        other["failures"] = 1
    elif change == "map":
        other["map_sigma_m"] = 0.1
    elif change == "spec":
        spec2 = Specification(lateral=0.07, heading=0.1)
    elif change == "budget":
        other["budget_usd"] = 50_000.0
    elif change == "limits":
        other["constraints"] = Constraints(exclude=c.exclude, max_sensors=3)
    elif change == "estimate":
        other["estimate"] = "smoother"
    else:
        target = suburb_problem
    word = {
        "failures": "failures",
        "map": "model",
        "spec": "specification",
        "budget": "budget",
        "limits": "limits",
        "route": "routes",
        "estimate": "estimate",
    }[change]
    with pytest.warns(CacheWarning, match=word):
        again = require(target, spec2, checkpoint=ck, resume=True, **other)
    fresh = require(target, spec2, **other)
    assert (again.suite, again.cost_usd) == (fresh.suite, fresh.cost_usd)
    assert again.n_resumed == 0  # nothing read back


def test_require_in_some_conditions_only(tmp_path):
    """A domain of one route in two conditions: demanding the specification in clear weather alone
    never costs more than in clear weather and in fog, and equals the plain route's answer."""
    dom = tmp_path / "d.yaml"
    dom.write_text(
        "keyframe_rate_hz: 1.0\nconditions:\n  - {name: fog, fog_visibility_m: 60, share: 0.2}\n"
        "routes:\n  - {name: tiny, fixture: tiny}\n"
    )
    excl = ",".join(sorted(set(_all_ids()) - set(SMALL)))
    base = ["require", "--engine", "fast", "--jobs", "1", "-q", "--preset", "freeway", "--exclude", excl, "--json"]
    clear = json.loads(_invoke([*base, "--domain", dom, "--in", "clear"]).stdout)
    both = _invoke([*base, "--domain", dom])
    plain = json.loads(_invoke([*base, *T]).stdout)
    assert [r["route"] for r in clear["routes"]] == ["tiny/clear"]
    assert clear["status"] == plain["status"] == "optimal" and clear["cost_usd"] == plain["cost_usd"]
    assert clear["suite"] == plain["suite"]
    assert both.exit_code == 0, both.output  # freeway is met in 60 m fog too: an answer, always checked
    both_doc = json.loads(both.stdout)
    assert both_doc["status"] == "optimal" and both_doc["cost_usd"] >= clear["cost_usd"]
    assert [r["route"] for r in both_doc["routes"]] == ["tiny/clear", "tiny/fog"]
    assert all(r["verdict"]["meets"] for r in both_doc["routes"])
    bad = _invoke([*base, "--domain", dom, "--in", "snow"])
    assert bad.exit_code == 2 and "--in: unknown condition(s) snow" in bad.stderr and "clear, fog" in bad.stderr
    bad = _invoke([*base, *T, "--in", "clear"])
    assert bad.exit_code == 2 and "--in" in bad.stderr
