"""A design study: one target, a grid of settings, one run per cell (``sensorsel study FILE.yaml -o DIR``).

A study file is YAML (read safely, a key repeated in one mapping refused; every error names the
file, the key path and the line, like an operating-domain file)::

    target:                        # what every cell runs on: one route ...
      fixture: tiny                #   fixture, seq (+ kitti_root) or route (+ format, times), as a domain's route
      landmarks: synthetic         #   real, synthetic, {synthetic: {seed: N}} or a landmark CSV
      rate: 1.0                    #   keyframes per second (default 1)
      clearance_m: 3.0             #   optional: drop landmarks closer than this to the route
      # domain: domain.yaml        # ... or an operating domain (instead of the keys above),
      # aggregate: normalised      #     its routes combined as `--aggregate` does (normalised or raw)
    grid:                          # the cells: every combination, one run each
      budgets: [5000, "$12,000"]   # required; dollars (a number, or text such as "$110,000")
      rules: [uniform, best-of]    # greedy rules (default [uniform])
      failures: [0, 1]             # sensors that may fail, alpha (default [0])
      landmark_seeds: [0, 1]       # seeds of the synthetic map (needs target.landmarks: synthetic)
      libraries: [default, reduced_library.yaml]   # sensor libraries; default: Table I (a domain: its own)
    engine: fast                   # optional: the scoring engine
    method: algorithm-2            # how a cell with failures > 0 chooses: algorithm-2 or robust
    certificate: true              # alpha = 0 cells: the certificate's "at least X% of the best" (default true)

Relative paths are relative to the study file's folder.

**A cell** is one (library, landmark seed, failures, rule, budget); cells are numbered in that
order, the budget varying fastest. A cell with 0 failures is a greedy run (and its certificate:
at most one sweep of the library per pick). A cell with alpha > 0 failures runs, by default, the
paper's Algorithm 2 with the cell's rule (:func:`sensorsel.designs.resilient.resilient_select`: the alpha
sensors with the best single scores assumed to fail, the rest of the budget spent greedily), and
scores the suite's exact worst case; Algorithm 2 is chosen as the default because it is a fixed,
bounded amount of work per cell (two greedy runs and C(|S|, alpha) evaluations), so a grid's cost
is predictable. ``method: robust`` runs :func:`sensorsel.designs.robust.robust_select` instead (greedy with
the cell's rule, Algorithm 2 and further methods, the best exact worst case kept, with an upper
bound: its row's certificate is the worst case as a percentage of that bound), at a cost that
depends on the bound's search.

**Results**: one :class:`StudyRow` per cell (settings, suite, cost, score, worst case, certificate,
evaluations, seconds), in cell order, whatever order the cells finished in. :func:`run_study` runs
the cells as a plan (:func:`cell_plan`) through an executor (:mod:`sensorsel.pipeline`: in this
process, or one Dask task per cell); the rows are the same bytes (timings aside). With ``outdir``, each
finished cell is written to ``OUTDIR/cells/cell-KEY.json`` as it finishes (atomically; KEY a digest
of the cell's settings), with a fingerprint of everything the cell depends on (the target by
content, library, seed, budget, rule, failures, method, engine, aggregate, laziness, certificate);
``resume`` reads back the cells whose fingerprint matches instead of running them again.
"""

from __future__ import annotations

import csv
import hashlib
import io
import itertools
import json
import math
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Callable, ClassVar, NoReturn, Sequence

from sensorsel.designs.certify import certificate
from sensorsel.errors import SensorselError
from sensorsel.information.evaluators import ENGINES, evaluator_for
from sensorsel.information.evaluators.domain import AGGREGATES
from sensorsel.information.evaluators.registry import check_engine
from sensorsel.io import results
from sensorsel.io.files import atomic_write_text
from sensorsel.io.progress import Progress
from sensorsel.io.results import result_kind
from sensorsel.model.domain import (ROUTE_KEYS, SYNTHETIC, Checker, DomainError, Map, Seq, load_domain_file,
                                    load_domain_scenarios, parse_route)
