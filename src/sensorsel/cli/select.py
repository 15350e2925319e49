"""Selection commands: ``greedy`` (one suite under a budget) and ``pareto`` (the cost-performance tradespace)."""

from __future__ import annotations

import sys
from dataclasses import replace
from typing import Any

import click

from sensorsel.api import (
    DEFAULT_RULES,
    RULES,
    Architecture,
    CertifiedGreedyResult,
    DomainDesign,
    by_condition,
    check_affordable,
    design_domain,
    format_certificate,
    front_acceptance,
    parse_budgets,
    parse_rules,
    run_greedy,
    run_tradespace,
    write_csv,
)
from sensorsel.cli.cluster import cluster_evaluator, require_domain
from sensorsel.cli.common import (
    compact_suite,
    echo_result,
    print_accuracy,
    print_limits,
    print_target,
    specification_from,
    specification_given,
    specification_options,
    table,
)
from sensorsel.cli.options import (
    budget_option,
    design_from,
    design_options,
    lazy_option,
    map_sigma_option,
    output_option,
    path_option,
    plot_format,
    plots_folder_from,
    plots_folder_option,
    progress_bar,
    quality_options,
    result_file,
    result_options,
    resume_option,
)
from sensorsel.cli.rules import kept_label, rule_option, rules_option
from sensorsel.cli.vocabulary import Command
from sensorsel.io import results
from sensorsel.io.files import output_file
from sensorsel.model.library import SensorLibrary
from sensorsel.model.problem import ProblemInfo


def _position(lib: SensorLibrary, sensor_id: str) -> tuple[str, str]:
    s = lib[lib.position(sensor_id)]
    return s.model.name, s.position_label


def _print_greedy(res: CertifiedGreedyResult, lib: SensorLibrary) -> None:
    print_target(res.problem)
    unit = (res.problem or ProblemInfo).score_unit  # a recorded domain's score has no unit
    unit = f"_{unit}" if unit else ""
    rule = kept_label(res.rule, res.winning_rule)
    click.echo(f"budget     ${res.budget_usd:,.0f}   rule {rule}   engine {res.engine}{' (lazy)' if res.lazy else ''}")
    click.echo("")
    rows = []
    for k, st in enumerate(res.steps, 1):
        model, where = _position(lib, st.pick)
        rows.append([str(k), st.pick, model, where, f"{st.sensor_cost_usd:,.0f}", f"{st.gain:.3f}", f"{st.score:.3f}"])
    click.echo(table(rows, ["pick", "id", "model", "position", "cost_usd", f"gain{unit}", f"score{unit}"]))
    if not rows:
        click.echo("(empty suite)")
    click.echo("")
    click.echo(f"suite      {','.join(res.suite) or '(empty)'}  ({len(res.suite)} sensors)")
    owned = res.constraints is not None and res.constraints.owned
    click.echo(
        f"cost       ${res.cost_usd:,.0f} of ${res.budget_usd:,.0f}{' (owned sensors not counted)' if owned else ''}"
    )
    click.echo(f"score      {res.score:.3f}{unit.replace('_', ' ')}")
    click.echo(f"evaluated  {res.n_evaluations} suites in {res.seconds:.2f} s")
    click.echo(f"stopped    {res.stop_reason}")
    print_limits(lib, res.budget_usd, res.constraints, res.suite)
    if res.certificate is not None:
        click.echo(format_certificate(res.certificate))
    print_accuracy(res.accuracy, res.integrity)


def _print_breakdown(design: DomainDesign) -> None:
    click.echo(
        f"\nper route (the domain suite against each route's own {design.greedy.rule} design at the same budget):"
    )
    rows = [
        [
            r.name,
            f"{r.weight:.3f}",
            f"{r.score:.3f}",
            f"{r.share_of_best:.4f}",
            f"{r.own_score:.3f}",
            f"{r.share_of_own:.4f}",
            f"{r.own_cost_usd:,.0f}",
            compact_suite(r.own_suite),
        ]
        for r in design.routes
    ]
    click.echo(
        table(rows, ["route", "weight", "score_nats", "of_best", "own_nats", "of_own", "own_cost_usd", "own_suite"])
    )
    worst = next(r for r in design.routes if r.name == design.worst_route)
    click.echo(
        f"worst route {worst.name}: the domain suite reaches {worst.share_of_own:.1%} of what its own design "
        "reaches there"
    )
    conditions = by_condition(design)
    if conditions:
        click.echo("\nper condition (its members' shares, weighted):")
        rows = [
            [c.name, f"{c.weight:.3f}", f"{c.share_of_best:.4f}", f"{c.share_of_own:.4f}", c.worst_member]
            for c in conditions
        ]
        click.echo(table(rows, ["condition", "weight", "of_best", "of_own", "worst_member"]))


