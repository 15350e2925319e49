"""Core commands: ``library``, ``score``, ``scene``."""

from __future__ import annotations

import math
from typing import Any

import click

from .. import results
from ..library import load_library
from ..pipeline import score_suite
from .options import engine_options, problem_from, run, scenario_options, table


@click.command("library")
@click.option("--library", "library_path", type=click.Path(dir_okay=False, path_type=str), help="Sensor library YAML (default: the paper's Table I).")
@run
def library_cmd(library_path: str | None) -> None:
    """List the placed sensors of the library (id, paper index, model, position, range, FOV, cost)."""
    lib = load_library(library_path)
    rows = [
        [s.id, str(s.index), s.model.name, s.position_label, f"{s.model.range_m:g}", f"{math.degrees(s.model.fov_rad):.1f}",
         f"{s.model.bearing_sigma():.5f}", "z^2 model" if s.model.type == "stereo" else f"{s.model.sigma_range_m:g}", f"{s.cost_usd:,.0f}"]
        for s in lib
    ]
    click.echo(table(rows, ["id", "index", "model", "position", "range_m", "fov_deg", "sigma_brg_rad", "sigma_rng_m", "cost_usd"]))
    click.echo(f"\n{len(lib)} sensors from {lib.source}")


@click.command("score")
@scenario_options
@engine_options
@click.option("--suite", required=True, help="Comma-separated sensor ids or indices, e.g. LRL-roof,LRR-12 (see `sensorsel library`).")
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON.")
@run
def score_cmd(suite: str, as_json: bool, engine: str | None, jobs: int, **kw: Any) -> None:
    """Score a sensor suite: cost and f(S) = log det L(S) - log det L(empty) in nats."""
    problem, spec = problem_from(kw)
    res = score_suite(problem, suite, engine=engine, spec=spec)
    if as_json:
        click.echo(results.dumps(res), nl=False)
        return
    p = res.problem
    click.echo(f"scenario   {p.scenario}: {p.n_poses} keyframes, {p.n_landmarks} landmarks ({p.landmark_source})")
    click.echo(f"suite      {','.join(res.suite)}")
    click.echo(f"cost       ${res.cost_usd:,.0f}")
    click.echo(f"score      {res.score:.3f} nats  (log det {res.logdet:.3f}, sensorless {res.baseline_logdet:.3f})")
    click.echo(f"measures   {res.n_measurements} range-bearing measurements of {res.n_landmarks_seen} landmarks")


@click.command("scene")
@scenario_options
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False, path_type=str), help="Image file (.png, .svg, .pdf).")
@click.option("--suite", default=None, help="Draw these sensors' cones (comma-separated ids).")
@click.option("--pose", "pose_index", type=int, default=None, help="Keyframe at which to draw the cones (default: the middle one).")
@run
def scene_cmd(output: str, suite: str | None, pose_index: int | None, **kw: Any) -> None:
    """Draw the route and landmarks (the paper's Fig. 2), optionally a suite's sensing cones."""
    from ..plotting import plot_scene, save_figure

    problem, _ = problem_from(kw)
    positions = problem.library.parse_suite(suite) if suite else ()
    ax = plot_scene(problem.scenario, library=problem.library, suite=positions, pose_index=pose_index)
    path = save_figure(ax.figure, output)
    click.echo(f"wrote {path}")


COMMANDS = [library_cmd, score_cmd, scene_cmd]
