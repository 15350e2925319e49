"""``sensorsel optimal``: the exact best suite within a budget (branch and bound), and greedy beside it.
``sensorsel certify``: how close a greedy suite (run now, or read from a result file) is to the best
possible one (an upper bound on the optimum; ``sensorsel greedy`` prints the same certificate line).
"""

from __future__ import annotations

import warnings
from typing import Any

import click

from sensorsel.api import (
    DEFAULT_MAX_NODES,
    Certificate,
    CertifiedGreedyResult,
    DomainDesign,
    DomainEvaluator,
    GreedyResult,
    certify_result,
    check_affordable,
    check_budget,
    constraints_mismatch,
    format_certificate,
    run_greedy,
    run_optimal,
)
from sensorsel.cli.cluster import evaluator_on, require_domain
from sensorsel.cli.common import echo_result, is_result_file, print_accuracy, print_limits, print_target
from sensorsel.cli.options import (
    DesignInputs,
    budget_option,
    design_from,
    design_options,
    force_option,
    output_option,
    path_option,
    progress_bar,
    quality_options,
    result_file,
    result_options,
    resume_option,
    running,
    time_limit_option,
)
from sensorsel.cli.options import not_empty as not_empty_file
from sensorsel.cli.rules import kept_label, rule_option
from sensorsel.cli.vocabulary import Command
from sensorsel.errors import InputError, ResultFileError
from sensorsel.io import results
from sensorsel.io.files import output_file
from sensorsel.model.constraints import Constraints
from sensorsel.model.library import SensorLibrary
from sensorsel.model.problem import ProblemMismatchWarning, check_result_problem


def _suite_text(ids: tuple[str, ...]) -> str:
    return ",".join(ids) if ids else "(no sensor)"


def _check_result_constraints(res: GreedyResult, lib: SensorLibrary, path: str, force: bool) -> None:
    """Refuse (or, with --force, warn about) a result whose constraints were checked against other
    resources or mounting slots than this library's; constraints the library cannot express at all
    are refused even with --force."""
    mismatch = constraints_mismatch(res, lib)
    if mismatch is None:
        return
    why, usable = mismatch
    if force and usable:
        warnings.warn(f"{path}: {why}; used anyway (--force)", ProblemMismatchWarning, stacklevel=2)
        return
    hint = "give the library it was run with" + (", or --force to use it anyway" if usable else "")
    raise ResultFileError(path, f"{why}; {hint}")


@click.command(
    "optimal", cls=Command, short_help="Exact best suite within a budget (branch and bound), with greedy beside it."
)
@design_options
@budget_option(required=True, help="Budget per car in dollars: 110000, 110,000, $110,000 or 110_000.")
@click.option(
    "--max-nodes",
    type=click.IntRange(min=1),
    default=DEFAULT_MAX_NODES,
    show_default=True,
    help="Stop after expanding this many nodes (each scores one suite plus each candidate).",
)
@time_limit_option(
    "Also stop the search after this long and report the gap (the result then depends on the machine's speed)."
)
@quality_options
@output_option(
    help="Write the result as JSON here; the search's state is kept in FILE.checkpoint as it runs "
    "(the greedy start, then every 500 nodes; removed once FILE is written)."
)
@resume_option
@result_options
def optimal_cmd(
    budget: float,
    max_nodes: int,
    time_limit: float | None,
    output: str | None,
    resume: bool,
    as_json: bool,
    quiet: bool,
    **kw: Any,
) -> None:
    """The best suite within --budget, by branch and bound with the submodular knapsack bound.

    Starts from the greedy (best-of) suite and proves it optimal or improves on it. At the node
    limit it prints the best suite found and how much better the optimum can be. Exact search is for
    small libraries (e.g. one model per type: --library configs/reduced_library.yaml); on the full
    62-sensor library expect the node limit and a remaining gap. With --domain and
    --scheduler/--workers, each route is scored on a worker (every node's suites at once).

    With --limit, --include, --exclude, --max-sensors or the library's mounting slots, the optimum
    is the best suite they allow (node bounds: an integer program over the marginal gains, by HiGHS).

    With -o FILE, an interrupted search goes on with --resume from its last checkpoint (FILE.checkpoint),
    also with a larger --max-nodes; the answer is the uninterrupted run's.
    """
    budget = check_budget(budget)
    store = result_file(output, resume, "the search's state in FILE.checkpoint of -o FILE")
    inputs = design_from(kw)
    problem = inputs.target
    require_domain(inputs.cluster, problem)
    check_affordable(problem.library, budget, constraints=inputs.constraints)
    bar, progress = progress_bar(
        quiet or as_json, "branch and bound (nodes)", eta=False
    )  # the node limit is a cap, not a forecast
    with inputs.running(bar):
        ev = evaluator_on(inputs.cluster, problem, inputs.engine, inputs.jobs, inputs.aggregate)
        res = run_optimal(
            problem,
            budget,
            max_nodes=max_nodes,
            max_seconds=time_limit,
            progress=progress,
            constraints=inputs.constraints,
            evaluator=ev,
            checkpoint=store.checkpoint,
            resume=resume,
        )
    res = inputs.with_quality(res)
    store.save(res)
    echo_result(res, as_json, lambda: _print_optimal(res, problem.library, output))


