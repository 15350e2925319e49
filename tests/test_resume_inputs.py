"""The stores' fingerprints, field by field: a resume after changing any one input (budget,
failures alpha, rule, method, engine, lazy, period length, limits, and each part of the target:
library, landmark map, route, graph settings and operating condition; for ``require`` also the
specification and the localization model) recomputes, with a warning, never reuses a stored result.

Every store builds its fingerprint from one declaration (:mod:`sensorsel.designs.inputs`); the
target's parts walked here are the :class:`~sensorsel.model.problem.Fingerprint`'s own, so a part
added there and not here fails :func:`test_every_part_of_the_target_is_walked`.

Each store is checked where its fingerprints are made: a route's periods (:func:`period_plan`, the
plan the run executes), a robust run's tasks (the files it keeps), a study's cells
(:func:`cell_fingerprint`), a tradespace's rules (the files a
run writes, then a resume with one input changed) and a greedy checkpoint (:func:`run_fingerprint`,
and :func:`load_checkpoint`, which does not read it back). For each changed input, no fingerprint of the changed
run may equal one of the base run's: a stored file of the base run can then never be read back.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest
import yaml

from sensorsel.designs.resilient import CacheWarning, run_periods
from sensorsel.designs.resilient.periods import period_plan
from sensorsel.designs.robust import robust_choice
from sensorsel.io import results
from sensorsel.model.conditions import Condition
from sensorsel.model.constraints import Constraints, feasible_set
from sensorsel.model.problem import Fingerprint, GraphSettings, build_problem, with_condition
from sensorsel.model.scenario import ScenarioSpec, load_scenario

REPO = Path(__file__).resolve().parents[1]
SMALL = ("MRL-roof", "LRR-12", "MRR-3", "HD2K-12", "HD2K-6", "WSC-9")
LIMIT = Constraints.of(limits={"power_w": 40.0})


@pytest.fixture(scope="module")
def lib(library):
    return library.subset([library.position(s) for s in SMALL])


#: the target's parts each run is walked through (the names of Fingerprint.PARTS; "map": its landmarks)
TARGET_PARTS = ("library", "map", "route", "settings", "condition")


@pytest.fixture(scope="module")
def problems(lib, library):
    """The base route and one changed in each part of the target: library, landmark map, route,
    graph settings and condition (night: it changes no landmark of a period, only the noise)."""
    other_lib = library.subset([library.position(s) for s in SMALL[:-1]])
    tiny = load_scenario(ScenarioSpec(fixture="tiny"))
    base = build_problem(lib, tiny)
    return {
        "base": base,
        "library": build_problem(other_lib, tiny),
        "map": build_problem(lib, load_scenario(ScenarioSpec(fixture="tiny", landmarks="synthetic", landmark_seed=3))),
        "route": build_problem(lib, load_scenario(ScenarioSpec(fixture="tiny", keyframe_rate_hz=0.5))),
        "settings": build_problem(lib, tiny, GraphSettings(odometry_sigmas=(0.2, 0.2, 0.02))),
        "condition": with_condition(base, Condition(night=True)),
    }


def test_every_part_of_the_target_is_walked(problems):
    """Each part of a problem's Fingerprint has a changed problem here, and differs in it alone."""
    parts = [name for name, _ in Fingerprint.PARTS]
    assert sorted(TARGET_PARTS) == sorted(["map" if p == "landmarks" else p for p in parts])
    base = problems["base"].fingerprint
    for part in TARGET_PARTS:
        name = "landmarks" if part == "map" else part
        changed = [p for p in parts if getattr(problems[part].fingerprint, p) != getattr(base, p)]
        assert changed == [name], part
    for changes in (PERIOD_CHANGES, TRADE_CHANGES, GREEDY_CHANGES, ROBUST_CHANGES, OPTIMAL_CHANGES, REQUIRE_CHANGES):
        assert set(TARGET_PARTS) <= set(changes)


# ---------------------------------------------------------------------------------------- periods

PERIOD_BASE = dict(
    budget=20_000.0,
    alpha=1,
    rule="uniform",
    engine="fast",
    jobs=1,
    lazy=True,
    period=3.0,
    method="algorithm-2",
    selector=None,
    constraints=None,
)
PERIOD_CHANGES = {
    "budget": dict(budget=19_000.0),
    "alpha": dict(alpha=2),
    "rule": dict(rule="cost-benefit"),
    "method": dict(method="robust", selector=robust_choice),
    "engine": dict(engine="reference"),
    "lazy": dict(lazy=False),
    "period": dict(period=4.0),
    "limits": dict(constraints=LIMIT),
    **{part: {} for part in TARGET_PARTS},
}


