"""The finishing procedure of M3, path by path, and its result.

Per cutter-centre path (``paths``): initial postures (``posture``), machine joints
from the machine's inverse kinematics, reverse movements of A and C removed
(``reversals``; X, Y, Z reversals reported), tool tips recomputed from the
unchanged ball centres, interference checked and remedied (``interference``), then
postures still breaking a rule repaired (``repair``); a pass whose postures the
repair cannot free is cut into its clean pieces, the rest left out and named
(``pieces.finish_runs``, finish.json ``cut_short``).
``plan_finishing`` returns a ``FinishResult``; ``summary`` is what finish.json holds
(docs/formats.md).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from cam.finishing.axis_smoothing import AxisSmoothing, smooth_axis_rate
from cam.finishing.driven import driven_scene
from cam.finishing.interference import InterferenceResult, StepHint, resolve_interference
from cam.finishing.monotone_joints import (
    LINEAR,
    ROTARY,
    inverse_joints,
    remove_reversals,
    reversal_counts,
)
from cam.finishing.options import FinishOptions, scallop_stepover
from cam.finishing.passes import passage_paths
from cam.finishing.paths import CutterPath, blade_distance, rotate_path, subset_path
from cam.finishing.posture import (
    angle_between,
    axis_breaks,
    c_max,
    enforce_normal_angle,
    initial_axes,
    lead_tilt,
    max_turn_deg_per_mm,
    rotate_about_z,
)
from cam.finishing.repair import PostureRules, RepairResult, repair_postures, rule_violations
from cam.finishing.reversals import SmoothingResult, reversal_points
from cam.tools import Tool
from geometry.revolved import RevolvedSurface
from geometry.surfaces import ImpellerSurfaces
from impeller_cam.errors import InputError
from postproc.kinematics import Kinematics

if TYPE_CHECKING:
    from cam.collision import CollisionScene
    from cam.finishing.pieces import PassTrim
    from cam.finishing.plan_memo import PlanMemo

__all__ = [
    "FinishResult",
    "PathResult",
    "finish_path",
    "junction_errors",
    "plan_finishing",
    "remove_reversals",
    "tail_end",
    "reversal_counts",
]

Array = NDArray[np.float64]
#: The joints of postures, the path named on failure (``monotone_joints``).
_inverse = inverse_joints


@dataclass
class PathResult:
    """One finished path.

    Attributes
    ----------
    path : CutterPath
        The ideal cutter-centre path.
    tip, axis : (n, 3) float64
        Final postures.
    joints_before, joints_after : (n, 5) float64
        Machine joints (X Y Z mm, A C rad) of the initial and final postures.
    reversals_before, reversals_after : dict
        Reverse movements per axis, ``{"X", "Y", "Z", "A", "C"}``.
    smoothing : dict of str to SmoothingResult
        What the smoothing did to A and C.
    interference : InterferenceResult
    centre_deviation : float
        Largest distance of the final ball centre ``tip + R axis`` from the ideal
        centre, mm.
    junction_error : dict or None
        Junction paths: largest ``| distance to hub - R |`` and ``| distance to blade - R |``.
    lead, tilt : (n,) float64
        Lead and tilt from the contact normal, rad (hub-contact paths; NaN otherwise).
    normal_angle : (n,) float64
        Angle between axis and contact normal, rad.
    repair : RepairResult or None
        The cone-search repair after the eq. 7 remedy (None: nothing broke a rule).
    rule_points : (k,) intp
        Postures still breaking the normal-angle or lead/tilt rule.
    trimmed : int
        Points cut from the end of an open-ended pass (``CutterPath.open_end``).
    step_hint : StepHint or None
        What the eq. 7 remedy found (a proven-before-used guess for the same path in
        the next passage; ``interference.StepHint``).
    breaks : (k,) intp
        Hub passes: moves ``i -> i + 1`` turning the axis faster than the option
        ``max_axis_turn_deg_per_mm``: machined in pieces (``order.ordered_passes``).
    piece_of : str or None
        A piece of a pass cut where postures break a rule (``pieces.finish_runs``):
        the pass's name (its pieces are machined as one pass, each entered from the
        air); None for a whole pass.
    """

    path: CutterPath
    tip: Array
    axis: Array
    joints_before: Array
    joints_after: Array
    reversals_before: dict[str, int]
    reversals_after: dict[str, int]
    reversal_points_before: dict[str, list[int]]
    smoothing: dict[str, SmoothingResult]
    interference: InterferenceResult
    centre_deviation: float
    junction_error: dict[str, float] | None
    lead: Array
    tilt: Array
    normal_angle: Array
    repair: RepairResult | None = None
    rule_points: NDArray[np.intp] = field(default_factory=lambda: np.zeros(0, dtype=np.intp))
    trimmed: int = 0
    step_hint: StepHint | None = None
    breaks: NDArray[np.intp] = field(default_factory=lambda: np.zeros(0, dtype=np.intp))
    piece_of: str | None = None
    axis_smoothing: AxisSmoothing | None = None

    def summary(self, options: FinishOptions) -> dict[str, Any]:
        """This path's entry of finish.json (mm, deg)."""
        inter = self.interference
        clear = inter.clearance[np.isfinite(inter.clearance)]
        hub_contact = self.path.operation in ("junction", "hub")
        limits_lead = np.abs(self.lead) > math.radians(options.max_lead_deg)
        limits_tilt = np.abs(self.tilt) > math.radians(options.max_tilt_deg)
        return {
            "name": self.path.name,
            "operation": self.path.operation,
            "passage": self.path.passage,
            "points": len(self.path),
            "reversals_before": {k: self.reversals_before[k] for k in ROTARY},
            "reversals_after": {k: self.reversals_after[k] for k in ROTARY},
            "linear_reversals_before": {k: self.reversals_before[k] for k in LINEAR},
            "linear_reversals_after": {k: self.reversals_after[k] for k in LINEAR},
            "reversal_points_before": self.reversal_points_before,
            "smoothing": {
                k: {"rounds": s.rounds, "method": s.method,
                    "phi_l_deg": [round(math.degrees(p), 6) for p in s.phi_l],
                    "max_change_deg": round(float(np.degrees(np.max(np.abs(
                        self.joints_after[:, 3 + i] - self.joints_before[:, 3 + i])))), 6)}
                for i, (k, s) in enumerate(self.smoothing.items())
            },
            "collisions": int(inter.collides.sum()),
            "motion_collisions": int(inter.motion_collides.sum()),
            "motion_bound_mm": round(inter.motion_bound, 6),
            "min_clearance_mm": None if clear.size == 0 else round(float(clear.min()), 4),
            "max_centre_deviation_mm": float(f"{self.centre_deviation:.3e}"),
            "junction_distance_error_mm": None if self.junction_error is None else {
                k: float(f"{v:.3e}") for k, v in self.junction_error.items()},
            "delta_c_deg": round(math.degrees(inter.delta_c), 6),
            "c_max_deg": None if not math.isfinite(inter.c_max)
            else round(math.degrees(inter.c_max), 4),
            "smaller_tool_needed": inter.smaller_tool_needed,
            "interfering_points": inter.interfering_points.tolist(),
            "min_normal_angle_deg": round(float(np.degrees(self.normal_angle.min())), 4),
            "max_lead_deg": round(float(np.degrees(np.abs(self.lead).max())), 4)
            if hub_contact else None,
            "max_tilt_deg": round(float(np.degrees(np.abs(self.tilt).max())), 4)
            if hub_contact else None,
            "lead_tilt_violations": int((limits_lead | limits_tilt).sum()) if hub_contact else 0,
            "normal_angle_violations": int((self.normal_angle < math.radians(
                options.min_normal_angle_deg) - 1e-9).sum()),
            "rule_violation_points": self.rule_points.tolist(),
            "trimmed_points": self.trimmed,
            "axis_breaks": self.breaks.tolist(),
            "max_axis_turn_deg_per_mm": max_turn_deg_per_mm(self.path.centre, self.axis),
            "axis_rate_smoothing": None if self.axis_smoothing is None
            else self.axis_smoothing.summary(),
            "posture_repair": None if self.repair is None else {
                "rounds": self.repair.rounds,
                "tilted_points": self.repair.tilted.tolist(),
                "max_tilt_deg": round(math.degrees(self.repair.max_tilt), 4),
                "unresolved_points": self.repair.unresolved.tolist(),
            },
        }


