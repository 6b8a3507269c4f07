"""How many threads the project's compiled work uses, and a pool that runs
independent jobs on them.

The numba kernels of the collision grids and of the dexel sweep release the GIL
(``nogil=True``), so independent calls of them run in parallel on threads of one
process: no pickling, no second copy of the meshes.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import TypeVar

__all__ = ["default_threads", "run_on_threads"]

T = TypeVar("T")


def default_threads() -> int:
    """Threads for a sweep, a grid build or a distance query: ``IMPELLER_CAM_THREADS``
    or the CPUs this process may use."""
    env = os.environ.get("IMPELLER_CAM_THREADS", "")
    if env.isdigit() and int(env) > 0:
        return int(env)
    if hasattr(os, "sched_getaffinity"):
        return max(1, len(os.sched_getaffinity(0)))
    return max(1, os.cpu_count() or 1)


def run_on_threads(jobs: Sequence[Callable[[], T]], threads: int | None = None,
                   costs: Sequence[float] | None = None) -> list[T]:
    """Results of ``jobs`` in their order, run on up to ``threads`` threads
    (default ``default_threads()``; one thread: in the caller's, one after the other).

    ``costs`` (one per job, any unit): the jobs start in decreasing cost, so that a
    long job does not start last and leave the other threads idle; the results keep
    the jobs' order. An exception of a job is raised here, as a plain call would
    raise it.
    """
    count = min(len(jobs), threads if threads is not None else default_threads())
    if count <= 1:
        return [job() for job in jobs]
    order = range(len(jobs)) if costs is None else sorted(
        range(len(jobs)), key=lambda i: -costs[i])
    with ThreadPoolExecutor(max_workers=count) as pool:
        futures = {i: pool.submit(jobs[i]) for i in order}
        return [futures[i].result() for i in range(len(jobs))]
