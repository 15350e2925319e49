"""``sensorsel optimal``: the exact best suite within a budget (branch and bound), and greedy beside it.

The certificate line of ``sensorsel greedy`` comes from :func:`certificate_line` (see
:mod:`sensorsel.certify` for the bound).
"""

from __future__ import annotations

import sys
from typing import Any

import click

from .. import results
from ..certify import DEFAULT_MAX_NODES, certify_greedy, format_certificate, optimal
from ..objective import Evaluator, make_evaluator
from ..pipeline import problem_info
from ..selection import GreedyResult, check_budget
from .options import engine_options, problem_from, run, scenario_options


def certificate_line(evaluator: Evaluator, result: GreedyResult) -> str:
    """The line ``sensorsel greedy`` prints under its result: 'certificate: at least X% of the best possible ...'."""
    return format_certificate(certify_greedy(evaluator, result))


def _suite_text(ids: tuple[str, ...]) -> str:
    return ",".join(ids) if ids else "(no sensor)"


@click.command("optimal")
@scenario_options
@engine_options
@click.option("--budget", type=float, required=True, help="Budget per car [$].")
@click.option("--max-nodes", type=click.IntRange(min=1), default=DEFAULT_MAX_NODES, show_default=True,
              help="Stop after expanding this many nodes (each scores one suite plus each candidate).")
@click.option("--max-seconds", type=click.FloatRange(min=0, min_open=True), default=None,
              help="Also stop after this much wall time [s] (the result then depends on the machine's speed).")
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=str), default=None, help="Write the result as JSON here.")
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON.")
@click.option("--quiet", "-q", is_flag=True, help="No progress bar.")
@run
def optimal_cmd(budget: float, max_nodes: int, max_seconds: float | None, output: str | None, as_json: bool, quiet: bool,
                engine: str | None, jobs: int, **kw: Any) -> None:
    """The best suite within --budget, by branch and bound with the submodular knapsack bound.

    Starts from the greedy (best-of) suite and proves it optimal or improves on it. At the node
    limit it prints the best suite found and how much better the optimum can be. Exact search is for
    small libraries (e.g. one model per type: --library configs/reduced_library.yaml); on the full
    62-sensor library expect the node limit and a remaining gap.
    """
    budget = check_budget(budget)
    problem, spec = problem_from(kw)
    info = problem_info(problem, spec)
    ev = make_evaluator(problem, engine, jobs=jobs)
    if quiet or as_json:
        res = optimal(ev, budget, max_nodes=max_nodes, max_seconds=max_seconds, info=info)
    else:
        with click.progressbar(length=max_nodes, label="branch and bound (nodes)", file=sys.stderr) as bar:
            done = [0]

            def step(n: int, _total: int) -> None:
                bar.update(n - done[0])
                done[0] = n

            res = optimal(ev, budget, max_nodes=max_nodes, max_seconds=max_seconds, info=info, progress=step)
    if output:
        results.save(res, output)
    if as_json:
        click.echo(results.dumps(res), nl=False)
        return
    p = res.problem
    assert p is not None
    click.echo(f"scenario   {p.scenario}: {p.n_poses} keyframes, {p.n_landmarks} landmarks ({p.landmark_source})")
    click.echo(f"library    {p.n_sensors} sensors from {p.library}")
    click.echo(f"budget     ${res.budget_usd:,.0f}")
    if res.proved_optimal:
        click.echo(f"optimum    {_suite_text(res.suite)}  (${res.cost_usd:,.0f})  f = {res.score:.3f} nats  [proved optimal]")
    else:
        click.echo(f"best found {_suite_text(res.suite)}  (${res.cost_usd:,.0f})  f = {res.score:.3f} nats  [not proved: {res.stop_reason}]")
        click.echo(f"gap        the optimum scores at most {res.upper_bound:.3f} nats: at most {res.gap:.3f} nats "
                   f"({res.gap_percent:.2f}%) above the best found")
    rule = "best-of" + (f" ({res.greedy_rule})" if res.greedy_rule != "best-of" else "")
    rel = (f"{res.greedy_percent_of_best:.2f}% of the optimum" if res.proved_optimal
           else f"{res.greedy_percent_of_best:.2f}% of the best found, >= {res.greedy_percent_of_bound:.2f}% of the optimum")
    click.echo(f"greedy     {rule}: {_suite_text(res.greedy_suite)}  (${res.greedy_cost_usd:,.0f})  f = {res.greedy_score:.3f} nats = {rel}")
    click.echo(f"search     {res.n_nodes:,} nodes expanded, {res.n_pruned:,} pruned, {res.n_evaluations:,} suites scored "
               f"({res.engine} engine, {res.bound_method} bounds), {res.seconds:.1f} s")
    if output:
        click.echo(f"wrote      {output}")


COMMANDS = [optimal_cmd]