@click.command(
    "greedy", cls=Command, short_help="Greedy suite under a budget, with its certificate of near-optimality."
)
@design_options
@budget_option(required=True)
@rule_option("uniform")
@lazy_option
@output_option(help="Write the full result as JSON.")
@click.option(
    "--certificate/--no-certificate",
    "certify",
    default=True,
    show_default=True,
    help="Also bound the best possible score within the budget (at most one extra sweep of the library per pick) "
    "and print how close the suite is to it.",
)
@path_option(
    "--plot",
    "plot_path",
    help="With --domain: draw the per-route breakdown here (png, svg or pdf by its extension).",
)
@resume_option
@quality_options
@result_options
def greedy_cmd(
    budget: float,
    rule: str,
    lazy: bool,
    output: str | None,
    as_json: bool,
    certify: bool,
    quiet: bool,
    plot_path: str | None,
    resume: bool,
    **kw: Any,
) -> None:
    """Greedy sensor selection under a budget (the paper's Algorithm 1 and its cost-aware variants).

    Prints the suite in pick order with each pick's marginal gain, the cost, the score
    f(S) = log det L(S) - log det L(empty) [nats], why selection stopped, and a certificate: an
    upper bound on the score of any suite within the budget, so "at least X% of the best possible".
    A budget below the cheapest sensor is an error (exit status 2) naming the cheapest sensor.

    With --domain FILE, one suite for every route of an operating domain: the domain score is the
    weighted sum of each route's share of its best (--aggregate), and a per-route breakdown compares
    the suite with each route's own design at the same budget (--plot draws it).

    With -o FILE, a checkpoint FILE.checkpoint is written after each pick (and after the certificate
    and each route of the breakdown) and deleted once FILE is written; --resume goes on from it.
    """
    store = result_file(output, resume, "the checkpoint of -o FILE (FILE.checkpoint)")
    if plot_path:
        output_file(plot_path)
        plot_format(None, plot_path)
    inputs = design_from(kw)
    target = inputs.target
    if plot_path and target.kind != "domain":
        raise click.UsageError("--plot draws a domain's per-route breakdown: it goes with --domain FILE")
    require_domain(inputs.cluster, target)
    check_affordable(target.library, budget, constraints=inputs.constraints)
    bar, progress = progress_bar(quiet, f"greedy {rule}", phases=len(RULES[rule].component_rules))
    cert_bar, cert_progress = progress_bar(quiet or not certify, "certificate", after=bar)
    if resume and store.checkpoint is not None and not store.checkpoint.is_file():
        click.echo(f"sensorsel: note: no checkpoint {store.checkpoint}: starting from the first pick", err=True)
    how: dict[str, Any] = {
        **inputs.run_options,
        "lazy": lazy,
        "certify": certify,
        "progress": progress,
        "certify_progress": cert_progress,
        "checkpoint": store.checkpoint,
        "resume": resume,
    }
    design: DomainDesign | None = None  # a domain's: its greedy result and each route's share
    with inputs.running(bar, cert_bar):
        if target.kind == "domain":  # another result kind: the greedy result and each route's breakdown
            ev = cluster_evaluator(inputs.cluster, target, inputs.engine, inputs.aggregate)
            design = design_domain(target, budget, rule, aggregate=inputs.aggregate, evaluator=ev, **how)
            res = design.greedy
        else:
            res = run_greedy(target, budget, rule, **how)
    # the chosen suite's accuracy in metres (local evaluators: a cluster's routes answer scores only)
    res = inputs.with_quality(res)
    if design is not None:
        design = replace(design, greedy=res)
    out: CertifiedGreedyResult | DomainDesign = design if design is not None else res
    store.save(out)
    if design is not None and plot_path:
        from sensorsel.plotting import plot_domain_breakdown, save_figure, use_file_backend

        use_file_backend()
        save_figure(plot_domain_breakdown(design).figure, plot_path, close=True)

    def summary() -> None:
        _print_greedy(res, target.library)
        if design is not None:
            _print_breakdown(design)
        for path in (output, plot_path):
            if path:
                click.echo(f"wrote      {path}")

    echo_result(out, as_json, summary)


