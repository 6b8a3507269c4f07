"""The plain per-posture python-fcl loop: the reference the fast check must match.

For every posture, every part (cutter, shank, holder) and every role (scene
order), ``fcl.collide`` on the same meshes and fcl objects the scene uses,
stopping at the first contact of the posture; the clearance is one
``fcl.distance`` of the shank+holder mesh against the merged scene. No broad
phase. Used by the tests and by ``benchmarks/bench_collision.py``.
"""

from __future__ import annotations

import math
from collections.abc import Collection

import fcl
import numpy as np
from numpy.typing import ArrayLike

from cam.collision.postures import rotations_to, validate_postures
from cam.collision.scene import CollisionScene, PostureReport
from cam.collision.tool_mesh import PART_NAMES
from cam.tools import Tool


def plain_fcl_check(
    scene: CollisionScene,
    tool: Tool,
    tip: ArrayLike,
    axis: ArrayLike,
    *,
    parts: Collection[str] = PART_NAMES,
    cutter_allowance: float = 0.0,
    cutter_roles: Collection[str] | None = None,
    clearance: bool = True,
) -> PostureReport:
    """Check postures one by one with fcl only (the reference of ``check_postures``).

    Parameters
    ----------
    scene : CollisionScene
        The scene meshes.
    tool : Tool
        The tool (mm).
    tip, axis : (n, 3) array-like
        Tool tips (mm) and unit axes in the scene frame.
    parts, cutter_allowance, cutter_roles, clearance
        As ``CollisionScene.check_postures`` (lengths in mm).

    Returns
    -------
    PostureReport
        ``clearance`` is exact (fcl distance) for every posture.
    """
    tip_a, axis_a = validate_postures(tip, axis)
    model = scene.tool_model(tool, -float(cutter_allowance))
    rot = rotations_to(axis_a)
    n = len(tip_a)
    collides = np.zeros(n, dtype=bool)
    part_hit = np.full(n, -1, dtype=np.int8)
    hit_role: list[str | None] = [None] * n
    clear = np.full(n, math.nan)
    cutter_roles_t = scene.roles if cutter_roles is None else tuple(cutter_roles)
    request = fcl.CollisionRequest()
    distance_request = fcl.DistanceRequest()
    checked = [(PART_NAMES.index(p), model.objects[p]) for p in PART_NAMES
               if p in parts and p in model.objects]
    for i in range(n):
        transform = fcl.Transform(rot[i], tip_a[i])
        for code, obj in checked:
            obj.setTransform(transform)
            roles = cutter_roles_t if code == 0 else scene.roles
            hit = next(
                (
                    r
                    for r in scene.roles
                    if r in roles
                    and fcl.collide(obj, scene.objects[r], request, fcl.CollisionResult())
                ),
                None,
            )
            if hit is not None:
                collides[i], part_hit[i], hit_role[i] = True, code, hit
                break
        if clearance and model.clear_object is not None:
            model.clear_object.setTransform(transform)
            d = fcl.distance(
                model.clear_object, scene.whole_object, distance_request, fcl.DistanceResult()
            )
            clear[i] = max(float(d), 0.0)
    return PostureReport(collides, part_hit, hit_role, clear)
