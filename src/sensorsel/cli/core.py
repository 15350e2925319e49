"""Core commands: ``library``, ``score``, ``scene``."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from typing import Any

import click

from sensorsel.api import score_domain_suite, score_suite, suite_integrity
from sensorsel.cli.cluster import cluster_evaluator, require_domain
from sensorsel.cli.common import (
    echo_result,
    echo_written,
    is_result_file,
    print_accuracy,
    print_target,
    read_suite,
    table,
    usage_table,
)
from sensorsel.cli.options import (
    design_from,
    design_options,
    force_option,
    library_option,
    output_option,
    path_option,
    plot_format_option,
    problem_from,
    quality_options,
    result_options,
    scenario_options,
    spec_from,
    suite_option,
)
from sensorsel.cli.options import plot_format as plot_format_of
from sensorsel.cli.vocabulary import Command
from sensorsel.errors import InputError
from sensorsel.model.constraints import FeasibleSet, feasible_set
from sensorsel.model.library import SensorLibrary, load_library, resource_unit
from sensorsel.model.problem import Problem
from sensorsel.model.scenario import LandmarkModel, generate_landmarks, route_landmarks, write_landmarks_csv


def library_json(lib: SensorLibrary) -> str:
    """The library as JSON: its source and each placed sensor (id, index, model, clock, range, FOV, noise, cost)."""
    sensors = [
        {
            "id": s.id,
            "index": s.index,
            "model": s.model.code,
            "model_name": s.model.name,
            "type": s.model.type,
            "clock": s.clock,
            "position": s.position_label,
            "mount_angle_deg": round(math.degrees(s.mount_angle_rad), 9),
            "range_m": s.model.range_m,
            "fov_deg": round(math.degrees(s.model.fov_rad), 9),
            "sigma_bearing_rad": s.model.bearing_sigma(),
            "sigma_range_m": None if s.model.type == "stereo" else s.model.sigma_range_m,  # stereo: z^2 model
            "cost_usd": s.cost_usd,
            "resources": dict(s.model.resources),
        }
        for s in lib
    ]
    slots = [
        {"place": sl.place, "kind": sl.kind, "capacity": sl.capacity, "sensors": [lib.ids[i] for i in sl.members]}
        for sl in lib.slots
    ]
    return (
        json.dumps(
            {"source": lib.source, "n_sensors": len(lib), "sensors": sensors, "slots": slots}, indent=2, allow_nan=False
        )
        + "\n"
    )


@click.command("library", cls=Command, short_help="List the 62 placed sensors of the library (id, index, model, cost).")
@library_option()
@result_options
def library_cmd(library_path: str | None, as_json: bool, quiet: bool) -> None:
    """List the placed sensors of the library (id, paper index, model, position, range, FOV, cost),
    what each uses of the resources the file declares (what --limit can bound), and its mounting slots."""
    lib = load_library(library_path)
    if as_json:
        click.echo(library_json(lib), nl=False)
        return
    names = lib.resource_names
    rows = [
        [
            s.id,
            str(s.index),
            s.model.name,
            s.position_label,
            f"{s.model.range_m:g}",
            f"{math.degrees(s.model.fov_rad):.1f}",
            f"{s.model.bearing_sigma():.5f}",
            "z^2 model" if s.model.type == "stereo" else f"{s.model.sigma_range_m:g}",
            f"{s.cost_usd:,.0f}",
        ]
        + [f"{dict(s.model.resources)[n]:g}" if n in dict(s.model.resources) else "-" for n in names]
        for s in lib
    ]
    click.echo(
        table(
            rows,
            [
                "id",
                "index",
                "model",
                "position",
                "range_m",
                "fov_deg",
                "sigma_brg_rad",
                "sigma_rng_m",
                "cost_usd",
                *names,
            ],
        )
    )
    click.echo(f"\n{len(lib)} sensors from {lib.source}")
    if names:
        declared = ", ".join(f"{n} [{resource_unit(n) or '-'}]" for n in names)
        click.echo(f"resources  {declared}: bound them with --limit NAME=VALUE")
    if lib.slots:
        caps: dict[str, list[str]] = {}
        for sl in lib.slots:
            caps.setdefault(sl.place, []).append(f"{sl.kind} {sl.capacity}")
        groups: dict[str, list[str]] = {}
        for place, kinds in caps.items():
            groups.setdefault(", ".join(kinds), []).append("roof" if place == "roof" else place)
        click.echo(
            "slots      "
            + "; ".join(f"{'/'.join(ps)}: {k}" for k, ps in groups.items())
            + " (at most, per place; --no-slots ignores them)"
        )
    else:
        click.echo(
            "slots      none (no mounting limits; a file can add them: see configs/car_one_radar_one_camera.yaml)"
        )


@click.command("score", cls=Command, short_help="Score a suite: cost and f(S) = log det gain over no sensor [nats].")
@design_options
@suite_option(
    required=True,
    help="Comma-separated sensor ids or indices, e.g. LRL-roof,LRR-12 (see "
    "`sensorsel library`), or a result JSON (`sensorsel greedy -o FILE`, ...: its suite; computed on the same "
    "problem, see --force).",
)
@force_option
@quality_options
@result_options
def score_cmd(
    suite: str,
    as_json: bool,
    quiet: bool,
    force: bool,
    **kw: Any,
) -> None:
    """Score a sensor suite: cost and f(S) = log det L(S) - log det L(empty) in nats.

    With --domain FILE: the suite's score on every route, each as a share of the route's best, and
    the domain score (their weighted sum, --aggregate). With --scheduler/--workers, each route is
    built, normalised and scored on a worker. With --limit, --max-sensors, --include or --exclude
    (or a library with mounting slots): what the suite uses of each limit, and what it breaks.

    Also the suite's accuracy in metres and degrees (lateral, longitudinal, heading: 95 % errors over
    the keyframes), in the paper's SLAM graph or with --map-sigma localizing in a prior map."""
    inputs = design_from(kw)
    target, engine = inputs.target, inputs.engine
    require_domain(inputs.cluster, target)
    # score has no budget: the whole library is affordable, the other limits apply
    feas = feasible_set(target.library, float(target.library.costs.sum()), inputs.constraints)
    if target.kind == "domain":  # another result kind: the score of each route and the domain's
        if is_result_file(suite):
            raise InputError(
                f"--suite {suite}: a result file names a suite for one route; with --domain give the suite's ids"
            )
        with inputs.running():
            ev = cluster_evaluator(inputs.cluster, target, engine, inputs.aggregate)
            dres = score_domain_suite(target, suite, engine=engine, aggregate=inputs.aggregate, evaluator=ev)
        dres = inputs.with_quality(dres)
        echo_result(dres, as_json, lambda: _print_domain_score(dres, feas))
        return
    problem = target.routes[0].problem
    res = score_suite(
        problem,
        _suite_positions(suite, problem, force),
        engine=engine,
        map_sigma_m=inputs.map_sigma,
        estimate=inputs.estimate,
    )
    res = replace(res, integrity=suite_integrity(problem, res.suite, inputs.integrity, map_sigma_m=inputs.map_sigma))
    echo_result(res, as_json, lambda: _print_score(res, feas))


