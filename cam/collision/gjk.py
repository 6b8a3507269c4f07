"""Gilbert-Johnson-Keerthi distance between two convex shapes, and the tool pieces.

A tool part mesh (``tool_mesh.revolve``) is the revolved meridian polygon with ``N``
sections: ring vertices ``(R cos phi_j, R sin phi_j, z)``, ``phi_j = 2 pi j / N``,
``R = r sec(pi / N)``. The quads between two consecutive rings are planar (their
edges on the rings are parallel), so the solid between two consecutive profile
points is exactly the convex hull of the two rings (a ring of radius 0 is a point)
and the mesh solid is the union of these **pieces**. The distance from a scene
triangle to the mesh solid is the smallest distance to a piece; for a triangle
outside the solid it is the distance to the mesh surface, which is what fcl
computes between the meshes.

``gjk_interval`` is the one GJK of the project (the tool's pieces against scene
triangles here, the machine's convex pieces in ``cam.verify.machine_bounds``). It
runs on the Minkowski difference ``A - B`` of two **shapes**, each a tuple ``(kind,
points, lo, hi, params, rot, trans)`` placed by ``rot, trans`` whose support
``shape_support`` gives: a point set (``POINTS``, the furthest of ``points[lo:hi]``),
an exact cylinder (``CYLINDER``) or a revolved piece (``REVOLVED``: the ring vertex
nearest the direction's azimuth on the better of its two rings, O(1)). The nearest
point of a simplex to the origin is Ericson's (*Real-Time Collision Detection*
5.1.5-5.1.6). Every iteration gives a **certified interval**: ``|v|`` (a point of
the difference) is an upper bound, ``v . w / |v|`` (``w`` the support in ``-v``: a
separating plane) a lower bound. The iteration stops when they agree to the
caller's tolerance (``GJK_TOLERANCE`` for the tool), when the lower bound reaches
``prune`` (the caller has a nearer piece already, or a bound that certifies its
query), when the upper bound falls to ``stop_below``, when it stalls, or after the
caller's number of iterations; callers only rely on the interval.
"""

from __future__ import annotations

import math
from typing import Any

import numba
import numpy as np
from numpy.typing import NDArray

__all__ = ["CYLINDER", "GJK_ITERATIONS", "GJK_TOLERANCE", "POINTS", "REVOLVED", "gjk_interval",
           "section_ring", "shape_support", "triangle_piece_distance"]

#: Width at which the GJK interval counts as converged, mm.
GJK_TOLERANCE = 1e-9
#: Largest number of GJK iterations (the interval is certified whatever the count).
GJK_ITERATIONS = 64

#: Shape kinds of ``shape_support``: the hull of ``points[lo:hi]`` (3 columns).
POINTS = 0
#: An exact cylinder: ``params`` centre (3), unit axis (3), radius, half-length, mm.
CYLINDER = 1
#: A revolved piece (hull of two N-gon rings about +Z, a vertex at angle 0):
#: ``params[:4]`` ``r0, z0, r1, z1`` (circumradii and heights, mm), ``points[lo:hi]``
#: the ``(N, 2)`` cos and sin of the section angles (``section_ring``).
REVOLVED = 2

#: ``rot``, ``trans`` of a shape given in the outer frame (no transform).
_UNPLACED = np.zeros((0, 3))
_NO_SHIFT = np.zeros(3)


def section_ring(sections: int) -> NDArray[np.float64]:
    """``(N, 2)`` cos and sin of the section angles ``2 pi j / N`` of a revolved mesh."""
    phi = 2.0 * math.pi * np.arange(sections) / sections
    return np.column_stack([np.cos(phi), np.sin(phi)])


