"""Cast a grid of axis-parallel rays through a closed triangle mesh (numba).

Used to turn any stock STL (and the revolved blank) into dexel intervals. A ray
along world axis ``k`` through the point ``(ci, cj)`` of the grid plane hits a
triangle when the point lies inside the triangle's projection; the inside test uses
edge functions computed in a canonical vertex order with the top-left fill rule, so
a ray through a shared edge or vertex of a closed mesh counts exactly one hit.
Sorted hits are paired (enter, leave) into material intervals.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray


@njit(cache=True)
def _edge(ax, ay, bx, by, px, py):  # type: ignore[no-untyped-def]
    """Edge function of ``p`` against edge a->b, computed in canonical vertex order."""
    if ax < bx or (ax == bx and ay < by):
        return (bx - ax) * (py - ay) - (by - ay) * (px - ax)
    return -((ax - bx) * (py - by) - (ay - by) * (px - bx))


@njit(cache=True)
def _top_left(ax, ay, bx, by):  # type: ignore[no-untyped-def]
    dy = by - ay
    dx = bx - ax
    return dy > 0.0 or (dy == 0.0 and dx < 0.0)


@njit(cache=True, inline="always")
def _row_span(ax, ay, bx, by, px, pad, ylo, yhi):  # type: ignore[no-untyped-def]
    """``(ylo, yhi)`` widened to the point(s) of edge a->b on the line ``x = px``
    (the nearer end for a line within ``pad`` beyond the edge's ends)."""
    if px < min(ax, bx) - pad or px > max(ax, bx) + pad:
        return ylo, yhi
    if ax == bx:
        return min(ylo, ay, by), max(yhi, ay, by)
    t = min(max((px - ax) / (bx - ax), 0.0), 1.0)
    y = ay + t * (by - ay)
    return min(ylo, y), max(yhi, y)


@njit(cache=True)
def _cast(pi, pj, pk, faces, origin, shape, h, count_only, counts, fill, t_out):  # type: ignore[no-untyped-def]
    nj = shape[1]
    for f in range(faces.shape[0]):
        v0, v1, v2 = faces[f, 0], faces[f, 1], faces[f, 2]
        x0, y0, x1, y1, x2, y2 = pi[v0], pj[v0], pi[v1], pj[v1], pi[v2], pj[v2]
        area = (x1 - x0) * (y2 - y0) - (y1 - y0) * (x2 - x0)
        if area == 0.0:
            continue
        if area < 0.0:  # orient counter-clockwise in the grid plane
            x1, y1, x2, y2 = x2, y2, x1, y1
            v1, v2 = v2, v1
            area = -area
        i0 = max(0, int(math.ceil((min(x0, x1, x2) - origin[0]) / h - 0.5)))
        i1 = min(shape[0] - 1, int(math.floor((max(x0, x1, x2) - origin[0]) / h - 0.5)))
        j0 = max(0, int(math.ceil((min(y0, y1, y2) - origin[1]) / h - 0.5)))
        j1 = min(nj - 1, int(math.floor((max(y0, y1, y2) - origin[1]) / h - 0.5)))
        tl0 = _top_left(x1, y1, x2, y2)
        tl1 = _top_left(x2, y2, x0, y0)
        tl2 = _top_left(x0, y0, x1, y1)
        # slack of the row spans: far above the rounding of the edge functions (a ray
        # outside the triangle by less than that could pass them), far below a pitch
        pad = 1e-6 + 1e-9 * (abs(x0) + abs(x1) + abs(x2) + abs(y0) + abs(y1) + abs(y2))
        for ii in range(i0, i1 + 1):
            px = origin[0] + (ii + 0.5) * h
            # the rays of this row the triangle can cover: its section by the row's
            # line, widened by pad (a sliver of a revolved blank spans a fraction of
            # its bounding box); the edge functions still decide every ray
            ylo, yhi = _row_span(x0, y0, x1, y1, px, pad, math.inf, -math.inf)
            ylo, yhi = _row_span(x1, y1, x2, y2, px, pad, ylo, yhi)
            ylo, yhi = _row_span(x2, y2, x0, y0, px, pad, ylo, yhi)
            if ylo > yhi:
                continue
            ja = max(j0, int(math.ceil((ylo - pad - origin[1]) / h - 0.5)))
            jb = min(j1, int(math.floor((yhi + pad - origin[1]) / h - 0.5)))
            for jj in range(ja, jb + 1):
                py = origin[1] + (jj + 0.5) * h
                w0 = _edge(x1, y1, x2, y2, px, py)
                if w0 < 0.0 or (w0 == 0.0 and not tl0):
                    continue
                w1 = _edge(x2, y2, x0, y0, px, py)
                if w1 < 0.0 or (w1 == 0.0 and not tl1):
                    continue
                w2 = _edge(x0, y0, x1, y1, px, py)
                if w2 < 0.0 or (w2 == 0.0 and not tl2):
                    continue
                r = ii * nj + jj
                if count_only:
                    counts[r] += 1
                else:
                    s = w0 + w1 + w2
                    t_out[fill[r]] = (w0 * pk[v0] + w1 * pk[v1] + w2 * pk[v2]) / s
                    fill[r] += 1


def cast_mesh(
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    k: int,
    origin: NDArray[np.float64],
    shape: tuple[int, int],
    pitch: float,
) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]:
    """Material intervals of a closed mesh along the rays of one grid.

    Parameters
    ----------
    vertices : (v, 3) float64
    faces : (f, 3) int64
    k : int
        Ray direction.
    origin : (2,) float64
        Grid corner on axes ``(k+1) % 3``, ``(k+2) % 3``.
    shape : (2,) int
    pitch : float

    Returns
    -------
    rays : (n,) int64
    lo, hi : (n,) float64
        Intervals sorted by ray and start. A ray with an odd number of hits (an open
        mesh) drops its last hit.
    """
    a, b = (k + 1) % 3, (k + 2) % 3
    pi = np.ascontiguousarray(vertices[:, a])
    pj = np.ascontiguousarray(vertices[:, b])
    pk = np.ascontiguousarray(vertices[:, k])
    faces = np.ascontiguousarray(faces, dtype=np.int64)
    shape_a = np.asarray(shape, dtype=np.int64)
    origin = np.asarray(origin, dtype=np.float64)
    n_rays = int(shape_a[0] * shape_a[1])
    counts = np.zeros(n_rays, np.int64)
    dummy = np.zeros(1, np.int64)
    _cast(pi, pj, pk, faces, origin, shape_a, pitch, True, counts, dummy, np.zeros(1))
    offsets = np.zeros(n_rays + 1, np.int64)
    offsets[1:] = np.cumsum(counts)
    fill = offsets[:-1].copy()
    hits = np.zeros(int(offsets[-1]))
    _cast(pi, pj, pk, faces, origin, shape_a, pitch, False, counts, fill, hits)
    rays, lo, hi = _pair_hits(hits, offsets)
    return rays, lo, hi


