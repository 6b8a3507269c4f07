"""Drop-cutter of a ball along +Z against a triangle mesh (numba, many CL points at once).

For each cutter-location (CL) point ``(x, y)`` the ball of radius ``rho`` comes down
from ``z = +inf`` along -Z and stops at its first contact with any triangle; the
answer is the height of the ball centre there, i.e. the largest of the contact
heights of the three classical cases (Chuang et al.; OpenCAMLib's ``BallCutter``):

* **vertex** ``v`` within ``rho`` in XY: ``z_c = v_z + sqrt(rho^2 - d_xy^2)``;
* **facet** with upward unit normal ``n`` (``n_z > 0``): the contact point is
  ``(x, y) - rho (n_x, n_y)``; if it lies inside the triangle's XY projection,
  ``z_c = z_plane(contact) + rho n_z``;
* **edge** with horizontal direction ``e`` and slope ``s``: at horizontal distance
  ``h < rho`` from the edge's XY line the ball section is a circle of radius
  ``r' = sqrt(rho^2 - h^2)``; ``z_c = z_line(t) + r' sqrt(1 + s^2)`` when the foot
  point ``t + r' s / sqrt(1 + s^2)`` lies on the edge.

Triangles are bucketed in a uniform XY grid (each triangle in every cell its XY box
grown by ``rho`` touches), so a CL point only tests the triangles of its own cell;
each cell lists its triangles highest first, and the search stops at the first
triangle whose top plus ``rho`` is not above the best contact found so far.
Points that no triangle can reach get ``-inf``. A roughing axis other than +Z is
handled by rotating the mesh (``frame_to_z``) into a frame where that axis is +Z.
"""

from __future__ import annotations

import math
from typing import Protocol

import numba
import numpy as np
from numpy.typing import NDArray

__all__ = ["DropCutter", "DropSurface", "drop_ball", "frame_to_z"]

#: Default edge of the XY bucket cells as a multiple of the ball radius.
CELL_FACTOR = 0.5
_EPS = 1e-12


class DropSurface(Protocol):
    """Anything that answers drop-cutter heights: ``drop(points (n, 3)) -> (n,)``."""

    def drop(self, points: NDArray[np.float64]) -> NDArray[np.float64]: ...


def frame_to_z(axis: NDArray[np.float64]) -> tuple[NDArray[np.float64], float, float]:
    """Rotation ``M = Ry(beta) Rx(alpha)`` taking the unit ``axis`` onto +Z (M4, Fig. 2).

    alpha turns the axis about X into the x-z plane, beta about Y onto Z, as in the
    paper's construction of the UMR frame.

    Parameters
    ----------
    axis : (3,) float64
        Unit tool axis in W.

    Returns
    -------
    matrix : (3, 3) float64
        ``M @ axis = (0, 0, 1)``; points map as ``p' = M p``.
    alpha, beta : float
        Rotation angles about X and Y, rad.
    """
    t = np.asarray(axis, dtype=np.float64)
    t = t / np.linalg.norm(t)
    alpha = math.atan2(t[1], t[2])
    zp = math.hypot(t[1], t[2])
    beta = math.atan2(-t[0], zp)
    ca, sa, cb, sb = math.cos(alpha), math.sin(alpha), math.cos(beta), math.sin(beta)
    rx = np.array([[1.0, 0.0, 0.0], [0.0, ca, -sa], [0.0, sa, ca]])
    ry = np.array([[cb, 0.0, sb], [0.0, 1.0, 0.0], [-sb, 0.0, cb]])
    return ry @ rx, alpha, beta


@numba.njit(cache=True)
def _triangle_height(tri: NDArray[np.float64], x: float, y: float, rho: float) -> float:
    """Ball-centre contact height over one triangle ``(3, 3)``; -inf if no contact."""
    best = -np.inf
    r2 = rho * rho
    # vertices
    for i in range(3):
        dx = x - tri[i, 0]
        dy = y - tri[i, 1]
        d2 = dx * dx + dy * dy
        if d2 <= r2:
            z = tri[i, 2] + math.sqrt(r2 - d2)
            if z > best:
                best = z
    # facet
    ax, ay, az = tri[1, 0] - tri[0, 0], tri[1, 1] - tri[0, 1], tri[1, 2] - tri[0, 2]
    bx, by, bz = tri[2, 0] - tri[0, 0], tri[2, 1] - tri[0, 1], tri[2, 2] - tri[0, 2]
    nx, ny, nz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
    nn = math.sqrt(nx * nx + ny * ny + nz * nz)
    if nn > _EPS:
        nx, ny, nz = nx / nn, ny / nn, nz / nn
        if nz < 0.0:
            nx, ny, nz = -nx, -ny, -nz
        if nz > 1e-9:
            px = x - rho * nx
            py = y - rho * ny
            # barycentric test in XY
            det = ax * by - ay * bx
            if abs(det) > _EPS:
                qx, qy = px - tri[0, 0], py - tri[0, 1]
                s = (qx * by - qy * bx) / det
                t = (ax * qy - ay * qx) / det
                if s >= 0.0 and t >= 0.0 and s + t <= 1.0:
                    zp = tri[0, 2] - (nx * qx + ny * qy) / nz
                    z = zp + rho * nz
                    if z > best:
                        best = z
    # edges
    for i in range(3):
        j = (i + 1) % 3
        ex, ey, ez = tri[j, 0] - tri[i, 0], tri[j, 1] - tri[i, 1], tri[j, 2] - tri[i, 2]
        lxy = math.sqrt(ex * ex + ey * ey)
        if lxy < _EPS:
            continue
        ux, uy = ex / lxy, ey / lxy
        qx, qy = x - tri[i, 0], y - tri[i, 1]
        t = qx * ux + qy * uy
        h = qx * uy - qy * ux
        if h * h >= r2:
            continue
        rp = math.sqrt(r2 - h * h)
        s = ez / lxy
        root = math.sqrt(1.0 + s * s)
        tf = t + rp * s / root
        if tf < 0.0 or tf > lxy:
            continue
        z = tri[i, 2] + s * t + rp * root
        if z > best:
            best = z
    return best


