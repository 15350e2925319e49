"""``sensorsel simulate``: Monte-Carlo SLAM of one or two suites, with failures, against the ground truth."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import click

from sensorsel.cli.common import read_suite, table
from sensorsel.cli.options import (
    check_map_sigma,
    cluster_from,
    cluster_options,
    force_option,
    jobs_option,
    plots_folder_from,
    plots_folder_option,
    prior_map_option,
    progress_bar,
    result_options,
    running,
    scenario_options,
    spec_from,
    suite_option,
)
from sensorsel.cli.vocabulary import Command
from sensorsel.errors import InputError
from sensorsel.io import results
from sensorsel.model.library import SensorLibrary
from sensorsel.model.problem import GraphSettings, Problem, load_problem


def _fmt(v: float | None, digits: int = 3) -> str:
    return "n/a" if v is None else f"{v:.{digits}f}"


@click.command("simulate", cls=Command, short_help="Monte-Carlo SLAM with GTSAM on one or two suites, with failures.")
@scenario_options
@suite_option(
    required=True,
    help='Comma-separated sensor ids, or a result JSON of `sensorsel greedy`/`resilient` (its "suite").',
)
@suite_option(
    "--compare",
    help="A second suite (same forms) simulated with the same noise and drawn beside the first.",
)
@click.option(
    "--label",
    default=None,
    help='Name of --suite in the table and plots (default: the result file\'s name, or "suite").',
)
@click.option(
    "--compare-label", default=None, help='Name of --compare (default: the result file\'s name, or "compare").'
)
@click.option(
    "--fail",
    "fail",
    default=None,
    metavar="ID[@FROM-TO],...",
    help="Failed sensors: ID for the whole route, ID@20-40 for keyframes 20..39, ID@30s-60s for a period in seconds. "
    "Applied to each simulated suite that has the sensor.",
)
@click.option(
    "--start-sigmas",
    default=None,
    metavar="X,Y,HEADING",
    help="Std of the prior on the first pose [m, m, rad] (default: the score's, 0.01,0.01,0.001). Its heading "
    "uncertainty turns the whole map about the start; make it small to see the design's own errors.",
)
@prior_map_option(
    "Simulate localization in a prior map whose landmarks are known to this std [m]: each run draws the map "
    "(every landmark off by that std) and adds a landmark prior there [default: the paper's SLAM, no landmark prior]."
)
@click.option("--runs", type=click.IntRange(min=1), default=20, show_default=True, help="Monte-Carlo runs.")
@click.option(
    "--solver",
    type=click.Choice(["lm", "isam2"]),
    default="lm",
    show_default=True,
    help="lm: batch Levenberg-Marquardt; isam2: incremental, keyframes in order.",
)
@click.option(
    "--seed", type=click.IntRange(min=0), default=0, show_default=True, help="Base seed; run r draws from (seed, r)."
)
@click.option(
    "--noise-scale",
    type=float,
    default=1.0,
    show_default=True,
    help="Factor on every noise sigma (odometry, prior, sensors).",
)
@jobs_option("Processes running the Monte-Carlo draws (results do not depend on it).")
@click.option(
    "--associate",
    is_flag=True,
    default=False,
    help="Instead of SLAM runs: run the associator (gated nearest neighbour on the NIS) on simulated measurements "
    "at every keyframe and set its wrong associations beside the predicted association risk (estimate and bound), "
    "with a calibration plot.",
)
@click.option(
    "--draws",
    type=int,
    default=2000,
    show_default=True,
    metavar="N",
    help="--associate: draws per keyframe (per measurement with --importance-sampling).",
)
@click.option(
    "--importance-sampling",
    "importance",
    is_flag=True,
    default=False,
    help="--associate: importance sampling (each measurement from a mixture of draws shifted toward its wrong "
    "candidates' decision boundaries, weighted by the likelihood ratio): reaches rare wrong associations.",
)
@click.option(
    "--clutter-per-km",
    "clutter_per_km",
    type=float,
    default=0.0,
    show_default=True,
    metavar="DENSITY",
    help="--associate: unmapped clutter objects per km of route (within the map's landmark corridor), detected "
    "by the suite's sensors and run through the associator.",
)
@click.option(
    "--gate-probability",
    "gate_probability",
    type=float,
    default=0.9999,
    show_default=True,
    metavar="P",
    help="--associate: the associator's chi-square gate probability (2 degrees of freedom).",
)
@cluster_options
@plots_folder_option(
    "Output folder: simulation.json (every run), trajectories, error_along_route and simulate plots "
    "(--associate: simulation.json and association_calibration).",
)
@force_option
@result_options
def simulate_cmd(
    suite: str,
    compare: str | None,
    label: str | None,
    compare_label: str | None,
    fail: str | None,
    start_sigmas: str | None,
    map_sigma: float | None,
    runs: int,
    solver: str,
    seed: int,
    noise_scale: float,
    jobs: int,
    associate: bool,
    draws: int,
    importance: bool,
    clutter_per_km: float,
    gate_probability: float,
    force: bool,
    as_json: bool,
    quiet: bool,
    **kw: Any,
) -> None:
    """Validate designs by running SLAM on them: N noisy Monte-Carlo runs solved with GTSAM.

    Prints pose, heading and landmark RMSE, the worst position error along the route, the errors the
    information matrix predicts, and the average NEES of the poses with its 95 % chi-square bounds;
    then the 95 % lateral, longitudinal and heading errors measured (95th percentile of |error| over
    the runs, per keyframe) beside those predicted (1.96σ), in the SLAM graph or with --map-sigma in a prior map;
    writes the plots and a JSON of every run to OUTPUT. With --scheduler/--workers each Monte-Carlo
    run is one Dask task (run r draws from (seed, r) wherever it runs: the same result).

    With --associate: no SLAM runs; the associator runs on --draws simulated measurements per keyframe
    (pose and map errors from the car's own predicted covariance, the sensors' noise, optional clutter),
    its wrong associations set beside the predicted risk, with a calibration plot. Each keyframe is one
    task (with --workers, one Dask task), drawn from (seed, keyframe) wherever it runs.
    """
    from sensorsel.plotting import (
        plot_error_along_route,
        plot_simulation_comparison,
        plot_simulation_overview,
        save_figure,
        use_file_backend,
    )
    from sensorsel.simulation import SimulationReport, parse_failures, simulate

    if not (math.isfinite(noise_scale) and noise_scale > 0):
        raise click.BadParameter(f"must be a positive number, got {noise_scale!r}", param_hint="--noise-scale")
    if compare_label is not None and compare is None:
        raise click.UsageError("--compare-label needs --compare")
    map_sigma = check_map_sigma(map_sigma)
    if associate:
        from sensorsel.simulation.association_run import check_association_args

        check_association_args(draws, seed, importance, clutter_per_km, gate_probability)
    else:
        for name, given in (
            ("--draws", draws != 2000),
            ("--importance-sampling", importance),
            ("--clutter-per-km", clutter_per_km != 0.0),
            ("--gate-probability", gate_probability != 0.9999),
        ):
            if given:
                raise click.UsageError(f"{name} needs --associate")
    out, fmt = plots_folder_from(kw)
    cluster = cluster_from(kw)
    settings = _settings(start_sigmas)
    spec = spec_from(kw)
    problem = load_problem(spec, kw.pop("library_path"), settings)
    lib = problem.library
    ignore = ("settings",) if start_sigmas is not None else ()  # --start-sigmas changes the first-pose prior on purpose
    designs = [read_suite(suite, lib, "--suite", problem, force, ignore)]
    if compare is not None:
        designs.append(read_suite(compare, lib, "--compare", problem, force, ignore))
    designs = _labelled(designs, label, compare_label)
    failures = parse_failures(fail, problem) if fail else ()
    _check_failures(designs, failures, lib, fail)
    if associate:
        if failures:
            raise click.UsageError("--fail with --associate: the association check runs the suite as given")
        _associate(
            problem,
            designs,
            cluster,
            map_sigma,
            draws,
            seed,
            importance,
            clutter_per_km,
            gate_probability,
            out,
            fmt,
            as_json,
            quiet,
        )
        return

    sims = []
    with running(cluster):
        executor = cluster.executor if cluster is not None else None  # with a cluster, each run is one task there
        for positions, name, _ in designs:
            ids = set(lib.suite_ids(positions))
            mine = tuple(f for f in failures if f.sensor in ids)
            bar, progress = progress_bar(quiet, f"simulating {name}")
            with running(bar):
                res = simulate(
                    problem,
                    positions,
                    failures=mine,
                    runs=runs,
                    solver=solver,
                    seed=seed,
                    noise_scale=noise_scale,
                    jobs=jobs,
                    label=name,
                    progress=progress,
                    executor=executor,
                    map_sigma_m=map_sigma,
                )
            sims.append(res)

    report = SimulationReport(tuple(sims))
    json_path = results.save(report, out / "simulation.json")
    sc = problem.scenario
    paths = [json_path]
    use_file_backend()
    axes = plot_simulation_comparison(sims, sc)
    paths.append(save_figure(axes[0].figure, out / f"trajectories.{fmt}", close=True))
    ax = plot_error_along_route(sims, sc)
    paths.append(save_figure(ax.figure, out / f"error_along_route.{fmt}", close=True))
    paths.append(save_figure(plot_simulation_overview(sims, sc), out / f"simulate.{fmt}", close=True))

    if as_json:
        click.echo(results.dumps(report), nl=False)
        return
    _print_report(sims, sc, runs, solver, seed, noise_scale, start_sigmas, settings)
    t = sum(s.timing.total_s for s in sims if s.timing)
    click.echo(f"time      {t:.1f} s ({jobs} job{'s' if jobs > 1 else ''})")
    for p in paths:
        click.echo(f"wrote     {p}")


COMMANDS = [simulate_cmd]


def _associate(
    problem: Problem,
    designs: list[Design],
    cluster: Any,
    map_sigma: float | None,
    draws: int,
    seed: int,
    importance: bool,
    clutter_per_km: float,
    gate_probability: float,
    out: Path,
    fmt: str,
    as_json: bool,
    quiet: bool,
) -> None:
    """``simulate --associate``: the association check of each design, its JSON, plot and printout."""
    from sensorsel.plotting import plot_association_calibration, save_figure, use_file_backend
    from sensorsel.simulation import SimulationReport
    from sensorsel.simulation.association_run import simulate_association

    checks = []
    with running(cluster):
        executor = cluster.executor if cluster is not None else None
        for positions, name, _ in designs:
            bar, progress = progress_bar(quiet, f"associating {name}")
            with running(bar):
                checks.append(
                    simulate_association(
                        problem,
                        positions,
                        map_sigma_m=map_sigma,
                        draws=draws,
                        seed=seed,
                        gate_probability=gate_probability,
                        importance=importance,
                        clutter_per_km=clutter_per_km,
                        label=name,
                        executor=executor,
                        progress=progress,
                    )
                )
    report = SimulationReport(associations=tuple(checks))
    paths = [results.save(report, out / "simulation.json")]
    use_file_backend()
    for i, c in enumerate(checks):
        suffix = "" if i == 0 else "_compare"
        paths.append(
            save_figure(
                plot_association_calibration(c).figure, out / f"association_calibration{suffix}.{fmt}", close=True
            )
        )
    if as_json:
        click.echo(results.dumps(report), nl=False)
        return
    sc = problem.scenario
    click.echo(f"{'scenario':<9} {sc.name}: {sc.n_poses} keyframes, {sc.n_landmarks} landmarks ({sc.landmark_source})")
    for c in checks:
        _print_association(c)
    for p in paths:
        click.echo(f"wrote     {p}")


def _p(x: float) -> str:
    return "n/a" if not math.isfinite(x) else ("0" if x == 0 else f"{x:.3g}")


def _print_association(c: Any) -> None:
    """One design's association check: the route's rates, the calibration bins, the sensors, the worst keyframes."""
    from sensorsel.api import gate_of, model_label

    click.echo("")
    click.echo(
        f"{c.label:<9} {','.join(c.suite)}: gated nearest neighbour on the NIS, gate p_G {c.gate_probability:g} "
        f"(chi2_2 {gate_of(c.gate_probability):.2f}), {model_label(c.model, c.map_sigma_m)}"
    )
    click.echo(f"sampling  {c.draws} draws per keyframe, seed {c.seed}; {c.sampling}")
    if c.clutter_per_km > 0:
        clut = [k.observed_clutter for k in c.keyframes]
        click.echo(
            f"clutter   {c.clutter_per_km:g} unmapped objects per km within {c.corridor_m:.1f} m of the route: "
            "P(a clutter detection matched to a landmark) per keyframe mean "
            f"{_p(float(sum(clut) / max(1, len(clut))))}, "
            f"worst {_p(max(clut, default=0.0))} (not in the prediction)"
        )
    click.echo(
        f"per hour  wrong associations at {c.keyframes_per_hour:.0f} keyframes/h: predicted {_p(c.predicted_per_hour)} "
        f"(estimate), {_p(c.bound_per_hour)} (bound); observed {_p(c.observed_per_hour)}"
    )
    click.echo(
        f"calibration  {c.resolved} keyframes resolved by the draws: estimate within 2x of the observed at "
        f"{c.within_factor_2}; bound below the observed 99% lower limit at {c.bound_below_lower} of "
        f"{len(c.keyframes)} keyframes"
    )
    rows = [
        [
            f"[{b.lo:.0e}, {b.hi:.0e})",
            str(b.keyframes),
            _p(b.predicted),
            _p(b.bound),
            _p(b.observed),
            f"[{_p(b.ci_low)}, {_p(b.ci_high)}]",
        ]
        for b in c.bins
    ]
    click.echo(table(rows, ["predicted bin", "keyframes", "estimate", "bound", "observed", "99% CI"]))
    click.echo("")
    rows = [[s.sensor, _p(s.predicted_per_keyframe), _p(s.observed_per_keyframe)] for s in c.sensors]
    click.echo(table(rows, ["sensor", "predicted wrong/keyframe", "observed wrong/keyframe"]))
    click.echo("")
    worst = sorted(c.keyframes, key=lambda k: (-k.predicted_bound, k.keyframe))[:5]
    rows = [
        [
            str(k.keyframe),
            str(k.n_measurements),
            _p(k.predicted_estimate),
            _p(k.predicted_bound),
            _p(k.observed),
            f"{_p(k.shift_lateral_m)} / {_p(k.shift_longitudinal_m)} / {_p(k.shift_heading_deg)}",
            _p(k.p_beyond_alert),
        ]
        for k in worst
    ]
    click.echo(
        table(
            rows,
            [
                "keyframe",
                "measurements",
                "estimate",
                "bound",
                "observed",
                "shift lat m / lon m / hdg deg",
                "P(beyond alert)",
            ],
        )
    )
    click.echo(
        "shift: mean largest shift of the pose estimate a wrong association causes, by " + c.shift + ";\n"
        "P(beyond alert): P(it shifts the estimate past 0.29 m lateral, 0.29 m longitudinal or 0.5 deg heading)."
    )


def _settings(start_sigmas: str | None) -> GraphSettings:
    """The graph settings of the simulation: the default, or --start-sigmas X,Y,HEADING as the first-pose prior."""
    if start_sigmas is None:
        return GraphSettings()
    try:
        sig = tuple(float(v) for v in start_sigmas.split(","))
    except ValueError:
        raise click.BadParameter(
            f"expected three numbers X,Y,HEADING, got {start_sigmas!r}", param_hint="--start-sigmas"
        ) from None
    if len(sig) != 3 or not all(math.isfinite(v) and v > 0 for v in sig):
        raise click.BadParameter(
            f"expected three positive numbers X,Y,HEADING, got {start_sigmas!r}", param_hint="--start-sigmas"
        )
    return GraphSettings(first_pose_sigmas=(sig[0], sig[1], sig[2]))


Design = tuple[tuple[int, ...], str, tuple[str, ...]]  # (positions, label, sensors the source assumed to fail)


def _labelled(designs: list[Design], label: str | None, compare_label: str | None) -> list[Design]:
    """The designs with --label/--compare-label applied, and two equal labels told apart."""
    for i, name in enumerate((label, compare_label)[: len(designs)]):
        if name is not None:
            if not name.strip():
                raise click.BadParameter("must not be empty", param_hint="--label" if i == 0 else "--compare-label")
            designs[i] = (designs[i][0], name.strip(), designs[i][2])
    if len(designs) == 2 and designs[0][1] == designs[1][1]:
        designs = [
            (designs[0][0], designs[0][1] + " (suite)", designs[0][2]),
            (designs[1][0], designs[1][1] + " (compare)", designs[1][2]),
        ]
    return designs


def _check_failures(designs: list[Design], failures: tuple[Any, ...], lib: SensorLibrary, fail: str | None) -> None:
    """Notes for a failure a design does not have or a failure a design assumed but is not simulated;
    an error when no design has any of the failed sensors."""
    named = {f.sensor for f in failures}
    for positions, name, assumed in designs:
        ids = set(lib.suite_ids(positions))
        missing = sorted(named - ids)
        if missing:
            click.echo(f"note: {name} has no {', '.join(missing)}: that failure does not apply to it", err=True)
        if assumed and not set(assumed) <= named:
            click.echo(
                f"note: {name} assumes {', '.join(assumed)} fail(s); add --fail {','.join(assumed)} to simulate that",
                err=True,
            )
    if named and not any(named & set(lib.suite_ids(p)) for p, _, _ in designs):
        raise InputError(f"--fail {fail!r}: no simulated suite has {', '.join(sorted(named))}")


def _print_report(
    sims: list[Any],
    sc: Any,
    runs: int,
    solver: str,
    seed: int,
    noise_scale: float,
    start_sigmas: str | None,
    settings: GraphSettings,
) -> None:
    """The simulation table: errors, their predictions, NEES and consistency, one row per design."""
    click.echo(f"{'scenario':<9} {sc.name}: {sc.n_poses} keyframes, {sc.n_landmarks} landmarks ({sc.landmark_source})")
    from sensorsel.api import model_label

    click.echo(
        f"runs      {runs} per suite, solver {solver}, seed {seed}, "
        f"{model_label(sims[0].model, sims[0].map_sigma_m) if sims else ''}"
        + (f", noise x{noise_scale:g}" if noise_scale != 1 else "")
        + (
            ""
            if start_sigmas is None
            else f", first-pose prior sigmas {','.join(f'{v:g}' for v in settings.first_pose_sigmas)}"
        )
    )
    w = max(9, *(len(s.label) for s in sims))
    for s in sims:
        click.echo(
            f"{s.label:<{w}} {','.join(s.suite) or '(no sensor)'}  (${s.cost_usd:,.0f}); "
            f"{s.n_measurements} measurements/run ({s.n_measurements_failed} lost to failures), "
            f"{len(s.unmeasured_landmarks)} landmarks never measured"
        )
    click.echo("")
    rows = []
    for s in sims:
        lo_c, hi_c = s.nees_bounds_correlated
        lo, hi = s.nees_bounds
        rows.append(
            [
                s.label,
                ",".join(f.describe(sc.n_poses) for f in s.failures) or "-",
                f"{s.position_rmse_m:.3f}",
                f"{s.predicted_position_rmse_m:.3f}",
                f"{math.degrees(s.heading_rmse_rad):.4f}",
                f"{math.degrees(s.predicted_heading_rmse_rad):.4f}",
                _fmt(s.landmark_rmse_m),
                _fmt(s.predicted_landmark_rmse_m),
                f"{s.max_position_error_m:.3f}",
                f"{s.initial_position_rmse_m:.2f}",
                f"{s.nees_mean:.2f} [{lo_c:.2f},{hi_c:.2f}]",
                f"{s.nees_joint_mean:.2f} [{lo:.2f},{hi:.2f}]",
                "yes" if s.nees_joint_inside_bounds else "NO",
            ]
        )
    click.echo(
        table(
            rows,
            [
                "design",
                "failed",
                "pos_rmse_m",
                "pred_m",
                "hdg_rmse_deg",
                "pred_deg",
                "lm_rmse_m",
                "pred_m",
                "max_pos_err_m",
                "dead_reck_m",
                "nees/pose [95%]",
                "joint_nees [95%]",
                "consistent",
            ],
        )
    )
    click.echo("")
    click.echo(
        "pred: predicted by the information matrix at the truth; dead_reck: RMSE of the dead-reckoned start.\n"
        "nees/pose: average 3-dof pose NEES (expect 3), 95 % bounds allowing for the correlation of "
        "poses along the route;\n"
        "joint_nees: NEES of the whole trajectory / K, exact 95 % chi-square bounds; consistent: "
        "joint_nees inside them."
    )
    _print_accuracy(sims)


def _print_accuracy(sims: list[Any]) -> None:
    """Predicted against measured 95 % errors, per design and component (median / 95th pct / worst keyframe)."""
    from sensorsel.api import estimate_label, model_label

    checked = [s for s in sims if s.accuracy is not None]
    if not checked:
        return
    click.echo("")
    click.echo(
        "predicted vs measured 95 % errors in each keyframe's frame, "
        f"{model_label(checked[0].model, checked[0].map_sigma_m)}, "
        f"{estimate_label('smoother')}: each run solves the whole route"
    )
    rows = []
    for s in checked:
        for comp, unit, d in (("lateral", "m", 3), ("longitudinal", "m", 3), ("heading", "deg", 3)):
            p, m = s.accuracy.spread("predicted", comp), s.accuracy.spread("measured", comp)
            cov = dict(s.accuracy.coverage)[comp]
            rows.append(
                [
                    s.label,
                    f"{comp} [{unit}]",
                    f"{p.median:.{d}f} / {p.p95:.{d}f} / {p.max:.{d}f}",
                    f"{m.median:.{d}f} / {m.p95:.{d}f} / {m.max:.{d}f}",
                    f"{100 * cov:.1f} %",
                ]
            )
    click.echo(
        table(
            rows,
            [
                "design",
                "component",
                "predicted 1.96σ (median / p95 / worst)",
                "measured (median / p95 / worst)",
                "inside ±1.96σ",
            ],
        )
    )
    click.echo("")
    click.echo(
        "measured: per keyframe the 95th percentile of |error| over the runs (x forward = longitudinal, y left = "
        "lateral),\n"
        "then over the keyframes median / 95th percentile / worst; inside ±1.96σ: share of all (run, keyframe) errors\n"
        "inside the predicted 95 % bound (expect 95 %). With few runs the per-keyframe 95th percentile is noisy."
    )
