"""Plots. The only package that imports matplotlib; nothing here calls ``plt.show()``.

Every function takes ``ax=None`` (a new figure is made when omitted) and returns what it drew.
:func:`save_figure` writes PNG, SVG or PDF by the file's extension, atomically.

Importing this package leaves matplotlib's backend alone (a notebook keeps its inline or widget
backend). Programs that only write files, like the CLI, call :func:`use_file_backend` first.

- :mod:`~sensorsel.plotting.figures`: axes, the file backend, saving, colours;
- :mod:`~sensorsel.plotting.scene`: a route's scene with a suite's cones, a domain's city, the mounting;
- :mod:`~sensorsel.plotting.designs`: the selection grid, the tradespace, a domain's breakdown;
- :mod:`~sensorsel.plotting.accuracy`: accuracy in metres against a specification;
- :mod:`~sensorsel.plotting.simulation`: Monte-Carlo SLAM runs;
- :mod:`~sensorsel.plotting.association`: the association risk predicted against ``simulate --associate``.
"""

from __future__ import annotations

from sensorsel.plotting.accuracy import plot_accuracy_along_route, plot_front_accuracy, plot_route_margin
from sensorsel.plotting.association import plot_association_calibration
from sensorsel.plotting.designs import RULE_STYLES, plot_domain_breakdown, plot_selection_grid, plot_tradespace
from sensorsel.plotting.figures import (
    EXTRA_MODEL_COLOURS,
    FORMATS,
    MODEL_COLOURS,
    model_colours,
    new_axes,
    route_distance_m,
    save_figure,
    short_source,
    use_file_backend,
)
from sensorsel.plotting.scene import ZOOM_BELOW, plot_domain_scene, plot_mounting, plot_scene
from sensorsel.plotting.simulation import (
    ERROR_CMAP,
    SOLVER_WORDS,
    plot_error_along_route,
    plot_simulation,
    plot_simulation_comparison,
    plot_simulation_overview,
    typical_run,
)

__all__ = [
    "plot_association_calibration",
    "EXTRA_MODEL_COLOURS",
    "FORMATS",
    "MODEL_COLOURS",
    "model_colours",
    "new_axes",
    "route_distance_m",
    "save_figure",
    "short_source",
    "use_file_backend",
    "ZOOM_BELOW",
    "plot_domain_scene",
    "plot_mounting",
    "plot_scene",
    "ERROR_CMAP",
    "SOLVER_WORDS",
    "plot_error_along_route",
    "plot_simulation",
    "plot_simulation_comparison",
    "plot_simulation_overview",
    "typical_run",
    "RULE_STYLES",
    "plot_domain_breakdown",
    "plot_selection_grid",
    "plot_tradespace",
    "plot_accuracy_along_route",
    "plot_front_accuracy",
    "plot_route_margin",
]
