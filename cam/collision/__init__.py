"""Collision service: tool (cutter, shank, holder) postures against impeller meshes.

``CollisionScene(meshes).check_postures(tool, tip, axis)`` answers, for many
postures at once, whether any tool part touches the scene, which part and which
scene role, and the clearance of shank and holder; ``check_motion`` checks the
motion between consecutive postures by subdivision with a stated bound. See
docs/collision.md for the method, the bounds and the semantics.
"""

from cam.collision.postures import motion_bound, rotations_to, subdivide_motion
from cam.collision.reference import plain_fcl_check
from cam.collision.scene import CollisionScene, PostureReport
from cam.collision.tool_mesh import PART_NAMES, PartGeometry, part_geometry, tool_geometry

__all__ = [
    "PART_NAMES",
    "CollisionScene",
    "PartGeometry",
    "PostureReport",
    "motion_bound",
    "part_geometry",
    "plain_fcl_check",
    "rotations_to",
    "subdivide_motion",
    "tool_geometry",
]
