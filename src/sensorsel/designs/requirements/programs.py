"""The integer programs of the requirement solver (scipy's ``milp``, HiGHS): the cheapest suite
that satisfies the feasible set's rows, every cut and no-good found so far (:mod:`.solver`)."""

from __future__ import annotations

import hashlib
import math
import re
import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from sensorsel.designs.requirements.oracle import mask_of as _mask
from sensorsel.designs.requirements.oracle import suite_of as _suite
from sensorsel.io.files import quiet_stdout

__all__ = ["FLOOR_AFTER_NODES", "MILP_NODE_LIMIT", "Solved", "floor_cost", "propose", "tol"]

#: an integer program's answer as a journal keeps it (:func:`_solve`): (the program's key, scipy's
#: status, the library positions at 1 in its solution or None, the objective [$] or None, HiGHS's
#: dual bound [$] or None, its branch-and-bound nodes)
Solved = tuple[str, int, tuple[int, ...] | None, float | None, float | None, int]

#: HiGHS's branch-and-bound node limit per integer program (deterministic, unlike a time limit)
MILP_NODE_LIMIT = 100_000
#: once an integer program of a search needs this many branch-and-bound nodes, the search's later
#: programs carry its proved lower bound as a row (:func:`propose`'s ``floor``). Measured side by
#: side (``bench/require.py --solvers new nofloor``): on the bundled fixtures' domain, local streets,
#: the programs' time 92 -> 29 s and the run's 164 -> 87 s; on the README tour and KITTI 03, whose
#: programs need a few nodes, nothing changes. Not from the first program: where proving the optimum
#: costs HiGHS little, the suite it proves optimal was measured to lead to fewer checks than the
#: first one it finds at the bound (the tour: 37 against 103 programs), and which suite it proposes
#: is all the row changes
FLOOR_AFTER_NODES = 20
#: two costs closer than this [$] (plus a relative 1e-9) are equal: a tenth of a cent, above the
#: slack of HiGHS's dual bound (its rows hold to feasibility tolerances, so an optimum's dual bound can
#: sit below the optimal cost: 1.7e-5 under a $3,279 suite in a case of tests/test_require_solver.py,
#: where a tolerance of 1e-6 left the lower bound short of the cost and the loop proposing the same
#: suite to its iteration limit) and below any difference of two costs of whole cents
_COST_TOL = 1e-3
#: slack on a packing row relative to its limit, as the feasible set's (constraints.REL_SLACK)
_ROW_SLACK = 1e-9
#: how far [$] (plus a relative 1e-9) below a proved lower bound the floor row of :func:`propose`
#: sits: above the rounding of HiGHS's dual bounds, well under the optimality gap below
_FLOOR_MARGIN = 1e-4
#: HiGHS's absolute optimality gap [$] above the floor row's margin: a suite within it of the dual
#: bound is optimal. It stays under :data:`_COST_TOL`, so such a suite costs what the cheapest does
#: by the solver's own equality of costs (:func:`tol`)
_GAP_ABOVE_MARGIN = 4e-4


@dataclass(frozen=True)
class _Result:
    """What the search reads of scipy's ``milp`` result: its own, or one read back from a journal."""

    status: int
    x: np.ndarray | None
    fun: float | None
    mip_dual_bound: float | None
    mip_node_count: int


def _key(price: np.ndarray, lb: np.ndarray, ub: np.ndarray, rows: Sequence[Any], options: dict[str, object]) -> str:
    """sha256 of everything an integer program's answer depends on: the costs, the bounds, every
    row and HiGHS's options but its time limit (which stops a search, and does not steer it)."""
    h = hashlib.sha256()
    for a in (price, lb, ub):
        h.update(np.ascontiguousarray(a, dtype=float).tobytes() + b"|")
    for r in rows:
        A = np.atleast_2d(np.asarray(r.A, dtype=float))
        h.update(repr(A.shape).encode() + np.ascontiguousarray(A).tobytes())
        for limit in (r.lb, r.ub):
            h.update(np.ascontiguousarray(np.broadcast_to(np.asarray(limit, dtype=float), A.shape[:1])).tobytes())
    h.update(repr(sorted((k, v) for k, v in options.items() if k != "time_limit")).encode())
    return h.hexdigest()


