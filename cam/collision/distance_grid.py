"""A grid of lower bounds of the unsigned distance to a sampled surface.

Built once per scene. Every surface sample marks its nearest grid node and
the exact Euclidean distance transform (``edt.distance_transform``, numba; the
values of ``scipy.ndimage.distance_transform_edt``) gives each node the distance
``D`` to the nearest marked node. A sample lies within ``g sqrt(3) / 2`` of the node it
marked and every surface point within the covering radius ``h`` of a sample, so
the distance from a node to the surface is at least ``D - g sqrt(3)/2 - h``.
Nodes in a narrow band (``D <= band``) get the exact distance to the triangles
(``triangle_bvh.TriangleBVH.distances``). All grids of a scene share one
frame, so the grid of the whole scene is the node-wise minimum of the roles'.

The distance to a surface is 1-Lipschitz, so at a point ``p`` inside a cell
``d(p) >= max over the 8 corners c (L_c - |p - c|)``; outside the grid, and
everywhere as a second bound, ``d(p) >= distance(p, bounding box of the
surface)``. Every grid also keeps a *coarse* copy (every ``COARSE_STEP``-th
node per axis, small enough to stay in the processor cache) for a first,
cheaper bound ``L_c - |p - c|`` at the nearest coarse node. The lookups are
compiled with numba.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numba
import numpy as np
from numpy.typing import NDArray

from cam.collision.edt import distance_transform

#: Rounding allowance for storing bounds in float32, mm.
_F32_ALLOWANCE = 1e-4
#: Every this many nodes (per axis) a node of the coarse copy of a grid.
COARSE_STEP = 4


@numba.njit(cache=True, nogil=True)
def point_lower_bound(
    bounds: NDArray[np.float32],
    origin: NDArray[np.float64],
    spacing: float,
    box_lo: NDArray[np.float64],
    box_hi: NDArray[np.float64],
    x: float,
    y: float,
    z: float,
) -> float:  # pragma: no cover - compiled
    p = (x, y, z)
    out2 = 0.0
    for a in range(3):
        if p[a] < box_lo[a]:
            out2 += (box_lo[a] - p[a]) ** 2
        elif p[a] > box_hi[a]:
            out2 += (p[a] - box_hi[a]) ** 2
    best = math.sqrt(out2)
    fx = (x - origin[0]) / spacing
    fy = (y - origin[1]) / spacing
    fz = (z - origin[2]) / spacing
    i, j, k = math.floor(fx), math.floor(fy), math.floor(fz)
    nx, ny, nz = bounds.shape
    if i < 0 or j < 0 or k < 0 or i >= nx - 1 or j >= ny - 1 or k >= nz - 1:
        return best
    for di in range(2):
        for dj in range(2):
            for dk in range(2):
                ex = (fx - i - di) * spacing
                ey = (fy - j - dj) * spacing
                ez = (fz - k - dk) * spacing
                v = bounds[i + di, j + dj, k + dk] - math.sqrt(ex * ex + ey * ey + ez * ez)
                if v > best:
                    best = v
    return best


@numba.njit(cache=True, nogil=True)
def coarse_lower_bound(
    coarse: NDArray[np.float32],
    origin: NDArray[np.float64],
    spacing: float,
    box_lo: NDArray[np.float64],
    box_hi: NDArray[np.float64],
    x: float,
    y: float,
    z: float,
) -> float:  # pragma: no cover - compiled
    """Lower bound of the distance at ``(x, y, z)`` from the coarse grid (one node).

    ``coarse`` holds every ``COARSE_STEP``-th node (spacing ``spacing``) of a grid;
    ``d(p) >= L_c - |p - c|`` at its node ``c`` nearest to ``p``, and
    ``d(p) >= distance(p, box)``. Small enough to stay in cache: a cheap first test.
    """
    p = (x, y, z)
    out2 = 0.0
    for a in range(3):
        if p[a] < box_lo[a]:
            out2 += (box_lo[a] - p[a]) ** 2
        elif p[a] > box_hi[a]:
            out2 += (p[a] - box_hi[a]) ** 2
    best = math.sqrt(out2)
    i = round((x - origin[0]) / spacing)
    j = round((y - origin[1]) / spacing)
    k = round((z - origin[2]) / spacing)
    nx, ny, nz = coarse.shape
    if 0 <= i < nx and 0 <= j < ny and 0 <= k < nz:
        ex = x - origin[0] - i * spacing
        ey = y - origin[1] - j * spacing
        ez = z - origin[2] - k * spacing
        v = coarse[i, j, k] - math.sqrt(ex * ex + ey * ey + ez * ez)
        if v > best:
            best = v
    return best


@numba.njit(cache=True, nogil=True)
def _part_bounds(
    bounds: NDArray[np.float32],
    origin: NDArray[np.float64],
    spacing: float,
    box_lo: NDArray[np.float64],
    box_hi: NDArray[np.float64],
    tip: NDArray[np.float64],
    axis: NDArray[np.float64],
    heights: NDArray[np.float64],
    radii: NDArray[np.float64],
    stop_below: float,
) -> NDArray[np.float64]:  # pragma: no cover - compiled
    n = tip.shape[0]
    out = np.empty(n)
    for q in range(n):
        lowest = np.inf
        for s in range(heights.shape[0]):
            h = heights[s]
            b = point_lower_bound(
                bounds,
                origin,
                spacing,
                box_lo,
                box_hi,
                tip[q, 0] + h * axis[q, 0],
                tip[q, 1] + h * axis[q, 1],
                tip[q, 2] + h * axis[q, 2],
            ) - radii[s]
            if b < lowest:
                lowest = b
                if lowest <= stop_below:
                    break
        out[q] = lowest
    return out


@numba.njit(cache=True, nogil=True)
def _part_bounds_outer(
    bounds: NDArray[np.float32],
    origin: NDArray[np.float64],
    spacing: float,
    box_lo: NDArray[np.float64],
    box_hi: NDArray[np.float64],
    outer: NDArray[np.float32],
    outer_origin: NDArray[np.float64],
    outer_spacing: float,
    outer_lo: NDArray[np.float64],
    outer_hi: NDArray[np.float64],
    tip: NDArray[np.float64],
    axis: NDArray[np.float64],
    heights: NDArray[np.float64],
    radii: NDArray[np.float64],
    stop_below: float,
) -> NDArray[np.float64]:  # pragma: no cover - compiled
    """``_part_bounds`` with each centre's bound the larger of two grids' bounds."""
    n = tip.shape[0]
    out = np.empty(n)
    for q in range(n):
        lowest = np.inf
        for s in range(heights.shape[0]):
            h = heights[s]
            x = tip[q, 0] + h * axis[q, 0]
            y = tip[q, 1] + h * axis[q, 1]
            z = tip[q, 2] + h * axis[q, 2]
            b = max(point_lower_bound(bounds, origin, spacing, box_lo, box_hi, x, y, z),
                    point_lower_bound(outer, outer_origin, outer_spacing, outer_lo,
                                      outer_hi, x, y, z)) - radii[s]
            if b < lowest:
                lowest = b
                if lowest <= stop_below:
                    break
        out[q] = lowest
    return out


class DistanceGrid:
    """Node lower bounds of the distance to a surface, on a fixed grid frame.

    Parameters
    ----------
    bounds : (nx, ny, nz) float32
        Node lower bounds, mm.
    origin : (3,) float64
        Position of node (0, 0, 0), mm.
    spacing : float
        Grid spacing g, mm.
    box_lo, box_hi : (3,) float64
        Bounding box of the surface, mm.

    Attributes
    ----------
    coarse : (ceil(nx/k), ceil(ny/k), ceil(nz/k)) float32
        Every ``k = COARSE_STEP``-th node of ``bounds`` (same values), spacing
        ``coarse_spacing = k * spacing``.
    """

    def __init__(
        self,
        bounds: NDArray[np.float32],
        origin: NDArray[np.float64],
        spacing: float,
        box_lo: NDArray[np.float64],
        box_hi: NDArray[np.float64],
    ) -> None:
        self.bounds = bounds
        self.origin = np.asarray(origin, dtype=np.float64)
        self.spacing = float(spacing)
        self.box_lo = np.asarray(box_lo, dtype=np.float64)
        self.box_hi = np.asarray(box_hi, dtype=np.float64)
        step = COARSE_STEP
        #: every ``COARSE_STEP``-th node (a valid bound there), spacing ``coarse_spacing``
        self.coarse = np.ascontiguousarray(bounds[::step, ::step, ::step])
        self.coarse_spacing = self.spacing * step

    @classmethod
    def from_samples(
        cls,
        points: NDArray[np.float64],
        covering_radius: float,
        origin: NDArray[np.float64],
        shape: tuple[int, int, int],
        spacing: float,
        band: float,
        exact: Callable[[NDArray[np.float64], float], NDArray[np.float64]] | None = None,
    ) -> DistanceGrid:
        """Build from surface samples (EDT), tightened in a band by exact distances.

        Parameters
        ----------
        points : (m, 3) float64
            Surface samples, all inside the grid, mm.
        covering_radius : float
            Every surface point is within this distance of a sample, mm.
        origin, shape, spacing
            The grid frame (node ``(i, j, k)`` at ``origin + spacing * (i, j, k)``).
        band : float
            Nodes with ``D <= band`` get exact distances when ``exact`` is given, mm.
        exact : callable, optional
            ``exact(points (k, 3), reach) -> (k,)`` exact distances to the
            surface (``inf`` beyond ``reach``).
        """
        marked = np.ones(shape, dtype=bool)  # EDT measures the distance to False cells
        node = np.rint((points - origin) / spacing).astype(np.int64)
        marked[node[:, 0], node[:, 1], node[:, 2]] = False
        return cls.from_marked(marked, covering_radius, origin, spacing, points.min(axis=0),
                               points.max(axis=0), band, exact)

    @classmethod
    def from_marked(
        cls,
        marked: NDArray[np.bool_],
        covering_radius: float,
        origin: NDArray[np.float64],
        spacing: float,
        box_lo: NDArray[np.float64],
        box_hi: NDArray[np.float64],
        band: float,
        exact: Callable[[NDArray[np.float64], float], NDArray[np.float64]] | None = None,
    ) -> DistanceGrid:
        """``from_samples`` with the samples' nodes already marked.

        Parameters
        ----------
        marked : (nx, ny, nz) bool
            False at the node nearest to each surface sample, True elsewhere.
        covering_radius, origin, spacing, band, exact
            As ``from_samples``.
        box_lo, box_hi : (3,) float64
            Bounding box of the samples, mm.
        """
        distance = distance_transform(marked, spacing)
        loss = 0.5 * math.sqrt(3.0) * spacing + covering_radius
        bounds = distance - loss
        if exact is not None:
            near = np.flatnonzero(distance.ravel() <= band)
            ijk = np.column_stack(np.unravel_index(near, distance.shape))
            # a band node is within D + g sqrt(3)/2 of a sample on the surface: this
            # reach gives every band node its exact distance
            reach = band + 0.5 * math.sqrt(3.0) * spacing + 1e-6
            tight = exact(origin + spacing * ijk, reach)
            tight = np.where(np.isfinite(tight), tight, reach)
            bounds.ravel()[near] = np.maximum(bounds.ravel()[near], tight)
        bounds -= _F32_ALLOWANCE
        return cls(bounds.astype(np.float32), origin, spacing, box_lo, box_hi)

    @classmethod
    def minimum(cls, grids: list[DistanceGrid]) -> DistanceGrid:
        """Grid of the union of the surfaces of grids sharing one frame."""
        bounds = grids[0].bounds.copy()
        for grid in grids[1:]:
            np.minimum(bounds, grid.bounds, out=bounds)
        return cls(
            bounds,
            grids[0].origin,
            grids[0].spacing,
            np.min([g.box_lo for g in grids], axis=0),
            np.max([g.box_hi for g in grids], axis=0),
        )

    def part_bounds(
        self,
        tip: NDArray[np.float64],
        axis: NDArray[np.float64],
        heights: NDArray[np.float64],
        radii: NDArray[np.float64],
        stop_below: float = -math.inf,
        outer: DistanceGrid | None = None,
    ) -> NDArray[np.float64]:
        """Lower bound of the distance from sphere-covered parts to the surface.

        Parameters
        ----------
        tip, axis : (n, 3) float64
            Postures (axis unit).
        heights, radii : (m,) float64
            Axis spheres of the part (see ``broad_phase.axis_spheres``).
        stop_below : float
            A posture's scan stops at the first sphere whose bound is at most
            this (its result is then that bound, not the minimum), mm.
        outer : DistanceGrid, optional
            A grid of the same surface on a larger (coarser) frame: each centre's
            bound is the larger of the two (beyond this grid's frame, where its
            bound is only the distance to the surface's bounding box).

        Returns
        -------
        (n,) float64
            ``min over spheres (d_lower(centre) - rho)``, mm.
        """
        if outer is not None:
            return np.asarray(_part_bounds_outer(
                self.bounds, self.origin, self.spacing, self.box_lo, self.box_hi,
                outer.bounds, outer.origin, outer.spacing, outer.box_lo, outer.box_hi,
                np.ascontiguousarray(tip, dtype=np.float64),
                np.ascontiguousarray(axis, dtype=np.float64),
                np.ascontiguousarray(heights, dtype=np.float64),
                np.ascontiguousarray(radii, dtype=np.float64), float(stop_below)))
        return np.asarray(
            _part_bounds(
                self.bounds,
                self.origin,
                self.spacing,
                self.box_lo,
                self.box_hi,
                np.ascontiguousarray(tip, dtype=np.float64),
                np.ascontiguousarray(axis, dtype=np.float64),
                np.ascontiguousarray(heights, dtype=np.float64),
                np.ascontiguousarray(radii, dtype=np.float64),
                float(stop_below),
            )
        )


@numba.njit(cache=True, nogil=True)
def _role_masks(
    masks: NDArray[np.int64],
    origin: NDArray[np.float64],
    spacing: float,
    tip: NDArray[np.float64],
    axis: NDArray[np.float64],
    heights: NDArray[np.float64],
    radii: NDArray[np.float64],
    limit: float,
) -> NDArray[np.int64]:  # pragma: no cover - compiled
    n = tip.shape[0]
    out = np.zeros(n, dtype=np.int64)
    nx, ny, nz = masks.shape
    half_diagonal = 0.5 * math.sqrt(3.0) * spacing
    for q in range(n):
        acc = 0
        for s in range(heights.shape[0]):
            if radii[s] + half_diagonal > limit:
                acc = -1  # a sphere too large for the mask: every role
                break
            i = int(round((tip[q, 0] + heights[s] * axis[q, 0] - origin[0]) / spacing))
            j = int(round((tip[q, 1] + heights[s] * axis[q, 1] - origin[1]) / spacing))
            k = int(round((tip[q, 2] + heights[s] * axis[q, 2] - origin[2]) / spacing))
            if 0 <= i < nx and 0 <= j < ny and 0 <= k < nz:
                acc |= masks[i, j, k]
        out[q] = acc
    return out


class RoleMask:
    """Per grid node, the bit set of roles whose distance bound is at most ``limit``.

    A role can come within ``rho`` of a point only if its bound at the nearest
    node is at most ``rho + g sqrt(3)/2`` (1-Lipschitz), so spheres with
    ``rho + g sqrt(3)/2 <= limit`` need only the roles in the masks of their
    nearest nodes. The grids' margin must exceed ``limit`` (points off the grid
    are then farther than ``limit`` from every role).

    Parameters
    ----------
    grids : list of DistanceGrid
        One per role (at most 62), all on one frame.
    limit : float
        Distance threshold of the masks, mm.
    """

    def __init__(self, grids: list[DistanceGrid], limit: float) -> None:
        self.limit = float(limit)
        self.origin = grids[0].origin
        self.spacing = grids[0].spacing
        self.masks = np.zeros(grids[0].bounds.shape, dtype=np.int64)
        for r, grid in enumerate(grids):
            self.masks |= (grid.bounds <= limit).astype(np.int64) << r

    def roles_near(
        self,
        tip: NDArray[np.float64],
        axis: NDArray[np.float64],
        heights: NDArray[np.float64],
        radii: NDArray[np.float64],
        margin: float,
    ) -> NDArray[np.int64]:
        """``(n,)`` bit sets of the roles a part's spheres (grown by ``margin``) may reach.

        ``-1`` (all bits) when a sphere is too large for the masks.
        """
        return np.asarray(
            _role_masks(
                self.masks,
                self.origin,
                self.spacing,
                np.ascontiguousarray(tip, dtype=np.float64),
                np.ascontiguousarray(axis, dtype=np.float64),
                np.ascontiguousarray(heights, dtype=np.float64),
                np.ascontiguousarray(radii + margin, dtype=np.float64),
                self.limit,
            )
        )
