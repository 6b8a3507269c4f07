"""The lathe-turned blank: the shroud envelope grown by the stock allowance.

The blank is the solid of revolution bounded by the shroud contour offset outwards by
``stock_allowance`` (M4: "a cylindrical blank is first machined by lathe to form the
outer profile of the shroud surface"), closed by the inlet face at
``z_top = max z(shroud) + allowance`` and the outer cylinder at
``r_out = max r(shroud, hub) + allowance`` (a hub rim and the blades' trailing edge at
the hub may reach beyond the shroud outlet; the verification blank,
``cam.verify.sources.blank_profile``, has the same outer radius). A ball of radius R
centred at ``c`` cuts material only if it meets the blank: ``d_blank(c) > -R`` with
``d_blank`` the signed distance to the offset shroud (positive inside),
``c_z - R < z_top`` and ``r(c) - R < r_out``.
"""

from __future__ import annotations

import math

import numpy as np
import trimesh
from numpy.typing import NDArray

from geometry.surfaces import ImpellerSurfaces

__all__ = ["Blank"]


class Blank:
    """The roughing blank of an impeller (see module docstring)."""

    def __init__(self, surfaces: ImpellerSurfaces) -> None:
        self.shroud = surfaces.shroud
        self.allowance = float(surfaces.spec.stock_allowance)
        contour = self.shroud.contour
        self.z_top = float(contour[:, 0].max()) + self.allowance
        hub_r = float(np.asarray(surfaces.spec.hub_contour)[:, 1].max())
        self.r_out = max(float(contour[:, 1].max()), hub_r) + self.allowance

    def touches(self, centres: NDArray[np.float64], radius: float) -> NDArray[np.bool_]:
        """True where a ball of ``radius`` at ``centres`` ``(..., 3)`` meets the blank."""
        c = np.asarray(centres, dtype=np.float64)
        flat = c.reshape(-1, 3)
        inside = self.shroud.signed_distance(flat) + self.allowance > -radius
        r = np.hypot(flat[:, 0], flat[:, 1])
        out = inside & (flat[:, 2] - radius < self.z_top) & (r - radius < self.r_out)
        return np.asarray(out.reshape(c.shape[:-1]))

    def mesh(self, sections: int = 180, samples: int = 60) -> trimesh.Trimesh:
        """Triangles of the blank's envelope (offset shroud and inlet face), mm."""
        s = np.linspace(0.0, 1.0, samples)
        zr = self.shroud.meridian(s) - self.allowance * self.shroud.meridian_normal(s)
        phi = np.linspace(0.0, 2.0 * math.pi, sections + 1)
        z = np.concatenate([[self.z_top, self.z_top], zr[:, 0]])
        r = np.concatenate([[0.0, zr[0, 1]], zr[:, 1]])
        grid = np.stack([r[:, None] * np.cos(phi), r[:, None] * np.sin(phi),
                         np.broadcast_to(z[:, None], (len(z), len(phi)))], axis=-1)
        from cam.finishing.scene import grid_mesh

        return grid_mesh(grid)

    def closed_mesh(self, z_bottom: float = 0.0, sections: int = 180,
                    samples: int = 60) -> trimesh.Trimesh:
        """``mesh`` plus the outer boundary below the offset shroud's outlet end.

        The offset shroud ends at the outlet below ``r_out``; the blank goes on out
        to ``r_out`` (an annulus at that height) and down the outer cylinder to
        ``z_bottom`` (the hub's back face, z = 0 in W): seen along any axis from the
        spindle side, the first point of this mesh met from outside is the blank's
        boundary (``ZMap``'s top ``T``; the frames' safe heights clear it).
        """
        from cam.finishing.scene import grid_mesh

        end = self.shroud.meridian(np.array([1.0])) - self.allowance * (
            self.shroud.meridian_normal(np.array([1.0])))
        z_end, r_end = float(end[0, 0]), float(end[0, 1])
        phi = np.linspace(0.0, 2.0 * math.pi, sections + 1)
        z = np.array([z_end, z_end, z_bottom])
        r = np.array([r_end, self.r_out, self.r_out])
        rim = np.stack([r[:, None] * np.cos(phi), r[:, None] * np.sin(phi),
                        np.broadcast_to(z[:, None], (len(z), len(phi)))], axis=-1)
        whole = trimesh.util.concatenate([self.mesh(sections, samples), grid_mesh(rim)])
        assert isinstance(whole, trimesh.Trimesh)
        return whole
