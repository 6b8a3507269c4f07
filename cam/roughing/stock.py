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
from numpy.typing import NDArray

from geometry.blank import spec_blank_profile
from geometry.surfaces import ImpellerSurfaces

__all__ = ["Blank"]

#: Point-edge pairs tested at a time (memory: a few arrays of this many floats).
PAIRS = 2_000_000


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
        profile = spec_blank_profile(surfaces.spec, surfaces)
        if np.linalg.norm(profile[0] - profile[-1]) > 1e-9:
            profile = np.vstack([profile, profile[:1]])
        self.profile = profile
        self.z_top = float(profile[:, 1].max())
        self.r_out = float(profile[:, 0].max())

    def distance(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        """Distance ``(n,)`` of W points ``(n, 3)`` to the blank, mm (0 inside)."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        rz = np.column_stack([np.hypot(p[:, 0], p[:, 1]), p[:, 2]])
        out = np.empty(len(rz))
        a, b = self.profile[:-1], self.profile[1:]
        d = b - a
        dd = np.maximum(np.einsum("ij,ij->i", d, d), 1e-300)
        chunk = max(1, PAIRS // len(a))
        for lo in range(0, len(rz), chunk):
            q = rz[lo:lo + chunk]
            rel = q[:, None, :] - a[None]
            t = np.clip(np.einsum("nkj,kj->nk", rel, d) / dd, 0.0, 1.0)
            gap = rel - t[..., None] * d[None]
            near = np.sqrt(np.einsum("nkj,nkj->nk", gap, gap).min(axis=1))
            # even-odd rule: edges crossed by the ray from q towards +r
            straddle = (a[None, :, 1] > q[:, None, 1]) != (b[None, :, 1] > q[:, None, 1])
            with np.errstate(divide="ignore", invalid="ignore"):
                cross = a[None, :, 0] + (q[:, None, 1] - a[None, :, 1]) * d[None, :, 0] / d[
                    None, :, 1]
            inside = (np.count_nonzero(straddle & (cross > q[:, None, 0]), axis=1) % 2) == 1
            out[lo:lo + chunk] = np.where(inside, 0.0, near)
        return out

    def touches(self, centres: NDArray[np.float64], radius: float) -> NDArray[np.bool_]:
        """True where a ball of ``radius`` at ``centres`` ``(..., 3)`` meets the blank
        (its centre inside, or within ``radius`` of the boundary)."""
        c = np.asarray(centres, dtype=np.float64)
        d = self.distance(c.reshape(-1, 3))
        hit = d < radius if radius > 0.0 else d <= 0.0
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
