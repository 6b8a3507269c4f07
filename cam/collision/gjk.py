"""Distance between a triangle and a revolved tool piece by GJK, in numba.

A tool part mesh (``tool_mesh.revolve``) is the revolved meridian polygon with ``N``
sections: ring vertices ``(R cos phi_j, R sin phi_j, z)``, ``phi_j = 2 pi j / N``,
``R = r sec(pi / N)``. The quads between two consecutive rings are planar (their
edges on the rings are parallel), so the solid between two consecutive profile
points is exactly the convex hull of the two rings (a ring of radius 0 is a point)
and the mesh solid is the union of these **pieces**. The distance from a scene
triangle to the mesh solid is the smallest distance to a piece; for a triangle
outside the solid it is the distance to the mesh surface, which is what fcl
computes between the meshes.

The triangle-piece distance is Gilbert-Johnson-Keerthi's (GJK) on the Minkowski
difference ``T - P``: the support of a piece in a direction ``d`` is the ring
vertex nearest ``d``'s azimuth on the better of its two rings (O(1)), the nearest
point of a simplex to the origin is Ericson's (*Real-Time Collision Detection*
5.1.5-5.1.6). Every iteration gives a **certified interval**: ``|v|`` (a point
of the difference) is an upper bound, ``v . w / |v|`` (``w`` the support in
``-v``: a separating plane) a lower bound. The iteration stops when they agree to
``GJK_TOLERANCE``, when the lower bound reaches ``prune`` (the caller has a
nearer piece already), or after ``GJK_ITERATIONS``; callers only rely on the
interval.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

__all__ = ["GJK_ITERATIONS", "GJK_TOLERANCE", "section_ring", "triangle_piece_distance"]

#: Width at which the GJK interval counts as converged, mm.
GJK_TOLERANCE = 1e-9
#: Largest number of GJK iterations (the interval is certified whatever the count).
GJK_ITERATIONS = 64


@numba.njit(cache=True, nogil=True, inline="always")
def _piece_support(
    dx: float, dy: float, dz: float, r0: float, z0: float, r1: float, z1: float,
    ring: NDArray[np.float64],
) -> tuple[float, float, float]:  # pragma: no cover - compiled
    """Vertex of the piece (hull of rings ``(r0, z0)``, ``(r1, z1)``) furthest along d.

    ``ring`` (N, 2) holds ``cos, sin`` of the section angles ``2 pi j / N``."""
    sections = ring.shape[0]
    if dx == 0.0 and dy == 0.0:
        j = 0
    else:
        j = int(round(math.atan2(dy, dx) * (sections / (2.0 * math.pi)))) % sections
    c, s = ring[j, 0], ring[j, 1]
    along = dx * c + dy * s
    v0 = r0 * along + dz * z0
    v1 = r1 * along + dz * z1
    if v0 >= v1:
        return r0 * c, r0 * s, z0
    return r1 * c, r1 * s, z1


def section_ring(sections: int) -> NDArray[np.float64]:
    """``(N, 2)`` cos and sin of the section angles ``2 pi j / N`` of a revolved mesh."""
    phi = 2.0 * math.pi * np.arange(sections) / sections
    return np.column_stack([np.cos(phi), np.sin(phi)])


@numba.njit(cache=True, nogil=True, inline="always")
def _triangle_support(
    dx: float, dy: float, dz: float, t: NDArray[np.float64]
) -> tuple[float, float, float]:  # pragma: no cover - compiled
    best = 0
    value = dx * t[0, 0] + dy * t[0, 1] + dz * t[0, 2]
    for k in range(1, 3):
        v = dx * t[k, 0] + dy * t[k, 1] + dz * t[k, 2]
        if v > value:
            best, value = k, v
    return t[best, 0], t[best, 1], t[best, 2]


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
    # the guessed direction: one separating-plane bound, and the first simplex point
    v = np.empty(3)
    if dx == 0.0 and dy == 0.0 and dz == 0.0:
        dx = 1.0
    ax, ay, az = _triangle_support(-dx, -dy, -dz, t)
    bx, by, bz = _piece_support(dx, dy, dz, r0, z0, r1, z1, ring)
    v[0], v[1], v[2] = ax - bx, ay - by, az - bz
    lower = max((dx * v[0] + dy * v[1] + dz * v[2]) / math.sqrt(dx * dx + dy * dy + dz * dz),
                0.0)
    if lower >= prune:
        return lower, math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    simplex[0] = v  # a point of the difference: the first simplex
    count = 1
    for _ in range(GJK_ITERATIONS):
        vv = v[0] * v[0] + v[1] * v[1] + v[2] * v[2]
        if vv <= 0.0:
            return 0.0, 0.0
        norm = math.sqrt(vv)
        ax, ay, az = _triangle_support(-v[0], -v[1], -v[2], t)
        bx, by, bz = _piece_support(v[0], v[1], v[2], r0, z0, r1, z1, ring)
        wx, wy, wz = ax - bx, ay - by, az - bz
        vw = v[0] * wx + v[1] * wy + v[2] * wz
        if vw > 0.0:
            lower = max(lower, vw / norm)
        if lower >= prune or norm - lower <= GJK_TOLERANCE:
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