def _period_fps(problem, **kw) -> set[str]:
    return {t.fingerprint for t in period_plan(problem, **kw).tasks}


@pytest.mark.parametrize("field", list(PERIOD_CHANGES))
def test_a_period_file_is_never_reused_after_changing_one_input(field, problems):
    base = _period_fps(problems["base"], **PERIOD_BASE)
    changed = _period_fps(problems.get(field, problems["base"]), **{**PERIOD_BASE, **PERIOD_CHANGES[field]})
    assert len(base) > 1 and changed
    assert not base & changed


def test_a_resume_with_two_failures_recomputes_the_one_failure_periods(problems, tmp_path):
    """The issue's case: with alpha left out of the period fingerprint, this resume read back the
    1-failure periods silently."""
    p = problems["base"]
    one = run_periods(p, 20_000, 1, period_s=3.0, outdir=tmp_path)
    with pytest.warns(CacheWarning) as caught:
        two = run_periods(p, 20_000, 2, period_s=3.0, outdir=tmp_path, resume=True)
    assert len({str(w.message).split(":")[0] for w in caught}) == len(one.periods)
    fresh = run_periods(p, 20_000, 2, period_s=3.0)
    assert _untimed(two.periods) == _untimed(fresh.periods)
    assert [q.result.failed for q in two.periods] != [q.result.failed for q in one.periods]


def _untimed(obj: object) -> object:
    """The JSON of a result without its timings."""

    def rec(o: object) -> object:
        if isinstance(o, dict):
            return {k: rec(v) for k, v in o.items() if k != "seconds"}
        return [rec(v) for v in o] if isinstance(o, list) else o

    return rec(results.to_jsonable(obj))


# ------------------------------------------------------------------------------------------ study

# certificate off: with it on, the method also changes whether a cell computes a certificate, which
# would hide the method's own place in the fingerprint
STUDY_BASE = {
    "target": {"fixture": "tiny"},
    "grid": {"budgets": [5000], "rules": ["uniform"], "failures": [1]},
    "certificate": False,
}
STUDY_CHANGES = {
    "budget": {"grid": {"budgets": [6000]}},
    "alpha": {"grid": {"failures": [2]}},
    "rule": {"grid": {"rules": ["marginal"]}},
    "method": {"method": "robust"},
    "engine": {"engine": "reference"},
    "library": {"grid": {"libraries": [str(REPO / "configs" / "reduced_library.yaml")]}},
    "map": {"target": {"landmarks": "synthetic"}},
    "route": {"target": {"fixture": "suburb"}},
}


def _merge(base: dict, change: dict) -> dict:
    out = {k: dict(v) if isinstance(v, dict) else v for k, v in base.items()}
    for k, v in change.items():
        out[k] = {**out[k], **v} if isinstance(v, dict) and k in out else v
    return out


def _cell_fps(data: dict, folder: Path) -> set[str]:
    from sensorsel.designs.study import cell_fingerprint, load_study

    path = folder / f"study-{len(list(folder.glob('study-*.yaml')))}.yaml"
    path.write_text(yaml.safe_dump(data), encoding="utf-8")
    study = load_study(path)
    return {cell_fingerprint(study, c, study.targets[c.target].fingerprints()) for c in study.cells}


@pytest.mark.parametrize("field", list(STUDY_CHANGES))
def test_a_study_cell_is_never_reused_after_changing_one_input(field, tmp_path):
    base, changed = _cell_fps(STUDY_BASE, tmp_path), _cell_fps(_merge(STUDY_BASE, STUDY_CHANGES[field]), tmp_path)
    assert base and changed and not base & changed


def test_the_method_does_not_touch_a_cell_without_failures(tmp_path):
    """A greedy cell (no failure) is the same run whatever the method: reused, correctly."""
    greedy = _merge(STUDY_BASE, {"grid": {"failures": [0]}})
    assert _cell_fps(greedy, tmp_path) == _cell_fps(_merge(greedy, {"method": "robust"}), tmp_path)


# ------------------------------------------------------------------------------------- tradespace

TRADE_BASE = dict(budgets=[3000.0, 9000.0], rules=["uniform"], engine="fast", lazy=True, constraints=None)
TRADE_CHANGES = {
    "budget": dict(budgets=[3000.0, 8000.0]),
    "rule": dict(rules=["marginal"]),
    "engine": dict(engine="reference"),
    "lazy": dict(lazy=False),
    "limits": dict(constraints=LIMIT),
    **{part: {} for part in TARGET_PARTS},
}


