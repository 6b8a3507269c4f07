"""Each finishing operation linked into one toolpath, and the check of its air moves.

``finish_toolpaths`` joins the passes of every operation of a ``FinishResult``
(``linking.Linker``: departures, approaches, links chosen and checked in joint space);
``check_links`` checks the air moves the linker did not (feed moves as cuts, straight
rapids as rapids). With a ``run_memo.RunMemo`` an operation made of the very plans the
last run linked (a rerun against less stock) keeps its toolpath and its count.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from cam.finishing.linking import Envelope, Linker, LinkRules
from cam.finishing.machine_obstacle import MachineObstacle
from cam.finishing.order import ordered_passes
from cam.finishing.run_memo import MadeOperation
from impeller_cam.processes import map_forked
from postproc.toolpath import Cutter, MoveKind, Toolpath

if TYPE_CHECKING:
    from cam.collision import CollisionScene
    from cam.finishing.options import FinishOptions
    from cam.finishing.plan import FinishResult
    from cam.finishing.run_memo import RunMemo
    from cam.tools import Tool
    from geometry.surfaces import ImpellerSurfaces
    from postproc.kinematics import Kinematics

__all__ = ["AXIS_STILL", "Linked", "check_links", "checked_links", "finish_toolpaths"]

#: Largest change of the unit tool axis over a rapid the post writes as one straight
#: ``G0`` (a rapid turning a rotary joint by more than ``postproc.feeds.ROTARY_STILL``,
#: 1e-12 rad, gets the post's safe retract).
AXIS_STILL = 1e-9

#: One operation: ``(toolpath, air mask (n,) bool, link entries)``.
Linked = tuple[Toolpath, np.ndarray, list[dict[str, Any]]]


def _envelope(surfaces: ImpellerSurfaces, clearance: float) -> Envelope:
    contours = np.concatenate([surfaces.hub.contour, surfaces.shroud.contour])
    return Envelope(float(contours[:, 1].max()) + clearance,
                    float(contours[:, 0].max()) + clearance)


def finish_toolpaths(result: FinishResult, surfaces: ImpellerSurfaces,
                     scene: CollisionScene, kins: Kinematics, made: RunMemo | None = None
                     ) -> dict[str, Linked]:
    """One linked ``Toolpath`` per operation, the mask of its air poses, its links.

    Parameters
    ----------
    result : FinishResult
        The finished paths.
    surfaces : ImpellerSurfaces
        The impeller (retract envelope).
    scene : CollisionScene
        Collision meshes the links are checked against.
    kins : Kinematics
        The machine's kinematics.
    made : RunMemo, optional
        The last run's operations: one of the same plans is taken over (``RunMemo.
        operation``); every operation is recorded in it.

    Returns
    -------
    dict
        Operation -> ``(toolpath, air mask (n,) bool, link entries)``; poses in W, mm.
    """
    tool, options = result.tool, result.options
    feed = float(tool.feed) if tool.feed else 1000.0
    rules = LinkRules(
        tool=tool, feed=feed, departure=options.departure_mm, clearance=options.clearance_mm,
        cutter_allowance=options.cutter_allowance_mm, step_mm=options.motion_step_mm,
        step_rad=math.radians(options.motion_step_deg),
        envelope=_envelope(surfaces, options.retract_clearance_mm),
        longest=tool.length + 500.0, turn_step=math.radians(options.link_step_deg),
        feed_link=options.feed_link_mm, undriven_allowance=options.undriven_allowance_mm,
        hub=surfaces.hub)
    linker = Linker(scene, kins, rules)
    operations = result.operations()
    known: dict[str, MadeOperation | None] = {
        op: None if made is None else made.operation(op, members, tool.name)
        for op, members in operations.items()}
    todo = [op for op, found in known.items() if found is None]

    def link(k: int) -> Linked:
        return linker.join(f"finish_{todo[k]}", ordered_passes(operations[todo[k]],
                                                               options.zigzag),
                           tool_number=tool.number,
                           cutter=Cutter(tool.diameter, tool.corner_radius, tool.flute_length),
                           spindle_rpm=tool.spindle_rpm)

    # the operations are linked on forked processes (their links ask the same scene,
    # nothing else): what the machine model counted and kept comes back (``keep``)
    linked = map_forked(link, len(todo), costs=[
        float(sum(len(p.tip) for p in operations[op])) for op in todo], keep=scene)
    for op, joined in zip(todo, linked, strict=True):
        known[op] = new = MadeOperation(operations[op], tool.name, joined)
        if made is not None:
            made.operations[op] = new
    return {op: found.linked for op, found in known.items() if found is not None}


def check_links(scene: CollisionScene, tool: Tool, toolpath: Toolpath,
                air: np.ndarray, options: FinishOptions) -> int:
    """Collision-check every air move that is not a checked link (those are checked in
    joint space by ``Linker``), linearly in W as the planner means them; the count.

    Feed moves (departures, approaches, stepovers) are checked as cuts: the cutter,
    shrunk by the cutting allowance, may cut the stock. A rapid that keeps the tool
    axis (the post writes it as one straight ``G0``; one that turns it is guarded by
    the post's safe retract) is checked as a rapid: the whole tool, the cutter over its
    fluted length grown by ``clearance_mm``, against the design and the stock.

    The machine model (``MachineObstacle``) checks the feed moves and the straight
    rapids as the post moves them. A rapid that turns the axis is not moved linearly
    in W by the post (safe retract, orient, position, down), so its machine check is
    finish.json's machine entry (``operation_clearance``, the post's moves); here it
    is checked against the part's scene alone.
    """
    part = scene.inner if isinstance(scene, MachineObstacle) else scene
    moving = (air & ~toolpath.link)[1:]
    still = np.linalg.norm(np.diff(toolpath.axis, axis=0), axis=1) < AXIS_STILL
    rapid = moving & (toolpath.kind[1:] == MoveKind.RAPID)
    bad = 0
    for mask, allowance, where in ((moving & ~rapid, options.cutter_allowance_mm, scene),
                                   (rapid & ~still, options.cutter_allowance_mm, part),
                                   (rapid & still, -options.clearance_mm, scene)):
        edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(np.int8), [0]])))
        for start, stop in zip(edges[::2], edges[1::2], strict=True):
            tip, axis = toolpath.tip[start:stop + 1], toolpath.axis[start:stop + 1]
            report = where.check_motion(tool, tip, axis, max_step_mm=options.motion_step_mm,
                                        max_step_deg=options.motion_step_deg,
                                        cutter_allowance=allowance,
                                        # only compared with the limit: exact below it
                                        clearance_cap=options.clearance_mm,
                                        clearance_limits=(options.clearance_mm,))
            clear = np.asarray(report.clearance)
            bad += int((report.collides | (np.isfinite(clear)
                                           & (clear < options.clearance_mm))).sum())
    return bad


def checked_links(scene: CollisionScene, tools: dict[str, Tool],
                  toolpaths: dict[str, Linked], options: FinishOptions,
                  made: RunMemo | None = None) -> dict[str, int]:
    """``check_links`` of every operation (with its tool); an operation taken over from
    the last run (``made``) keeps its count, every count is recorded in ``made``."""
    counts = {}
    for op, (toolpath, air, _) in toolpaths.items():
        known = None if made is None else made.operations.get(op)
        if known is not None and known.linked[0] is not toolpath:
            known = None
        if known is None or known.link_collisions < 0:
            counts[op] = check_links(scene, tools[op], toolpath, air, options)
            if known is not None:
                known.link_collisions = counts[op]
        else:
            counts[op] = known.link_collisions
    return counts
