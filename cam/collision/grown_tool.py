"""The shank and holder grown by a clearance cap: a cheap proof of clearance >= cap.

``CollisionScene`` reports shank+holder clearances exactly up to a cap and as a lower
bound (>= cap) above it. Before an ``fcl.distance`` (about 1 ms against an impeller),
one ``fcl.collide`` (about 0.03 ms) of the shank and holder grown by the cap
(``tool_mesh.grown_profile``, sections circumscribed like the tool's) settles most
postures: a miss proves the clearance is at least the cap. fcl meshes only meet where
surfaces cross, so a scene piece small enough to lie wholly inside the grown tool is
tested by one of its vertices and, if inside, left to the distance.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import fcl
import numpy as np
from numpy.typing import NDArray

from cam.collision.exact_phase import TriangleSet
from cam.collision.tool_mesh import PartGeometry, bvh_model, concatenate, grown_profile, revolve

__all__ = ["GrownTool"]


@dataclass
class GrownTool:
    """Shank and holder grown by ``cap`` mm.

    Attributes
    ----------
    object : fcl.CollisionObject
        The grown meshes in the tool frame (tip at the origin, axis +Z).
    outlines : list of (k, 2) float64
        ``(r, z)`` outlines as meshed (radii times the sections' circumscription).
    pieces : (p, 3) float64
        One vertex of every scene piece no larger than the grown tool, mm.
    """

    object: fcl.CollisionObject
    outlines: list[NDArray[np.float64]]
    pieces: NDArray[np.float64]

    @classmethod
    def build(cls, body: list[PartGeometry], cap: float, sections: int,
              scene: list[TriangleSet]) -> GrownTool:
        """Grow ``body`` (shank, holder) by ``cap`` against the scene's pieces."""
        outlines = [grown_profile(p.profile, cap) for p in body]
        mesh = concatenate([revolve(o, sections) for o in outlines])
        scale = 1.0 / math.cos(math.pi / sections)
        size = float(np.linalg.norm(np.ptp(mesh.vertices, axis=0)))
        pieces = np.concatenate([t.piece_points[t.piece_diagonals <= size] for t in scene])
        return cls(fcl.CollisionObject(bvh_model(mesh.vertices, mesh.faces)),
                   [o[1:-1] * np.array([scale, 1.0]) for o in outlines], pieces)

    def misses(self, scene: fcl.CollisionObject, rot: NDArray[np.float64],
               tip: NDArray[np.float64], axis: NDArray[np.float64]) -> NDArray[np.bool_]:
        """``(n,) bool``: clearance proven >= cap at postures ``rot (n, 3, 3)``,
        ``tip, axis (n, 3)`` (the grown tool misses the merged ``scene`` and holds no
        small piece)."""
        touch = fcl.CollisionRequest()
        near = np.zeros(len(tip), dtype=bool)
        for i in range(len(tip)):
            self.object.setTransform(fcl.Transform(rot[i], tip[i]))
            near[i] = fcl.collide(self.object, scene, touch, fcl.CollisionResult()) > 0
        missed = np.flatnonzero(~near)
        near[missed] = self.holds_piece(tip[missed], axis[missed])
        return ~near

    def holds_piece(self, tip: NDArray[np.float64], axis: NDArray[np.float64]
                    ) -> NDArray[np.bool_]:
        """``(n,) bool``: a small scene piece's vertex lies inside the grown tool (the
        piece may lie wholly inside it, no surface crossing)."""
        inside = np.zeros(len(tip), dtype=bool)
        if not len(self.pieces) or not len(tip):
            return inside
        chunk = max(1, 1_000_000 // len(self.pieces))  # postures x points per block
        for a in range(0, len(tip), chunk):
            rel = self.pieces[None, :, :] - tip[a:a + chunk, None, :]
            ax = axis[a:a + chunk]
            height = np.einsum("npk,nk->np", rel, ax)
            radial = np.linalg.norm(rel - height[..., None] * ax[:, None, :], axis=-1)
            for outline in self.outlines:
                r, z = outline[:, 0], outline[:, 1]
                within = (height >= z[0]) & (height <= z[-1])
                inside[a:a + chunk] |= (within & (radial <= np.interp(height, z, r))).any(axis=1)
        return inside
