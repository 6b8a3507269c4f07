"""Stock of a fixed-axis (3+2) region as a Z-map in the region's frame (axis = +Z).

The tool of a 3+2 region is a ball of radius R with its cylinder (flutes, shank)
above it along +Z: wherever the ball centre has been at ``c``, the column of radius R
above the ball's lower half (``z >= c_z - sqrt(R^2 - d^2)`` at XY distance ``d``) is
air afterwards. Together with the air above the blank, the air is the region above
a height field ``G(x, y)`` on a square grid of nodes:

* ``T(x, y)``: the top of the blank along the frame's Z (the first point of the blank
  met coming down from +inf; ``-inf`` where the column misses it);
* ``F(x, y)``: the lowest ball bottom swept there so far (``+inf`` before any cut),
  the moves swept as segments (XY distance to the segment) cut into pieces that
  rise at most ``SWEEP_RISE``;
* ``G = min(T, F)``.

``air_height`` is the lowest ball-centre height at an XY point whose ball lies in air
(above ``G`` at every node of its footprint): ``max_nodes G + sqrt(R^2 - d^2)``, the
drop-cutter of the ball against the Z-map. Links, approaches and entries use it, and
``rapids_in_stock`` replays a whole program through the map: every rapid move,
sampled, must keep its ball in air given the cuts made before it.

Resolution: the map knows the stock at its nodes (``cell``, default 0.5 mm). Between
nodes the wall at the rim of a cut groove stands where no node sees it, so the link
planner asks ``air_height(conservative=True)``: each node's ground is the highest of
its 3 x 3 neighbourhood and stands anywhere within ``cell / sqrt(2)`` of the node.
The check (``rapids_in_stock``, ``aircheck``) asks the nodes as they are: a node
inside a rapid's ball is stock there (within ``tolerance``).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray
from scipy.ndimage import maximum_filter

from cam.roughing.dropcutter import DropCutter
from postproc.toolpath import MoveKind

__all__ = ["ZMap", "rapids_in_stock"]

#: Sample spacing of moves checked against the map, mm.
SWEEP_STEP = 0.5
#: Largest height change of a swept sub-segment (the floor is conservative by it), mm.
SWEEP_RISE = 0.05


@numba.njit(cache=True)
def _sweep(floor: NDArray[np.float64], origin: NDArray[np.float64], cell: float,
           a: NDArray[np.float64], b: NDArray[np.float64], radius: float) -> None:
    """Lower ``floor`` under the ball moving along the segments ``a[k] -> b[k]``.

    At XY distance ``d`` from a segment's XY projection the floor becomes
    ``max(a_z, b_z) - sqrt(R^2 - d^2)``: the ball at the nearest point of the segment
    removes down to its own height minus the root, which is no lower (a conservative
    floor; callers cut the segments so that their height changes little).
    """
    nx, ny = floor.shape
    r2 = radius * radius
    for k in range(a.shape[0]):
        ax, ay, bx, by = a[k, 0], a[k, 1], b[k, 0], b[k, 1]
        top = max(a[k, 2], b[k, 2])
        ex, ey = bx - ax, by - ay
        ee = ex * ex + ey * ey
        i0 = max(0, int(math.ceil((min(ax, bx) - radius - origin[0]) / cell)))
        i1 = min(nx - 1, int(math.floor((max(ax, bx) + radius - origin[0]) / cell)))
        j0 = max(0, int(math.ceil((min(ay, by) - radius - origin[1]) / cell)))
        j1 = min(ny - 1, int(math.floor((max(ay, by) + radius - origin[1]) / cell)))
        for i in range(i0, i1 + 1):
            px = origin[0] + i * cell - ax
            for j in range(j0, j1 + 1):
                py = origin[1] + j * cell - ay
                t = 0.0
                if ee > 0.0:
                    t = min(1.0, max(0.0, (px * ex + py * ey) / ee))
                dx = px - t * ex
                dy = py - t * ey
                d2 = dx * dx + dy * dy
                if d2 <= r2:
                    bottom = top - math.sqrt(r2 - d2)
                    if bottom < floor[i, j]:
                        floor[i, j] = bottom


@numba.njit(cache=True)
def _air(ground: NDArray[np.float64], origin: NDArray[np.float64], cell: float,
         points: NDArray[np.float64], radius: float, grow: float) -> NDArray[np.float64]:
    """Lowest ball-centre heights in air over XY ``points``; +inf off the map.

    A node at XY distance ``d`` counts with ``ground + sqrt(R^2 - max(d - grow, 0)^2)``
    when ``d <= R + grow``: ``grow`` > 0 stands for stock anywhere within ``grow`` of
    the node (the planner's conservative view of the cells between nodes).
    """
    nx, ny = ground.shape
    r2 = radius * radius
    reach = radius + grow
    out = np.empty(points.shape[0])
    for k in range(points.shape[0]):
        x, y = points[k, 0], points[k, 1]
        i0 = int(math.ceil((x - reach - origin[0]) / cell))
        i1 = int(math.floor((x + reach - origin[0]) / cell))
        j0 = int(math.ceil((y - reach - origin[1]) / cell))
        j1 = int(math.floor((y + reach - origin[1]) / cell))
        if i0 < 0 or j0 < 0 or i1 >= nx or j1 >= ny:
            out[k] = np.inf
            continue
        best = -np.inf
        for i in range(i0, i1 + 1):
            dx = origin[0] + i * cell - x
            for j in range(j0, j1 + 1):
                dy = origin[1] + j * cell - y
                d = math.sqrt(dx * dx + dy * dy)
                if d <= reach:
                    e = max(d - grow, 0.0)
                    h = ground[i, j] + math.sqrt(max(r2 - e * e, 0.0))
                    if h > best:
                        best = h
        out[k] = best
    return out


@numba.njit(cache=True)
def _disc_max(ground: NDArray[np.float64], origin: NDArray[np.float64], cell: float,
              points: NDArray[np.float64], radius: float) -> NDArray[np.float64]:
    """Highest ``ground`` over the nodes within XY distance ``radius`` of each point
    (``-inf`` where no node of the map is that close)."""
    nx, ny = ground.shape
    r2 = radius * radius
    out = np.full(points.shape[0], -np.inf)
    for k in range(points.shape[0]):
        x, y = points[k, 0], points[k, 1]
        i0 = max(0, int(math.ceil((x - radius - origin[0]) / cell)))
        i1 = min(nx - 1, int(math.floor((x + radius - origin[0]) / cell)))
        j0 = max(0, int(math.ceil((y - radius - origin[1]) / cell)))
        j1 = min(ny - 1, int(math.floor((y + radius - origin[1]) / cell)))
        best = -np.inf
        for i in range(i0, i1 + 1):
            dx = origin[0] + i * cell - x
            for j in range(j0, j1 + 1):
                dy = origin[1] + j * cell - y
                if dx * dx + dy * dy <= r2 and ground[i, j] > best:
                    best = ground[i, j]
        out[k] = best
    return out


def _chains(a: NDArray[np.float64], b: NDArray[np.float64]
            ) -> list[NDArray[np.float64]]:
    """Polylines of the segments ``a[k] -> b[k]`` (joined where one ends at the next)."""
    breaks = np.flatnonzero(np.any(b[:-1] != a[1:], axis=1)) + 1
    out = []
    for lo, hi in zip(np.concatenate([[0], breaks]), np.concatenate([breaks, [len(a)]]),
                      strict=True):
        out.append(np.concatenate([a[lo:lo + 1], b[lo:hi]]))
    return out


def sample_moves(centres: NDArray[np.float64], step: float = SWEEP_STEP
                 ) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Points every ``step`` mm along the moves ``centres[i-1] -> centres[i]``.

    Returns the points ``(k, 3)`` (each move's end included, its start excluded) and
    the index of the move (its end pose) each point belongs to ``(k,)``.
    """
    if len(centres) < 2:
        return np.zeros((0, 3)), np.zeros(0, np.int64)
    a, b = centres[:-1], centres[1:]
    n = np.maximum(np.ceil(np.linalg.norm(b - a, axis=1) / step).astype(np.int64), 1)
    owner = np.repeat(np.arange(len(n)), n)
    first = np.repeat(np.cumsum(n) - n, n)
    t = (np.arange(len(owner)) - first + 1) / n[owner]
    return a[owner] + t[:, None] * (b - a)[owner], owner + 1


class ZMap:
    """Air above a height field in a fixed-axis frame (see module docstring).

    Parameters
    ----------
    lo, hi : (2,) float64
        XY corners of the mapped area in the frame, mm.
    blank_triangles : (m, 3, 3) float64
        The blank's boundary in the frame (its top along +Z is ``T``), mm.
    radius : float
        Ball radius R of the tool, mm.
    cell : float
        Node spacing, mm.
    """

    def __init__(self, lo: NDArray[np.float64], hi: NDArray[np.float64],
                 blank_triangles: NDArray[np.float64], radius: float,
                 cell: float = 0.5) -> None:
        self.origin = np.asarray(lo, dtype=np.float64)
        self.cell = float(cell)
        self.radius = float(radius)
        shape = np.maximum(np.ceil((np.asarray(hi) - self.origin) / cell).astype(int) + 1, 2)
        ii, jj = np.meshgrid(np.arange(shape[0]), np.arange(shape[1]), indexing="ij")
        nodes = np.stack([self.origin[0] + ii * cell, self.origin[1] + jj * cell], axis=-1)
        probe = 1e-3  # a tiny ball: the blank's top point under each node
        top = DropCutter(blank_triangles, probe, cell=max(cell, 1.0)).drop(
            nodes.reshape(-1, 2)) - probe
        self.top = np.ascontiguousarray(top.reshape(shape))
        self.floor = np.full(tuple(shape), np.inf)

    def copy(self) -> ZMap:
        """An independent copy (same blank, same cuts so far)."""
        out = object.__new__(ZMap)
        out.origin, out.cell, out.radius = self.origin, self.cell, self.radius
        out.top = self.top
        out.floor = self.floor.copy()
        return out

    def sweep(self, path: NDArray[np.float64]) -> None:
        """Remove what the ball cuts moving along the polyline ``path`` ``(n, 3)``
        (frame; one point: that ball alone)."""
        pts = np.asarray(path, dtype=np.float64).reshape(-1, 3)
        if not len(pts):
            return
        if len(pts) == 1:
            pts = np.concatenate([pts, pts])
        a, b = pts[:-1], pts[1:]
        n = np.maximum(np.ceil(np.abs(b[:, 2] - a[:, 2]) / SWEEP_RISE).astype(np.int64), 1)
        owner = np.repeat(np.arange(len(n)), n)
        first = np.repeat(np.cumsum(n) - n, n)
        step = np.arange(len(owner)) - first
        t0 = (step / n[owner])[:, None]
        t1 = ((step + 1) / n[owner])[:, None]
        d = (b - a)[owner]
        _sweep(self.floor, self.origin, self.cell, np.ascontiguousarray(a[owner] + t0 * d),
               np.ascontiguousarray(a[owner] + t1 * d), self.radius)

    def sweep_moves(self, centres: NDArray[np.float64], kind: NDArray[np.int8]) -> None:
        """Sweep the cutting (non-rapid) moves ``centres[i-1] -> centres[i]``."""
        cut = np.flatnonzero(kind[1:] != MoveKind.RAPID) + 1
        if len(cut):
            a, b = centres[cut - 1], centres[cut]
            for path in _chains(a, b):
                self.sweep(path)

    def ground(self) -> NDArray[np.float64]:
        """``G = min(T, F)`` at the nodes ``(nx, ny)``, mm."""
        return np.minimum(self.top, self.floor)

    def highest(self, points: NDArray[np.float64], radius: float) -> NDArray[np.float64]:
        """Highest stock ``(n,)`` (ground ``G``) within XY distance ``radius`` of
        ``(n, 2|3)`` points, mm: the top of what a cylinder of that radius along the
        axis would meet there (``-inf`` off the map)."""
        return self.highest_within(points, [radius])[:, 0]

    def highest_within(self, points: NDArray[np.float64], radii: list[float]
                       ) -> NDArray[np.float64]:
        """``highest`` for several radii at once ``(n, len(radii))`` (the ground is
        formed once)."""
        pts = np.ascontiguousarray(np.asarray(points, dtype=np.float64)[:, :2])
        ground = np.ascontiguousarray(self.ground())
        out = [_disc_max(ground, self.origin, self.cell, pts, float(r)) for r in radii]
        return np.stack(out, axis=1) if out else np.zeros((len(pts), 0))

    def air_height(self, points: NDArray[np.float64], conservative: bool = True
                   ) -> NDArray[np.float64]:
        """Lowest ball-centre heights ``(n,)`` in air over ``(n, 2|3)`` points, mm.

        ``+inf`` where the ball's footprint leaves the map. ``conservative``: the
        ground of every node is taken as the highest of its 3 x 3 neighbourhood and
        as standing anywhere within ``cell / sqrt(2)`` of it, so stock between nodes
        (the wall at the rim of a cut groove) is not missed: the link planner's
        view. ``False``: the nodes as they are (the check's view: every node it
        finds inside a ball is stock there).
        """
        pts = np.ascontiguousarray(np.asarray(points, dtype=np.float64)[:, :2])
        ground = self.ground()
        grow = 0.0
        if conservative:
            ground = maximum_filter(ground, size=3, mode="nearest")
            grow = self.cell / math.sqrt(2.0)
        return np.asarray(_air(np.ascontiguousarray(ground), self.origin, self.cell, pts,
                               self.radius, grow))


def rapids_in_stock(zmap: ZMap, centres: NDArray[np.float64], kind: NDArray[np.int8],
                    tolerance: float = 0.05) -> tuple[int, int, float]:
    """Replay a fixed-axis program through ``zmap`` (modified: it ends cut).

    Moves are taken in order; cutting moves (every kind but RAPID) are swept into the
    map, every RAPID move is sampled every ``SWEEP_STEP`` mm and its ball must be in
    air (``z >= air_height - tolerance``) given the cuts before it.

    Parameters
    ----------
    zmap : ZMap
    centres : (n, 3) float64
        Ball centres in the map's frame, mm.
    kind : (n,) int8
        ``MoveKind`` of the move ending at each pose.

    Returns
    -------
    bad : int
        Rapid moves with a sample in uncut stock.
    rapids : int
        Rapid moves checked.
    depth : float
        Deepest intrusion into stock of a rapid sample, mm (<= 0: all in air).
    """
    rapid = np.concatenate([[True], kind[1:] == MoveKind.RAPID])
    # chunks of consecutive rapid / cutting moves, in program order
    edges = np.flatnonzero(np.diff(np.concatenate([[-1], rapid.astype(np.int8), [-1]])))
    bad_moves: set[int] = set()
    depth = -np.inf
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        if not rapid[a]:
            zmap.sweep(centres[a - 1:b])  # the chain with its start pose
            continue
        lo = max(a, 1)
        if lo >= b:
            continue
        pts, owner = sample_moves(centres[lo - 1:b])
        dip = zmap.air_height(pts, conservative=False) - pts[:, 2]
        depth = max(depth, float(np.max(dip)))
        bad_moves.update((owner[dip > tolerance] + lo - 1).tolist())
    n_rapid = int(np.sum(kind[1:] == MoveKind.RAPID))
    return len(bad_moves), n_rapid, depth
