"""A Dask client for the project's parallel sweeps and batches, opened and closed in one place.

Local worker processes by default (one thread each: the work is numpy/numba and holds
the GIL in places), or an existing cluster given by its scheduler address.
"""

from __future__ import annotations

import logging
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from impeller_cam.errors import InputError

__all__ = ["dask_client"]


@contextmanager
def dask_client(scheduler: str | None, workers: int, connect_timeout: float = 10.0
                ) -> Iterator[Any]:
    """Yield a ``dask.distributed.Client``; close it (and a local cluster) on exit.

    Parameters
    ----------
    scheduler : str or None
        Scheduler address (``tcp://host:8786``); None starts a local cluster.
    workers : int
        Worker processes of the local cluster.
    connect_timeout : float
        Seconds to wait for a remote scheduler.

    Raises
    ------
    InputError
        The scheduler cannot be reached (field ``--scheduler``).
    """
    from dask.distributed import Client, LocalCluster

    cluster = None
    if scheduler is None:
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               dashboard_address=":0", silence_logs=logging.ERROR)
        client = Client(cluster)
    else:
        try:
            client = Client(scheduler, timeout=f"{connect_timeout}s")
        except (OSError, TimeoutError) as error:
            raise InputError(f"cannot reach the Dask scheduler: {error}",
                             field="--scheduler", value=scheduler,
                             accepted="a running scheduler address, e.g. tcp://host:8786"
                             ) from None
    try:
        yield client
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
