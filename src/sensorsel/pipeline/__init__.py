"""Running a design run: a plan of tasks, an executor that runs them, a store that keeps their results.

A design run (a tradespace's rules, a route's periods, a study's cells, a simulation's Monte-Carlo
runs) is written once, as a :class:`Plan`: small picklable task messages, the state they run on
(sent once to each place that runs tasks, or rebuilt there from a recipe) and the one function that
runs a task on a state. :func:`execute` hands the tasks a store does not already hold to an
executor (:class:`InProcess`, or :class:`DaskExecutor` on a Dask client) and gathers the results in
task order: the same bytes wherever the tasks ran. A store (:class:`NoStore`, or
:class:`FileStore`: one fingerprinted file per task, read back by ``--resume``) keeps each result as
it arrives, so an interrupted run goes on where it stopped. See docs/architecture.md.

This package is at the base of the layers: it knows nothing of sensors or routes.
"""

from sensorsel.pipeline.executors import (
    ClusterError,
    DaskExecutor,
    Executor,
    InProcess,
    LocalProcesses,
    import_distributed,
)
from sensorsel.pipeline.plan import Plan
from sensorsel.pipeline.run import execute
from sensorsel.pipeline.store import FileStore, NoStore, Store, digest

__all__ = [
    "ClusterError",
    "DaskExecutor",
    "Executor",
    "FileStore",
    "InProcess",
    "LocalProcesses",
    "NoStore",
    "Plan",
    "Store",
    "digest",
    "execute",
    "import_distributed",
]