@numba.njit(cache=True, nogil=True, inline="always")
def shape_support(shape: Any, dx: float, dy: float, dz: float
                  ) -> tuple[float, float, float]:  # pragma: no cover - compiled
    """Point of a placed shape furthest along ``d`` (both in the outer frame), mm.

    ``shape``: ``(kind, points, lo, hi, params, rot, trans)`` (module docstring):
    ``points`` (m, 3) or the ring (N, 2) float64, ``lo, hi`` int, ``params`` 8
    floats, ``rot`` (3, 3) and ``trans`` (3,) float64 placing the shape's frame (or
    ``rot`` (0, 3): the shape is given in the outer frame, ``trans`` unused).
    """
    kind, points, lo, hi, c, rot, trans = shape
    placed = rot.shape[0] == 3
    lx, ly, lz = dx, dy, dz
    if placed:
        lx = rot[0, 0] * dx + rot[1, 0] * dy + rot[2, 0] * dz
        ly = rot[0, 1] * dx + rot[1, 1] * dy + rot[2, 1] * dz
        lz = rot[0, 2] * dx + rot[1, 2] * dy + rot[2, 2] * dz
    if kind == REVOLVED:
        sections = hi - lo
        if lx == 0.0 and ly == 0.0:
            j = lo
        else:
            j = lo + int(round(math.atan2(ly, lx) * (sections / (2.0 * math.pi)))) % sections
        cs, sn = points[j, 0], points[j, 1]
        along = lx * cs + ly * sn
        if c[0] * along + lz * c[1] >= c[2] * along + lz * c[3]:
            px, py, pz = c[0] * cs, c[0] * sn, c[1]
        else:
            px, py, pz = c[2] * cs, c[2] * sn, c[3]
    elif kind == CYLINDER:
        along = lx * c[3] + ly * c[4] + lz * c[5]
        rx, ry, rz = lx - along * c[3], ly - along * c[4], lz - along * c[5]
        norm = math.sqrt(rx * rx + ry * ry + rz * rz)
        scale = c[6] / norm if norm > 0.0 else 0.0
        h = c[7] if along >= 0.0 else -c[7]
        px = c[0] + h * c[3] + scale * rx
        py = c[1] + h * c[4] + scale * ry
        pz = c[2] + h * c[5] + scale * rz
    else:
        best = lo
        value = lx * points[lo, 0] + ly * points[lo, 1] + lz * points[lo, 2]
        for m in range(lo + 1, hi):
            v = lx * points[m, 0] + ly * points[m, 1] + lz * points[m, 2]
            if v > value:
                best, value = m, v
        px, py, pz = points[best, 0], points[best, 1], points[best, 2]
    if not placed:
        return px, py, pz
    return (rot[0, 0] * px + rot[0, 1] * py + rot[0, 2] * pz + trans[0],
            rot[1, 0] * px + rot[1, 1] * py + rot[1, 2] * pz + trans[1],
            rot[2, 0] * px + rot[2, 1] * py + rot[2, 2] * pz + trans[2])


@numba.njit(cache=True, nogil=True)
def _closest_segment(s: NDArray[np.float64], keep: NDArray[np.bool_]) -> NDArray[np.float64]:
    """Point of segment s[0] s[1] nearest the origin; ``keep`` marks its support."""
    ax, ay, az = s[0, 0], s[0, 1], s[0, 2]
    ex, ey, ez = s[1, 0] - ax, s[1, 1] - ay, s[1, 2] - az
    length2 = ex * ex + ey * ey + ez * ez
    t = 0.0 if length2 <= 0.0 else -(ax * ex + ay * ey + az * ez) / length2
    out = np.empty(3)
    if t <= 0.0:
        keep[0], keep[1] = True, False
        t = 0.0
    elif t >= 1.0:
        keep[0], keep[1] = False, True
        t = 1.0
    else:
        keep[0], keep[1] = True, True
    out[0], out[1], out[2] = ax + t * ex, ay + t * ey, az + t * ez
    return out


@numba.njit(cache=True, nogil=True)
def _closest_triangle(
    a: NDArray[np.float64], b: NDArray[np.float64], c: NDArray[np.float64],
    keep: NDArray[np.bool_],
) -> NDArray[np.float64]:  # pragma: no cover - compiled
    """Point of triangle abc nearest the origin (Ericson 5.1.5); ``keep`` its support."""
    out = np.empty(3)
    ab = b - a
    ac = c - a
    ap = -a
    d1 = ab[0] * ap[0] + ab[1] * ap[1] + ab[2] * ap[2]
    d2 = ac[0] * ap[0] + ac[1] * ap[1] + ac[2] * ap[2]
    keep[0], keep[1], keep[2] = False, False, False
    if d1 <= 0.0 and d2 <= 0.0:
        keep[0] = True
        out[:] = a
        return out
    bp = -b
    d3 = ab[0] * bp[0] + ab[1] * bp[1] + ab[2] * bp[2]
    d4 = ac[0] * bp[0] + ac[1] * bp[1] + ac[2] * bp[2]
    if d3 >= 0.0 and d4 <= d3:
        keep[1] = True
        out[:] = b
        return out
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        v = d1 / (d1 - d3)
        keep[0], keep[1] = True, True
        out[:] = a + v * ab
        return out
    cp = -c
    d5 = ab[0] * cp[0] + ab[1] * cp[1] + ab[2] * cp[2]
    d6 = ac[0] * cp[0] + ac[1] * cp[1] + ac[2] * cp[2]
    if d6 >= 0.0 and d5 <= d6:
        keep[2] = True
        out[:] = c
        return out
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        w = d2 / (d2 - d6)
        keep[0], keep[2] = True, True
        out[:] = a + w * ac
        return out
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        keep[1], keep[2] = True, True
        out[:] = b + w * (c - b)
        return out
    denom = 1.0 / (va + vb + vc)
    v = vb * denom
    w = vc * denom
    keep[0], keep[1], keep[2] = True, True, True
    out[:] = a + ab * v + ac * w
    return out


