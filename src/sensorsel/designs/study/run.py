"""Running a design study: one task per cell, stored as it finishes; its CSV."""

from __future__ import annotations

import csv
import io
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from sensorsel.designs.greedy_run import GreedyRun, greedy_design
from sensorsel.designs.inputs import result_fingerprint
from sensorsel.designs.options import RunOptions
from sensorsel.designs.parts import elapsed_s
from sensorsel.designs.resilient import ALGORITHM_2, resilient_select, worst_case
from sensorsel.designs.robust import robust_select
from sensorsel.designs.study.records import (
    FORMAT,
    Cell,
    Study,
    StudyCellRecord,
    StudyResult,
    StudyRow,
    StudyTarget,
    TargetFiles,
)
from sensorsel.information.evaluators import evaluator_for
from sensorsel.information.evaluators.domain import AGGREGATES
from sensorsel.information.evaluators.registry import check_engine
from sensorsel.io import results
from sensorsel.io.files import atomic_write_text
from sensorsel.io.progress import Progress
from sensorsel.model.problem import Target, TargetInfo
from sensorsel.pipeline import Executor, FileStore, NoStore, Plan, Store, execute

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
        g = greedy_design(target, GreedyRun(budget, cell.rule, RunOptions(lazy=study.lazy), study.certificate), ev)
        suite, score, cost = g.suite, g.score, g.cost_usd
        if g.certificate is not None:
            cert = g.certificate.percent_of_best
    elif study.method == ALGORITHM_2:
        a2 = resilient_select(ev, budget, alpha, cell.rule, lazy=study.lazy)
        w = worst_case(ev, [lib.position(i) for i in a2.suite], alpha)
        suite, score, cost, worst, worst_failures, assumed = (
            a2.suite,
            a2.score,
            a2.cost_usd,
            w.score,
            w.failures,
            a2.failed,
        )
    else:
        rb = robust_select(ev, budget, alpha, rules=(cell.rule,))
        suite, score, cost, worst, worst_failures = rb.suite, rb.nominal_score, rb.cost_usd, rb.worst_score, rb.failures
        cert = 100.0 * rb.worst_score / rb.bound if rb.bound > 0 else 100.0
    return StudyRow(
        cell=cell.index,
        library=cell.library,
        landmark_seed=cell.landmark_seed,
        failures=alpha,
        rule=cell.rule,
        budget_usd=budget,
        suite=tuple(suite),
        n_sensors=len(suite),
        cost_usd=float(cost),
        score=float(score),
        worst_score=None if worst is None else float(worst),
        worst_failures=tuple(worst_failures),
        assumed_failed=tuple(assumed),
        certificate_percent=cert,
        n_evaluations=ev.n_evaluations,
        engine=ev.name,
        seconds=elapsed_s(t0),
    )


def cell_fingerprint(study: Study, cell: Cell, target_fp: list[Any]) -> str:
    """Digest of everything a cell's row depends on (``target_fp``: :meth:`TargetFiles.fingerprints`)."""
    return result_fingerprint(
        "study-cell",
        FORMAT,
        target_fp,
        library=cell.library,
        landmark_seed=cell.landmark_seed,
        failures=cell.failures,
        rule=cell.rule,
        budget_usd=cell.budget_usd,
        method=study.method if cell.failures else "",
        engine=check_engine(study.engine),
        aggregate=study.aggregate,
        lazy=study.lazy,
        certificate=study.certificate and (cell.failures == 0 or study.method == "robust"),
    )


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
    return Plan(
        "study cell",
        cell_step,
        tuple(CellTask(c, study, jobs) for c in cells),
        states=tuple(study.targets),
        build=_build_target,
        state_of=tuple(c.target for c in cells),
    )


def run_study(
    study: Study,
    *,
    outdir: str | Path | None = None,
    resume: bool = False,
    jobs: int = 1,
    executor: Executor | None = None,
    progress: Progress | None = None,
) -> StudyResult:
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
        store = FileStore(
            [cell_file(outdir, c) for c in study.cells],
            fps,
            StudyCellRecord,
            lambda i, got: StudyCellRecord(fps[i], got[0], got[1]),
            lambda rec: (rec.row, rec.target),
            resume=resume,
            what="other inputs (target, library, seed or settings)",
        )
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
    return StudyResult(
        source=study.source,
        method=study.method,
        engine=rows[0].engine,
        aggregate=study.aggregate,
        certificate=study.certificate,
        rows=tuple(rows),
        targets=tuple(targets),
        n_reused=n_reused[0],
        seconds=elapsed_s(t0),
    )


CSV_COLUMNS = (
    "cell",
    "library",
    "landmark_seed",
    "failures",
    "rule",
    "budget_usd",
    "suite",
    "n_sensors",
    "cost_usd",
    "score",
    "worst_score",
    "worst_failures",
    "assumed_failed",
    "certificate_percent",
    "n_evaluations",
    "engine",
    "seconds",
)


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
