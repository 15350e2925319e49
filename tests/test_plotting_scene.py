"""Pictures a person reads without help: a colour and a legend entry per sensor model, a zoom
at the car where the cones are small against the route, the domain plot's red route name explained."""

from __future__ import annotations

from pathlib import Path

import matplotlib
import numpy as np
import pytest
from matplotlib.colors import to_rgba
from matplotlib.patches import Wedge

from sensorsel.plotting import ZOOM_BELOW, model_colours, plot_domain_breakdown, plot_scene

matplotlib.use("Agg")
import matplotlib.pyplot as plt


@pytest.fixture(autouse=True)
def _close():
    yield
    plt.close("all")


def _cone_colours(ax) -> dict[str, tuple]:
    out = {}
    for p in ax.patches:
        if isinstance(p, Wedge) and p.get_label() and not p.get_label().startswith("_"):
            out[p.get_label()] = p.get_edgecolor()
    return out


def test_each_model_has_its_own_colour_and_legend_entry(suburb_problem):
    lib = suburb_problem.library
    colours = model_colours(lib)
    codes = sorted({s.model.code for s in lib})
    assert len(set(to_rgba(colours[c]) for c in codes)) == len(codes), "two models share a colour"
    suite = lib.parse_suite("LRL-roof,MRL-roof,LRR-12,LRR-6,HD2K-3,HD2K-9")
    ax = plot_scene(suburb_problem.scenario, library=lib, suite=suite)
    zoom = [a for a in ax.figure.axes if a is not ax][0]
    legend = [t.get_text() for t in zoom.get_legend().get_texts()]
    # one entry per model, with how many of it the suite has; both LiDARs apart
    assert len(legend) == 4 and sum("LiDAR" in t for t in legend) == 2
    assert any("HD2K" in t and t.endswith("× 2") for t in legend) and any(
        "LRR" in t and t.endswith("× 2") for t in legend
    )
    assert len({c for c in _cone_colours(zoom).values()}) == 4


def test_a_zoom_at_the_car_only_where_the_cones_are_small(suburb_problem):
    lib = suburb_problem.library
    sc = suburb_problem.scenario
    route = sc.route or sc.keyframes
    extent = max(np.ptp(route.poses[:, 0]), np.ptp(route.poses[:, 1]))
    lidar_only = plot_scene(sc, library=lib, suite=lib.parse_suite("LRL-roof"))
    assert lib[lib.parse_suite("LRL-roof")[0]].model.range_m >= ZOOM_BELOW * extent
    assert len(lidar_only.figure.axes) == 1, "a zoom although the LiDAR's cone is large on this route"
    hd2k = lib[lib.parse_suite("HD2K-12")[0]].model.range_m
    assert hd2k < ZOOM_BELOW * extent  # 20 m against a few hundred metres
    ax = plot_scene(sc, library=lib, suite=lib.parse_suite("LRL-roof,HD2K-12"), pose_index=10)
    (zoom,) = [a for a in ax.figure.axes if a is not ax]
    x, y, _ = sc.keyframes.poses[10]
    lo, hi = zoom.get_xlim()
    assert lo < x < hi and hi - lo < 4 * hd2k, "the zoom does not frame the car at the cameras' scale"
    # drawn on the caller's axes: an inset, and the caller's axes come back
    fig, own = plt.subplots()
    assert plot_scene(sc, own, library=lib, suite=lib.parse_suite("HD2K-12")) is own
    assert len(own.child_axes) == 1


def test_title_names_the_map_not_its_folders(suburb_problem):
    ax = plot_scene(suburb_problem.scenario)
    title = ax.get_title()
    assert "suburb" in title and "/" not in title and len(title) <= 60


def test_domain_plot_explains_its_red_route(tmp_path):
    from sensorsel import design_domain, load_domain

    domain = load_domain(str(Path(__file__).resolve().parents[1] / "configs" / "domain_fixtures.yaml"))
    design = design_domain(domain, 20_000, "uniform")
    ax = plot_domain_breakdown(design)
    red = [t for t in ax.get_yticklabels() if to_rgba(t.get_color()) == to_rgba("tab:red")]
    assert [t.get_text().split(" (")[0] for t in red] == [design.worst_route]
    texts = ax.get_legend().get_texts()
    explained = [t for t in texts if "red" in t.get_text()]
    assert len(explained) == 1 and to_rgba(explained[0].get_color()) == to_rgba("tab:red")


def test_pareto_plot_explains_every_mark(tiny_problem):
    from sensorsel import run_tradespace
    from sensorsel.plotting import plot_tradespace

    ts = run_tradespace(tiny_problem)
    ax = plot_tradespace(ts)
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert any(lab.startswith("Pareto front") for lab in labels)
    assert any("of the best" in lab for lab in labels), "the dotted 99%/95% lines are not in the legend"
    assert any("cheapest" in lab for lab in labels), "the stars are not in the legend"
    assert any(lab.startswith("made by ") for lab in labels), "the markers do not say which rule made them"


@pytest.mark.parametrize(
    "suite_ids, condition",
    [
        ("LRL-roof,MRL-roof,LRR-12,MRR-12,HD2K-12,HD2K-6,WSC-12,LSC-12,HD2K-3", None),  # every model, zoomed
        ("LRL-roof,MRL-roof,LRR-12,MRR-12", "night"),  # long ranges: one panel, with the condition's title
    ],
)
def test_a_city_routes_scene_keeps_every_legend_inside_the_figure(tmp_path, suite_ids, condition):
    """The scene of a city route (a 1 km route of the bundled Helsinki sample, its OSM landmarks):
    each legend lies inside the saved figure (a legend cut off at the figure's edge loses entries)."""
    import io

    from click.testing import CliRunner

    from sensorsel.cli import cli
    from sensorsel.model.conditions import parse_condition
    from sensorsel.model.library import load_library
    from sensorsel.model.scenario import ScenarioSpec, load_scenario
    from sensorsel.model.sensing import condition_effects

    r = CliRunner().invoke(cli, ["osm", "--sample", "helsinki", "--output-dir", str(tmp_path / "city")])
    assert r.exit_code == 0, r.output
    sc = load_scenario(
        ScenarioSpec(
            route=str(tmp_path / "city" / "routes" / "r002.csv"),
            landmarks=str(tmp_path / "city" / "routes" / "r002_landmarks.csv"),
        )
    )
    lib = load_library()
    ranges = None if condition is None else [e.range_m for e in condition_effects(lib, parse_condition(condition))]
    ax = plot_scene(sc, library=lib, suite=lib.resolve_suite(suite_ids), ranges_m=ranges, condition=condition)
    fig = ax.figure
    fig.savefig(io.BytesIO(), format="png")
    renderer = fig.canvas.get_renderer()
    legends = [a.get_legend() for a in fig.axes if a.get_legend() is not None]
    assert legends
    for leg in legends:
        b = leg.get_window_extent(renderer)
        assert fig.bbox.x0 <= b.x0 and b.x1 <= fig.bbox.x1 and fig.bbox.y0 <= b.y0 and b.y1 <= fig.bbox.y1, b
    plt.close(fig)
