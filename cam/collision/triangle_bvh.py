"""A bounding-volume hierarchy of triangles for exact point distances, in numba.

Axis-aligned boxes, median split on the longest axis of the triangle centroids,
at most ``LEAF`` triangles per leaf. Every node also has a *slab*: two parallel
planes, normal to the direction of least spread of its vertices (smallest
principal axis), that enclose its triangles; every triangle has one along its
normal. The distance from a point to a node's triangles is at least the larger of
its distances to the node's box and slab (both contain the triangles, which are
the convex hulls of their vertices); on the smooth, finely tessellated impeller
surfaces the slab is nearly as tight as the surface itself, where a box around
a slanted patch is not. A query (distance from a point to the nearest triangle,
if closer than ``reach``) walks the tree nearest node first and prunes nodes
and triangles (bounding sphere, slab) farther than the best distance so far;
the point-triangle distance is Ericson's closest point on a triangle
(*Real-Time Collision Detection*, 5.1.5). It may stop at the first triangle
closer than ``stop``.

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
STACK = 128
#: Widening of the triangle and node slabs, mm: far above the rounding error of
#: ``n . p`` for coordinates below 1e4 mm, far below any contact tolerance.
SLAB_PAD = 1e-9


@numba.njit(cache=True, nogil=True, inline="always")
def closest_point(
    px: float, py: float, pz: float, t: NDArray[np.float64]
) -> tuple[float, float, float]:  # pragma: no cover - compiled
    """Closest point to ``(px, py, pz)`` on the triangle ``t`` (3, 3) (Ericson 5.1.5)."""
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
    return qx, qy, qz


@numba.njit(cache=True, nogil=True, inline="always")
def _closest_distance2(
    px: float, py: float, pz: float, t: NDArray[np.float64]
) -> float:  # pragma: no cover - compiled
    qx, qy, qz = closest_point(px, py, pz, t)
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
    stack = np.empty((STACK, 3), dtype=np.int64)
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


@numba.njit(cache=True, nogil=True, inline="always")
def _slab_distance(
    x: float, y: float, z: float, slab: NDArray[np.float64]
) -> float:  # pragma: no cover - compiled
    s = slab[0] * x + slab[1] * y + slab[2] * z
    return max(slab[3] - s, 0.0, s - slab[4])


@numba.njit(cache=True, nogil=True)
def profile_depth(
    profile: NDArray[np.float64],
    tip: NDArray[np.float64],
    axis: NDArray[np.float64],
    x: float,
    y: float,
    z: float,
) -> float:  # pragma: no cover - compiled
    """Signed distance of a point inside the revolved profile polygon (< 0 outside), mm.

    Meridian coordinates of the point: height ``h`` along the axis above the tip,
    radius ``rho`` from the axis. Inside: a ray from ``(rho, h)`` towards
    ``+r`` crosses the profile (axis to axis; the closing axis segment lies at
    ``r = 0 <= rho`` and is never crossed) an odd number of times. The depth is
    the distance to the profile's segments (the axis segment is not a surface).
    """
    wx, wy, wz = x - tip[0], y - tip[1], z - tip[2]
    h = wx * axis[0] + wy * axis[1] + wz * axis[2]
    rho = math.sqrt(max(wx * wx + wy * wy + wz * wz - h * h, 0.0))
    crossings = 0
    best2 = np.inf
    for k in range(profile.shape[0] - 1):
        ar, az = profile[k, 0], profile[k, 1]
        br, bz = profile[k + 1, 0], profile[k + 1, 1]
        if (az <= h) != (bz <= h):
            if ar + (h - az) / (bz - az) * (br - ar) > rho:
                crossings += 1
        er, ez = br - ar, bz - az
        length2 = er * er + ez * ez
        u = 0.0
        if length2 > 0.0:
            u = min(max(((rho - ar) * er + (h - az) * ez) / length2, 0.0), 1.0)
        dr, dz = rho - ar - u * er, h - az - u * ez
        best2 = min(best2, dr * dr + dz * dz)
    distance = math.sqrt(best2)
    return distance if crossings % 2 == 1 else -distance


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
    tri_slab: NDArray[np.float64],
    node_lo: NDArray[np.float64],
    node_hi: NDArray[np.float64],
    node_slab: NDArray[np.float64],
    left: NDArray[np.int64],
    first: NDArray[np.int64],
    size: NDArray[np.int64],
    root: int,
    stack: NDArray[np.int64],
    lower: NDArray[np.float64],
    profile: NDArray[np.float64],
    tip: NDArray[np.float64],
    axis: NDArray[np.float64],
    deep: float,
) -> tuple[float, int, bool]:  # pragma: no cover - compiled
    """Distance to, and leaf-order index of, the nearest triangle within ``reach``.

    ``(inf, -1, False)`` when none is. A node is pruned when its box or its slab
    is farther than the best distance so far; a triangle when its bounding
    sphere or its slab is. The tree starts at node ``root`` (several trees can
    share the arrays). ``stack`` (int64) and ``lower`` (float64), both of length
    ``STACK``, are work space.

    Returns early, with the third value True, at the first triangle closer than
    ``stop`` or (when ``profile`` has rows) whose point closest to ``(x, y, z)``
    lies deeper than ``deep`` inside the part ``profile`` revolved about the
    axis through ``tip`` (``profile_depth``); the distance is then that
    triangle's, not necessarily the nearest.
    """
    if reach <= 0.0:
        return np.inf, -1, False
    test_inside = profile.shape[0] > 1
    best = reach
    best2 = reach * reach
    found = -1
    stack[0] = root
    lower[0] = 0.0
    depth = 1
    while depth > 0:
        depth -= 1
        node = stack[depth]
        if lower[depth] > best2:
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
                if _slab_distance(x, y, z, tri_slab[i]) > best:
                    continue  # so is the thin slab around its plane
                qx, qy, qz = closest_point(x, y, z, tris[i])
                d2 = (x - qx) ** 2 + (y - qy) ** 2 + (z - qz) ** 2
                if d2 < best2:
                    best2 = d2
                    best = math.sqrt(d2)
                    found = i
                    if best < stop:
                        return best, found, True
                    if test_inside and profile_depth(profile, tip, axis, qx, qy, qz) > deep:
                        return best, found, True
            continue
        a, b = child, child + 1
        da = max(
            _box_distance2(x, y, z, node_lo[a], node_hi[a]),
            _slab_distance(x, y, z, node_slab[a]) ** 2,
        )
        db = max(
            _box_distance2(x, y, z, node_lo[b], node_hi[b]),
            _slab_distance(x, y, z, node_slab[b]) ** 2,
        )
        if da > db:
            a, b, da, db = b, a, db, da
        # nearer child on top of the stack; children beyond the best are not stacked
        if db <= best2:
            stack[depth], lower[depth] = b, db
            depth += 1
        if da <= best2:
            stack[depth], lower[depth] = a, da
            depth += 1
    return (best, found, False) if found >= 0 else (np.inf, -1, False)


@numba.njit(cache=True, nogil=True)
def _slabs(
    tris: NDArray[np.float64], first: NDArray[np.int64], size: NDArray[np.int64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:  # pragma: no cover - compiled
    """Slabs ``(nx, ny, nz, lo, hi)`` holding each triangle and each node's triangles.

    A triangle's slab is normal to the triangle; a node's is normal to the
    direction of least spread of its vertices (smallest principal axis). Both
    are widened by ``SLAB_PAD`` so rounding cannot make them exclude a point.
    """
    count = tris.shape[0]
    tri_slab = np.empty((count, 5))
    for i in range(count):
        ux, uy, uz = tris[i, 1, 0] - tris[i, 0, 0], tris[i, 1, 1] - tris[i, 0, 1], \
            tris[i, 1, 2] - tris[i, 0, 2]
        vx, vy, vz = tris[i, 2, 0] - tris[i, 0, 0], tris[i, 2, 1] - tris[i, 0, 1], \
            tris[i, 2, 2] - tris[i, 0, 2]
        nx, ny, nz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
        length = math.sqrt(nx * nx + ny * ny + nz * nz)
        if length > 0.0:
            nx, ny, nz = nx / length, ny / length, nz / length
        else:
            nx, ny, nz = 0.0, 0.0, 0.0  # degenerate: the slab test never prunes
        lo, hi = np.inf, -np.inf
        for k in range(3):
            s = nx * tris[i, k, 0] + ny * tris[i, k, 1] + nz * tris[i, k, 2]
            lo, hi = min(lo, s), max(hi, s)
        tri_slab[i, 0], tri_slab[i, 1], tri_slab[i, 2] = nx, ny, nz
        tri_slab[i, 3], tri_slab[i, 4] = lo - SLAB_PAD, hi + SLAB_PAD
    nodes = first.shape[0]
    node_slab = np.empty((nodes, 5))
    cov = np.empty((3, 3))
    mean = np.empty(3)
    for node in range(nodes):
        s0, s1 = first[node], first[node] + size[node]
        mean[:] = 0.0
        cov[:, :] = 0.0
        for i in range(s0, s1):
            for k in range(3):
                for a in range(3):
                    mean[a] += tris[i, k, a]
        mean /= 3.0 * (s1 - s0)
        for i in range(s0, s1):
            for k in range(3):
                for a in range(3):
                    for b in range(3):
                        cov[a, b] += (tris[i, k, a] - mean[a]) * (tris[i, k, b] - mean[b])
        _, vectors = np.linalg.eigh(cov)
        nx, ny, nz = vectors[0, 0], vectors[1, 0], vectors[2, 0]
        length = math.sqrt(nx * nx + ny * ny + nz * nz)
        nx, ny, nz = nx / length, ny / length, nz / length
        lo, hi = np.inf, -np.inf
        for i in range(s0, s1):
            for k in range(3):
                s = nx * tris[i, k, 0] + ny * tris[i, k, 1] + nz * tris[i, k, 2]
                lo, hi = min(lo, s), max(hi, s)
        node_slab[node, 0], node_slab[node, 1], node_slab[node, 2] = nx, ny, nz
        node_slab[node, 3], node_slab[node, 4] = lo - SLAB_PAD, hi + SLAB_PAD
    return tri_slab, node_slab


#: Relative and absolute slack (mm) of the reach ``_distances_within`` carries from
#: one point to the next, over the rounding of the distances.
_REACH_SLACK = 1e-9


@numba.njit(cache=True, nogil=True)
def _distances_within(
    points: NDArray[np.float64],
    reach: float,
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
) -> NDArray[np.float64]:  # pragma: no cover - compiled
    out = np.empty(points.shape[0])
    stack = np.empty(STACK, dtype=np.int64)
    lower = np.empty(STACK)
    none = np.zeros((0, 2))
    zero = np.zeros(3)
    root = int(np.int64(0))  # typed int64, not Literal[int](0): no second signature
    for q in range(points.shape[0]):
        limit = reach
        if q > 0 and out[q - 1] < reach:
            # 1-Lipschitz: d(q) <= d(q-1) + |q - (q-1)|; a search within a reach just
            # above that finds the same nearest triangle (the same value), sooner
            # (consecutive points, e.g. grid nodes, are close)
            step = math.sqrt((points[q, 0] - points[q - 1, 0]) ** 2
                             + (points[q, 1] - points[q - 1, 1]) ** 2
                             + (points[q, 2] - points[q - 1, 2]) ** 2)
            limit = min(reach, (out[q - 1] + step) * (1.0 + _REACH_SLACK) + _REACH_SLACK)
        out[q] = nearest_within(
            points[q, 0], points[q, 1], points[q, 2], limit, -1.0, tris, tri_centre,
            tri_radius, tri_slab, node_lo, node_hi, node_slab, left, first, size, root, stack,
            lower, none, zero, zero, 0.0,
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
        ``(tris, tri_centre, tri_radius, tri_slab, node_lo, node_hi, node_slab,
        left, first, size)`` for the kernels (bounding sphere and slab of each
        triangle; box and slab of each node; the right child of node ``k`` is
        ``left[k] + 1``; node ``k`` holds triangles ``first[k] .. first[k] +
        size[k] - 1``, a leaf when ``left[k] < 0``).
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
        tri_slab, node_slab = _slabs(self.tris, first, size)
        self.arrays = (
            self.tris, centre, radius, tri_slab, lo, hi, node_slab, left, first, size
        )

    def distances(self, points: NDArray[np.float64], reach: float) -> NDArray[np.float64]:
        """Exact ``(k,)`` distances of points ``(k, 3)`` to the triangles (inf beyond reach)."""
        return np.asarray(
            _distances_within(np.ascontiguousarray(points, dtype=np.float64), float(reach),
                              *self.arrays)
        )
