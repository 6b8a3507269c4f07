"""One dexel grid: rays parallel to a world axis holding sorted material intervals.

``DexelGrid`` is the thin facade over the pool arrays the kernels in
``cam.verify.kernels`` work on (layout described there). Grids are built from flat
interval lists (``from_intervals``), grow their pool when a sweep splits more
intervals than it has room for, and give back volume and surface samples.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numba import njit
from numpy.typing import NDArray


@njit(cache=True)
def _compact(lo, hi, lom, him, start, count, cap, size):  # type: ignore[no-untyped-def]
    """Copy the used intervals into a fresh pool of ``size`` with room to grow."""
    n_lo = np.empty(size)
    n_hi = np.empty(size)
    n_lom = np.empty(size, np.int32)
    n_him = np.empty(size, np.int32)
    new_start = np.empty_like(start)
    new_cap = np.empty_like(cap)
    pos = 0
    for r in range(start.shape[0]):
        c = count[r]
        room = max(cap[r], c + 2) if c > 0 else 0
        new_start[r] = pos
        new_cap[r] = room
        for m in range(c):
            n_lo[pos + m] = lo[start[r] + m]
            n_hi[pos + m] = hi[start[r] + m]
            n_lom[pos + m] = lom[start[r] + m]
            n_him[pos + m] = him[start[r] + m]
        pos += room
    return n_lo, n_hi, n_lom, n_him, new_start, new_cap, pos


@dataclass
class DexelGrid:
    """Rays along world axis ``k`` through the cell centres of a square grid.

    Attributes
    ----------
    k : int
        Ray direction: 0 (X), 1 (Y) or 2 (Z).
    origin : (2,) float64
        Grid corner on world axes ``(k+1) % 3`` and ``(k+2) % 3``, mm.
    shape : (2,) int64
        Number of rays along those two axes; ray ``r = i * shape[1] + j``.
    pitch : float
        Grid pitch h, mm.
    lo, hi : (P,) float64
        Interval pool: start and end coordinate along ``k``, mm.
    lo_move, hi_move : (P,) int32
        Index of the move that made each end (-1: the initial stock).
    start : (R,) int64
        First pool slot of each ray.
    count, cap : (R,) int32
        Intervals used and slots owned by each ray.
    used : (1,) int64
        Pool slots handed out.
    """

    k: int
    origin: NDArray[np.float64]
    shape: NDArray[np.int64]
    pitch: float
    lo: NDArray[np.float64]
    hi: NDArray[np.float64]
    lo_move: NDArray[np.int32]
    hi_move: NDArray[np.int32]
    start: NDArray[np.int64]
    count: NDArray[np.int32]
    cap: NDArray[np.int32]
    used: NDArray[np.int64]
    #: Sweep diagnostics accumulated by ``sweep.sweep_grid`` (see there).
    counters: NDArray[np.int64] = field(default_factory=lambda: np.zeros(6, np.int64))

    @classmethod
    def from_intervals(
        cls,
        k: int,
        origin: NDArray[np.float64],
        shape: tuple[int, int] | NDArray[np.int64],
        pitch: float,
        ray: NDArray[np.int64],
        lo: NDArray[np.float64],
        hi: NDArray[np.float64],
    ) -> DexelGrid:
        """Build a grid from flat intervals sorted by ray, then by ``lo``.

        Parameters
        ----------
        ray : (n,) int64
            Ray index of each interval.
        lo, hi : (n,) float64
            Interval ends along the ray, mm, disjoint and sorted within a ray.
        """
        shape_a = np.asarray(shape, dtype=np.int64).reshape(2)
        n_rays = int(shape_a[0] * shape_a[1])
        count = np.bincount(np.asarray(ray, np.int64), minlength=n_rays).astype(np.int32)
        cap = np.where(count > 0, count + 1, 0).astype(np.int32)  # room for one split
        start = np.zeros(n_rays, np.int64)
        start[1:] = np.cumsum(cap)[:-1]
        used = int(cap.sum())
        size = int(used * 1.25) + 1024
        pool_lo = np.zeros(size)
        pool_hi = np.zeros(size)
        first = np.zeros(n_rays, np.int64)
        first[1:] = np.cumsum(count)[:-1]
        slot = start[ray] + (np.arange(len(ray)) - first[ray])
        pool_lo[slot] = lo
        pool_hi[slot] = hi
        return cls(
            k=int(k),
            origin=np.asarray(origin, dtype=np.float64).reshape(2),
            shape=shape_a,
            pitch=float(pitch),
            lo=pool_lo,
            hi=pool_hi,
            lo_move=np.full(size, -1, np.int32),
            hi_move=np.full(size, -1, np.int32),
            start=start,
            count=count,
            cap=cap,
            used=np.array([used], np.int64),
        )

    @property
    def axes(self) -> tuple[int, int]:
        """World axes of the grid plane: ``((k+1) % 3, (k+2) % 3)``."""
        return (self.k + 1) % 3, (self.k + 2) % 3

    def grow(self) -> None:
        """Compact the pool and double its free room (after a kernel overflow)."""
        size = max(2 * len(self.lo), 1024)
        out = _compact(
            self.lo, self.hi, self.lo_move, self.hi_move, self.start, self.count, self.cap, size
        )
        self.lo, self.hi, self.lo_move, self.hi_move, self.start, self.cap, used = out
        self.used = np.array([used], np.int64)

    def slots(self) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        """Pool slots of all used intervals and the ray of each, in ray order."""
        total = int(self.count.sum())
        rays = np.repeat(np.arange(len(self.count), dtype=np.int64), self.count)
        first = np.zeros(len(self.count), np.int64)
        first[1:] = np.cumsum(self.count)[:-1]
        slot = self.start[rays] + (np.arange(total) - first[rays])
        return slot, rays

    def volume(self) -> float:
        """Material volume seen by this grid: sum of interval lengths times h^2, mm^3."""
        slot, _ = self.slots()
        return float(np.sum(self.hi[slot] - self.lo[slot]) * self.pitch**2)

    def ray_points(self, rays: NDArray[np.int64]) -> NDArray[np.float64]:
        """``(n, 3)`` points on the given rays with coordinate 0 along ``k``."""
        i, j = np.divmod(rays, self.shape[1])
        out = np.zeros((len(rays), 3))
        a, b = self.axes
        out[:, a] = self.origin[0] + (i + 0.5) * self.pitch
        out[:, b] = self.origin[1] + (j + 0.5) * self.pitch
        return out

    def ends(self) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int32]]:
        """Surface samples: every interval end with its outward normal and move id.

        Returns
        -------
        points : (2n, 3) float64
        normals : (2n, 3) float64
            ``-e_k`` at interval starts, ``+e_k`` at interval ends.
        moves : (2n,) int32
            Move that made the end (-1: initial stock).
        """
        slot, rays = self.slots()
        base = self.ray_points(rays)
        starts = base.copy()
        starts[:, self.k] = self.lo[slot]
        stops = base
        stops[:, self.k] = self.hi[slot]
        normals = np.zeros((2 * len(slot), 3))
        normals[: len(slot), self.k] = -1.0
        normals[len(slot) :, self.k] = 1.0
        moves = np.concatenate([self.lo_move[slot], self.hi_move[slot]])
        return np.vstack([starts, stops]), normals, moves

    def to_arrays(self, prefix: str) -> dict[str, NDArray]:
        """Compact arrays for saving (``<prefix>_...`` keys, see docs/formats.md)."""
        slot, _ = self.slots()
        return {
            f"{prefix}_meta": np.array([self.k, self.shape[0], self.shape[1]], np.int64),
            f"{prefix}_origin": self.origin,
            f"{prefix}_count": self.count,
            f"{prefix}_lo": self.lo[slot],
            f"{prefix}_hi": self.hi[slot],
            f"{prefix}_lo_move": self.lo_move[slot],
            f"{prefix}_hi_move": self.hi_move[slot],
        }

    @classmethod
    def from_arrays(cls, data: dict[str, NDArray], prefix: str, pitch: float) -> DexelGrid:
        """Inverse of ``to_arrays``."""
        meta = data[f"{prefix}_meta"]
        count = np.asarray(data[f"{prefix}_count"], np.int64)
        rays = np.repeat(np.arange(len(count), dtype=np.int64), count)
        grid = cls.from_intervals(
            int(meta[0]), data[f"{prefix}_origin"], (int(meta[1]), int(meta[2])), pitch,
            rays, data[f"{prefix}_lo"], data[f"{prefix}_hi"],
        )
        slot, _ = grid.slots()
        grid.lo_move[slot] = data[f"{prefix}_lo_move"]
        grid.hi_move[slot] = data[f"{prefix}_hi_move"]
        return grid
