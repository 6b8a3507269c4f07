"""``impeller-cam rough SPEC -m MACHINE -t TOOL -o OUT/``: 3+2 roughing by UMRs (M4).

Writes into OUT/ (all or nothing, ``staged_directory``):

* ``rough_umr<i>_layers<k>-<k>.apt``: one APT operation per visit of a UMR (its
  layers ``k`` in all passages; every passage a ``$$ SEGMENT/3+2,<n>`` block with
  its fixed axis), in cut order: every UMR's layer k before any UMR's layer k + 1
  (``layers_per_visit``; ``rough_umr<i>.apt`` when a UMR is cut in one visit);
* ``rough.json``: UMRs (lane, axis, ``A_deg``, ``C_deg``, area), ``collisions``
  (postures, moves, index moves), ``min_allowance_mm``, ``time_min`` (``3axis`` /
  ``5axis`` by feed, nominal), ``time_limited_min`` (with the machine's limits),
  per-UMR times, the time breakdown by move kind (docs/formats.md);
* ``table1.md``: the paper's Table 1 for the run.
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
from cam.roughing.umr import UMR, partition_passage
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

#: The drop-cutter leaves the ball exactly eta from the design triangles, and the
#: collision service's tool meshes circumscribe the tool by up to ~0.05 mm: the
#: cutter is checked grown by ``eta - CONTACT_MARGIN`` so a tangent ball is not a hit.
CONTACT_MARGIN = 0.05

#: The paper's Table 1 (minutes), quoted next to ours in rough.json.
PAPER_TABLE1 = {
    "3axis": {"500": 59.117, "1000": 29.958, "1500": 20.239, "2000": 15.398},
    "5axis": {"500": 66.169, "1000": 33.447, "1500": 22.389, "2000": 16.882},
    "umrs": 3,
}


@dataclass
class RoughResult:
    """Everything ``run_rough`` writes, in memory."""

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
                  progress: Any = None) -> RoughResult:
    """UMR partition and 3+2 segments of every passage, plus the 5-axis baseline.

    The 3+2 segments come in ``layer_visits`` order: each UMR cuts
    ``options.layers_per_visit`` layers in every passage, then the next UMR, so a
    UMR's shank, tilted over its neighbours' part of the passage, meets no stock the
    neighbours' layers above would have removed (issue 8). A UMR's stock map is
    carried over from visit to visit.
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
                                      lane=lane_index)
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
        base_links = LinkSettings(options.clearance_mm, options.entry_height_mm,
                                  options.entry_angle_deg, np.inf, options.lift_mm)
        base = five_axis_baseline(grid.with_layering(options.baseline_layering), blank, tool,
                                  eta, base_links, options.direct_link_mm, triangles, rho)
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
    segment each), in cut order."""
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


def _index_poses(kins: Any, a: Segment, b: Segment, samples: int = 24
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Poses along the index move from the end of ``a`` to the start of ``b``.

    The machine moves its joints on a straight line (a synchronised rapid), so the
    tool sweeps the forward kinematics of the interpolated joints, not a line in W.
    """
    q = np.asarray(kins.inverse(np.stack([a.tip[-1], b.tip[0]]),
                                np.stack([a.axis[-1], b.axis[0]])))
    t = np.linspace(0.0, 1.0, samples)[:, None]
    tip, axis = kins.forward(q[0][None] + t * (q[1] - q[0])[None])
    return np.asarray(tip), np.asarray(axis)


