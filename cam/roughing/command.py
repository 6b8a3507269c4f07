"""``impeller-cam rough SPEC -m MACHINE -t TOOL -o OUT/``: 3+2 roughing by UMRs (M4).

Writes into OUT/ (all or nothing, ``staged_directory``):

* ``rough.apt``: the whole roughing operation, one program with one tool call; each
  visit of a UMR (its layers ``k`` in all passages; every passage a
  ``$$ SEGMENT/3+2,<n>`` block with its fixed axis) is one section
  (``$$ OPERATION/rough_umr<i>_layers<k>-<k>``), in cut order: every UMR's layer k
  before any UMR's layer k + 1 (``layers_per_visit``; ``rough_umr<i>`` when a UMR is
  cut in one visit). With ``program_layout = "visit"`` each section is its own file
  ``rough_umr<i>_layers<k>-<k>.apt`` (the earlier layout);
* ``rough.json``: UMRs (lane, axis, ``A_deg``, ``C_deg``, area), ``collisions``
  (postures, moves, index moves), ``min_allowance_mm``, ``time_min`` (``3axis`` /
  ``5axis`` by feed, nominal), ``time_limited_min`` (with the machine's limits),
  per-UMR times, the time breakdown by move kind (docs/formats.md);
* ``table1.md``: the paper's Table 1 for the run (with ``compare``: the simultaneous
  five-axis baseline is planned, timed and checked beside the 3+2 plan; without it,
  as in the chain's main job, rough.json has the 3+2 plan alone).
"""

from __future__ import annotations

import json
from contextlib import nullcontext
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
from numpy.typing import NDArray

from cam.collision import CollisionScene
from cam.finishing.scene import surface_meshes
from cam.roughing.aircheck import rapid_checks
from cam.roughing.baseline import five_axis_baseline
from cam.roughing.checks import check_collisions, min_allowance
from cam.roughing.dropcutter import DropCutter
from cam.roughing.linking import LinkSettings
from cam.roughing.options import FEEDS, RoughOptions
from cam.roughing.passage import PassageGrid, passage_grid, passage_lanes
from cam.roughing.plan import (
    Segment,
    layer_visits,
    region_segment,
    rotate_segment,
    safe_height_of,
    stock_map,
)
from cam.roughing.report import breakdown, table1_markdown
from cam.roughing.shank import shank_steps
from cam.roughing.stock import Blank
from cam.roughing.stockmap import ZMap
from cam.roughing.timing import block_times
from cam.roughing.tool_size import check_tool_size
from cam.roughing.umr import UMR, Admissible, partition_passage
from cam.tools import Tool, resolve_tool
from geometry.figures import minimum_passage_width
from geometry.spec import load_spec
from geometry.surfaces import ImpellerSurfaces, build_surfaces
from impeller_cam.atomic import staged_directory, write_text_atomic
from impeller_cam.errors import InputError
from impeller_cam.progress import progress_bar
from postproc.apt import write_apt
from postproc.toolpath import Cutter, MoveKind, Toolpath

__all__ = ["RoughResult", "plan_roughing", "run_rough"]

#: The paper's Table 1 (minutes), quoted next to ours in rough.json.
PAPER_TABLE1 = {
    "3axis": {"500": 59.117, "1000": 29.958, "1500": 20.239, "2000": 15.398},
    "5axis": {"500": 66.169, "1000": 33.447, "1500": 22.389, "2000": 16.882},
    "umrs": 3,
}


@dataclass
class RoughResult:
    """Everything ``run_rough`` writes, in memory.

    Attributes
    ----------
    tool : Tool
        The roughing ball-end mill.
    options : RoughOptions
        The options planned with.
    umrs : list of UMR
        The unit machining regions, each with its fixed tool axis.
    segments : list of Segment
        The 3+2 segments (cutter locations, mm) in cut order.
    baseline : list of Segment
        The simultaneous five-axis baseline (``compare``; else empty).
    floor_area : float
        Passage floor area, mm^2.
    r_max : float
        Largest ball radius the passage admits (eq. 1), mm.
    d_min : float
        Narrowest passage width, mm.
    meshes : dict of str to trimesh.Trimesh
        Design meshes by face role (mm) the plan was checked against.
    """

    tool: Tool
    options: RoughOptions
    umrs: list[UMR]
    segments: list[Segment]
    baseline: list[Segment]
    floor_area: float
    r_max: float
    d_min: float
    meshes: dict[str, trimesh.Trimesh]


