"""DaskCluster's wait for workers: a scheduler that has none is one ClusterError naming the scheduler
and the timeout, and the client it opened is closed (no half-started cluster is left behind)."""

from __future__ import annotations

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