def _share(at: float) -> str:
    return "every keyframe" if at >= 1.0 else f"{100 * at:g}% of the keyframes"


def _by_suite(acceptance: Any, front: Any) -> list[Any]:
    """The acceptance point of each front architecture, in the front's order."""
    points = {tuple(p.suite): p for p in acceptance.points}
    return [points[tuple(a.suite)] for a in front]


def _arch_row(a: Architecture) -> list[str]:
    return [
        f"{a.cost_usd:,.0f}",
        f"{a.score:.3f}",
        f"{a.normalized:.4f}",
        str(a.n_sensors),
        "+".join(a.rules),
        compact_suite(a.suite),
    ]


@click.command("pareto", cls=Command, short_help="Cost-performance tradespace and its Pareto front (plot, CSV, JSON).")
@design_options
@click.option(
    "--budgets",
    default=None,
    metavar="B1,B2,...",
    help="Comma-separated budgets in dollars, e.g. 5000,27_000,$110000 (default: 14 log-spaced from the "
    "cheapest sensor to the whole library).",
)
@budget_option(
    multiple=True,
    help="A budget in dollars (110000, 110,000, $110,000 or 110_000); repeat it for several; adds to --budgets.",
)
@rules_option(",".join(DEFAULT_RULES))
@lazy_option
@map_sigma_option
@specification_options
@plots_folder_option(
    "Folder for pareto.<format>, architectures.csv, tradespace.json, and the front's accuracy: "
    "accuracy.json and pareto-accuracy.<format>.",
)
@resume_option
@result_options
def pareto_cmd(
    budgets: str | None,
    budget: tuple[float, ...],
    rules: str,
    lazy: bool,
    resume: bool,
    as_json: bool,
    quiet: bool,
    **kw: Any,
) -> None:
    """The cost-performance tradespace (the paper's Fig. 4): greedy runs over a grid of budgets,
    every intermediate architecture, and the Pareto front (lower cost, higher score).

    Writes the plot, a CSV of every architecture (cost, score, normalized score, selectors, suite,
    on-front flag) and the full result as JSON; prints the front and the cheapest architectures that
    reach 99% and 95% of the best score.

    --limit, --include, --exclude, --max-sensors and the library's slots hold at every budget (a
    budget sweep with the other limits fixed).

    The front's accuracy in metres (lateral 95 % error per suite; in the SLAM graph, or with
    --map-sigma in a prior map), and with a specification (--preset, --lateral, ..., --spec) which
    front suites meet it: the acceptable region of the front, drawn as cost against lateral error.
    """
    given_spec = specification_given(kw)
    grid = parse_budgets(budgets) if budgets is not None else None
    if budget:
        grid = tuple(sorted(set(grid or ()) | set(budget)))
    names = parse_rules(rules)
    out, fmt = plots_folder_from(kw)
    inputs = design_from(kw)
    problem, constraints = inputs.target, inputs.constraints
    routes = [r.name for r in problem.routes]
    specs = specification_from(kw, routes) if given_spec else None
    if not given_spec:
        for k in ("preset", "spec_path", "lateral", "longitudinal", "heading", "sigma", "at"):
            kw.pop(k, None)
    if grid:
        check_affordable(
            problem.library,
            max(grid),
            budget_option="--budgets" if budgets is not None else "--budget",
            constraints=constraints,
        )
    else:
        check_affordable(problem.library, float(problem.library.costs.sum()), constraints=constraints)
    bar, progress = progress_bar(quiet, "tradespace runs")
    with inputs.running(bar):  # with a cluster, each rule's chain of budgets is one task there
        res = run_tradespace(
            problem,
            grid,
            names,
            **inputs.run_options,
            lazy=lazy,
            aggregate=inputs.aggregate,
            progress=progress,
            executor=inputs.executor,
            outdir=out,
            resume=resume,
        )

    written = [results.save(res, out / "tradespace.json"), write_csv(res, out / "architectures.csv")]
    acceptance = None
    if res.architectures:
        from sensorsel.plotting import plot_front_accuracy, plot_tradespace, save_figure, use_file_backend

        use_file_backend()
        ax = plot_tradespace(res)
        written.insert(0, save_figure(ax.figure, out / f"pareto.{fmt}", close=True))
        acceptance = front_acceptance(
            problem,
            [(a.suite, a.cost_usd, a.score) for a in res.front],
            specs,
            map_sigma_m=inputs.map_sigma,
            engine=inputs.engine,
            estimate=inputs.estimate,
        )
        written.append(results.save(acceptance, out / "accuracy.json"))
        written.append(save_figure(plot_front_accuracy(acceptance).figure, out / f"pareto-accuracy.{fmt}", close=True))

    echo_result(res, as_json, lambda: _print_pareto(res, acceptance, specs, problem.library, written))
    if not res.architectures:
        sys.exit(2)