def junction_errors(path: CutterPath, centres: Array, hub: RevolvedSurface, radius: float,
                    pitch: float) -> dict[str, float] | None:
    """Largest ``|distance - R|`` of ball centres from the hub and from the blade, mm.

    The centres are turned back into passage 0 (where ``path.wall`` lies); the
    blade distance comes from an independent foot-point search.
    """
    if path.wall is None or path.blade_v is None:
        return None
    back = rotate_about_z(centres, -path.passage * pitch)
    hub_error = np.abs(hub.signed_distance(back) - radius)
    blade = blade_distance(path.wall, back, path.wall.own_u(path.curve_u), path.blade_v)
    return {"hub": float(hub_error.max()), "blade": float(np.abs(blade - radius).max())}


#: Open-ended passes are shortened at most this many times, and never below half.
_TRIM_ROUNDS = 3


def tail_end(result: PathResult, bad: NDArray[np.intp]) -> int:
    """Where a pass ends when it is cut before its offending points ``bad`` (exclusive).

    ``bad`` are indices into ``result.path`` as ``pieces.offenders`` gives them: a
    posture that interferes or breaks a rule, or the start ``i`` of a motion ``i -> i +
    1`` that interferes. The pass ends before the first offending posture, or after
    the start of the first offending motion (that posture is clean and the motion is
    no longer made). Ending before a motion's start lost one clean posture per cut: on
    the splitter the fillet passes round the trailing edges, where the neck passes the
    in-process stock, kept their last posture inside the outlet rim (r 79.2 mm) when the
    next one, beyond the rim, was clean.
    """
    inter = result.interference
    posture = inter.collides.copy()
    posture[result.rule_points] = True
    ends = [i if posture[i] else i + 1 for i in np.asarray(bad, dtype=np.intp).tolist()]
    return min(ends) if ends else len(result.path)