from sensorsel.model.domain import read_yaml as _read_domain_yaml
from sensorsel.model.library import load_library
from sensorsel.model.problem import Fingerprint, GraphSettings, Target, TargetInfo, load_domain, load_problem
from sensorsel.pipeline import Executor, FileStore, NoStore, Plan, Store, digest, execute
from sensorsel.designs.resilient import ALGORITHM_2, METHODS, method_name, resilient_select, worst_case  # METHODS: how a cell with failures chooses
from sensorsel.designs.robust import robust_select
from sensorsel.designs.selection import RULES, check_affordable, greedy
from sensorsel.model.scenario import ScenarioSpec, load_scenario

#: Bumped when what a cell computes, or its file, changes (invalidates resume).
FORMAT = 1
DEFAULT_LIBRARY = "default"

_TOP_KEYS = ("target", "grid", "engine", "method", "certificate")
_TARGET_KEYS = ("fixture", "seq", "kitti_root", "route", "format", "times", "landmarks", "rate", "clearance_m", "name",
                "domain", "aggregate")
_GRID_KEYS = ("budgets", "rules", "failures", "landmark_seeds", "libraries")


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
                    members.append([f"{d.name}/{c.name}" if c is not None else d.name, d.weight * share, d.unit,
                                    results.to_jsonable(Fingerprint.of(lib, d.scenario, settings, c))])
            return members
        assert self.spec is not None
        lib = load_library(self.library)
        return [["", 1.0, "", results.to_jsonable(Fingerprint.of(lib, load_scenario(self.spec), settings))]]


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


# ------------------------------------------------------------------------------------------ parsing


class _StudyChecker(Checker):
    def fail(self, key: str, message: str, line: int | None) -> NoReturn:
        raise StudyError(self.path, key, message, line)


def _read_yaml(path: Path) -> Any:
    return _read_domain_yaml(path, StudyError, "study file")


def _list(c: _StudyChecker, m: Map, key: str, default: list[Any] | None) -> tuple[list[Any], list[int]]:
    """The list under ``grid.key`` and each item's line (``default`` when absent; required when None)."""
    if key not in m:
        if default is None:
            c.fail(f"grid.{key}", "missing: expected a non-empty list", m.line)
        return list(default), [m.line] * len(default)
    v = m[key]
    if not isinstance(v, Seq) or not v:
        c.fail(f"grid.{key}", f"expected a non-empty list, e.g. [a, b], got {v!r}", m.lines[key])
    return list(v), list(v.lines)


def _budget(c: _StudyChecker, value: Any, key: str, line: int) -> float:
    if isinstance(value, str):
        text = value.strip().replace("$", "").replace(",", "").replace("_", "")
        try:
            value = float(text)
        except ValueError:
            c.fail(key, f"expected a number of dollars (5000, \"$110,000\"), got {value!r}", line)
    return c.number(value, key, line, strict=False)


def _unique(c: _StudyChecker, items: list[Any], lines: list[int], key: str) -> None:
    seen: dict[Any, int] = {}
    for i, (v, ln) in enumerate(zip(items, lines)):
        if v in seen:
            c.fail(f"grid.{key}[{i}]", f"{v!r} repeated (also grid.{key}[{seen[v]}]): every cell would run twice", ln)
        seen[v] = i