@pytest.mark.parametrize("field", list(TRADE_CHANGES))
def test_a_tradespace_rule_file_is_never_reused_after_changing_one_input(field, problems, tmp_path):
    from sensorsel.designs.tradespace import run_tradespace

    def run(problem, resume: bool, budgets, rules, **kw):
        return run_tradespace(problem, budgets, rules, outdir=tmp_path, resume=resume, **kw)

    run(problems["base"], False, **TRADE_BASE)
    stored = {f.name: f.read_bytes() for f in (tmp_path / "runs").glob("rule-*.json")}
    assert stored
    changed = {**TRADE_BASE, **TRADE_CHANGES[field]}
    target = problems.get(field, problems["base"])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        again = run(target, True, **changed)
    theirs = {f"rule-{r}.json" for r in changed["rules"]}
    reread = [n for n, b in stored.items() if n in theirs and (tmp_path / "runs" / n).read_bytes() == b]
    assert not reread  # a file of one of this run's rules was recomputed and overwritten, not read back
    assert all(issubclass(w.category, CacheWarning) for w in caught)
    fresh = run_tradespace(
        target,
        changed["budgets"],
        changed["rules"],
        engine=changed["engine"],
        lazy=changed["lazy"],
        constraints=changed["constraints"],
    )
    assert [(r.suite, r.score) for r in again.runs] == [(r.suite, r.score) for r in fresh.runs]


# ----------------------------------------------------------------------------------------- greedy

GREEDY_BASE = dict(budget=20_000.0, rule="uniform", engine="fast", aggregate="", lazy=True, constraints=None)
GREEDY_CHANGES = {
    "budget": dict(budget=19_000.0),
    "rule": dict(rule="cost-benefit"),
    "engine": dict(engine="reference"),
    "lazy": dict(lazy=False),
    "limits": dict(constraints=LIMIT),
    **{part: {} for part in TARGET_PARTS},
}


@pytest.mark.parametrize("field", list(GREEDY_CHANGES))
def test_a_greedy_checkpoint_is_not_read_back_after_changing_one_input(field, problems, tmp_path):
    from sensorsel.designs.checkpoint import GreedyCheckpoint, GreedyInputs, load_checkpoint, run_fingerprint

    def fp_and_limits(problem, budget, rule, engine, aggregate, lazy, constraints):
        limits = feasible_set(problem.library, budget, constraints).record if constraints is not None else None
        return run_fingerprint(problem, budget, rule, engine, aggregate, lazy, limits), limits

    base = problems["base"]
    fp, _ = fp_and_limits(base, **GREEDY_BASE)
    path = results.save(
        GreedyCheckpoint(
            fingerprint=fp,
            budget_usd=GREEDY_BASE["budget"],
            rule="uniform",
            engine="fast",
            aggregate="",
            lazy=True,
            target=base.info,
        ),
        tmp_path / "g.json.checkpoint",
    )
    kw = {**GREEDY_BASE, **GREEDY_CHANGES[field]}
    target = problems.get(field, base)
    fp2, limits2 = fp_and_limits(target, **kw)
    assert fp2 != fp
    with pytest.warns(CacheWarning, match="g.json.checkpoint: not reused"):
        inputs = GreedyInputs(kw["budget"], kw["rule"], kw["engine"], kw["aggregate"], kw["lazy"], limits2)
        got = load_checkpoint(path, target, inputs, fp2)
    assert got is None


# ----------------------------------------------------------------------------------------- robust

ROBUST_BASE = dict(
    budget=20_000.0,
    alpha=1,
    rules=("uniform", "marginal"),
    methods=("oblivious", "local-search"),
    engine="fast",
    constraints=None,
)
ROBUST_CHANGES = {
    "budget": dict(budget=19_000.0),
    "alpha": dict(alpha=2),
    "rule": dict(rules=("uniform", "cost-benefit")),
    "method": dict(methods=("oblivious", "saturate")),
    "engine": dict(engine="reference"),
    "limits": dict(constraints=LIMIT),
    **{part: {} for part in TARGET_PARTS},
}


def _robust_fps(problem, folder: Path, budget, alpha, **kw) -> set[str]:
    from sensorsel.designs.robust import RobustTaskRecord, run_robust

    run_robust(problem, budget, alpha, outdir=folder, skip_when_proved=False, **kw)
    return {results.load(f, RobustTaskRecord).fingerprint for f in folder.glob("*.json")}


