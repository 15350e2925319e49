"""``require --integrity``: the cheapest suite meeting accuracy AND integrity, against brute force on
small libraries of the tiny fixture (every suite checked with ``route_integrity`` and the accuracy
verdict directly), including libraries where adding a sensor breaks integrity; bad input one line."""

from __future__ import annotations

import itertools
import json

import pytest
from click.testing import CliRunner

from sensorsel.cli import cli
from sensorsel.designs.requirements import Specification, require, verdict
from sensorsel.designs.requirements.design import require_fingerprint
from sensorsel.information.evaluators import FastEvaluator
from sensorsel.information.evaluators.accuracy import route_accuracy
from sensorsel.information.integrity import IntegritySpec, route_integrity
from sensorsel.model.constraints import Constraints
from sensorsel.model.problem import build_problem
from sensorsel.model.scenario import ScenarioSpec, load_scenario

#: eight sensors of the library (the rest excluded): 256 suites to brute-force
SMALL = ("LRL-roof", "MRL-roof", "LRR-6", "WSC-12", "HD2K-12", "HD2K-6", "LSC-12", "HD2K-3")
ACCURACY = Specification(lateral=1.0, longitudinal=1.0, heading=3.0)
LIMITS = (1.0, 1.0, 3.0)  # alert limits [m, m, deg]: wide enough that some suites reach a risk below 1 per hour
MAP_SIGMA = 0.05
#: a gate narrow enough that some suites' association risk is below 1 per hour on the tiny route
GATE_PROBABILITY = 0.999


def _spec(risk: float) -> IntegritySpec:
    return IntegritySpec(
        integrity_risk=risk,
        alert_lateral_m=LIMITS[0],
        alert_longitudinal_m=LIMITS[1],
        alert_heading_deg=LIMITS[2],
        gate_probability=GATE_PROBABILITY,
    )


class _Table:
    """Every suite of SMALL: the accuracy verdict and the integrity risk per hour, computed directly."""

    def __init__(self, problem) -> None:
        lib = problem.library
        self.problem, self.lib = problem, lib
        self.pos = sorted(lib.position(i) for i in SMALL)
        ev = FastEvaluator(problem)
        self.accurate: dict[tuple[int, ...], bool] = {}
        self.risk: dict[tuple[int, ...], float] = {}
        for k in range(len(self.pos) + 1):
            for s in itertools.combinations(self.pos, k):
                self.accurate[s] = verdict(
                    route_accuracy(ev, s, map_sigma_m=MAP_SIGMA, estimate="filter"), ACCURACY
                ).meets
                self.risk[s] = route_integrity(problem, s, _spec(0.5), map_sigma_m=MAP_SIGMA).integrity_risk_per_hour

    def meets(self, s: tuple[int, ...], risk: float) -> bool:
        return self.accurate[s] and self.risk[s] <= risk

    def cheapest(self, risk: float, failures: int = 0) -> tuple[float, tuple[int, ...]] | None:
        best = None
        for s in self.risk:
            if len(s) < (failures + 1 if failures else 0):
                continue
            if all(
                self.meets(tuple(x for x in s if x not in f), risk)
                for a in range(failures + 1)
                for f in itertools.combinations(s, a)
            ):
                cost = float(self.lib.costs[list(s)].sum())
                if best is None or cost < best[0] - 1e-9:
                    best = (cost, s)
        return best

    def breaking(self, risk: float) -> list[tuple[tuple[int, ...], int]]:
        """(suite, sensor): the suite meets the requirement, the suite with the sensor added fails integrity."""
        return [
            (s, p)
            for s in self.risk
            if self.meets(s, risk)
            for p in self.pos
            if p not in s and self.risk[tuple(sorted(s + (p,)))] > risk
        ]


@pytest.fixture(scope="module")
def table(tiny_problem):
    return _Table(tiny_problem)


def _exclude(lib) -> Constraints:
    return Constraints(exclude=tuple(sorted(set(lib.ids) - set(SMALL))))


