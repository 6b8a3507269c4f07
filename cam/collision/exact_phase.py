"""Sphere tests of one tool part against all scene roles, in numba (stages 1 and 2).

A tool part is covered by spheres on its axis (``broad_phase.axis_spheres``).
For every posture, one compiled kernel (``classify_part``) does:

1. **Whole scene**: each sphere (centre ``c``, radius ``rho``) whose lower
   bound of the distance to the whole scene exceeds ``rho + m`` is clear of
   every role (the scene grid is the node-wise minimum of the role grids): the
   coarse copy of the grid first (one cached node,
   ``distance_grid.coarse_lower_bound``), then, for spheres small enough for
   the role masks, the mask of the nearest node (no role in it: clear), else
   the 8 corners of the fine scene grid. A posture with no sphere left is clear.
2. **Roles**, in scene order, for the spheres left: the role must be in the
   sphere's role mask (``distance_grid.RoleMask``; spheres too large for the
   mask try every role), the role's coarse and fine grid bounds must not clear
   the sphere, and then the exact distance ``d`` from ``c`` to the role's
   triangles within ``rho + m`` is computed (``triangle_bvh``), deepest sphere
   first:

   * ``d > rho + m``: the sphere, hence this slab of the part mesh, is clear;
   * ``d < r_in - m``: a point of the surface lies strictly inside the inscribed
     ball of radius ``r_in`` of the *true* part at that axis point, which lies
     inside the part mesh. If the connected piece of the role mesh holding that
     point also has points outside the part mesh, the two surfaces cross and fcl
     must report contact (a *definite hit*). Sufficient for that: every piece of
     the role is larger (bounding-box diagonal) than the part mesh, or the
     piece's bounding box is not inside the box around this posture's covering
     spheres. A definite hit ends the posture (later roles and parts cannot
     come first in the report);
   * otherwise fcl decides (*undecided*).

``m`` is the broad-phase margin; a part/role pair is clear when every sphere is.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numba
import numpy as np
from numpy.typing import NDArray
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from cam.collision.distance_grid import (
    DistanceGrid,
    RoleMask,
    coarse_lower_bound,
    point_lower_bound,
)
from cam.collision.triangle_bvh import STACK, TriangleBVH, nearest_within

CLEAR, UNDECIDED, HIT = 0, 1, 2


@numba.njit(cache=True, nogil=True)
def _sphere_bound(
    fine: NDArray[np.float32],
    coarse: NDArray[np.float32],
    origin: NDArray[np.float64],
    spacing: float,
    coarse_spacing: float,
    box_lo: NDArray[np.float64],
    box_hi: NDArray[np.float64],
    x: float,
    y: float,
    z: float,
    need: float,
) -> float:  # pragma: no cover - compiled
    """Lower bound of the distance at a point: coarse grid, then fine if below ``need``."""
    b = coarse_lower_bound(coarse, origin, coarse_spacing, box_lo, box_hi, x, y, z)
    if b > need:
        return b
    return max(b, point_lower_bound(fine, origin, spacing, box_lo, box_hi, x, y, z))


@numba.njit(cache=True, nogil=True)
def _classify_part(
    whole: NDArray[np.float32],
    whole_coarse: NDArray[np.float32],
    whole_lo: NDArray[np.float64],
    whole_hi: NDArray[np.float64],
    origin: NDArray[np.float64],
    spacing: float,
    coarse_spacing: float,
    role_fine: NDArray[np.float32],
    role_coarse: NDArray[np.float32],
    role_lo: NDArray[np.float64],
    role_hi: NDArray[np.float64],
    masks: NDArray[np.int64],
    mask_limit: float,
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
    piece: NDArray[np.int64],
    piece_lo: NDArray[np.float64],
    piece_hi: NDArray[np.float64],
    tip: NDArray[np.float64],
    axis: NDArray[np.float64],
    heights: NDArray[np.float64],
    radii: NDArray[np.float64],
    inner: NDArray[np.float64],
    profile: NDArray[np.float64],
    deep: float,
    role_on: NDArray[np.bool_],
    allow_hit: NDArray[np.bool_],
    margin: float,
    max_reach: float,
) -> NDArray[np.int8]:  # pragma: no cover - compiled
    n = tip.shape[0]
    m = heights.shape[0]
    roles = role_fine.shape[0]
    state = np.zeros((n, roles), dtype=np.int8)
    centre = np.empty((m, 3))
    todo = np.empty(m, dtype=np.int64)
    bits = np.empty(m, dtype=np.int64)
    pick = np.empty(m, dtype=np.int64)
    gap = np.empty(m)
    box_lo_q = np.empty(3)
    box_hi_q = np.empty(3)
    stack = np.empty(STACK, dtype=np.int64)
    lower = np.empty(STACK)
    half_diagonal = 0.5 * math.sqrt(3.0) * spacing
    mx, my, mz = masks.shape
    for q in range(n):
        box_lo_q[:] = np.inf
        box_hi_q[:] = -np.inf
        count = 0
        for s in range(m):
            h = heights[s]
            for a in range(3):
                centre[s, a] = tip[q, a] + h * axis[q, a]
                box_lo_q[a] = min(box_lo_q[a], centre[s, a] - radii[s])
                box_hi_q[a] = max(box_hi_q[a], centre[s, a] + radii[s])
            need = radii[s] + margin
            cx, cy, cz = centre[s, 0], centre[s, 1], centre[s, 2]
            b = coarse_lower_bound(
                whole_coarse, origin, coarse_spacing, whole_lo, whole_hi, cx, cy, cz
            )
            if b > need:
                continue  # clear of the whole scene
            # roles that may come within rho + m of this sphere
            if need + half_diagonal > mask_limit:
                # too large for the masks: the fine whole-scene grid, then every role
                b = point_lower_bound(whole, origin, spacing, whole_lo, whole_hi, cx, cy, cz)
                if b > need:
                    continue
                bits[count] = -1
            else:
                # the roles in the mask; their own grids are tested next
                i = int(round((cx - origin[0]) / spacing))
                j = int(round((cy - origin[1]) / spacing))
                k = int(round((cz - origin[2]) / spacing))
                if not (0 <= i < mx and 0 <= j < my and 0 <= k < mz):
                    continue  # off the grid: farther than the limit from every role
                bits[count] = masks[i, j, k]
                if bits[count] == 0:
                    continue
            todo[count] = s
            count += 1
        if count == 0:
            continue
        for r in range(roles):
            if not role_on[r]:
                continue
            chosen = 0
            for c in range(count):
                if bits[c] != -1 and ((bits[c] >> r) & 1) == 0:
                    continue
                s = todo[c]
                need = radii[s] + margin
                b = _sphere_bound(
                    role_fine[r], role_coarse[r], origin, spacing, coarse_spacing,
                    role_lo[r], role_hi[r], centre[s, 0], centre[s, 1], centre[s, 2], need,
                )
                if b > need:
                    continue
                pick[chosen] = s
                gap[chosen] = b - radii[s]
                chosen += 1
            if chosen == 0:
                continue
            # deepest spheres first: a definite hit, if any, is found with least work
            for o in range(1, chosen):  # insertion sort of (gap, pick); chosen is small
                g, v = gap[o], pick[o]
                j = o - 1
                while j >= 0 and gap[j] > g:
                    gap[j + 1], pick[j + 1] = gap[j], pick[j]
                    j -= 1
                gap[j + 1], pick[j + 1] = g, v
            verdict = CLEAR
            for o in range(chosen):
                s = pick[o]
                rho = radii[s]
                hit_below = inner[s] - margin
                reach = rho + 2.0 * margin
                if reach > max_reach:
                    verdict = UNDECIDED
                    continue
                d, t, inside = nearest_within(
                    centre[s, 0], centre[s, 1], centre[s, 2], reach, hit_below, tris,
                    tri_centre, tri_radius, tri_slab, node_lo, node_hi, node_slab, left, first,
                    size, roots[r], stack, lower, profile, tip[q], axis[q], deep,
                )
                if t < 0:
                    continue  # nothing within reach: this sphere is clear
                # inside: a surface point found strictly inside the true part (in the
                # inscribed ball, or deeper than ``deep`` inside the profile)
                if inside:
                    # the surface piece of triangle t enters the true part; it also
                    # leaves the part mesh if it is larger than the part (allow_hit)
                    # or sticks out of the box around this posture's spheres
                    p = piece[t]
                    outside = False
                    for a in range(3):
                        if piece_lo[p, a] < box_lo_q[a] or piece_hi[p, a] > box_hi_q[a]:
                            outside = True
                    if allow_hit[r] or outside:
                        verdict = HIT
                        break
                    verdict = UNDECIDED  # (the search stopped early: d may not be the least)
                elif d - rho <= margin:
                    verdict = UNDECIDED
            state[q, r] = verdict
            if verdict == HIT:
                break  # the posture's answer is this pair (or an earlier one)
    return state


class TriangleSet:
    """A role mesh's triangles in a BVH, and the size of its smallest piece.

    Parameters
    ----------
    vertices : (v, 3) float64
    faces : (f, 3) int

    Attributes
    ----------
    bvh : TriangleBVH
    piece : (t,) int64
        Connected piece of each triangle (BVH leaf order).
    piece_lo, piece_hi : (c, 3) float64
        Bounding box of each piece, mm.
    smallest_component : float
        Smallest bounding-box diagonal of a piece, mm.
    piece_points, piece_diagonals : (p, 3), (p,) float64
        One vertex of every piece and its bounding-box diagonal, mm.
    """

    def __init__(self, vertices: NDArray[np.float64], faces: NDArray[np.int64]) -> None:
        self.bvh = TriangleBVH(np.asarray(vertices, dtype=np.float64)[faces])
        label, self.piece_lo, self.piece_hi = _pieces(vertices, faces)
        self.piece = np.ascontiguousarray(label[self.bvh.order])  # per leaf-order triangle
        diagonal = np.linalg.norm(self.piece_hi - self.piece_lo, axis=1)
        self.smallest_component = float(diagonal.min())
        present, first = np.unique(label, return_index=True)
        #: one vertex ``(p, 3)`` of every piece and the piece's diagonal ``(p,)``, mm
        self.piece_points = np.asarray(vertices, dtype=np.float64)[faces[first, 0]]
        self.piece_diagonals = diagonal[present]

    def distances(self, points: NDArray[np.float64], reach: float) -> NDArray[np.float64]:
        """Exact ``(k,)`` distances of points ``(k, 3)`` to the triangles (inf beyond reach)."""
        return self.bvh.distances(points, reach)


def _pieces(
    vertices: NDArray[np.float64], faces: NDArray[np.int64]
) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]:
    """Connected pieces of a triangle set: label per face, bounding box per piece.

    Vertices at the same position are merged first, so a triangle soup (STL)
    is connected where its triangles meet.
    """
    vertices, inverse = np.unique(vertices, axis=0, return_inverse=True)
    faces = inverse.reshape(-1)[faces]
    n = len(vertices)
    edges = np.vstack([faces[:, [0, 1]], faces[:, [1, 2]]])
    graph = coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    used = np.unique(faces)
    lo = np.full((label.max() + 1, 3), np.inf)
    hi = np.full((label.max() + 1, 3), -np.inf)
    np.minimum.at(lo, label[used], vertices[used])
    np.maximum.at(hi, label[used], vertices[used])
    return label[faces[:, 0]].astype(np.int64), lo, hi


@dataclass
class SceneArrays:
    """Everything the kernel needs about a scene, in flat arrays.

    The roles' triangle BVHs are concatenated into one forest (``roots[r]`` is
    role ``r``'s root node; triangle and piece indices are global); the roles'
    grids are stacked (``role_fine[r]``, ``role_coarse[r]``, all on one frame).
    """

    whole: DistanceGrid
    role_fine: NDArray[np.float32]
    role_coarse: NDArray[np.float32]
    role_lo: NDArray[np.float64]
    role_hi: NDArray[np.float64]
    masks: NDArray[np.int64]
    mask_limit: float
    forest: tuple[Any, ...]
    roots: NDArray[np.int64]
    piece: NDArray[np.int64]
    piece_lo: NDArray[np.float64]
    piece_hi: NDArray[np.float64]

    @classmethod
    def build(
        cls,
        grids: Sequence[DistanceGrid],
        whole: DistanceGrid,
        role_mask: RoleMask | None,
        sets: Sequence[TriangleSet],
    ) -> SceneArrays:
        """Stack the role grids (the grids then view the stack) and join the BVHs."""
        role_fine = np.stack([g.bounds for g in grids])
        for r, grid in enumerate(grids):
            grid.bounds = role_fine[r]  # share the memory
        role_coarse = np.stack([g.coarse for g in grids])
        masks: NDArray[np.int64] = np.zeros((1, 1, 1), dtype=np.int64)
        limit = -math.inf  # too many roles for the bit sets: every role, always
        if role_mask is not None:
            masks, limit = role_mask.masks, role_mask.limit
        tri_off = np.cumsum([0] + [len(t.piece) for t in sets])
        node_off = np.cumsum([0] + [len(t.bvh.arrays[4]) for t in sets])
        piece_off = np.cumsum([0] + [len(t.piece_lo) for t in sets])
        arrays = [t.bvh.arrays for t in sets]
        forest: list[Any] = [np.concatenate([a[k] for a in arrays]) for k in range(7)]
        pairs = list(zip(arrays, node_off[:-1], tri_off[:-1], strict=True))
        forest.append(np.concatenate([np.where(a[7] >= 0, a[7] + n, -1) for a, n, _ in pairs]))
        forest.append(np.concatenate([a[8] + t for a, _, t in pairs]))
        forest.append(np.concatenate([a[9] for a in arrays]))
        forest = [np.ascontiguousarray(f) for f in forest]
        for t, a, t0, t1, n0, n1 in zip(
            sets, arrays, tri_off[:-1], tri_off[1:], node_off[:-1], node_off[1:], strict=True
        ):
            # the roles' own trees view the forest's arrays (no second copy)
            t.bvh.arrays = (
                *(forest[k][t0:t1] for k in range(4)),
                *(forest[k][n0:n1] for k in range(4, 7)),
                *a[7:],
            )
            t.bvh.tris = t.bvh.arrays[0]
        return cls(
            whole,
            role_fine,
            role_coarse,
            np.array([g.box_lo for g in grids]),
            np.array([g.box_hi for g in grids]),
            masks,
            float(limit),
            tuple(forest),
            np.asarray(node_off[:-1], dtype=np.int64),
            np.concatenate([t.piece + off for t, off in zip(sets, piece_off[:-1], strict=True)]),
            np.concatenate([t.piece_lo for t in sets]),
            np.concatenate([t.piece_hi for t in sets]),
        )


def classify_part(
    scene: SceneArrays,
    tip: NDArray[np.float64],
    axis: NDArray[np.float64],
    heights: NDArray[np.float64],
    radii: NDArray[np.float64],
    inner: NDArray[np.float64],
    profile: NDArray[np.float64],
    profile_excess: float,
    role_on: NDArray[np.bool_],
    allow_hit: NDArray[np.bool_],
    *,
    margin: float,
    max_reach: float,
) -> NDArray[np.int8]:
    """Classify the pairs (posture, role) of one tool part: CLEAR, UNDECIDED or HIT.

    Parameters
    ----------
    scene : SceneArrays
    tip, axis : (n, 3) float64
        Postures (unit axes), mm.
    heights, radii : (m,) float64
        Covering spheres of the part mesh (axis heights above the tip, radii), mm.
    inner : (m,) float64
        Inscribed-ball radius of the true part at each sphere centre, mm.
    profile : (k, 2) float64
        Meridian polygon ``(r, z)`` of the part, axis to axis, that contains the
        true outline, mm.
    profile_excess : float
        Largest distance of ``profile`` outside the true outline, mm: a point
        inside the polygon deeper than this lies in the true part.
    role_on : (roles,) bool
        Roles the part is checked against (others stay CLEAR).
    allow_hit : (roles,) bool
        Every piece of the role is larger than the part (definite hits need no
        per-posture box test).
    margin : float
        Safety margin, mm.
    max_reach : float
        Spheres larger than this are left to fcl (their search would be slow), mm.

    Returns
    -------
    (n, roles) int8
        Per posture and role; after a HIT the later roles of the posture stay CLEAR.
    """
    whole = scene.whole
    args: list[Any] = [
        whole.bounds,
        whole.coarse,
        whole.box_lo,
        whole.box_hi,
        whole.origin,
        whole.spacing,
        whole.coarse_spacing,
        scene.role_fine,
        scene.role_coarse,
        scene.role_lo,
        scene.role_hi,
        scene.masks,
        scene.mask_limit,
        *scene.forest,
        scene.roots,
        scene.piece,
        scene.piece_lo,
        scene.piece_hi,
        np.ascontiguousarray(tip, dtype=np.float64),
        np.ascontiguousarray(axis, dtype=np.float64),
        np.ascontiguousarray(heights, dtype=np.float64),
        np.ascontiguousarray(radii, dtype=np.float64),
        np.ascontiguousarray(inner, dtype=np.float64),
        np.ascontiguousarray(profile, dtype=np.float64),
        float(profile_excess + margin),
        np.ascontiguousarray(role_on, dtype=np.bool_),
        np.ascontiguousarray(allow_hit, dtype=np.bool_),
        float(margin),
        float(max_reach),
    ]
    return np.asarray(_classify_part(*args))
