"""A design study's inputs and results: its target, cells, rows and result kinds."""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from typing import Any, ClassVar

from sensorsel.designs.inputs import route_entry
from sensorsel.designs.resilient import METHODS  # how a cell with failures > 0 chooses its suite
from sensorsel.io.results import result_kind
from sensorsel.model.domain import DomainError, load_domain_file, load_domain_scenarios
from sensorsel.model.library import load_library
from sensorsel.model.osm import load_geo_scenario
from sensorsel.model.problem import Fingerprint, GraphSettings, Target, TargetInfo, load_domain, load_problem
from sensorsel.model.scenario import ScenarioSpec

#: Bumped when what a cell computes, or its file, changes (invalidates resume).
FORMAT = 1
DEFAULT_LIBRARY = "default"


class StudyError(DomainError):
    """A study file is malformed: names the file, the key path and the line (as a domain file's
    errors do: the study file shares the domain file's reader)."""


# ------------------------------------------------------------------------------------------ records


@dataclass(frozen=True)
class TargetFiles:
    """One target of a study as a worker rebuilds it: a route (``spec``) or a domain file
    (``domain``), with a library (None: the default; a domain: its own)."""

    spec: ScenarioSpec | None
    domain: str | None
    library: str | None

    def build(self) -> Target:
        if self.domain is not None:
            return load_domain(self.domain, self.library)
        assert self.spec is not None
        return load_problem(self.spec, self.library)

    def fingerprints(self) -> list[Any]:
        """Each route's (name, weight, unit, content fingerprint): the target by content, read from
        its files without computing what the sensors see (cheap enough for the client)."""
        settings = GraphSettings()
        if self.domain is not None:
            spec = load_domain_file(self.domain)
            lib = load_library(self.library if self.library is not None else spec.library)
            # each member: a route, or (route, condition) pairs when the file has conditions
            members: list[Any] = []
            for d in load_domain_scenarios(spec):
                for c, share in d.conditions or ((None, 1.0),):
                    members.append(
                        route_entry(
                            f"{d.name}/{c.name}" if c is not None else d.name,
                            d.weight * share,
                            d.unit,
                            Fingerprint.of(lib, d.scenario, settings, c),
                        )
                    )
            return members
        assert self.spec is not None
        lib = load_library(self.library)
        return [
            route_entry("", 1.0, "", Fingerprint.of(lib, load_geo_scenario(self.spec), settings, self.spec.condition))
        ]


@dataclass(frozen=True)
class Cell:
    """One cell of the grid.

    Attributes:
        index: its number, in grid order (libraries, landmark seeds, failures, rules, budgets).
        library: the library as the study file names it ("default" or the path written there).
        landmark_seed: the synthetic map's seed (None: the target's own landmarks).
        failures: alpha, the sensors that may fail.
        rule: the greedy rule.
        budget_usd: the budget [$].
        target: which of :attr:`Study.targets` it runs on.
    """

    index: int
    library: str
    landmark_seed: int | None
    failures: int
    rule: str
    budget_usd: float
    target: int

    @property
    def key(self) -> str:
        """A short digest of the cell's settings: its file's name, stable when the grid grows."""
        what = [self.library, self.landmark_seed, self.failures, self.rule, self.budget_usd]
        return hashlib.sha256(json.dumps(what).encode()).hexdigest()[:16]


@dataclass(frozen=True)
class Study:
    """A validated study file: its target(s), cells and settings.

    Attributes:
        source: the study file.
        targets: one recipe per (library, landmark seed) of the grid.
        cells: the grid's cells, in order.
        engine: the scoring engine (None: the default).
        aggregate: how a domain combines its routes ("" for a route).
        method: how cells with failures > 0 choose ("algorithm-2" or "robust").
        certificate: whether alpha = 0 cells compute their certificate.
        lazy: lazy greedy evaluation (always; recorded in the fingerprint).
    """

    source: str
    targets: tuple[TargetFiles, ...]
    cells: tuple[Cell, ...]
    engine: str | None = None
    aggregate: str = ""
    method: str = METHODS[0]
    certificate: bool = True
    lazy: bool = True


@dataclass(frozen=True)
class StudyRow:
    """The result of one cell.

    Attributes:
        cell, library, landmark_seed, failures, rule, budget_usd: the cell (see :class:`Cell`).
        suite: ids of the chosen suite (failures > 0, Algorithm 2: the failing set first, in pick order).
        n_sensors: its size.
        cost_usd: its cost [$].
        score: f(S) with nothing failed [nats; a domain: its aggregate].
        worst_score: failures > 0: the score left after the worst ``failures`` sensors fail; else None.
        worst_failures: the sensors whose failure gives ``worst_score``.
        assumed_failed: Algorithm 2's failing set (the sensors it assumes fail); robust and alpha = 0: empty.
        certificate_percent: alpha = 0: "at least X% of the best possible score" (None without
            ``certificate``); robust: the worst case as a percentage of its upper bound; Algorithm 2: None.
        n_evaluations: suites the cell's evaluator scored.
        engine: the evaluator's name.
        seconds: wall time of the cell [s] (the only field that varies between runs).
    """

    cell: int
    library: str
    landmark_seed: int | None
    failures: int
    rule: str
    budget_usd: float
    suite: tuple[str, ...]
    n_sensors: int
    cost_usd: float
    score: float
    worst_score: float | None
    worst_failures: tuple[str, ...]
    assumed_failed: tuple[str, ...]
    certificate_percent: float | None
    n_evaluations: int
    engine: str
    seconds: float = 0.0


@result_kind("study-cell")
@dataclass(frozen=True)
class StudyCellRecord:
    """A finished cell as written to ``OUTDIR/cells/cell-KEY.json`` (read back by ``resume``)."""

    KIND: ClassVar[str] = "study-cell"

    fingerprint: str
    row: StudyRow
    target: TargetInfo


@dataclass(frozen=True)
class StudyTarget:
    """What one target of a study is (recorded in the result).

    Attributes:
        library: the library as the study names it.
        landmark_seed: the synthetic map's seed (None: the target's own landmarks).
        problem: the target's info (route or domain, with content fingerprints).
    """

    library: str
    landmark_seed: int | None
    problem: TargetInfo


@result_kind("study")
@dataclass(frozen=True)
class StudyResult:
    """A design study's table.

    Attributes:
        source: the study file.
        method, engine, aggregate, certificate: the study's settings.
        targets: what each (library, landmark seed) was, in grid order (as the cells that ran on it record).
        rows: one per cell, in cell order.
        n_reused: cells read back from an earlier run (``resume``).
        seconds: wall time of the study [s].
    """

    KIND: ClassVar[str] = "study"

    source: str
    method: str
    engine: str
    aggregate: str
    certificate: bool
    rows: tuple[StudyRow, ...]
    targets: tuple[StudyTarget, ...] = ()
    n_reused: int = 0
    seconds: float = 0.0
