"""``sensorsel resilient``: resilient selection against failures, whole route and period by period."""

from __future__ import annotations

from collections import Counter
from pathlib import Path
from typing import Any

import click

from sensorsel.api import ALGORITHM_2, METHODS
from sensorsel.cli.common import echo_result, print_accuracy, print_limits, print_target, table
from sensorsel.cli.options import (
    DesignInputs,
    budget_option,
    design_from,
    design_options,
    failures_option,
    plots_folder_from,
    plots_folder_option,
    progress_bar,
    quality_options,
    result_options,
    resume_option,
)
from sensorsel.cli.rules import rule_option
from sensorsel.cli.vocabulary import Command
from sensorsel.errors import InputError
from sensorsel.io import results


@click.command(
    "resilient",
    cls=Command,
    short_help="Resilient selection against failing sensors, whole route and per period (grid).",
)
@design_options
@budget_option(
    default=110_000.0,
    help="Budget in dollars (110000, 110,000, $110,000 or 110_000), the sensors assumed to fail included.",
)
@failures_option("Number of sensors assumed to fail (alpha); 0 is plain greedy selection.")
@click.option(
    "--period",
    "period_s",
    type=float,
    default=10.0,
    show_default=True,
    help="Length of a period of the per-period selection [s of keyframe timestamps].",
)
@rule_option("uniform", "Greedy rule spending the budget left after the failing sensors.")
@click.option(
    "--method",
    type=click.Choice(list(METHODS)),
    default=ALGORITHM_2,
    show_default=True,
    help="How the suite is chosen, whole route and each period: algorithm-2 = the paper's Algorithm 2; "
    "robust = robust selection (best exact worst case among greedy, "
    "Algorithm 2 and more; never below either).",
)
@plots_folder_option(
    "Output folder: resilient.json, grid.csv, the grid plot, and periods/ (one file per period).",
)
@resume_option
@quality_options
@result_options
def resilient_cmd(
    budget: float,
    alpha: int,
    period_s: float,
    rule: str,
    method: str,
    resume: bool,
    as_json: bool,
    quiet: bool,
    **kw: Any,
) -> None:
    """Resilient sensor selection (the paper's Algorithm 2, for ALPHA failures).

    The ALPHA sensors with the largest individual scores are bought and assumed to fail; the rest of
    the budget goes to greedy selection on the library without them. Prints greedy versus resilient
    selection on the whole route (nominal score, worst-case score after the worst ALPHA failures,
    and that failure set), then runs the selection on each period of the route and draws the grid of
    failed (red) and active (green) sensors per period (the paper's Fig. 5); a black cross marks the
    failure set worst for each period's suite (also the worst_failures column of grid.csv).

    --method robust chooses the whole route's suite and each period's by robust selection instead
    (the best exact worst case among greedy, Algorithm 2 and further methods): no sensor is assumed
    to fail in advance, so its grid is all active, with the worst failures crossed.

    With --domain FILE the comparison is on the domain's score (one suite for all its routes); there
    are no periods then (a period is a stretch of one route).
    """
    from sensorsel.api import check_affordable, check_alpha, check_budget, check_period

    budget = check_budget(budget)
    alpha = check_alpha(alpha)
    period_s = check_period(period_s)
    out, fmt = plots_folder_from(kw)
    inputs = design_from(kw)
    problem = inputs.target
    check_affordable(problem.library, budget, alpha, constraints=inputs.constraints)
    if inputs.cluster is not None and problem.kind != "route":
        raise click.UsageError("--scheduler/--workers run a route's periods as tasks: a domain has no periods")
    report = _report(inputs, budget, alpha, period_s, rule, method, out, resume, quiet)
    r = report.comparison.resilient
    if alpha and len(r.suite) <= alpha:
        # the failing set took what the budget buys: every sensor of the suite could fail
        raise InputError(
            f"--failures {alpha}: the resilient suite within --budget ${budget:,.0f} holds only {len(r.suite)} "
            f"sensor(s) ({', '.join(r.suite) or 'none'}; {r.failure_note or 'the failing sensors take the budget'}), "
            f"so every one could fail (worst case 0): give fewer --failures or a larger --budget"
        )
    report = inputs.with_quality(report)
    written = _write(report, problem, out, fmt, period_s, alpha, budget, method)

    def summary() -> None:
        _print_comparison(report, budget, alpha, rule, method)
        print_accuracy(report.accuracy, report.integrity)
        print_limits(
            problem.library,
            report.budget_usd,
            report.constraints,
            report.suite,
            "\nlimits    ",
            " (every suite above and every period's); the chosen suite uses:",
        )
        _print_periods(report.per_period, period_s)
        for p in written:
            click.echo(f"wrote {p}")
        if report.per_period is not None:
            click.echo(f"wrote {len(report.per_period.periods)} period files under {out / 'periods'}")

    echo_result(report, as_json, summary)


