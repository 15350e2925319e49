"""Designs: a selection grid, the tradespace, a domain's breakdown by route and condition."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.patches import Rectangle

from sensorsel.errors import InputError
from sensorsel.plotting.figures import new_axes

if TYPE_CHECKING:  # the result types only (their modules need no matplotlib; simulate's imports gtsam)
    from sensorsel.designs.domain_design import DomainDesign
    from sensorsel.designs.resilient import SelectionGrid
    from sensorsel.designs.tradespace import TradespaceResult


def plot_selection_grid(grid: SelectionGrid, ax: Axes | None = None, *, title: str | None = None) -> Axes:
    """The per-period selection grid (the paper's Fig. 5): rows = periods, columns = sensors.

    Columns are grouped by sensor model (group label: the model code; column label: the clock
    position or "roof"); sensors assumed to fail are red, active sensors green, others blank. A black
    cross marks, in each period, the failure set worst for that period's suite (``grid.worst_failures``).
    Without ``ax`` the figure is sized for the grid (about 0.2 in per column, 0.24 in per row), so
    that the 62 columns of the paper's library stay readable.

    Args:
        grid: a :class:`sensorsel.designs.resilient.SelectionGrid`.
        ax: axes to draw on; a new figure when None.
        title: the axes' title (default: "Resilient selection per period").
    Returns:
        The axes drawn on.
    """
    from matplotlib.colors import to_rgb
    from matplotlib.patches import Patch

    n_rows, n_cols = len(grid.cells), len(grid.sensors)
    if ax is None:
        ax = new_axes(figsize=(max(6.0, 0.2 * n_cols + 2.6), max(2.6, 0.24 * n_rows + 1.9)))
    colours = {"failed": to_rgb("tab:red"), "active": to_rgb("tab:green"), "": (1.0, 1.0, 1.0)}
    img = np.ones((max(n_rows, 1), max(n_cols, 1), 3))
    for r, row in enumerate(grid.cells):
        for c, state in enumerate(row):
            img[r, c] = colours[state]
    ax.imshow(img, aspect="auto", interpolation="nearest", extent=(-0.5, n_cols - 0.5, max(n_rows, 1) - 0.5, -0.5))
    # thin cell borders, thick borders between sensor models
    ax.set_xticks(np.arange(-0.5, n_cols, 1.0), minor=True)
    ax.set_yticks(np.arange(-0.5, n_rows, 1.0), minor=True)
    ax.grid(True, which="minor", color="0.8", lw=0.5)
    ax.tick_params(which="minor", length=0)
    groups: list[tuple[str, int, int]] = []  # (model code, first column, last column)
    for c, m in enumerate(grid.models):
        if groups and groups[-1][0] == m:
            groups[-1] = (m, groups[-1][1], c)
        else:
            groups.append((m, c, c))
    for _, a, _b in groups[1:]:
        ax.axvline(a - 0.5, color="k", lw=1.2)
    for m, a, b in groups:
        ax.text(
            (a + b) / 2,
            -0.6,
            m,
            ha="center",
            va="bottom",
            fontsize=8,
            fontweight="bold",
            transform=ax.transData,
            clip_on=False,
        )
    ax.set_xticks(np.arange(n_cols))
    ax.set_xticklabels(grid.positions, fontsize=6.5)
    for lab, pos in zip(ax.get_xticklabels(), grid.positions):
        if len(pos) > 2:
            lab.set_rotation(90)
    ax.set_yticks(np.arange(n_rows))
    ax.set_yticklabels(grid.period_labels, fontsize=7)
    ax.tick_params(axis="both", which="major", length=2, pad=1.5)
    ax.set_xlabel("sensor: clock position (12 = ahead, 3 = right) or roof, grouped by model", fontsize=8)
    ax.set_ylabel("period", fontsize=8)
    default_title = (
        "Robust selection per period" if getattr(grid, "method", "") == "robust" else "Resilient selection per period"
    )
    ax.set_title(title or default_title, fontsize=10, pad=14)
    handles: list[Any] = [
        Patch(color=colours["failed"], label="assumed to fail"),
        Patch(color=colours["active"], label="active"),
    ]
    col = {s: c for c, s in enumerate(grid.sensors)}
    xs = [col[s] for r in range(n_rows) for s in grid.worst(r)]
    ys = [r for r in range(n_rows) for _ in grid.worst(r)]
    if xs:
        from matplotlib.lines import Line2D

        ax.scatter(xs, ys, marker="x", s=22, color="k", linewidths=1.1, zorder=3)
        handles.append(Line2D([], [], ls="", marker="x", color="k", label="worst failure for the suite"))
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.005, 1.0), fontsize=8, frameon=False)
    return ax


#: Colours and markers of the rules in the tradespace plot (the paper's Fig. 4: uniform orange,
#: cost-benefit blue). Hollow markers of different shapes keep suites made by several rules visible.
RULE_STYLES = {
    "uniform": ("tab:orange", "o", 60),
    "cost-benefit": ("tab:blue", "s", 34),
    "marginal": ("tab:green", "^", 30),
    "best-of": ("tab:purple", "D", 16),
}


def plot_tradespace(
    result: TradespaceResult,
    ax: Axes | None = None,
    *,
    log_cost: bool = True,
    fractions: Sequence[float] = (0.99, 0.95),
    title: str | None = None,
) -> Axes:
    """The cost-performance tradespace (the paper's Fig. 4).

    Every architecture is a hollow marker coloured by the rule that made it (one marker per
    rule when several made it); the Pareto front is a dashed red step line: from a front point
    the line stays flat until the next front point's cost, since between two front architectures a
    larger budget buys no better recorded architecture. The cheapest architectures reaching each of
    ``fractions`` of the best score are starred and labelled.

    Args:
        result: a :class:`sensorsel.designs.tradespace.TradespaceResult`.
        ax: axes to draw on; a new figure when None.
        log_cost: logarithmic cost axis (the costs span $449 to $200,000 in the paper's library).
        fractions: fractions of the best score whose cheapest architecture to mark.
        title: the axes' title (default: names the scenario and the counts).
    Returns:
        The axes drawn on.
    """
    from matplotlib.ticker import FuncFormatter

    ax = ax or new_axes((8.0, 5.5))
    archs = result.architectures
    if not archs:
        raise InputError(
            "plot_tradespace: the tradespace has no architectures (every budget is below the cheapest sensor)"
        )
    for name in result.rules:
        pts = [(a.cost_usd, a.normalized) for a in archs if name in a.rules]
        colour, marker, size = RULE_STYLES.get(name, ("tab:gray", "x", 30))
        if pts:
            x, y = np.array(pts).T
            ax.scatter(
                x,
                y,
                s=size,
                marker=marker,
                facecolors="none",
                edgecolors=colour,
                linewidths=1.1,
                label=f"made by {name} ({len(pts)})",
                zorder=3,
            )
    front = result.front
    fx = np.array([a.cost_usd for a in front])
    fy = np.array([a.normalized for a in front])
    ax.step(fx, fy, where="post", ls="--", color="red", lw=1.4, label=f"Pareto front ({len(front)})", zorder=2)
    ax.scatter(fx, fy, s=5, color="red", zorder=4)
    if log_cost:
        ax.set_xscale("log")
    costs = np.array([a.cost_usd for a in archs])
    lo_x, hi_x = (np.log(costs.min()), np.log(costs.max())) if log_cost else (costs.min(), costs.max())
    for k, frac in enumerate(fractions):
        a = result.cheapest_reaching(frac)
        if a is None:
            continue
        first = k == 0
        ax.axhline(
            frac,
            color="0.6",
            lw=0.8,
            ls=":",
            zorder=1,
            label=" and ".join(f"{f:.0%}" for f in fractions) + " of the best" if first else None,
        )
        ax.scatter(
            [a.cost_usd],
            [a.normalized],
            s=160,
            marker="*",
            color="gold",
            edgecolors="k",
            linewidths=0.7,
            zorder=5,
            label="cheapest suite reaching it" if first else None,
        )
        # the label goes below the point, towards the middle of the plot, so it stays inside the axes
        x = np.log(a.cost_usd) if log_cost else a.cost_usd
        right = x > (lo_x + hi_x) / 2
        ax.annotate(
            f"{frac:.0%} of best: ${a.cost_usd:,.0f}\n({a.n_sensors} sensors)",
            (a.cost_usd, a.normalized),
            xytext=(-14 if right else 14, -30 - 30 * k),
            textcoords="offset points",
            fontsize=8.5,
            ha="right" if right else "left",
            va="top",
            arrowprops=dict(arrowstyle="-", color="0.4", lw=0.7),
            bbox=dict(boxstyle="round,pad=0.25", fc="white", ec="0.7", alpha=0.9),
            zorder=6,
        )
    ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"${v / 1000:,.0f}k" if v >= 1000 else f"${v:,.0f}"))
    lo = min(a.normalized for a in archs)
    ax.set_ylim(max(0.0, lo - 0.05), 1.03)
    ax.set_xlabel("suite cost [$]" + (" (log scale)" if log_cost else ""))
    ax.set_ylabel("normalized performance  f(S) / max f")
    p = result.problem
    where = f"{p.headline}: " if p is not None else ""
    ax.set_title(
        title
        or f"{where}{len(archs)} architectures from {len(result.runs)} greedy runs ({len(result.budgets_usd)} budgets)",
        fontsize=10,
    )
    ax.grid(True, which="major", alpha=0.3)
    ax.grid(True, which="minor", alpha=0.1)
    ax.legend(loc="lower right", fontsize=8.5)
    return ax


def plot_domain_breakdown(design: DomainDesign, ax: Axes | None = None, *, title: str | None = None) -> Axes:
    """The price of one suite for a whole domain, route by route.

    For each route (one row), the share of the route's best f_r(S)/f_r(all sensors) reached by the
    domain suite (filled dot) and by the suite the same rule picks for that route alone at the same
    budget (hollow dot), joined by a line: the gap is what the route gives up for the others. The
    worst route (lowest share of its own design) is labelled in red.

    Args:
        design: a :class:`sensorsel.designs.domain_design.DomainDesign`.
        ax: axes to draw on; a new figure when None.
    Returns:
        The axes drawn on.
    """
    routes = design.routes
    if any(r.condition for r in design.domain.routes):
        return _plot_condition_grid(design, ax, title=title)
    ax = ax if ax is not None else new_axes((7.0, 0.45 * len(routes) + 2.6))
    y = np.arange(len(routes))[::-1]
    domain_share = np.array([r.share_of_best for r in routes])
    own_share = np.array([r.own_score / r.best_score if r.best_score > 0 else 0.0 for r in routes])
    for yi, a, b in zip(y, domain_share, own_share):
        ax.plot([a, b], [yi, yi], color="0.7", lw=2, zorder=1)
    ax.scatter(
        own_share,
        y,
        s=60,
        facecolors="white",
        edgecolors="tab:blue",
        lw=1.5,
        zorder=2,
        label="each route's own design (same budget and rule)",
    )
    ax.scatter(domain_share, y, s=60, color="tab:blue", zorder=3, label="the domain suite")
    labels = [f"{r.name} ({r.weight:.1%})" for r in routes]
    ax.set_yticks(y, labels)
    for tick, r in zip(ax.get_yticklabels(), routes):
        if r.name == design.worst_route:
            tick.set_color("tab:red")
    ax.set_xlabel("share of the route's best score, f_r(S) / f_r(all sensors)")
    ax.set_xlim(min(0.9, float(min(domain_share.min(), own_share.min())) - 0.02), 1.0)
    ax.grid(axis="x", alpha=0.3)
    ax.set_ylim(-2.2, len(routes) - 0.5)  # a band below the last route for the legend
    handles, labels = ax.get_legend_handles_labels()
    if design.worst_route:
        from matplotlib.patches import Patch

        handles.append(Patch(color="none"))
        labels.append("red name: the route that loses most to its own design")
    leg = ax.legend(handles, labels, loc="lower left", fontsize="small", ncol=1)
    if design.worst_route:
        leg.get_texts()[-1].set_color("tab:red")
    budget = design.greedy.budget_usd
    # "\\$" is a literal dollar: a bare $ starts matplotlib's mathtext
    ax.set_title(
        title
        or f"One suite for {len(routes)} routes at \\${budget:,.0f}: \\${design.greedy.cost_usd:,.0f}, "
        f"{len(design.greedy.suite)} sensors (weights in brackets)",
        fontsize="medium",
    )
    return ax


def _plot_condition_grid(design: DomainDesign, ax: Axes | None = None, *, title: str | None = None) -> Axes:
    """A domain with operating conditions: routes (rows) x conditions (columns), each cell the
    domain suite's share of that member's best f_r(S)/f_r(all sensors), with its share of the
    member's own design below it; the worst member (lowest share of its own design) framed in red."""
    info = {r.name: r for r in design.domain.routes}
    routes = list(dict.fromkeys(info[r.name].route or r.name for r in design.routes))
    conditions = list(dict.fromkeys(info[r.name].condition for r in design.routes))
    grid = np.full((len(routes), len(conditions)), np.nan)
    own = np.full_like(grid, np.nan)
    for r in design.routes:
        i, j = routes.index(info[r.name].route or r.name), conditions.index(info[r.name].condition)
        grid[i, j], own[i, j] = r.share_of_best, r.share_of_own
    ax = ax if ax is not None else new_axes((1.6 * len(conditions) + 3.0, 0.5 * len(routes) + 2.0))
    im = ax.imshow(grid, cmap="viridis", aspect="auto", vmin=float(np.nanmin(grid)), vmax=1.0)
    for i in range(len(routes)):
        for j in range(len(conditions)):
            if np.isfinite(grid[i, j]):
                ax.text(
                    j,
                    i,
                    f"{grid[i, j]:.3f}\n({own[i, j]:.1%} of own)",
                    ha="center",
                    va="center",
                    fontsize=7,
                    color="white" if grid[i, j] < 0.5 * (np.nanmin(grid) + 1.0) else "black",
                )
    worst = info.get(design.worst_route)
    if worst is not None:
        i, j = routes.index(worst.route or worst.name), conditions.index(worst.condition)
        ax.add_patch(Rectangle((j - 0.5, i - 0.5), 1, 1, fill=False, edgecolor="tab:red", lw=2))
    weights = {c: sum(r.weight for r in design.routes if info[r.name].condition == c) for c in conditions}
    ax.set_xticks(range(len(conditions)), [f"{c}\n({weights[c]:.1%})" for c in conditions])
    ax.set_yticks(range(len(routes)), routes)
    ax.figure.colorbar(im, ax=ax, label="share of the member's best")
    budget = design.greedy.budget_usd
    ax.set_title(
        title
        or f"One suite for {len(routes)} routes x {len(conditions)} conditions at \\${budget:,.0f}: "
        f"\\${design.greedy.cost_usd:,.0f} (red: worst member)",
        fontsize="medium",
    )
    return ax
