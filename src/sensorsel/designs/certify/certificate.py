"""A certificate for every greedy answer: how far it can be from the best possible suite.

The score f(S) = log det L(S) - log det L(empty) is monotone and submodular in the suite S (each
sensor adds a positive semi-definite block to the information matrix L; log det of such a sum has
diminishing returns; ``tests/test_properties.py`` checks it). For such an f and any suite S:

    f(OPT) <= f(S ∪ OPT) <= f(S) + Σ_{e ∈ OPT \\ S} Δ(e | S),      Δ(e | S) = f(S + e) - f(S) >= 0

(monotonicity, then submodularity along any order of OPT \\ S). OPT \\ S costs at most the budget
B, and nothing more is known about it, so the sum is at most the best 0/1 knapsack of the marginal
gains over the sensors outside S with capacity **B** (not B - Cost(S): OPT need not contain S, so
the sensors it adds to S may use the whole budget). This is the "online bound" of Leskovec et al.
(2007) with the knapsack solved exactly instead of by its fractional relaxation:

    U(S) = f(S) + max { Σ_{e ∈ T} Δ(e | S) : T ⊆ V \\ S, Cost(T) <= B }  >=  f(OPT)

:func:`certificate` keeps the smallest U over the empty suite and every intermediate suite of a
greedy run (one sweep of ``scores_with`` per suite, skipping the suites whose U provably cannot be
smaller). The greedy suite then scores at least ``score / bound`` of the best possible.

**With constraints** (:mod:`sensorsel.model.constraints`: the feasible suites are those with A x <= b,
holding the required sensors R and none of the excluded ones) the same argument holds with OPT
feasible: T = OPT \\ S holds R \\ S, and the rest of it, T \\ R, uses at most b - A 1_R (OPT holds R).
So the knapsack becomes an integer program over the marginal gains (several knapsack rows, mounting
slots, a count):

    U(S) = f(S) + Σ_{e ∈ R \\ S} Δ(e | S) + max { Σ_{e ∈ T} Δ(e | S) : T ⊆ V \\ (S ∪ R ∪ X), A 1_T <= b - A 1_R }

(X the excluded sensors), solved by scipy's ``milp`` (HiGHS, :func:`~.knapsack.packing_bound`),
whose value is its proved dual bound, never below the maximum. When the budget is the only row and
nothing is required or excluded, the single knapsack is solved exactly by dynamic programming.

Deterministic for a deterministic evaluator: same inputs, same bytes out (the wall time sits in a
separate ``seconds`` field). A gain below round-off counts as zero.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from sensorsel.designs.certify.knapsack import MAX_DP_CELLS, KnapsackSolution, knapsack, packing_bound
from sensorsel.designs.parts import Provenance, provenance
from sensorsel.designs.selection import REL_TOL, GreedyResult, check_budget
from sensorsel.errors import InputError
from sensorsel.information.evaluators import Evaluator, make_evaluator
from sensorsel.io.codec import last
from sensorsel.io.progress import Progress
from sensorsel.io.records import RuleBudget, SuiteScore
from sensorsel.io.results import result_kind
from sensorsel.model.constraints import Constraints, FeasibleSet, feasible_set
from sensorsel.model.library import SensorLibrary
from sensorsel.model.problem import Problem, ProblemInfo

#: progress(done, total)


@result_kind("certificate")
@dataclass(frozen=True)
class Certificate(Provenance, SuiteScore, RuleBudget):
    """How close a greedy suite is to the best possible suite of its budget.

    Computed by :func:`certificate` (the bound is explained in the module docstring).

    Attributes:
        bound: an upper bound on the score of every suite within the budget [nats]: the smallest
            U(S) over the empty suite and the greedy run's intermediate suites (and never below
            ``score``).
        ratio: score / bound in [0, 1]: the greedy suite scores at least this fraction of the best
            possible (1 when the bound is 0: nothing informative is affordable).
        percent_of_best: 100 * ratio: "at least X% of the best possible".
        gap: bound - score [nats]: the most the best possible suite can score above the greedy one.
        bound_step: where the smallest bound was attained: 0 = the empty suite, k = after the k-th pick.
        bound_suite: ids of that intermediate suite.
        step_bounds: U at the empty suite and after each pick [nats], shape (n_steps + 1,); None
            where the sweep was skipped because a lower bound on U there already reached ``bound``.
        knapsack_method: how the knapsacks were solved ("dp"; "milp" with constraints besides the
            budget; or every method used, joined by "+").
        knapsack_exact: whether every knapsack was solved exactly (the bound is valid either way).
        n_evaluations: suites scored for the certificate.
        engine: the evaluator used.
        constraints: (with ``problem`` and ``seconds``, :class:`~sensorsel.designs.parts.Provenance`'s)
            the greedy run's, which the bound respects.
    """

    bound: float
    ratio: float
    percent_of_best: float
    gap: float
    bound_step: int
    bound_suite: tuple[str, ...]
    step_bounds: tuple[float | None, ...]
    knapsack_method: str
    knapsack_exact: bool
    n_evaluations: int
    engine: str


@result_kind("greedy")
@dataclass(frozen=True)
class CertifiedGreedyResult(GreedyResult):
    """A greedy run with its certificate, when one was asked for (what ``sensorsel greedy`` writes).

    A :class:`~sensorsel.designs.selection.GreedyResult` with one more field, so that its JSON is a greedy
    result's plus ``certificate`` (any greedy result file loads as a ``GreedyResult``). It lives
    here, not in :mod:`sensorsel.designs.selection`, because selection sits below certify and may not import it.

    Attributes:
        certificate: how close the suite is to the best possible one of the budget (an upper bound
            on the optimum); None when it was not asked for.
    """

    certificate: Certificate | None = last(None)

    @classmethod
    def of(cls, result: GreedyResult, certificate: Certificate | None) -> CertifiedGreedyResult:
        """``result`` with ``certificate`` attached."""
        fields = {f: getattr(result, f) for f in GreedyResult.__dataclass_fields__}
        return cls(**fields, certificate=certificate)


@result_kind("suite-bound")
@dataclass(frozen=True)
class SuiteBound:
    """The submodular upper bound U(S) on the best possible score, evaluated at one suite S.

    Attributes:
        suite: ids of S.
        score: f(S) [nats].
        bound: U(S) = f(S) + the knapsack of the marginal gains with capacity the budget [nats].
        knapsack_suite: ids of the sensors of the best knapsack (what the bound "adds" to S).
        knapsack_method: how the knapsack was solved (see :class:`KnapsackSolution`).
        knapsack_exact: whether the knapsack value is its exact maximum (else an upper bound).
    """

    suite: tuple[str, ...]
    score: float
    bound: float
    knapsack_suite: tuple[str, ...]
    knapsack_method: str
    knapsack_exact: bool


def suite_bound(
    evaluator: Evaluator,
    suite: Sequence[int],
    budget_usd: float,
    *,
    score: float | None = None,
    exclude: frozenset[int] = frozenset(),
    max_cells: int = MAX_DP_CELLS,
    gains_out: np.ndarray | None = None,
    feas: FeasibleSet | None = None,
) -> SuiteBound:
    """U(S) >= f(OPT) for the best suite OPT within ``budget_usd`` (see the module docstring).

    Costs one sweep: ``scores_with(S, every sensor outside S that fits the budget)``. Negative gains (round-off of a
    sensor that adds nothing) count as zero, which can only raise the bound.

    Args:
        suite: library positions of S.
        budget_usd: the budget B [$]; the knapsack capacity is all of B.
        score: f(S) if already known [nats] (saves one evaluation).
        exclude: sensors that may not join (e.g. assumed failed); leaving them in only loosens the bound.
        gains_out: (n_sensors,) array; the swept sensors' marginal gains Δ(e | S) [nats] are written
            into it (others left as they are).
        feas: the feasible set OPT lies in (its budget is used, not ``budget_usd``); None, or one
            with the budget as its only row and nothing required or excluded: the single knapsack.
    """
    budget = check_budget(budget_usd)
    lib = evaluator.library
    s = tuple(int(i) for i in suite)
    f_s = evaluator.score(s) if score is None else float(score)
    if feas is not None and not feas.plain:
        return _constrained_bound(evaluator, s, f_s, feas, exclude, gains_out)
    inside = set(s) | set(exclude)
    costs = lib.costs
    # a sensor dearer than the whole budget is in no feasible T: no need to score it
    cand = [i for i in range(len(lib)) if i not in inside and costs[i] <= budget * (1 + 1e-12) + 1e-9]
    gains = np.maximum(evaluator.scores_with(s, cand) - f_s, 0.0) if cand else np.zeros(0)
    if gains_out is not None:
        gains_out[cand] = gains
    ks = knapsack(gains, costs[cand], budget, max_cells=max_cells)
    return SuiteBound(
        suite=lib.suite_ids(s),
        score=f_s,
        bound=f_s + ks.value,
        knapsack_suite=lib.suite_ids(sorted(cand[i] for i in ks.chosen)),
        knapsack_method=ks.method,
        knapsack_exact=ks.exact,
    )


def _constrained_bound(
    evaluator: Evaluator,
    s: tuple[int, ...],
    f_s: float,
    feas: FeasibleSet,
    exclude: frozenset[int],
    gains_out: np.ndarray | None,
) -> SuiteBound:
    """U(S) under the constraints of ``feas`` (the module docstring): the required sensors not in S
    are in every completion; the others pack into what the required sensors leave of each row."""
    lib = evaluator.library
    room, cand, forced = _packing_items(feas, s, exclude)
    swept = sorted(cand + forced)
    gains = np.maximum(evaluator.scores_with(s, swept) - f_s, 0.0) if swept else np.zeros(0)
    g = dict(zip(swept, gains))
    if gains_out is not None and swept:
        gains_out[swept] = gains
    ks = _packing(feas, np.array([g[i] for i in cand]), cand, room)
    return SuiteBound(
        suite=lib.suite_ids(s),
        score=f_s,
        bound=f_s + float(sum(g[i] for i in forced)) + ks.value,
        knapsack_suite=lib.suite_ids(sorted(forced + [cand[i] for i in ks.chosen])),
        knapsack_method=ks.method,
        knapsack_exact=ks.exact,
    )


def _packing_items(
    feas: FeasibleSet, s: tuple[int, ...], exclude: frozenset[int]
) -> tuple[np.ndarray, list[int], list[int]]:
    """(what the required sensors leave of each row (m,), the sensors that may join S besides them
    and fit that room on their own, the required sensors not in S)."""
    inside = set(s)
    required = set(feas.required)
    room = feas.b - feas.usage(feas.required)
    fits_alone = np.all(feas.A <= (room + 1e-9 * np.maximum(1.0, np.abs(feas.b)))[:, None], axis=0)
    cand = [
        i
        for i in range(len(feas.library))
        if i not in inside and i not in required and i not in feas.excluded and i not in exclude and fits_alone[i]
    ]
    forced = [i for i in feas.required if i not in inside]
    return room, cand, forced


def _packing(feas: FeasibleSet, values: np.ndarray, cand: list[int], room: np.ndarray) -> KnapsackSolution:
    """max Σ values over sets of ``cand`` within ``room`` of every row of ``feas`` (an upper bound)."""
    if not cand:
        return KnapsackSolution(0.0, (), 0.0, "trivial", True)
    return packing_bound(values, feas.A[:, cand], room)


def certificate(
    evaluator: Evaluator,
    greedy_result: GreedyResult,
    *,
    progress: Progress | None = None,
    max_cells: int = MAX_DP_CELLS,
    prune: bool = True,
) -> Certificate:
    """Certify a greedy run: an upper bound on the best possible score within its budget.

    The bound is the smallest U(S) (:func:`suite_bound`) over the empty suite and every
    ``greedy_result.steps`` suite. Valid for any suite the greedy returned, whatever its rule; with
    starting sensors or exclusions the bound over the whole library is still an upper bound (on a
    larger set of suites).

    Sweeps run from the final suite backwards. With ``prune``, a step is swept only if it could
    lower the bound: submodularity gives lower bounds on its marginal gains (a sensor's gain at S_k
    is at least its gain at any later, larger S_m already swept, and a later pick's gain at S_k is
    at least the gain it was bought with), so f(S_k) + the knapsack of those lower bounds is a lower
    bound on U(S_k); when it is not below the smallest U found (to a relative 1e-9), U(S_k) cannot
    improve the certificate and its sweep is skipped. On KITTI 03 and 00 at $110,000 this leaves
    two sweeps of eleven to fourteen (the final suite and the empty one). ``prune=False`` sweeps
    every step.

    Raises:
        InputError: the result names sensors that are not in the evaluator's library.
    """
    t0 = time.perf_counter()
    lib = evaluator.library
    n0 = evaluator.n_evaluations
    res = greedy_result
    budget = check_budget(res.budget_usd)
    feas = feasible_set(lib, budget, res.constraints if res.constraints is not None else Constraints(slots=False))
    constrained = None if feas.plain else feas
    try:
        step_suites: list[tuple[int, ...]] = [()] + [tuple(lib.position(x) for x in st.suite) for st in res.steps]
    except InputError as exc:
        raise InputError(f"the greedy result does not belong to this library: {exc}") from None
    n_steps = len(step_suites)
    # f at each suite: the run's own numbers when it used this engine (no re-evaluation)
    if res.engine == evaluator.name:
        step_scores = [0.0] + [st.score for st in res.steps]
    else:
        step_scores = [0.0] + [evaluator.score(s) for s in step_suites[1:]]
    # step j bought one sensor on top of step j - 1 (not so from the empty suite to a run's first
    # step when it started from given sensors): its gain there is a lower bound on its gain earlier
    later_picks = [
        (step_suites[j][-1], step_scores[j] - step_scores[j - 1]) if step_suites[j][:-1] == step_suites[j - 1] else None
        for j in range(1, n_steps)
    ]
    gain_low = np.zeros(len(lib))  # lower bounds on each sensor's gain at the step being looked at
    bounds: list[SuiteBound | None] = [None] * n_steps
    best = math.inf
    for done, k in enumerate(range(n_steps - 1, -1, -1), start=1):
        s = step_suites[k]
        skip = (
            prune
            and math.isfinite(best)
            and _cannot_improve(
                lib.costs, s, step_scores[k], gain_low, later_picks[k:], budget, best, max_cells, constrained
            )
        )
        if not skip:
            gains = np.zeros(len(lib))
            b = suite_bound(
                evaluator, s, budget, score=step_scores[k], max_cells=max_cells, gains_out=gains, feas=constrained
            )
            np.maximum(gain_low, gains, out=gain_low)
            bounds[k] = b
            best = min(best, b.bound)
        if progress:
            progress(done, n_steps)
    final = tuple(lib.position(x) for x in res.suite)
    score = res.score if res.engine == evaluator.name else (evaluator.score(final) if final else 0.0)
    return _certificate_record(res, bounds, score, evaluator, n0, t0, None if constrained is None else res.constraints)


def _cannot_improve(
    costs: np.ndarray,
    suite: tuple[int, ...],
    score: float,
    gain_low: np.ndarray,
    later_picks: Sequence[tuple[int, float] | None],
    budget: float,
    best: float,
    max_cells: int,
    feas: FeasibleSet | None = None,
) -> bool:
    """True when U(suite) provably cannot go below ``best`` (to a relative 1e-9): f(S) plus the
    knapsack of lower bounds on the gains at S (what was swept at larger suites, and the gains
    the later picks were bought with) already reaches it. With constraints (``feas``), the integer
    program's feasible solution found (its ``achieved``, a lower bound on its maximum) stands for the knapsack."""
    low = gain_low.copy()
    for pick_gain in later_picks:  # sensors bought after this step
        if pick_gain is not None:
            low[pick_gain[0]] = max(low[pick_gain[0]], pick_gain[1])
    if feas is not None:
        room, cand, forced = _packing_items(feas, suite, frozenset())
        packed = _packing(feas, np.maximum(low[cand], 0.0), cand, room).achieved
        lower_c = score + float(np.maximum(low[forced], 0.0).sum()) + packed
        return bool(lower_c >= best - REL_TOL * max(1.0, abs(best)))
    inside = set(suite)
    out = [i for i in range(len(costs)) if i not in inside and costs[i] <= budget * (1 + 1e-12) + 1e-9]
    lower = score + knapsack(np.maximum(low[out], 0.0), costs[out], budget, max_cells=max_cells).value
    return bool(lower >= best - REL_TOL * max(1.0, abs(best)))


def _certificate_record(
    res: GreedyResult,
    bounds: list[SuiteBound | None],
    score: float,
    evaluator: Evaluator,
    n0: int,
    t0: float,
    constraints: Constraints | None = None,
) -> Certificate:
    """The :class:`Certificate` from the swept steps' bounds (None: skipped) and the suite's score."""
    swept = [k for k, b in enumerate(bounds) if b is not None]
    swept_bounds = {k: b for k, b in enumerate(bounds) if b is not None}
    k_best = min(swept, key=lambda k: (swept_bounds[k].bound, k))  # first of equal minima: deterministic
    # U(S) >= f(OPT) >= score in exact arithmetic; round-off could put U a hair below: keep it valid.
    bound = max(swept_bounds[k_best].bound, score)
    ratio = 1.0 if bound <= 0 else min(1.0, max(0.0, score / bound))
    methods = sorted({b.knapsack_method for b in swept_bounds.values()})
    return Certificate(
        rule=res.rule,
        budget_usd=res.budget_usd,
        suite=res.suite,
        cost_usd=res.cost_usd,
        score=score,
        bound=bound,
        ratio=ratio,
        percent_of_best=100.0 * ratio,
        gap=bound - score,
        bound_step=k_best,
        bound_suite=swept_bounds[k_best].suite,
        step_bounds=tuple(None if b is None else b.bound for b in bounds),
        knapsack_method="+".join(methods),
        knapsack_exact=all(b.knapsack_exact for b in swept_bounds.values()),
        n_evaluations=evaluator.n_evaluations - n0,
        engine=evaluator.name,
        **provenance(res.problem, t0, constraints),
    )


def certify_greedy(
    source: Evaluator | Problem, result: GreedyResult, *, jobs: int = 1, progress: Progress | None = None
) -> Certificate:
    """The certificate of a greedy result (what ``sensorsel greedy`` prints); see :func:`certificate`.

    Args:
        source: the evaluator the run used, or its problem (then a fresh evaluator of the run's
            engine is made, with ``jobs`` processes).
    """
    ev = source if isinstance(source, Evaluator) else make_evaluator(source, result.engine, jobs=jobs)
    return certificate(ev, result, progress=progress)


def constraints_mismatch(result: GreedyResult, library: SensorLibrary) -> tuple[str, bool] | None:
    """Why a greedy result's constraints do not fit ``library``, or None when they do.

    Returns (the reason, whether the constraints can still be applied): a library whose resources
    or mounting slots differ from those the run was checked against (``library_digest``) can be
    used anyway (a caller's ``--force``); constraints the library cannot express at all (a resource
    it does not declare, an unknown sensor id) cannot.
    """
    c = result.constraints
    if c is None:
        return None
    try:
        here = feasible_set(library, result.budget_usd, c).constraints.library_digest
    except InputError as exc:
        return f"its constraints ({c.describe()}) do not apply to the library {library.source}: {exc}", False
    if c.library_digest and here != c.library_digest:
        return (
            f"its constraints ({c.describe()}) were checked against other resources or mounting slots than the "
            f"library {library.source} declares (digest {c.library_digest[:12]}, here {here[:12]})"
        ), True
    return None


def format_certificate(cert: Certificate) -> str:
    """One line: 'certificate: at least 97.3% of the best possible suite under $110,000 (...)'."""
    where = "the empty suite" if cert.bound_step == 0 else f"step {cert.bound_step} of {len(cert.step_bounds) - 1}"
    unit = (cert.problem or ProblemInfo).score_unit  # a domain's score is a weighted share of the best
    unit = f" {unit}" if unit else ""
    limits = " and its limits" if cert.constraints is not None else ""
    return (
        f"certificate: at least {_pct(cert.percent_of_best)}% of the best possible suite under "
        f"${cert.budget_usd:,.0f}{limits} "
        f"(f = {cert.score:.3f}{unit}; best possible <= {cert.bound:.3f}{unit}, bound from {where}; "
        f"{cert.n_evaluations:,} evaluations, {cert.seconds:.1f} s)"
    )


def _pct(p: float) -> str:
    """A percentage with one decimal, never rounded up to 100.0 unless it is 100."""
    if p >= 100.0:
        return "100"
    return f"{math.floor(p * 10) / 10:.1f}"
