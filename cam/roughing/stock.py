"""The lathe-turned blank roughing plans against: the verification's blank.

The blank is the solid of revolution of ``geometry.blank.spec_blank_profile`` (M4: "a
cylindrical blank is first machined by lathe to form the outer profile of the shroud
surface"): the shroud contour offset outwards by the stock allowance, the inlet face,
the hub nose turned to its contour, the outer diameter turned to the blades' largest
radius plus the allowance and beyond it the hub contour plus the allowance out to the
rim, raised wherever the blades' faces and fillets need more to keep the allowance
(the design's true extent, issue 28). Verification
(``--stock SPEC``) simulates the same solid, so the planner's "is there material"
is the verifier's.

A ball of radius R centred at ``c`` meets the blank when the meridional point
``(r(c), c_z)`` lies inside the profile polygon or within R of its boundary: the
closest point of a solid of revolution to a point lies in the point's meridional
half-plane.
"""

from __future__ import annotations

import math

import numpy as np
import trimesh
from numba import njit
from numpy.typing import NDArray

from geometry.blank import spec_blank_profile
from geometry.surfaces import ImpellerSurfaces

__all__ = ["Blank"]

#: Cells of ``Blank.touches``'s screen along the profile's longer side.
SCREEN_CELLS = 256


@njit(cache=True, nogil=True)
def _edge_gap2(qr: float, qz: float, ar: float, az: float, dr: float, dz: float) -> float:
    """Squared distance of ``(qr, qz)`` to the segment from ``(ar, az)`` along
    ``(dr, dz)``, mm^2."""
    dd = max(dr * dr + dz * dz, 1e-300)
    rr, rz = qr - ar, qz - az
    t = min(max((rr * dr + rz * dz) / dd, 0.0), 1.0)
    gr, gz = rr - t * dr, rz - t * dz
    return gr * gr + gz * gz


@njit(cache=True, nogil=True)
def _inside(qr: float, qz: float, profile: NDArray[np.float64]) -> bool:
    """Even-odd rule: edges of the closed ``profile`` crossed by the ray from
    ``(qr, qz)`` towards +r."""
    crossings = 0
    for k in range(profile.shape[0] - 1):
        ar, az = profile[k, 0], profile[k, 1]
        br, bz = profile[k + 1, 0], profile[k + 1, 1]
        if (az > qz) != (bz > qz):
            if ar + (qz - az) * (br - ar) / (bz - az) > qr:
                crossings += 1
    return crossings % 2 == 1


@njit(cache=True, nogil=True)
def _nearest(qr: float, qz: float, profile: NDArray[np.float64], stop: float) -> float:
    """Distance of ``(qr, qz)`` to the closed ``profile``'s edges, mm; the first edge
    closer than ``stop`` ends the search (its distance, below ``stop``, is returned)."""
    best = np.inf
    for k in range(profile.shape[0] - 1):
        g = np.sqrt(_edge_gap2(qr, qz, profile[k, 0], profile[k, 1],
                               profile[k + 1, 0] - profile[k, 0],
                               profile[k + 1, 1] - profile[k, 1]))
        if g < stop:
            return g
        best = min(best, g)
    return best


@njit(cache=True, nogil=True)
def _profile_distance(points: NDArray[np.float64], profile: NDArray[np.float64]
                      ) -> NDArray[np.float64]:
    """Distance ``(n,)`` of points ``(n, 3)`` to the solid of revolution of the closed
    meridional polygon ``profile`` ``(k, 2)`` (r, z) about +Z, mm (0 inside)."""
    out = np.empty(points.shape[0])
    for i in range(points.shape[0]):
        qr, qz = np.hypot(points[i, 0], points[i, 1]), points[i, 2]
        out[i] = 0.0 if _inside(qr, qz, profile) else _nearest(qr, qz, profile, -np.inf)
    return out


@njit(cache=True, nogil=True)
def _cell_screen(profile: NDArray[np.float64], origin: NDArray[np.float64], size: float,
                 shape: tuple[int, int]) -> tuple[NDArray[np.bool_], NDArray[np.float64]]:
    """Per cell of a (r, z) grid (``origin`` its lowest corner, square cells of side
    ``size`` mm, ``shape`` cells): whether its centre lies inside the closed
    ``profile``, and a lower bound of the distance of every point of the cell to the
    profile's boundary (the centre's distance less the half diagonal and 1e-9 mm;
    negative where the boundary may cross the cell), mm."""
    inside = np.empty(shape, dtype=np.bool_)
    clear = np.empty(shape)
    half = 0.5 * math.sqrt(2.0) * size + 1e-9
    for i in range(shape[0]):
        for j in range(shape[1]):
            qr, qz = origin[0] + (i + 0.5) * size, origin[1] + (j + 0.5) * size
            inside[i, j] = _inside(qr, qz, profile)
            clear[i, j] = _nearest(qr, qz, profile, -np.inf) - half
    return inside, clear


