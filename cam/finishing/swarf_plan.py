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
dropped from the swarf cut (``plan_swarf``). With ``blade_strategy = "swarf_or_point"``
the blade point passes are cut to what the swarf band leaves, with an overlap
(``point_passes_left``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from cam.finishing.edge_cover import EdgeCover, edge_cover_turns
from cam.finishing.flank_tool import FlankTool
from cam.finishing.interference import check_path
from cam.finishing.options import FinishOptions, scallop_stepover
from cam.finishing.paths import CutterPath, Wall, passage_walls, rotate_path
from cam.finishing.plan import FinishResult, PathResult, reversal_counts
from cam.finishing.posture import angle_between
from cam.finishing.reversals import SmoothingResult, reversal_points
from cam.finishing.swarf_blade import BladeSwarfPass, plan_blade_side, side_segment
from cam.tools import Tool
from geometry.surfaces import ImpellerSurfaces, rotation_z
from postproc.kinematics import Kinematics

if TYPE_CHECKING:
    from cam.collision import CollisionScene

__all__ = ["PointPassTrim", "SwarfWall", "plan_swarf", "point_passes_left", "swarf_check_text",
           "swarf_report", "swarf_setup", "swarf_walls"]

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

    def inside(self, blade_u: Array, blade_v: Array, margin_mm: float = 0.0
               ) -> NDArray[np.bool_]:
        """Points ``(u, v)`` of this wall at least ``margin_mm`` inside a swarf pass's band.

        Parameters
        ----------
        blade_u, blade_v : (k,) float64
            The blade's own u and v of the points.
        margin_mm : float
            Least depth above the band bottom, measured along the ruling, mm.

        Returns
        -------
        (k,) bool
            ``u`` lies between the end rulings of a run of at least two swarf-cut
            rulings (a pass, ``plan_swarf``) and ``(v_b(u) - v) L(u) >= margin_mm``,
            ``L`` the ruling's length (v = 0 to 1) and ``v_b`` the band bottom. Nothing
            beyond a run's end ruling counts.
        """
        blade_u = np.asarray(blade_u, dtype=np.float64)
        order = np.argsort(self.blade_u)
        u, cut = self.blade_u[order], self.result.cuttable[order]
        bottom = self.result.v_bottom[order]
        blade, side = self.wall.blade, self.wall.side
        length = np.linalg.norm(blade.side(u, np.zeros_like(u), side)
                                - blade.side(u, np.ones_like(u), side), axis=1)
        depth = (np.interp(blade_u, u, bottom) - blade_v) * np.interp(blade_u, u, length)
        within = np.zeros(len(blade_u), dtype=bool)
        for run in _runs(cut):
            within |= (blade_u >= u[run[0]]) & (blade_u <= u[run[-1]])
        return np.asarray(within & (depth >= margin_mm))


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


@dataclass(frozen=True)
class PointPassTrim:
    """The blade point passes cut to what the swarf passes leave (``point_passes_left``).

    Attributes
    ----------
    walls : dict of str to SwarfWall
        The checked walls by label.
    overlap_mm, end_overlap_mm : float
        See ``point_passes_left``.
    covered : callable, optional
        See ``point_passes_left``.
    """

    walls: dict[str, SwarfWall]
    overlap_mm: float
    end_overlap_mm: float
    covered: Callable[[Array, Array], NDArray[np.bool_]] | None = None

    def __call__(self, path: CutterPath) -> NDArray[np.bool_] | None:
        """None for a pass kept whole (not a blade pass, no swarf wall, nothing inside
        the band), else the (n,) bool mask of the points to machine."""
        if path.operation != "blade" or path.wall is None or path.blade_v is None:
            return None
        sw = self.walls.get(path.wall.label)
        if sw is None:
            return None
        left = ~sw.inside(path.wall.own_u(path.curve_u), path.blade_v, self.overlap_mm)
        if self.covered is not None:
            left &= ~self.covered(path.centre, path.normal)
        if left.all():
            return None
        if not left.any():
            return left
        arc = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(path.centre, axis=0), axis=1))]
        out = arc[left]
        after = np.clip(np.searchsorted(out, arc), 0, len(out) - 1)
        before = np.clip(after - 1, 0, len(out) - 1)
        reach = np.minimum(np.abs(arc - out[after]), np.abs(arc - out[before]))
        return np.asarray(reach <= self.end_overlap_mm)

    def region(self, piece: CutterPath) -> int:
        """The gap between swarf passes a kept piece lies in: the number of its wall's
        swarf passes (runs of cut rulings) whose middle lies before the piece's middle
        in blade u; -1 when the piece spans the middle of a pass."""
        sw = self.walls.get(piece.wall.label) if piece.wall is not None else None
        if sw is None or piece.wall is None:
            return -1
        u = piece.wall.own_u(piece.curve_u)
        order = np.argsort(sw.blade_u)
        ruling_u = sw.blade_u[order]
        middles = np.array([0.5 * (ruling_u[r[0]] + ruling_u[r[-1]])
                            for r in _runs(sw.result.cuttable[order])])
        if np.any((middles > u.min()) & (middles < u.max())):
            return -1
        return int(np.sum(middles < 0.5 * (u.min() + u.max())))


