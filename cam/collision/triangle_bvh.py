"""A bounding-volume hierarchy of triangles for exact point distances, in numba.

Axis-aligned boxes, median split on the longest axis of the triangle centroids,
at most ``LEAF`` triangles per leaf. A query (distance from a point to the nearest
triangle, if closer than ``reach``) walks the tree nearest box first and prunes
boxes farther than the best distance so far; the point-triangle distance is
Ericson's closest point on a triangle (*Real-Time Collision Detection*, 5.1.5).
It may stop at the first triangle closer than ``stop``.

The cost grows with the logarithm of the triangle count and with the number of
triangles near the query sphere's boundary, not with the mesh density around it
as a uniform grid of buckets would.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

#: Largest number of triangles in a leaf.
LEAF = 8
#: Traversal stack size (depth of a median-split tree of 2**60 triangles).
_STACK = 128


@numba.njit(cache=True, nogil=True)
def _closest_distance2(
    px: float, py: float, pz: float, t: NDArray[np.float64]
) -> float:  # pragma: no cover - compiled
    ax, ay, az = t[0, 0], t[0, 1], t[0, 2]
    abx, aby, abz = t[1, 0] - ax, t[1, 1] - ay, t[1, 2] - az
    acx, acy, acz = t[2, 0] - ax, t[2, 1] - ay, t[2, 2] - az
    apx, apy, apz = px - ax, py - ay, pz - az
    d1 = abx * apx + aby * apy + abz * apz
    d2 = acx * apx + acy * apy + acz * apz
    if d1 <= 0.0 and d2 <= 0.0:
        qx, qy, qz = ax, ay, az
    else:
        bpx, bpy, bpz = px - t[1, 0], py - t[1, 1], pz - t[1, 2]
        d3 = abx * bpx + aby * bpy + abz * bpz
        d4 = acx * bpx + acy * bpy + acz * bpz
        cpx, cpy, cpz = px - t[2, 0], py - t[2, 1], pz - t[2, 2]
        d5 = abx * cpx + aby * cpy + abz * cpz
        d6 = acx * cpx + acy * cpy + acz * cpz
        vc = d1 * d4 - d3 * d2
        vb = d5 * d2 - d1 * d6
        va = d3 * d6 - d5 * d4
        if d3 >= 0.0 and d4 <= d3:
            qx, qy, qz = t[1, 0], t[1, 1], t[1, 2]
        elif d6 >= 0.0 and d5 <= d6:
            qx, qy, qz = t[2, 0], t[2, 1], t[2, 2]
        elif vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
            v = d1 / (d1 - d3)
            qx, qy, qz = ax + v * abx, ay + v * aby, az + v * abz
        elif vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
            w = d2 / (d2 - d6)
            qx, qy, qz = ax + w * acx, ay + w * acy, az + w * acz
        elif va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
            w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
            bx, by, bz = t[1, 0], t[1, 1], t[1, 2]
            qx = bx + w * (t[2, 0] - bx)
            qy = by + w * (t[2, 1] - by)
            qz = bz + w * (t[2, 2] - bz)
        else:
            denom = 1.0 / (va + vb + vc)
            v = vb * denom
            w = vc * denom
            qx = ax + abx * v + acx * w
            qy = ay + aby * v + acy * w
            qz = az + abz * v + acz * w
    return (px - qx) ** 2 + (py - qy) ** 2 + (pz - qz) ** 2


@numba.njit(cache=True, nogil=True)
def _build(
    centroids: NDArray[np.float64], tri_lo: NDArray[np.float64], tri_hi: NDArray[np.float64]
) -> tuple[
    NDArray[np.int64], NDArray[np.float64], NDArray[np.float64], NDArray[np.int64],
    NDArray[np.int64], NDArray[np.int64],
]:  # pragma: no cover - compiled
    count = centroids.shape[0]
    capacity = max(1, 2 * count)
    order = np.arange(count)
    node_lo = np.empty((capacity, 3))
    node_hi = np.empty((capacity, 3))
    left = np.full(capacity, -1, dtype=np.int64)
    first = np.zeros(capacity, dtype=np.int64)
    size = np.zeros(capacity, dtype=np.int64)
    stack = np.empty((_STACK, 3), dtype=np.int64)
    stack[0, 0], stack[0, 1], stack[0, 2] = 0, 0, count
    depth = 1
    nodes = 1
    while depth > 0:
        depth -= 1
        node, s, e = stack[depth, 0], stack[depth, 1], stack[depth, 2]
        first[node], size[node] = s, e - s
        c_lo = np.full(3, np.inf)
        c_hi = np.full(3, -np.inf)
        for a in range(3):
            node_lo[node, a] = np.inf
            node_hi[node, a] = -np.inf
        for i in range(s, e):
            t = order[i]
            for a in range(3):
                node_lo[node, a] = min(node_lo[node, a], tri_lo[t, a])
                node_hi[node, a] = max(node_hi[node, a], tri_hi[t, a])
                c_lo[a] = min(c_lo[a], centroids[t, a])
                c_hi[a] = max(c_hi[a], centroids[t, a])
        if e - s <= LEAF:
            continue
        axis = int(np.argmax(c_hi - c_lo))
        part = order[s:e].copy()
        order[s:e] = part[np.argsort(centroids[part, axis], kind="mergesort")]
        mid = (s + e) // 2
        left[node] = nodes
        stack[depth, 0], stack[depth, 1], stack[depth, 2] = nodes, s, mid
        stack[depth + 1, 0], stack[depth + 1, 1], stack[depth + 1, 2] = nodes + 1, mid, e
        depth += 2
        nodes += 2
    return order, node_lo[:nodes].copy(), node_hi[:nodes].copy(), left[:nodes].copy(), \
        first[:nodes].copy(), size[:nodes].copy()


@numba.njit(cache=True, nogil=True, inline="always")
def _box_distance2(
    x: float, y: float, z: float, lo: NDArray[np.float64], hi: NDArray[np.float64]
) -> float:  # pragma: no cover - compiled
    dx = max(lo[0] - x, 0.0, x - hi[0])
    dy = max(lo[1] - y, 0.0, y - hi[1])
    dz = max(lo[2] - z, 0.0, z - hi[2])
    return dx * dx + dy * dy + dz * dz


@numba.njit(cache=True, nogil=True)
def nearest_within(
    x: float,
    y: float,
    z: float,
    reach: float,
    stop: float,
    tris: NDArray[np.float64],
    tri_centre: NDArray[np.float64],
    tri_radius: NDArray[np.float64],
    node_lo: NDArray[np.float64],
    node_hi: NDArray[np.float64],
    left: NDArray[np.int64],
    first: NDArray[np.int64],
    size: NDArray[np.int64],
) -> tuple[float, int]:  # pragma: no cover - compiled
    """Distance to, and leaf-order index of, the nearest triangle within ``reach``.

    ``(inf, -1)`` when none is. Returns early at the first triangle closer than
    ``stop``.
    """
    if reach <= 0.0:
        return np.inf, -1
    best = reach
    best2 = reach * reach
    found = -1
    stack = np.empty(_STACK, dtype=np.int64)
    stack[0] = 0
    depth = 1
    while depth > 0:
        depth -= 1
        node = stack[depth]
        if _box_distance2(x, y, z, node_lo[node], node_hi[node]) > best2:
            continue
        child = left[node]
        if child < 0:
            for i in range(first[node], first[node] + size[node]):
                dx = x - tri_centre[i, 0]
                dy = y - tri_centre[i, 1]
                dz = z - tri_centre[i, 2]
                lim = best + tri_radius[i]
                if dx * dx + dy * dy + dz * dz > lim * lim:
                    continue  # the triangle's bounding sphere is beyond the best so far
                d2 = _closest_distance2(x, y, z, tris[i])
                if d2 < best2:
                    best2 = d2
                    best = math.sqrt(d2)
                    found = i
                    if best < stop:
                        return best, found
            continue
        near = _box_distance2(x, y, z, node_lo[child], node_hi[child])
        far = _box_distance2(x, y, z, node_lo[child + 1], node_hi[child + 1])
        if near <= far:
            stack[depth], stack[depth + 1] = child + 1, child
        else:
            stack[depth], stack[depth + 1] = child, child + 1
        depth += 2
    return (best, found) if found >= 0 else (np.inf, -1)


@numba.njit(cache=True, nogil=True)
def _distances_within(
    points: NDArray[np.float64],
    reach: float,
    tris: NDArray[np.float64],
    tri_centre: NDArray[np.float64],
    tri_radius: NDArray[np.float64],
    node_lo: NDArray[np.float64],
    node_hi: NDArray[np.float64],
    left: NDArray[np.int64],
    first: NDArray[np.int64],
    size: NDArray[np.int64],
) -> NDArray[np.float64]:  # pragma: no cover - compiled
    out = np.empty(points.shape[0])
    for q in range(points.shape[0]):
        out[q] = nearest_within(
            points[q, 0], points[q, 1], points[q, 2], reach, -1.0, tris, tri_centre,
            tri_radius, node_lo, node_hi, left, first, size,
        )[0]
    return out


class TriangleBVH:
    """Triangles of one mesh in a bounding-volume hierarchy.

    Parameters
    ----------
    tris : (t, 3, 3) float64
        Triangle corners, mm.

    Attributes
    ----------
    tris : (t, 3, 3) float64
        The triangles in leaf order.
    order : (t,) int64
        Index in the given triangles of each leaf-order triangle.
    arrays : tuple
        ``(tris, tri_centre, tri_radius, node_lo, node_hi, left, first, size)``
        for the kernels (bounding sphere of each triangle; the right child of
        node ``k`` is ``left[k] + 1``; leaf ``k`` holds triangles
        ``first[k] .. first[k] + size[k] - 1``).
    """

    def __init__(self, tris: NDArray[np.float64]) -> None:
        given = np.ascontiguousarray(tris, dtype=np.float64)
        order, lo, hi, left, first, size = _build(
            given.mean(axis=1), given.min(axis=1), given.max(axis=1)
        )
        self.order = order
        self.tris = np.ascontiguousarray(given[order])
        centre = self.tris.mean(axis=1)
        radius = np.linalg.norm(self.tris - centre[:, None, :], axis=2).max(axis=1)
        self.arrays = (self.tris, centre, radius, lo, hi, left, first, size)

    def distances(self, points: NDArray[np.float64], reach: float) -> NDArray[np.float64]:
        """Exact ``(k,)`` distances of points ``(k, 3)`` to the triangles (inf beyond reach)."""
        return np.asarray(
            _distances_within(np.ascontiguousarray(points, dtype=np.float64), float(reach),
                              *self.arrays)
        )