def design_meshes(surfaces: ImpellerSurfaces, options: RoughOptions
                  ) -> tuple[dict[str, trimesh.Trimesh], float]:
    """Design meshes by role and their tessellation tolerance (mm).

    ``options.design == "solid"``: the B-rep impeller with fillets and rounded edges
    (``geometry.impeller.Impeller``) tessellated within ``options.tessellation_mm``;
    its triangles lie up to that much inside convex faces, so the drop-cutter adds
    it to the ball. ``"surfaces"``: the closed-form surfaces
    triangulated on a ``mesh_spacing_mm`` grid (no fillets, flat edge strips).
    """
    if options.design == "surfaces":
        return surface_meshes(surfaces, options.mesh_spacing_mm), 0.0
    from geometry.impeller import Impeller

    tol = options.tessellation_mm
    impeller = Impeller(surfaces.spec, fillets=True)
    whole = impeller.mesh(tolerance=tol)
    labels = impeller.triangle_roles(tol)
    meshes = {}
    for role in dict.fromkeys(labels.tolist()):
        sub = whole.submesh([np.flatnonzero(labels == role)], append=True)
        if isinstance(sub, trimesh.Trimesh) and len(sub.faces):
            meshes[str(role)] = sub
    return meshes, tol


def plan_roughing(surfaces: ImpellerSurfaces, tool: Tool, options: RoughOptions,
                  progress: Any = None, compare: bool = False,
                  admissible: Admissible | None = None) -> RoughResult:
    """UMR partition and 3+2 segments of every passage, plus (``compare``) the
    simultaneous 5-axis baseline of the paper's Table 1 (else ``baseline`` is empty).

    The 3+2 segments come in ``layer_visits`` order: each UMR cuts
    ``options.layers_per_visit`` layers in every passage, then the next UMR, so a
    UMR's shank, tilted over its neighbours' part of the passage, meets no stock the
    neighbours' layers above would have removed (issue 8). A UMR's stock map is
    carried over from visit to visit.

    Parameters
    ----------
    surfaces : ImpellerSurfaces
        The impeller (``geometry.build_surfaces``), mm.
    tool : Tool
        A ball-end mill no larger than r_max.
    options : RoughOptions
        Scallop, depth, spacing, links (mm, deg).
    progress : callable, optional
        ``progress(done, total, name)`` after each UMR.
    compare : bool
        Also plan the paper's simultaneous five-axis baseline.
    admissible : callable, optional
        The machine's check of a UMR orientation (``machine_pose.orientation_check``;
        ``umr.partition_passage`` keeps to orientations it admits).

    Returns
    -------
    RoughResult

    Raises
    ------
    InputError
        A tool larger than r_max, an unreachable posture.
    """
    spec = surfaces.spec
    eta = spec.finishing_allowance
    d_min = minimum_passage_width(surfaces).distance
    r_max = check_tool_size(tool, d_min, eta, options.k,
                            None if spec.source is None else str(spec.source))
    radius = tool.radius
    depth = options.max_depth_mm or radius
    meshes, tessellation = design_meshes(surfaces, options)
    rho = radius + eta + tessellation
    triangles = np.concatenate([np.asarray(m.triangles) for m in meshes.values()])
    blank = Blank(surfaces)
    closed_tri = np.asarray(blank.closed_mesh().triangles)
    n_pass = options.passages or spec.blades
    if n_pass > spec.blades:
        raise InputError("more passages asked than the impeller has", field="passages",
                         value=n_pass, accepted=f"0..{spec.blades}")
    lanes = passage_lanes(surfaces)
    umrs: list[UMR] = []
    segments: list[Segment] = []
    base0: list[Segment] = []
    floor = 0.0
    regions: list[tuple[UMR, PassageGrid, LinkSettings, ZMap]] = []
    for lane_index, lane in enumerate(lanes):
        grid = passage_grid(surfaces, radius, eta, scallop=options.scallop_mm,
                            max_depth=depth, step_along=options.step_along_mm, lane=lane,
                            layering=options.umr_layering)
        floor += float(grid.floor_area.sum())
        lane_umrs = partition_passage(grid, lane.suction, triangles, rho,
                                      reach_tolerance=options.reach_tolerance_mm,
                                      min_reach=options.min_reach, first_index=len(umrs),
                                      lane=lane_index, admissible=admissible)
        umrs += lane_umrs
        for umr in lane_umrs:
            umr.frame.keep_shank_clear(tool, eta + options.scallop_mm)
            envelope = DropCutter(np.concatenate([umr.frame.triangles,
                                                  closed_tri @ umr.frame.matrix.T]),
                                  rho)
            safe = safe_height_of(umr, envelope, options.safe_distance_mm)
            settings = LinkSettings(options.clearance_mm, options.entry_height_mm,
                                    options.entry_angle_deg, safe, options.lift_mm)
            regions.append((umr, grid, settings,
                            stock_map(umr.frame, grid, closed_tri, radius)))
        if compare:
            base_links = LinkSettings(options.clearance_mm, options.entry_height_mm,
                                      options.entry_angle_deg, np.inf, options.lift_mm)
            base = five_axis_baseline(grid.with_layering(options.baseline_layering), blank,
                                      tool, eta, base_links, options.direct_link_mm,
                                      triangles, rho)
            base.notes["lane"] = float(lane_index)
            base0.append(base)
    visits = layer_visits([g.n1 for _, g, _, _ in regions], options.layers_per_visit)
    for done, (span, r) in enumerate(visits):
        umr, grid, settings, zmap = regions[r]
        if progress is not None:
            progress(done, len(visits), f"UMR {umr.index + 1}: layers {span[0]}-{span[1]}")
        piece = region_segment(umr, grid, blank, closed_tri, radius, settings,
                               options.direct_link_mm, tool.stickout - radius, segments,
                               span, zmap, shank_steps(tool))
        if len(piece.tip):
            segments.append(piece)
    # each visit (one UMR: one A, C; some layers) over every passage, then the next
    segments = [rotate_segment(s, p, spec.pitch) for s in segments for p in range(n_pass)]
    baseline = [rotate_segment(b, p, spec.pitch) for p in range(n_pass) for b in base0]
    return RoughResult(tool, options, umrs, segments, baseline, floor,
                       r_max, d_min, meshes)


