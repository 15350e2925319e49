"""Scoring ahead: a lazy round's idle threads or workers score what the lazy greedy will likely ask next.

A lazy greedy round on a domain (:meth:`~sensorsel.information.evaluators.domain.DomainEvaluator.scores_or_bounds`)
asks one or two candidates on the one or two routes whose bounds matter: on 2 threads or more, the
others idle (seven KITTI routes at $110,000: 41 % of the greedy's CPU in rounds of 1-2 route calls).
Scoring ahead gives each idle place (a thread, or a worker whose routes have no call in the round)
more route calls of the same base suite S: the next routes of the round's candidates, then the
routes of the next candidates of the lazy queue (what the greedy would re-score after them), in the
order the round itself would ask them (largest bounded term per unit of work first). Each answer is
f_r(S + {c}) exactly, the very bytes the route's engine gives when the round asks it later (an
engine scores each candidate on its own against the shared base: alone or in a batch, the same
bytes), so it is kept, keyed by (route, candidate), until the lazy greedy asks it at this S or S
grows.

Why the choice never depends on timing, and every run's bytes are those of one thread: what is
scored ahead depends only on the lazy state and the number of places; a kept answer is used, and
counted as an evaluation, exactly when and where the one-thread run computes it, and nothing
else reads it (not the bounds, not the mirrors), so the lazy greedy takes the same path with the
same numbers on 1 and N threads and on any number of workers; only the wall time changes. An
answer scored ahead that the greedy never asks is work lost: it is counted apart
(``n_ahead`` / ``n_ahead_used`` on the evaluator), and not in any result.

How much goes ahead: only places that the round leaves empty take calls, on routes without a call
of the round, while their predicted load stays within the round's longest (so that, by the
estimate, the round does not take longer). A route's cost per candidate is estimated as K^1.7 (K its
keyframes; measured on the KITTI routes: 03, 81 keyframes ~1 ms; 00, 455 ~20 ms). Also filling the
places that have calls of their own (after a route's own call, on its thread) scored more ahead
(274 calls against 189 on the seven KITTI routes on 2 threads, 36 and 32 of them used) and
modelled no faster (1.46-1.51x against 1.49x), the longer rounds eating the gain.

What it gives, modelled from each run's CPU trace (bench/parallel.py, seven KITTI routes at
$110,000, two runs on a loaded 2-core machine): 1.41-1.49x on 2 threads (1.45-1.48x without),
1.80-1.92x on 4 (1.71x without): a round's candidates are often bounded out after their first
route, so most calls scored ahead are never asked (32 of 189 used on 2 threads).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

#: a route call's estimated cost grows as its keyframes to this power (see the module's documentation)
COST_POWER = 1.7

#: the fewest places (threads, or workers) on which a lazy round scores ahead: on 2 threads it
#: modelled no faster (1.41-1.49x with, 1.45-1.48x without) for about 30 % more CPU, on 4 it
#: modelled 1.80-1.92x against 1.71x; below this, nothing is scored ahead
MIN_PLACES = 4


def next_routes(
    scale: np.ndarray,
    work: np.ndarray,
    stale: np.ndarray,
    known: np.ndarray | None,
    mirror: np.ndarray,
    clear: np.ndarray,
) -> list[int]:
    """The routes a candidate would be scored on next, likeliest first, as
    :meth:`DomainEvaluator.scores_or_bounds` orders them: its unknown terms largest per unit of
    work (infinite ones first, in route order), a mirror's term counted with its clear member's.

    Args:
        scale: each route's factor in F, shape (R,).
        work: each route's relative work, shape (R,).
        stale: the candidate's bounds on each route's gain [nats], shape (R,) (inf: none yet).
        known: its exact f_r(S + {c}) so far, shape (R,) (nan: not yet), or None (nothing yet).
        mirror: (R,) bool, the members whose score comes with their clear member's.
        clear: each member's clear member, shape (R,) (−1: none).
    """
    R = len(scale)
    todo = np.ones(R, dtype=bool) if known is None else np.isnan(known)
    gap = np.where(todo, scale * stale, -np.inf)
    for j in np.flatnonzero(mirror & todo).tolist():
        gap[clear[j]] += gap[j]
    gap[mirror] = -np.inf
    with np.errstate(invalid="ignore"):
        prio = np.where(np.isinf(gap) & (gap > 0), np.inf, gap / work)
    ask = todo & ~mirror
    return [k for k in np.argsort(-prio, kind="stable").tolist() if ask[k]]


def breadth_first(lists: Sequence[list[int]], candidates: Sequence[int]) -> list[tuple[int, int]]:
    """(route, candidate) pairs: every candidate's first route (in the order given), then every
    candidate's second, and so on."""
    out: list[tuple[int, int]] = []
    depth = max((len(x) for x in lists), default=0)
    for d in range(depth):
        out += [(routes[d], c) for routes, c in zip(lists, candidates) if d < len(routes)]
    return out


def fill(
    places: list[tuple[frozenset[int] | None, float]],
    home: dict[int, int],
    pairs: Sequence[tuple[int, int]],
    cost: np.ndarray,
) -> dict[int, list[int]]:
    """Route calls scored ahead: {route: candidates}.

    Args:
        places: each thread or worker's (routes it may run, None: any; its predicted load of the
            round's own calls), in a fixed order.
        home: the place of each route with a call of the round (an engine answers one call at a
            time: what is scored ahead on it joins that call, on that place).
        pairs: the (route, candidate) calls wanted, likeliest first.
        cost: each route's estimated cost per candidate, shape (R,).

    Each pair on a route without a call of the round goes to the least loaded place that may run
    it and that the round left empty, while that place's load stays within the round's largest:
    by the estimate, the round takes no longer than its own calls.
    """
    loads = [load for _, load in places]
    top = max(loads, default=0.0)
    where = dict(home)
    taken: dict[int, list[int]] = {}
    for k, c in pairs:
        if k in home:
            continue  # a route with a call of the round: scored ahead after it, its call would take longer
        allowed = (
            [where[k]]
            if k in where
            else [p for p, (routes, load) in enumerate(places) if (routes is None or k in routes) and load == 0.0]
        )
        fits = [p for p in allowed if loads[p] + float(cost[k]) <= top]
        if not fits:
            continue
        p = min(fits, key=lambda q: (loads[q], q))
        loads[p] += float(cost[k])
        where[k] = p
        taken.setdefault(k, []).append(c)
    return taken


def lpt(costs: dict[int, float], n: int) -> tuple[list[float], dict[int, int]]:
    """Loads of ``n`` threads, and each task's thread, when tasks (``costs`` by route) go, dearest
    first (ties by route), to the least loaded (as the evaluator's pool starts them)."""
    loads = [0.0] * n
    home: dict[int, int] = {}
    for k in sorted(costs, key=lambda k: (-costs[k], k)):
        i = loads.index(min(loads))
        loads[i] += costs[k]
        home[k] = i
    return loads, home
