"""A route is a domain of one route: runs read a target through one surface (``routes``,
``route_keys``, ``info``, ``kind``, ``score_unit``, ``headline``), not through ``isinstance``.

The guard: every ``isinstance`` branch on a target type (a problem or domain, what a result
records of one, their evaluators and designs) in ``src/`` is listed here with the reason the two
really differ there; a new one fails this test. The surface itself is checked against what the
branches it replaced computed (fingerprints of routes, differences, units).
"""

from __future__ import annotations

import ast
from collections import Counter
from dataclasses import replace
from pathlib import Path

import pytest

from sensorsel.designs.checkpoint import run_fingerprint
from sensorsel.designs.inputs import route_entry, route_inputs
from sensorsel.errors import InputError, ResultFileError
from sensorsel.model.problem import (
    ONE_ROUTE_KEYS,
    Domain,
    DomainRoute,
    check_result_problem,
    target_differences,
)

SRC = Path(__file__).resolve().parents[1] / "src" / "sensorsel"

#: the target types a branch must not test for
TARGET_TYPES = {
    "Problem",
    "Domain",
    "ProblemInfo",
    "DomainInfo",
    "ProblemEvaluator",
    "DomainEvaluator",
    "DomainDesign",
}

#: (module, enclosing function) -> (how many, why the two really differ there)
ALLOWED: dict[tuple[str, str], tuple[int, str]] = {
    ("information/evaluators/__init__.py", "evaluator_name"): (
        1,
        "the one dispatch from a target to its evaluator: a domain's combines its routes' engines; model "
        "(below information) cannot hold it as a method",
    ),
    ("information/evaluators/__init__.py", "evaluator_for"): (1, "the same dispatch as evaluator_name"),
    ("model/recipes.py", "of"): (
        1,
        "a recipe rebuilds the type it was given (a worker gets a Problem back for a Problem); its pickled "
        "form is what workers receive",
    ),
}


def _target_branches(root: Path = SRC) -> Counter[tuple[str, str]]:
    """Each isinstance call on a target type under ``root``, by (module, enclosing function)."""
    found: Counter[tuple[str, str]] = Counter()
    for path in sorted(root.rglob("*.py")):
        tree = ast.parse(path.read_text(), str(path))
        rel = path.relative_to(root).as_posix()

        def visit(node: ast.AST, func: str) -> None:
            for child in ast.iter_child_nodes(node):
                if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                    visit(child, child.name)
                    continue
                if (
                    isinstance(child, ast.Call)
                    and isinstance(child.func, ast.Name)
                    and child.func.id == "isinstance"
                    and len(child.args) == 2
                ):
                    kinds = child.args[1]
                    names = kinds.elts if isinstance(kinds, ast.Tuple) else [kinds]
                    if any(isinstance(n, ast.Name) and n.id in TARGET_TYPES for n in names):
                        found[(rel, func)] += 1
                visit(child, func)

        visit(tree, "<module>")
    return found


def test_no_new_isinstance_branch_on_a_target() -> None:
    found = _target_branches()
    extra = {k: n for k, n in found.items() if n > ALLOWED.get(k, (0, ""))[0]}
    assert not extra, (
        f"isinstance branches on a target type not in the allowed list: {extra}; read the target through "
        "its routes/route_keys/info/kind/score_unit, or add the site to ALLOWED with why the two differ there"
    )
    stale = {k for k, (n, _) in ALLOWED.items() if found.get(k, 0) < n}
    assert not stale, f"allowed branches that are gone (lower the count): {stale}"


def test_the_guard_sees_a_branch(tmp_path: Path) -> None:
    """The scanner finds an isinstance on a target type, alone or in a tuple, by its function; not one
    on another type."""
    (tmp_path / "m.py").write_text(
        "def f(t):\n    return isinstance(t, (int, Domain))\n\n"
        "def g(t):\n    if isinstance(t, ProblemInfo):\n        return isinstance(t, int)\n"
    )
    assert _target_branches(tmp_path) == Counter({("m.py", "f"): 1, ("m.py", "g"): 1})


def _domain(problem, names=("a", "b"), weights=(1.0, 2.0)) -> Domain:  # type: ignore[no-untyped-def]
    return Domain(tuple(DomainRoute(n, problem, w) for n, w in zip(names, weights)), "d.yaml")