def _joints(kins: Any, segments: list[Segment]) -> NDArray[np.float64]:
    tip = np.concatenate([s.tip for s in segments])
    axis = np.concatenate([s.axis for s in segments])
    return np.asarray(kins.inverse(tip, axis))


def _times(result: RoughResult, machine: Any, kins: Any, segments: list[Segment]
           ) -> tuple[dict[str, dict[str, float]], dict[str, dict[str, float]],
                      dict[int, dict[str, dict[str, float]]], dict[str, Any]]:
    """Totals nominal / limited by feed (min), per UMR, and the move-kind breakdown."""
    tip = np.concatenate([s.tip for s in segments])
    kind = np.concatenate([s.kind for s in segments])
    owner = np.concatenate([np.full(len(s.tip), s.umr) for s in segments])
    joints = _joints(kins, segments)
    nominal: dict[str, float] = {}
    limited: dict[str, float] = {}
    per: dict[int, dict[str, dict[str, float]]] = {}
    split: dict[str, Any] = {}
    for feed in FEEDS:
        key = str(int(feed))
        nom, lim = block_times(tip, joints, kind, feed, result.options.plunge_feed_ratio,
                               machine)
        split[key] = breakdown(tip, kind, nom, lim)
        nominal[key] = float(nom.sum()) / 60.0
        limited[key] = float(lim.sum()) / 60.0
        for u in np.unique(owner).tolist():
            sel = owner == u
            entry = per.setdefault(int(u), {"nominal": {}, "limited": {}})
            entry["nominal"][key] = float(nom[sel].sum()) / 60.0
            entry["limited"][key] = float(lim[sel].sum()) / 60.0
    return {"nominal": nominal}, {"limited": limited}, per, split