@pytest.mark.parametrize("risk, failures", [(0.35, 0), (0.5, 0), (0.5, 1)])
def test_require_integrity_equals_brute_force(tiny_problem, table, risk, failures):
    want = table.cheapest(risk, failures)
    res = require(
        tiny_problem,
        ACCURACY,
        map_sigma_m=MAP_SIGMA,
        failures=failures,
        constraints=_exclude(tiny_problem.library),
        engine="fast",
        integrity=_spec(risk),
    )
    if want is None:
        assert res.status == "infeasible"
        return
    assert res.status == "optimal"
    assert res.cost_usd == pytest.approx(want[0])
    assert res.lower_bound_usd == pytest.approx(want[0])
    got = tuple(sorted(tiny_problem.library.resolve_suite(",".join(res.suite))))
    assert table.meets(got, risk)
    assert res.integrity_routes[0].integrity_risk_per_hour == pytest.approx(table.risk[got])
    assert res.integrity == _spec(risk)
    for sid in res.integrity_alone:  # fixed out before the search: in no suite that meets it
        p = tiny_problem.library.position(sid)
        assert not any(table.meets(s, risk) for s in table.risk if p in s)


def test_the_cases_are_not_trivial(table):
    """The answers are not the empty suite nor every sensor, and adding a sensor breaks integrity."""
    for risk in (0.35, 0.5):
        cost, suite = table.cheapest(risk)
        assert 0 < len(suite) < len(table.pos)
        assert table.breaking(risk), "no suite of the library where a sensor added breaks integrity"
    # integrity alone is not monotone here: the full library fails what a sub-suite meets
    assert table.risk[tuple(table.pos)] > 0.5 and table.cheapest(0.5) is not None
    # integrity changes the answer: accuracy alone is met by a cheaper suite
    assert table.cheapest(0.35)[0] > table.cheapest(float("inf"))[0]


def test_accuracy_alone_unchanged_without_integrity(tiny_problem):
    res = require(
        tiny_problem, ACCURACY, map_sigma_m=MAP_SIGMA, constraints=_exclude(tiny_problem.library), engine="fast"
    )
    assert res.integrity is None and res.integrity_routes == ()


def _run(args):
    return CliRunner().invoke(cli, [str(a) for a in args])


def _cli_args(lib, risk: float) -> list[str]:
    return [
        "require",
        "--fixture",
        "tiny",
        "--landmarks",
        "synthetic",
        "--engine",
        "fast",
        "--jobs",
        "1",
        "-q",
        "--lateral",
        "1",
        "--longitudinal",
        "1",
        "--heading",
        "3",
        "--integrity-risk",
        str(risk),
        "--alert-lateral",
        "1",
        "--alert-longitudinal",
        "1",
        "--alert-heading",
        "3",
        "--gate-probability",
        str(GATE_PROBABILITY),
        "--exclude",
        ",".join(sorted(set(lib.ids) - set(SMALL))),
    ]


def test_cli_equals_brute_force_and_records_integrity(library, tmp_path):
    problem = build_problem(library, load_scenario(ScenarioSpec(fixture="tiny", landmarks="synthetic")))
    t = _Table(problem)
    want = t.cheapest(0.5)
    assert want is not None
    out = tmp_path / "r.json"
    r = _run(_cli_args(library, 0.5) + ["-o", out])
    assert r.exit_code == 0, r.output
    data = json.loads(out.read_text())
    assert data["status"] == "optimal"
    assert data["cost_usd"] == pytest.approx(want[0])
    assert data["integrity"]["integrity_risk"] == 0.5 and data["integrity"]["alert_heading_deg"] == 3.0
    got = tuple(sorted(library.resolve_suite(",".join(data["suite"]))))
    assert data["integrity_routes"][0]["integrity_risk_per_hour"] == pytest.approx(t.risk[got])
    printed = _run(_cli_args(library, 0.5))
    assert "integrity  required: at most 0.5 per hour" in printed.output
    assert "integrity 0." in printed.output  # the answer's integrity line on its route


def test_cli_infeasible_is_one_line_exit_2(library, tmp_path):
    r = _run(_cli_args(library, 1e-6))
    assert r.exit_code == 2
    err = [line for line in r.stderr.splitlines() if line]
    assert len(err) == 1 and err[0].startswith("sensorsel: error: no suite") and "integrity" in err[0]