@njit(cache=True, nogil=True)
def _profile_touches(points: NDArray[np.float64], profile: NDArray[np.float64],
                     radius: float, origin: NDArray[np.float64], size: float,
                     cell_inside: NDArray[np.bool_], cell_clear: NDArray[np.float64]
                     ) -> NDArray[np.bool_]:
    """``_profile_distance(points) < radius`` (``<= 0`` for ``radius`` 0) without
    computing every distance: the bounding box, then the point's cell of the screen
    (``_cell_screen``: a cell whose every point lies farther than ``radius`` from the
    boundary answers with its centre's side), then the first edge closer than
    ``radius``, decide."""
    out = np.empty(points.shape[0], dtype=np.bool_)
    rmin, rmax = profile[:, 0].min(), profile[:, 0].max()
    zmin, zmax = profile[:, 1].min(), profile[:, 1].max()
    far = max(radius, 0.0) + 1e-9  # a bounding-box gap beyond this decides "no"
    ni, nj = cell_clear.shape
    for i in range(points.shape[0]):
        qr, qz = np.hypot(points[i, 0], points[i, 1]), points[i, 2]
        if qr - rmax > far or rmin - qr > far or qz - zmax > far or zmin - qz > far:
            out[i] = False
            continue
        ci = int(math.floor((qr - origin[0]) / size))
        cj = int(math.floor((qz - origin[1]) / size))
        if 0 <= ci < ni and 0 <= cj < nj and cell_clear[ci, cj] > far:
            out[i] = cell_inside[ci, cj]
        elif radius > 0.0:
            out[i] = _nearest(qr, qz, profile, radius) < radius or _inside(qr, qz, profile)
        else:
            out[i] = _inside(qr, qz, profile) or _nearest(qr, qz, profile, 0.0) <= 0.0
    return out


class Blank:
    """The roughing blank of an impeller (see module docstring).

    Attributes
    ----------
    profile : (k, 2) float64
        Closed meridional polygon (r, z), mm (first point repeated at the end).
    z_top, r_out : float
        Highest z and largest r of the blank, mm.
    """

    def __init__(self, surfaces: ImpellerSurfaces) -> None:
        self._take(spec_blank_profile(surfaces.spec, surfaces))

    @classmethod
    def of_profile(cls, profile: NDArray[np.float64]) -> Blank:
        """The blank of a meridional polygon ``(k, 2)`` (r, z), mm (closed here when
        its last point is not its first)."""
        blank = object.__new__(cls)
        blank._take(np.asarray(profile, dtype=np.float64))
        return blank

    def _take(self, profile: NDArray[np.float64]) -> None:
        if np.linalg.norm(profile[0] - profile[-1]) > 1e-9:
            profile = np.vstack([profile, profile[:1]])
        self.profile = np.ascontiguousarray(profile)
        self.z_top = float(profile[:, 1].max())
        self.r_out = float(profile[:, 0].max())
        # the cell screen of ``touches`` (``_cell_screen``): SCREEN_CELLS cells along
        # the profile's longer side
        lo, hi = profile.min(axis=0), profile.max(axis=0)
        self._cell = float(max(hi - lo)) / SCREEN_CELLS
        self._origin = np.ascontiguousarray(lo - self._cell)
        shape = tuple(int(n) for n in np.ceil((hi - lo) / self._cell).astype(np.int64) + 2)
        self._cell_inside, self._cell_clear = _cell_screen(
            self.profile, self._origin, self._cell, (shape[0], shape[1]))

    def distance(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        """Distance ``(n,)`` of W points ``(n, 3)`` to the blank, mm (0 inside)."""
        p = np.ascontiguousarray(np.asarray(points, dtype=np.float64).reshape(-1, 3))
        return _profile_distance(p, self.profile)

    def touches(self, centres: NDArray[np.float64], radius: float) -> NDArray[np.bool_]:
        """True where a ball of ``radius`` at ``centres`` ``(..., 3)`` meets the blank
        (its centre inside, or within ``radius`` of the boundary)."""
        c = np.asarray(centres, dtype=np.float64)
        flat = np.ascontiguousarray(c.reshape(-1, 3))
        hit = _profile_touches(flat, self.profile, float(radius), self._origin, self._cell,
                               self._cell_inside, self._cell_clear)
        return np.asarray(hit.reshape(c.shape[:-1]))

    def closed_mesh(self, sections: int = 180) -> trimesh.Trimesh:
        """The blank's closed boundary: the profile turned about +Z in ``sections``
        steps, mm. Seen along any axis from the spindle side, the first point of it
        met from outside is the blank's boundary (``ZMap``'s top ``T``; the frames'
        safe heights clear it)."""
        from cam.finishing.scene import grid_mesh

        phi = np.linspace(0.0, 2.0 * math.pi, sections + 1)
        r, z = self.profile[:, 0], self.profile[:, 1]
        grid = np.stack([r[:, None] * np.cos(phi), r[:, None] * np.sin(phi),
                         np.broadcast_to(z[:, None], (len(z), len(phi)))], axis=-1)
        return grid_mesh(grid)
