"""The requirement solver on requirements that are not monotone (adding a sensor may break them, as
integrity does): the answer is the brute-force cheapest suite on 12 sensors, with failures and
limits, whatever relaxations are given; the lower bound is never above it."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from sensorsel.designs.requirements import cheapest_suite
from sensorsel.model.constraints import Constraints, feasible_set

KEEP = [0, 14, 15, 16, 25, 26, 27, 38, 39, 40, 50, 51]  # 12 sensors of the real library, every model price


def _instance(n: int, seed: int):
    """meets(S) = coverage(S) >= need (monotone) and risk(S) <= cap (anti-monotone: each sensor
    adds risk) and not (a conflicting pair in S without its mediator) (neither)."""
    r = np.random.default_rng(seed)
    w = r.exponential(1.0, (n, 4)) * (r.random((n, 4)) < 0.6)
    need = 0.25 * w.sum(axis=0) * r.uniform(0.5, 1.0, 4) + 1e-9
    risk = r.uniform(0.0, 1.0, n)
    cap = float(r.uniform(1.5, 3.5))
    a, b, c = (int(x) for x in r.choice(n, 3, replace=False))

    def cover(s):
        return bool(np.all((w[list(s)].sum(axis=0) if s else np.zeros(4)) >= need))

    def safe(s):
        return float(risk[list(s)].sum()) <= cap

    def meets(s):
        return cover(s) and safe(s) and not ({a, b} <= set(s) and c not in s)

    return meets, cover, safe


def _meets_after(meets, s, alpha):
    return all(
        meets(tuple(x for x in s if x not in f))
        for k in range(min(alpha, len(s)) + 1)
        for f in itertools.combinations(s, k)
    )


def _brute(fs, meets, alpha):
    allowed = [i for i in range(len(fs.library)) if i not in fs.excluded]
    best = math.inf
    for r in range(len(allowed) + 1):
        for s in itertools.combinations(allowed, r):
            cost = float(fs.A[0, list(s)].sum()) if s else 0.0
            if cost < best and fs.fits(s) and _meets_after(meets, s, alpha):
                best = cost
    return best


CONS = [Constraints(), Constraints(max_sensors=4), Constraints.of(require=["WSC-12"], exclude=["LRR-1"])]


# without the monotone relaxation each suite short of coverage is excluded alone (one integer program
# each): those run on seven sensors, and with a failure only with a required sensor (fewer suites)
CASES = [(r, ci, a) for r in ("both", "down") for ci in range(len(CONS)) for a in (0, 1)] + [
    (r, ci, a) for r in ("up", "none") for ci, a in ((0, 0), (2, 0), (2, 1))
]


@pytest.mark.parametrize("relax, ci, alpha", CASES)
def test_equals_brute_force(library, alpha, ci, relax):
    sub = library.subset(KEEP if relax in ("both", "down") else [KEEP[i] for i in (1, 2, 5, 6, 7, 8, 10)])
    for seed in range(3):
        meets, cover, safe = _instance(len(sub), seed)
        fs = feasible_set(sub, math.inf, CONS[ci])
        best = _brute(fs, meets, alpha)
        r = cheapest_suite(
            fs,
            meets,
            failures=alpha,
            monotone=False,
            necessary_monotone=cover if relax in ("both", "down") else None,
            necessary_antimonotone=safe if relax in ("both", "up") else None,
        )
        assert r.lower_bound <= best + 1e-6
        if math.isinf(best):
            assert r.status == "infeasible" and r.suite is None
        else:
            assert r.status == "optimal" and r.cost == best and fs.fits(r.suite)
            assert _meets_after(meets, r.suite, alpha)
            for t in r.ties:  # every tie is as cheap and meets it too
                assert float(fs.A[0, list(t)].sum()) == pytest.approx(best) and _meets_after(meets, t, alpha)


def test_adding_a_sensor_breaks_it_and_the_answer_is_not_the_monotone_one(library):
    """An instance where a suite meets the requirement and a superset does not: the solver must not
    infer the superset meets (the monotone solver, told the same predicate, answers a suite that fails)."""
    sub = library.subset(KEEP)
    for seed in range(40):
        meets, cover, safe = _instance(len(sub), seed)
        fs = feasible_set(sub, math.inf, Constraints())
        best = _brute(fs, meets, 1)
        if math.isinf(best):
            continue
        wrong = cheapest_suite(fs, meets, failures=1)  # told (wrongly) that it is monotone
        if wrong.suite is not None and _meets_after(meets, wrong.suite, 1):
            continue
        right = cheapest_suite(
            fs, meets, failures=1, monotone=False, necessary_monotone=cover, necessary_antimonotone=safe
        )
        assert right.status == "optimal" and right.cost == best and _meets_after(meets, right.suite, 1)
        suites = [s for k in range(len(sub) + 1) for s in itertools.combinations(range(len(sub)), k)]
        assert any(
            meets(s) and not meets(tuple(sorted(set(s) | {i}))) for s in suites for i in range(len(sub)) if i not in s
        )
        return
    pytest.fail("no instance where the monotone inference goes wrong: the test proves nothing")


def test_relaxations_only_for_a_requirement_that_is_not_monotone(library):
    fs = feasible_set(library.subset(KEEP), math.inf, Constraints())
    with pytest.raises(ValueError, match="monotone=False"):
        cheapest_suite(fs, lambda s: True, necessary_monotone=lambda s: True)
