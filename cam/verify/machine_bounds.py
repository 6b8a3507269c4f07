"""Certified lower bounds of the machine's pair distances, compiled and batched.

``MachineClearance`` (``cam.verify.machine_query``) needs, per pose and checked pair,
either the exact distance (fcl, ``machine_scene._distance``) or a lower bound at or
above the pair's limit (its clearance plus the caller's cap). Every solid of a
``MachineScene`` is a union of convex pieces as fcl measures them: a box's corners,
an exact cylinder, the holder's hull, the part's pieces (a mesh solid: the hull of
its points, which holds it). So, for any unit direction ``u``, ``min_b u.b - max_a
u.a`` over the two pieces (their support functions) is a lower bound of the distance
(a separating-plane certificate), whatever way ``u`` was found.

``pair_bounds`` walks the poses of one call in order, per pair (the first that
certifies the row ends it):

1. the bounding spheres' ``|c_i - c_j| - (r_i + r_j)``, and each sphere's distance
   from the other solid itself (exact from a box or a cylinder: the spindle head's
   sphere, 359 mm for a 300 x 420 x 500 mm box, certifies nothing);
2. conservative advancement (checked first): a bound ``d`` found at an earlier row
   (by 1, 3 or itself) holds at this one less the motion of both solids since
   (``|delta centre| + radius * angle`` per row);
3. per pair of convex pieces, Gilbert-Johnson-Keerthi on the two point sets, started
   from the direction the same piece pair ended with last time (consecutive poses are
   close, so one support usually certifies): ``cam.collision.gjk.gjk_interval``, the
   project's one GJK; every iteration's certificate is a valid bound. A bound is
   improved to ``ADVANCE_SLACK`` past what certifies the row, so that it carries.

A pair is certified at a row when one of them reaches ``limit + GUARD``; then its
value is that bound less ``GUARD`` (still at or above the limit). Otherwise the row is
left undecided and the caller measures it with fcl, so a distance below the limit is
always fcl's own. ``GUARD`` covers fcl's own GJK tolerance: a pose fcl puts below the
limit is never certified above it here.

In ``tight`` mode (``MachineClearance.survey`` and ``smallest``) the bounds are run to
convergence for every entry whose lower bound is below the smallest upper bound found
so far (plus ``2 GUARD``), so that only the entries below their limit and those that
can hold the minimum go to fcl.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numba
import numpy as np
from numpy.typing import NDArray

from cam.collision.gjk import CYLINDER, POINTS, gjk_interval

__all__ = ["ADVANCE_SLACK", "GUARD", "PackedSolids", "pack_solids", "pair_bounds",
           "stack_poses"]

#: Margin kept over fcl's own distance tolerance, mm (module docstring).
GUARD = 1e-4
#: How far above the limit a bound is improved, so that it carries over rows, mm.
ADVANCE_SLACK = 2.0
#: Width at which a GJK interval counts as converged, mm.
_TOLERANCE = 1e-7
#: Largest number of GJK iterations (the bound is certified whatever the count).
_ITERATIONS = 48

Array = NDArray[np.float64]
IntArray = NDArray[np.int64]


@dataclass(frozen=True)
class PackedSolids:
    """The scene's solids as convex point sets, flattened for the kernel.

    Attributes
    ----------
    points : (v, 3) float64
        Hull vertices of every piece, in its solid's group frame, mm.
    piece_start : (q + 1,) int64
        Piece ``k``'s points are ``points[piece_start[k]:piece_start[k + 1]]``.
    piece_centre : (q, 3) float64
        Centres of the pieces' bounding spheres, group frame, mm.
    piece_radius : (q,) float64
    piece_cylinder : (q, 8) float64
        A piece that is an exact cylinder (as fcl measures it): centre (3), unit axis
        (3), radius and half-length in the group frame, mm; radius ``-1`` for a piece
        given by its points.
    solid_box : (s, 6) float64
        A solid that is a box (as fcl measures it): centre and half-sizes in its group
        frame, mm; half-size ``-1`` otherwise.
    solid_start : (s + 1,) int64
        Solid ``i``'s pieces are ``solid_start[i]:solid_start[i + 1]``.
    solid_group : (s,) int64
        Index of each solid's group in ``groups``.
    solid_excess : (s,) float64
        How far the pieces reach beyond the solid fcl measures, mm (0; ``inf`` for a
        mesh, whose hull distance bounds nothing from above): a distance of the
        pieces plus both excesses is an upper bound of fcl's.
    groups : tuple of str
        Group names in the order of ``stack_poses``.
    """

    points: Array
    piece_start: IntArray
    piece_centre: Array
    piece_radius: Array
    piece_cylinder: Array
    solid_box: Array
    solid_start: IntArray
    solid_group: IntArray
    solid_excess: Array
    groups: tuple[str, ...]


def _hull_points(points: Array) -> Array:
    """Vertices of the convex hull of ``points`` (the points themselves when few)."""
    import trimesh

    points = np.asarray(points, np.float64)
    if len(points) <= 8:
        return points
    return np.asarray(trimesh.convex.convex_hull(points).vertices, np.float64)


def pack_solids(solids: list[Any], tilt: str) -> PackedSolids:
    """``PackedSolids`` of a scene's solids (``MachineScene.solids``).

    A solid with ``pieces`` is the union of their hulls (as fcl measures it); any
    other is the hull of its vertices, which holds the box, cylinder or convex solid
    fcl measures; a cylinder is kept exact (``piece_cylinder``).
    """
    groups = ("base", "X", "Y", "Z", tilt, "C")
    chunks: list[Array] = []
    cylinders: list[Array] = []
    solid_start = [0]
    excess = []
    for solid in solids:
        pieces = solid.pieces if solid.pieces else (solid.vertices,)
        chunks += [_hull_points(p) for p in pieces]
        cylinders += [_cylinder(solid)] * len(pieces)
        solid_start.append(len(chunks))
        excess.append(0.0 if solid.pieces or solid.kind != "stl" else math.inf)
    sizes = np.array([len(c) for c in chunks], dtype=np.int64)
    centre = np.array([0.5 * (c.min(axis=0) + c.max(axis=0)) for c in chunks])
    radius = np.array([float(np.linalg.norm(c - m, axis=1).max())
                       for c, m in zip(chunks, centre, strict=True)])
    return PackedSolids(np.ascontiguousarray(np.vstack(chunks)),
                        np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64),
                        centre, radius, np.asarray(cylinders, np.float64),
                        np.array([_box(s) for s in solids], np.float64),
                        np.asarray(solid_start, np.int64),
                        np.array([groups.index(s.group) for s in solids], np.int64),
                        np.asarray(excess, np.float64), groups)


def _box(solid: Any) -> Array:
    """``solid_box``'s row of a solid."""
    out = np.full(6, -1.0)
    if solid.box is not None and not solid.pieces:
        out[:3] = solid.box[1]
        out[3:] = 0.5 * np.asarray(solid.box[0], np.float64)
    return out


