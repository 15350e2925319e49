"""``sensorsel robust``: the best worst case under failures, greedy and Algorithm 2 beside it."""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

import click

from sensorsel.api import (
    ROBUST_AGGREGATES,
)  # --aggregate of this command: the combined score (as elsewhere), or the worst route
from sensorsel.cli.cluster import cluster_evaluator, require_domain
from sensorsel.cli.common import compact_suite, echo_result, print_accuracy, print_limits, print_target, table
from sensorsel.cli.options import (
    budget_option,
    design_from,
    design_options,
    failures_option,
    output_option,
    quality_options,
    result_file,
    result_options,
    resume_option,
)
from sensorsel.cli.vocabulary import Command
from sensorsel.io import results
from sensorsel.model.library import SensorLibrary


def _worst_aggregate(fn: Any) -> Any:
    """Widen the shared --aggregate choice with "worst" (the worst route of a domain), for this command only."""
    for p in getattr(fn, "__click_params__", []):
        if p.name == "aggregate":
            p.type = click.Choice(list(ROBUST_AGGREGATES))
            p.help = (
                (p.help or "") + " worst = the worst route's share of its best under the failures "
                "(max-min over the routes; robust only)."
            )
    return fn


def tasks_folder(output: str) -> Path:
    """Where ``robust -o FILE`` keeps its methods' outcomes while it runs: ``FILE.tasks/``."""
    return Path(output).with_name(Path(output).name + ".tasks")


def _csv(xs: Any) -> str:
    return ",".join(xs) or "-"


@click.command(
    "robust", cls=Command, short_help="Robust selection: the best worst case under failing sensors, with its bound."
)
@_worst_aggregate
@design_options
@budget_option(default=110_000.0, help="Budget in dollars (110000, 110,000, $110,000 or 110_000).")
@failures_option("Number of sensors that may fail (alpha); the design maximises the score left after the worst ALPHA.")
@click.option(
    "--rules",
    default="uniform,marginal",
    show_default=True,
    metavar="RULES",
    help="Plain greedy rules run as candidates, comma-separated (uniform always runs).",
)
@click.option(
    "--methods",
    default=None,
    help="Further methods, comma-separated, or 'none' [default: oblivious,saturate,local-search; "
    "with --aggregate worst: saturate,local-search].",
)
@click.option(
    "--no-skip", is_flag=True, help="Run every method even when the bound already proves a candidate optimal."
)
@quality_options
@output_option(
    help='Write the result as JSON here (kind "robust"); each method\'s outcome is kept in FILE.tasks/ '
    "as it comes (removed once FILE is written; not with --aggregate worst)."
)
@resume_option
@result_options
def robust_cmd(
    budget: float,
    alpha: int,
    rules: str,
    methods: str | None,
    no_skip: bool,
    output: str | None,
    resume: bool,
    as_json: bool,
    quiet: bool,
    **kw: Any,
) -> None:
    """Robust sensor selection: maximise the worst-case score after ALPHA sensors fail.

    Runs plain greedy, the paper's Algorithm 2 and further methods, scores every suite by its exact
    worst case (all failure sets enumerated) and keeps the best, so the answer's worst case is never
    below greedy's nor Algorithm 2's. An upper bound on the best achievable worst case and the gap to
    it are printed; gap 0 proves the answer optimal.

    With --domain FILE and --aggregate worst, the design maximises the worst route's share of its best
    (f_r(S) / f_r(all sensors)) under the failures.

    With --scheduler/--workers, the methods of each stage run as tasks on the workers (with
    --aggregate worst: each route is scored on a worker); the answer is the same bytes, timings
    aside. With -o FILE each method's outcome is kept in FILE.tasks/ as it comes; after an
    interruption, the same command with --resume reads back those whose inputs match.

    --limit, --include, --exclude, --max-sensors and the library's slots hold for every candidate;
    the bound then relaxes them to the budget alone (still an upper bound).
    """
    from sensorsel.api import check_affordable, check_alpha, check_budget, run_robust

    budget, alpha = check_budget(budget), check_alpha(alpha)
    aggregate = kw["aggregate"]
    result_file(output, resume, "the methods kept in FILE.tasks/ of -o FILE")
    if resume and aggregate == "worst":
        raise click.UsageError("--aggregate worst runs as one search, with nothing kept to resume from: drop --resume")
    rule_list = tuple(r.strip() for r in rules.split(",") if r.strip())
    from sensorsel.api import EXTRA_METHODS, WORST_METHODS

    method_list: tuple[str, ...]
    if methods is None:
        method_list = WORST_METHODS if aggregate == "worst" else EXTRA_METHODS
    elif methods.strip() in ("", "none"):
        method_list = ()
    else:
        method_list = tuple(m.strip() for m in methods.split(",") if m.strip())
    inputs = design_from(kw)
    target, cluster = inputs.target, inputs.cluster
    if aggregate == "worst":  # its routes are spread over the cluster (the methods' tasks need no domain)
        require_domain(cluster, target)
    check_affordable(target.library, budget, constraints=inputs.constraints)
    if not quiet:
        click.echo(f"robust selection: ${budget:,.0f}, {alpha} failure(s) ...", err=True)

    tasks = tasks_folder(output) if output and aggregate != "worst" else None
    with inputs.running():
        if aggregate == "worst":  # one search over the routes' shares: on a cluster each route on a worker
            how: dict[str, Any] = {"evaluator": cluster_evaluator(cluster, target, inputs.engine, "normalised")}
        else:  # the methods as tasks: here, or on the cluster's workers; kept under FILE.tasks/
            how = {"executor": inputs.executor, "outdir": tasks, "resume": resume}
        res = run_robust(
            target,
            budget,
            alpha,
            **inputs.run_options,
            aggregate=aggregate,
            rules=rule_list,
            methods=method_list,
            skip_when_proved=not no_skip,
            **how,
        )
    res = inputs.with_quality(res)
    written = results.save(res, output) if output else None
    if tasks is not None:  # the result is written: the run is no longer interrupted
        shutil.rmtree(tasks, ignore_errors=True)

    def summary() -> None:
        print_robust(res, target.library)
        print_accuracy(res.accuracy, res.integrity)
        if written is not None:
            click.echo(f"wrote {written}")

    echo_result(res, as_json, summary)


