"""``sensorsel require``: the cheapest suite that meets a specification in metres."""

from __future__ import annotations

import sys
from dataclasses import replace
from typing import Any

import click

from sensorsel.api import (
    DEFAULT_MAP_SIGMA_M,
    RequireResult,
    RouteRequirement,
    integrity_preset,
    run_require,
)
from sensorsel.cli.cluster import cluster_evaluator, require_domain
from sensorsel.cli.common import echo_result, print_target, read_suite, specification_from, specification_options
from sensorsel.cli.integrity import INTEGRITY_KEYS, integrity_from, integrity_options
from sensorsel.cli.options import (
    budget_option,
    check_map_sigma,
    design_from,
    design_options,
    estimate_option,
    failures_option,
    output_option,
    path_option,
    plot_format,
    prior_map_option,
    progress_bar,
    result_file,
    result_options,
    resume_option,
    suite_option,
    time_limit_option,
)
from sensorsel.cli.vocabulary import Command
from sensorsel.errors import InputError
from sensorsel.io.files import output_file


@click.command(
    "require",
    cls=Command,
    short_help="The cheapest suite that meets an accuracy specification in metres, with a proof.",
)
@design_options(aggregate=False)
@specification_options
@prior_map_option(
    f"Accuracy in a prior map whose landmarks are known to this std [m] (default: {DEFAULT_MAP_SIGMA_M:g} m, "
    "an assumption: see the requirements guide)."
)
@click.option(
    "--slam", is_flag=True, help="Judge accuracy in the paper's SLAM graph (landmarks unknown) instead of a prior map."
)
@estimate_option
@click.option(
    "--integrity",
    "integrity_flag",
    is_flag=True,
    help="Also demand integrity on every route: P(error beyond an alert limit) per hour within --integrity-risk "
    "(the preset's alert limits, Reid et al.: local-streets 0.29 m, 0.29 m, 0.50 deg; freeway 0.57 m, "
    "1.40 m, 1.50 deg; 1e-8 per hour). Any integrity option given demands it too.",
)
@integrity_options
@click.option(
    "--in",
    "in_conditions",
    default=None,
    metavar="C1,C2,...",
    help="With a --domain that has conditions: demand the specification only in these conditions "
    "(e.g. clear,rain); (default: in every condition).",
)
@click.option(
    "--margin",
    "margin_text",
    default=None,
    metavar="PERCENT",
    help="Demand the specification with this much of each limit to spare, e.g. 10% (every error within 90 % "
    "of its limit); default 0.",
)
@failures_option(
    "The suite must still meet the specification after any this many of its sensors fail.", default=0, dest="failures"
)
@budget_option(help="Most the suite may cost, in dollars (default: no budget: the cheapest suite is the question).")
@time_limit_option("Stop the exact search after this long and report the gap (default: run until proved).")
@path_option(
    "--plot",
    "plot_path",
    help="Draw the errors along the route with the requirement, and the route coloured by its margin "
    "(png, svg or pdf by the extension; a domain: its route with the least margin).",
)
@suite_option(
    "--compare",
    help="With --plot: a suite to draw beside the answer (ids, or a result file such as greedy's -o).",
)
@output_option(
    help="Write the result as JSON (also when no suite meets the specification); the search's answers are "
    "journalled in FILE.checkpoint as they come (deleted once FILE is written, kept when the search "
    "stopped at --time-limit: --resume goes on from it)."
)
@resume_option
@result_options
def require_cmd(
    map_sigma: float | None,
    slam: bool,
    estimate: str,
    in_conditions: str | None,
    margin_text: str | None,
    failures: int,
    budget: float | None,
    time_limit: float | None,
    plot_path: str | None,
    compare: str | None,
    output: str | None,
    resume: bool,
    as_json: bool,
    quiet: bool,
    integrity_flag: bool,
    **kw: Any,
) -> None:
    """The cheapest suite that meets an accuracy specification, on a route or every route of a
    domain (--domain), with a lower bound on the cost of ANY suite that meets it: the answer is
    proved optimal, or the gap is stated.

    The specification bounds the car's lateral and longitudinal position error [m] and heading error
    [deg] (95 % bounds unless --sigma) at every keyframe (or --at PERCENT of them), from the marginal
    covariance of each pose. Accuracy is judged localizing in a prior map whose landmarks are known to
    --map-sigma (default 0.05 m), or with --slam in the paper's SLAM graph (landmarks unknown,
    uncertainty growing from the first pose). The accuracy judged is the filter's (--estimate filter,
    the default: at each keyframe from the measurements up to it, what the car has as it drives), or
    with --estimate smoother the smoother's (from the whole route: optimistic before its last keyframe).

    A specification no suite meets is an error (exit status 2) naming the best any suite reaches and
    where it fails; with -o or --json that diagnosis is still written.
    """
    if slam and map_sigma is not None:
        raise click.UsageError("--slam judges accuracy without a map: drop --map-sigma")
    map_sigma = check_map_sigma(DEFAULT_MAP_SIGMA_M if map_sigma is None else map_sigma)
    store = result_file(output, resume, "the journal of -o FILE (FILE.checkpoint)")
    if compare and not plot_path:
        raise click.UsageError("--compare draws a second suite on --plot: give --plot FILE")
    if plot_path:
        output_file(plot_path)
        plot_format(None, plot_path)
    margin = parse_margin(margin_text)
    integrity = _integrity_from(kw, integrity_flag)
    landmarks_given = tuple(kw.get("landmarks") or ())
    inputs = design_from(kw)
    target, cluster = inputs.target, inputs.cluster
    # a route's own problem (a domain file names its landmarks: none invented, no route to compare on)
    route = target.routes[0].problem if target.kind == "route" else None
    if (
        route is not None
        and route.scenario.landmark_source.startswith("generated")
        and "synthetic" not in landmarks_given
    ):
        raise InputError(
            f"route {route.scenario.name} has no landmark file: a proof on invented landmarks signs nothing; "
            "give --landmarks FILE, a map (--landmarks osm:FILE), or --landmarks synthetic to accept invented ones"
        )
    require_domain(cluster, target)
    routes = [r.name for r in target.routes]
    specs = specification_from(kw, routes)
    if margin:
        specs = [replace(sp, margin=margin) for sp in specs]
    compared = None
    if compare:
        positions, label, _ = read_suite(compare, target.library, "--compare", route)
        compared = (label, positions)
    bar, progress = progress_bar(
        quiet or as_json, "searching", counted=False
    )  # the count is only a cap: the text says what is left
    with inputs.running(bar):
        # on a cluster each route's accuracy checks run on its worker's actor (the same bytes)
        ev = cluster_evaluator(cluster, target, inputs.engine, "normalised")
        res = run_require(
            target,
            specs,
            map_sigma_m=None if slam else map_sigma,
            failures=failures,
            budget_usd=budget,
            **inputs.run_options,
            time_limit_s=time_limit,
            progress=progress,
            checkpoint=store.checkpoint,
            resume=resume,
            evaluator=ev,
            conditions=None if in_conditions is None else [c.strip() for c in in_conditions.split(",") if c.strip()],
            estimate=estimate,
            integrity=integrity,
        )
    # a search stopped at its time limit keeps its journal: --resume goes on towards the proof
    store.save(res, unfinished=res.status == "gap")
    if plot_path:
        _plot(
            res,
            target,
            compared,
            plot_path,
            map_sigma_m=None if slam else map_sigma,
            engine=inputs.engine,
            estimate=estimate,
        )
    echo_result(res, as_json, lambda: _print(res))
    if res.status == "infeasible":
        click.echo(f"sensorsel: error: {_infeasible_line(res)}", err=True)
        sys.exit(2)
    if not res.suite and res.status == "gap":
        click.echo(
            f"sensorsel: error: the search stopped ({res.stop}) before finding a suite that meets the specification "
            f"(none costs less than ${res.lower_bound_usd:,.0f}): give a longer --time-limit",
            err=True,
        )
        sys.exit(2)


