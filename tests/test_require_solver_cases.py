"""The exact solver of `sensorsel require` against brute force on small libraries."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from sensorsel.designs.requirements import cheapest_suite, meets_after_failures
from sensorsel.model.constraints import Constraints, feasible_set

KEEP = [0, 14, 15, 16, 25, 26, 27, 38, 39, 40, 50, 51]  # 12 sensors of the real library, every model price


def _instance(n: int, seed: int, q: float):
    r = np.random.default_rng(seed)
    w = r.exponential(1.0, (n, 6)) * (r.random((n, 6)) < 0.5)
    need = q * w.sum(axis=0) * r.uniform(0.5, 1.0, 6) + 1e-9

    def got(s):
        return w[list(s)].sum(axis=0) if s else np.zeros(6)

    return (lambda s: bool(np.all(got(s) >= need))), (lambda s: float(np.max(np.maximum(0.0, 1 - got(s) / need))))


def _brute(fs, meets, alpha):
    allowed = [i for i in range(len(fs.library)) if i not in fs.excluded]
    best = math.inf
    for r in range(len(allowed) + 1):
        for s in itertools.combinations(allowed, r):
            cost = float(fs.A[0, list(s)].sum()) if s else 0.0
            if cost >= best or not fs.fits(s):
                continue
            if all(meets(tuple(x for x in s if x not in f)) for f in itertools.combinations(s, min(alpha, len(s)))):
                best = cost
    return best


def _is_the_brute_force_answer(fs, meets, alpha, r, best) -> bool:
    """Assert that the solver's result ``r`` is brute force's ``best`` cost: a lower bound never above
    it, "infeasible" where nothing meets it, else optimal at that cost with a suite that fits and
    meets it after ``alpha`` failures. False where it is infeasible."""
    assert r.lower_bound <= best + 1e-6
    if math.isinf(best):
        assert r.status == "infeasible"
        return False
    assert r.status == "optimal" and r.cost == best and fs.fits(r.suite)
    assert meets_after_failures(meets, [r.suite], failures=alpha) == (True,)
    return True


CONS = [Constraints(), Constraints(max_sensors=5), Constraints.of(require=["WSC-12"], exclude=["LRR-1"])]


@pytest.mark.parametrize("alpha", [0, 1, 2])
@pytest.mark.parametrize("ci", range(len(CONS)))
def test_equals_brute_force(library, alpha, ci):
    sub = library.subset(KEEP)
    for seed in range(4):
        meets, viol = _instance(len(sub), seed, [0.3, 0.2, 0.12][alpha])
        fs = feasible_set(sub, math.inf, CONS[ci])
        best = _brute(fs, meets, alpha)
        for v in (viol, None):
            r = cheapest_suite(fs, meets, failures=alpha, violation=v)
            if not _is_the_brute_force_answer(fs, meets, alpha, r, best):
                assert r.suite is None


def test_deterministic(library):
    sub = library.subset(KEEP)
    meets, viol = _instance(len(sub), 1, 0.2)
    fs = feasible_set(sub, math.inf, Constraints())
    a, b = (cheapest_suite(fs, meets, failures=1, violation=viol) for _ in range(2))
    assert (a.suite, a.cost, a.cuts, a.n_checks) == (b.suite, b.cost, b.cuts, b.n_checks)


#: twelve sensors of one price (cameras at their clock positions): the symmetric case, many ties
SAME_PRICE = list(range(38, 50))


@pytest.mark.parametrize("alpha", [0, 1])
def test_many_sensors_of_one_price_equal_brute_force(library, alpha):
    sub = library.subset(SAME_PRICE)
    assert len(set(sub.costs.tolist())) == 1
    for seed in range(3):
        meets, viol = _instance(len(sub), seed, [0.3, 0.2][alpha])
        fs = feasible_set(sub, math.inf, Constraints())
        best = _brute(fs, meets, alpha)
        r = cheapest_suite(fs, meets, failures=alpha, violation=viol)
        assert r.lower_bound <= best + 1e-6
        if math.isinf(best):
            assert r.status == "infeasible"
            continue
        assert r.status == "optimal" and r.cost == best
        for t in (r.suite, *r.ties):  # the answer and every tie meet it, at the same cost
            assert meets_after_failures(meets, [t], failures=alpha) == (True,) and len(t) == len(r.suite)


#: a long-range radar, a wide-angle camera and six cameras ($449): the radar alone meets the
#: requirement, as do three cameras
FLOOR_CASE = [13, 26, 38, 41, 44, 47, 50, 56]


def _radar_or_three_cameras(sub):
    radar, cams = sub.ids.index("LRR-12"), [k for k, i in enumerate(sub.ids) if i.startswith(("HD2K", "LSC"))]

    def meets(s):
        return radar in s or sum(1 for i in s if i in cams) >= 3

    def viol(s):
        return 0.0 if meets(s) else 1.0 - sum(1 for i in s if i in cams) / 3

    return meets, viol


@pytest.mark.parametrize("alpha", [1, 2])
@pytest.mark.parametrize("cons", [Constraints(), Constraints.of(require=["WSC-12"])], ids=["free", "required"])
def test_failures_fix_out_what_no_cheaper_suite_holds(library, alpha, cons):
    # With failures, a suite holding the radar ($1,493) keeps a suite that meets the requirement
    # without it (>= 3 cameras, $1,347) once the radar fails: no suite holding it costs less than
    # $2,840, while α + 3 cameras ($1,796, $2,245) meet it. The radar alone costs less than that,
    # so only the floor of the suites without it fixes it out of the search (no check); the answer
    # is still brute force's (a required sensor, which no floor counts, included: then the radar
    # stays in, its floor with the required sensor's $2,990 being under the cheapest suite).
    sub = library.subset(FLOOR_CASE)
    meets, viol = _radar_or_three_cameras(sub)
    fs = feasible_set(sub, math.inf, cons)
    best = _brute(fs, meets, alpha)
    r = cheapest_suite(fs, meets, failures=alpha, violation=viol)
    assert r.status == "optimal" and r.cost == best and r.lower_bound == best
    assert meets_after_failures(meets, [r.suite], failures=alpha) == (True,)
    base = sum(float(fs.A[0, i]) for i in fs.required)
    by_price = sum(1 for i in range(len(sub)) if i not in fs.required and base + fs.A[0, i] > best + 1e-6)
    radar = sub.ids.index("LRR-12")
    assert base + fs.A[0, radar] < best
    assert r.fixed_out >= by_price + (0 if fs.required else 1)  # the radar too, but beside the required sensor


@pytest.mark.parametrize("alpha", [0, 1, 2])
def test_with_the_proved_lower_bound_as_a_row_from_the_first_program_the_answers_stay_the_cheapest(
    library, alpha, monkeypatch
):
    """Once a search's integer programs need branch and bound, each carries the lower bound proved so
    far as a row and HiGHS stops at the first suite at that cost (:func:`.programs.propose`'s
    ``floor``). Here that holds from the first program on (the threshold of nodes 0): on the mixed
    prices, the twelve sensors of one price and under limits, the same cheapest cost as brute force,
    a lower bound never above it, and every program after the first one carried the row."""
    from sensorsel.designs.requirements import programs

    monkeypatch.setattr(programs, "FLOOR_AFTER_NODES", 0)
    rows = []
    propose = programs.propose

    def counting(s, *a, **kw):
        rows.append(bool(s.hard and kw.get("floor", 0.0) > 0))
        return propose(s, *a, **kw)

    monkeypatch.setattr("sensorsel.designs.requirements.solver._propose", counting)
    for keep, cons in ((KEEP, Constraints()), (SAME_PRICE, Constraints()), (KEEP, Constraints(max_sensors=5))):
        sub = library.subset(keep)
        for seed in range(3):
            meets, viol = _instance(len(sub), seed, [0.3, 0.2, 0.12][alpha])
            fs = feasible_set(sub, math.inf, cons)
            best = _brute(fs, meets, alpha)
            _is_the_brute_force_answer(
                fs, meets, alpha, cheapest_suite(fs, meets, failures=alpha, violation=viol), best
            )
    assert sum(rows) > 0, "no program carried the row: the floor is not exercised"


def test_highs_takes_the_absolute_gap_the_floor_needs():
    """scipy's ``milp`` passes ``mip_abs_gap`` (an option it does not check itself) to HiGHS verbatim;
    HiGHS warns (OptimizeWarning) of an option it does not know. A program with the floor row raises
    no warning at all (propose silences scipy's own note only), and stops at a suite of the floor's
    cost."""
    import warnings
    from types import SimpleNamespace

    from sensorsel.designs.requirements import programs
    from sensorsel.model.library import load_library

    lib = load_library().subset(SAME_PRICE)
    fs = feasible_set(lib, math.inf, Constraints())
    n = len(lib)
    s = SimpleNamespace(
        n=n,
        fs=fs,
        down=None,
        up=None,
        nogoods=[1 << 0],
        allowed=list(range(n)),
        fixed_out=0,
        alpha=0,
        price=np.asarray(fs.A[0], float),
        orders=(),
        hard=True,
        solved={},
        resumed_from=frozenset(),
        programs_resumed=0,
    )
    s.down = SimpleNamespace(failing=SimpleNamespace(masks=[(1 << n) - 1 - (1 << 3) - (1 << 7)]))  # x3 + x7 >= 1
    spent = [0.0, 0]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        bound, suite, proved = programs.propose(s, None, spent, floor=float(s.price[3]))
    assert proved and suite in (1 << 3, 1 << 7) and bound <= s.price[3] + programs.tol(s.price[3])


def _one_swaps_in_order(s, last):
    """Every suite ``last`` with one member swapped for an outsider of its price, in the documented
    order (dearest member first, then cheapest outsider; ties by position), by plain sets."""
    members = sorted((i for i in range(s.n) if last >> i & 1), key=lambda i: (-s.price[i], i))
    outside = sorted((j for j in s.allowed if not last >> j & 1), key=lambda j: (s.price[j], j))
    return [last & ~(1 << i) | 1 << j for i in members for j in outside if s.price[i] == s.price[j]]


def _satisfies_every_row(s, m) -> bool:
    inside = lambda a, b: a & ~b == 0  # noqa: E731
    cuts_ok = all(bin(m & ~f).count("1") >= s.alpha + 1 for f in s.down.failing.masks)
    return cuts_ok and inside(s.required, m) and not m & s.fixed_out and m not in s.nogoods and s.fits(m)


@pytest.mark.parametrize("alpha", [0, 1])
def test_a_plateau_swap_is_the_first_one_swap_every_row_allows(library, alpha):
    from sensorsel.designs.requirements.oracle import Monotone, mask_of
    from sensorsel.designs.requirements.programs import plateau_swap
    from sensorsel.designs.requirements.solver import _Search

    sub = library.subset(SAME_PRICE)  # twelve sensors of one price: every swap keeps the cost
    fs = feasible_set(sub, math.inf, Constraints())
    s = _Search(fs, alpha, Monotone(len(sub), lambda _: False), None, None)
    last = mask_of([0, 1, 2, 3])
    lower = s.cost(last)
    # a failing set known that rules out the first swaps in order (member 0 for outsider 4, ...)
    s.down.record(mask_of([1, 2, 3, 4, 5] if alpha == 0 else [1, 2, 3, 5]), False)
    s.fixed_out = mask_of([11])
    swaps = _one_swaps_in_order(s, last)
    s.nogoods.append([m for m in swaps if _satisfies_every_row(s, m)][0])  # and a no-good the first left
    allowed = [m for m in swaps if _satisfies_every_row(s, m)]
    assert allowed and allowed[0] != swaps[0]  # the first swaps are ruled out: the rows are what picks it
    assert all(not m >> 11 & 1 for m in allowed)
    assert plateau_swap(s, last, lower) == allowed[0]
    # a suite that does not cost the proved lower bound is no optimum of the next program: none
    assert plateau_swap(s, last, lower - 449.0) is None
    # every swap ruled out by a cut: none
    s.down.record(mask_of(range(11)), False)
    assert plateau_swap(s, last, lower) is None


@pytest.mark.parametrize("alpha", [1, 2])
def test_plateau_swaps_keep_the_brute_force_answer(library, alpha):
    """With failures the search proposes swaps on plateaus of one price (the symmetric library and
    the mixed one): the answer stays brute force's, and the swaps are used (they are what is tested)."""
    used = 0
    for keep, q in ((SAME_PRICE, [0.3, 0.2, 0.12][alpha]), (KEEP, [0.3, 0.2, 0.12][alpha])):
        sub = library.subset(keep)
        for seed in range(3):
            meets, viol = _instance(len(sub), seed, q)
            fs = feasible_set(sub, math.inf, Constraints())
            r = cheapest_suite(fs, meets, failures=alpha, violation=viol)
            _is_the_brute_force_answer(fs, meets, alpha, r, _brute(fs, meets, alpha))
            used += r.plateau_swaps
    assert used > 0


@pytest.mark.parametrize("alpha", [0, 1])
def test_every_sensor_together_is_checked_only_where_the_greedy_found_nothing(library, alpha):
    """The check of every allowed sensor together (the infeasibility test) comes after the greedy
    and only where it found no suite: a suite that meets the requirement shows that every sensor
    together does. Where nothing meets it, it is still asked and the answer is "infeasible" by the
    library, as brute force says. Questions (of the requirement and of its violation) recorded by
    wrapping them (plain functions); the violation is summed over the requirement's six dimensions, so that the greedy
    (which stops where no single sensor lowers it) reaches a suite."""
    sub = library.subset(KEEP)
    universe = tuple(range(len(sub)))
    r_ = np.random.default_rng(7)
    w = r_.exponential(1.0, (len(sub), 6)) * (r_.random((len(sub), 6)) < 0.5)
    for q in ([0.3, 0.2][alpha], 1.5):  # one instance some suite meets, one that nothing meets
        need = q * w.sum(axis=0) + 1e-9
        asked: list[tuple[int, ...]] = []

        def meets(s, need=need):
            return bool(np.all(w[list(s)].sum(axis=0) >= need)) if s else False

        def recorded(s, meets=meets):
            asked.append(tuple(sorted(s)))
            return meets(s)

        def violation(s, need=need):
            asked.append(tuple(sorted(s)))
            got = w[list(s)].sum(axis=0) if s else np.zeros(6)
            return float(np.sum(np.maximum(0.0, 1 - got / need)))

        fs = feasible_set(sub, math.inf, Constraints())
        best = _brute(fs, meets, alpha)
        r = cheapest_suite(fs, recorded, failures=alpha, violation=violation)
        _is_the_brute_force_answer(fs, meets, alpha, r, best)
        if math.isinf(best):  # asked (or known from the greedy's own question about it)
            assert r.status == "infeasible" and r.infeasible_by == "library" and universe in asked
        else:
            assert universe not in asked


@pytest.mark.parametrize("alpha", [0, 1])
def test_a_cheap_refutation_of_every_sensor_answers_infeasible_before_the_greedy(library, alpha):
    """``refute`` (a cheap bound: here the requirement with every sensor's weights 20 % larger, which
    a suite fails only where it fails the requirement) is asked of every allowed sensor together
    first. Where it refutes them, the answer is brute force's "infeasible" by the library with no
    question asked of the requirement; where it does not, the search asks the very questions, in
    the same order, and gives the same answer as without it."""
    sub = library.subset(KEEP)
    universe = tuple(range(len(sub)))
    r_ = np.random.default_rng(7)
    w = r_.exponential(1.0, (len(sub), 6)) * (r_.random((len(sub), 6)) < 0.5)
    for q in ([0.3, 0.2][alpha], 1.5):
        need = q * w.sum(axis=0) + 1e-9

        def meets(s, need=need, scale=1.0):
            return bool(np.all(scale * w[list(s)].sum(axis=0) >= need)) if s else False

        def run(refute):
            asked: list[tuple[str, tuple[int, ...]]] = []

            def recorded(s):
                asked.append(("meets", tuple(sorted(s))))
                return meets(s)

            def violation(s, need=need):
                asked.append(("violation", tuple(sorted(s))))
                got = w[list(s)].sum(axis=0) if s else np.zeros(6)
                return float(np.sum(np.maximum(0.0, 1 - got / need)))

            fs = feasible_set(sub, math.inf, Constraints())
            return cheapest_suite(fs, recorded, failures=alpha, violation=violation, refute=refute), asked

        refuted: list[tuple[int, ...]] = []

        def refute(s):
            refuted.append(tuple(s))
            return not meets(s, scale=1.2)

        plain, asked_plain = run(None)
        got, asked = run(refute)
        assert refuted == [universe]
        fs = feasible_set(sub, math.inf, Constraints())
        best = _brute(fs, meets, alpha)
        _is_the_brute_force_answer(fs, meets, alpha, got, best)
        if math.isinf(best):
            assert got.status == "infeasible" and got.infeasible_by == "library" and asked == []
            assert asked_plain  # without it, the greedy asked its way there
        else:
            assert asked == asked_plain
            assert (got.status, got.suite, got.cost, got.lower_bound) == (
                plain.status,
                plain.suite,
                plain.cost,
                plain.lower_bound,
            )
