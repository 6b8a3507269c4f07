"""A pass's plan in another passage: passage 0's plan turned about the axis, re-checked.

The passages of an impeller are rotations of passage 0 about +Z by the pitch
(``paths.rotate_path``), and so are their cutter-centre paths. Planning the same pass
again in every passage repeats the M3 procedure (postures, reverse movements, the eq. 7
remedy search, the posture repair, the axis-rate smoothing) only to find, on a part
that is symmetric up to its tessellation, the same postures turned. ``turned_plan``
turns passage 0's finished postures instead and checks them again in full against the
scene the pass is planned in (postures and the motions between them: the part, the
in-process stock, the machine, whatever the scene holds; ``interference.check_path``),
with the posture rules, the reverse movements of the machine joints and the axis
breaks. The turned plan is kept only when every check is as clean as passage 0's;
otherwise the pass is planned in full (``pieces.finish_runs``).

A kept turned plan uses passage 0's C increase (eq. 7's dC), which is free in this
passage too but not necessarily its smallest free step (on nine_blade at the main
job's settings ``blade.blade0.pressure.07`` needs 22 deg in passage 0, and 21 deg would
do in passages 1, 4 and 7). Only plans that leave no point out are turned: a pass
with points left out in passage 0 is planned in full in every passage, so no passage
leaves more out than its own plan would.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from cam.finishing.driven import driven_scene
from cam.finishing.interference import check_path
from cam.finishing.monotone_joints import ROTARY, inverse_joints, reversal_counts
from cam.finishing.options import FinishOptions
from cam.finishing.paths import CutterPath, rotate_path
from cam.finishing.plan import PathResult, junction_errors
from cam.finishing.posture import angle_between, axis_breaks, c_max, lead_tilt, rotate_about_z
from cam.finishing.repair import PostureRules, rule_violations
from cam.finishing.reversals import reversal_points
from cam.tools import Tool
from geometry.surfaces import ImpellerSurfaces
from postproc.kinematics import Kinematics

if TYPE_CHECKING:
    from cam.collision import CollisionScene

__all__ = ["turned_plan", "turned_result"]

#: Largest distance of a turned passage-0 ball centre from the pass's own, mm (the
#: pass must be the same pass by rotation).
_SAME_PATH_MM = 1e-9


def turned_plan(pieces: list[PathResult], original: CutterPath, path: CutterPath,
                pitch: float, tool: Tool, kins: Kinematics, scene: CollisionScene,
                options: FinishOptions, surfaces: ImpellerSurfaces | None
                ) -> list[PathResult] | None:
    """Passage 0's clean pieces of a pass turned into ``path``'s passage, or None.

    Parameters
    ----------
    pieces : list of PathResult
        Passage 0's finished pieces of the pass (clean, nothing left out;
        ``pieces.finish_runs``).
    original : CutterPath
        Passage 0's pass (what ``pieces`` were planned from).
    path : CutterPath
        The same pass in another passage (``rotate_path(original, k, pitch)``).
    pitch : float
        Angle between passages, rad.
    tool, kins, scene, options, surfaces
        As ``plan.finish_path``.

    Returns
    -------
    list of PathResult or None
        The turned pieces, each checked again in this passage and clean; None when
        ``path`` is not ``original`` turned or a turned piece fails a check (plan it).
    """
    k = path.passage - original.passage
    if k <= 0 or original.passage != 0 or len(path) != len(original) or not pieces:
        return None
    angle = k * pitch
    if not np.allclose(rotate_about_z(original.centre, angle), path.centre, rtol=0.0,
                       atol=_SAME_PATH_MM):
        return None
    out = []
    for piece in pieces:
        turned = turned_result(piece, k, pitch, tool, kins, scene, options, surfaces)
        if turned is None:
            return None
        out.append(turned)
    return out


def turned_result(result: PathResult, passage: int, pitch: float, tool: Tool,
                  kins: Kinematics, scene: CollisionScene, options: FinishOptions,
                  surfaces: ImpellerSurfaces | None) -> PathResult | None:
    """One finished passage-0 path turned into ``passage`` and checked again there.

    The turned postures are checked as any finished path (``check_path`` in the
    pass's ``driven_scene``, the posture rules); their joints come from the inverse
    kinematics. None when a posture or motion interferes, a rule is broken, the
    reverse movements of any joint or the axis breaks differ from ``result``'s, or
    passage 0's C increase exceeds this path's eq. 7 limit.
    """
    if result.interference.interfering_points.size or result.rule_points.size:
        return None
    angle = passage * pitch
    path = rotate_path(result.path, passage, pitch)
    tip = rotate_about_z(result.tip, angle)
    axis = rotate_about_z(result.axis, angle)
    old = result.interference
    limit = float(np.min(c_max(path.centre, path.reference_axis, path.opposite_tip)))
    if abs(old.delta_c) > limit + 1e-12:
        return None
    rules = PostureRules(path.centre, path.normal, path.tangent, path.away,
                         path.operation in ("junction", "hub"))
    if rule_violations(axis, rules, options).any():
        return None
    joints = inverse_joints(kins, tip, axis, path.name)
    if reversal_counts(joints, options) != result.reversals_after:
        return None
    max_turn = math.radians(
        options.max_axis_turn_deg_per_mm if path.operation == "hub" else math.inf)
    centre_now = tip + tool.radius * axis
    breaks = axis_breaks(centre_now, axis, max_turn)
    if not np.array_equal(breaks, result.breaks):
        return None
    inter = check_path(driven_scene(scene, path, options), tool, tip, axis, options)
    if inter.smaller_tool_needed:
        return None
    inter.delta_c, inter.steps, inter.c_max = old.delta_c, old.steps, limit
    inter.witnesses = old.witnesses
    tip0, axis0 = kins.forward(result.joints_before)
    joints0 = inverse_joints(kins, rotate_about_z(tip0, angle), rotate_about_z(axis0, angle),
                             path.name)
    deadband = math.radians(options.reversal_deadband_deg)
    points_before = {key: reversal_points(joints0[:, 3 + i], deadband).tolist()
                     for i, key in enumerate(ROTARY)}
    lead, tilt = lead_tilt(axis, path.normal, path.tangent)
    if path.operation == "blade":
        lead, tilt = np.full(len(path), np.nan), np.full(len(path), np.nan)
    junction = None
    if surfaces is not None and path.operation == "junction":
        junction = junction_errors(path, centre_now, surfaces.hub, tool.radius, pitch)
    repair = None if result.repair is None else replace(result.repair, interference=inter,
                                                        joints=joints)
    smoothing = None if result.axis_smoothing is None else replace(
        result.axis_smoothing, interference=inter, joints=joints)
    piece_of = None if result.piece_of is None else \
        result.piece_of.replace(f"p{result.path.passage}.", f"p{passage}.", 1)
    deviation = float(np.linalg.norm(centre_now - path.centre, axis=1).max())
    return PathResult(path, tip, axis, joints0, joints, reversal_counts(joints0, options),
                      reversal_counts(joints, options), points_before, result.smoothing,
                      inter, deviation, junction, lead, tilt,
                      angle_between(axis, path.normal), repair, result.rule_points.copy(),
                      result.trimmed, result.step_hint, breaks, piece_of, smoothing)