def _solve(s: Any, lb: np.ndarray, ub: np.ndarray, rows: Sequence[Any], options: dict[str, object]) -> _Result:
    """min ``s.price`` · x over binary x within [``lb``, ``ub``] and ``rows``, by scipy's ``milp``, or
    its answer kept in ``s.solved`` (key -> :data:`Solved`: a resumed run's journal gives the
    programs an interrupted run solved, in the order the search poses them again; ``s.resumed_from``
    holds those keys and ``s.programs_resumed`` counts them as they are read). An answer is kept
    unless a time limit may have cut it (scipy's status 1 with a ``time_limit``: the node limit alone
    stops a search where it always does). A journal's answer is an optimum (or the dual bound) of
    this very program, so the search goes on as sound as if HiGHS had solved it here."""
    from scipy.optimize import Bounds, milp

    key = _key(s.price, lb, ub, rows, options)
    got = s.solved.get(key)
    if got is not None:
        s.programs_resumed += key in s.resumed_from
        _, status, ones, fun, dual, nodes = got
        x = None if ones is None else np.isin(np.arange(len(s.price)), ones).astype(float)
        return _Result(status, x, fun, dual, nodes)
    with quiet_stdout(), warnings.catch_warnings():
        # scipy's milp names mip_abs_gap among the options it does not check itself and passes to
        # HiGHS verbatim (a RuntimeWarning says so); HiGHS knows it (a test checks that it takes effect)
        warnings.filterwarnings("ignore", re.escape("Unrecognized options detected: {'mip_abs_gap'}"), RuntimeWarning)
        res = milp(s.price, integrality=np.ones(len(s.price)), bounds=Bounds(lb, ub), constraints=rows, options=options)
    dual = getattr(res, "mip_dual_bound", None)
    out = _Result(
        int(res.status),
        res.x,
        None if res.fun is None else float(res.fun),
        None if dual is None else float(dual),
        int(getattr(res, "mip_node_count", 0) or 0),
    )
    if out.status != 1 or "time_limit" not in options:
        ones = None if res.x is None else tuple(int(i) for i in np.flatnonzero(res.x > 0.5))
        s.solved[key] = (key, out.status, ones, out.fun, out.mip_dual_bound, out.mip_node_count)
    return out


def tol(cost: float) -> float:
    """How close two costs [$] must be to count as equal."""
    return _COST_TOL + 1e-9 * abs(cost) if math.isfinite(cost) else 0.0


