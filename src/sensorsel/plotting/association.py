"""The calibration of the predicted association risk against ``simulate --associate``."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from matplotlib.axes import Axes

from sensorsel.plotting.figures import new_axes

if TYPE_CHECKING:
    from sensorsel.simulation.records import AssociationCheck

#: the highest floor of the log axes (a bin observed at 0 is drawn on the floor, its interval up)
FLOOR = 1e-7


def plot_association_calibration(check: AssociationCheck, ax: Axes | None = None) -> Axes:
    """Predicted against observed P(at least one wrong association per keyframe), by bins of the
    predicted estimate (decades): each bin's mean estimate (x) against the rate observed over its
    keyframes (y) with its 99 % confidence interval, the mean bound (x) at the same observed rate,
    the diagonal and the factor-2 band. Log axes; a rate observed at 0 is drawn at the floor.

    Returns:
        The axes drawn on (a new figure when ``ax`` is None).
    """
    ax = ax if ax is not None else new_axes((6.5, 6.0))
    bins = [b for b in check.bins if b.predicted > 0]
    lo_all = FLOOR
    if bins:
        x = np.array([b.predicted for b in bins])
        bnd = np.array([b.bound for b in bins])
        raw = np.array([[b.observed, b.ci_low, b.ci_high] for b in bins])
        positive = np.concatenate([x, raw[raw > 0]])
        # the floor: a decade below the smallest positive value drawn (zeros are drawn there)
        lo_all = float(min(FLOOR, positive.min() / 10.0))
        y, lo, hi = (np.maximum(raw[:, c], lo_all) for c in range(3))
        ax.errorbar(
            x,
            y,
            yerr=[y - np.minimum(lo, y), np.maximum(hi - y, 0.0)],
            fmt="o",
            color="C0",
            capsize=3,
            label="estimate vs observed (99% CI)",
        )
        ax.plot(bnd, y, "v", color="C3", label="bound vs observed")
        for xi, yi, n in zip(x, y, (b.keyframes for b in bins)):
            ax.annotate(f"{n}", (xi, yi), textcoords="offset points", xytext=(5, 5), fontsize=7, color="0.3")
    grid = np.array([lo_all, 1.0])
    ax.plot(grid, grid, "-", color="0.4", lw=1, label="observed = predicted")
    ax.fill_between(grid, grid / 2, np.minimum(grid * 2, 1.0), color="0.85", label="within a factor of 2")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlim(lo_all, 1.0)
    ax.set_ylim(lo_all, 1.0)
    ax.set_xlabel("predicted P(wrong association) per keyframe")
    ax.set_ylabel("observed (simulate --associate)")
    model = "SLAM" if check.model == "slam" else f"map known to {check.map_sigma_m:g} m"
    how = "importance sampling" if check.importance_sampling else "plain Monte Carlo"
    ax.set_title(f"{check.label}: {model}, {how}, {check.draws} draws/keyframe", fontsize=9)
    ax.legend(loc="upper left", fontsize=8)
    return ax