def toolpaths(result: RoughResult) -> list[Toolpath]:
    """One ``Toolpath`` per visit of a UMR (its layers in all passages, one 3+2
    segment each), in cut order.

    Parameters
    ----------
    result : RoughResult
        A roughing plan.

    Returns
    -------
    list of Toolpath
        Poses in the workpiece frame W (mm), feeds mm/min.
    """
    tool = result.tool
    feed = float(tool.feed) if tool.feed else 1000.0
    out = []
    groups: list[list[Segment]] = []
    for s in result.segments:  # consecutive segments of one visit (all its passages)
        if groups and (groups[-1][0].umr, groups[-1][0].layers) == (s.umr, s.layers):
            groups[-1].append(s)
        else:
            groups.append([s])
    split = len(groups) > len({s.umr for s in result.segments})
    for mine in groups:
        umr = result.umrs[mine[0].umr]
        first, last = mine[0].layers
        name = (f"rough_umr{umr.index + 1}_layers{first}-{last}" if split
                else f"rough_umr{umr.index + 1}")
        kind = np.concatenate([s.kind for s in mine])
        seg = np.concatenate([np.full(len(s.tip), umr.index * 1000 + s.passage)
                              for s in mine])
        f = np.where(kind == MoveKind.RAPID, np.nan,
                     np.where(kind == MoveKind.PLUNGE,
                              feed * result.options.plunge_feed_ratio, feed))
        out.append(Toolpath(np.concatenate([s.tip for s in mine]),
                            np.concatenate([s.axis for s in mine]), f, kind, seg,
                            name=name, tool_number=tool.number,
                            cutter=Cutter(tool.diameter, tool.corner_radius, tool.flute_length),
                            spindle_rpm=tool.spindle_rpm))
    return out