def _cylinder(solid: Any) -> Array:
    """``piece_cylinder``'s row of a solid (radius -1: not an exact cylinder)."""
    out = np.full(8, -1.0)
    if solid.cylinder is not None and not solid.pieces:
        radius, length, turn, centre = solid.cylinder
        out[:3] = centre
        out[3:6] = np.asarray(turn, np.float64)[:, 2]  # local +Z: the axis
        out[6], out[7] = float(radius), 0.5 * float(length)
    return out


def stack_poses(poses: dict[str, Any], groups: tuple[str, ...]) -> tuple[Array, Array]:
    """``group_poses``' dict as contiguous arrays: rotations ``(n, g, 3, 3)`` and
    translations ``(n, g, 3)`` in the order of ``groups``."""
    rot = np.ascontiguousarray(np.stack([poses[g][0] for g in groups], axis=1))
    trans = np.ascontiguousarray(np.stack([poses[g][1] for g in groups], axis=1))
    return rot, trans


@numba.njit(cache=True, nogil=True, inline="always")
def _piece(points: Array, piece_start: IntArray, cylinder: Array, k: int, rot: Array,
           trans: Array) -> Any:  # pragma: no cover - compiled
    """Piece ``k`` placed by ``rot``, ``trans`` as a ``gjk.shape_support`` shape: an
    exact cylinder, else the hull of its points."""
    c = cylinder[k]
    kind = CYLINDER if c[6] >= 0.0 else POINTS
    return (kind, points, piece_start[k], piece_start[k + 1],
            (c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]), rot, trans)