def propose(
    s: Any,
    time_left: float | None,
    programs: list[float],
    *,
    cap: float | None = None,
    exclude: Sequence[int] = (),
    floor: float = 0.0,
) -> tuple[float, int | None, bool] | None:
    """min cost(x) over the feasible set's rows, every cut and no-good, the sensors fixed out at 0
    (and with ``cap`` the cost at most ``cap``, the suites ``exclude`` excluded): (lower bound [$],
    the optimal suite or None, whether HiGHS proved it optimal), or None when no suite satisfies
    them all. Its time is added to ``programs[0]``.

    ``floor`` [$]: a lower bound already proved on every suite these rows allow (an earlier
    program's, whose rows these only add to), used once ``s.hard`` is set. It becomes a row, cost(x)
    >= ``floor`` (less :data:`_FLOOR_MARGIN`), and HiGHS stops at a suite within its absolute gap of
    it. Why: on a plateau (many suites of one price, the cuts ruling them out one by one) each
    program's optimum is the last one's, and without the row HiGHS proves it again by branch and
    bound (a second or more on the bundled fixtures' domain, where a weighted set cover of sensors
    of one price gives a weak relaxation); with it, the first suite found at that cost closes the
    gap. The cost proposed is the same, and the lower bound the search keeps still only rises; which
    of the equally priced suites is proposed may differ. A program that needs
    :data:`FLOOR_AFTER_NODES` nodes or more sets ``s.hard``."""
    from scipy.optimize import LinearConstraint

    n, fs = s.n, s.fs
    cuts = s.down.failing.masks if s.down is not None else []
    cuts_in = s.up.failing.masks if s.up is not None else []
    nogoods = list(s.nogoods) + list(exclude)
    if n == 0:
        return (0.0, 0, True) if not cuts and 0 not in nogoods else None
    lb = np.zeros(n)
    ub = np.zeros(n)
    ub[s.allowed] = 1.0
    ub[list(_suite(s.fixed_out))] = 0.0
    lb[list(fs.required)] = 1.0
    rows = []
    finite = np.isfinite(fs.b)
    if finite.any():
        b = fs.b[finite]
        room = b + _ROW_SLACK * np.maximum(1.0, np.abs(b))
        scale = 1.0 / np.maximum(np.abs(room), 1e-12)  # rows ~1 so that dollars and counts are alike to HiGHS
        rows.append(LinearConstraint(fs.A[finite] * scale[:, None], -np.inf, room * scale))
    if cap is not None:
        c = cap + tol(cap)
        rows.append(LinearConstraint(s.price[None, :] / max(abs(c), 1.0), -np.inf, c / max(abs(c), 1.0)))
    if cuts:
        out = np.array([[0.0 if f >> i & 1 else 1.0 for i in range(n)] for f in cuts])
        rows.append(LinearConstraint(out, s.alpha + 1, np.inf))
    if cuts_in:
        inside = np.array([[1.0 if m >> i & 1 else 0.0 for i in range(n)] for m in cuts_in])
        rows.append(LinearConstraint(inside, -np.inf, inside.sum(axis=1) - 1.0))
    if not getattr(s, "hard", False):
        floor = 0.0
    margin = _FLOOR_MARGIN + 1e-9 * abs(floor)
    if floor > margin:  # cost(x) >= floor - margin, scaled as the cap's row
        rows.append(LinearConstraint(s.price[None, :] / floor, (floor - margin) / floor, np.inf))
    orders = getattr(s, "orders", ())
    if orders:  # x_w - x_s <= 0: a dominated sensor only with its dominator (dominance.dominance_order)
        order_rows = np.zeros((len(orders), n))
        for r, (w, v) in enumerate(orders):
            order_rows[r, w], order_rows[r, v] = 1.0, -1.0
        rows.append(LinearConstraint(order_rows, -np.inf, 0.0))
    for g in nogoods:  # Σ_{i ∉ g} x_i - Σ_{i ∈ g} x_i >= 1 - |g|: any suite but g
        sign = np.array([-1.0 if g >> i & 1 else 1.0 for i in range(n)])
        rows.append(LinearConstraint(sign[None, :], 1 - bin(g).count("1"), np.inf))
    options: dict[str, object] = {"node_limit": MILP_NODE_LIMIT, "mip_rel_gap": 0.0, "presolve": True, "disp": False}
    if floor > margin:
        options["mip_abs_gap"] = margin + _GAP_ABOVE_MARGIN
    if time_left is not None:
        options["time_limit"] = max(time_left, 1e-3)
    t = time.perf_counter()
    res = _solve(s, lb, ub, rows, options)
    programs[0] += time.perf_counter() - t
    if res.mip_node_count >= FLOOR_AFTER_NODES:
        s.hard = True
    if res.status == 2:
        return None
    proposal = _mask(int(i) for i in np.flatnonzero(res.x > 0.5)) if res.x is not None else None
    dual = res.mip_dual_bound
    if res.status == 0 and res.fun is not None:
        bound = float(res.fun) if dual is None or not math.isfinite(dual) else min(float(res.fun), float(dual))
        return bound, proposal, True
    bound = float(dual) if dual is not None and math.isfinite(dual) else 0.0
    return bound, proposal, False


