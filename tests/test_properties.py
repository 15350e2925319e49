"""The score is monotone and submodular: what the greedy guarantee, the lazy greedy and the
certificate's upper bound (sensorsel.designs.certify) rely on.

Checked exhaustively on the whole lattice of small sub-libraries (every suite S, every pair of
sensors e, x outside S):

    monotone            Δ(e | S) = f(S + e) - f(S) >= -tol
    diminishing returns Δ(e | S) >= Δ(e | S + x) - tol

(the local form is equivalent to Δ(e | A) >= Δ(e | B) for all A ⊆ B). f(S + e) comes from
``scores_with``, the path the bound uses. tol is round-off: 1e-9 of the largest |log det| of the
problem (the violations measured are ~1e-16 of it); a modelling change that breaks the property
breaks it by far more. Every registered engine is checked.
"""

from __future__ import annotations

import math

import pytest
from hypothesis import HealthCheck, given, settings
from scenario_strategies import problems

from sensorsel.information.evaluators import ENGINES, make_evaluator
from sensorsel.model.library import load_library
from sensorsel.model.problem import build_problem
from sensorsel.model.scenario import ScenarioSpec, load_scenario

REL_TOL = 1e-9
LIBRARY = load_library()
HYPOTHESIS = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def lattice_violations(f: dict[int, float], n: int, tol: float) -> list[str]:
    """Monotonicity and diminishing-returns violations of a set function given on bit masks 0..2^n-1."""
    bad = []
    for mask in range(1 << n):
        outside = [e for e in range(n) if not mask >> e & 1]
        for e in outside:
            gain = f[mask | 1 << e] - f[mask]
            if gain < -tol:
                bad.append(f"not monotone: Δ({e} | {mask:b}) = {gain:.3g}")
            for x in outside:
                if x == e:
                    continue
                later = f[mask | 1 << e | 1 << x] - f[mask | 1 << x]
                if later > gain + tol:
                    bad.append(f"not submodular: Δ({e} | {mask:b}) = {gain:.6g} < Δ({e} | +{x}) = {later:.6g}")
    return bad


def score_lattice(ev) -> dict[int, float]:
    """f on every suite of the evaluator's library: f(S + e) from scores_with(S, every e outside S)."""
    n = ev.problem.n_sensors
    f = {0: 0.0}
    for mask in range(1 << n):
        suite = tuple(i for i in range(n) if mask >> i & 1)
        outside = [e for e in range(n) if not mask >> e & 1]
        if not outside:
            continue
        for e, v in zip(outside, ev.scores_with(suite, outside)):
            f.setdefault(mask | 1 << e, float(v))  # first value seen; others are checked below
    return f


def check_problem(problem, engine: str) -> None:
    ev = make_evaluator(problem, engine)
    n = problem.n_sensors
    f = score_lattice(ev)
    scale = max(1.0, abs(ev.baseline_logdet), max(abs(v + ev.baseline_logdet) for v in f.values()))
    tol = REL_TOL * scale
    # the same suite reached through different last sensors must score the same
    for mask in range(1, 1 << n):
        suite = [i for i in range(n) if mask >> i & 1]
        assert ev.score(suite) == pytest.approx(f[mask], rel=REL_TOL, abs=tol)
    assert lattice_violations(f, n, tol) == []


# ----------------------------------------------------------------------------- the checker itself


def _as_masks(n: int, fn) -> dict[int, float]:
    return {mask: float(fn([i for i in range(n) if mask >> i & 1])) for mask in range(1 << n)}


def test_checker_passes_a_concave_function_of_the_count_and_a_coverage_function():
    assert lattice_violations(_as_masks(4, lambda s: math.sqrt(len(s))), 4, 1e-12) == []
    cover = [{0, 1}, {1, 2}, {2, 3, 4}, {0, 4}]
    assert lattice_violations(_as_masks(4, lambda s: len(set().union(*[cover[i] for i in s]))), 4, 0.0) == []


def test_checker_flags_a_supermodular_and_a_decreasing_function():
    assert any("not submodular" in v for v in lattice_violations(_as_masks(3, lambda s: len(s) ** 2), 3, 1e-12))
    assert any("not monotone" in v for v in lattice_violations(_as_masks(3, lambda s: -len(s)), 3, 1e-12))


def test_checker_flags_a_modelling_change_that_couples_sensors():
    """A score that rewards pairs of sensors (e.g. a bonus per pair seeing the same landmark, or a
    noise that shrinks as sensors are added) breaks diminishing returns; the check must notice."""
    problem = build_problem(LIBRARY.subset([0, 25, 26, 29, 38]), load_scenario(ScenarioSpec(fixture="tiny")))
    ev = make_evaluator(problem, "reference")
    f = score_lattice(ev)
    coupled = {m: v + 50.0 * bin(m).count("1") ** 2 for m, v in f.items()}
    assert any("not submodular" in v for v in lattice_violations(coupled, 5, 1e-6))


# --------------------------------------------------------------------------------- the score


@pytest.mark.parametrize("engine", sorted(ENGINES))
@HYPOTHESIS
@given(problem=problems(LIBRARY, 3, 6))
def test_score_is_monotone_and_submodular_on_random_scenarios(engine, problem):
    check_problem(problem, engine)
    # not vacuous: the roof LiDAR of every drawn sub-library sees every landmark (all within 35 m)
    lidar = next(i for i, s in enumerate(problem.library) if s.id in ("LRL-roof", "MRL-roof"))
    assert set(problem.observations[lidar].landmarks_seen.tolist()) == set(range(problem.scenario.n_landmarks))


@pytest.mark.parametrize("engine", sorted(ENGINES))
@pytest.mark.parametrize(
    "fixture, ids",
    [
        # one sensor of each model, facing different ways: LiDARs, radars ahead and to the side, cameras
        ("tiny", ["LRL-roof", "MRL-roof", "MRR-12", "LRR-3", "WSC-12", "WSC-6", "HD2K-9", "LSC-3"]),
        ("suburb", ["LRL-roof", "LRR-12", "WSC-3", "HD2K-9", "LSC-6"]),  # fewer: suburb's suites are larger
    ],
)
def test_score_is_monotone_and_submodular_on_the_fixtures(engine, fixture, ids):
    problem = build_problem(
        LIBRARY.subset([LIBRARY.position(i) for i in ids]), load_scenario(ScenarioSpec(fixture=fixture))
    )
    check_problem(problem, engine)