@numba.njit(cache=True, nogil=True, inline="always")
def _outside_plane(
    a: NDArray[np.float64], b: NDArray[np.float64], c: NDArray[np.float64],
    d: NDArray[np.float64],
) -> bool:  # pragma: no cover - compiled
    """The origin and d lie on opposite sides of plane abc (Ericson 5.1.6)."""
    ab = b - a
    ac = c - a
    nx = ab[1] * ac[2] - ab[2] * ac[1]
    ny = ab[2] * ac[0] - ab[0] * ac[2]
    nz = ab[0] * ac[1] - ab[1] * ac[0]
    sign_p = -(a[0] * nx + a[1] * ny + a[2] * nz)
    sign_d = (d[0] - a[0]) * nx + (d[1] - a[1]) * ny + (d[2] - a[2]) * nz
    return sign_p * sign_d < 0.0


@numba.njit(cache=True, nogil=True)
def _reduce(simplex: NDArray[np.float64], count: int) -> tuple[NDArray[np.float64], int]:
    """Nearest point of the simplex's hull to the origin; simplex reduced to its support.

    Returns the point and the new vertex count (0 when the origin is inside a
    tetrahedron: the sets overlap).
    """  # pragma: no cover - compiled
    keep = np.zeros(4, dtype=np.bool_)
    if count == 1:
        return simplex[0].copy(), 1
    if count == 2:
        point = _closest_segment(simplex, keep)
    elif count == 3:
        point = _closest_triangle(simplex[0], simplex[1], simplex[2], keep)
    else:
        # tetrahedron: the nearest of the faces the origin is outside of
        faces = ((0, 1, 2, 3), (0, 2, 3, 1), (0, 3, 1, 2), (1, 3, 2, 0))
        best2 = np.inf
        point = np.zeros(3)
        sub = np.zeros(3, dtype=np.bool_)
        for fa, fb, fc, fd in faces:
            if _outside_plane(simplex[fa], simplex[fb], simplex[fc], simplex[fd]):
                q = _closest_triangle(simplex[fa], simplex[fb], simplex[fc], sub)
                d2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2]
                if d2 < best2:
                    best2 = d2
                    point = q
                    keep[:] = False
                    keep[fa], keep[fb], keep[fc] = sub[0], sub[1], sub[2]
        if best2 == np.inf:
            return np.zeros(3), 0  # origin inside
    kept = 0
    for k in range(count):
        if keep[k]:
            simplex[kept] = simplex[k]
            kept += 1
    return point, kept


