"""DaskCluster's workers: a scheduler that has none is one ClusterError naming the scheduler and the
timeout, and the client it opened is closed (no half-started cluster is left behind); the local
workers it starts keep glibc's malloc thresholds and one BLAS thread."""

from __future__ import annotations

import os

import pytest

distributed = pytest.importorskip("distributed")

from sensorsel.pipeline import ClusterError  # noqa: E402
from sensorsel.pipeline.cluster import DaskCluster  # noqa: E402


def test_a_scheduler_without_workers_is_one_error_and_the_client_is_closed():
    with distributed.LocalCluster(
        n_workers=0,
        processes=False,
        protocol="tcp://",
        host="127.0.0.1",
        scheduler_port=0,
        dashboard_address="127.0.0.1:0",
    ) as bare:
        address = bare.scheduler_address
        cluster = DaskCluster(scheduler=address, connect_timeout_s=1.0, echo=lambda line: None)
        with pytest.raises(ClusterError) as err:
            cluster.__enter__()
        # the kind of timeout Dask gives, in brackets (WorkerStartTimeoutError in distributed 2024)
        assert str(err.value).startswith(f"the Dask scheduler at {address} has no worker after 1 s (")
        assert str(err.value).endswith("TimeoutError)")
        assert cluster.client is None


def _local_workers_environ(monkeypatch: pytest.MonkeyPatch, value: str | None) -> dict[str, str | None]:
    """The malloc and BLAS variables a worker of DaskCluster(workers=1) has, ``value`` being this
    process's MALLOC_TRIM_THRESHOLD_ (None: unset) when it starts the cluster."""
    if value is None:
        monkeypatch.delenv("MALLOC_TRIM_THRESHOLD_", raising=False)
    else:
        monkeypatch.setenv("MALLOC_TRIM_THRESHOLD_", value)
    names = ("MALLOC_TRIM_THRESHOLD_", "OPENBLAS_NUM_THREADS")
    with DaskCluster(workers=1, echo=lambda line: None) as cluster:
        (env,) = cluster.client.run(lambda: {n: os.environ.get(n) for n in names}).values()
    return env


def test_local_workers_keep_glibcs_malloc_thresholds_and_one_blas_thread(monkeypatch):
    # not Dask's 64 KiB trim threshold (which maps and unmaps every array over 128 KiB afresh), still
    # Dask's single BLAS thread per worker
    assert _local_workers_environ(monkeypatch, None) == {"MALLOC_TRIM_THRESHOLD_": None, "OPENBLAS_NUM_THREADS": "1"}
    # a threshold the user's environment sets is theirs: passed on
    assert _local_workers_environ(monkeypatch, "262144")["MALLOC_TRIM_THRESHOLD_"] == "262144"
