"""Where a greedy run keeps what it has done, and how an interrupted one is resumed
(``sensorsel greedy -o FILE --resume``, on a route or a domain; the run itself:
:func:`sensorsel.designs.greedy_run.greedy_design`).

A greedy run with a checkpoint file writes it, atomically, after each pick: the picks so far (each
:class:`~sensorsel.designs.selection.Step` as computed), a strategy's finished component runs, then the
certificate and, for a domain, each route's breakdown as they finish. ``resume=True`` reads it back
and goes on from there:

- the recorded picks are taken as recorded (suite, cost, score: not recomputed) and greedy goes on
  from that suite. Greedy is deterministic and lazy evaluation is exact (a candidate is skipped only
  when its bound proves it cannot be picked), so the picks, and every number of the result but
  two, are those of an uninterrupted run: ``seconds`` (timings) and ``n_evaluations``. The resumed
  run's lazy bounds start afresh at the first new pick (the interrupted run's bounds were not
  recorded), so it may score a few more suites; ``n_evaluations`` counts what both sessions spent
  on the recorded picks and after them;
- a finished certificate or route breakdown is read back, not recomputed.

A checkpoint written by another run (another route, landmark map, library or settings, by content:
:class:`~sensorsel.model.problem.Fingerprint`; another domain, budget, rule, engine, aggregate,
laziness or limits) is not read back: as every store (:func:`sensorsel.pipeline.store.load_matching`),
a :class:`~sensorsel.pipeline.store.CacheWarning` names the file and what differs, and the run starts
afresh, overwriting it.

The checkpoint of ``-o design.json`` is ``design.json.checkpoint`` (:func:`checkpoint_path`); the
command deletes it once the result itself is written.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Any, ClassVar

from sensorsel.designs.certify import Certificate
from sensorsel.designs.domain_design import RouteShare
from sensorsel.designs.inputs import result_fingerprint
from sensorsel.designs.selection import GreedyResult, Step
from sensorsel.information.evaluators.domain import check_aggregate
from sensorsel.information.evaluators.registry import check_engine
from sensorsel.io import results
from sensorsel.io.results import result_kind
from sensorsel.model.constraints import Constraints, recorded
from sensorsel.model.problem import Target, TargetInfo, target_differences
from sensorsel.pipeline.store import load_matching

#: Bumped when what a checkpoint holds, or how a run is resumed from it, changes.
FORMAT = 1

__all__ = ["GreedyCheckpoint", "GreedyInputs", "GreedyStore", "checkpoint_path", "remove_checkpoint"]


@result_kind("greedy-checkpoint")
@dataclass(frozen=True)
class GreedyCheckpoint:
    """Where an interrupted greedy run was (kind ``greedy-checkpoint``).

    Attributes:
        fingerprint: digest of everything the run depends on (see :func:`run_fingerprint`).
        budget_usd, rule, engine, aggregate, lazy: the run's settings (``aggregate`` is "" for a route).
        target: what it runs on (:class:`ProblemInfo` or :class:`DomainInfo`, with fingerprints).
        runs: a strategy's finished component runs, in order (a single rule: its run, once finished).
        steps: the picks of the component run under way, as computed.
        n_evaluations: suites the run under way scored to make those picks (every session's).
        certificate: the run's certificate, once computed.
        routes: the domain breakdown's routes finished so far, in route order.
        constraints: the run's limits besides the budget, with the digest of the resources and slots
            they read (None: the budget alone).
    """

    KIND: ClassVar[str] = "greedy-checkpoint"

    fingerprint: str
    budget_usd: float
    rule: str
    engine: str
    aggregate: str
    lazy: bool
    target: TargetInfo
    runs: tuple[GreedyResult, ...] = ()
    steps: tuple[Step, ...] = ()
    n_evaluations: int = 0
    certificate: Certificate | None = None
    routes: tuple[RouteShare, ...] = ()
    constraints: Constraints | None = None


def checkpoint_path(output: str | Path) -> Path:
    """The checkpoint file of the result file ``output``: ``OUTPUT.checkpoint`` beside it."""
    p = Path(output)
    return p.with_name(p.name + ".checkpoint")


def run_fingerprint(
    target: Target,
    budget: float,
    rule: str,
    engine: str,
    aggregate: str,
    lazy: bool,
    constraints: Constraints | None = None,
) -> str:
    """Digest of what a greedy run depends on: each route by content (library, route and rate,
    landmarks, graph settings), a domain's route names, weights and units, budget, rule, engine,
    aggregate, laziness and limits (with the resources and slots they read) (not file paths, not
    ``jobs``, not where it runs)."""
    return result_fingerprint(
        "greedy-checkpoint",
        FORMAT,
        target,
        budget_usd=budget,
        rule=rule,
        engine=engine,
        aggregate=aggregate,
        lazy=lazy,
        **({"constraints": constraints} if constraints is not None else {}),
    )


def _money(v: float) -> str:
    return f"${v:,.0f}" if v == round(v) else f"${v:,.2f}"


@dataclass(frozen=True)
class GreedyInputs:
    """A greedy run's own inputs besides its target, named as :class:`GreedyCheckpoint` records them.

    Attributes:
        budget_usd: the budget [$].
        rule, engine, aggregate, lazy: the run's settings (``aggregate`` as checked, for a route too).
        constraints: its limits besides the budget, with the digest of the resources and slots they
            read (None: the budget alone).
    """

    budget_usd: float
    rule: str
    engine: str
    aggregate: str
    lazy: bool
    constraints: Constraints | None = None

    def fingerprint(self, target: Target) -> str:
        """:func:`run_fingerprint` of these inputs on ``target``."""
        return run_fingerprint(
            target, self.budget_usd, self.rule, self.engine, self.aggregate, self.lazy, self.constraints
        )

    def start(self, target: Target, fingerprint: str) -> GreedyCheckpoint:
        """The checkpoint of a run of these inputs on ``target`` before its first pick."""
        return GreedyCheckpoint(fingerprint=fingerprint, target=target.info, **self._fields())

    def differences(self, ck: GreedyCheckpoint, target: Target) -> list[str]:
        """How the run that wrote ``ck`` differs from a run of these inputs on ``target``, in words
        (empty: unknown)."""
        diffs = target_differences(ck.target, target)
        for name, ours in self._fields().items():
            theirs = getattr(ck, name)
            if name == "constraints" or theirs == ours:
                continue
            shown = (_money(theirs), _money(ours)) if name == "budget_usd" else (theirs, ours)
            diffs.append(f"{_SAID.get(name, name)} {shown[0]} (this run: {shown[1]})")
        if ck.constraints != self.constraints:
            theirs_c, ours_c = recorded(ck.constraints), recorded(self.constraints)
            what = (
                f"limits {theirs_c.describe()} (this run: {ours_c.describe()})"
                if theirs_c.describe() != ours_c.describe()
                else "the library's resources or slots"
            )
            diffs.append(what)
        return diffs

    def _fields(self) -> dict[str, Any]:
        return {f.name: getattr(self, f.name) for f in fields(self)}


#: how a difference names an input where its field's name is not the word
_SAID = {"budget_usd": "budget"}


def load_checkpoint(path: Path, target: Target, inputs: GreedyInputs, fingerprint: str) -> GreedyCheckpoint | None:
    """The checkpoint at ``path`` when it was written by this very run (``inputs`` on ``target``, whose
    digest is ``fingerprint``); None when there is none, or (with a
    :class:`~sensorsel.pipeline.store.CacheWarning` naming the file and what differs) when it cannot be
    read or was written by another run."""
    return load_matching(
        GreedyCheckpoint,
        path,
        fingerprint,
        lambda ck: inputs.differences(ck, target),
        "another version of sensorsel",
    )


class GreedyStore:
    """Where a greedy run keeps what it has done: the greedy run's
    :class:`~sensorsel.designs.selection.greedy.Journal`, its certificate and its domain breakdown.
    With a ``path``, :attr:`ck` is rewritten there (atomically) at each change; without one it is
    kept in memory only (a run that cannot be resumed)."""

    def __init__(self, path: Path | None, ck: GreedyCheckpoint) -> None:
        self.path, self.ck = path, ck

    @classmethod
    def open(cls, checkpoint: str | Path | None, resume: bool, target: Target, inputs: GreedyInputs) -> GreedyStore:
        """The store of a run of ``inputs`` on ``target``: in memory without ``checkpoint`` (``inputs`` as
        given); else that file, with the engine and aggregate checked, starting from what it holds when
        ``resume`` and it was written by this very run (:func:`load_checkpoint`)."""
        if checkpoint is None:
            return cls(None, inputs.start(target, ""))
        path = Path(checkpoint)
        inputs = replace(
            inputs, engine=check_engine(inputs.engine or None), aggregate=check_aggregate(inputs.aggregate)
        )
        fp = inputs.fingerprint(target)
        ck = load_checkpoint(path, target, inputs, fp) if resume else None
        return cls(path, ck if ck is not None else inputs.start(target, fp))

    def update(self, **changes: Any) -> None:
        self.ck = replace(self.ck, **changes)
        if self.path is not None:
            results.save(self.ck, self.path)

    @property
    def runs(self) -> tuple[GreedyResult, ...]:
        return self.ck.runs

    @property
    def steps(self) -> tuple[Step, ...]:
        return self.ck.steps

    @property
    def n_evaluations(self) -> int:
        return self.ck.n_evaluations

    def record_steps(self, steps: tuple[Step, ...], n_evaluations: int) -> None:
        self.update(steps=steps, n_evaluations=n_evaluations)

    def record_runs(self, runs: tuple[GreedyResult, ...]) -> None:
        self.update(runs=runs, steps=(), n_evaluations=0)

    def record_routes(self, routes: tuple[RouteShare, ...]) -> None:
        self.update(routes=routes)


def remove_checkpoint(path: str | Path) -> None:
    """Delete a finished run's checkpoint (its result is written)."""
    Path(path).unlink(missing_ok=True)