@numba.njit(cache=True, nogil=True, inline="always")
def gjk_interval(a: Any, b: Any, direction: NDArray[np.float64], prune: float,
                 stop_below: float, tolerance: float, iterations: int,
                 simplex: NDArray[np.float64]) -> tuple[float, float]:  # pragma: no cover
    """Certified interval ``(lower, upper)`` of the distance of two convex shapes, mm.

    Parameters
    ----------
    a, b : tuple
        The shapes (``shape_support``); GJK runs on ``A - B``.
    direction : (3,) float64
        A guess of the direction from B to A (any; zero: +x); a good one ends most
        calls after one support. The last direction searched is written back.
    prune : float
        Stop as soon as the lower bound reaches this, mm (``upper`` may then be far
        above ``lower``).
    stop_below : float
        Stop as soon as the upper bound is at or below this, mm (``-inf``: never).
    tolerance : float
        Stop when ``upper - lower`` is at most this, mm.
    iterations : int
        Largest number of iterations (the interval is certified whatever the count).
    simplex : (4, 3) float64
        Work space.

    Returns
    -------
    lower, upper : float
        ``0 <= lower <= distance <= upper`` (``0, 0``: the sets overlap).
    """
    dx, dy, dz = direction[0], direction[1], direction[2]
    if dx == 0.0 and dy == 0.0 and dz == 0.0:
        dx = 1.0
    ax, ay, az = shape_support(a, -dx, -dy, -dz)
    bx, by, bz = shape_support(b, dx, dy, dz)
    # the guessed direction: one separating-plane bound, and the first simplex point
    simplex[0, 0], simplex[0, 1], simplex[0, 2] = ax - bx, ay - by, az - bz
    v = simplex[0]  # read before the simplex changes, then _reduce's point
    lower = max((dx * v[0] + dy * v[1] + dz * v[2]) / math.sqrt(dx * dx + dy * dy + dz * dz),
                0.0)
    upper = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    if lower >= prune or upper <= stop_below:
        if upper > 0.0:
            direction[0], direction[1], direction[2] = v[0], v[1], v[2]
        return lower, upper
    count = 1
    for _ in range(iterations):
        vv = v[0] * v[0] + v[1] * v[1] + v[2] * v[2]
        if vv <= 0.0:
            return 0.0, 0.0
        norm = math.sqrt(vv)  # |v| only decreases: the upper bound
        direction[0], direction[1], direction[2] = v[0], v[1], v[2]
        ax, ay, az = shape_support(a, -v[0], -v[1], -v[2])
        bx, by, bz = shape_support(b, v[0], v[1], v[2])
        wx, wy, wz = ax - bx, ay - by, az - bz
        vw = v[0] * wx + v[1] * wy + v[2] * wz
        if vw > 0.0:
            lower = max(lower, vw / norm)
        if lower >= prune or norm <= stop_below or norm - lower <= tolerance:
            return lower, norm
        # w already in the simplex: no progress possible
        for k in range(count):
            if simplex[k, 0] == wx and simplex[k, 1] == wy and simplex[k, 2] == wz:
                return lower, norm
        simplex[count, 0], simplex[count, 1], simplex[count, 2] = wx, wy, wz
        count += 1
        v, count = _reduce(simplex, count)
        if count == 0:
            return 0.0, 0.0
        if v[0] * v[0] + v[1] * v[1] + v[2] * v[2] >= vv:
            return lower, norm  # no decrease (rounding): stop with the interval
    return lower, math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])


@numba.njit(cache=True, nogil=True)
def triangle_piece_distance(
    t: NDArray[np.float64],
    r0: float,
    z0: float,
    r1: float,
    z1: float,
    ring: NDArray[np.float64],
    prune: float,
    simplex: NDArray[np.float64],
    dx: float,
    dy: float,
    dz: float,
) -> tuple[float, float]:  # pragma: no cover - compiled
    """Certified interval ``(lower, upper)`` of the distance triangle - piece, mm.

    Parameters
    ----------
    t : (3, 3) float64
        Triangle corners in the tool frame (tip at the origin, axis +Z), mm.
    r0, z0, r1, z1 : float
        The piece: convex hull of the N-gon rings of circumradius ``r0`` at
        height ``z0`` and ``r1`` at ``z1`` (a vertex at angle 0), mm.
    ring : (N, 2) float64
        ``cos, sin`` of the section angles ``2 pi j / N`` (``section_ring``).
    prune : float
        Stop as soon as the lower bound reaches this (mm); ``upper`` may then be
        far above ``lower``.
    simplex : (4, 3) float64
        Work space.
    dx, dy, dz : float
        A guess of the direction from the piece to the triangle (e.g. from the
        piece's nearest meridian point to the triangle's centroid); any
        direction is valid, a good one ends most calls after one support.

    Returns
    -------
    lower, upper : float
        ``0 <= lower <= distance <= upper`` (``0, 0``: the sets overlap).
    """
    direction = np.empty(3)
    direction[0], direction[1], direction[2] = dx, dy, dz
    unused = 0.0
    return gjk_interval(
        (POINTS, t, 0, 3, (unused, unused, unused, unused, unused, unused, unused, unused),
         _UNPLACED, _NO_SHIFT),
        (REVOLVED, ring, 0, ring.shape[0], (r0, z0, r1, z1, unused, unused, unused, unused),
         _UNPLACED, _NO_SHIFT),
        direction, prune, -math.inf, GJK_TOLERANCE, GJK_ITERATIONS, simplex)
