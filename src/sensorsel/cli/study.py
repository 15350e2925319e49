"""``sensorsel study``: a design study over a grid of settings, one run per cell (in-process or as Dask tasks)."""

from __future__ import annotations

from typing import Any

import click

from sensorsel.cli.common import compact_suite, table
from sensorsel.cli.options import (
    cluster_from,
    cluster_options,
    jobs_option,
    output_option,
    progress_bar,
    result_options,
    resume_option,
    running,
)
from sensorsel.cli.vocabulary import Command
from sensorsel.io import results
from sensorsel.io.files import output_dir


def _num(v: float | None, fmt: str = "{:,.3f}") -> str:
    return "-" if v is None else fmt.format(v)


@click.command(
    "study",
    cls=Command,
    short_help="A design study: a grid of budgets, rules, failures, maps and libraries, one run per cell.",
)
@click.argument("study_file", metavar="FILE.yaml", type=click.Path(dir_okay=False, path_type=str))
@output_option(
    folder=True, required=True, help="Folder for study.csv, study.json and cells/ (each cell written as it finishes)."
)
@resume_option
@cluster_options
@jobs_option(
    "Threads scoring candidate suites in each in-process cell (results do not depend on it; on a "
    "cluster every task uses one).",
    default=1,
)
@result_options
def study_cmd(study_file: str, outdir: str, resume: bool, jobs: int, as_json: bool, quiet: bool, **kw: Any) -> None:
    """Run a design study: every combination of the grid in FILE.yaml (budgets x rules x failures x
    landmark seeds x libraries) on its target (a route or an operating domain), one run per cell.

    A cell with no failure is a greedy run with its certificate; a cell with failures runs the
    paper's Algorithm 2 (or robust selection, `method: robust`) and scores the exact worst case.
    Writes OUTPUT/study.csv and study.json (one row per cell, in grid order) and each cell to
    OUTPUT/cells/ as it finishes, so --resume skips finished cells. With --scheduler/--workers each
    cell is one Dask task; the rows are the same (timings aside). See configs/study_example.yaml.
    """
    from sensorsel.api import load_study, run_study, write_study

    output_dir(outdir)
    cluster = cluster_from(kw)
    study = load_study(study_file)
    bar, progress = progress_bar(quiet or as_json, "study cells")
    with running(cluster, bar):  # with a cluster, each cell is one task there
        res = run_study(
            study,
            outdir=outdir,
            resume=resume,
            jobs=jobs,
            progress=progress,
            executor=cluster.executor if cluster is not None else None,
        )
    written = write_study(res, outdir)
    if as_json:
        click.echo(results.dumps(res), nl=False)
        return
    click.echo(
        f"study      {res.source}: {len(res.rows)} cells on {len(res.targets)} target(s), engine {res.engine}"
        + (f", failures by {res.method}" if any(r.failures for r in res.rows) else "")
    )
    if res.n_reused:
        click.echo(f"resumed    {res.n_reused} cells read back from {outdir}/cells")
    rows = [
        [
            str(r.cell),
            r.library,
            "-" if r.landmark_seed is None else str(r.landmark_seed),
            str(r.failures),
            r.rule,
            f"{r.budget_usd:,.0f}",
            compact_suite(r.suite),
            f"{r.cost_usd:,.0f}",
            _num(r.score),
            _num(r.worst_score),
            _num(r.certificate_percent, "{:.1f}%"),
            f"{r.seconds:.2f}",
        ]
        for r in res.rows
    ]
    click.echo(
        table(
            rows,
            [
                "cell",
                "library",
                "seed",
                "failures",
                "rule",
                "budget_usd",
                "suite",
                "cost_usd",
                "score",
                "worst",
                "certified",
                "seconds",
            ],
        )
    )
    click.echo("wrote " + ", ".join(str(w) for w in written))


COMMANDS = [study_cmd]
