"""Exact distance of posed tool meshes to the scene's triangles, for many postures.

A tool part mesh is the union of convex **pieces**, one per segment of its
revolved meridian polygon (``gjk``). The distance from the scene (triangles of
some roles) to a posed part is the smallest triangle-piece distance; it is found
per posture by a nearest-first walk of the scene's triangle BVH
(``exact_phase.SceneArrays.forest``) in which

* a node is skipped when the meridian distance of its box centre to the part's
  profile (radii at the ring circumradius, so the profile's revolve contains the
  mesh), less the box's half diagonal, is at least the best distance so far;
* a triangle likewise with its bounding sphere, piece by piece;
* the remaining triangle-piece pairs get a GJK interval (``gjk``).

The result per posture is a certified interval ``lower <= d <= upper`` of the
distance between the scene triangles and the part mesh *solid* (``upper`` is
``inf`` when nothing is within ``cap``). When ``lower > 0`` the solids are
disjoint and ``d`` is the distance between the mesh surfaces, which is what
``fcl.distance`` computes; ``lower = 0`` (a triangle in or on the part solid) is
left to fcl by the callers (a buried triangle is not a surface contact for fcl).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numba
import numpy as np
from numpy.typing import NDArray

from cam.collision.gjk import section_ring, triangle_piece_distance
from cam.collision.triangle_bvh import STACK

__all__ = ["BodyShape", "body_distances", "tool_pieces"]


def tool_pieces(profiles: Sequence[NDArray[np.float64]], radial_scale: float
                ) -> NDArray[np.float64]:
    """Convex pieces ``(p, 4)`` = ``(r0, z0, r1, z1)`` of revolved meridian profiles.

    A flat segment (``z0 = z1``: a disc or annulus) is left out when a sloped
    piece has a ring at that height at least as large (the flat piece lies in it:
    the union, hence every distance, is unchanged).

    Parameters
    ----------
    profiles : sequence of (k, 2) float64
        Axis-to-axis ``(r, z)`` polylines as ``tool_mesh.revolve`` meshes them
        (z non-decreasing), mm.
    radial_scale : float
        ``sec(pi / sections)``: ring circumradius over profile radius.

    Returns
    -------
    (p, 4) float64
        Ring circumradii and heights of each piece, mm.
    """
    rows = []
    for profile in profiles:
        r = np.asarray(profile[:, 0], dtype=np.float64).copy()
        r[1:-1] *= radial_scale  # the end points lie on the axis
        z = np.asarray(profile[:, 1], dtype=np.float64)
        rows += [(r[k], z[k], r[k + 1], z[k + 1]) for k in range(len(profile) - 1)
                 if r[k] > 0.0 or r[k + 1] > 0.0]
    sloped = [p for p in rows if p[3] > p[1]]
    rings = [(p[0], p[1]) for p in sloped] + [(p[2], p[3]) for p in sloped]
    kept = [p for p in rows if p[3] > p[1]
            or not any(z == p[1] and r >= max(p[0], p[2]) for r, z in rings)]
    return np.asarray(kept, dtype=np.float64).reshape(-1, 4)


@dataclass(frozen=True)
class BodyShape:
    """A posed part's geometry for ``body_distances`` (tool frame, mm).

    Attributes
    ----------
    pieces : (p, 4) float64
        Exact convex pieces (``tool_pieces``).
    coarse : (c, 4) float64
        Few pieces whose revolves contain the part: the pieces themselves when
        there are at most ``_COARSE_LIMIT``, else one cylinder of the largest
        ring radius over the part's height.
    spheres : (s, 2) float64
        Axis spheres ``(height, radius)`` containing the part (used with a
        cylinder: the ball's sphere is tight where the cylinder is not), or none.
    """

    pieces: NDArray[np.float64]
    coarse: NDArray[np.float64]
    spheres: NDArray[np.float64]

    @classmethod
    def build(cls, pieces: NDArray[np.float64], heights: NDArray[np.float64],
              radii: NDArray[np.float64]) -> BodyShape:
        """Coarse bounds of ``pieces`` (with the part's axis spheres ``heights, radii``)."""
        if len(pieces) <= _COARSE_LIMIT:
            return cls(pieces, pieces, np.zeros((0, 2)))
        r = float(pieces[:, [0, 2]].max())
        cylinder = np.array([[r, float(pieces[:, 1].min()), r, float(pieces[:, 3].max())]])
        return cls(pieces, cylinder, np.column_stack([heights, radii]))


#: Parts with more pieces than this get a cylinder and spheres as coarse bounds.
_COARSE_LIMIT = 4


@numba.njit(cache=True, nogil=True, inline="always")
def _segment_nearest(
    rho: float, h: float, ar: float, az: float, br: float, bz: float
) -> tuple[float, float, float]:  # pragma: no cover - compiled
    """Squared distance of ``(rho, h)`` to segment a-b, and the nearest point."""
    er, ez = br - ar, bz - az
    length2 = er * er + ez * ez
    u = 0.0
    if length2 > 0.0:
        u = min(max(((rho - ar) * er + (h - az) * ez) / length2, 0.0), 1.0)
    nr, nz = ar + u * er, az + u * ez
    return (rho - nr) ** 2 + (h - nz) ** 2, nr, nz


@numba.njit(cache=True, nogil=True, inline="always")
def _piece_meridian(
    rho: float, h: float, r0: float, z0: float, r1: float, z1: float
) -> tuple[float, float, float]:  # pragma: no cover - compiled
    """Distance of meridian point ``(rho >= 0, h)`` to the region ``r <= r(z)``,
    ``z0 <= z <= z1`` (the revolve of the piece's rings), mm, and the region's
    nearest point ``(r, z)``."""
    if z1 > z0 and z0 <= h <= z1:
        if rho <= r0 + (h - z0) / (z1 - z0) * (r1 - r0):
            return 0.0, rho, h
    d2, nr, nz = _segment_nearest(rho, h, r0, z0, r1, z1)
    e2, er, ez = _segment_nearest(rho, h, 0.0, z0, r0, z0)
    if e2 < d2:
        d2, nr, nz = e2, er, ez
    e2, er, ez = _segment_nearest(rho, h, 0.0, z1, r1, z1)
    if e2 < d2:
        d2, nr, nz = e2, er, ez
    return math.sqrt(d2), nr, nz


@numba.njit(cache=True, nogil=True, inline="always")
def _meridian(
    x: float, y: float, z: float, tip: NDArray[np.float64], axis: NDArray[np.float64]
) -> tuple[float, float]:  # pragma: no cover - compiled
    wx, wy, wz = x - tip[0], y - tip[1], z - tip[2]
    h = wx * axis[0] + wy * axis[1] + wz * axis[2]
    rho = math.sqrt(max(wx * wx + wy * wy + wz * wz - h * h, 0.0))
    return rho, h


@numba.njit(cache=True, nogil=True, inline="always")
def _outer_bound(
    rho: float, h: float, coarse: NDArray[np.float64], spheres: NDArray[np.float64]
) -> float:  # pragma: no cover - compiled
    """Lower bound of the distance of meridian point ``(rho, h)`` to the part: to the
    coarse pieces (which contain it) and, if any, to its axis spheres (idem)."""
    d = np.inf
    for k in range(coarse.shape[0]):
        d = min(d, _piece_meridian(rho, h, coarse[k, 0], coarse[k, 1], coarse[k, 2],
                                   coarse[k, 3])[0])
    if spheres.shape[0]:
        e = np.inf
        for k in range(spheres.shape[0]):
            e = min(e, math.sqrt(rho * rho + (h - spheres[k, 0]) ** 2) - spheres[k, 1])
        d = max(d, e)
    return d


@numba.njit(cache=True, nogil=True, inline="always")
def _slab_gap(
    slab: NDArray[np.float64], tip: NDArray[np.float64], rot: NDArray[np.float64],
    pieces: NDArray[np.float64],
) -> float:  # pragma: no cover - compiled
    """Lower bound of the distance between a slab ``(nx, ny, nz, lo, hi)`` (all points
    with ``lo <= n . x <= hi``) and the posed part: the gap between the slab and the
    part's extent along n (revolves of the pieces' rings contain the part)."""
    nx, ny, nz = slab[0], slab[1], slab[2]
    dx = rot[0, 0] * nx + rot[1, 0] * ny + rot[2, 0] * nz
    dy = rot[0, 1] * nx + rot[1, 1] * ny + rot[2, 1] * nz
    dz = rot[0, 2] * nx + rot[1, 2] * ny + rot[2, 2] * nz
    across = math.sqrt(dx * dx + dy * dy)
    high = -np.inf  # max over the part of n . x (tool frame), and of -n . x
    low = -np.inf
    for k in range(pieces.shape[0]):
        for e in range(2):
            r, z = pieces[k, 2 * e], pieces[k, 2 * e + 1]
            high = max(high, r * across + dz * z)
            low = max(low, r * across - dz * z)
    base = nx * tip[0] + ny * tip[1] + nz * tip[2]
    return max(slab[3] - (base + high), (base - low) - slab[4], 0.0)


@numba.njit(cache=True, nogil=True)
def _posture_distance(
    tris: NDArray[np.float64],
    tri_centre: NDArray[np.float64],
    tri_radius: NDArray[np.float64],
    tri_slab: NDArray[np.float64],
    node_lo: NDArray[np.float64],
    node_hi: NDArray[np.float64],
    node_slab: NDArray[np.float64],
    left: NDArray[np.int64],
    first: NDArray[np.int64],
    size: NDArray[np.int64],
    roots: NDArray[np.int64],
    tip: NDArray[np.float64],
    rot: NDArray[np.float64],
    pieces: NDArray[np.float64],
    coarse: NDArray[np.float64],
    spheres: NDArray[np.float64],
    ring: NDArray[np.float64],
    cap: float,
    stack: NDArray[np.int64],
    lower: NDArray[np.float64],
    simplex: NDArray[np.float64],
    local: NDArray[np.float64],
) -> tuple[float, float]:  # pragma: no cover - compiled
    axis = rot[:, 2]
    best = cap  # prune threshold: the least upper bound so far, or the cap
    found = False
    low = np.inf  # least lower bound of the pairs examined below the threshold
    npieces = pieces.shape[0]
    for root in roots:
        if root < 0:
            continue
        stack[0] = root
        lower[0] = -np.inf
        depth = 1
        while depth > 0:
            depth -= 1
            node = stack[depth]
            if lower[depth] >= best:
                continue
            child = left[node]
            if child < 0:
                for i in range(first[node], first[node] + size[node]):
                    rho, h = _meridian(tri_centre[i, 0], tri_centre[i, 1], tri_centre[i, 2],
                                       tip, axis)
                    if _outer_bound(rho, h, coarse, spheres) - tri_radius[i] >= best:
                        continue
                    if _slab_gap(tri_slab[i], tip, rot, pieces) >= best:
                        continue
                    placed = False
                    cx = cy = cz = 0.0
                    for k in range(npieces):
                        r0, z0, r1, z1 = pieces[k, 0], pieces[k, 1], pieces[k, 2], pieces[k, 3]
                        gap, nr, nz = _piece_meridian(rho, h, r0, z0, r1, z1)
                        if gap - tri_radius[i] >= best:
                            continue
                        if not placed:  # the triangle in the tool frame: R^T (p - tip)
                            for c in range(3):
                                px = tris[i, c, 0] - tip[0]
                                py = tris[i, c, 1] - tip[1]
                                pz = tris[i, c, 2] - tip[2]
                                for a in range(3):
                                    local[c, a] = rot[0, a] * px + rot[1, a] * py + rot[2, a] * pz
                            cx = (local[0, 0] + local[1, 0] + local[2, 0]) / 3.0
                            cy = (local[0, 1] + local[1, 1] + local[2, 1]) / 3.0
                            cz = (local[0, 2] + local[1, 2] + local[2, 2]) / 3.0
                            placed = True
                        # guess: from the piece's nearest meridian point to the centroid
                        radial = math.sqrt(cx * cx + cy * cy)
                        ux, uy = (cx / radial, cy / radial) if radial > 0.0 else (1.0, 0.0)
                        lo, hi = triangle_piece_distance(local, r0, z0, r1, z1, ring, best,
                                                         simplex, cx - nr * ux, cy - nr * uy,
                                                         cz - nz)
                        if lo < best:
                            low = min(low, lo)
                            if hi < best:
                                best = hi
                                found = True
                continue
            bounds = np.empty(2)
            for side in range(2):
                c = child + side
                cx = 0.5 * (node_lo[c, 0] + node_hi[c, 0])
                cy = 0.5 * (node_lo[c, 1] + node_hi[c, 1])
                cz = 0.5 * (node_lo[c, 2] + node_hi[c, 2])
                half = 0.5 * math.sqrt((node_hi[c, 0] - node_lo[c, 0]) ** 2
                                       + (node_hi[c, 1] - node_lo[c, 1]) ** 2
                                       + (node_hi[c, 2] - node_lo[c, 2]) ** 2)
                rho, h = _meridian(cx, cy, cz, tip, axis)
                bounds[side] = max(_outer_bound(rho, h, coarse, spheres) - half,
                                   _slab_gap(node_slab[c], tip, rot, coarse))
            a, b = child, child + 1
            da, db = bounds[0], bounds[1]
            if da > db:
                a, b, da, db = b, a, db, da
            if db < best:
                stack[depth], lower[depth] = b, db
                depth += 1
            if da < best:
                stack[depth], lower[depth] = a, da
                depth += 1
    if found:
        return min(low, best), best
    return min(low, cap), np.inf


@numba.njit(cache=True, nogil=True)
def _body_distances(
    tris: NDArray[np.float64],
    tri_centre: NDArray[np.float64],
    tri_radius: NDArray[np.float64],
    tri_slab: NDArray[np.float64],
    node_lo: NDArray[np.float64],
    node_hi: NDArray[np.float64],
    node_slab: NDArray[np.float64],
    left: NDArray[np.int64],
    first: NDArray[np.int64],
    size: NDArray[np.int64],
    roots: NDArray[np.int64],
    tip: NDArray[np.float64],
    rot: NDArray[np.float64],
    pieces: NDArray[np.float64],
    coarse: NDArray[np.float64],
    spheres: NDArray[np.float64],
    ring: NDArray[np.float64],
    cap: float,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:  # pragma: no cover - compiled
    n = tip.shape[0]
    out_lo = np.empty(n)
    out_hi = np.empty(n)
    stack = np.empty(STACK, dtype=np.int64)
    lower = np.empty(STACK)
    simplex = np.empty((4, 3))
    local = np.empty((3, 3))
    for q in range(n):
        out_lo[q], out_hi[q] = _posture_distance(
            tris, tri_centre, tri_radius, tri_slab, node_lo, node_hi, node_slab, left, first,
            size, roots[q],
            tip[q], rot[q], pieces, coarse, spheres, ring, cap, stack, lower, simplex,
            local)
    return out_lo, out_hi


def body_distances(
    forest: tuple[Any, ...],
    roots: NDArray[np.int64],
    tip: NDArray[np.float64],
    rot: NDArray[np.float64],
    shape: BodyShape,
    sections: int,
    cap: float,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Certified intervals of the distance from scene triangles to a posed tool mesh.

    Parameters
    ----------
    forest : tuple
        ``SceneArrays.forest`` (triangles and BVH nodes of every role).
    roots : (n, k) int64
        Per posture, the BVH roots (roles) to search; -1 entries are skipped.
    tip : (n, 3) float64
        Tool tips, mm.
    rot : (n, 3, 3) float64
        Tool-frame rotations (``postures.rotations_to``; the mesh is posed as fcl
        poses it).
    shape : BodyShape
        The part meshes' pieces and coarse bounds.
    sections : int
        Sections of the part meshes.
    cap : float
        Triangles farther than this are not measured, mm.

    Returns
    -------
    lower, upper : (n,) float64
        ``lower <= d <= upper`` with d the distance of the roles' triangles to the
        part mesh solid; ``upper = inf`` (and ``lower`` up to ``cap``) when nothing
        is nearer than ``cap``. Converged intervals are ``GJK_TOLERANCE`` wide.
    """
    tris, tri_centre, tri_radius, tri_slab, node_lo, node_hi, node_slab, left, first, size \
        = forest
    if not len(tip):
        return np.zeros(0), np.zeros(0)
    lo, hi = _body_distances(
        tris, tri_centre, tri_radius, tri_slab, node_lo, node_hi, node_slab, left, first, size,
        # writable too: a read-only ``roots`` (a broadcast view) is another signature,
        # compiled a second time on a cold cache
        np.require(roots, np.int64, ("C", "W")),
        np.ascontiguousarray(tip, dtype=np.float64),
        np.ascontiguousarray(rot, dtype=np.float64),
        np.ascontiguousarray(shape.pieces, dtype=np.float64),
        np.ascontiguousarray(shape.coarse, dtype=np.float64),
        np.ascontiguousarray(shape.spheres, dtype=np.float64), section_ring(int(sections)),
        float(cap))
    return np.asarray(lo), np.asarray(hi)
