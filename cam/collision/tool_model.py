"""Everything a ``CollisionScene`` keeps about one tool: meshes, fcl objects, covers.

Built once per (tool, cutter offset) and cached by the scene (``CollisionScene.
tool_model``): the part meshes (``tool_mesh``), their fcl objects, the axis-sphere
covers of the broad phase with their inscribed radii, the convex pieces of the
exact distance kernel (``body_distance``), and the merged shank+holder (the
clearance body).
"""

from __future__ import annotations

from dataclasses import dataclass

import fcl
import numpy as np
from numpy.typing import NDArray

from cam.collision.body_distance import BodyShape, tool_pieces
from cam.collision.broad_phase import axis_spheres, inscribed_radii
from cam.collision.tool_mesh import PartGeometry, bvh_model, concatenate, tool_geometry
from cam.tools import Tool

__all__ = ["BODY_PARTS", "ToolModel", "build_tool_model"]

#: The parts whose clearance is reported (the cutter is meant to touch).
BODY_PARTS = ("shank", "holder")


@dataclass
class ToolModel:
    """One tool's collision geometry (tool frame: tip at the origin, axis +Z, mm).

    Attributes
    ----------
    parts : dict of str to PartGeometry
        The parts the tool has, by name.
    objects : dict of str to fcl.CollisionObject
        One fcl object per part.
    spheres : dict of str to ((m,), (m,)) float64
        Axis-sphere cover per part: heights above the tip and radii, mm.
    inner : dict of str to (m,) float64
        Inscribed-ball radius of the true part at each sphere centre, mm.
    size : dict of str to float
        Bounding-box diagonal of each part mesh, mm.
    pieces : dict of str to BodyShape
        Convex pieces of each part mesh and their coarse bounds (``body_distance``).
    clear_object : fcl.CollisionObject or None
        Shank and holder meshes merged (None: the tool has neither).
    clear_spheres : ((m,), (m,)) float64 or None
        Their sphere covers, concatenated.
    clear_pieces : BodyShape
        Their convex pieces, together.
    reach : float
        Largest distance of a tool mesh vertex from the tip, mm.
    """

    parts: dict[str, PartGeometry]
    objects: dict[str, fcl.CollisionObject]
    spheres: dict[str, tuple[NDArray[np.float64], NDArray[np.float64]]]
    inner: dict[str, NDArray[np.float64]]
    size: dict[str, float]
    pieces: dict[str, BodyShape]
    clear_object: fcl.CollisionObject | None
    clear_spheres: tuple[NDArray[np.float64], NDArray[np.float64]] | None
    clear_pieces: BodyShape
    reach: float


def build_tool_model(tool: Tool, cutter_offset: float, sections: int, arc_step: float,
                     slack: float) -> ToolModel:
    """Meshes, fcl objects, sphere covers and pieces of ``tool``.

    Parameters
    ----------
    tool : Tool
    cutter_offset : float
        Signed offset of the cutter, mm (> 0 grows).
    sections : int
        Sections of the revolved meshes.
    arc_step : float
        Largest angular step of circumscribed arcs, radians.
    slack : float
        Largest excess of a cover sphere over the part radius, mm.
    """
    parts = tool_geometry(tool, cutter_offset=cutter_offset, sections=sections,
                          arc_step=arc_step)
    objects = {n: fcl.CollisionObject(p.bvh, fcl.Transform()) for n, p in parts.items()}
    spheres = {n: axis_spheres(p.profile, p.radial_scale, slack, p.corner_centre_height)
               for n, p in parts.items()}
    inner = {n: inscribed_radii(p.profile, spheres[n][0], p.arc_excess)
             for n, p in parts.items()}
    size = {n: float(np.linalg.norm(np.ptp(p.mesh.vertices, axis=0)))
            for n, p in parts.items()}
    pieces = {n: BodyShape.build(tool_pieces([p.profile], p.radial_scale), *spheres[n])
              for n, p in parts.items()}
    body = [parts[n] for n in BODY_PARTS if n in parts]
    clear_object = None
    clear_spheres = None
    clear_pieces = BodyShape.build(np.zeros((0, 4)), np.zeros(0), np.zeros(0))
    if body:
        mesh = concatenate([p.mesh for p in body])
        clear_object = fcl.CollisionObject(bvh_model(mesh.vertices, mesh.faces))
        clear_spheres = (np.concatenate([spheres[p.name][0] for p in body]),
                         np.concatenate([spheres[p.name][1] for p in body]))
        clear_pieces = BodyShape.build(
            tool_pieces([p.profile for p in body], body[0].radial_scale),
            *clear_spheres)
    reach = max(float(np.linalg.norm(p.mesh.vertices, axis=1).max()) for p in parts.values())
    return ToolModel(parts, objects, spheres, inner, size, pieces, clear_object,
                     clear_spheres, clear_pieces, reach)
