"""One dexel grid: rays parallel to a world axis holding sorted material intervals.

``DexelGrid`` is the thin facade over the pool arrays the kernels in
``cam.verify.kernels`` work on (layout described there). Grids are built from flat
interval lists (``from_intervals``), grow their pool when a sweep splits more
intervals than it has room for, and give back volume and surface samples.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numba import njit
from numpy.typing import NDArray

from cam.verify.kernels import tile_bounds

#: Rays per side of the blocks the sweep skips at once (``kernels.tile_bounds``).
TILE = 16


@njit(cache=True, nogil=True)
def material_range(lo, hi, start, count):  # type: ignore[no-untyped-def]
    """Per ray: lowest start and highest end of its material (inf, -inf when none),
    and its first gap, the end of its first interval and the start of its second
    (inf, -inf when it has fewer than two)."""
    n_rays = count.shape[0]
    mat_lo = np.full(n_rays, np.inf)
    mat_hi = np.full(n_rays, -np.inf)
    gap_lo = np.full(n_rays, np.inf)
    gap_hi = np.full(n_rays, -np.inf)
    for r in range(n_rays):
        n = count[r]
        if n > 0:
            mat_lo[r] = lo[start[r]]
            mat_hi[r] = hi[start[r] + n - 1]
        if n > 1:
            gap_lo[r] = hi[start[r]]
            gap_hi[r] = lo[start[r] + 1]
    return mat_lo, mat_hi, gap_lo, gap_hi


@njit(cache=True, nogil=True)
def fill_ends(lo, hi, lom, him, start, count, origin, shape, pitch, k, a, b, points, moves,
              offset):  # type: ignore[no-untyped-def]
    """Write a grid's interval ends into ``points[offset:]`` (n, 3) and ``moves``.

    The order and the values of ``DexelGrid.ends``: every interval's start in ray
    order, then every interval's end; coordinate ``a`` of a ray's points
    ``origin[0] + (i + 0.5) * pitch``, ``b`` likewise with ``j``, ``k`` the end.
    Returns the number of ends written (twice the intervals).
    """
    nj = shape[1]
    total = 0
    for r in range(count.shape[0]):
        total += count[r]
    w0 = offset
    w1 = offset + total
    for r in range(count.shape[0]):
        n = count[r]
        if n == 0:
            continue
        i = r // nj
        j = r - i * nj
        ca = origin[0] + (i + 0.5) * pitch
        cb = origin[1] + (j + 0.5) * pitch
        base = start[r]
        for m in range(n):
            points[w0, a] = ca
            points[w0, b] = cb
            points[w0, k] = lo[base + m]
            moves[w0] = lom[base + m]
            points[w1, a] = ca
            points[w1, b] = cb
            points[w1, k] = hi[base + m]
            moves[w1] = him[base + m]
            w0 += 1
            w1 += 1
    return 2 * total


@njit(cache=True, nogil=True)
def refresh_tiles(lo, hi, start, count, shape, tile, t_lo, t_hi, dirty):  # type: ignore[no-untyped-def]
    """Recompute the material range of the tiles flagged in ``dirty`` (and clear the
    flags); the others are left as they are."""
    nj = shape[1]
    for ti in range(dirty.shape[0]):
        for tj in range(dirty.shape[1]):
            if not dirty[ti, tj]:
                continue
            dirty[ti, tj] = False
            a = math.inf
            b = -math.inf
            for i in range(ti * tile, min(shape[0], (ti + 1) * tile)):
                for j in range(tj * tile, min(nj, (tj + 1) * tile)):
                    r = i * nj + j
                    n = count[r]
                    if n > 0:
                        a = min(a, lo[start[r]])
                        b = max(b, hi[start[r] + n - 1])
            t_lo[ti, tj] = a
            t_hi[ti, tj] = b


@dataclass
class SweepIndex:
    """What the sweep keeps of a grid between calls, up to date after every change.

    Attributes
    ----------
    mat_lo, mat_hi, gap_lo, gap_hi : (R,) float64
        Per ray: ``material_range``.
    tile_lo, tile_hi : (TI, TJ) float64
        Per ``TILE`` x ``TILE`` block of rays: lowest start and highest end of its
        material, mm. A block the sweep changed is flagged in ``dirty`` and refreshed
        before the next call (material only goes, so a stale range still bounds it).
    dirty : (TI, TJ) bool
    acc : (R,) float64
        Zeros (the per-ray cut of the move in progress while a sweep runs).
    touched : (R + 1,) int64
        Zeros (the rays in ``acc`` while a sweep runs, ``touched[0]`` their count).
    """

    mat_lo: NDArray[np.float64]
    mat_hi: NDArray[np.float64]
    gap_lo: NDArray[np.float64]
    gap_hi: NDArray[np.float64]
    tile_lo: NDArray[np.float64]
    tile_hi: NDArray[np.float64]
    dirty: NDArray[np.bool_]
    acc: NDArray[np.float64]
    touched: NDArray[np.int64]


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
    #: Summaries the sweep keeps (``sweep_index``); None until built.
    index: SweepIndex | None = field(default=None, repr=False, compare=False)

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
        grid = cls(
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
        grid.sweep_index()  # part of the grid: built with it, kept by every sweep
        return grid

    def sweep_index(self) -> SweepIndex:
        """The summaries the sweep works with (built once, then kept up to date by
        ``sweep.sweep_grid``; a kernel that changes the pool otherwise must call
        ``invalidate``)."""
        if self.index is None:
            n_rays = len(self.count)
            t_lo, t_hi = tile_bounds(self.lo, self.hi, self.start, self.count, self.shape,
                                     TILE)
            m_lo, m_hi, g_lo, g_hi = material_range(self.lo, self.hi, self.start, self.count)
            self.index = SweepIndex(
                mat_lo=m_lo, mat_hi=m_hi, gap_lo=g_lo, gap_hi=g_hi, tile_lo=t_lo,
                tile_hi=t_hi, dirty=np.zeros(t_lo.shape, np.bool_),
                acc=np.zeros(n_rays), touched=np.zeros(n_rays + 1, np.int64),
            )
        else:
            index = self.index
            refresh_tiles(self.lo, self.hi, self.start, self.count, self.shape, TILE,
                          index.tile_lo, index.tile_hi, index.dirty)
        return self.index

    def invalidate(self) -> None:
        """Forget the sweep's summaries (after changing the pool outside a sweep)."""
        self.index = None

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

    def n_ends(self) -> int:
        """Interval ends (surface samples) of the grid: twice its intervals."""
        return 2 * int(self.count.sum())

    def fill_ends(self, points: NDArray[np.float64], moves: NDArray[np.int32],
                  offset: int) -> int:
        """Write ``ends()``'s points and move ids (without normals) into
        ``points[offset:]`` ((n, 3) float64, mm) and ``moves[offset:]`` (compiled, no
        temporaries); returns the number written (``n_ends``)."""
        a, b = self.axes
        return int(fill_ends(self.lo, self.hi, self.lo_move, self.hi_move, self.start,
                             self.count, self.origin, np.asarray(self.shape, np.int64),
                             float(self.pitch), self.k, a, b, points, moves, offset))

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
