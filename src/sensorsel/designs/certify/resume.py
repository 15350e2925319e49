"""Resuming ``sensorsel optimal``: the branch and bound's state kept in a checkpoint file as it runs.

What a killed search would lose is kept in ``FILE.checkpoint`` (``optimal -o FILE``): the greedy
start (the incumbent, its label and the greedy runs' certificate bound: on the full library the
certificates alone take a while), then every :data:`CHECKPOINT_EVERY` expanded nodes the whole
search state (open nodes, best suite, counts). The search is deterministic for a deterministic
evaluator, so going on from node k gives what the uninterrupted run gives from node k on: the same
answer, the same counts (``n_evaluations`` aside: suites scored before the checkpoint are not
scored again). A checkpoint is read back only when its fingerprint (the target by content, engine,
budget, rule or given incumbent, excluded sensors, limits, knapsack resolution) matches; else a
:class:`~sensorsel.pipeline.store.CacheWarning` names it and the search starts again. The node
limit is not in the fingerprint: a resume with a larger ``--max-nodes`` goes on where it stopped.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from sensorsel.designs.inputs import result_fingerprint
from sensorsel.designs.selection import GreedyResult
from sensorsel.io import results
from sensorsel.io.results import result_kind
from sensorsel.model.problem import TargetInfo
from sensorsel.pipeline.store import load_matching

#: expanded nodes between two checkpoints of the search state
CHECKPOINT_EVERY = 500
#: bumped when what the search computes, or the checkpoint, changes
FORMAT = 1


@dataclass(frozen=True)
class OpenNode:
    """An open node of the search: -bound, tie counter, suite S (pick order), f(S) [nats], Cost(S)
    [cost units], the candidates R (positions), what S uses of each row of the feasible set."""

    neg_bound: float
    counter: int
    suite: tuple[int, ...]
    score: float
    cost_units: int
    rest: tuple[int, ...]
    used: tuple[float, ...]


@result_kind("optimal-checkpoint")
@dataclass(frozen=True)
class OptimalCheckpoint:
    """The state of an interrupted ``optimal`` run (see the module docstring).

    Attributes:
        fingerprint: digest of every input of the search.
        incumbent, rule_label, cert_bound: the greedy start (the first incumbent, its label, the
            greedy runs' certificate bound [nats]).
        n_start_evaluations: suites the start scored.
        nodes, pruned, solved, counter: the search's counts and tie counter.
        methods: the knapsack methods used so far.
        best_suite, best_score, best_cost: the best suite found (sorted positions), f [nats], cost [$].
        heap: the open nodes, in heap order; None: the search has not started (the root is next).
        n_evaluations: suites scored so far (start included).
    """

    fingerprint: str
    incumbent: GreedyResult
    rule_label: str
    cert_bound: float
    n_start_evaluations: int
    nodes: int = 0
    pruned: int = 0
    solved: int = 0
    counter: int = 0
    methods: tuple[str, ...] = ()
    best_suite: tuple[int, ...] = ()
    best_score: float = 0.0
    best_cost: float = 0.0
    heap: tuple[OpenNode, ...] | None = None
    n_evaluations: int = 0


def search_fingerprint(
    info: TargetInfo | None,
    engine: str,
    budget: float,
    rule: str,
    incumbent: GreedyResult | None,
    exclude: frozenset[int],
    constraints: Any,
    max_cells: int,
) -> str:
    """Digest of what the search's answer depends on (not the node or time limit)."""
    return result_fingerprint(
        "optimal",
        FORMAT,
        info,
        engine=engine,
        budget=budget,
        rule=rule,
        incumbent=incumbent,
        exclude=sorted(exclude),
        constraints=constraints,
        max_cells=max_cells,
    )


def read_checkpoint(path: Path | None, fingerprint: str, resume: bool) -> OptimalCheckpoint | None:
    """The checkpoint at ``path`` to go on from (None: none, not resuming, or another run's: warned)."""
    if path is None or not resume:
        return None
    return load_matching(
        OptimalCheckpoint,
        Path(path),
        fingerprint,
        what="other inputs (target, engine, budget, rule, excluded sensors or limits)",
    )


def save_checkpoint(path: Path, ck: OptimalCheckpoint) -> None:
    """Write the checkpoint atomically (a kill mid-write leaves the previous one)."""
    results.save(ck, path)


def open_nodes(heap: list[Any]) -> tuple[OpenNode, ...]:
    """The search's heap as records (same order: still a heap when read back)."""
    return tuple(
        OpenNode(
            float(h[0]),
            int(h[1]),
            tuple(h[2]),
            float(h[3]),
            int(h[4]),
            tuple(h[5]),
            tuple(float(x) for x in np.asarray(h[6]).ravel()),
        )
        for h in heap
    )


def heap_of(nodes: tuple[OpenNode, ...]) -> list[Any]:
    """The records back as the search's heap entries."""
    return [
        (n.neg_bound, n.counter, tuple(n.suite), n.score, n.cost_units, tuple(n.rest), np.array(n.used, dtype=float))
        for n in nodes
    ]
