"""Exact Euclidean distance transform of a 3-D grid (numba), for the distance grids.

``distance_transform(marked, spacing)`` gives every node the distance to the
nearest node that is not marked, like ``scipy.ndimage.distance_transform_edt``
(which the distance grids used before; it also builds the three int32 feature
arrays that the grids never read). Method: the separable transform of
Felzenszwalb and Huttenlocher ("Distance transforms of sampled functions", 2012):
squared distances along z by two sweeps, then along y and x the lower envelope of
the parabolas ``f(v) + (q - v)^2``. Everything is integer-valued in float64 (exact
up to 2^53), so the squared node distance is exact; the result is
``sqrt(d2) * spacing``. With ``spacing`` 1 (the collision scenes' default) that is
bit for bit scipy's value (``sqrt`` of the same integer); otherwise it differs from
scipy's ``sqrt(sum((d_i spacing)^2))`` by rounding only.
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray

__all__ = ["distance_transform"]


@numba.njit(cache=True, nogil=True)
def _envelope(f: NDArray[np.float64], out: NDArray[np.float64], v: NDArray[np.int64],
              z: NDArray[np.float64]) -> None:  # pragma: no cover - compiled
    """``out[q] = min_v f[v] + (q - v)^2`` (inf where every ``f`` is inf)."""
    n = f.shape[0]
    k = -1
    for q in range(n):
        fq = f[q]
        if fq == np.inf:
            continue
        s = -np.inf
        while k >= 0:
            vk = v[k]
            s = ((fq + q * q) - (f[vk] + vk * vk)) / (2.0 * (q - vk))
            if s <= z[k]:
                k -= 1
                s = -np.inf
            else:
                break
        k += 1
        v[k] = q
        z[k] = s
        z[k + 1] = np.inf
    if k < 0:
        for q in range(n):
            out[q] = np.inf
        return
    j = 0
    for q in range(n):
        while z[j + 1] < q:
            j += 1
        d = q - v[j]
        out[q] = d * d + f[v[j]]


@numba.njit(cache=True, nogil=True)
def _squared(marked: NDArray[np.bool_]) -> NDArray[np.float64]:  # pragma: no cover - compiled
    nx, ny, nz = marked.shape
    d2 = np.empty((nx, ny, nz))
    # along z: squared distance to the nearest unmarked node of the line
    for i in range(nx):
        for j in range(ny):
            last = -1
            for k in range(nz):
                if not marked[i, j, k]:
                    last = k
                d2[i, j, k] = np.inf if last < 0 else float((k - last) * (k - last))
            last = -1
            for k in range(nz - 1, -1, -1):
                if not marked[i, j, k]:
                    last = k
                if last >= 0:
                    e = float((last - k) * (last - k))
                    if e < d2[i, j, k]:
                        d2[i, j, k] = e
    size = max(nx, ny)
    f = np.empty(size)
    out = np.empty(size)
    v = np.empty(size, dtype=np.int64)
    z = np.empty(size + 1)
    for i in range(nx):  # along y
        for k in range(nz):
            for j in range(ny):
                f[j] = d2[i, j, k]
            _envelope(f[:ny], out[:ny], v, z)
            for j in range(ny):
                d2[i, j, k] = out[j]
    plane = np.empty((nx, nz))  # one x-z plane, gathered row by row (contiguous reads)
    for j in range(ny):  # along x
        for i in range(nx):
            for k in range(nz):
                plane[i, k] = d2[i, j, k]
        for k in range(nz):
            for i in range(nx):
                f[i] = plane[i, k]
            _envelope(f[:nx], out[:nx], v, z)
            for i in range(nx):
                plane[i, k] = out[i]
        for i in range(nx):
            for k in range(nz):
                d2[i, j, k] = plane[i, k]
    return d2


def distance_transform(marked: NDArray[np.bool_], spacing: float) -> NDArray[np.float64]:
    """Distance of every node to the nearest node that is not marked, mm.

    Parameters
    ----------
    marked : (nx, ny, nz) bool
        True everywhere except at the feature nodes (at least one False).
    spacing : float
        Node spacing (the same along every axis), mm.

    Returns
    -------
    (nx, ny, nz) float64
        ``spacing * sqrt(d2)``, d2 the squared node distance (an integer).
    """
    grid = np.ascontiguousarray(marked, dtype=np.bool_)
    if grid.ndim != 3:
        raise ValueError("distance_transform needs a 3-D grid")
    if grid.all():
        raise ValueError("distance_transform needs at least one unmarked node")
    distance = np.sqrt(_squared(grid))
    if spacing != 1.0:
        distance *= float(spacing)
    return distance

