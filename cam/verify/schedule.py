"""The three dexel grids through batches of moves on a pool of threads.

A grid's rays see the moves in order, but the grids are independent of each other:
grid X may sweep batch 2 while grid Z still sweeps batch 1. With one thread per grid
on fewer cores than grids (two cores, three grids) the third grid of every batch ran
alone while the other core waited: the wall time of a batch was about twice that of
one grid. Here each grid is a chain of tasks, one per batch, each submitted when the
grid's previous batch is done; the pool's queue rotates over the grids, so the cores
stay busy to the last batch (wall about 1.5 times one grid's on two cores).

Every grid still sweeps the same batches in the same order with the same compiled
call (``cam.verify.sweep.sweep_grid``), so the stock and the statistics do not depend
on the number of threads or the order in which the tasks ran.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ThreadPoolExecutor, wait

import numpy as np
from numpy.typing import NDArray

from cam.verify.dexel import TILE, DexelGrid
from cam.verify.sweep import sweep_grid

__all__ = ["sweep_grids"]

#: (tips, moves, axes, move ids, primitives, cutting flags, strides, primitive masks):
#: a sweep's arrays.
Job = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.int32],
            NDArray[np.float64], NDArray[np.bool_], NDArray[np.int64], NDArray[np.int64]]


def sweep_grid_batch(grid: DexelGrid, job: Job, begin: int, end: int,
                     stats: NDArray[np.float64]) -> None:
    """Moves ``begin:end`` of ``job`` through one grid (compiled, releases the GIL);
    their statistics into ``stats[begin:end]`` ((m, 4): cut sum, longest cut, overlap
    sum, longest overlap). A pool overflow grows the grid and resumes."""
    tips, moves, axes, ids, prims, cuts, strides, masks = job
    part = stats[begin:end]
    first = 0
    index = grid.sweep_index()
    while True:
        failed = sweep_grid(
            grid.lo, grid.hi, grid.lo_move, grid.hi_move, grid.start, grid.count,
            grid.cap, grid.used, grid.k, grid.origin, grid.shape, grid.pitch,
            index.tile_lo, index.tile_hi, index.dirty, TILE, tips[begin:end],
            moves[begin:end], axes[begin:end], ids[begin:end], prims, cuts, strides,
            masks[begin:end], first,
            part, index.acc, index.touched, grid.counters,
            index.mat_lo, index.mat_hi, index.gap_lo, index.gap_hi,
        )
        if failed < 0:
            return
        grid.grow()
        first = failed


def sweep_grids(grids: Sequence[DexelGrid], job: Job, batch: int | None, threads: int,
                done: Callable[[int], None] | None = None) -> list[NDArray[np.float64]]:
    """Sweep the moves of ``job`` through every grid, ``batch`` moves per compiled call.

    Parameters
    ----------
    grids : sequence of DexelGrid
    job : tuple
        ``(tips, moves, axes, move_ids, prims, cuts, strides)`` as ``Stock.sweep``
        makes them.
    batch : int or None
        Moves per call (``None``: all in one call per grid).
    threads : int
        Threads (at most one per grid; 1: the calling thread, grid after grid).
    done : callable, optional
        Called (in the calling thread) with the number of leading moves that every
        grid has swept, after each batch that advances it.

    Returns
    -------
    list of (m, 4) float64
        Per grid and move: cut sum, longest cut, overlap sum, longest overlap (ray
        lengths, mm).
    """
    m = len(job[0])
    size = m if batch is None else max(1, int(batch))
    bounds = [(s, min(m, s + size)) for s in range(0, m, size)]
    stats = [np.zeros((m, 4)) for _ in grids]
    if not bounds:
        return stats
    if threads <= 1 or m <= 1:
        for begin, end in bounds:
            for grid, out in zip(grids, stats, strict=True):
                sweep_grid_batch(grid, job, begin, end, out)
            if done is not None:
                done(end)
        return stats
    finished = [0] * len(grids)  # batches done per grid
    with ThreadPoolExecutor(max_workers=min(threads, len(grids))) as pool:
        def submit(g: int) -> Future[None]:
            begin, end = bounds[finished[g]]
            return pool.submit(sweep_grid_batch, grids[g], job, begin, end, stats[g])

        pending = {submit(g): g for g in range(len(grids))}
        while pending:
            ready, _ = wait(pending, return_when=FIRST_COMPLETED)
            for future in ready:
                g = pending.pop(future)
                future.result()  # a failure in a task is raised here
                before = min(finished)
                finished[g] += 1
                if finished[g] < len(bounds):
                    pending[submit(g)] = g
                if done is not None and min(finished) > before:
                    done(bounds[min(finished) - 1][1])
    return stats