@numba.njit(cache=True, nogil=True, inline="always")
def _centre(rot: Array, trans: Array, c: Array) -> tuple[float, float, float]:
    """``rot @ c + trans``."""  # pragma: no cover - compiled
    return (rot[0, 0] * c[0] + rot[0, 1] * c[1] + rot[0, 2] * c[2] + trans[0],
            rot[1, 0] * c[0] + rot[1, 1] * c[1] + rot[1, 2] * c[2] + trans[1],
            rot[2, 0] * c[0] + rot[2, 1] * c[1] + rot[2, 2] * c[2] + trans[2])


@numba.njit(cache=True, nogil=True)
def _point_distance(x: float, y: float, z: float, rot: Array, trans: Array, box: Array,
                    cylinder: Array, piece_centre: Array, piece_radius: Array, first: int,
                    last: int) -> float:
    """Lower bound of the distance of point ``(x, y, z)`` (machine frame) from a solid
    (placed by ``rot``, ``trans``): exact for a box or a cylinder, else from its
    pieces' bounding spheres, mm."""
    # pragma: no cover - compiled
    dx, dy, dz = x - trans[0], y - trans[1], z - trans[2]
    lx = rot[0, 0] * dx + rot[1, 0] * dy + rot[2, 0] * dz
    ly = rot[0, 1] * dx + rot[1, 1] * dy + rot[2, 1] * dz
    lz = rot[0, 2] * dx + rot[1, 2] * dy + rot[2, 2] * dz
    if box[3] >= 0.0:
        qx = max(abs(lx - box[0]) - box[3], 0.0)
        qy = max(abs(ly - box[1]) - box[4], 0.0)
        qz = max(abs(lz - box[2]) - box[5], 0.0)
        return math.sqrt(qx * qx + qy * qy + qz * qz)
    c = cylinder[first]
    if last - first == 1 and c[6] >= 0.0:
        qx, qy, qz = lx - c[0], ly - c[1], lz - c[2]
        along = qx * c[3] + qy * c[4] + qz * c[5]
        rx, ry, rz = qx - along * c[3], qy - along * c[4], qz - along * c[5]
        radial = max(math.sqrt(rx * rx + ry * ry + rz * rz) - c[6], 0.0)
        axial = max(abs(along) - c[7], 0.0)
        return math.sqrt(radial * radial + axial * axial)
    out = math.inf
    for k in range(first, last):
        m = piece_centre[k]
        d = math.sqrt((lx - m[0]) ** 2 + (ly - m[1]) ** 2 + (lz - m[2]) ** 2) - piece_radius[k]
        out = min(out, d)
    return max(out, 0.0)


