"""Past one machine: a Dask cluster for a run (``sensorsel[dask]``): :class:`DaskCluster`.

    with DaskCluster(workers=2) as cluster:              # or DaskCluster(scheduler="tcp://10.0.0.5:8786")
        results = execute(plan, cluster.executor)          # a plan's tasks on the workers
        ev = DistributedDomainEvaluator(cluster.client, domain)   # a domain's routes on the workers

It knows no sensor: the plans' tasks run through :attr:`DaskCluster.executor`
(:class:`~sensorsel.pipeline.DaskExecutor`), and a domain's routes are held on the workers by
:mod:`sensorsel.information.evaluators.distributed`, beside the evaluators it distributes.

Dask is imported only here and by the Dask executor, and only when a cluster is started: a run
without one never imports it.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from typing import Any

from sensorsel.pipeline import ClusterError, DaskExecutor, import_distributed

#: seconds to wait for a scheduler to answer before giving up
DEFAULT_CONNECT_TIMEOUT_S = 5.0

__all__ = ["ClusterError", "DaskCluster", "DEFAULT_CONNECT_TIMEOUT_S"]


class DaskCluster:
    """A Dask client for a run: to an existing scheduler, or to a LocalCluster of ``workers``
    processes that this object starts and stops (a context manager; ``close()`` is idempotent).

    Args:
        scheduler: address of a running scheduler (``tcp://10.0.0.5:8786``).
        workers: number of local worker processes (one thread each) to start instead.
        connect_timeout_s: how long a scheduler has to answer.
        echo: where to say what was started (the dashboard's address); default stderr.

    Raises:
        ClusterError: the extra is missing, both or neither of scheduler / workers, or no answer.
    """

    def __init__(
        self,
        scheduler: str | None = None,
        workers: int | None = None,
        *,
        connect_timeout_s: float = DEFAULT_CONNECT_TIMEOUT_S,
        echo: Callable[[str], None] | None = None,
    ) -> None:
        if (scheduler is None) == (workers is None):
            raise ClusterError("give a scheduler address or a number of workers (one of them)")
        if workers is not None and workers < 1:
            raise ClusterError(f"--workers must be at least 1, got {workers}")
        self.scheduler, self.workers, self.connect_timeout_s = scheduler, workers, float(connect_timeout_s)
        self.echo = echo or (lambda line: print(line, file=sys.stderr))
        self.client: Any = None
        self._local: Any = None

    def __enter__(self) -> DaskCluster:
        distributed = import_distributed()
        if self.scheduler is not None:
            try:
                self.client = distributed.Client(
                    self.scheduler, timeout=self.connect_timeout_s
                )  # actors find their client as the default one
            except (OSError, TimeoutError, ValueError) as exc:
                raise ClusterError(
                    f"no Dask scheduler answered at {self.scheduler} within {self.connect_timeout_s:g} s "
                    f"({type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''})"
                ) from None
            self._wait_for_workers(
                1, f"the Dask scheduler at {self.scheduler} has no worker after {self.connect_timeout_s:g} s"
            )
            self.echo(f"sensorsel: dask scheduler {self.scheduler}: {len(self.client.nthreads())} workers")
            return self
        import importlib.util
        import logging

        import dask

        # the dashboard needs bokeh; without it the scheduler's HTTP server still starts, on the
        # default port 8787 unless told otherwise (taken by another cluster: a warning): a free port
        dashboard = importlib.util.find_spec("bokeh") is not None
        # the workers keep glibc's own malloc thresholds: Dask's nannies set MALLOC_TRIM_THRESHOLD_
        # to 64 KiB by default (to hand freed memory back to the system promptly), and setting it
        # fixes glibc's mmap threshold too, so every array of more than 128 KiB a route's scoring
        # allocates is mapped, faulted in page by page and unmapped again. Measured
        # (bench/parallel.py, the seven KITTI routes' greedy on 2 workers, alternating runs): the
        # workers' CPU 9.0-9.7 s with it and 7.5-7.9 s without, the greedy 6.6-7.2 s and 5.6-6.0 s.
        # A value the environment sets is still passed on (the user's, or an earlier cluster's in
        # this process: a nanny writes its variables into the environment it spawns from)
        with dask.config.set({"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None}):
            self._local = distributed.LocalCluster(
                n_workers=self.workers,
                threads_per_worker=1,
                processes=True,
                host="127.0.0.1",
                scheduler_port=0,
                dashboard_address="127.0.0.1:0",
                silence_logs=logging.ERROR,
                worker_dashboard_address=None,
            )
        self.client = distributed.Client(self._local)  # actors find their client as the default one
        # every worker registered before the first placement (the cluster starts them, they report later)
        assert self.workers is not None  # the constructor took a scheduler or workers
        self._wait_for_workers(
            self.workers,
            f"the local Dask cluster started fewer than {self.workers} workers within {self.connect_timeout_s:g} s",
        )
        where = self.client.dashboard_link if dashboard else "none (install bokeh for one)"
        self.echo(
            f"sensorsel: dask LocalCluster of {self.workers} worker processes at {self._local.scheduler_address}; "
            f"dashboard {where}"
        )
        return self

    def _wait_for_workers(self, n: int, failure: str) -> None:
        """Wait up to ``connect_timeout_s`` for ``n`` workers; else close the client (and the local
        cluster) and raise ClusterError: ``failure`` and the kind of error Dask gave."""
        try:
            self.client.wait_for_workers(n, timeout=self.connect_timeout_s)
        except (OSError, TimeoutError) as exc:
            self.close()
            raise ClusterError(f"{failure} ({type(exc).__name__})") from None

    def __exit__(self, *exc: Any) -> None:
        self.close()

    @property
    def executor(self) -> DaskExecutor:
        """The executor that runs a plan's tasks on this cluster (:mod:`sensorsel.pipeline`); started first."""
        if self.client is None:
            raise ClusterError("the Dask cluster is not started: use it in a with statement")
        return DaskExecutor(self.client)

    def close(self) -> None:
        if self.client is not None:
            self.client.close()
            self.client = None
        if self._local is not None:
            self._local.close()
            self._local = None