def parse_study(data: Any, path: str | Path = "<memory>") -> Study:
    """Validate a parsed study document (as :func:`load_study` reads it) and resolve its paths.

    Raises:
        StudyError: naming ``path``, the key path and the line of the first problem found.
    """
    path = Path(path)
    c = _StudyChecker(path)
    if not isinstance(data, Map):
        c.fail("", f"expected a mapping with target and grid, got {type(data).__name__}", getattr(data, "line", None))
    c.keys(data, "", _TOP_KEYS)
    for k in ("target", "grid"):
        if k not in data:
            c.fail(k, "missing", data.line)
    engine = data.get("engine")
    if "engine" in data and engine not in ENGINES:
        c.fail("engine", f"unknown engine {engine!r}; available: {', '.join(sorted(ENGINES))}", data.lines["engine"])
    method = data.get("method", METHODS[0])
    method = method_name(method) if isinstance(method, str) else method  # "paper": Algorithm 2's name before
    if method not in METHODS:
        c.fail("method", f"expected one of {', '.join(METHODS)}, got {method!r}", data.lines["method"])
    cert = data.get("certificate", True)
    if not isinstance(cert, bool):
        c.fail("certificate", f"expected true or false, got {cert!r}", data.lines["certificate"])
    spec, domain, aggregate, fixed_seed = _parse_target(c, data["target"], data.lines["target"])

    grid = data["grid"]
    if not isinstance(grid, Map):
        c.fail("grid", f"expected a mapping (budgets, rules, failures, landmark_seeds, libraries), got {grid!r}",
               data.lines["grid"])
    c.keys(grid, "grid", _GRID_KEYS)
    raw_budgets, b_lines = _list(c, grid, "budgets", None)
    budgets = [_budget(c, v, f"grid.budgets[{i}]", ln) for i, (v, ln) in enumerate(zip(raw_budgets, b_lines))]
    _unique(c, budgets, b_lines, "budgets")
    rules, r_lines = _list(c, grid, "rules", ["uniform"])
    for i, (r, ln) in enumerate(zip(rules, r_lines)):
        if r not in RULES:
            c.fail(f"grid.rules[{i}]", f"unknown rule {r!r}; available: {', '.join(RULES)}", ln)
    _unique(c, rules, r_lines, "rules")
    failures, f_lines = _list(c, grid, "failures", [0])
    for i, (a, ln) in enumerate(zip(failures, f_lines)):
        if isinstance(a, bool) or not isinstance(a, int) or a < 0:
            c.fail(f"grid.failures[{i}]", f"expected an integer >= 0 (sensors that may fail), got {a!r}", ln)
    _unique(c, failures, f_lines, "failures")
    seeds: list[int | None] = [None]
    s_lines = [grid.line]
    if "landmark_seeds" in grid:
        line = grid.lines["landmark_seeds"]
        if domain is not None:
            c.fail("grid.landmark_seeds", "a domain's routes name their own landmarks (its file): seeds go with one route", line)
        if spec is None or spec.landmarks != SYNTHETIC:
            c.fail("grid.landmark_seeds", "seeds choose synthetic maps: give target.landmarks: synthetic", line)
        if fixed_seed:
            c.fail("grid.landmark_seeds", "target.landmarks fixes its seed ({synthetic: {seed: N}}): give the seeds "
                   "in one place (target.landmarks: synthetic)", line)
        raw_seeds, s_lines = _list(c, grid, "landmark_seeds", None)
        for i, (s, ln) in enumerate(zip(raw_seeds, s_lines)):
            if isinstance(s, bool) or not isinstance(s, int) or s < 0:
                c.fail(f"grid.landmark_seeds[{i}]", f"expected an integer >= 0, got {s!r}", ln)
        _unique(c, raw_seeds, s_lines, "landmark_seeds")
        seeds = list(raw_seeds)
    libs, l_lines = _list(c, grid, "libraries", [DEFAULT_LIBRARY])
    lib_paths: list[str | None] = []
    for i, (lib, ln) in enumerate(zip(libs, l_lines)):
        key = f"grid.libraries[{i}]"
        lib_paths.append(None if lib == DEFAULT_LIBRARY else c.file(lib, key, ln))
        libs[i] = c.string(lib, key, ln)
    _unique(c, libs, l_lines, "libraries")

    targets: list[TargetFiles] = []
    cells: list[Cell] = []
    for (lib, lib_path), seed in itertools.product(zip(libs, lib_paths), seeds):
        t = len(targets)
        targets.append(TargetFiles(replace(spec, landmark_seed=seed) if spec is not None and seed is not None else spec,
                                    domain, lib_path))
        for alpha, rule, budget in itertools.product(failures, rules, budgets):
            cells.append(Cell(len(cells), lib, seed, alpha, rule, budget, t))
    _check_budgets(c, cells, targets, budgets, b_lines, failures, f_lines)
    return Study(str(path), tuple(targets), tuple(cells), engine, aggregate, method, cert)