def floor_cost(s: Any, programs: list[float], without: int = 0) -> tuple[float, int | None]:
    """A lower bound [$] on the cost of every suite that passes the monotone predicate ``s.down``
    and holds no sensor fixed out, excluded, nor in ``without`` (a bit mask): min cost(x) such that
    Σ_{i ∉ M} x_i >= 1 for every failing set M known, with neither the feasible set's rows nor its
    required sensors (a suite minus its failed sensors need keep neither); with the optimal suite
    (None when HiGHS stopped at its node limit: the bound is then its dual bound). (inf, None) when
    no suite satisfies the cuts. Its time is added to ``programs[0]``."""
    from scipy.optimize import LinearConstraint

    n = s.n
    cuts = s.down.failing.masks
    if n == 0 or not cuts:
        return 0.0, 0
    ub = np.zeros(n)
    ub[s.allowed] = 1.0
    ub[list(_suite(s.fixed_out | without))] = 0.0
    out = np.array([[0.0 if f >> i & 1 else 1.0 for i in range(n)] for f in cuts])
    t = time.perf_counter()
    res = _solve(
        s,
        np.zeros(n),
        ub,
        [LinearConstraint(out, 1.0, np.inf)],
        {"node_limit": MILP_NODE_LIMIT, "mip_rel_gap": 0.0, "presolve": True, "disp": False},
    )
    programs[0] += time.perf_counter() - t
    if res.status == 2:
        return math.inf, None
    dual = res.mip_dual_bound
    if res.status == 0 and res.fun is not None and res.x is not None:
        bound = float(res.fun) if dual is None or not math.isfinite(dual) else min(float(res.fun), float(dual))
        return bound, _mask(int(i) for i in np.flatnonzero(res.x > 0.5))
    return (float(dual) if dual is not None and math.isfinite(dual) else 0.0), None


def _bits(rows: np.ndarray, n: int) -> np.ndarray:
    """(R, n) 0/1 of sets given as rows of 64-bit words (:meth:`.oracle.Antichain.as_words`; bit i:
    library position i)."""
    if not len(rows):
        return np.zeros((0, n), np.int32)
    as_bytes = np.ascontiguousarray(rows.astype("<u8")).view(np.uint8)
    return np.unpackbits(as_bytes, axis=1, bitorder="little")[:, :n].astype(np.int32)


def plateau_swap(s: Any, last: int, lower: float) -> int | None:
    """A suite of cost ``lower`` [$] that satisfies every row of the next integer program, found
    without one: ``last`` (the last proposal, which failed) with one of its sensors swapped for one
    of the same price outside it (dearest member first, cheapest outsider first); None when no
    swap satisfies them. ``lower`` is a lower bound proved on programs whose rows the next one's
    only add to (cuts, no-goods and sensors fixed out only grow), so such a suite is an optimum of
    the next program: the search proposes it and saves the program (on a plateau, many suites of
    one price ruled out one by one, each program's optimum is the last one's cost)."""
    if abs(s.cost(last) - lower) > tol(lower):
        return None
    n = s.n
    members = [i for i in s.dear_first if last >> i & 1 and not s.required >> i & 1]
    outside = [j for j in s.cheap_first if not last >> j & 1 and not s.fixed_out >> j & 1]
    swaps = [
        last & ~(1 << i) | 1 << j for i in members for j in outside if abs(s.price[i] - s.price[j]) <= tol(s.price[i])
    ]
    swaps = [m for m in swaps if m not in s.nogoods]
    if not swaps:
        return None
    x = np.array([[m >> i & 1 for i in range(n)] for m in swaps], np.int32)  # (C, n)
    ok = np.ones(len(swaps), bool)
    if s.down is not None and s.down.failing.masks:  # Σ_{i ∉ M} x_i >= α + 1
        inside = _bits(s.down.failing.as_words(), n)
        ok &= np.all(x @ (1 - inside).T >= s.alpha + 1, axis=1)
    if s.up is not None and s.up.failing.masks:  # Σ_{i ∈ m} x_i <= |m| - 1
        m_in = _bits(s.up.failing.as_words(), n)
        ok &= np.all(x @ m_in.T <= m_in.sum(axis=1) - 1, axis=1)
    for w, v in getattr(s, "orders", ()):  # x_w <= x_v
        ok &= x[:, w] <= x[:, v]
    for c in np.flatnonzero(ok):
        if s.fits(swaps[c]):
            return swaps[c]
    return None
