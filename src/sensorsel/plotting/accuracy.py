"""Accuracy in metres: a front against a specification, errors along a route, a route's margin."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.axes import Axes

from sensorsel.model.scenario import Scenario
from sensorsel.plotting.figures import new_axes, route_distance_m

if TYPE_CHECKING:  # the result types only (their modules need no matplotlib; simulate's imports gtsam)
    from sensorsel.designs.requirements.front import FrontAcceptance
    from sensorsel.designs.requirements.spec import Specification
    from sensorsel.information.evaluators.accuracy import RouteAccuracy


# ------------------------------------------------------------------------------ accuracy in metres


def plot_front_accuracy(acceptance: FrontAcceptance, ax: Axes | None = None, *, log_cost: bool = True) -> Axes:
    """The Pareto front as cost [$] against the lateral 95 % error [m] (the worst route, at the
    specification's share of keyframes), each suite marked by whether it meets the specification,
    with the lateral requirement drawn as a line: which part of the front is acceptable."""

    ax = ax if ax is not None else new_axes((7.5, 5.0))
    pts = acceptance.points
    cost = np.array([p.cost_usd for p in pts])
    lat = np.array([p.lateral_95_m for p in pts])
    ax.plot(cost, lat, color="0.6", lw=1, zorder=1, label="Pareto front (cheapest first)")
    if acceptance.specifications:
        ok = np.array([bool(p.meets) for p in pts])
        ax.scatter(cost[ok], lat[ok], color="tab:green", s=40, zorder=3, label="meets the specification")
        ax.scatter(cost[~ok], lat[~ok], color="tab:red", marker="x", s=40, zorder=3, label="does not meet it")
        specs: list[Specification] = [s for _, s in acceptance.specifications]
        bounds = sorted(
            {(s.lateral if not s.sigma else s.lateral * 1.959963984540054) for s in specs if s.lateral is not None}
        )
        for b in bounds:
            ax.axhline(b, color="tab:blue", ls="--", lw=1.2, zorder=2)
        if bounds:
            ax.plot([], [], color="tab:blue", ls="--", label=f"lateral requirement ({specs[0].name})")
        best = acceptance.cheapest_meeting
        if best is not None:
            ax.annotate(
                f"cheapest meeting it: ${best.cost_usd:,.0f}",
                (best.cost_usd, best.lateral_95_m),
                xytext=(10, 15),
                textcoords="offset points",
                fontsize=8,
                arrowprops=dict(arrowstyle="->", lw=0.8),
            )
    else:
        ax.scatter(cost, lat, color="tab:blue", s=30, zorder=3, label="front suite")
    if log_cost:
        ax.set_xscale("log")
    ax.set_yscale("log")
    from matplotlib.ticker import FuncFormatter

    plain = FuncFormatter(lambda v, _: f"{v:g}")
    ax.yaxis.set_major_formatter(plain)
    ax.yaxis.set_minor_formatter(FuncFormatter(lambda v, _: f"{v:g}" if f"{v:.1g}"[0] in "25" else ""))
    ax.set_xlabel("suite cost [$]")
    ax.set_ylabel("lateral error, 95 % [m]")
    ax.set_title(f"Cost against lateral accuracy\n{acceptance.model_label}", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="upper right")
    return ax


def plot_accuracy_along_route(
    accuracies: Sequence[tuple[str, RouteAccuracy]],
    scenario: Scenario,
    specification: Specification | None = None,
    ax: Axes | None = None,
    component: str = "lateral",
) -> Axes:
    """A component's 95 % error (1.96σ, or 1σ if the specification is stated in σ) along the route
    [m or deg] against distance driven [m], one line per (label, accuracy), with the
    specification's bound drawn in."""
    from sensorsel.information.evaluators.accuracy import Z95

    ax = ax if ax is not None else new_axes((8.0, 4.0))
    dist = route_distance_m(scenario)
    factor = 1.0 if specification is not None and specification.sigma else Z95
    for (label, acc), colour in zip(accuracies, ("tab:green", "tab:orange", "tab:purple", "tab:brown")):
        ax.plot(dist, factor * acc.sigmas(component), color=colour, lw=1.5, label=label)
    unit = "deg" if component == "heading" else "m"
    if specification is not None and getattr(specification, component) is not None:
        ax.axhline(
            getattr(specification, component),
            color="tab:red",
            ls="--",
            lw=1.2,
            label=f"requirement ({specification.name}): {getattr(specification, component):g} {unit}",
        )
    ax.set_xlabel("distance along the route [m]")
    ax.set_ylabel(f"{component} error, {'1σ' if factor == 1.0 else '95 %'} [{unit}]")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    return ax


def plot_route_margin(
    accuracy: RouteAccuracy, scenario: Scenario, specification: Specification, ax: Axes | None = None
) -> Axes:
    """The route coloured by its margin at each keyframe: the largest, over the specification's
    components, of error / bound (below 1: met; above 1: missed), with the landmarks in grey."""
    from matplotlib.collections import LineCollection
    from matplotlib.colors import TwoSlopeNorm

    ax = ax if ax is not None else new_axes((7.0, 6.0))
    ratio = np.zeros(accuracy.n_keyframes)
    for comp, bound, _ in specification.bounds():
        ratio = np.maximum(ratio, specification.factor * accuracy.sigmas(comp) / bound)
    xy = scenario.keyframes.poses[:, :2]
    if len(scenario.landmarks):
        ax.scatter(scenario.landmarks[:, 0], scenario.landmarks[:, 1], s=4, color="0.7", label="landmarks", zorder=1)
    segs = np.stack([xy[:-1], xy[1:]], axis=1)
    hi = max(2.0, float(ratio.max()))
    norm = TwoSlopeNorm(vmin=0.0, vcenter=1.0, vmax=hi)
    lc = LineCollection(list(segs), cmap="RdYlGn_r", norm=norm, linewidths=3, zorder=2)
    lc.set_array(np.maximum(ratio[:-1], ratio[1:]))
    ax.add_collection(lc)
    bad = ratio > 1.0
    if np.any(bad):
        ax.scatter(
            xy[bad, 0],
            xy[bad, 1],
            s=18,
            facecolors="none",
            edgecolors="black",
            zorder=3,
            label=f"keyframes missing it ({int(bad.sum())})",
        )
    cb = ax.figure.colorbar(lc, ax=ax, shrink=0.8)
    cb.set_label("error / requirement (worst component; > 1 misses)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.autoscale_view()
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.legend(fontsize=8, loc="best")
    return ax