def parse_margin(text: str | None) -> float:
    """--margin "10%" (or "10") -> 0.10; an InputError naming the option for anything else."""
    if text is None:
        return 0.0
    raw = text.strip().removesuffix("%").strip()
    try:
        value = float(raw)
    except ValueError:
        raise InputError(f"--margin {text}: expected a percentage of each limit to spare, e.g. 10%") from None
    if not (0.0 <= value < 100.0):  # also refuses nan
        raise InputError(f"--margin {text}: the share of each limit to spare must be at least 0 % and below 100 %")
    return value / 100.0


def _integrity_from(kw: dict[str, Any], flag: bool) -> Any:
    """The integrity demanded (an IntegritySpec) or None: --integrity, or any integrity option given
    on the command line; the limits not given are the --preset's (local streets' without one)."""
    from click.core import ParameterSource

    ctx = click.get_current_context()
    given = {k for k in INTEGRITY_KEYS if ctx.get_parameter_source(k) not in (ParameterSource.DEFAULT, None)}
    spec = integrity_from(kw)  # also checks every value, naming the option
    if not (flag or given):
        return None
    base = integrity_preset(kw.get("preset"))
    fields = {
        "integrity_risk": "integrity_risk",
        "alert_lateral": "alert_lateral_m",
        "alert_longitudinal": "alert_longitudinal_m",
        "alert_heading": "alert_heading_deg",
    }
    return replace(spec, **{f: getattr(base, f) for k, f in fields.items() if k not in given})