@njit(cache=True)
def _pair_hits(hits, offsets):  # type: ignore[no-untyped-def]
    """Sort each ray's hits (``hits[offsets[r]:offsets[r + 1]]``, in place) and pair
    them, the 1st with the 2nd, the 3rd with the 4th, ... (an odd last hit is dropped;
    empty pairs too). Returns the rays, starts and ends of the intervals.

    A stable insertion sort per ray (a ray has a few hits): the order and values of a
    stable sort of all hits by (ray, position), in one pass over the hits.
    """
    n_rays = offsets.shape[0] - 1
    rays = np.empty(hits.shape[0] // 2, np.int64)
    lo = np.empty(hits.shape[0] // 2)
    hi = np.empty(hits.shape[0] // 2)
    n = 0
    for r in range(n_rays):
        a = offsets[r]
        b = offsets[r + 1]
        for m in range(a + 1, b):
            x = hits[m]
            q = m
            while q > a and hits[q - 1] > x:
                hits[q] = hits[q - 1]
                q -= 1
            hits[q] = x
        for m in range(a, b - 1, 2):
            if hits[m + 1] > hits[m]:
                rays[n] = r
                lo[n] = hits[m]
                hi[n] = hits[m + 1]
                n += 1
    return rays[:n], lo[:n], hi[:n]
