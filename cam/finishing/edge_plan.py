"""The edge finishing operation: each span level's lean chosen so the flutes stay off.

An edge pass's ball touches the blade's outline at its contact; above the ball the
flutes (a cylinder of the ball's radius) must lean off the blade, else they cut
into the edge beside the contact. The collision check of the M3 procedure cannot see
that: it shrinks the cutter by ``cutter_allowance_mm`` (0.05 mm) so that the ball may
touch what it cuts, so flutes leaning *towards* the surface pass it while cutting up
to that much into the part. That was the cause of the main job's five gouges of
0.050-0.053 mm on nine_blade's leading edges (verification tolerance 0.05 mm): the
edge passes leaned 5 deg towards the local contact normal, which turns by 180 deg
round the edge, so A and C reversed; the smoothing, the eq. 7 remedy (C turned by up
to 49 deg to keep the shank 2.5 mm off the blade at the lower levels) and the repair
then turned the axes until they leaned 2-7 deg *into* the edge at the gouges.

Here (``edge_paths``) the lean direction is ``edge outward + SIDE_SHARE n``, which
turns monotonically round the edge (from one side's normal to the other's, through
the edge's outward direction, by at most 2 atan(SIDE_SHARE)), and each level's lean
is the first of ``LEAN_LADDER_DEG`` whose initial postures keep every clearance
(``interference.first_interference``), so the eq. 7 remedy has nothing to turn. After the
M3 procedure (``pieces.finish_trimmed``) every posture must still lean at least
``MIN_LEAN_DEG`` off the surface at its contact (``lean_at_contact``); a level that
does not is planned again at the next lean of the ladder. Levels that reach the end
of the ladder keep the last result, and their postures below the minimum lean are
counted (``EdgeReport``). Like the fillet passes (``pieces.finish_runs``) a
level whose ends are trimmed keeps the clean runs of the trimmed points as pieces of
their own (each also leaning at least ``MIN_LEAN_DEG`` everywhere), and the points
left out are listed in finish.json's ``cut_short``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cam.collision import CollisionScene
from cam.finishing.edge_paths import EdgeLevel, edge_levels
from cam.finishing.interference import first_interference
from cam.finishing.options import FinishOptions, scallop_stepover
from cam.finishing.paths import CutterPath, rotate_path
from cam.finishing.pieces import cut_short_entry, finish_runs
from cam.finishing.plan import FinishResult, PathResult
from cam.finishing.plan_memo import PlanMemo
from cam.finishing.posture import initial_axes
from cam.tools import Tool
from geometry.surfaces import ImpellerSurfaces
from impeller_cam.processes import map_forked
from postproc.kinematics import Kinematics

__all__ = ["LEAN_LADDER_DEG", "MIN_LEAN_DEG", "EdgeReport", "lean_at_contact", "plan_edges"]

Array = NDArray[np.float64]
#: Leans tried per level, deg: the first whose initial postures are clear is planned.
LEAN_LADDER_DEG = (8.0, 12.0, 16.0, 20.0, 25.0, 30.0)
#: Least lean of the final axis off the surface at the contact, deg.
MIN_LEAN_DEG = 0.5


def lean_at_contact(axis: Array, normal: Array) -> Array:
    """Lean of unit axes off the surface at the contact, deg, ``(n,)``.

    ``asin(a . n)``: positive when the flutes above the ball centre lean away from the
    surface (the contact lies below the ball's equator), negative when they lean into
    it.
    """
    return np.asarray(np.degrees(np.arcsin(np.clip(np.einsum("ij,ij->i", axis, normal),
                                                   -1.0, 1.0))))


@dataclass
class EdgeReport:
    """What the lean search did, per path name: the lean used and the postures left
    below ``MIN_LEAN_DEG`` (0 on every path of nine_blade and round_te as measured).
    Kept in ``FinishResult.extra["edge"]``; not written to finish.json."""

    lean_deg: dict[str, float] = field(default_factory=dict)
    low_lean_points: dict[str, int] = field(default_factory=dict)


def _witness(path: CutterPath, tool: Tool, scene: CollisionScene, options: FinishOptions,
             first: int | None) -> int:
    """A posture of the path's initial postures (the C tilt applied) that breaks a
    clearance (itself or its motion to the next), or -1; ``first`` is tried first
    (``interference.first_interference``: the witness of the previous lean)."""
    axis, _ = initial_axes(path.reference_axis, path.away, math.radians(options.c_tilt_deg))
    return first_interference(scene, tool, path.centre - tool.radius * axis, axis,
                              np.arange(len(path), dtype=np.intp), options, first)


def _low_lean(result: PathResult) -> int:
    """Postures of a finished edge path leaning less than ``MIN_LEAN_DEG`` off the edge."""
    return int(np.count_nonzero(lean_at_contact(result.axis, result.path.normal)
                                < MIN_LEAN_DEG))


def _plan_level(level: EdgeLevel, passage: int, pitch: float, tool: Tool, kins: Kinematics,
                scene: CollisionScene, options: FinishOptions, surfaces: ImpellerSurfaces,
                first: int) -> tuple[list[PathResult], int, int, dict[str, Any] | None]:
    """Finish one level in ``passage`` from ladder rung ``first`` on.

    Returns the pieces (one unless the level was cut), the rung used, their count of
    postures below the minimum lean and the ``cut_short`` entry (None: nothing left out).
    """
    pieces: list[PathResult] = []
    lost = np.zeros(0, dtype=np.intp)
    causes: list[str | None] = []  # what the points left out meet (finish_runs)
    low = 0
    rung = first
    witness: int | None = None
    path = level.path
    for rung in range(first, len(LEAN_LADDER_DEG)):
        path = level.leaned(LEAN_LADDER_DEG[rung])
        if passage:
            path = rotate_path(path, passage, pitch)
        if rung < len(LEAN_LADDER_DEG) - 1:
            found = _witness(path, tool, scene, options, witness)
            if found >= 0:
                witness = found
                continue
        pieces, lost = finish_runs(path, tool, kins, scene, options, surfaces,
                                   accept=lambda piece: not _low_lean(piece), causes=causes)
        low = sum(_low_lean(piece) for piece in pieces)
        if not low and not any(piece.interference.interfering_points.size for piece in pieces):
            break
    return pieces, rung, low, (cut_short_entry(path, lost, causes) if lost.size else None)


def plan_edges(surfaces: ImpellerSurfaces, tool: Tool, kins: Kinematics,
               scene: CollisionScene, options: FinishOptions, *, scene_source: str,
               progress: Callable[[int, int, str], None] | None = None,
               memo: PlanMemo | None = None) -> FinishResult:
    """Finish the passes round the blade edges of every passage with ``tool``.

    Parameters
    ----------
    surfaces : ImpellerSurfaces
    tool : Tool
        The blade and hub finishing ball (span levels at its scallop stepover).
    kins, scene, options, scene_source, progress, memo
        As ``plan.plan_finishing`` (a level of a passage is recalled as a whole).

    Returns
    -------
    FinishResult
        Paths of operation ``"edge"`` in passage order; ``extra["edge"]``: the
        ``EdgeReport``; ``extra["cut_short"]``: the points left out, per level
        (``pieces.cut_short_entry``).
    """
    levels = edge_levels(surfaces, tool.radius,
                         scallop_stepover(tool.radius, options.scallop_mm),
                         options.point_spacing_mm)
    blades = surfaces.spec.blades
    count = blades if options.passages is None else min(options.passages, blades)
    pitch = surfaces.spec.pitch
    report = EdgeReport()
    results: list[PathResult] = []
    cut_short = []
    total = count * len(levels)
    done = 0

    def names(i: int) -> list[str]:
        return [rotate_path(levels[i].path, k, pitch).name if k else levels[i].path.name
                for k in range(count)]

    def level_plans(i: int) -> list[Any]:
        """Level ``i`` in every passage: the other passages are near rotations, each
        starts at the lean rung the one before ended on (None: the memo's plan)."""
        plans: list[Any] = []
        start = 0
        for k, name in enumerate(names(i)):
            known = None if memo is None else memo.lookup(tool.name, name)
            plans.append(None if known is not None else _plan_level(
                levels[i], k, pitch, tool, kins, scene, options, surfaces, start))
            start = (known if known is not None else plans[-1])[1]
        return plans

    def level_done(i: int, plans: list[Any]) -> None:
        nonlocal done
        done += count
        if progress is not None:
            progress(done, total, names(i)[-1])

    # the levels are independent: planned on forked processes (``impeller_cam.
    # processes``; the machine model's counts and kept answers come back)
    planned = map_forked(level_plans, len(levels), done=level_done, keep=scene)
    for k in range(count):
        for i in range(len(levels)):
            name = names(i)[k]
            known = planned[i][k]
            if known is None:
                assert memo is not None
                known = memo.recall(tool.name, name)
            elif memo is not None:
                memo.record(tool.name, name, known)
            pieces, _, low, short = known
            for piece in pieces:
                report.lean_deg[piece.path.name] = LEAN_LADDER_DEG[known[1]]
                report.low_lean_points[piece.path.name] = _low_lean(piece)
            results += pieces
            if short is not None:
                cut_short.append(short)
    return FinishResult(results, tool, options, scene_source,
                        extra={"edge": report, "cut_short": cut_short})