@numba.njit(cache=True, nogil=True)
def _pieces_bound(points: Array, piece_start: IntArray, piece_centre: Array,
                  piece_radius: Array, cylinder: Array, si: int, ei: int, sj: int,
                  ej: int, ra: Array, ta: Array, rb: Array, tb: Array, prune: float,
                  target: float, stop_below: float, guesses: Array, simplex: Array
                  ) -> tuple[float, float]:
    """Lower and upper bound of the distance of two unions of pieces (``si:ei`` on
    ``ra, ta``, ``sj:ej`` on ``rb, tb``); a piece pair's bound is improved up to
    ``target`` (at or above ``prune``); classification (``stop_below`` finite) stops
    at the first piece pair below ``prune``."""
    # pragma: no cover - compiled
    lower, upper = math.inf, math.inf
    slot = 0
    for a in range(si, ei):
        cax, cay, caz = _centre(ra, ta, piece_centre[a])
        for b in range(sj, ej):
            cbx, cby, cbz = _centre(rb, tb, piece_centre[b])
            sphere = math.sqrt((cax - cbx) ** 2 + (cay - cby) ** 2 + (caz - cbz) ** 2) \
                - piece_radius[a] - piece_radius[b]
            if sphere >= target:
                lower = min(lower, sphere)
            else:
                lo, hi = gjk_interval(_piece(points, piece_start, cylinder, a, ra, ta),
                                      _piece(points, piece_start, cylinder, b, rb, tb),
                                      guesses[slot], target, stop_below, _TOLERANCE,
                                      _ITERATIONS, simplex)
                lower = min(lower, lo)
                upper = min(upper, hi)
                if lo < prune and stop_below > -math.inf:
                    return lower, upper  # undecided: the caller measures the pair
            slot += 1
    return lower, upper


@numba.njit(cache=True, nogil=True)
def _cumulative_motion(rot: Array, trans: Array, joints: Array, solid_group: IntArray,
                       solid_centre: Array, solid_radius: Array) -> Array:
    """Cumulative motion bound of every solid from row 0 ``(n, s)``, mm: per row the
    move of its bounding-sphere centre plus its radius times the turn of its group
    (the tilt for the cradle, tilt and C for the table; groups 4 and 5)."""
    # pragma: no cover - compiled
    n, s = rot.shape[0], solid_group.shape[0]
    out = np.zeros((n, s))
    for k in range(s):
        g = solid_group[k]
        px, py, pz = _centre(rot[0, g], trans[0, g], solid_centre[k])
        for row in range(1, n):
            cx, cy, cz = _centre(rot[row, g], trans[row, g], solid_centre[k])
            step = math.sqrt((cx - px) ** 2 + (cy - py) ** 2 + (cz - pz) ** 2)
            if g >= 4:
                turn = 0.0
                for axis in range(3, 5 if g == 5 else 4):
                    d = joints[row, axis] - joints[row - 1, axis]
                    turn += abs((d + math.pi) % (2.0 * math.pi) - math.pi)  # same rotation
                step += solid_radius[k] * turn
            out[row, k] = out[row - 1, k] + step
            px, py, pz = cx, cy, cz
    return out