def point_passes_left(walls: list[SwarfWall], overlap_mm: float, end_overlap_mm: float,
                      covered: Callable[[Array, Array], NDArray[np.bool_]] | None = None
                      ) -> PointPassTrim:
    """``keep`` for ``plan.plan_finishing``: the blade passes cut to what swarf leaves.

    A point of a passage-0 blade pass is left to the swarf passes when it lies at least
    ``overlap_mm`` inside the band of a run of swarf-cut rulings of its wall
    (``SwarfWall.inside``) and at least ``end_overlap_mm`` along the pass (the ball
    centres' arc length) from every point that does not: the point passes overlap
    the swarf band by about a stepover across the rulings and by ``end_overlap_mm``
    where they run into or out of it, so no ridge stays between the two. A point
    ``covered`` finishes (the edge passes' ends: ``edge_cover.EdgeCover``) is left to it
    as well, so no stub is kept at a pass's edge end. The pieces are machined region
    by region (``PointPassTrim.region``, ``pieces.trimmed_passes``).

    Parameters
    ----------
    walls : list of SwarfWall
        The checked walls (``plan_swarf``'s ``extra["swarf_walls"]``).
    overlap_mm : float
        Depth into the band (along the ruling, from the band bottom) a point must
        lie to be left to the swarf passes, mm (the blade passes' stepover).
    end_overlap_mm : float
        Length along a pass the kept parts reach into the band, mm (a stepover plus
        a ruling step: the flank leaves up to 0.08 mm within a ruling step inside a
        pass's end rulings, ``swarf_sweep.pass_deviation``).
    covered : callable, optional
        ``covered(centre, normal)`` ((k, 3) ball centres and side normals of a pass,
        mm) -> (k,) bool: the points another operation finishes to the scallop.

    Returns
    -------
    PointPassTrim
    """
    return PointPassTrim({sw.wall.label: sw for sw in walls}, overlap_mm, end_overlap_mm,
                         covered)


def swarf_check_text(surfaces: ImpellerSurfaces, tool: Tool, options: FinishOptions) -> str:
    """The limits stated before planning (``impeller-cam finish --check-swarf``).

    The blades' rule deviation (``geometry.figures.rule_deviation``: the camber
    surface from its ruled approximation) and, per wall of passage 0, the predicted
    swarf deviation of its band (``swarf_walls``: per ruling and over the sweep,
    against the exact side) with the rulings within the tolerances and the flutes.
    No collision or reversal check: ``plan_swarf`` may drop more rulings.

    Parameters
    ----------
    surfaces : ImpellerSurfaces
    tool : Tool
        The finishing tool (its flutes are the flank).
    options : FinishOptions
        ``swarf_*`` tolerances and ruling step, ``clearance_mm`` (flute margin).

    Returns
    -------
    str
        Lines of text (mm; share of the side's area in %).
    """
    from geometry.figures import rule_deviation

    deviation, _ = rule_deviation(surfaces)
    lines = [f"rule deviation of the blades: {deviation:.4f} mm",
             f"swarf tool {tool.name}: flutes {tool.flute_length:g} mm, taper "
             f"{tool.flute_taper_deg:g} deg; tolerances overcut {options.swarf_overcut_mm:g} mm, "
             f"undercut {options.swarf_undercut_mm:g} mm",
             "predicted deviation per band (< 0 overcut, > 0 undercut; before the collision "
             "and reversal checks):"]
    for sw in swarf_walls(surfaces, tool, options):
        f = sw.result.summary()
        lines.append(
            f"  {sw.wall.label}: rulings {f['cuttable_rulings']}/{f['rulings']} within "
            f"tolerance and flutes, per ruling overcut {f['ruling_overcut_mm']:.4f} / "
            f"undercut {f['ruling_undercut_mm']:.4f} mm, swept overcut "
            f"{f['swept_overcut_mm']:.4f} / undercut {f['swept_undercut_mm']:.4f} mm, "
            f"rulings reach {f['max_top_height_mm']:.1f} mm up the tool, "
            f"{100 * float(f['area_share']):.1f} % of the side")
    return "\n".join(lines) + "\n"


def swarf_setup(surfaces: ImpellerSurfaces, tool: Tool, kins: Kinematics,
                collision: CollisionScene, opts: FinishOptions, scene: str,
                report: Any, edges: FinishResult | None = None
                ) -> tuple[FinishResult | None, FinishOptions, Any]:
    """The checked swarf passes (None for ``blade_strategy = "point"``), the options of
    the point milling (no blade passes for ``"swarf"``) and its ``keep``: the blade
    passes cut to what the swarf passes leave (``"swarf_or_point"``; overlap: a
    stepover across the rulings, a stepover and a ruling step along the passes) and to
    what the planned ``edges`` of passage 0 leave, turned by ``edge_cover_turns``."""
    if opts.blade_strategy == "point":
        return None, opts, None
    flank = plan_swarf(surfaces, tool, kins, collision, opts, scene_source=scene,
                       progress=report)
    if opts.blade_strategy == "swarf":
        return flank, replace(opts, blade_passes=False), None
    stepover = scallop_stepover(tool.radius, opts.scallop_mm)
    covered = None
    if edges is not None:
        balls = [r.tip + tool.radius * r.axis for r in edges.paths if r.path.passage == 0]
        covered = EdgeCover([b @ rotation_z(k * surfaces.spec.pitch).T for k in
                             edge_cover_turns(opts, surfaces.spec.blades) for b in balls],
                            tool.radius, opts.scallop_mm)
    return flank, opts, point_passes_left(flank.extra["swarf_walls"], stepover,
                                          stepover + opts.swarf_ruling_step_mm, covered)
