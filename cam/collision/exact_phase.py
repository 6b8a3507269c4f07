"""Exact sphere-against-mesh tests in numba: the second stage of the broad phase.

For a sphere of a tool part's cover (centre ``c``, radius ``rho``) that the
role's distance grid could not clear, the exact distance ``d`` from ``c`` to the
role's triangles within ``rho + m`` is computed (``triangle_bvh``). Then

* ``d > rho + m``: the sphere, hence this slab of the part mesh, is clear;
* ``d < r_in - m``: a point of the surface lies strictly inside the inscribed
  ball of radius ``r_in`` of the *true* part at that axis point, which lies
  inside the part mesh. If the connected piece of the role mesh holding that
  point also has points outside the part mesh, the two surfaces cross and fcl
  must report contact (a *definite hit*). Sufficient for that: every piece of the
  role is larger (bounding-box diagonal) than the part mesh, or the piece's
  bounding box is not inside the box around this posture's covering spheres;
* otherwise fcl decides.

``m`` is the broad-phase margin; a part/role pair is clear when every sphere is.
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from cam.collision.distance_grid import DistanceGrid, point_lower_bound
from cam.collision.triangle_bvh import TriangleBVH, nearest_within

CLEAR, UNDECIDED, HIT = 0, 1, 2


@numba.njit(cache=True, nogil=True)
def _classify(
    bounds: NDArray[np.float32],
    g_origin: NDArray[np.float64],
    g_spacing: float,
    box_lo: NDArray[np.float64],
    box_hi: NDArray[np.float64],
    tris: NDArray[np.float64],
    tri_centre: NDArray[np.float64],
    tri_radius: NDArray[np.float64],
    node_lo: NDArray[np.float64],
    node_hi: NDArray[np.float64],
    left: NDArray[np.int64],
    first: NDArray[np.int64],
    size: NDArray[np.int64],
    piece: NDArray[np.int64],
    piece_lo: NDArray[np.float64],
    piece_hi: NDArray[np.float64],
    tip: NDArray[np.float64],
    axis: NDArray[np.float64],
    heights: NDArray[np.float64],
    radii: NDArray[np.float64],
    inner: NDArray[np.float64],
    margin: float,
    allow_hit: bool,
    max_reach: float,
) -> NDArray[np.int8]:  # pragma: no cover - compiled
    n = tip.shape[0]
    m = heights.shape[0]
    state = np.zeros(n, dtype=np.int8)
    centre = np.empty((m, 3))
    gap = np.empty(m)
    box_lo_q = np.empty(3)
    box_hi_q = np.empty(3)
    for q in range(n):
        box_lo_q[:] = np.inf
        box_hi_q[:] = -np.inf
        for s in range(m):
            h = heights[s]
            for a in range(3):
                centre[s, a] = tip[q, a] + h * axis[q, a]
                box_lo_q[a] = min(box_lo_q[a], centre[s, a] - radii[s])
                box_hi_q[a] = max(box_hi_q[a], centre[s, a] + radii[s])
            gap[s] = point_lower_bound(
                bounds, g_origin, g_spacing, box_lo, box_hi, centre[s, 0], centre[s, 1],
                centre[s, 2],
            ) - radii[s]
        if gap.min() > margin:
            continue  # every sphere clears the grid bound: clear
        # deepest spheres first: a definite hit, if any, is found with least work
        for s in np.argsort(gap):
            if gap[s] > margin:
                break  # this and all further spheres are clear
            rho = radii[s]
            lower = gap[s] + rho
            hit_below = inner[s] - margin
            if state[q] == UNDECIDED:
                # already undecided: only a definite hit can still change the answer
                if lower >= hit_below:
                    continue
                reach = hit_below
            else:
                reach = rho + 2.0 * margin
                if reach > max_reach:
                    state[q] = UNDECIDED
                    continue
            d, t = nearest_within(
                centre[s, 0], centre[s, 1], centre[s, 2], reach, hit_below, tris, tri_centre,
                tri_radius, node_lo, node_hi, left, first, size,
            )
            if d < hit_below:
                # the surface piece of triangle t enters the true part; it also
                # leaves the part mesh if it is larger than the part (allow_hit)
                # or sticks out of the box around this posture's spheres
                c = piece[t]
                outside = False
                for a in range(3):
                    if piece_lo[c, a] < box_lo_q[a] or piece_hi[c, a] > box_hi_q[a]:
                        outside = True
                if allow_hit or outside:
                    state[q] = HIT
                    break
            if d - rho <= margin:
                state[q] = UNDECIDED
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
    """

    def __init__(self, vertices: NDArray[np.float64], faces: NDArray[np.int64]) -> None:
        self.bvh = TriangleBVH(np.asarray(vertices, dtype=np.float64)[faces])
        label, self.piece_lo, self.piece_hi = _pieces(vertices, faces)
        self.piece = np.ascontiguousarray(label[self.bvh.order])  # per leaf-order triangle
        diagonal = np.linalg.norm(self.piece_hi - self.piece_lo, axis=1)
        self.smallest_component = float(diagonal.min())

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


def classify_spheres(
    grid: DistanceGrid,
    triangles: TriangleSet,
    tip: NDArray[np.float64],
    axis: NDArray[np.float64],
    heights: NDArray[np.float64],
    radii: NDArray[np.float64],
    inner: NDArray[np.float64],
    *,
    margin: float,
    allow_hit: bool,
    max_reach: float,
) -> NDArray[np.int8]:
    """Classify part/role pairs per posture: CLEAR (0), UNDECIDED (1) or HIT (2).

    Parameters
    ----------
    grid : DistanceGrid
        The role's distance grid (first, cheap test of each sphere).
    triangles : TriangleSet
        The role's triangles.
    tip, axis : (n, 3) float64
    heights, radii : (m,) float64
        Covering spheres of the part mesh.
    inner : (m,) float64
        Inscribed-ball radius of the true part at each sphere centre, mm.
    margin : float
        Safety margin, mm.
    allow_hit : bool
        Every piece of the role is larger than the part (definite hits need no
        per-posture box test).
    max_reach : float
        Spheres larger than this are left to fcl (their search would be slow), mm.

    Returns
    -------
    (n,) int8
    """
    return np.asarray(
        _classify(
            grid.bounds,
            grid.origin,
            grid.spacing,
            grid.box_lo,
            grid.box_hi,
            *triangles.bvh.arrays,
            triangles.piece,
            triangles.piece_lo,
            triangles.piece_hi,
            np.ascontiguousarray(tip, dtype=np.float64),
            np.ascontiguousarray(axis, dtype=np.float64),
            np.ascontiguousarray(heights, dtype=np.float64),
            np.ascontiguousarray(radii, dtype=np.float64),
            np.ascontiguousarray(inner, dtype=np.float64),
            float(margin),
            bool(allow_hit),
            float(max_reach),
        )
    )