@numba.njit(cache=True, nogil=True)
def pair_bounds(points: Array, piece_start: IntArray, piece_centre: Array,
                piece_radius: Array, cylinder: Array, solid_box: Array,
                solid_start: IntArray, solid_group: IntArray, solid_excess: Array,
                solid_centre: Array, solid_radius: Array, first: IntArray,
                second: IntArray, limit: Array, rot: Array, trans: Array,
                joints: Array, guesses: Array, tight: bool, best: float, slack: float
                ) -> tuple[Array, NDArray[np.bool_], float]:
    """Lower bounds of every pair at every pose (module docstring).

    Parameters
    ----------
    points, piece_start, piece_centre, piece_radius, cylinder, solid_box, solid_start,
    solid_group, solid_excess
        ``PackedSolids`` (``cylinder``: ``piece_cylinder``).
    solid_centre, solid_radius : (s, 3), (s,) float64
        Bounding spheres of the solids, group frames, mm.
    first, second : (p,) int64
        The pairs' solids.
    limit : (p,) float64
        Per pair: certify at ``limit + GUARD`` (classification mode), mm.
    rot, trans : (n, g, 3, 3), (n, g, 3) float64
        Group poses per row (``stack_poses``).
    joints : (n, 5) float64
        The rows' joints (X Y Z mm, tilt C rad), for the motion bound.
    guesses : (p, k, 3) float64
        Start directions per pair and piece pair (updated in place).
    tight : bool
        ``smallest``'s mode: bounds to convergence below the running minimum.
    best : float
        Tight mode: a known distance the minimum is at or below (mm, ``inf``: none).
    slack : float
        A bound is improved up to ``slack`` (mm) above what certifies the row, so that
        it carries over the next rows (``ADVANCE_SLACK``).

    Returns
    -------
    value : (n, p) float64
        Certified lower bound less ``GUARD`` where ``certain``; else the best lower
        bound found (classification: to be measured by fcl).
    certain : (n, p) bool
        The bound is at or above ``limit`` (plus ``GUARD``) and, in tight mode, the
        entry cannot hold the minimum either (its bound exceeds the returned ``best``
        plus ``2 GUARD``).
    best : float
        Tight mode: the smallest upper bound of fcl's distance found (or the given
        ``best``), mm.
    """
    # pragma: no cover - compiled
    n, p = rot.shape[0], first.shape[0]
    cumulative = _cumulative_motion(rot, trans, joints, solid_group, solid_centre,
                                    solid_radius)
    value = np.empty((n, p))
    certain = np.zeros((n, p), dtype=np.bool_)
    simplex = np.empty((4, 3))
    for k in range(p):
        i, j = first[k], second[k]
        gi, gj = solid_group[i], solid_group[j]
        last_bound = -math.inf
        last_row = 0
        for row in range(n):
            prune = limit[k] + GUARD
            if tight:
                prune = max(prune, best + 2.0 * GUARD)
            # the bound carried from the last row with a fresh one, first: on a path
            # it certifies most rows of the pairs far from their limit
            bound = last_bound - ((cumulative[row, i] - cumulative[last_row, i])
                                  + (cumulative[row, j] - cumulative[last_row, j]))
            if bound < prune:
                ra, ta = rot[row, gi], trans[row, gi]
                rb, tb = rot[row, gj], trans[row, gj]
                cix, ciy, ciz = _centre(ra, ta, solid_centre[i])
                cjx, cjy, cjz = _centre(rb, tb, solid_centre[j])
                bound = max(bound, math.sqrt((cix - cjx) ** 2 + (ciy - cjy) ** 2
                                             + (ciz - cjz) ** 2)
                            - solid_radius[i] - solid_radius[j])
                if bound < prune:  # each sphere against the other solid itself
                    bound = max(bound, _point_distance(
                        cjx, cjy, cjz, ra, ta, solid_box[i], cylinder, piece_centre,
                        piece_radius, solid_start[i], solid_start[i + 1]) - solid_radius[j])
                if bound < prune:
                    bound = max(bound, _point_distance(
                        cix, ciy, ciz, rb, tb, solid_box[j], cylinder, piece_centre,
                        piece_radius, solid_start[j], solid_start[j + 1]) - solid_radius[i])
                if bound < prune:
                    lower, upper = _pieces_bound(
                        points, piece_start, piece_centre, piece_radius, cylinder,
                        solid_start[i], solid_start[i + 1], solid_start[j], solid_start[j + 1],
                        ra, ta, rb, tb, prune, prune + slack, -math.inf if tight else prune,
                        guesses[k], simplex)
                    bound = max(bound, lower)
                    upper += solid_excess[i] + solid_excess[j]
                    if tight and upper < best:
                        best = upper
                if bound >= prune:
                    last_bound, last_row = bound, row
            value[row, k] = bound - GUARD if bound >= prune else bound
            certain[row, k] = bound >= prune
    if tight:  # entries certified against an earlier, larger running minimum
        for row in range(n):
            for k in range(p):
                if (not certain[row, k] and value[row, k] > best + 2.0 * GUARD
                        and value[row, k] >= limit[k] + GUARD):
                    certain[row, k] = True
                    value[row, k] -= GUARD
    return value, certain, best