@numba.njit(cache=True, parallel=True)
def _drop_kernel(
    triangles: NDArray[np.float64],
    top: NDArray[np.float64],
    cell_start: NDArray[np.int64],
    cell_items: NDArray[np.int64],
    origin: NDArray[np.float64],
    cell: float,
    shape: NDArray[np.int64],
    points: NDArray[np.float64],
    rho: float,
) -> NDArray[np.float64]:
    n = points.shape[0]
    out = np.full(n, -np.inf)
    for k in numba.prange(n):
        x, y = points[k, 0], points[k, 1]
        i = int(math.floor((x - origin[0]) / cell))
        j = int(math.floor((y - origin[1]) / cell))
        if i < 0 or j < 0 or i >= shape[0] or j >= shape[1]:
            continue
        c = i * shape[1] + j
        best = -np.inf
        for m in range(cell_start[c], cell_start[c + 1]):
            t = cell_items[m]
            if top[t] + rho <= best:
                break
            z = _triangle_height(triangles[t], x, y, rho)
            if z > best:
                best = z
        out[k] = best
    return out


@numba.njit(cache=True)
def _bucket(
    lo: NDArray[np.int64], hi: NDArray[np.int64], shape: NDArray[np.int64],
    order: NDArray[np.int64],
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Triangles per XY cell (CSR ``start``, ``items``), each cell's highest first.

    ``order``: the triangles by descending top; filling the cells in that order
    leaves every cell sorted (one global sort instead of one per cell).
    """
    ncell = shape[0] * shape[1]
    counts = np.zeros(ncell + 1, dtype=np.int64)
    for t in range(lo.shape[0]):
        for i in range(lo[t, 0], hi[t, 0] + 1):
            for j in range(lo[t, 1], hi[t, 1] + 1):
                counts[i * shape[1] + j + 1] += 1
    start = np.cumsum(counts)
    fill = start[:-1].copy()
    items = np.empty(start[-1], dtype=np.int64)
    # highest triangles first: a drop can stop once no remaining triangle is higher
    for t in order:
        for i in range(lo[t, 0], hi[t, 0] + 1):
            for j in range(lo[t, 1], hi[t, 1] + 1):
                c = i * shape[1] + j
                items[fill[c]] = t
                fill[c] += 1
    return start, items


class DropCutter:
    """A ball of radius ``rho`` dropped along +Z onto fixed triangles.

    Parameters
    ----------
    triangles : (m, 3, 3) float64
        Triangles in the drop frame (the drop axis is +Z), mm.
    rho : float
        Ball radius, mm (tool radius plus allowance for roughing).
    cell : float, optional
        XY bucket cell edge, mm (default ``CELL_FACTOR * rho``).
    """

    def __init__(self, triangles: NDArray[np.float64], rho: float,
                 cell: float | None = None) -> None:
        tri = np.ascontiguousarray(triangles, dtype=np.float64).reshape(-1, 3, 3)
        if not rho > 0:
            raise ValueError(f"ball radius must be positive, not {rho!r}")
        self.triangles = tri
        self.rho = float(rho)
        self.cell = float(cell) if cell is not None else CELL_FACTOR * self.rho
        lo_xy = tri[:, :, :2].min(axis=1) - self.rho
        hi_xy = tri[:, :, :2].max(axis=1) + self.rho
        self.origin = lo_xy.min(axis=0) if len(tri) else np.zeros(2)
        top = hi_xy.max(axis=0) if len(tri) else np.ones(2)
        self.shape = np.maximum(np.ceil((top - self.origin) / self.cell).astype(np.int64), 1)
        lo = np.floor((lo_xy - self.origin) / self.cell).astype(np.int64)
        hi = np.minimum(np.floor((hi_xy - self.origin) / self.cell).astype(np.int64),
                        self.shape - 1)
        self.top = np.ascontiguousarray(tri[:, :, 2].max(axis=1))
        order = np.argsort(-self.top, kind="stable").astype(np.int64)
        self.cell_start, self.cell_items = _bucket(lo, hi, self.shape, order)

    def drop(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        """Ball-centre heights ``(n,)`` over ``(n, 2)`` (or ``(n, 3)``) XY points, mm.

        ``-inf`` where no triangle is within ``rho`` in XY.
        """
        pts = np.ascontiguousarray(np.asarray(points, dtype=np.float64)[:, :2])
        return np.asarray(_drop_kernel(self.triangles, self.top, self.cell_start, self.cell_items,
                                       self.origin, self.cell, self.shape, pts, self.rho))


def drop_ball(triangles: NDArray[np.float64], points: NDArray[np.float64],
              rho: float) -> NDArray[np.float64]:
    """One-shot ``DropCutter(triangles, rho).drop(points)``: ball-centre heights, mm."""
    return DropCutter(triangles, rho).drop(points)
