"""The paper's search for the S-curve inputs with the shortest positioning time (M5).

Seed 000, section III.C: with the stroke fixed, scan S in 0..115 (step 2.5), Amaxu and
|Amaxd| in 10,000..30,000 mm/s^2 (step 500) and Vmax in 200..500 mm/s (step 5):
47 x 41 x 41 x 61 = 4,819,427 profiles. The result is the best asymmetric input
(Amaxu != Amaxd allowed), the best symmetric one (Amaxu = Amaxd) and the paper's
Case I (all maxima, S = 22) for comparison.

The grid is cut into a few hundred index ranges; each task rebuilds its parameters
from the indices (tasks are tiny to ship), plans the profiles and computes positioning
times in closed form (``cam.motion.positioning``). Tasks run on Dask: a
``LocalCluster`` of worker processes by default, or an existing cluster given by its
scheduler address; ``workers=0`` runs them in this process (no Dask).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cam.motion.plant import TwoMassPlant
from cam.motion.positioning import Settling, positioning_times
from cam.motion.scurve import PAPER_PID_PERIOD, plan_scurve
from impeller_cam.cluster import dask_client
from impeller_cam.errors import InputError

#: The paper's Case I S factor (all other parameters at their maxima).
CASE_I_S_FACTOR = 22.0

#: ``progress(done, total)``: called as tasks finish.
Progress = Callable[[int, int], None]

#: Aim for this many tasks over the grid.
DEFAULT_TASKS = 200


def value_range(start: float, stop: float, step: float, name: str) -> NDArray[np.float64]:
    """Inclusive range ``start, start + step, ..., <= stop`` (robust to rounding).

    Raises
    ------
    InputError
        When ``step <= 0`` or ``stop < start`` or a value is not finite.
    """
    values = (start, stop, step)
    if not all(math.isfinite(v) for v in values) or step <= 0.0 or stop < start:
        raise InputError("invalid grid range", field=name, value=values,
                         accepted="finite start <= stop and step > 0")
    count = int(math.floor((stop - start) / step + 1e-9)) + 1
    return start + step * np.arange(count, dtype=np.float64)


@dataclass(frozen=True)
class Grid:
    """Parameter values searched (each a sorted 1-D array).

    Attributes
    ----------
    s_factor : (ns,) float64
    amax_up : (na,) float64
        mm/s^2.
    amax_down : (nd,) float64
        Magnitudes, mm/s^2.
    vmax : (nv,) float64
        mm/s.
    """

    s_factor: NDArray[np.float64]
    amax_up: NDArray[np.float64]
    amax_down: NDArray[np.float64]
    vmax: NDArray[np.float64]

    @property
    def shape(self) -> tuple[int, int, int, int]:
        """``(ns, na, nd, nv)``."""
        return (len(self.s_factor), len(self.amax_up), len(self.amax_down), len(self.vmax))

    @property
    def size(self) -> int:
        """Number of profiles."""
        return int(np.prod(self.shape))

    def parameters(self, start: int, stop: int) -> tuple[
        NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]
    ]:
        """(vmax, amax_up, amax_down, s_factor) of the flat indices ``start:stop``."""
        i_s, i_a, i_d, i_v = np.unravel_index(np.arange(start, stop), self.shape)
        return self.vmax[i_v], self.amax_up[i_a], self.amax_down[i_d], self.s_factor[i_s]

    def describe(self) -> dict[str, Any]:
        """JSON-ready description (first, last, count of each axis)."""
        def axis(values: NDArray[np.float64]) -> dict[str, float | int]:
            return {"first": float(values[0]), "last": float(values[-1]), "count": len(values)}

        return {"s_factor": axis(self.s_factor), "amax_up_mm_s2": axis(self.amax_up),
                "amax_down_mm_s2": axis(self.amax_down), "vmax_mm_s": axis(self.vmax),
                "profiles": self.size}


def paper_grid() -> Grid:
    """The paper's grid: S 0..115/2.5, A 10,000..30,000/500 (both), V 200..500/5."""
    accel = value_range(10000.0, 30000.0, 500.0, "amax")
    return Grid(value_range(0.0, 115.0, 2.5, "s_factor"), accel, accel.copy(),
                value_range(200.0, 500.0, 5.0, "vmax"))


