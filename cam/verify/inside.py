"""Inside test of points against a closed triangle mesh by ray parity (numba).

The sign of a closest-triangle distance (``cam.verify.deviation``) is only as good
as the orientation of the surface nearest to the point. Where a design surface folds
over itself (a rolling-ball fillet whose centre line curves tighter than its radius,
as at nine_blade's suction-side trailing-edge corner, ``fillet_fold_ratio`` 1.35 in
geometry.json, before ``geometry.fillet.trim_fold`` trimmed such folds; any mesh may
still carry one), the nearest sheet of the fold faces inwards and points out in the
air read as inside the part. A ray from the
point, on the other hand, crosses the folded sheets an even number of times more and
keeps the parity of the crossings of the real boundary.

``MeshParity.inside`` casts three rays from each point, along +X, +Y and +Z, and
takes the majority of the three parities. Each ray is tested against the triangles
whose projection bounds share its cell of a uniform grid in the plane across the
ray; the crossing test uses the same edge functions and top-left fill rule as the
stock's ray casting (``cam.verify.raycast``), so a ray through a shared edge or
vertex of a closed mesh counts exactly one crossing.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange
from numpy.typing import NDArray

from cam.verify.raycast import _edge, _top_left

__all__ = ["MeshParity"]

#: Cell size of the bucket grid as a multiple of the mean projected triangle size.
CELL_FACTOR = 2.0


@njit(cache=True)
def _cells(ti, tj, f, origin_i, origin_j, h, ni, nj):  # type: ignore[no-untyped-def]
    """Cell index range (i0, i1, j0, j1) of triangle f's projection bounds."""
    i0 = max(0, int((min(ti[f, 0], ti[f, 1], ti[f, 2]) - origin_i) / h))
    i1 = min(ni - 1, int((max(ti[f, 0], ti[f, 1], ti[f, 2]) - origin_i) / h))
    j0 = max(0, int((min(tj[f, 0], tj[f, 1], tj[f, 2]) - origin_j) / h))
    j1 = min(nj - 1, int((max(tj[f, 0], tj[f, 1], tj[f, 2]) - origin_j) / h))
    return i0, i1, j0, j1


@njit(cache=True)
def _bucket(ti, tj, origin_i, origin_j, h, ni, nj):  # type: ignore[no-untyped-def]
    """CSR lists (start, index) of the triangles whose projection bounds touch each cell."""
    start = np.zeros(ni * nj + 1, np.int64)
    for f in range(ti.shape[0]):
        i0, i1, j0, j1 = _cells(ti, tj, f, origin_i, origin_j, h, ni, nj)
        for a in range(i0, i1 + 1):
            for b in range(j0, j1 + 1):
                start[a * nj + b + 1] += 1
    for c in range(ni * nj):
        start[c + 1] += start[c]
    index = np.empty(start[ni * nj], np.int64)
    fill = start[:-1].copy()
    for f in range(ti.shape[0]):
        i0, i1, j0, j1 = _cells(ti, tj, f, origin_i, origin_j, h, ni, nj)
        for a in range(i0, i1 + 1):
            for b in range(j0, j1 + 1):
                index[fill[a * nj + b]] = f
                fill[a * nj + b] += 1
    return start, index


@njit(cache=True, parallel=True)
def _parity(ti, tj, tk, start, index, origin_i, origin_j, h, ni, nj,
            pi, pj, pk, out):  # type: ignore[no-untyped-def]
    """Parity (0/1) of the crossings of the ray from each point along +k (points split
    over the threads: each answer is its own)."""
    for p in prange(pi.shape[0]):
        a = int((pi[p] - origin_i) / h)
        b = int((pj[p] - origin_j) / h)
        if a < 0 or b < 0 or a >= ni or b >= nj:
            out[p] = 0
            continue
        crossings = 0
        px, py = pi[p], pj[p]
        for n in range(start[a * nj + b], start[a * nj + b + 1]):
            f = index[n]
            x0, y0, x1, y1, x2, y2 = ti[f, 0], tj[f, 0], ti[f, 1], tj[f, 1], ti[f, 2], tj[f, 2]
            k0, k1, k2 = tk[f, 0], tk[f, 1], tk[f, 2]
            area = (x1 - x0) * (y2 - y0) - (y1 - y0) * (x2 - x0)
            if area == 0.0:
                continue
            if area < 0.0:  # counter-clockwise in the plane across the ray
                x1, y1, x2, y2 = x2, y2, x1, y1
                k1, k2 = k2, k1
                area = -area
            w0 = _edge(x1, y1, x2, y2, px, py)
            if w0 < 0.0 or (w0 == 0.0 and not _top_left(x1, y1, x2, y2)):
                continue
            w1 = _edge(x2, y2, x0, y0, px, py)
            if w1 < 0.0 or (w1 == 0.0 and not _top_left(x2, y2, x0, y0)):
                continue
            w2 = _edge(x0, y0, x1, y1, px, py)
            if w2 < 0.0 or (w2 == 0.0 and not _top_left(x0, y0, x1, y1)):
                continue
            if (w0 * k0 + w1 * k1 + w2 * k2) / area > pk[p]:
                crossings += 1
        out[p] = crossings & 1


class MeshParity:
    """Ray-parity inside test against a closed triangle mesh.

    Parameters
    ----------
    triangles : (m, 3, 3) float64
        Triangles of a closed mesh, mm (orientation does not matter).
    """

    def __init__(self, triangles: NDArray[np.float64]) -> None:
        self.triangles = np.ascontiguousarray(triangles, dtype=np.float64)
        self._grids: dict[int, tuple] = {}  # type: ignore[type-arg]

    def _grid(self, k: int) -> tuple:  # type: ignore[type-arg]
        if k not in self._grids:
            i, j = [a for a in range(3) if a != k]
            ti = np.ascontiguousarray(self.triangles[:, :, i])
            tj = np.ascontiguousarray(self.triangles[:, :, j])
            tk = np.ascontiguousarray(self.triangles[:, :, k])
            span = np.maximum(ti.max(axis=1) - ti.min(axis=1), tj.max(axis=1) - tj.min(axis=1))
            h = max(float(CELL_FACTOR * span.mean()), 1e-6)
            lo_i, lo_j = float(ti.min()), float(tj.min())
            ni = int((ti.max() - lo_i) / h) + 1
            nj = int((tj.max() - lo_j) / h) + 1
            start, index = _bucket(ti, tj, lo_i, lo_j, h, ni, nj)
            self._grids[k] = (ti, tj, tk, start, index, lo_i, lo_j, h, ni, nj)
        return self._grids[k]

    def parity(self, points: NDArray[np.float64], k: int) -> NDArray[np.int64]:
        """Parity (n,) of the crossings of the rays from ``points`` (n, 3) along +axis k."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        ti, tj, tk, start, index, lo_i, lo_j, h, ni, nj = self._grid(k)
        i, j = [a for a in range(3) if a != k]
        out = np.zeros(len(p), np.int64)
        _parity(ti, tj, tk, start, index, lo_i, lo_j, h, ni, nj,
                np.ascontiguousarray(p[:, i]), np.ascontiguousarray(p[:, j]),
                np.ascontiguousarray(p[:, k]), out)
        return out

    def inside(self, points: NDArray[np.float64]) -> NDArray[np.bool_]:
        """True (n,) where at least two of the rays along +X, +Y, +Z cross an odd
        number of times."""
        votes = sum(self.parity(points, k) for k in range(3))
        return np.asarray(votes >= 2)
