"""Certified distance bounds between two placed convex vertex sets, by GJK in numba.

The machine model's solids (``postproc.machine_model``: cylinders and boxes, the
part's pieces, tool and holder) are held by the convex hulls of their vertices; the
distance between two hulls is a lower bound of the distance between the solids
(each solid lies inside its hull), and for two convex solids it is their distance.
The planner's machine queries (``cam.verify.machine_query``) only compare such
distances with a limit, so a certified lower bound at or above the limit decides a
pose without the exact (fcl) query; below it fcl still decides.

``placed_gaps`` runs Gilbert-Johnson-Keerthi on the Minkowski difference ``B - A``
of the two placed sets (``A = R_a V_a + t_a``): the support of a placed set in a
direction ``d`` is ``R (argmax_v v . R^T d) + t``, one pass over the vertices. Each
iteration gives a certified interval: ``|v|`` (a point of the difference) is an upper
bound and ``v . w / |v|`` (``w`` the difference's support in ``-v``: a separating
plane) a lower bound, valid for any ``v`` whatever the simplex code did. The
simplex reduction is ``gjk._reduce`` (Ericson's closest point of a simplex).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

from cam.collision.gjk import GJK_ITERATIONS, _reduce

__all__ = ["placed_gaps"]

Array = NDArray[np.float64]


@numba.njit(cache=True, nogil=True, inline="always")
def _placed_support(
    verts: Array, rot: Array, trans: Array, dx: float, dy: float, dz: float
) -> tuple[float, float, float]:  # pragma: no cover - compiled
    """Vertex of ``rot @ verts + trans`` furthest along ``d`` (machine frame)."""
    lx = rot[0, 0] * dx + rot[1, 0] * dy + rot[2, 0] * dz
    ly = rot[0, 1] * dx + rot[1, 1] * dy + rot[2, 1] * dz
    lz = rot[0, 2] * dx + rot[1, 2] * dy + rot[2, 2] * dz
    best = 0
    value = verts[0, 0] * lx + verts[0, 1] * ly + verts[0, 2] * lz
    for k in range(1, verts.shape[0]):
        v = verts[k, 0] * lx + verts[k, 1] * ly + verts[k, 2] * lz
        if v > value:
            best, value = k, v
    px, py, pz = verts[best, 0], verts[best, 1], verts[best, 2]
    return (rot[0, 0] * px + rot[0, 1] * py + rot[0, 2] * pz + trans[0],
            rot[1, 0] * px + rot[1, 1] * py + rot[1, 2] * pz + trans[1],
            rot[2, 0] * px + rot[2, 1] * py + rot[2, 2] * pz + trans[2])


@numba.njit(cache=True, nogil=True)
def _gap(
    va: Array, ra: Array, ta: Array, vb: Array, rb: Array, tb: Array,
    gx: float, gy: float, gz: float, prune: float, tolerance: float,
    simplex: Array, direction: Array,
) -> tuple[float, float]:  # pragma: no cover - compiled
    """Certified ``(lower, upper)`` distance of two placed sets; ``direction`` gets the
    last separating direction (from A towards B, unit; zeros when they overlap)."""
    if gx == 0.0 and gy == 0.0 and gz == 0.0:
        gx = 1.0
    # w = support of B - A in -g: B's support in -g minus A's in +g
    bx, by, bz = _placed_support(vb, rb, tb, -gx, -gy, -gz)
    ax, ay, az = _placed_support(va, ra, ta, gx, gy, gz)
    v = np.empty(3)
    v[0], v[1], v[2] = bx - ax, by - ay, bz - az
    norm_g = math.sqrt(gx * gx + gy * gy + gz * gz)
    lower = max((gx * v[0] + gy * v[1] + gz * v[2]) / norm_g, 0.0)
    direction[0], direction[1], direction[2] = gx / norm_g, gy / norm_g, gz / norm_g
    if lower >= prune:
        return lower, math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    simplex[0] = v
    count = 1
    for _ in range(GJK_ITERATIONS):
        vv = v[0] * v[0] + v[1] * v[1] + v[2] * v[2]
        if vv <= 0.0:
            direction[:] = 0.0
            return 0.0, 0.0
        norm = math.sqrt(vv)
        bx, by, bz = _placed_support(vb, rb, tb, -v[0], -v[1], -v[2])
        ax, ay, az = _placed_support(va, ra, ta, v[0], v[1], v[2])
        wx, wy, wz = bx - ax, by - ay, bz - az
        vw = v[0] * wx + v[1] * wy + v[2] * wz
        if vw > 0.0 and vw / norm > lower:
            lower = vw / norm
            direction[0], direction[1], direction[2] = v[0] / norm, v[1] / norm, v[2] / norm
        if lower >= prune or norm - lower <= tolerance:
            return lower, norm
        for k in range(count):  # w already in the simplex: no progress possible
            if simplex[k, 0] == wx and simplex[k, 1] == wy and simplex[k, 2] == wz:
                return lower, norm
        simplex[count, 0], simplex[count, 1], simplex[count, 2] = wx, wy, wz
        count += 1
        v, count = _reduce(simplex, count)
        if count == 0:
            direction[:] = 0.0
            return 0.0, 0.0
        if v[0] * v[0] + v[1] * v[1] + v[2] * v[2] >= vv:
            return lower, norm  # no decrease (rounding): stop with the interval
    return lower, math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])


@numba.njit(cache=True, nogil=True)
def placed_gaps(
    va: Array, ra: Array, ta: Array, vb: Array, rb: Array, tb: Array,
    guess: Array, prune: float, tolerance: float,
) -> tuple[Array, Array, Array]:  # pragma: no cover - compiled
    """Certified distance intervals of two convex vertex sets at ``m`` placements.

    Parameters
    ----------
    va, vb : (na, 3), (nb, 3) float64
        Vertices of the two sets in their own frames, mm (their hulls are the sets).
    ra, rb : (m, 3, 3) float64
        Rotations of the sets per placement.
    ta, tb : (m, 3) float64
        Translations per placement, mm: a point ``p`` of set A is at ``ra @ p + ta``.
    guess : (m, 3) float64
        A direction from A towards B per placement (any; a good one, e.g. the last
        witness, ends most placements after one support each).
    prune : float
        Stop a placement as soon as its lower bound reaches this, mm.
    tolerance : float
        Stop when the interval is this narrow, mm.

    Returns
    -------
    lower, upper : (m,) float64
        ``0 <= lower <= distance of the hulls <= upper`` (0, 0: the hulls overlap).
    direction : (m, 3) float64
        Unit direction from A towards B of the best separating plane (zeros: overlap).
    """
    m = ra.shape[0]
    lower = np.empty(m)
    upper = np.empty(m)
    direction = np.zeros((m, 3))
    simplex = np.empty((4, 3))
    for i in range(m):
        lower[i], upper[i] = _gap(va, ra[i], ta[i], vb, rb[i], tb[i], guess[i, 0],
                                  guess[i, 1], guess[i, 2], prune, tolerance, simplex,
                                  direction[i])
    return lower, upper, direction


@numba.njit(cache=True, nogil=True)
def sequence_gaps(
    verts: Array, offsets: NDArray[np.int64], rot: Array, trans: Array, centres: Array,
    radius: Array, moved: Array, first: NDArray[np.intp], second: NDArray[np.intp],
    limit: Array, witness: Array, safety: float, tolerance: float,
) -> tuple[Array, NDArray[np.bool_]]:  # pragma: no cover - compiled
    """Lower bounds of pairs of placed convex sets along a sequence of placements.

    Per pair ``k`` (sets ``first[k]``, ``second[k]``) and row, in row order: the
    bounding spheres' gap; where it is below ``limit[k]``, the bound ``d - motion``
    carried from the last row the pair was bounded at (conservative advancement);
    where that is below too, the hulls' gap (``_gap`` from the last separating
    direction, stopped at ``limit[k] + safety``) lowered by ``safety``. A row where
    even that stays below the limit is flagged: its distance is for the caller to
    measure.

    Parameters
    ----------
    verts : (V, 3) float64
        Every set's vertices, in its own frame, set ``s`` at ``offsets[s]:offsets[s + 1]``.
    rot, trans : (n, S, 3, 3), (n, S, 3) float64
        Placement of every set per row.
    centres, radius : (n, S, 3), (S,) float64
        Bounding spheres per row, mm.
    moved : (n, S) float64
        Motion bound of every set from the row before, mm.
    witness : (P, 3) float64
        Per pair a direction from ``first`` towards ``second`` in ``first``'s frame
        (zeros: none yet); updated to the last separating direction found.

    Returns
    -------
    lower : (n, P) float64
        Lower bounds of the distances, mm; at or above ``limit[k]`` where not flagged.
    flagged : (n, P) bool
    """
    n = rot.shape[0]
    pairs = first.shape[0]
    lower = np.zeros((n, pairs))
    flagged = np.zeros((n, pairs), dtype=np.bool_)
    simplex = np.empty((4, 3))
    direction = np.empty(3)
    for k in range(pairs):
        i, j = first[k], second[k]
        va = verts[offsets[i]:offsets[i + 1]]
        vb = verts[offsets[j]:offsets[j + 1]]
        reach = radius[i] + radius[j]
        w = witness[k]
        known = -1
        known_d = 0.0
        travel = 0.0  # motion of the pair since the known row
        for s in range(n):
            if known >= 0 and s > 0:
                travel += moved[s, i] + moved[s, j]
            dx = centres[s, j, 0] - centres[s, i, 0]
            dy = centres[s, j, 1] - centres[s, i, 1]
            dz = centres[s, j, 2] - centres[s, i, 2]
            bound = math.sqrt(dx * dx + dy * dy + dz * dz) - reach
            value = max(bound, 0.0)
            if bound >= limit[k]:
                lower[s, k] = value
                continue
            if known >= 0 and known_d - travel >= limit[k]:
                lower[s, k] = max(value, known_d - travel)
                continue
            ra = rot[s, i]
            if w[0] != 0.0 or w[1] != 0.0 or w[2] != 0.0:
                gx = ra[0, 0] * w[0] + ra[0, 1] * w[1] + ra[0, 2] * w[2]
                gy = ra[1, 0] * w[0] + ra[1, 1] * w[1] + ra[1, 2] * w[2]
                gz = ra[2, 0] * w[0] + ra[2, 1] * w[1] + ra[2, 2] * w[2]
            else:
                gx, gy, gz = dx, dy, dz
            low, _ = _gap(va, ra, trans[s, i], vb, rot[s, j], trans[s, j], gx, gy, gz,
                          limit[k] + safety, tolerance, simplex, direction)
            if direction[0] != 0.0 or direction[1] != 0.0 or direction[2] != 0.0:
                for c in range(3):  # into first's frame: R^T direction
                    w[c] = (ra[0, c] * direction[0] + ra[1, c] * direction[1]
                            + ra[2, c] * direction[2])
            if low - safety >= limit[k]:
                lower[s, k] = max(value, low - safety)
                known, known_d, travel = s, low - safety, 0.0
            else:
                lower[s, k] = value
                flagged[s, k] = True
                known = -1
    return lower, flagged