@pytest.mark.parametrize("field", list(ROBUST_CHANGES))
def test_a_robust_task_file_is_never_reused_after_changing_one_input(field, problems, tmp_path):
    base = _robust_fps(problems["base"], tmp_path / "base", **ROBUST_BASE)
    changed = _robust_fps(
        problems.get(field, problems["base"]), tmp_path / "changed", **{**ROBUST_BASE, **ROBUST_CHANGES[field]}
    )
    assert len(base) >= 5 and changed
    assert not base & changed


def test_a_robust_resume_with_two_failures_recomputes_the_one_failure_tasks(problems, tmp_path):
    from sensorsel.designs.robust import run_robust

    p, kw = problems["base"], dict(rules=("uniform",), methods=("oblivious",), skip_when_proved=False)
    run_robust(p, 20_000, 1, outdir=tmp_path, **kw)
    n = len(list(tmp_path.glob("*.json")))
    with pytest.warns(CacheWarning) as caught:
        two = run_robust(p, 20_000, 2, outdir=tmp_path, resume=True, **kw)
    assert len({str(w.message).split(":")[0] for w in caught}) == n
    assert _untimed(two) == _untimed(run_robust(p, 20_000, 2, **kw))


def test_a_resume_at_night_recomputes_the_clear_periods(problems, tmp_path):
    """The issue's case: the period fingerprint left the condition out, and night changes no
    landmark of a period, so a resume at night read back the clear periods silently (the whole
    route was recomputed, with a warning)."""
    clear, night = problems["base"], problems["condition"]
    first = run_periods(clear, 20_000, 1, period_s=3.0, outdir=tmp_path)
    assert [q.period.n_landmarks for q in first.periods] == [
        t.span.n_landmarks for t in period_plan(night, **PERIOD_BASE).tasks
    ]
    with pytest.warns(CacheWarning) as caught:
        again = run_periods(night, 20_000, 1, period_s=3.0, outdir=tmp_path, resume=True)
    assert len({str(w.message).split(":")[0] for w in caught}) == len(first.periods)
    assert any("another operating condition" in str(w.message) for w in caught)
    fresh = run_periods(night, 20_000, 1, period_s=3.0)
    assert _untimed(again.periods) == _untimed(fresh.periods)
    assert _untimed(fresh.periods) != _untimed(first.periods)


def test_a_period_of_a_problem_built_from_objects_is_selected_under_its_condition(problems):
    """A period is selected under the route's condition even when the problem has no spec to carry
    it (the condition was passed only through the spec): its scores are the night ones."""
    from dataclasses import replace

    night = replace(problems["condition"], spec=None)
    assert night.condition is not None
    spec_less = run_periods(night, 20_000, 1, period_s=3.0)
    clear = run_periods(problems["base"], 20_000, 1, period_s=3.0)
    assert [q.result.score for q in spec_less.periods] != [q.result.score for q in clear.periods]
    assert all(q.result.problem.condition == "night" for q in spec_less.periods)


# ---------------------------------------------------------------------------------------- optimal

OPTIMAL_BASE = dict(budget=20_000.0, rule="uniform", engine="fast", constraints=None)
OPTIMAL_CHANGES = {
    "budget": dict(budget=19_000.0),
    "rule": dict(rule="cost-benefit"),
    "engine": dict(engine="reference"),
    "limits": dict(constraints=LIMIT),
    **{part: {} for part in TARGET_PARTS},
}


@pytest.mark.parametrize("field", list(OPTIMAL_CHANGES))
def test_an_optimal_checkpoint_is_not_reused_after_changing_one_input(field, problems, tmp_path):
    from sensorsel.designs.certify import optimal
    from sensorsel.information.evaluators import evaluator_for

    def run(problem, resume, budget, rule, engine, constraints):
        return optimal(
            evaluator_for(problem, engine),
            budget,
            rule=rule,
            info=problem.info,
            constraints=constraints,
            checkpoint=tmp_path / "opt.checkpoint",
            resume=resume,
        )

    run(problems["base"], False, **OPTIMAL_BASE)
    assert (tmp_path / "opt.checkpoint").is_file()
    kw = {**OPTIMAL_BASE, **OPTIMAL_CHANGES[field]}
    target = problems.get(field, problems["base"])
    with pytest.warns(CacheWarning, match="opt.checkpoint: not reused"):
        again = run(target, True, **kw)
    fresh = optimal(
        evaluator_for(target, kw["engine"]),
        kw["budget"],
        rule=kw["rule"],
        info=target.info,
        constraints=kw["constraints"],
    )
    assert (again.suite, again.score) == (fresh.suite, fresh.score)