def _parse_target(c: _StudyChecker, raw: Any, line: int) -> tuple[ScenarioSpec | None, str | None, str, bool]:
    """(route spec or None, domain file or None, aggregate, whether the landmarks fix a seed)."""
    if not isinstance(raw, Map):
        c.fail("target", f"expected a mapping (fixture, seq or route, landmarks, rate; or domain), got {raw!r}", line)
    c.keys(raw, "target", _TARGET_KEYS)
    ln = lambda k: raw.lines.get(k, raw.line)  # noqa: E731
    if "domain" in raw:
        other = [k for k in raw if k not in ("domain", "aggregate")]
        if other:
            c.fail(f"target.{other[0]}", "a domain file lists its own routes, landmarks and rate: give domain alone "
                   "(with aggregate)", ln(other[0]))
        agg = raw.get("aggregate", AGGREGATES[0])
        if agg not in AGGREGATES:
            c.fail("target.aggregate", f"expected one of {', '.join(AGGREGATES)}, got {agg!r}", ln("aggregate"))
        return None, c.file(raw["domain"], "target.domain", ln("domain")), agg, False
    if "aggregate" in raw:
        c.fail("target.aggregate", "combines a domain's routes: it goes with target.domain", ln("aggregate"))
    rate = c.number(raw["rate"], "target.rate", ln("rate")) if "rate" in raw else 1.0
    clearance = c.number(raw["clearance_m"], "target.clearance_m", ln("clearance_m"), strict=False) if "clearance_m" in raw else None
    name = c.string(raw["name"], "target.name", ln("name")) if "name" in raw else None
    route = Map({k: v for k, v in raw.items() if k in ROUTE_KEYS})
    route.line, route.lines = raw.line, raw.lines
    route["name"] = name or "target"
    r = parse_route(c, route, "target", line, ScenarioSpec(keyframe_rate_hz=rate, clearance_m=clearance), None, "hours")
    landmarks = raw.get("landmarks")
    return replace(r.spec, name=name), None, "", isinstance(landmarks, Map)


def _check_budgets(c: _StudyChecker, cells: list[Cell], targets: list[TargetFiles], budgets: list[float],
                   b_lines: list[int], failures: list[int], f_lines: list[int]) -> None:
    """Every budget must buy a sensor (more than alpha of them) from every library of the grid, as
    a command's --budget must (:func:`sensorsel.designs.selection.check_affordable`)."""
    seen: set[tuple[str, int, float]] = set()
    for cell in cells:
        lib_path = targets[cell.target].library
        if (cell.library, cell.failures, cell.budget_usd) in seen:
            continue
        seen.add((cell.library, cell.failures, cell.budget_usd))
        if targets[cell.target].domain is not None and lib_path is None:
            lib_path = load_domain_file(targets[cell.target].domain or "").library
        lib = load_library(lib_path)
        i, j = budgets.index(cell.budget_usd), failures.index(cell.failures)
        try:
            check_affordable(lib, cell.budget_usd, cell.failures, budget_option="budget", alpha_option="failures")
        except SensorselError as exc:
            where = f" (library {cell.library})" if cell.library != DEFAULT_LIBRARY else ""
            if str(exc).startswith("failures"):
                c.fail(f"grid.failures[{j}]", f"{exc}{where}", f_lines[j])
            c.fail(f"grid.budgets[{i}]", f"{exc}{where}", b_lines[i])