def test_route_keys_give_the_fingerprints_the_branches_gave(suburb_problem) -> None:  # type: ignore[no-untyped-def]
    """One route: named by nothing ([\"\", 1, \"\", fp]); a domain: each member's name, weight, unit."""
    p = suburb_problem
    assert route_inputs(p) == [route_entry("", 1.0, "", p.fingerprint)]
    assert route_inputs(p.info) == route_inputs(p)
    d = _domain(p)
    expect = [route_entry("a", 1.0, "hours", p.fingerprint), route_entry("b", 2.0, "hours", p.fingerprint)]
    assert route_inputs(d) == expect and route_inputs(d.info) == expect
    assert p.route_keys == p.info.route_keys == ONE_ROUTE_KEYS
    # one route under another name is the same problem; a domain's member renamed is another domain
    renamed = replace(p, scenario=replace(p.scenario, name="other"))
    assert run_fingerprint(renamed, 1000, "cost", "reference", "normalised", True) == run_fingerprint(
        p, 1000, "cost", "reference", "normalised", True
    )
    assert route_inputs(_domain(p, names=("a", "c"))) != expect


def test_one_function_tells_what_differs(suburb_problem, tiny_problem) -> None:  # type: ignore[no-untyped-def]
    p, q = suburb_problem, tiny_problem
    assert target_differences(p.info, p) == []
    assert target_differences(q.info, p) == q.fingerprint.differences(p.fingerprint)
    assert target_differences(p.info, _domain(p)) == ["it was computed on one route, this run is on a domain"]
    assert target_differences(_domain(p).info, p) == ["it was computed on a domain, this run is on one route"]
    assert target_differences(_domain(p).info, _domain(p, weights=(1.0, 3.0)))[0].startswith("routes and weights")
    mixed = Domain((DomainRoute("a", p, 1.0), DomainRoute("b", q, 2.0)), "d.yaml")
    assert target_differences(mixed.info, _domain(p)) == [
        f"route b: {d}" for d in q.fingerprint.differences(p.fingerprint)
    ]
    unprinted = replace(p.info, fingerprint=None)
    assert target_differences(unprinted, p) == ["it records no fingerprint of its route"]
    # check_result_problem refuses through the same function, and names what differs
    with pytest.raises(ResultFileError, match="another domain .*route b: another"):
        check_result_problem(mixed.info, _domain(p), "r.json")
    with pytest.raises(ResultFileError, match="written before fingerprints"):
        check_result_problem(unprinted, p, "r.json")
    with pytest.raises(ResultFileError, match="one route, this run is on a domain"):
        check_result_problem(p.info, _domain(p), "r.json")
    check_result_problem(_domain(p).info, _domain(p), "r.json")


def test_units_and_headlines(suburb_problem) -> None:  # type: ignore[no-untyped-def]
    p = suburb_problem
    assert (p.info.score_unit, p.info.kind, p.kind) == ("nats", "route", "route")
    d = _domain(p).info
    assert (d.score_unit, d.kind, _domain(p).kind) == ("", "domain", "domain")
    assert p.info.headline == f"scenario {p.scenario.name}" and d.headline == "domain of 2 routes"
    assert [r.name for r in p.info.routes] == [r.name for r in p.routes] == [p.scenario.name]


def test_time_line_is_a_route_s_own_and_no_domain_s(suburb_problem, tmp_path) -> None:  # type: ignore[no-untyped-def]
    """A run that splits time into periods or keeps one route's comparison reads ``time_line``: the
    problem itself on a route; None on a domain, a domain of one route too (its member has the time
    line, the domain's score is another number)."""
    from sensorsel.designs.options import RunOptions
    from sensorsel.designs.resilient import compare, resilient_report
    from sensorsel.io import results

    p = suburb_problem
    assert p.time_line is p
    assert _domain(p).time_line is None and _domain(p, names=("a",), weights=(1.0,)).time_line is None
    # a route's comparison is stored with its fingerprint; a domain's is neither stored nor fingerprinted
    fast = RunOptions(engine="fast")
    route = compare(p, 20_000, 1, options=fast, cache=tmp_path / "route.json")
    assert route.fingerprint and results.load(tmp_path / "route.json") == route
    dom = compare(_domain(p), 20_000, 1, options=fast, cache=tmp_path / "domain.json")
    assert dom.fingerprint == "" and not (tmp_path / "domain.json").exists()
    # the same greedy suite: a domain of copies of one route scores a suite as that route does
    assert dom.greedy.suite == route.greedy.suite
    with pytest.raises(InputError, match="one route, not on a domain"):
        resilient_report(_domain(p), 20_000, 1, period_s=5.0, engine="fast")


def test_worst_route_is_refused_on_one_route(suburb_problem) -> None:  # type: ignore[no-untyped-def]
    """'worst' is told apart by the target's kind (a Literal type), not by isinstance: refused on a route."""
    from sensorsel.api import run_robust

    with pytest.raises(InputError, match="worst route of an operating domain"):
        run_robust(suburb_problem, 20_000, 1, aggregate="worst")