def run_rough(spec: str | Path, machine: str | Path, tool: str, out: str | Path, *,
              options: RoughOptions | None = None, library: str | Path | None = None,
              progress: bool | None = None, check: bool = True, compare: bool = False,
              refuse_machine_collisions: bool = False) -> dict[str, Any]:
    """Three-axis UMR roughing of an impeller: APT per UMR and rough.json.

    Parameters
    ----------
    spec : str or Path
        Impeller spec TOML.
    machine : str or Path
        Machine TOML (inverse kinematics for A/C, limits for the limited times).
    tool : str
        Tool name in the library (a ball-end mill no larger than r_max).
    out : str or Path
        Output folder.
    options : RoughOptions, optional
        The roughing options (default ``RoughOptions()``; mm, deg); the CLI and the
        spec's ``[machining.rough]`` table build them with ``RoughOptions.from_mapping``.
    library : str or Path, optional
        Tool library (default: fixtures/tools/library.toml).
    progress : bool, optional
        Show a progress bar (default: when stderr is a terminal).
    check : bool
        Run the collision checks (python-fcl, holder included).
    compare : bool
        Also plan, time and check the paper's simultaneous five-axis baseline and
        write its Table 1 (``table1.md``; the ``5axis`` entries of rough.json). The
        chain's main job leaves it out: it is a research comparison, not a program.
    refuse_machine_collisions : bool
        With a machine ``[model]``: refuse the plan when a posted block brings two
        machine components closer than their clearance (else rough.json ``machine``
        reports them; ``cam.roughing.machine_fit``).

    Returns
    -------
    dict
        The content of rough.json.

    Raises
    ------
    InputError
        Bad spec, machine, tool or option; a tool larger than r_max; an unreachable
        posture. Nothing is written then.
    """
    from postproc.kinematics import kinematics_for
    from postproc.machine import load_machine

    opts = options if options is not None else RoughOptions()
    the_tool = resolve_tool(tool, library)
    the_machine = load_machine(machine)
    kins = kinematics_for(the_machine)
    surfaces = build_surfaces(load_spec(spec))
    eta = surfaces.spec.finishing_allowance
    bar = progress_bar(progress)
    with bar if bar is not None else nullcontext():
        task = bar.add_task("roughing", total=None) if bar is not None else None

        def report(done: int, total: int, name: str) -> None:
            if bar is not None:
                bar.update(task, completed=done, total=total, description=name)

        admissible = None
        if check:
            from cam.roughing.machine_pose import orientation_check

            admissible = orientation_check(the_machine, kins, the_tool, spec,
                                           surfaces.spec.pitch,
                                           opts.passages or surfaces.spec.blades)
        result = plan_roughing(surfaces, the_tool, opts, report, compare=compare,
                               admissible=admissible)
        paths = toolpaths(result)
        plans = {"3axis": result.segments}
        if compare:
            plans["5axis"] = result.baseline
        times = {name: _times(result, the_machine, kins, segs)
                 for name, segs in plans.items()}
        per_umr = times["3axis"][2]
        checks: dict[str, Any] = {"collisions": -1, "postures_checked": 0,
                                  "min_clearance_mm": float("nan")}
        if check:
            scene = CollisionScene(result.meshes)
            checks = check_collisions(scene, result, eta, kins)
        allowance = min_allowance(result)
        if compare:
            checks["baseline_min_allowance_mm"] = min_allowance(result, result.baseline)
        else:
            for key in ("baseline_collisions", "baseline_moves_checked"):
                checks.pop(key, None)
        if check:
            blank = Blank(surfaces)
            rapids = rapid_checks(result.segments, result.baseline, result.umrs, blank,
                                  np.asarray(blank.closed_mesh().triangles),
                                  the_tool.radius, the_tool.stickout - the_tool.radius)
            checks.update({key: {plan: value[plan] for plan in plans}
                           for key, value in rapids.items()})
    joints0 = [np.asarray(kins.inverse(u.frame.axis[None] * 0.0, u.axis[None]))[0]
               for u in result.umrs]
    umrs = []
    for u, j in zip(result.umrs, joints0, strict=True):
        umr_times = per_umr.get(u.index, {"nominal": {}, "limited": {}})
        umrs.append({
            "index": u.index + 1,
            "lane": u.lane,
            "u_range": list(u.u_range),
            "stations": list(u.stations),
            "axis": u.axis.tolist(),
            "alpha_deg": float(np.degrees(u.alpha)),
            "beta_deg": float(np.degrees(u.beta)),
            "A_deg": float(np.degrees(j[3])),
            "C_deg": float(np.degrees(j[4])),
            "area_mm2": u.area,
            "time_min": umr_times["nominal"],
            "time_limited_min": umr_times["limited"],
        })
    covered = sum(u.area for u in result.umrs)
    document: dict[str, Any] = {
        "format": "impeller-cam rough 1",
        "spec": str(spec),
        "machine": str(machine),
        "tool": {"name": the_tool.name, "number": the_tool.number,
                 "diameter_mm": the_tool.diameter},
        "options": opts.as_dict(),
        "compare": compare,
        "d_min_mm": result.d_min,
        "r_max_mm": result.r_max,
        "finishing_allowance_mm": eta,
        "passage_floor_mm2": result.floor_area,
        "covered_floor_mm2": covered,
        "umrs": umrs,
        **checks,
        "min_allowance_mm": allowance,
        "time_min": {plan: t[0]["nominal"] for plan, t in times.items()},
        "time_limited_min": {plan: t[1]["limited"] for plan, t in times.items()},
        "time_breakdown": {plan: t[3] for plan, t in times.items()},
        "cut_points": {plan: sum(s.cut_points for s in segs) for plan, segs in plans.items()},
        "plan_notes": {"3axis": [dict(s.notes, umr=s.umr + 1) for s in result.segments
                                 if s.passage == 0]},
        "operations": [],
    }
    if compare:
        document["paper_table1_min"] = PAPER_TABLE1
        document["plan_notes"]["5axis"] = [dict(b.notes) for b in result.baseline
                                           if b.passage == 0]
    with staged_directory(out) as stage:
        if opts.program_layout == "operation":
            # one program, one tool call: each UMR visit a section ($$ OPERATION/)
            write_apt(stage / "rough.apt", paths, header=f"impeller-cam rough: "
                      f"{len(paths)} UMR visits, tool {the_tool.name}, 3+2 segments per "
                      "passage")
            document["operations"].append({
                "apt": "rough.apt", "poses": int(sum(len(p) for p in paths)),
                "segments": int(sum(len(np.unique(p.segment)) for p in paths)),
                "sections": [{"name": p.name, "poses": len(p),
                              "segments": int(len(np.unique(p.segment)))} for p in paths]})
        else:
            for path in paths:
                name = f"{path.name}.apt"
                write_apt(stage / name, [path], header=f"impeller-cam rough: {path.name}, "
                          f"tool {the_tool.name}, 3+2 segments per passage")
                document["operations"].append({"apt": name, "poses": len(path),
                                               "segments": int(len(np.unique(path.segment)))})
        if compare:
            write_text_atomic(stage / "table1.md", table1_markdown(document))
        if check:
            from cam.roughing.machine_fit import check_machine_fit

            document["machine"] = check_machine_fit(
                [stage / op["apt"] for op in document["operations"]], machine, the_machine,
                kins, the_tool, spec, refuse=refuse_machine_collisions,
                scene=None if admissible is None else admissible.scene)
        write_text_atomic(stage / "rough.json", json.dumps(document, indent=2) + "\n")
    return document