def _report(
    inputs: DesignInputs,
    budget: float,
    alpha: int,
    period_s: float,
    rule: str,
    method: str,
    out: Path,
    resume: bool,
    quiet: bool,
) -> Any:
    """The resilient report: on a route, its comparison and periods (in-process, or as tasks on a
    cluster) with one progress bar over the periods; a domain has no single time line, so no periods:
    its comparison alone."""
    from sensorsel.api import resilient_report, split_periods

    target = inputs.target
    how: dict[str, Any] = {
        **inputs.run_options,
        "rule": rule,
        "method": method,
    }
    if target.kind != "route":
        return resilient_report(target, budget, alpha, period_s=None, aggregate=inputs.aggregate, **how)
    sc = target.routes[0].problem.scenario
    n_periods = len(split_periods(sc.keyframes.times, period_s))
    bar, progress = progress_bar(quiet, f"{n_periods} periods of {period_s:g} s")
    if bar is not None and bar.terminal:  # off a terminal the status lines say it
        click.echo(
            f"whole route: greedy and resilient selection on {sc.n_poses} keyframes, {sc.n_landmarks} landmarks ...",
            err=True,
        )
    with inputs.running(bar):  # with a cluster, every period as a task there
        return resilient_report(
            target,
            budget,
            alpha,
            period_s=period_s,
            outdir=out,
            resume=resume,
            progress=progress,
            executor=inputs.executor,
            **how,
        )


def _write(
    report: Any, problem: Any, out: Path, fmt: str, period_s: float, alpha: int, budget: float, method: str
) -> list[Path]:
    """resilient.json, and for a route grid.csv and the grid plot."""
    from sensorsel.api import save_grid_csv
    from sensorsel.plotting import plot_selection_grid, save_figure, use_file_backend

    written = [results.save(report, out / "resilient.json")]
    per = report.per_period
    if per is None:
        return written
    written.append(save_grid_csv(per.grid, out / "grid.csv"))
    use_file_backend()
    what = "robust" if method == "robust" else "resilient"
    title = (
        f"{problem.scenario.name}: {what} selection per {period_s:g} s period, {alpha} failure(s), budget "
        f"${budget:,.0f}"
    )
    ax = plot_selection_grid(per.grid, title=title)
    written.append(save_figure(ax.figure, out / f"grid.{fmt}", close=True))
    return written


def _print_comparison(report: Any, budget: float, alpha: int, rule: str, method: str) -> None:
    """Greedy, the resilient (and robust) design side by side: nominal and worst-case scores."""
    c = report.comparison
    print_target(c.problem)
    click.echo(f"budget    ${budget:,.0f}, {alpha} failure(s), rule {rule}, engine {c.engine}, method {method}")
    r = c.resilient
    if r.failed:
        fails = ", ".join(f"{s} (f = {v:.2f})" for s, v in zip(r.failed, r.failed_scores))
        click.echo(
            f"{'Algorithm 2: ' if method == 'robust' else ''}assumed to fail: {fails}; ${r.failed_cost_usd:,.0f} "
            "of the budget"
        )
    if r.failure_note:
        click.echo(f"note: {r.failure_note}")
    click.echo("")
    rows = []
    for label, suite, cost, w in (
        ("greedy", c.greedy.suite, c.greedy.cost_usd, c.greedy_worst),
        ("resilient", r.suite, r.cost_usd, c.resilient_worst),
    ):
        rows.append(
            [
                label,
                ",".join(suite) or "(none)",
                f"{cost:,.0f}",
                f"{w.nominal_score:.2f}",
                f"{w.score:.2f}",
                ",".join(w.failures) or "-",
            ]
        )
    rb = report.robust
    if rb is not None:
        rows.append(
            [
                "robust",
                ",".join(rb.suite) or "(none)",
                f"{rb.cost_usd:,.0f}",
                f"{rb.nominal_score:.2f}",
                f"{rb.worst_score:.2f}",
                ",".join(rb.failures) or "-",
            ]
        )
    click.echo(table(rows, ["design", "suite", "cost_usd", "nominal", "worst_case", "worst_failure"]))
    if rb is not None:
        click.echo(f"robust: method {rb.method}, bound {rb.bound:.2f}, gap {rb.gap_percent:.2f}%")
    if c.greedy_worst.score > 0:
        gain = 100.0 * (c.resilient_worst.score - c.greedy_worst.score) / c.greedy_worst.score
        click.echo(
            f"\nworst case: resilient {gain:+.1f} % versus greedy (scores in nats: f(S) = log det L(S) - log det "
            "L(empty))"
        )


def _print_periods(per: Any, period_s: float) -> None:
    """Per period: which sensors were assumed to fail, used, and worst for the suite."""
    if per is None:
        return
    n = len(per.periods)
    failed = Counter(s for p in per.periods if p.result is not None for s in p.result.failed)
    active = Counter(s for p in per.periods for s in (p.result.active if p.result is not None else p.worst.suite))
    worst = Counter(s for p in per.periods for s in p.worst.failures)
    click.echo(f"\nper period: {n} periods of {period_s:g} s")
    if failed:
        click.echo("  assumed to fail: " + ", ".join(f"{s} in {k}/{n}" for s, k in failed.most_common()))
    if active:
        click.echo("  most used active: " + ", ".join(f"{s} in {k}/{n}" for s, k in active.most_common(8)))
    if worst:
        click.echo("  worst failure for the suite: " + ", ".join(f"{s} in {k}/{n}" for s, k in worst.most_common(8)))


COMMANDS = [resilient_cmd]