def _print_optimal(res: Any, lib: SensorLibrary, output: str | None) -> None:
    """The optimum (or the best found and the gap), greedy beside it, the search, the limits, the accuracy."""
    print_target(res.problem)
    click.echo(f"library    {len(lib)} sensors from {lib.source}")
    click.echo(f"budget     ${res.budget_usd:,.0f}")
    if res.proved_optimal:
        click.echo(
            f"optimum    {_suite_text(res.suite)}  (${res.cost_usd:,.0f})  f = {res.score:.3f} nats  [proved optimal]"
        )
    else:
        click.echo(
            f"best found {_suite_text(res.suite)}  (${res.cost_usd:,.0f})  f = {res.score:.3f} nats  [not proved: "
            f"{res.stop_reason}]"
        )
        click.echo(
            f"gap        the optimum scores at most {res.upper_bound:.3f} nats: at most {res.gap:.3f} nats "
            f"({res.gap_percent:.2f}%) above the best found"
        )
    rule = res.greedy_rule
    rel = (
        f"{res.greedy_percent_of_best:.2f}% of the optimum"
        if res.proved_optimal
        else f"{res.greedy_percent_of_best:.2f}% of the best found, >= {res.greedy_percent_of_bound:.2f}% of the "
        "optimum"
    )
    click.echo(
        f"greedy     {rule}: {_suite_text(res.greedy_suite)}  (${res.greedy_cost_usd:,.0f})  f = "
        f"{res.greedy_score:.3f} nats = {rel}"
    )
    click.echo(
        f"search     {res.n_nodes:,} nodes expanded ({res.n_solved:,} settled whole), {res.n_pruned:,} pruned, "
        f"{res.n_evaluations:,} suites scored "
        f"({res.engine} engine, {res.bound_method} bounds), {res.seconds:.1f} s"
    )
    print_limits(lib, res.budget_usd, res.constraints, res.suite)
    print_accuracy(res.accuracy, res.integrity)
    if output:
        click.echo(f"wrote      {output}")