def _spec_line(routes: tuple[RouteRequirement, ...]) -> str:
    specs = {r.specification.describe() for r in routes}
    if len(specs) == 1:
        return specs.pop()
    return "; ".join(f"{r.route}: {r.specification.describe()}" for r in routes)


def _print(res: RequireResult) -> None:
    print_target(res.problem)
    click.echo(f"requires   {_spec_line(res.routes)}")
    if res.integrity is not None:
        i = res.integrity
        click.echo(
            f"integrity  required: at most {i.integrity_risk:g} per hour beyond the alert limits "
            f"{i.alert_lateral_m:g} m "
            f"lateral, {i.alert_longitudinal_m:g} m longitudinal, {i.alert_heading_deg:g} deg, on every route"
        )
    click.echo(f"model      {res.model_label}")
    if res.failures:
        click.echo(f"failures   still met after any {res.failures} sensor(s) fail")
    if res.status == "infeasible":
        click.echo("suite      none: no suite within the limits meets the specification")
        what = {"failures": "after the worst failures, every allowed sensor together reaches:"}.get(
            res.infeasible_by, "every allowed sensor together reaches:"
        )
        if res.integrity_alone:
            what = (
                f"{len(res.integrity_alone)} allowed sensor(s) break integrity alone (their association risk alone "
                f"exceeds it); {what.replace('every allowed sensor', 'every other allowed sensor')}"
            )
        click.echo(f"best       {what}")
        _print_routes(res.routes)
        _print_integrity(res)
        return
    if not res.suite:
        click.echo(f"suite      none found before the search stopped ({res.stop})")
        return
    invented = (
        f"  on INVENTED landmarks (--landmarks synthetic: route {', '.join(res.synthetic_landmarks)})"
        if res.synthetic_landmarks
        else ""
    )
    click.echo(
        f"suite      {','.join(res.suite) or '(empty: odometry alone meets it)'}  ({len(res.suite)} sensors){invented}"
    )
    if res.status == "optimal":
        click.echo(
            f"cost       ${res.cost_usd:,.0f}: proved the cheapest (no suite that meets the specification costs less)"
        )
    else:
        click.echo(
            f"cost       ${res.cost_usd:,.0f}; no suite that meets it costs less than ${res.lower_bound_usd:,.0f} "
            f"(gap ${res.gap_usd:,.0f}: the search stopped at its time limit)"
        )
    _print_routes(res.routes)
    _print_integrity(res)
    if res.margin is not None:
        click.echo(f"margin     {res.margin.line()}")
    click.echo(f"ties       {_ties_line(res)}")
    if res.worst_failure:
        click.echo(f"worst failure  {','.join(res.worst_failure)}: then")
        _print_routes(res.worst_failure_routes)
    click.echo(
        f"searched   {res.iterations} integer programs ({res.seconds_programs:.2f} s)"
        + (f" and {res.plateau_swaps} plateau swaps" if res.plateau_swaps else "")
        + f", {res.n_checks} accuracy "
        f"computations ({res.seconds_checks:.2f} s; {res.n_refuted} more suites refuted by a cheap bound"
        + (f", {res.n_accepted} accepted by an upper bound" if res.n_accepted else "")
        + f"), {res.seconds:.2f} s in all"
        + (
            f"; resumed from {res.n_resumed} answers of an earlier run, not counted here"
            + (f", and {res.n_programs_resumed} of its integer programs' solutions" if res.n_programs_resumed else "")
            if res.n_resumed
            else ""
        )
    )


def _ties_line(res: RequireResult) -> str:
    """The equal-cost suites that also meet it, or that none was found and how far the search looked."""
    cost = f"${res.cost_usd:,.0f}"
    looked = (
        f"the search ran out of suites of {cost}"
        if res.ties_exhaustive
        else f"looked at {res.tie_programs} more integer programs' suites of {cost}, not all of them"
    )
    if not res.ties:
        return (
            "none: no other suite of " + cost + " meets it (" + looked + ")"
            if res.ties_exhaustive
            else f"none found ({looked})"
        )
    shown = "; ".join(",".join(t) for t in res.ties[:4]) + (
        f"; ... ({len(res.ties)} in all)" if len(res.ties) > 4 else ""
    )
    return f"{len(res.ties)} other suite(s) of {cost} also meet it: {shown} ({looked})"


def _print_integrity(res: RequireResult) -> None:
    for r in res.integrity_routes:
        click.echo(f"  {r.route:<10} integrity {r.line()}")