@dataclass(frozen=True)
class Candidate:
    """One input and its times (s); accelerations mm/s^2, velocity mm/s."""

    amax_up: float
    amax_down: float
    vmax: float
    s_factor: float
    access_time: float
    settling_time: float

    @property
    def positioning_time(self) -> float:
        """Access + settling, s."""
        return self.access_time + self.settling_time

    def as_dict(self) -> dict[str, float]:
        """JSON-ready (boundary units)."""
        return {"amax_up_mm_s2": self.amax_up, "amax_down_mm_s2": self.amax_down,
                "vmax_mm_s": self.vmax, "s_factor": self.s_factor,
                "access_time_s": self.access_time, "settling_time_s": self.settling_time,
                "positioning_time_s": self.positioning_time}


@dataclass
class OptimisationResult:
    """Positioning time over the grid and the best inputs.

    Attributes
    ----------
    grid : Grid
    times : (ns, na, nd, nv) float64
        Positioning time of every profile, s.
    best, best_symmetric, case_max : Candidate
    stroke : float
        mm.
    """

    grid: Grid
    times: NDArray[np.float64]
    best: Candidate
    best_symmetric: Candidate
    case_max: Candidate
    stroke: float
    extra: dict[str, Any] = field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready summary (the CLI's ``--json`` object)."""
        return {
            "stroke_mm": self.stroke,
            "positioning_time_s": {"best": self.best.positioning_time,
                                   "best_symmetric": self.best_symmetric.positioning_time,
                                   "case_max": self.case_max.positioning_time},
            "best": self.best.as_dict(),
            "best_symmetric": self.best_symmetric.as_dict(),
            "case_max": self.case_max.as_dict(),
            "improvement_vs_case_max": 1.0 - self.best.positioning_time
            / self.case_max.positioning_time,
            "grid": self.grid.describe(),
            **self.extra,
        }


def evaluate(
    plant: TwoMassPlant,
    stroke: float,
    vmax: NDArray[np.float64],
    amax_up: NDArray[np.float64],
    amax_down: NDArray[np.float64],
    s_factor: NDArray[np.float64],
    settling: Settling,
    pid_period: float = PAPER_PID_PERIOD,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Access and settling times ``(n,)`` of explicit inputs, s."""
    profiles = plan_scurve(stroke, vmax, amax_up, amax_down, s_factor, pid_period)
    times = positioning_times(plant, profiles, settling)
    return times.access, times.settling


def evaluate_range(
    plant: TwoMassPlant, stroke: float, grid: Grid, start: int, stop: int,
    settling: Settling, pid_period: float,
) -> NDArray[np.float64]:
    """Positioning times of the flat grid indices ``start:stop`` (one task), s."""
    vmax, amax_up, amax_down, s_factor = grid.parameters(start, stop)
    access, settle = evaluate(plant, stroke, vmax, amax_up, amax_down, s_factor, settling,
                              pid_period)
    return access + settle


def _candidate(
    plant: TwoMassPlant, stroke: float, params: tuple[float, float, float, float],
    settling: Settling, pid_period: float,
) -> Candidate:
    v, au, ad, s = params
    access, settle = evaluate(plant, stroke, np.array([v]), np.array([au]), np.array([ad]),
                              np.array([s]), settling, pid_period)
    return Candidate(au, ad, v, s, float(access[0]), float(settle[0]))


def _ranges(size: int, tasks: int) -> list[tuple[int, int]]:
    tasks = max(1, min(tasks, size))
    edges = np.linspace(0, size, tasks + 1).round().astype(np.int64)
    return [(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:], strict=True) if b > a]


def _submit(
    client: Any, plant: TwoMassPlant, stroke: float, grid: Grid, settling: Settling,
    pid_period: float, ranges: list[tuple[int, int]], progress: Progress | None = None,
) -> list[NDArray[np.float64]]:
    from dask.distributed import as_completed

    grid_future = client.scatter(grid, broadcast=True)
    futures = [client.submit(evaluate_range, plant, stroke, grid_future, a, b, settling,
                             pid_period, pure=False) for a, b in ranges]
    if progress is not None:
        for done, _ in enumerate(as_completed(futures), start=1):
            progress(done, len(futures))
    return list(client.gather(futures))


def _run_tasks(
    plant: TwoMassPlant, stroke: float, grid: Grid, settling: Settling, pid_period: float,
    ranges: list[tuple[int, int]], scheduler: str | None, workers: int,
    connect_timeout: float, client: Any = None, progress: Progress | None = None,
) -> list[NDArray[np.float64]]:
    if client is not None:
        return _submit(client, plant, stroke, grid, settling, pid_period, ranges, progress)
    if scheduler is None and workers == 0:
        parts = []
        for done, (a, b) in enumerate(ranges, start=1):
            parts.append(evaluate_range(plant, stroke, grid, a, b, settling, pid_period))
            if progress is not None:
                progress(done, len(ranges))
        return parts
    with dask_client(scheduler, workers, connect_timeout) as client:
        return _submit(client, plant, stroke, grid, settling, pid_period, ranges, progress)


def optimise(
    plant: TwoMassPlant,
    stroke: float,
    grid: Grid | None = None,
    settling: Settling | None = None,
    pid_period: float = PAPER_PID_PERIOD,
    scheduler: str | None = None,
    workers: int = 2,
    tasks: int = DEFAULT_TASKS,
    connect_timeout: float = 10.0,
    client: Any = None,
    progress: Progress | None = None,
) -> OptimisationResult:
    """Search the grid for the shortest positioning time.

    Parameters
    ----------
    plant : TwoMassPlant
    stroke : float
        Move length, mm (> 0).
    grid : Grid, optional
        Default: ``paper_grid()``.
    settling : Settling, optional
        Default: +/-840 mm/s^2 on table acceleration, 250 us grid.
    pid_period : float
        s; ``tj = S * pid_period``.
    scheduler : str, optional
        Address of a running Dask scheduler; when given, ``workers`` is ignored.
    workers : int
        Local worker processes of a ``LocalCluster``; 0 = run in this process.
    tasks : int
        Number of tasks the grid is cut into.
    connect_timeout : float
        Seconds to wait for the scheduler at ``scheduler``.
    client : dask.distributed.Client, optional
        An open client to run the tasks on (left open); overrides ``scheduler`` and
        ``workers``.
    progress : callable(done, total), optional
        Called as tasks finish (the CLI draws a progress bar on a TTY).

    Returns
    -------
    OptimisationResult
        Ties go to the first grid index (S, Amaxu, Amaxd, Vmax order): deterministic.
    """
    if not (math.isfinite(stroke) and stroke > 0.0):
        raise InputError("must be a finite number > 0", field="stroke", value=stroke,
                         accepted="a stroke in mm > 0")
    if workers < 0:
        raise InputError("must be >= 0", field="workers", value=workers,
                         accepted="0 (this process) or a number of worker processes")
    grid = paper_grid() if grid is None else grid
    settling = Settling() if settling is None else settling
    ranges = _ranges(grid.size, tasks)
    parts = _run_tasks(plant, stroke, grid, settling, pid_period, ranges, scheduler, workers,
                       connect_timeout, client, progress)
    times = np.concatenate(parts).reshape(grid.shape)

    best_index = int(np.argmin(times))
    symmetric = times.copy()
    same = grid.amax_up[:, None] == grid.amax_down[None, :]
    symmetric[:, ~same, :] = np.inf
    sym_index = int(np.argmin(symmetric))
    if not np.isfinite(symmetric.flat[sym_index]):
        raise InputError("the grid has no symmetric input (Amaxu = Amaxd)", field="grid",
                         accepted="acceleration ranges that share values")

    def params(index: int) -> tuple[float, float, float, float]:
        v, au, ad, s = grid.parameters(index, index + 1)
        return float(v[0]), float(au[0]), float(ad[0]), float(s[0])

    case = (float(grid.vmax[-1]), float(grid.amax_up[-1]), float(grid.amax_down[-1]),
            CASE_I_S_FACTOR)
    return OptimisationResult(
        grid=grid,
        times=times,
        best=_candidate(plant, stroke, params(best_index), settling, pid_period),
        best_symmetric=_candidate(plant, stroke, params(sym_index), settling, pid_period),
        case_max=_candidate(plant, stroke, case, settling, pid_period),
        stroke=stroke,
        extra={"tasks": len(ranges)},
    )