#: The words a user reads for each candidate method of a robust result (the result file keeps the
#: method's key, e.g. "bound-leaf"; a key not listed here is printed as it is).
METHOD_WORDS = {
    "greedy-uniform": "greedy (uniform rule)",
    "greedy-cost-benefit": "greedy (cost-benefit rule)",
    "greedy-marginal": "greedy (marginal rule)",
    "algorithm-2": "the paper's Algorithm 2",
    "bound-leaf": "the upper bound's search",
    "oblivious-eta2": "Oblivious-Greedy",
    "oblivious": "Oblivious-Greedy",
    "saturate": "SATURATE",
    "local-search": "local search",
}


def method_words(method: str) -> str:
    """What a robust candidate's method is called in the output ("bound-leaf" -> "the upper bound's search")."""
    return METHOD_WORDS.get(method, method)


def print_robust(res: Any, lib: SensorLibrary | None = None) -> None:
    """The summary of a :class:`~sensorsel.designs.robust.RobustResult`: greedy, Algorithm 2 and the robust design
    side by side, the winning method, every candidate, and (worst route) the per-route breakdown."""
    worst = res.aggregate == "worst"
    unit = "share of the route's best" if worst else "nats"
    fmt = (lambda v: f"{v:.4f}") if worst else (lambda v: f"{v:,.2f}")
    print_target(res.problem)
    what = "the worst route's share of its best" if worst else "the score"
    click.echo(
        f"budget     ${res.budget_usd:,.0f}, {res.alpha} failure(s), engine {res.engine}; worst case = {what} "
        f"after the worst {res.alpha} failure(s)"
    )
    click.echo("")
    first: dict[str, Any] = {}
    for c in res.candidates:
        first.setdefault(c.method, c)
    win = next(c for c in res.candidates if c.method == res.method and tuple(c.suite) == tuple(res.suite))
    rows = []
    for label, c in (
        ("greedy", first.get("greedy-uniform")),
        ("algorithm 2", first.get("algorithm-2")),
        ("robust", win),
    ):
        if c is None:
            continue
        fail = _csv(c.failures) + (f" on {c.worst_member}" if c.worst_member else "")
        rows.append(
            [
                label,
                compact_suite(c.suite, lib),
                f"{c.cost_usd:,.0f}",
                fmt(c.nominal_score),
                fmt(c.worst_score),
                fail,
                fmt(res.bound),
                f"{100.0 * (res.bound - c.worst_score) / res.bound if res.bound > 0 else 0.0:.2f}%",
            ]
        )
    click.echo(table(rows, ["design", "suite", "cost_usd", "nominal", "worst_case", "worst_failures", "bound", "gap"]))
    click.echo(
        f"\nchosen by {method_words(res.method)}; worst case {fmt(res.worst_score)} ({unit}), bound {fmt(res.bound)}, "
        f"gap {res.gap_percent:.2f}%" + (" (proved optimal)" if res.bound_detail.proved or res.gap_percent == 0 else "")
    )
    if res.greedy_worst_score > 0:
        click.echo(
            f"versus greedy {100.0 * (res.worst_score - res.greedy_worst_score) / res.greedy_worst_score:+.1f} %, "
            f"versus Algorithm 2 "
            f"{100.0 * (res.worst_score - res.algorithm2_worst_score) / max(res.algorithm2_worst_score, 1e-300):+.1f} %"
        )
    if worst and res.members:
        click.echo(f"\nper route (worst: {res.worst_member})")
        click.echo(
            table(
                [
                    [m.name, f"{m.best_score:,.2f}", f"{m.nominal_share:.4f}", f"{m.worst_share:.4f}", _csv(m.failures)]
                    for m in res.members
                ],
                ["route", "best_nats", "nominal_share", "worst_share", "worst_failures"],
            )
        )
    click.echo("\ncandidates")
    click.echo(
        table(
            [
                [
                    method_words(c.method),
                    compact_suite(c.suite, lib),
                    f"{c.cost_usd:,.0f}",
                    fmt(c.nominal_score),
                    fmt(c.worst_score),
                    _csv(c.failures) + (f" on {c.worst_member}" if c.worst_member else ""),
                    str(c.n_evaluations),
                    f"{c.seconds:.1f}",
                ]
                for c in res.candidates
            ],
            ["method", "suite", "cost_usd", "nominal", "worst_case", "worst_failures", "evaluations", "seconds"],
        )
    )
    for s in res.skipped:
        method, _, why = s.partition(": ")
        click.echo(f"skipped: {method_words(method)}: {why}" if why else f"skipped: {s}")
    if lib is not None:
        relaxation = f"; bound: {res.bound_detail.relaxation}" if res.bound_detail.relaxation else ""
        print_limits(lib, res.budget_usd, res.constraints, res.suite, "\nlimits     ", relaxation)
    click.echo(f"{res.n_evaluations:,} suites scored in {res.seconds:.1f} s")


COMMANDS = [robust_cmd]