def _print_suite(target: Any, suite: tuple[str, ...], cost_usd: float) -> None:
    """The target a suite is scored on, the suite and its cost."""
    print_target(target)
    click.echo(f"suite      {','.join(suite)}")
    click.echo(f"cost       ${cost_usd:,.0f}")


def _print_score(res: Any, feas: FeasibleSet) -> None:
    """A suite's score on one route: its log det gain, what it measures, its accuracy, the limits."""
    _print_suite(res.problem, res.suite, res.cost_usd)
    click.echo(f"score      {res.score:.3f} nats  (log det {res.logdet:.3f}, sensorless {res.baseline_logdet:.3f})")
    click.echo(f"measures   {res.n_measurements} range-bearing measurements of {res.n_landmarks_seen} landmarks")
    print_accuracy([res.accuracy] if res.accuracy is not None else [], res.integrity)
    _print_limits(feas, feas.library.resolve_suite(res.suite))


def _print_domain_score(dres: Any, feas: FeasibleSet) -> None:
    """A suite's score on a domain: each route's share of its best, the domain score, the accuracy, the limits."""
    _print_suite(dres.domain, dres.suite, dres.cost_usd)
    rows = [
        [r.name, f"{r.weight:.3f}", f"{r.score:.3f}", f"{r.best_score:.3f}", f"{r.share_of_best:.4f}"]
        for r in dres.routes
    ]
    click.echo(table(rows, ["route", "weight", "score_nats", "best_nats", "of_best"]))
    unit = "(weighted share of the best)" if dres.aggregate == "normalised" else "nats (weighted)"
    click.echo(f"score      {dres.score:.4f} {unit}")
    print_accuracy(dres.accuracy, dres.integrity)
    _print_limits(feas, feas.library.resolve_suite(dres.suite))


