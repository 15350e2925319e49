"""Monte-Carlo validation of a design: drive the route with a suite's noisy sensors, solve SLAM, measure.

log det L(S) predicts how well SLAM will do with suite S. This module checks the prediction: for each
run it draws noisy odometry and range-bearing measurements from the same noise models the score uses
(:class:`~sensorsel.model.problem.GraphSettings` for odometry and the first-pose prior, the per-measurement
sigmas of :class:`~sensorsel.model.sensing.SensorObservations`), builds the nonlinear factor graph, starts
from dead reckoning (never from the truth), solves it with GTSAM and compares the estimate with the
ground truth.

Conventions (those of :class:`sensorsel.information.graph.GraphBuilder`): poses ``X(k)`` (``Pose2``), landmarks
``L(j)`` (``Point2``), ``BearingRangeFactor2D`` per measurement. Noise is drawn in each factor's own
error coordinates, so the factors' noise models are exactly right:

- first-pose prior: ``truth_0.retract(sigma * z)``; odometry: ``truth_{k-1}.between(truth_k).retract(sigma * z)``;
- bearing and range: truth + sigma * z.

Differences from the scoring graph, on purpose: there is no prior on landmarks (a car has none; a
prior at the true position would leak the truth into the estimate), and landmarks the suite never
measures (or measures only while failed) are left out and reported. The weak 100 m prior of the
score adds 1e-4 m^-2 of information per landmark, negligible against any measurement.

Two localization models, as in :mod:`sensorsel.information.evaluators.accuracy`: the paper's SLAM (above), and
with ``map_sigma_m`` a car localizing in a prior map whose landmarks are known to that std: each run
draws its map (every landmark off the truth by an isotropic error of that std), starts each
landmark there and adds a landmark prior there of that std. Each run's errors are also expressed in
each true keyframe's own frame (x forward = longitudinal, y left = lateral), and the result carries
the measured 95 % errors beside the predicted 1.96σ (:class:`~.records.AccuracyCheck`).

Random numbers: run ``r`` of seed ``s`` draws odometry from ``SeedSequence([s, r, 0])``, the
measurements of library sensor ``i`` from ``SeedSequence([s, r, 1, i])`` and the map (map model) from
``SeedSequence([s, r, 2])``. So results do not depend on
``jobs``, and two suites (or a suite with and without a failure) see the same noise on the
odometry and on the sensors they share (common random numbers: their difference is the design's).

Consistency: each pose's error ``xi_k = truth_k.localCoordinates(estimate_k)`` (3-dof, GTSAM's tangent
space) is compared with the covariance predicted by the information matrix of the graph linearized
at the **ground truth** (in closed form and inverted densely, equal to ``gtsam.Marginals`` there).
That is the same information matrix whose log det is the score, it does not depend on the draw, and
it is computed once. (Marginals at each run's solution would measure the estimator's own opinion of
itself, not whether the design's prediction holds.)

- ``nees_mean``: the average of ``xi_k' P_k^-1 xi_k`` over N runs and K poses, with the two-sided 95 %
  chi-square bounds ``chi2.ppf([0.025, 0.975], 3 N K) / (N K)``. These bounds treat the N K terms as
  independent; poses along one route are correlated, so the true spread of this average is wider
  and the bounds are optimistic (a value slightly outside them is not, alone, a failure).
- ``nees_joint_mean``: the joint NEES of all poses of a run, ``xi' P^-1 xi`` with the full (3K x 3K)
  predicted covariance, averaged over runs and divided by K. Runs are independent, so
  ``N K nees_joint_mean ~ chi2(3 N K)`` exactly for a consistent linear-Gaussian estimator: the same
  bounds hold without approximation. This is the test to trust.

Worker processes (``jobs > 1``) are started by ``forkserver`` (``spawn`` where it does not exist):
they never inherit the parent's BLAS threads or gtsam objects, and only numbers travel between
processes (the measurement arrays once per worker, the estimates back).

Modules: :mod:`.records` (the result records), :mod:`.failures` (``ID@FROM-TO`` parsing),
:mod:`.noise` (the payload of numbers and its seeded draws), :mod:`.solve` (the graph of a draw, built
by :mod:`sensorsel.information.graph`; LM and iSAM2), :mod:`.consistency` (prediction, NEES, bounds) and
:mod:`.run` (``simulate`` and its worker processes).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from sensorsel.simulation.failures import check_failure, parse_failures
from sensorsel.simulation.records import (
    AccuracyCheck,
    ErrorSpread,
    Failure,
    RunResult,
    SimulationReport,
    SimulationResult,
    SimulationTiming,
    without_timing,
)

if TYPE_CHECKING:
    from sensorsel.simulation.consistency import COVARIANCE_NOTE, NEES_CONFIDENCE, nees_bounds
    from sensorsel.simulation.run import simulate
    from sensorsel.simulation.solve import DEFAULT_SOLVER, ISAM2_MAX_FINAL_UPDATES, LM_MAX_ITERATIONS, SOLVERS

#: the names whose modules import gtsam, by module: imported when first asked for (PEP 562), so
#: that importing sensorsel (every command) does not import gtsam (~0.1-0.15 s) for a simulation
#: it may never run
_LAZY = {
    "COVARIANCE_NOTE": "consistency",
    "NEES_CONFIDENCE": "consistency",
    "nees_bounds": "consistency",
    "simulate": "run",
    "DEFAULT_SOLVER": "solve",
    "ISAM2_MAX_FINAL_UPDATES": "solve",
    "LM_MAX_ITERATIONS": "solve",
    "SOLVERS": "solve",
}


def __getattr__(name: str) -> object:
    """One of :data:`_LAZY`'s names, from its module (imported now, kept for the next time)."""
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    from importlib import import_module

    value = getattr(import_module(f"{__name__}.{module}"), name)
    globals()[name] = value
    return value


__all__ = [
    "COVARIANCE_NOTE",
    "DEFAULT_SOLVER",
    "ISAM2_MAX_FINAL_UPDATES",
    "LM_MAX_ITERATIONS",
    "NEES_CONFIDENCE",
    "SOLVERS",
    "AccuracyCheck",
    "ErrorSpread",
    "Failure",
    "RunResult",
    "SimulationReport",
    "SimulationResult",
    "SimulationTiming",
    "check_failure",
    "nees_bounds",
    "parse_failures",
    "simulate",
    "without_timing",
]