@pytest.mark.parametrize(
    "option, value",
    [
        ("--integrity-risk", "2"),
        ("--integrity-risk", "0"),
        ("--alert-lateral", "-1"),
        ("--alert-heading", "nan"),
        ("--max-association-risk", "0.1"),
    ],
)
def test_bad_integrity_option_one_line(library, option, value):
    r = _run(
        [
            "require",
            "--fixture",
            "tiny",
            "--landmarks",
            "synthetic",
            "--engine",
            "fast",
            "-q",
            "--preset",
            "local-streets",
            "--integrity",
            option,
            value,
        ]
    )
    assert r.exit_code == 2
    err = [line for line in r.stderr.splitlines() if line]
    assert len(err) == 1 and err[0].startswith("sensorsel: error:") and option in err[0], r.stderr
    assert "Traceback" not in r.output


def test_presets_alert_limits_and_fingerprint(tiny_problem):
    from sensorsel.designs.requirements.integrity import integrity_preset

    free = integrity_preset("freeway")
    assert (free.alert_lateral_m, free.alert_longitudinal_m, free.alert_heading_deg, free.integrity_risk) == (
        0.57,
        1.40,
        1.50,
        1e-8,
    )
    local = integrity_preset("local-streets")
    assert (local.alert_lateral_m, local.alert_longitudinal_m, local.alert_heading_deg) == (0.29, 0.29, 0.50)
    args = ([tiny_problem], [ACCURACY], MAP_SIGMA, 0, None, None, "filter", "fast")
    plain = require_fingerprint(*args)[0]
    assert require_fingerprint(*args, None)[0] == plain
    assert len({plain, require_fingerprint(*args, local)[0], require_fingerprint(*args, free)[0]}) == 3


def test_relaxations_are_necessary_conditions(tiny_problem, table):
    """What the proof uses, on every suite of the library: a suite meeting integrity meets both
    relaxations; the floor is under each suite's risk (and not vacuous: positive on some suite)."""
    from sensorsel.designs.requirements.integrity import IntegrityRequirement

    req = IntegrityRequirement([tiny_problem], ["tiny"], table.pos, _spec(0.5), MAP_SIGMA)
    floors = {s: req.bounds[0].association_floor(s) for s in table.risk}
    assert max(floors.values()) > 0.0
    for s, risk in table.risk.items():
        assert floors[s] <= risk * (1 + 1e-9), (s, floors[s], risk)
        assert req.bounds[0].tail_relaxation(s) <= risk * (1 + 1e-9)
        if risk <= 0.5:
            assert req.tail_met(s) and req.floor_met(s)


def test_domain_demands_integrity_on_every_route(tmp_path):
    """A domain (the tiny route in clear weather and in fog): the answer equals the brute-force
    cheapest suite that meets accuracy and integrity on both members, and reports both."""
    from sensorsel.model.problem import load_domain

    path = tmp_path / "d.yaml"
    path.write_text(
        "keyframe_rate_hz: 1.0\nconditions:\n  - {name: fog, fog_visibility_m: 60, share: 0.2}\n"
        "routes:\n  - {name: tiny, fixture: tiny}\n"
    )
    domain = load_domain(path)
    tables = [_Table(r.problem) for r in domain.routes]
    risk = 0.9
    best = None
    for s in tables[0].risk:
        if all(t.meets(s, risk) for t in tables):
            cost = float(domain.library.costs[list(s)].sum())
            if best is None or cost < best[0] - 1e-9:
                best = (cost, s)
    res = require(
        domain,
        ACCURACY,
        map_sigma_m=MAP_SIGMA,
        constraints=_exclude(domain.library),
        engine="fast",
        integrity=_spec(risk),
    )
    assert best is not None
    assert res.status == "optimal" and res.cost_usd == pytest.approx(best[0])
    assert [r.route for r in res.integrity_routes] == [r.name for r in domain.routes]
    assert all(r.meets for r in res.integrity_routes)
