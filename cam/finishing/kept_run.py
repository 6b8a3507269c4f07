"""A run of clean postures of a finished pass, kept as it was planned (issue 28).

When a pass still holds postures that break a rule after the M3 procedure
(``plan.finish_path``), ``pieces.finish_runs`` cuts it into the runs between them.
Planning such a run again on its own (the dC remedy and the posture repair of a
shorter pass) can give other postures than the whole pass's plan, and those may
break a rule where the whole plan's did not: on the splitter fixture the pressure
side's first pass near the tip (``p0.blade.blade0.pressure.01``) broke a rule at
points 13 and 50-53 of 55 in its whole plan, yet 6-12 and 54 were left out as well,
because the end run 0-12, planned again alone, had other postures. On the splitter's
passage 0 (the chain's rough stock and options) the points left out go from 140 to
120 with ``kept_run`` (pressure side near the tip 38 -> 25, its junction 11 -> 7, a
splitter fillet 4 -> 1); 10 of the 22 passes with offenders change postures.

``kept_run`` is the other way: the run keeps the whole plan's postures and joints
(they are monotone and smooth there: a part of a smoothed curve) and is checked
again on its own (postures, the motions between them and the rules, exactly as any
finished path, ``interference.check_path``). The caller keeps it only if that check
is clean; a piece is entered from the air like every other piece (order.py), so
nothing outside the run is needed.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from cam.finishing.driven import driven_scene
from cam.finishing.interference import check_path
from cam.finishing.monotone_joints import reversal_counts
from cam.finishing.options import FinishOptions
from cam.finishing.paths import subset_path
from cam.finishing.plan import PathResult, junction_errors
from cam.finishing.posture import axis_breaks
from cam.finishing.repair import PostureRules, rule_violations
from cam.finishing.reversals import reversal_points
from cam.tools import Tool
from geometry.surfaces import ImpellerSurfaces

if TYPE_CHECKING:
    from cam.collision import CollisionScene

__all__ = ["kept_run"]

ROTARY = ("A", "C")


def _local(index: NDArray[np.intp], run: NDArray[np.intp]) -> NDArray[np.intp]:
    """Positions in ``run`` of the entries of ``index`` that lie in it."""
    return np.asarray(np.flatnonzero(np.isin(run, index)), dtype=np.intp)


def kept_run(result: PathResult, run: NDArray[np.intp], tool: Tool, scene: CollisionScene,
             options: FinishOptions, surfaces: ImpellerSurfaces | None) -> PathResult:
    """The postures ``run`` of a finished pass as a piece of their own, checked again.

    Parameters
    ----------
    result : PathResult
        A finished pass (``plan.finish_path``).
    run : (m,) intp
        Consecutive indices into ``result.path`` (at least two).
    tool, scene, options, surfaces
        As ``plan.finish_path``.

    Returns
    -------
    PathResult
        The run with the pass's postures and joints and its own check
        (``interference``, ``rule_points``): the caller keeps it only if nothing in it
        breaks a rule (``pieces.offenders``).
    """
    path = replace(subset_path(result.path, run), open_end=False)
    tip, axis = result.tip[run], result.axis[run]
    joints0, joints = result.joints_before[run], result.joints_after[run]
    old = result.interference
    # the cutter allowance on the pass's driven faces only (as plan.finish_path)
    inter = check_path(driven_scene(scene, path, options), tool, tip, axis, options)
    inter.delta_c, inter.steps, inter.c_max = old.delta_c, old.steps, old.c_max
    rules = PostureRules(path.centre, path.normal, path.tangent, path.away,
                         path.operation in ("junction", "hub"))
    rule_points = np.flatnonzero(rule_violations(axis, rules, options))
    centre_now = tip + tool.radius * axis
    deviation = float(np.linalg.norm(centre_now - path.centre, axis=1).max())
    junction = None
    if surfaces is not None and path.operation == "junction":
        junction = junction_errors(path, centre_now, surfaces.hub, tool.radius,
                                   surfaces.spec.pitch)
    repair = result.repair
    if repair is not None:
        repair = replace(repair, interference=inter, joints=joints,
                         tilted=_local(repair.tilted, run),
                         unresolved=np.asarray(rule_points, dtype=np.intp))
    deadband = math.radians(options.reversal_deadband_deg)
    points_before = {k: reversal_points(joints0[:, 3 + i], deadband).tolist()
                     for i, k in enumerate(ROTARY)}
    breaks = axis_breaks(centre_now, axis, math.radians(
        options.max_axis_turn_deg_per_mm if path.operation == "hub" else math.inf))
    return PathResult(path, tip, axis, joints0, joints, reversal_counts(joints0, options),
                      reversal_counts(joints, options), points_before, result.smoothing,
                      inter, deviation, junction, result.lead[run], result.tilt[run],
                      result.normal_angle[run], repair, rule_points, breaks=breaks)
