"""The integer programs of the requirement solver (scipy's ``milp``, HiGHS): the cheapest suite
that satisfies the feasible set's rows, every cut and no-good found so far (:mod:`.solver`)."""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from sensorsel.designs.requirements.oracle import mask_of as _mask
from sensorsel.designs.requirements.oracle import suite_of as _suite
from sensorsel.io.files import quiet_stdout

__all__ = ["MILP_NODE_LIMIT", "floor_cost", "propose", "tol"]

#: HiGHS's branch-and-bound node limit per integer program (deterministic, unlike a time limit)
MILP_NODE_LIMIT = 100_000
#: two costs closer than this [$] (plus a relative 1e-9) are equal: a tenth of a cent, above the
#: slack of HiGHS's dual bound (its rows hold to feasibility tolerances, so an optimum's dual bound can
#: sit below the optimal cost: 1.7e-5 under a $3,279 suite in a case of tests/test_require_solver.py,
#: where a tolerance of 1e-6 left the lower bound short of the cost and the loop proposing the same
#: suite to its iteration limit) and below any difference of two costs of whole cents
_COST_TOL = 1e-3
#: slack on a packing row relative to its limit, as the feasible set's (constraints.REL_SLACK)
_ROW_SLACK = 1e-9


def tol(cost: float) -> float:
    """How close two costs [$] must be to count as equal."""
    return _COST_TOL + 1e-9 * abs(cost) if math.isfinite(cost) else 0.0


def propose(
    s: Any, time_left: float | None, programs: list[float], *, cap: float | None = None, exclude: Sequence[int] = ()
) -> tuple[float, int | None, bool] | None:
    """min cost(x) over the feasible set's rows, every cut and no-good, the sensors fixed out at 0
    (and with ``cap`` the cost at most ``cap``, the suites ``exclude`` excluded): (lower bound [$],
    the optimal suite or None, whether HiGHS proved it optimal), or None when no suite satisfies
    them all. Its time is added to ``programs[0]``."""
    from scipy.optimize import Bounds, LinearConstraint, milp

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
    if time_left is not None:
        options["time_limit"] = max(time_left, 1e-3)
    t = time.perf_counter()
    with quiet_stdout():
        res = milp(s.price, integrality=np.ones(n), bounds=Bounds(lb, ub), constraints=rows, options=options)
    programs[0] += time.perf_counter() - t
    if res.status == 2:
        return None
    proposal = _mask(int(i) for i in np.flatnonzero(res.x > 0.5)) if res.x is not None else None
    dual = getattr(res, "mip_dual_bound", None)
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
    from scipy.optimize import Bounds, LinearConstraint, milp

    n = s.n
    cuts = s.down.failing.masks
    if n == 0 or not cuts:
        return 0.0, 0
    ub = np.zeros(n)
    ub[s.allowed] = 1.0
    ub[list(_suite(s.fixed_out | without))] = 0.0
    out = np.array([[0.0 if f >> i & 1 else 1.0 for i in range(n)] for f in cuts])
    t = time.perf_counter()
    with quiet_stdout():
        res = milp(
            s.price,
            integrality=np.ones(n),
            bounds=Bounds(np.zeros(n), ub),
            constraints=[LinearConstraint(out, 1.0, np.inf)],
            options={"node_limit": MILP_NODE_LIMIT, "mip_rel_gap": 0.0, "presolve": True, "disp": False},
        )
    programs[0] += time.perf_counter() - t
    if res.status == 2:
        return math.inf, None
    dual = getattr(res, "mip_dual_bound", None)
    if res.status == 0 and res.fun is not None and res.x is not None:
        bound = float(res.fun) if dual is None or not math.isfinite(dual) else min(float(res.fun), float(dual))
        return bound, _mask(int(i) for i in np.flatnonzero(res.x > 0.5))
    return (float(dual) if dual is not None and math.isfinite(dual) else 0.0), None
