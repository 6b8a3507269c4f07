"""Independent jobs of pure Python work on forked processes.

``impeller_cam.threads`` runs the compiled kernels (which release the GIL) on threads.
The finishing planner's per-pass work is mostly Python around those kernels, so
threads would wait on one another for the GIL; ``map_forked`` runs such jobs in
forked children instead. A fork inherits the caller's objects as they are (the
collision scene, meshes, grids), so only each job's index goes to a child and only
its result comes back (pickled).

A job that raises in a child is run again in the caller, which then raises its
exception with its own traceback; a child that dies (killed, out of memory), or a
result that does not pickle, leaves its jobs to the caller too. Where ``fork`` is not
available, with one worker, or in a child of ``map_forked`` itself, the jobs run in
the caller, one after the other. Either way the results are those of the plain
calls, in the jobs' order.

An object the jobs change as a side effect (query counters, answers kept for the
next question) can be handed in as ``keep``: it has ``fork_mark()`` (its state now),
``fork_delta(mark)`` (what changed since, to pickle) and ``merge_fork_delta(delta)``
(add that); each child's delta is merged into the caller's object as its job
finishes, so the object ends as if every job had run in the caller. Its optional
``fork_prepare()`` builds, before the fork, what every child would otherwise build
for itself (what is built on first use and is not picklable: fcl objects).
"""

from __future__ import annotations

import logging
import multiprocessing
import os
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from typing import Any, TypeVar

from impeller_cam.threads import default_threads

__all__ = ["map_forked"]

T = TypeVar("T")

_LOG = logging.getLogger(__name__)

#: The job function of the pool being run (inherited by its forked children).
_JOB: Callable[[int], Any] | None = None


def _run(index: int) -> tuple[int, bool, Any]:
    """In a child: ``(index, True, result)``, or ``(index, False, None)`` when the job
    raised (the caller runs it again to raise it)."""
    assert _JOB is not None
    try:
        return index, True, _JOB(index)
    except Exception:
        return index, False, None


def map_forked(job: Callable[[int], T], count: int, workers: int | None = None,
               costs: Sequence[float] | None = None,
               done: Callable[[int, T], None] | None = None, keep: Any = None,
               prepare: Callable[[], None] | None = None) -> list[T]:
    """``[job(0), ..., job(count - 1)]``, the jobs run on up to ``workers`` forked
    processes.

    Parameters
    ----------
    job : callable
        ``job(i)``: must not depend on the other jobs' side effects (each child has
        its own copy of the caller's objects); its result must pickle.
    count : int
        Number of jobs.
    workers : int, optional
        Processes at most (default ``default_threads()``: the CPUs this process may
        use, or ``IMPELLER_CAM_THREADS``); 1: in the caller.
    costs : sequence of float, optional
        One per job, any unit: the costliest jobs start first, so that a long job
        does not start last and leave the other workers idle.
    done : callable, optional
        ``done(i, result)``, called in the caller as each job finishes (any order).
    keep : object, optional
        What the jobs change and the caller keeps (module docstring; an object
        without ``fork_mark`` is ignored); its ``fork_prepare()``, when it has one,
        runs before the fork.
    prepare : callable, optional
        Called in the caller before it forks (not with one worker): build there what
        every job would build for itself.

    Returns
    -------
    list
        The jobs' results in the jobs' order.
    """
    global _JOB
    if getattr(keep, "fork_mark", None) is not None:
        return _map_keeping(job, count, workers, costs, done, keep)
    order = list(range(count)) if costs is None else sorted(range(count),
                                                             key=lambda i: -costs[i])
    size = min(count, default_threads() if workers is None else int(workers))
    results: dict[int, Any] = {}
    left = order
    forked = size > 1 and "fork" in multiprocessing.get_all_start_methods() and _JOB is None
    if forked:
        if prepare is not None:
            prepare()
        _JOB = job
        try:
            left = []
            with ProcessPoolExecutor(size, mp_context=multiprocessing.get_context("fork")) \
                    as pool:
                running: dict[Future[tuple[int, bool, Any]], int] = {
                    pool.submit(_run, i): i for i in order}
                while running:
                    finished, _ = wait(running, return_when=FIRST_COMPLETED)
                    for future in finished:
                        index = running.pop(future)
                        try:
                            _, ok, value = future.result()
                        except Exception:  # a dead child, a result that does not pickle
                            ok = False
                        if not ok:
                            left.append(index)
                            continue
                        results[index] = value
                        if done is not None:
                            done(index, value)
        finally:
            _JOB = None
        left.sort(key=order.index)
    failed = set(left) if forked else set()
    for index in left:  # one worker, no fork, or what failed in a child
        results[index] = job(index)
        if index in failed:  # it raised there, or its result did not come back
            _LOG.warning("job %d of %d failed in a forked process and ran in the caller",
                         index, count)
        if done is not None:
            done(index, results[index])
    return [results[i] for i in range(count)]


def _map_keeping(job: Callable[[int], T], count: int, workers: int | None,
                 costs: Sequence[float] | None, done: Callable[[int, T], None] | None,
                 keep: Any) -> list[T]:
    """``map_forked`` with ``keep``: each child's change to it merged in the caller."""
    caller = os.getpid()

    def marked(i: int) -> tuple[T, Any]:
        mark = keep.fork_mark()
        value = job(i)
        return value, None if os.getpid() == caller else keep.fork_delta(mark)

    def merged(i: int, result: tuple[T, Any]) -> None:
        if result[1] is not None:
            keep.merge_fork_delta(result[1])
        if done is not None:
            done(i, result[0])

    return [value for value, _ in map_forked(marked, count, workers, costs, merged,
                                             prepare=getattr(keep, "fork_prepare", None))]
