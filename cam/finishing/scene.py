"""Collision meshes for the finishing checks.

``solid_meshes`` takes the meshes of the built impeller solid per face role (hub,
pressure, suction, fillet, leading/trailing edge, shroud, back, ...): the same
geometry the STL export writes. ``surface_meshes`` triangulates the closed-form
surfaces directly (blade sides, tip, edges and hub, no fillets): an approximation
for quick studies and for impellers whose solid cannot be built; every finishing
result names the scene it was checked against.
"""

from __future__ import annotations

import math

import numpy as np
import trimesh
from numpy.typing import NDArray

from geometry.surfaces import ImpellerSurfaces

__all__ = ["grid_mesh", "solid_meshes", "surface_meshes"]

#: Roles of the solid that the finishing tool must not touch (all of them).
SOLID_ROLES_SKIPPED: tuple[str, ...] = ()


def grid_mesh(points: NDArray[np.float64]) -> trimesh.Trimesh:
    """Triangulate an ``(nu, nv, 3)`` grid of points into a surface mesh."""
    nu, nv, _ = points.shape
    index = np.arange(nu * nv).reshape(nu, nv)
    a, b = index[:-1, :-1].ravel(), index[1:, :-1].ravel()
    c, d = index[1:, 1:].ravel(), index[:-1, 1:].ravel()
    faces = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
    return trimesh.Trimesh(points.reshape(-1, 3), faces, process=False)


def surface_meshes(surfaces: ImpellerSurfaces, spacing: float = 0.5,
                   below_hub: float = 0.1, chordal: float = 0.005
                   ) -> dict[str, trimesh.Trimesh]:
    """Meshes of the closed-form surfaces by role, mm.

    Blade sides run from the tip (v = 0) to ``1 + below_hub`` (into the hub),
    closed by the tip strip and the leading/trailing edge strips; the hub is the
    revolved contour over the full turn.

    Parameters
    ----------
    spacing : float
        Target grid spacing along the blades and the hub contour, mm (the chordal
        error of these gently curved surfaces is far below it).
    chordal : float
        Largest chordal error of the hub sections around the axis, mm.
    """
    blades = surfaces.all_blades()
    hub = surfaces.hub
    r_max = float(hub.contour[:, 1].max())
    parts: dict[str, list[trimesh.Trimesh]] = {
        "hub": [], "pressure": [], "suction": [], "tip": [], "edges": []}
    for blade in blades:
        chord = float(np.linalg.norm(np.diff(blade.camber(np.linspace(0, 1, 64), 1.0),
                                             axis=0), axis=1).sum())
        height = float(np.linalg.norm(blade.camber(0.5, 0.0) - blade.camber(0.5, 1.0)))
        nu = max(int(math.ceil(chord / spacing)), 8) + 1
        nv = max(int(math.ceil(height * (1 + below_hub) / spacing)), 4) + 1
        u, v = np.meshgrid(np.linspace(0, 1, nu), np.linspace(0, 1 + below_hub, nv),
                           indexing="ij")
        press, suct = blade.side(u, v, +1), blade.side(u, v, -1)
        parts["pressure"].append(grid_mesh(press))
        parts["suction"].append(grid_mesh(suct))
        parts["tip"].append(grid_mesh(np.stack([press[:, 0], suct[:, 0]], axis=1)))
        parts["edges"].append(grid_mesh(np.stack([press[0], suct[0]], axis=1)))
        parts["edges"].append(grid_mesh(np.stack([press[-1], suct[-1]], axis=1)))
    ns = max(int(math.ceil(hub.length / spacing)), 8) + 1
    # around the axis the hub is a circle: sections from the chordal error
    nphi = max(int(math.ceil(math.pi / math.acos(1.0 - chordal / r_max))), 64) + 1
    s, phi = np.meshgrid(np.linspace(0, 1, ns), np.linspace(0, 2 * math.pi, nphi),
                         indexing="ij")
    parts["hub"].append(grid_mesh(hub.point(s, phi)))
    out: dict[str, trimesh.Trimesh] = {}
    for role, meshes in parts.items():
        merged = trimesh.util.concatenate(meshes)
        assert isinstance(merged, trimesh.Trimesh)
        out[role] = merged
    return out


def solid_meshes(impeller: object, tolerance: float) -> dict[str, trimesh.Trimesh]:
    """Meshes of the built impeller solid by face role (``Impeller.mesh(role)``)."""
    from geometry.assembly import ROLES

    out = {}
    for role in ROLES:
        if role in SOLID_ROLES_SKIPPED:
            continue
        mesh = impeller.mesh(role, tolerance=tolerance)  # type: ignore[attr-defined]
        if len(mesh.faces):
            out[role] = mesh
    return out