def finish_path(path: CutterPath, tool: Tool, kins: Kinematics, scene: CollisionScene,
                options: FinishOptions, surfaces: ImpellerSurfaces | None = None,
                hint: StepHint | None = None) -> PathResult:
    """Run M3 on one cutter-centre path (see the module docstring).

    An open-ended pass (``path.open_end``: hub passes ahead of a splitter) whose
    postures from some point on cannot be made to meet every rule is shortened to end
    before that point (if that keeps at least half of it) and finished again; the
    number of points cut is ``PathResult.trimmed``. ``hint`` (the same path's
    ``step_hint`` in another passage) only saves checks: the result is the same
    without it (``interference.resolve_interference``).
    """
    # the cutter allowance on the pass's driven faces only (cam/finishing/driven.py)
    scene = driven_scene(scene, path, options)
    result = _finish_once(path, tool, kins, scene, options, surfaces, hint)
    length = len(path)
    for _ in range(_TRIM_ROUNDS if path.open_end else 0):
        bad = np.union1d(result.interference.interfering_points, result.rule_points)
        end = tail_end(result, bad)
        if not bad.size or end < max(2, (length + 1) // 2):
            break
        keep = np.arange(end, dtype=np.intp)
        result = _finish_once(subset_path(result.path, keep), tool, kins, scene, options,
                              surfaces)
    result.trimmed = length - len(result.path)
    return result


def _finish_once(path: CutterPath, tool: Tool, kins: Kinematics, scene: CollisionScene,
                 options: FinishOptions, surfaces: ImpellerSurfaces | None = None,
                 hint: StepHint | None = None) -> PathResult:
    radius = tool.radius
    tangent = path.tangent
    axis0, sign = initial_axes(path.reference_axis, path.away, math.radians(options.c_tilt_deg))
    axis0, _ = enforce_normal_angle(axis0, path.normal, tangent,
                                    math.radians(options.min_normal_angle_deg))
    joints0 = _inverse(kins, path.centre - radius * axis0, axis0, path.name)
    before = reversal_counts(joints0, options)
    deadband = math.radians(options.reversal_deadband_deg)
    points_before = {k: reversal_points(joints0[:, 3 + i], deadband).tolist()
                     for i, k in enumerate(ROTARY)}
    axis, joints, smoothing = remove_reversals(path.centre, axis0, joints0, kins, radius,
                                               options, path.name)
    limits = c_max(path.centre, path.reference_axis, path.opposite_tip)
    inter = resolve_interference(scene, tool, path.centre, axis, sign, limits, options, hint)
    step_hint = StepHint.of(inter)
    if inter.delta_c:
        joints = _inverse(kins, inter.tip, inter.axis, path.name)
    rules = PostureRules(path.centre, path.normal, tangent, path.away,
                         path.operation in ("junction", "hub"))
    repair = None
    if inter.smaller_tool_needed or rule_violations(inter.axis, rules, options).any():
        repair = repair_postures(scene, tool, kins, rules, inter, joints, options)
        inter, joints = repair.interference, repair.joints
    max_turn = math.radians(  # hub: side changes in the air (axis_breaks below)
        options.max_axis_turn_deg_per_mm if path.operation == "hub" else math.inf)
    smoothed = smooth_axis_rate(scene, tool, kins, rules, inter, joints, options, max_turn)
    inter, joints = smoothed.interference, smoothed.joints
    rule_points = np.flatnonzero(rule_violations(inter.axis, rules, options))
    after = reversal_counts(joints, options)
    centre_now = inter.tip + radius * inter.axis
    deviation = float(np.linalg.norm(centre_now - path.centre, axis=1).max())
    lead, tilt = lead_tilt(inter.axis, path.normal, tangent)
    if path.operation == "blade":
        lead = np.full(len(path), np.nan)
        tilt = np.full(len(path), np.nan)
    junction = None
    if surfaces is not None and path.operation == "junction":
        junction = junction_errors(path, centre_now, surfaces.hub, radius,
                                   surfaces.spec.pitch)
    breaks = axis_breaks(centre_now, inter.axis, max_turn)
    return PathResult(path, inter.tip, inter.axis, joints0, joints, before, after,
                      points_before, smoothing, inter, deviation, junction, lead, tilt,
                      angle_between(inter.axis, path.normal), repair, rule_points,
                      step_hint=step_hint, breaks=breaks, axis_smoothing=smoothed)


@dataclass
class FinishResult:
    """All finished paths of a run, in machining order (operation, passage, path).

    Attributes
    ----------
    paths : list of PathResult
        Each path's final postures (tips mm, axes), joints and checks.
    tool : Tool
        The ball-end mill.
    options : FinishOptions
        The options planned with (mm, deg).
    scene_source : str
        Origin of the collision meshes (``"solid"`` or ``"surfaces"``).
    extra : dict
        Further entries of finish.json (stock clearance, fillet operation...).
    """

    paths: list[PathResult]
    tool: Tool
    options: FinishOptions
    scene_source: str
    extra: dict[str, Any] = field(default_factory=dict)

    def operations(self) -> dict[str, list[PathResult]]:
        """Paths grouped by operation: junction, blade, swarf, edge, hub, fillet (those present).

        Returns
        -------
        dict of str to list of PathResult
        """
        out: dict[str, list[PathResult]] = {}
        for op in ("junction", "blade", "swarf", "edge", "hub", "fillet"):
            members = [p for p in self.paths if p.path.operation == op]
            if members:
                out[op] = members
        return out

    def summary(self) -> dict[str, Any]:
        """The run's totals and per-path entries (finish.json without file names).

        Returns
        -------
        dict
            JSON-ready (mm, deg).
        """
        entries = [p.summary(self.options) for p in self.paths]
        clear = [e["min_clearance_mm"] for e in entries if e["min_clearance_mm"] is not None]

        def total(key: str, sub: str) -> int:
            return int(sum(e[key][sub] for e in entries))

        junction = [e for e in entries if e["operation"] == "junction"]
        return {
            "paths": len(entries),
            "points": int(sum(e["points"] for e in entries)),
            "junction_points": [e["points"] for e in junction],
            "reversals_before": {k: total("reversals_before", k) for k in ROTARY},
            "reversals_after": {k: total("reversals_after", k) for k in ROTARY},
            "linear_reversals_before": {k: total("linear_reversals_before", k) for k in LINEAR},
            "linear_reversals_after": {k: total("linear_reversals_after", k) for k in LINEAR},
            "collisions": int(sum(e["collisions"] for e in entries)),
            "motion_collisions": int(sum(e["motion_collisions"] for e in entries)),
            "min_clearance_mm": min(clear) if clear else None,
            "max_centre_deviation_mm": max((e["max_centre_deviation_mm"] for e in entries),
                                           default=0.0),
            "smaller_tool_needed": [e["name"] for e in entries if e["smaller_tool_needed"]],
            "lead_tilt_violations": int(sum(e["lead_tilt_violations"] for e in entries)),
            "normal_angle_violations": int(sum(e["normal_angle_violations"] for e in entries)),
            "rule_violation_paths": [e["name"] for e in entries if e["rule_violation_points"]],
            "axis_breaks": int(sum(len(e.get("axis_breaks", [])) for e in entries)),
            "posture_repairs": {
                "paths": sum(1 for e in entries if e["posture_repair"]),
                "tilted_points": int(sum(len(e["posture_repair"]["tilted_points"])
                                         for e in entries if e["posture_repair"])),
                "max_tilt_deg": max((e["posture_repair"]["max_tilt_deg"] for e in entries
                                     if e["posture_repair"]), default=0.0),
            },
            "smoothing_methods": {
                k: {m: sum(1 for e in entries if e["smoothing"][k]["method"] == m)
                    for m in sorted({e["smoothing"][k]["method"] for e in entries})}
                for k in ROTARY},
            "max_junction_distance_error_mm": max(
                (max(e["junction_distance_error_mm"].values()) for e in entries
                 if e["junction_distance_error_mm"] is not None), default=None),
            "path_entries": entries,
        }


def plan_finishing(surfaces: ImpellerSurfaces, tool: Tool, kins: Kinematics,
                   scene: CollisionScene, options: FinishOptions, *, scene_source: str,
                   progress: Callable[[int, int, str], None] | None = None,
                   keep: PassTrim | None = None,
                   before: Callable[[list[CutterPath]], object] | None = None,
                   memo: PlanMemo | None = None) -> FinishResult:
    """Generate and finish every path of every passage (passage 0, then rotations).

    Parameters
    ----------
    surfaces : ImpellerSurfaces
    tool : Tool
        A ball-end mill.
    kins : Kinematics
        The machine's kinematics (reverse movements are counted in its joints).
    scene : CollisionScene
    options : FinishOptions
    scene_source : str
        Name of the collision meshes' origin (reported).
    progress : callable, optional
        ``progress(done, total, path_name)`` after each path.
    keep : PassTrim, optional
        ``keep(path)`` of a passage-0 path: the (n,) bool mask of its points to
        machine, None for all (the blade passes cut to what a swarf operation leaves,
        ``swarf_plan.point_passes_left``). A pass kept in part becomes its runs, each
        finished and machined like a pass, ordered region by region
        (``pieces.trimmed_passes``); a pass with nothing kept is left out, with its
        rotations. ``extra["kept"]``: passage 0's blade points planned and kept,
        passes whole, cut and left out.
    before : callable, optional
        Called with every path of every passage before any is finished (a quick
        check that may refuse the job: ``machine_reach.check_machine_reach``).
    memo : PlanMemo, optional
        Plans of passes kept from an earlier run, recalled by name instead of planned
        again; what is planned is recorded (``plan_memo``; the chain's rest operation).

    Returns
    -------
    FinishResult
        Every path of every passage, machining order; a pass whose postures still
        interfere or break a rule after the repair is cut into its clean pieces and
        the points left out are listed in ``extra["cut_short"]`` (``pieces``).
    """
    if tool.shape != "ball":
        raise InputError("five-axis finishing needs a ball-end mill", field="tool",
                         value=tool.name, accepted="a tool of type 'ball'")
    stepover = scallop_stepover(tool.radius, options.scallop_mm)
    # a semi-finish (allowance_mm > 0) offsets the ball centres by R + allowance
    base = passage_paths(surfaces, tool.radius + options.allowance_mm,
                         options.point_spacing_mm, stepover,
                         blade=options.blade_passes, hub=options.hub_passes,
                         reach=max(tool.flute_length - tool.radius, 0.0),
                         chordal=options.chordal_tolerance_mm)
    from cam.finishing.pass_groups import finish_ordered  # they build on finish_path
    from cam.finishing.pieces import trimmed_passes

    kept: dict[str, int] = {}
    if keep is not None:
        base, kept = trimmed_passes(base, keep)
    blades = surfaces.spec.blades
    count = blades if options.passages is None else min(options.passages, blades)
    ordered: list[CutterPath] = []
    for op in ("junction", "blade", "hub"):
        for k in range(count):
            ordered += [p if k == 0 else rotate_path(p, k, surfaces.spec.pitch)
                        for p in base if p.operation == op]
    if before is not None:
        before(ordered)
    results, cut_short = finish_ordered(ordered, tool, kins, scene, options, surfaces,
                                        memo, progress)
    extra: dict[str, Any] = {"cut_short": cut_short}
    if keep is not None:
        extra["kept"] = kept
    return FinishResult(results, tool, options, scene_source, extra=extra)


def passes_of(results: Sequence[PathResult]) -> list[tuple[Array, Array]]:
    """``(tip, axis)`` of each path result (final postures, machining order)."""
    return [(r.tip, r.axis) for r in results]
