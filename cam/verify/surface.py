"""A triangle surface of the stock for rendering: voxel fill fractions + marching cubes.

Method: the Z dexel grid is binned into voxels of ``block`` x ``block`` rays and
height ``block * h``; each voxel gets the fraction of its volume covered by material
(exact along Z, averaged over the rays of the block). Marching cubes at the 0.5
level (VTK's ``contour`` through pyvista) turns the fraction field into a closed
triangle surface. Its accuracy is about one voxel (``block * h``) and it is only
used for pictures; volumes and deviations come from the dexels themselves.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from cam.verify.dexel import DexelGrid

#: Largest voxel count along any side of the render grid.
MAX_VOXELS = 160


@njit(cache=True)
def _fill(lo, hi, start, count, shape, block, z0, hz, nz):  # type: ignore[no-untyped-def]
    nbi = (shape[0] + block - 1) // block
    nbj = (shape[1] + block - 1) // block
    out = np.zeros((nbi + 2, nbj + 2, nz + 2), np.float32)
    weight = 1.0 / (block * block)
    nj = shape[1]
    for r in range(count.shape[0]):
        bi = (r // nj) // block + 1
        bj = (r % nj) // block + 1
        for m in range(count[r]):
            a = (lo[start[r] + m] - z0) / hz
            b = (hi[start[r] + m] - z0) / hz
            ka = max(0, int(math.floor(a)))
            kb = min(nz - 1, int(math.floor(b)))
            for kz in range(ka, kb + 1):
                cover = min(b, kz + 1.0) - max(a, float(kz))
                if cover > 0:
                    out[bi, bj, kz + 1] += weight * cover
    return out


def stock_surface(
    grid: DexelGrid, lower_z: float, upper_z: float, max_voxels: int = MAX_VOXELS
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Closed triangle surface of the material in a Z dexel grid.

    Parameters
    ----------
    grid : DexelGrid
        The stock's Z grid (``k == 2``).
    lower_z, upper_z : float
        Z range of the stock, mm.
    max_voxels : int
        Cap on voxels per side (sets the block size).

    Returns
    -------
    vertices : (v, 3) float64
    faces : (f, 3) int64
    """
    import pyvista as pv

    if grid.k != 2:
        raise ValueError(f"stock_surface needs the Z grid, not grid {grid.k}")
    h = grid.pitch
    span = max(int(grid.shape[0]), int(grid.shape[1]), int(math.ceil((upper_z - lower_z) / h)))
    block = max(1, int(math.ceil(span / max_voxels)))
    hz = block * h
    nz = max(1, int(math.ceil((upper_z - lower_z) / hz)))
    field = _fill(grid.lo, grid.hi, grid.start, grid.count, grid.shape, block, lower_z, hz, nz)
    image = pv.ImageData(
        dimensions=field.shape,
        spacing=(hz, hz, hz),
        # voxel centres; index 0 is a padding layer so the surface closes
        origin=(grid.origin[0] - 0.5 * hz, grid.origin[1] - 0.5 * hz, lower_z - 0.5 * hz),
    )
    image.point_data["fill"] = field.ravel(order="F")
    surface = image.contour([0.5], scalars="fill").triangulate()
    if surface.n_points == 0:
        return np.zeros((0, 3)), np.zeros((0, 3), np.int64)
    faces = np.asarray(surface.faces).reshape(-1, 4)[:, 1:].astype(np.int64)
    return np.asarray(surface.points, dtype=np.float64), faces