def load_study(path: str | Path) -> Study:
    """Read and validate a study YAML file (see the module's documentation).

    Raises:
        StudyError: missing file, malformed YAML, an unknown key, a wrong type or value, a missing
            file it names, a budget that buys nothing (each naming the file, the key path and the line).
    """
    path = Path(path)
    return parse_study(_read_yaml(path), path)


# ------------------------------------------------------------------------------------------ running


def run_cell(target: Target, cell: Cell, study: Study, *, jobs: int = 1) -> StudyRow:
    """One cell on its target: greedy (alpha = 0, with its certificate), else Algorithm 2 or robust
    selection with the exact worst case. A fresh evaluator per cell: its count is the cell's own."""
    t0 = time.perf_counter()
    ev = evaluator_for(target, study.engine, jobs=jobs, aggregate=study.aggregate or AGGREGATES[0])
    lib = target.library
    cost: float
    alpha, budget = cell.failures, cell.budget_usd
    worst: float | None = None
    worst_failures: tuple[str, ...] = ()
    assumed: tuple[str, ...] = ()
    cert: float | None = None
    if alpha == 0:
        g = greedy(ev, budget, cell.rule, lazy=study.lazy)
        suite, score, cost = g.suite, g.score, g.cost_usd
        if study.certificate:
            cert = certificate(ev, g).percent_of_best
    elif study.method == ALGORITHM_2:
        a2 = resilient_select(ev, budget, alpha, cell.rule, lazy=study.lazy)
        w = worst_case(ev, [lib.position(i) for i in a2.suite], alpha)
        suite, score, cost, worst, worst_failures, assumed = a2.suite, a2.score, a2.cost_usd, w.score, w.failures, a2.failed
    else:
        rb = robust_select(ev, budget, alpha, rules=(cell.rule,))
        suite, score, cost, worst, worst_failures = rb.suite, rb.nominal_score, rb.cost_usd, rb.worst_score, rb.failures
        cert = 100.0 * rb.worst_score / rb.bound if rb.bound > 0 else 100.0
    return StudyRow(cell=cell.index, library=cell.library, landmark_seed=cell.landmark_seed, failures=alpha, rule=cell.rule,
                    budget_usd=budget, suite=tuple(suite), n_sensors=len(suite), cost_usd=float(cost),
                    score=float(score), worst_score=None if worst is None else float(worst), worst_failures=tuple(worst_failures),
                    assumed_failed=tuple(assumed), certificate_percent=cert, n_evaluations=ev.n_evaluations, engine=ev.name,
                    seconds=round(time.perf_counter() - t0, 6))


def cell_fingerprint(study: Study, cell: Cell, target_fp: list[Any]) -> str:
    """Digest of everything a cell's row depends on (``target_fp``: :meth:`TargetFiles.fingerprints`)."""
    what = {"format": FORMAT, "what": "study-cell", "target": target_fp, "library": cell.library,
            "landmark_seed": cell.landmark_seed, "failures": cell.failures, "rule": cell.rule, "budget_usd": cell.budget_usd,
            "method": study.method if cell.failures else "", "engine": check_engine(study.engine), "aggregate": study.aggregate,
            "lazy": study.lazy, "certificate": study.certificate and (cell.failures == 0 or study.method == "robust")}
    return digest(what)


def cell_file(outdir: str | Path, cell: Cell) -> Path:
    return Path(outdir) / "cells" / f"cell-{cell.key}.json"


@dataclass(frozen=True)
class CellTask:
    """One cell of a study (a plan's task): the cell and the study's settings."""

    cell: Cell
    study: Study
    jobs: int = 1


def cell_step(target: Target, task: CellTask) -> tuple[StudyRow, TargetInfo]:
    """One cell on its target: (its row, what its target is)."""
    return run_cell(target, task.cell, task.study, jobs=task.jobs), target.info


