"""The swarf finishing operation: flank passes on the passage walls (issue 23).

For each wall of passage 0 (``paths.passage_walls``) the swarf pass is planned and
predicted (``swarf_blade.plan_blade_side``) with the flank of the finishing tool
(``FlankTool.from_tool``: the flutes' side, a cylinder or the cone of a tapered
ball). Every run of consecutive rulings within the tolerances (``swarf_overcut_mm``,
``swarf_undercut_mm``) and within the flutes becomes one pass of operation
``"swarf"``; its postures are fixed by the prediction (no smoothing or C remedy,
which would change the deviation), checked like any finishing path
(``interference.check_path``: the flutes are the cutter, shank and holder keep
``clearance_mm``) and counted for A/C reversals in the machine's joints. The other
passages get rotated copies. Postures that collide or start an A/C reversal are
dropped from the swarf cut (``plan_swarf``). ``covered`` tells the point-milling planner which blade
passes lie wholly inside the swarf-cut band (``blade_strategy = "swarf_or_point"``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from cam.finishing.flank_tool import FlankTool
from cam.finishing.interference import check_path
from cam.finishing.options import FinishOptions
from cam.finishing.paths import CutterPath, Wall, passage_walls, rotate_path
from cam.finishing.plan import FinishResult, PathResult, reversal_counts
from cam.finishing.posture import angle_between
from cam.finishing.reversals import SmoothingResult, reversal_points
from cam.finishing.swarf_blade import BladeSwarfPass, plan_blade_side, side_segment
from cam.tools import Tool
from geometry.surfaces import ImpellerSurfaces
from postproc.kinematics import Kinematics

if TYPE_CHECKING:
    from cam.collision import CollisionScene

__all__ = ["SwarfWall", "covered_by", "plan_swarf", "swarf_report", "swarf_walls"]

Array = NDArray[np.float64]
#: Check-and-drop rounds of the swarf postures of passage 0.
_CHECK_ROUNDS = 4


@dataclass(frozen=True)
class SwarfWall:
    """The swarf prediction of one wall of passage 0.

    Attributes
    ----------
    wall : Wall
    result : BladeSwarfPass
    blade_u : (n,) float64
        The blade's own u of each ruling.
    """

    wall: Wall
    result: BladeSwarfPass
    blade_u: Array

    def covered(self, blade_u: Array, blade_v: Array) -> NDArray[np.bool_]:
        """Points ``(u, v)`` of this wall inside the band of a swarf-cut ruling.

        Parameters
        ----------
        blade_u, blade_v : (k,) float64
            The blade's own u and v of the points.

        Returns
        -------
        (k,) bool
            The nearest ruling is cut and ``v`` lies above its band bottom. Points
            beyond the side's u range (on a broken corner or an edge cap: the edge
            passes' surfaces, not the side's) count as covered when their nearest
            ruling is cut.
        """
        order = np.argsort(self.blade_u)
        u, cut = self.blade_u[order], self.result.cuttable[order]
        bottom = self.result.v_bottom[order]
        nearest = np.clip(np.searchsorted(u, blade_u), 1, len(u) - 1)
        left = np.abs(blade_u - u[nearest - 1]) <= np.abs(u[nearest] - blade_u)
        nearest = np.where(left, nearest - 1, nearest)
        return np.asarray(cut[nearest] & (blade_v <= np.interp(blade_u, u, bottom)))


def swarf_walls(surfaces: ImpellerSurfaces, tool: Tool,
                options: FinishOptions) -> list[SwarfWall]:
    """Plan and predict the swarf pass on every wall of passage 0.

    Parameters
    ----------
    surfaces : ImpellerSurfaces
    tool : Tool
        The finishing tool (its flutes are the flank).
    options : FinishOptions
        ``swarf_*`` tolerances and ruling step (mm).

    Returns
    -------
    list of SwarfWall
    """
    spec = surfaces.spec
    flank = FlankTool.from_tool(tool)
    out = []
    for pair in passage_walls(surfaces):
        for wall in pair:
            role = "pressure" if wall.side > 0 else "suction"
            result = plan_blade_side(
                wall.blade, surfaces.hub, role, flank, leading_edge=spec.leading_edge,
                trailing_edge=spec.trailing_edge, fillet_radius=float(spec.fillet_radius),
                ruling_step_mm=options.swarf_ruling_step_mm, overcut=options.swarf_overcut_mm,
                undercut=options.swarf_undercut_mm, flute_margin=options.clearance_mm)
            seg = side_segment(wall.blade, role, spec.leading_edge, spec.trailing_edge)
            out.append(SwarfWall(wall, result, np.asarray(seg.u_of(result.postures.u))))
    return out


def _runs(mask: NDArray[np.bool_]) -> list[NDArray[np.intp]]:
    """Index runs of consecutive True values with at least two members."""
    idx = np.flatnonzero(mask)
    if not idx.size:
        return []
    runs = np.split(idx, np.flatnonzero(np.diff(idx) > 1) + 1)
    return [r for r in runs if len(r) >= 2]


def _path_result(path: CutterPath, tip: Array, axis: Array, tool: Tool, kins: Kinematics,
                 scene: CollisionScene, options: FinishOptions) -> PathResult:
    """A fixed-posture path checked and counted like a finishing path."""
    joints = kins.inverse(tip, axis)
    counts = reversal_counts(joints, options)
    deadband = math.radians(options.reversal_deadband_deg)
    points = {k: reversal_points(joints[:, 3 + i], deadband).tolist()
              for i, k in enumerate(("A", "C"))}
    smoothing = {k: SmoothingResult(joints[:, 3 + i].copy(), 0, [], "none")
                 for i, k in enumerate(("A", "C"))}
    inter = check_path(scene, tool, tip, axis, options)
    nan = np.full(len(tip), np.nan)
    return PathResult(path, tip, axis, joints, joints, counts, counts, points, smoothing,
                      inter, 0.0, None, nan, nan.copy(), angle_between(axis, path.normal))


def _wall_passes(sw: SwarfWall, cut: NDArray[np.bool_], tool: Tool
                 ) -> list[tuple[CutterPath, Array, Array, NDArray[np.intp]]]:
    """Passage-0 passes of a wall: one per run of rulings in ``cut``."""
    post = sw.result.postures
    normal = sw.wall.blade.side_normal(sw.blade_u, np.full(len(sw.blade_u), 0.5), sw.wall.side)
    out = []
    for j, run in enumerate(_runs(cut)):
        centre = post.tips[run] + tool.radius * post.axes[run]
        path = CutterPath(
            name=f"p0.swarf.{sw.wall.label}.{j:02d}", operation="swarf", passage=0,
            centre=centre, normal=normal[run], reference_axis=post.axes[run],
            away=normal[run], opposite_tip=centre.copy(),
            curve_u=sw.wall.curve_u(sw.blade_u[run]), wall=sw.wall)
        out.append((path, post.tips[run], post.axes[run], run))
    return out


def _blocked(result: PathResult) -> NDArray[np.bool_]:
    """Postures that collide, start or end a colliding motion, or start a reversal."""
    inter = result.interference
    bad = np.array(inter.collides, dtype=bool, copy=True)
    bad[:-1] |= inter.motion_collides
    bad[1:] |= inter.motion_collides
    for points in result.reversal_points_before.values():
        bad[np.asarray(points, dtype=np.intp)] = True
    return bad


def plan_swarf(surfaces: ImpellerSurfaces, tool: Tool, kins: Kinematics,
               scene: CollisionScene, options: FinishOptions, *, scene_source: str,
               walls: list[SwarfWall] | None = None,
               progress: Callable[[int, int, str], None] | None = None) -> FinishResult:
    """The swarf passes of every passage, checked; the prediction in ``extra``.

    Postures of passage 0 that collide (themselves or the motion to a neighbour:
    shank or holder nearer than ``clearance_mm``, the cutter into the part) or start
    an A/C reversal are dropped from the swarf cut (their postures are fixed by the
    deviation, so neither the eq. 7 remedy nor the smoothing may move them), the runs
    are split there and checked again, up to ``_CHECK_ROUNDS`` times; dropped rulings
    are left to point milling (``swarf_or_point``). The other passages are rotations
    of passage 0, checked again.

    Parameters
    ----------
    surfaces : ImpellerSurfaces
    tool : Tool
    kins, scene, options, scene_source, progress
        As ``plan.plan_finishing``.
    walls : list of SwarfWall, optional
        A prediction already made (``swarf_walls``).

    Returns
    -------
    FinishResult
        Paths of operation ``"swarf"``; ``extra["swarf"]``: the report
        (``swarf_report``); ``extra["swarf_walls"]``: the walls with the dropped
        rulings no longer cuttable; ``extra["swarf_dropped"]``: rulings dropped per
        wall label.
    """
    walls = swarf_walls(surfaces, tool, options) if walls is None else walls
    checked: list[SwarfWall] = []
    first: list[PathResult] = []
    dropped: dict[str, int] = {}
    for sw in walls:
        cut = np.array(sw.result.cuttable, dtype=bool, copy=True)
        results: list[PathResult] = []
        for _ in range(_CHECK_ROUNDS):
            results, changed = [], False
            for path, tip, axis, run in _wall_passes(sw, cut, tool):
                res = _path_result(path, tip, axis, tool, kins, scene, options)
                bad = _blocked(res)
                if bad.any():
                    cut[run[bad]] = False
                    changed = True
                results.append(res)
            if not changed:
                break
        dropped[sw.wall.label] = int(sw.result.cuttable.sum() - cut.sum())
        checked.append(SwarfWall(sw.wall, replace(sw.result, cuttable=cut), sw.blade_u))
        first += results
    blades = surfaces.spec.blades
    count = blades if options.passages is None else min(options.passages, blades)
    out = list(first)
    for k in range(1, count):
        for res0 in first:
            path = rotate_path(res0.path, k, surfaces.spec.pitch)
            axis = path.reference_axis
            tip = np.asarray(path.centre - tool.radius * axis)
            out.append(_path_result(path, tip, axis, tool, kins, scene, options))
            if progress is not None:
                progress(len(out), count * len(first), path.name)
    return FinishResult(out, tool, options, scene_source,
                        extra={"swarf": {**swarf_report(checked, out),
                                         "dropped_rulings": dropped},
                               "swarf_walls": checked, "swarf_dropped": dropped})


def swarf_report(walls: list[SwarfWall], results: list[PathResult]) -> dict[str, Any]:
    """The prediction per wall and the checks of the passes (finish.json ``swarf``).

    Parameters
    ----------
    walls : list of SwarfWall
    results : list of PathResult
        The checked swarf passes (all passages).

    Returns
    -------
    dict
        ``walls``: per wall ``BladeSwarfPass.summary`` (mm, share 0..1);
        ``blade_area_share``: the swarf-cut share of the walls' area (area-weighted);
        ``passes``, ``collisions``, ``reversals_A``, ``reversals_C``.
    """
    entries = [{"wall": sw.wall.label, **sw.result.summary()} for sw in walls]
    return {
        "walls": entries,
        "blade_area_share": float(
            sum(sw.result.area_share * sw.result.side_area for sw in walls)
            / max(sum(sw.result.side_area for sw in walls), 1e-300)),
        "passes": len(results),
        "collisions": int(sum(int(r.interference.collides.sum())
                              + int(r.interference.motion_collides.sum()) for r in results)),
        "reversals_A": int(sum(r.reversals_after["A"] for r in results)),
        "reversals_C": int(sum(r.reversals_after["C"] for r in results)),
    }


def covered_by(walls: list[SwarfWall]) -> Callable[[CutterPath], bool]:
    """``skip`` for ``plan.plan_finishing``: blade passes wholly inside a swarf band.

    Parameters
    ----------
    walls : list of SwarfWall

    Returns
    -------
    callable
        ``skip(path)``: True for a passage-0 blade pass whose every point lies in the
        band of a swarf-cut ruling of its wall (``SwarfWall.covered``).
    """
    by_label = {sw.wall.label: sw for sw in walls}

    def skip(path: CutterPath) -> bool:
        if path.operation != "blade" or path.wall is None or path.blade_v is None:
            return False
        sw = by_label.get(path.wall.label)
        if sw is None:
            return False
        return bool(sw.covered(path.wall.own_u(path.curve_u), path.blade_v).all())

    return skip