def _print_pareto(res: Any, acceptance: Any, specs: list[Any] | None, lib: SensorLibrary, written: list[Any]) -> None:
    """The tradespace's summary: its runs, the front with each suite's accuracy (and whether it meets
    ``specs``), the cheapest suites reaching 99 % and 95 % of the best, the limits, what was written."""
    print_target(res.problem)
    click.echo(
        f"runs       {len(res.runs)} ({', '.join(res.rules)} x {len(res.budgets_usd)} budgets "
        f"${res.budgets_usd[0]:,.0f}..${res.budgets_usd[-1]:,.0f}); engine "
        f"{res.engine}{' (lazy)' if res.lazy else ''}; "
        f"{res.n_evaluations} suites evaluated in {res.seconds:.1f} s"
    )
    click.echo(
        f"found      {len(res.architectures)} architectures, {len(res.front)} on the Pareto front; "
        f"best score {res.best_score:.3f} nats"
    )
    if not res.architectures:
        click.echo("every budget is below the cheapest sensor: nothing was bought", err=True)
        return
    click.echo("\nPareto front (cheapest first):")
    assert acceptance is not None
    rows = [
        _arch_row(a) + [f"{p.lateral_95_m:.3f}"] + ([] if p.meets is None else ["yes" if p.meets else "no"])
        for a, p in zip(res.front, _by_suite(acceptance, res.front))
    ]
    click.echo(
        table(
            rows,
            ["cost_usd", "score", "normalized", "n", "rules", "suite", "lateral95_m"]
            + ([] if specs is None else ["meets"]),
        )
    )
    click.echo(
        f"accuracy   {acceptance.model_label}; lateral95_m: the worst route's lateral 95 % error"
        + ("" if specs is None else f" at {_share(specs[0].at)}")
    )
    if specs is not None:
        best_ok = acceptance.cheapest_meeting
        click.echo(
            f"requires   {specs[0].describe()}"
            if len(set(specs)) == 1
            else "requires   per-route specifications (--spec)"
        )
        click.echo(
            f"acceptable {sum(bool(p.meets) for p in acceptance.points)} of {len(acceptance.points)} front suites; "
            + (
                f"the cheapest: ${best_ok.cost_usd:,.0f}, {','.join(best_ok.suite)}"
                if best_ok is not None
                else "none meets it (sensorsel require searches every suite, not only the front)"
            )
        )
    click.echo("")
    for frac in (0.99, 0.95):
        a = res.cheapest_reaching(frac)
        assert a is not None
        click.echo(
            f"cheapest reaching {frac:.0%} of the best: ${a.cost_usd:,.0f}, normalized {a.normalized:.4f}, "
            f"{a.n_sensors} sensors: {','.join(a.suite)}"
        )
    best = res.best
    assert best is not None
    click.echo(f"best: ${best.cost_usd:,.0f}, {best.n_sensors} sensors: {','.join(best.suite)}")
    print_limits(
        lib,
        res.budgets_usd[-1],
        res.constraints,
        best.suite,
        tail=" (at every budget); the best architecture uses, at the largest budget:",
    )
    click.echo("wrote " + ", ".join(str(w) for w in written))


COMMANDS = [greedy_cmd, pareto_cmd]