def _build_target(recipe: TargetFiles) -> Target:
    """A study's target (a route or a domain), built where its cells run, once for all of them."""
    return recipe.build()


def cell_plan(study: Study, cells: Sequence[Cell], jobs: int = 1) -> Plan[tuple[StudyRow, TargetInfo]]:
    """``cells`` of ``study`` as a plan: one task per cell, on its target (built once per target)."""
    return Plan("study cell", cell_step, tuple(CellTask(c, study, jobs) for c in cells), states=tuple(study.targets),
                build=_build_target, state_of=tuple(c.target for c in cells))


def run_study(study: Study, *, outdir: str | Path | None = None, resume: bool = False, jobs: int = 1,
              executor: Executor | None = None, progress: Progress | None = None) -> StudyResult:
    """Run every cell of ``study`` (in this process, or through ``executor``: :mod:`sensorsel.pipeline`)
    and gather the rows in cell order. ``outdir``: each finished cell is written to ``OUTDIR/cells/``
    as it finishes; ``resume``: cells whose file there matches are read back, not run (see the module
    documentation). ``progress(done, total)`` after each cell. ``jobs``: threads of each cell's engine."""
    t0 = time.perf_counter()
    plan = cell_plan(study, study.cells, jobs)
    store: Store[tuple[StudyRow, TargetInfo]] = NoStore()
    if outdir is not None:
        target_fps = [t.fingerprints() for t in study.targets]
        fps = [cell_fingerprint(study, c, target_fps[c.target]) for c in study.cells]
        store = FileStore([cell_file(outdir, c) for c in study.cells], fps, StudyCellRecord,
                          lambda i, got: StudyCellRecord(fps[i], got[0], got[1]), lambda rec: (rec.row, rec.target),
                          resume=resume, what="other inputs (target, library, seed or settings)")
    n_reused = [0]

    def count(i: int, got: tuple[StudyRow, TargetInfo], reused: bool) -> None:
        n_reused[0] += reused

    got = execute(plan, executor, store, progress, on_result=count)
    rows = [row for row, _ in got]
    infos: dict[int, TargetInfo] = {}
    for c, (_, info) in zip(study.cells, got):
        infos.setdefault(c.target, info)
    targets = []
    for t in range(len(study.targets)):
        c = next(c for c in study.cells if c.target == t)
        targets.append(StudyTarget(c.library, c.landmark_seed, infos[t]))
    return StudyResult(source=study.source, method=study.method, engine=rows[0].engine,
                       aggregate=study.aggregate, certificate=study.certificate,
                       rows=tuple(rows), targets=tuple(targets), n_reused=n_reused[0],
                       seconds=round(time.perf_counter() - t0, 6))


CSV_COLUMNS = ("cell", "library", "landmark_seed", "failures", "rule", "budget_usd", "suite", "n_sensors", "cost_usd",
               "score", "worst_score", "worst_failures", "assumed_failed", "certificate_percent", "n_evaluations", "engine",
               "seconds")


def _csv_value(v: Any) -> str:
    if v is None:
        return ""
    if isinstance(v, tuple):
        return " ".join(v)
    if isinstance(v, float):
        return repr(v) if math.isfinite(v) else str(v)
    return str(v)


def study_csv(res: StudyResult) -> str:
    """The table as CSV, one row per cell (floats as ``repr``: exact; suites as space-separated ids)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(CSV_COLUMNS)
    for r in res.rows:
        w.writerow([_csv_value(getattr(r, k)) for k in CSV_COLUMNS])
    return buf.getvalue()


def write_study(res: StudyResult, outdir: str | Path) -> list[Path]:
    """Write ``study.json`` and ``study.csv`` into ``outdir`` (atomically); returns their paths."""
    out = Path(outdir)
    return [results.save(res, out / "study.json"), atomic_write_text(out / "study.csv", study_csv(res))]