@click.command(
    "certify", cls=Command, short_help="How close a greedy suite is to the best possible one (an upper bound)."
)
@design_options
@path_option(
    "--suite",
    "result_path",
    callback=not_empty_file,
    metavar="FILE",
    help="The suite to certify: a greedy result file of sensor ids and the run that chose them "
    "(`sensorsel greedy -o FILE`); it must be of the same library, route, rate and landmarks "
    "(checked by content; see --force).",
)
@budget_option(
    help="Without --suite: run greedy at this budget in dollars (110000, 110,000, $110,000 or 110_000) and certify it."
)
@rule_option("best-of", "Without --suite: the greedy rule.")
@force_option
@output_option(help="Write the certificate as JSON here.")
@result_options
def certify_cmd(
    result_path: str | None,
    budget: float | None,
    rule: str,
    force: bool,
    output: str | None,
    as_json: bool,
    quiet: bool,
    **kw: Any,
) -> None:
    """How close is a greedy suite to the best possible suite of its budget?

    --suite FILE: a greedy result to certify (its suite, and the greedy run that chose it), as
    `simulate --suite FILE` takes one; or --budget DOLLARS: run greedy now and certify it.

    Evaluates the submodular upper bound f(S) + knapsack of the marginal gains (capacity: the
    budget) at every intermediate suite of the greedy run and keeps the smallest: no suite within
    the budget scores above it. At most one sweep of the library per greedy step (steps that
    provably cannot lower the bound are skipped). With --domain and --scheduler/--workers, each
    route is scored on a worker.

    The bound respects the constraints of the run: those a --suite file records (its library must
    declare the same resources and slots; see --force), or, with --budget, --limit, --include,
    --exclude, --max-sensors and the library's mounting slots (then an integer program, by HiGHS).
    """
    if result_path is not None and not is_result_file(result_path):
        raise InputError(
            f"--suite {result_path}: certify bounds a greedy run, so it takes a greedy result file "
            "(sensorsel greedy -o FILE), not sensor ids; or give --budget DOLLARS to run greedy now"
        )
    if result_path is not None and budget is not None:
        raise InputError("give either --suite FILE (a greedy result) or --budget DOLLARS (run greedy now), not both")
    if result_path is None and budget is None:
        raise InputError("give --suite FILE (a greedy result to certify) or --budget DOLLARS (run greedy now)")
    if output:
        output_file(output)
    inputs = design_from(kw)
    if result_path is not None and inputs.constraints != Constraints():
        raise InputError(
            "--suite FILE is certified under the constraints it records: give --limit, --no-slots, "
            "--include, --owned, --exclude or --max-sensors only with --budget"
        )
    require_domain(inputs.cluster, inputs.target)
    with inputs.running():
        res, cert = _certify(inputs, result_path, budget, rule, force, quiet or as_json)
    if output:
        results.save(cert, output)
    echo_result(cert, as_json, lambda: _print_certificate(res, cert, inputs.target.library, output))


def _print_certificate(res: Any, cert: Certificate, lib: SensorLibrary, output: str | None) -> None:
    """The greedy suite, its score and the bound on any suite's within the budget, the limits."""
    print_target(res.problem)
    click.echo(
        f"greedy     {kept_label(res.rule, res.winning_rule)}: {_suite_text(res.suite)}  (${res.cost_usd:,.0f} of "
        f"${res.budget_usd:,.0f})"
    )
    click.echo(f"score      {cert.score:.3f} nats")
    within = f"${cert.budget_usd:,.0f}" + (" and the limits below" if cert.constraints is not None else "")
    click.echo(
        f"bound      {cert.bound:.3f} nats: no suite within {within} scores more "
        f"(gap {cert.gap:.3f} nats; knapsack: {cert.knapsack_method})"
    )
    print_limits(lib, res.budget_usd, res.constraints, res.suite)
    click.echo(format_certificate(cert))
    if output:
        click.echo(f"wrote      {output}")


def _certify(
    inputs: DesignInputs, result_path: str | None, budget: float | None, rule: str, force: bool, quiet: bool
) -> tuple[Any, Certificate]:
    """The greedy result (read from --suite, under the constraints it records; or run now under the
    constraints of the options) and its certificate, on the cluster if one was asked for."""
    problem, engine = inputs.target, inputs.engine
    if result_path is not None:
        loaded = results.load(result_path, (CertifiedGreedyResult, DomainDesign))
        # a domain design holds its greedy result inside (its own result kind)
        res = loaded.greedy if results.kind_of(loaded) == results.kind_of(DomainDesign) else loaded
        check_result_problem(res.problem, problem, result_path, force=force, what="the greedy result")
        try:
            problem.library.parse_suite(list(res.suite))
        except InputError as exc:
            raise ResultFileError(result_path, f"its suite: {exc} (a result of another library?)") from None
        _check_result_constraints(res, problem.library, result_path, force)
        run_engine = None if res.engine == DomainEvaluator.name else res.engine
        ev = evaluator_on(inputs.cluster, problem, engine or run_engine, inputs.jobs, inputs.aggregate)
    else:
        assert budget is not None
        checked = check_affordable(problem.library, budget, constraints=inputs.constraints)
        ev = evaluator_on(inputs.cluster, problem, engine, inputs.jobs, inputs.aggregate)
        res = run_greedy(problem, checked, rule, constraints=inputs.constraints, evaluator=ev)
    bar, progress = progress_bar(quiet, "certificate (greedy steps)")
    with running(bar):
        cert: Certificate = certify_result(problem, res, progress=progress, force=force, evaluator=ev)
    return res, cert


COMMANDS = [optimal_cmd, certify_cmd]