def _suite_positions(text: str, problem: Problem, force: bool) -> tuple[int, ...]:
    """A --suite: ids or library positions, or a result file's suite (checked to be of ``problem``,
    as ``simulate --suite FILE``)."""
    return read_suite(text, problem.library, "--suite", problem, force)[0]


def _print_limits(feas: FeasibleSet, suite: tuple[int, ...]) -> None:
    """The suite against the limits besides money (nothing when there are none)."""
    if feas.only_budget:
        return
    click.echo(f"limits     {feas.constraints.describe()}")
    click.echo(usage_table([r for r in feas.rows_used(suite) if r.name != "budget"]))
    broken = feas.violations(suite)
    click.echo("fits       every limit" if not broken else f"breaks     {'; '.join(broken)}")


@click.command("scene", cls=Command, short_help="Draw the route, landmarks and a suite's sensing cones (PNG/SVG/PDF).")
@scenario_options
@output_option(required=True, help="Image file (.png, .svg, .pdf).")
@plot_format_option
@suite_option(
    help="Draw these sensors' cones: comma-separated sensor ids, or a result JSON "
    "(`sensorsel greedy -o FILE`, ...: its suite; computed on the same problem, see --force).",
)
@click.option(
    "--pose",
    "pose_index",
    type=int,
    default=None,
    help="Keyframe at which to draw the cones (default: the middle one).",
)
@path_option(
    "--domain",
    "domain_path",
    metavar="FILE",
    help="Draw an operating domain instead: every route, and its landmarks by class (sensorsel osm's domains).",
)
@force_option
@result_options
def scene_cmd(
    output: str,
    plot_format: str | None,
    suite: str | None,
    pose_index: int | None,
    domain_path: str | None,
    force: bool,
    as_json: bool,
    quiet: bool,
    **kw: Any,
) -> None:
    """Draw the route and landmarks (the paper's Fig. 2), optionally a suite's sensing cones.

    The format is --plot-format, or else the extension of -o (.png, .svg, .pdf); the two must agree.
    """
    from sensorsel.plotting import plot_domain_scene, plot_scene, save_figure, use_file_backend

    plot_format_of(plot_format, output)
    if domain_path is not None:
        if suite is not None or pose_index is not None:
            raise click.UsageError("--domain draws the routes and landmarks only: drop --suite and --pose")
        use_file_backend()
        ax = plot_domain_scene(domain_path)
        _said_written(save_figure(ax.figure, output, close=True), as_json, "scene", domain=domain_path)
        return
    problem = problem_from(kw)
    positions = _suite_positions(suite, problem, force) if suite else ()
    n = problem.scenario.n_poses
    if pose_index is not None and not 0 <= pose_index < n:
        raise InputError(f"--pose {pose_index}: the scenario {problem.scenario.name} has keyframes 0..{n - 1}")
    use_file_backend()
    ranges = None
    if problem.condition is not None:
        from sensorsel.model.sensing import condition_effects

        ranges = [e.range_m for e in condition_effects(problem.library, problem.condition)]
    ax = plot_scene(
        problem.scenario,
        library=problem.library,
        suite=positions,
        pose_index=pose_index,
        ranges_m=ranges,
        condition=problem.condition.label if problem.condition is not None else None,
    )
    _said_written(
        save_figure(ax.figure, output, close=True),
        as_json,
        "scene",
        scenario=problem.scenario.name,
        suite=list(problem.library.ids[i] for i in positions),
    )


def _said_written(path: Any, as_json: bool, kind: str, **fields: Any) -> None:
    """``wrote PATH``, or with --json what was written as JSON."""
    if as_json:
        echo_written(kind, file=str(path), **fields)
    else:
        click.echo(f"wrote {path}")