def check_collisions(scene: CollisionScene, result: RoughResult, eta: float,
                     kins: Any = None) -> dict[str, Any]:
    """Postures, all moves and index moves of the 3+2 plan; the baseline's moves.

    * every posture of every passage: the cutter grown by ``eta - CONTACT_MARGIN``
      and shank/holder closer than eta count as hits;
    * every move (cutting, link, retract) of passage 0's segments by subdivision
      (``check_motion``, 1 mm / 1 deg); the other passages are rotations of them by
      the blade pitch, and their postures are all checked above;
    * every index move between segments along the machine's joint-space path
      (forward kinematics of the interpolated joints), when ``kins`` is given;
    * the five-axis baseline's moves of passage 0 the same way (reported, not part
      of ``collisions``).

    Returns
    -------
    dict
        ``collisions`` (3+2 hits), ``postures_checked``, ``moves_checked``,
        ``index_moves_checked``, ``min_clearance_mm`` (shank+holder, capped at
        max(eta, 1)), ``hits`` (list of {kind, umr, part, role}) and
        ``baseline_collisions`` / ``baseline_moves_checked``.
    """
    grown = -(eta - CONTACT_MARGIN)
    cap = max(eta, 1.0)
    parts = ("cutter", "shank", "holder")
    hits: list[dict[str, Any]] = []

    def note(report: Any, what: str, umr: int) -> int:
        bad = np.flatnonzero(report.blocked(eta))
        for i in bad[:20].tolist():
            part = int(report.part[i])
            hits.append({"check": what, "umr": umr, "role": report.hit_role[i],
                         "part": parts[part] if part >= 0 else "clearance < eta"})
        return int(len(bad))

    segs = result.segments
    tips = np.concatenate([s.tip for s in segs])
    axes = np.concatenate([s.axis for s in segs])
    posture = scene.check_postures(result.tool, tips, axes, cutter_allowance=grown,
                                   clearance_cap=cap)
    bad = note(posture, "posture", -1)
    clear = float(np.nanmin(posture.clearance)) if len(posture.clearance) else np.inf
    moves = 0
    for s in segs:
        if s.passage != 0 or len(s.tip) < 2:
            continue
        motion = scene.check_motion(result.tool, s.tip, s.axis, max_step_mm=1.0,
                                    max_step_deg=1.0, cutter_allowance=grown,
                                    clearance_cap=cap)
        bad += note(motion, "move", s.umr + 1)
        moves += len(s.tip) - 1
    index_moves = 0
    if kins is not None:
        for a, b in zip(segs[:-1], segs[1:], strict=True):
            tip, axis = _index_poses(kins, a, b)
            report = scene.check_postures(result.tool, tip, axis, cutter_allowance=grown,
                                          clearance_cap=cap)
            bad += note(report, "index", b.umr + 1)
            index_moves += 1
    base_bad = 0
    base_moves = 0
    for base in result.baseline:
        if base.passage != 0:
            continue
        base_report = scene.check_motion(result.tool, base.tip, base.axis, max_step_mm=1.0,
                                         max_step_deg=1.0, cutter_allowance=grown,
                                         clearance_cap=cap)
        base_bad += int(base_report.blocked(eta).sum())
        base_moves += len(base.tip) - 1
    return {"collisions": bad, "postures_checked": len(tips), "moves_checked": moves,
            "index_moves_checked": index_moves, "min_clearance_mm": clear, "hits": hits,
            "baseline_collisions": base_bad, "baseline_moves_checked": base_moves}


def min_allowance(result: RoughResult, segments: list[Segment] | None = None) -> float:
    """Smallest distance of the ball surface from the design triangles, mm.

    Exact point-triangle distances (``cam.collision.triangle_bvh``) of the ball
    centres of passage 0 (the other passages are rotations of it), at the poses and
    at 3 points inside every cutting move, of ``segments`` (default: the 3+2 plan).
    """
    from cam.collision.triangle_bvh import TriangleBVH

    radius = result.tool.radius
    centres = []
    for s in result.segments if segments is None else segments:
        if s.passage != 0:
            continue
        c = s.tip + radius * s.axis
        cut = (s.kind[1:] == MoveKind.FEED) | (s.kind[1:] == MoveKind.PLUNGE)
        a, b = c[:-1][cut], c[1:][cut]
        t = np.arange(1, 4)[:, None, None] / 4.0
        centres += [c, (a[None] + t * (b - a)[None]).reshape(-1, 3)]
    if not centres:
        return float("nan")
    points = np.concatenate(centres)
    bvh = TriangleBVH(np.concatenate([np.asarray(m.triangles) for m in result.meshes.values()]))
    d = bvh.distances(points, 4.0 * radius)
    return float(d.min() - radius)