# ---------------------------------------------------------------------------------------- require

REQUIRE_BASE = dict(
    spec=dict(lateral=0.5, longitudinal=0.5),
    map_sigma_m=0.05,
    failures=0,
    budget_usd=None,
    constraints=None,
    engine="fast",
)
REQUIRE_CHANGES = {
    "specification": dict(spec=dict(lateral=0.4, longitudinal=0.5)),
    "share of keyframes": dict(spec=dict(lateral=0.5, longitudinal=0.5, at=0.9)),
    "map model": dict(map_sigma_m=None),
    "map sigma": dict(map_sigma_m=0.1),
    "failures": dict(failures=1),
    "budget": dict(budget_usd=50_000.0),
    "limits": dict(constraints=LIMIT),
    "engine": dict(engine="reference"),
    **{part: {} for part in TARGET_PARTS},
}


@pytest.mark.parametrize("field", list(REQUIRE_CHANGES))
def test_a_require_journal_is_not_read_back_after_changing_one_input(field, problems, tmp_path):
    from sensorsel.designs.requirements import Specification, require

    def run(problem, resume, spec, **kw):
        return require(problem, Specification(**spec), checkpoint=tmp_path / "req.checkpoint", resume=resume, **kw)

    run(problems["base"], False, **REQUIRE_BASE)
    assert (tmp_path / "req.checkpoint").is_file()
    kw = {**REQUIRE_BASE, **REQUIRE_CHANGES[field]}
    target = problems.get(field, problems["base"])
    with pytest.warns(CacheWarning, match="req.checkpoint: not reused"):
        again = run(target, True, **kw)
    spec = kw.pop("spec")
    fresh = require(target, Specification(**spec), **kw)
    assert (again.suite, again.cost_usd) == (fresh.suite, fresh.cost_usd)


def test_a_require_journal_of_the_same_inputs_is_read_back(problems, tmp_path):
    """The walk above is not vacuous: the same inputs resume from the journal."""
    from sensorsel.designs.requirements import Specification, require

    kw = dict(map_sigma_m=0.05, checkpoint=tmp_path / "req.checkpoint")
    first = require(problems["base"], Specification(lateral=0.5, longitudinal=0.5), **kw)
    again = require(problems["base"], Specification(lateral=0.5, longitudinal=0.5), resume=True, **kw)
    assert (again.suite, again.cost_usd) == (first.suite, first.cost_usd)


def test_an_optimal_checkpoint_without_recorded_info_is_keyed_on_the_evaluators_target(problems, tmp_path):
    """optimal(evaluator, ..., checkpoint=) without info=: the checkpoint is still keyed on the
    evaluator's problem by content (it was keyed on nothing: any problem's search was resumed)."""
    from sensorsel.designs.certify import optimal
    from sensorsel.information.evaluators import evaluator_for

    ck = tmp_path / "opt.checkpoint"
    optimal(evaluator_for(problems["base"], "fast"), 20_000.0, rule="uniform", checkpoint=ck)
    with pytest.warns(CacheWarning, match="opt.checkpoint: not reused"):
        again = optimal(
            evaluator_for(problems["condition"], "fast"), 20_000.0, rule="uniform", checkpoint=ck, resume=True
        )
    fresh = optimal(evaluator_for(problems["condition"], "fast"), 20_000.0, rule="uniform")
    assert (again.suite, again.score) == (fresh.suite, fresh.score)


@pytest.mark.parametrize("change", ["fog_visibility_m: 30", "night: true"])
def test_a_study_cell_on_a_domain_is_never_reused_under_another_condition(tmp_path, change):
    """A study on a domain with conditions: a member's condition changed alone (its name and share
    kept) gives other fingerprints for every cell."""

    def domain(cond: str) -> str:
        path = tmp_path / f"d{len(list(tmp_path.glob('d*.yaml')))}.yaml"
        path.write_text(
            f"keyframe_rate_hz: 1.0\nconditions:\n  - {{name: bad, {cond}, share: 0.2}}\n"
            "routes:\n  - {name: tiny, fixture: tiny}\n",
            encoding="utf-8",
        )
        return str(path)

    study = {
        "target": {"domain": domain("fog_visibility_m: 60")},
        "grid": {"budgets": [5000], "rules": ["uniform"], "failures": [0]},
        "certificate": False,
    }
    base = _cell_fps(study, tmp_path)
    changed = _cell_fps({**study, "target": {"domain": domain(change)}}, tmp_path)
    assert base and changed and not base & changed