def _range_m(text: str, option: str) -> tuple[float, float]:
    """'LOW,HIGH' [m] -> (low, high); the landmark model checks 0 <= low <= high."""
    try:
        lo, hi = (float(v) for v in text.split(","))
    except ValueError:
        raise InputError(f"{option} {text!r}: expected two distances LOW,HIGH in metres, e.g. 4,12") from None
    return lo, hi


_DEFAULT_MODEL = LandmarkModel()

#: The options of ``sensorsel landmarks``, one per field of the landmark model (the field is the
#: option's destination, its default the model's): a spacing or a clearance in metres, an offset a
#: range LOW,HIGH in metres.
_MODEL_OPTIONS = (
    ("--near-spacing", "near_spacing_m", "Route length between two near landmarks on each roadside [m]."),
    ("--near-offset", "near_offset_m", "Distance of near landmarks (poles, trees, facades) from the route [m]."),
    ("--far-spacing", "far_spacing_m", "Route length between two far landmarks, on a random side [m]."),
    ("--far-offset", "far_offset_m", "Distance of far landmarks (buildings, hills) from the route [m]."),
    ("--clearance", "clearance_m", "No landmark closer than this to the route (any point of it: the road itself) [m]."),
)


def _landmark_model_options(fn: Any) -> Any:
    """The options of :data:`_MODEL_OPTIONS`, in its order (read by :func:`_landmark_model_from`)."""
    for name, field, help in reversed(_MODEL_OPTIONS):
        default = getattr(_DEFAULT_MODEL, field)
        if isinstance(default, tuple):  # a range of distances
            kind: dict[str, Any] = {"default": "{:g},{:g}".format(*default), "metavar": "LOW,HIGH"}
        else:
            kind = {"type": float, "default": default, "metavar": "METRES"}
        fn = click.option(name, field, show_default=True, help=help, **kind)(fn)
    return fn


def _landmark_model_from(kw: dict[str, Any]) -> LandmarkModel:
    """The landmark model of :func:`_landmark_model_options` (popped from ``kw``: pop them before the
    scenario options, whose --clearance this command's own replaces)."""
    fields: dict[str, Any] = {}
    for name, field, _ in _MODEL_OPTIONS:
        value = kw.pop(field)
        fields[field] = _range_m(value, name) if isinstance(getattr(_DEFAULT_MODEL, field), tuple) else value
    return LandmarkModel(**fields)


@click.command("landmarks", cls=Command, short_help="Generate synthetic landmarks along a route and write them as CSV.")
@scenario_options
@_landmark_model_options
@output_option(required=True, help="CSV file to write (x,y in metres).")
@result_options
def landmarks_cmd(output: str, as_json: bool, quiet: bool, **kw: Any) -> None:
    """Generate synthetic landmarks along the route with the given densities and distances (seeded by
    --landmark-seed) and write them as CSV (x,y in sensorsel's planar frame, metres).

    Edit the file, or pass it to any command with --landmarks FILE. A real map can be written in the
    same format. The bundled fixtures' own landmark files are not read here: landmarks are always
    generated.
    """
    kw.pop("library_path")
    if kw.get("landmarks"):
        raise click.UsageError("--landmarks reads a landmark file; this command writes one (leave --landmarks out)")
    model = _landmark_model_from(kw)
    spec = replace(spec_from(kw), landmark_model=model)
    if spec.geo:
        raise click.UsageError(
            "--georef, --osm-classes and --osm-reach place OSM landmarks (--landmarks osm:FILE); this command "
            "generates synthetic ones (leave them out)"
        )
    from sensorsel.model.osm.track import gpx_route, is_gpx

    if spec.route is not None and is_gpx(spec.route):  # a GPS track: in the UTM frame of its mean position
        rf, _ = gpx_route(spec.route)
        landmarks = generate_landmarks(rf.route, model, spec.landmark_seed)
    else:
        landmarks = route_landmarks(spec)
    path = write_landmarks_csv(output, landmarks)
    if as_json:
        echo_written("landmarks", file=str(path), landmarks=len(landmarks), seed=spec.landmark_seed)
    else:
        click.echo(f"wrote {len(landmarks)} landmarks to {path}")


COMMANDS = [library_cmd, score_cmd, scene_cmd, landmarks_cmd]