def run_rough(spec: str | Path, machine: str | Path, tool: str, out: str | Path, *,
              library: str | Path | None = None, progress: bool | None = None,
              check: bool = True, **options: Any) -> dict[str, Any]:
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
    library : str or Path, optional
        Tool library (default: fixtures/tools/library.toml).
    progress : bool, optional
        Show a progress bar (default: when stderr is a terminal).
    check : bool
        Run the collision checks (python-fcl, holder included).
    **options
        Fields of ``RoughOptions``.

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

    opts = RoughOptions.from_mapping(options)
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

        result = plan_roughing(surfaces, the_tool, opts, report)
        paths = toolpaths(result)
        three_nom, three_lim, per_umr, three_split = _times(result, the_machine, kins,
                                                            result.segments)
        five_nom, five_lim, _, five_split = _times(result, the_machine, kins, result.baseline)
        checks: dict[str, Any] = {"collisions": -1, "postures_checked": 0,
                                  "min_clearance_mm": float("nan")}
        if check:
            scene = CollisionScene(result.meshes)
            checks = check_collisions(scene, result, eta, kins)
        allowance = min_allowance(result)
        base_allowance = min_allowance(result, result.baseline)
        if check:
            blank = Blank(surfaces)
            checks.update(rapid_checks(result.segments, result.baseline, result.umrs, blank,
                                       np.asarray(blank.closed_mesh().triangles),
                                       the_tool.radius,
                                       the_tool.stickout - the_tool.radius))
    joints0 = [np.asarray(kins.inverse(u.frame.axis[None] * 0.0, u.axis[None]))[0]
               for u in result.umrs]
    umrs = []
    for u, j in zip(result.umrs, joints0, strict=True):
        times = per_umr.get(u.index, {"nominal": {}, "limited": {}})
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
            "time_min": times["nominal"],
            "time_limited_min": times["limited"],
        })
    covered = sum(u.area for u in result.umrs)
    document: dict[str, Any] = {
        "format": "impeller-cam rough 1",
        "spec": str(spec),
        "machine": str(machine),
        "tool": {"name": the_tool.name, "number": the_tool.number,
                 "diameter_mm": the_tool.diameter},
        "options": opts.as_dict(),
        "d_min_mm": result.d_min,
        "r_max_mm": result.r_max,
        "finishing_allowance_mm": eta,
        "passage_floor_mm2": result.floor_area,
        "covered_floor_mm2": covered,
        "umrs": umrs,
        **checks,
        "min_allowance_mm": allowance,
        "baseline_min_allowance_mm": base_allowance,
        "time_min": {"3axis": three_nom["nominal"], "5axis": five_nom["nominal"]},
        "time_limited_min": {"3axis": three_lim["limited"], "5axis": five_lim["limited"]},
        "paper_table1_min": PAPER_TABLE1,
        "time_breakdown": {"3axis": three_split, "5axis": five_split},
        "cut_points": {"3axis": sum(s.cut_points for s in result.segments),
                       "5axis": sum(s.cut_points for s in result.baseline)},
        "plan_notes": {"3axis": [dict(s.notes, umr=s.umr + 1) for s in result.segments
                                 if s.passage == 0],
                       "5axis": [dict(b.notes) for b in result.baseline
                                 if b.passage == 0]},
        "operations": [],
    }
    with staged_directory(out) as stage:
        for path in paths:
            name = f"{path.name}.apt"
            write_apt(stage / name, [path], header=f"impeller-cam rough: {path.name}, "
                      f"tool {the_tool.name}, 3+2 segments per passage")
            document["operations"].append({"apt": name, "poses": len(path),
                                           "segments": int(len(np.unique(path.segment)))})
        write_text_atomic(stage / "table1.md", table1_markdown(document))
        write_text_atomic(stage / "rough.json", json.dumps(document, indent=2) + "\n")
    return document