def _print_routes(routes: tuple[RouteRequirement, ...]) -> None:
    for r in routes:
        spec = r.specification
        unit = "1σ" if spec.sigma else "95%"
        parts = []
        for comp, err, bound, bad in r.verdict.worst:
            mark = "ok" if err <= bound else f"FAILS at {len(bad)} keyframes"
            u = "deg" if comp == "heading" else "m"
            parts.append(f"{comp} {err:.3f} {u} of {bound:g} ({mark})")
        where = "every keyframe" if spec.at >= 1.0 else f"{100 * spec.at:g}% of keyframes"
        click.echo(f"  {r.route:<10} {unit} error at {where}: " + ", ".join(parts))


def _plot(
    res: RequireResult,
    target: Any,
    compared: tuple[str, tuple[int, ...]] | None,
    path: str,
    *,
    map_sigma_m: float | None,
    engine: str | None,
    estimate: str,
) -> None:
    """The errors along the route (the answer, and ``compared``) with the requirement, and the route
    coloured by the answer's margin; a domain: the route with the least margin."""
    import matplotlib.pyplot as plt

    from sensorsel.api import suite_accuracy
    from sensorsel.plotting import plot_accuracy_along_route, plot_route_margin, save_figure, use_file_backend

    use_file_backend()
    r = max(
        range(len(res.routes)),
        key=lambda i: (res.routes[i].verdict.violation, max(e / b for _, e, b, _ in res.routes[i].verdict.worst)),
    )
    route = res.routes[r]
    problem = target.routes[r].problem
    label = f"{'best any suite reaches' if res.status == 'infeasible' else 'the answer'} (${res.cost_usd:,.0f})"
    lines = [(label, route.accuracy)]
    if compared is not None:
        acc = suite_accuracy(problem, compared[1], map_sigma_m=map_sigma_m, engine=engine, estimate=estimate)[0]
        cost = problem.library.cost(compared[1])
        lines.append((f"{compared[0]} (${cost:,.0f})", acc))
    comps = [c for c, _, _ in route.specification.bounds()]
    fig = plt.figure(figsize=(13.0, 3.2 * max(2, len(comps))), layout="constrained")
    grid = fig.add_gridspec(len(comps), 2, width_ratios=(1.4, 1.0))
    for i, comp in enumerate(comps):
        plot_accuracy_along_route(
            lines, problem.scenario, route.specification, ax=fig.add_subplot(grid[i, 0]), component=comp
        )
    ax = plot_route_margin(route.accuracy, problem.scenario, route.specification, ax=fig.add_subplot(grid[:, 1]))
    ax.set_title(f"route {route.route}: margin of the answer", fontsize=10)
    fig.suptitle(f"{route.specification.describe()} - {res.model_label}", fontsize=10)
    save_figure(fig, path, close=True)


#: routes named in the one-line infeasible message (the worst first; the rest are in the JSON)
WORST_ROUTES_NAMED = 3


def _infeasible_line(res: RequireResult) -> str:
    """One line a person can read: how many routes miss, the worst few (by how far they miss) with
    their failing components, and where the rest are."""
    missing = sorted((r for r in res.routes if not r.verdict.meets), key=lambda r: -r.verdict.violation)
    fails = [f"route {r.route}: {r.verdict.failing().replace('; ', ', ')}" for r in missing[:WORST_ROUTES_NAMED]]
    if len(res.routes) > 1 and missing:
        more = len(missing) - len(fails)
        fails = [
            f"{len(missing)} of {len(res.routes)} routes miss it, the worst {r}" if i == 0 else r
            for i, r in enumerate(fails)
        ] + ([f"and {more} more route(s): every route in the JSON (--json, -o)"] if more else [])
    if res.infeasible_by == "failures":
        return (
            f"no suite meets the specification after {res.failures} failure(s): every allowed sensor together, after "
            "its worst failures, misses it (" + "; ".join(fails) + ")"
        )
    if res.integrity is not None and res.infeasible_by != "failures":
        worst = max(res.integrity_routes, key=lambda r: r.integrity_risk_per_hour, default=None)
        others = "every other allowed sensor" if res.integrity_alone else "every allowed sensor"
        alone = f"{len(res.integrity_alone)} allowed sensor(s) break it alone; " if res.integrity_alone else ""
        where = (
            f"{alone}{others} together: integrity {worst.integrity_risk_per_hour:.2g}/h on route {worst.route}"
            if worst is not None
            else alone
        )
        return (
            f"no suite within the limits meets the specification with integrity {res.integrity.integrity_risk:g}/h "
            f"(a sensor added can break integrity: the search ruled out every suite; {where}"
            + ("; " + "; ".join(fails) if fails else "")
            + ")"
        )
    if not fails:
        return (
            "no suite within the limits meets the specification (every allowed sensor together would: "
            "the limits --budget/--limit/--max-sensors/slots rule it out)"
        )
    return "no suite meets the specification even with every allowed sensor: " + "; ".join(fails)


COMMANDS = [require_cmd]
