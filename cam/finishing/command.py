"""``impeller-cam finish SPEC -m MACHINE -t TOOL -o OUT/``: five-axis finishing (M3).

Writes into OUT/ (all or nothing, ``staged_directory``):

* ``finish_junction.apt``, ``finish_blade.apt``, ``finish_hub.apt``: one APT CLDATA
  file per operation (workpiece frame, mm, mm/min); with ``fillet_tool`` also
  ``finish_fillet.apt`` (the fillet pencil passes, ``cam.finishing.fillet_plan``),
  and ``finish_edge.apt`` (passes round the blade edges, ``edge_passes`` option);
  with ``blade_strategy`` ``"swarf"`` or ``"swarf_or_point"`` also ``finish_swarf.apt``
  (flank passes along the blade rulings, ``cam.finishing.swarf_plan``; finish.json
  ``swarf``: the predicted deviations per wall and the swarf-cut share of blade area);
* ``finish.json``: per path the number of points, reverse movements of A and C
  before and after (``reversals_before`` / ``reversals_after``), ``collisions``,
  ``min_clearance_mm``, the largest deviation of the ball centre from its ideal path,
  and more (docs/formats.md); ``cut_short``: the points of every pass left out because
  no posture there keeps every rule (``cam.finishing.pieces``: never cut, so the
  programs hold no known collision);
* ``plots/<path>.png``: A and C angular displacement before and after smoothing
  (passage 0; the other passages are rotations of it and have the same curves);
* ``scene.stl``: the collision meshes the postures were checked against.

With ``stock`` (an in-process stock, e.g. the chain's verified ``verify/rough/
stock.npz``), shank and holder also keep ``stock_clearance_mm`` from the stock
material farther than ``clearance_mm - stock_clearance_mm`` from the design, and
every path reports the cutter's engagement in it
(``cam.finishing.stock_clearance``; finish.json ``stock``).
"""

from __future__ import annotations

import json
import math
from contextlib import nullcontext
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import trimesh

from cam.collision import CollisionScene
from cam.finishing.edge_plan import plan_edges
from cam.finishing.fillet_plan import check_fillet_tool, plan_fillet
from cam.finishing.linked_ops import AXIS_STILL, Linked, checked_links, finish_toolpaths
from cam.finishing.linked_ops import check_links as _check_links  # noqa: F401 (its old home)
from cam.finishing.machine_obstacle import MachineObstacle, operation_clearance
from cam.finishing.machine_reach import check_machine_reach
from cam.finishing.options import FinishOptions
from cam.finishing.plan import FinishResult, PathResult, plan_finishing
from cam.finishing.plots import plot_angular_displacements
from cam.finishing.scene import solid_meshes, surface_meshes
from cam.finishing.stock_clearance import (
    STOCK_ROLE,
    StockScene,
    engagement,
    excess_voxels,
    stock_blocked,
)
from cam.finishing.swarf_plan import swarf_setup
from cam.tools import Tool, resolve_tool
from geometry.spec import load_spec
from geometry.surfaces import ImpellerSurfaces, build_surfaces
from impeller_cam.atomic import staged_directory, write_text_atomic
from impeller_cam.errors import InputError
from impeller_cam.processes import map_forked
from impeller_cam.progress import progress_bar
from postproc.apt import format_apt
from postproc.kinematics import Kinematics

if TYPE_CHECKING:
    from cam.finishing.pieces import PassTrim
    from cam.finishing.plan_memo import PlanMemo
    from cam.finishing.run_memo import MadeOperation, RunMemo
    from cam.verify.deviation import DesignDistance
    from cam.verify.stock import Stock
    from geometry.impeller import Impeller
    from geometry.surfaces import ImpellerSurfaces

__all__ = ["AXIS_STILL", "SCENE_SOURCES", "finish_toolpaths", "run_finish"]

SCENE_SOURCES = ("solid", "surfaces")
#: Grid spacing of the closed-form collision meshes (``scene="surfaces"``), mm.
SURFACE_MESH_SPACING = 1.0
#: Ray spacing of the spec's blank when it stands for the part in the machine check, mm
#: (coarser casts give a larger solid of revolution: on the safe side).
BLANK_PITCH = 1.0
#: Paper figures quoted next to ours in finish.json.
PAPER = {"junction_cc_points": 475, "paths": 26, "reversals_after": 0}


def _tool_entry(tool: Tool) -> dict[str, Any]:
    """finish.json's description of a tool."""
    return {"name": tool.name, "number": tool.number, "diameter_mm": tool.diameter}


def _stock_scene(the_stock: Stock, impeller: Any, design: CollisionScene,
                 opts: FinishOptions, distance: DesignDistance | None = None) -> StockScene:
    """The design scene with the stock's excess material (``stock_clearance``);
    ``distance``: the signed distance from ``impeller.mesh()`` when already built."""
    from cam.verify.deviation import DesignDistance

    if distance is None:
        mesh = impeller.mesh()
        distance = DesignDistance(np.asarray(mesh.vertices, np.float64),
                                  np.asarray(mesh.faces, np.int64))
    excess = excess_voxels(the_stock, distance, opts.clearance_mm - opts.stock_clearance_mm,
                           opts.stock_voxel_mm)
    return StockScene(design, excess)


def _engagement(scene: StockScene, result: FinishResult, entries: list[dict[str, Any]],
                tools: dict[str, Tool]) -> dict[str, Any]:
    """Per path ``stock_engagement`` in ``entries``; finish.json's ``stock`` entry.

    Each path is measured with the tool of its operation (``tools``; the fillet
    pencil's ball for the fillet passes), else ``result.tool``."""
    total = 0
    deepest = -math.inf
    blocked_paths = []
    options = result.options
    for entry, path in zip(entries, result.paths, strict=True):
        tool = tools.get(path.path.operation, result.tool)
        depth, over = engagement(scene.excess, tool, path.tip, path.axis)
        found = depth[np.isfinite(depth)]
        # of the postures still interfering, those the stock blocks (contact, or
        # shank/holder closer than stock_clearance_mm to it)
        bad = path.interference.interfering_points
        blocked = bad[stock_blocked(scene, tool, path.tip[bad], path.axis[bad],
                                    options.cutter_allowance_mm,
                                    options.stock_clearance_mm)]
        entry["stock_engagement"] = {
            "max_depth_mm": round(float(found.max()), 4) if found.size else None,
            "points_over": np.flatnonzero(over).tolist()}
        entry["stock_blocked_points"] = blocked.tolist()
        if blocked.size or STOCK_ROLE in path.interference.hit_role:
            blocked_paths.append(path.path.name)
        total += int(over.sum())
        deepest = max(deepest, float(found.max()) if found.size else -math.inf)
    return {**scene.excess.summary(), "stock_clearance_mm": result.options.stock_clearance_mm,
            "engaged_points_over": total,
            "max_engagement_mm": round(deepest, 4) if math.isfinite(deepest) else None,
            "paths_blocked_by_stock": blocked_paths}


def _machine_obstacle(model: Any, kins: Kinematics, scene: CollisionScene,
                      the_stock: Stock | None, spec: str | Path) -> MachineObstacle:
    """The scene with the machine model as an obstacle; the part's solid from the
    in-process stock, else from the spec's blank (cast at ``BLANK_PITCH``)."""
    from cam.verify.machine_scene import part_solid
    from cam.verify.sources import load_stock

    source = the_stock if the_stock is not None else load_stock(str(spec), BLANK_PITCH)
    return MachineObstacle(scene, model, kins, part_solid(source))


def _machine_entry(obstacle: MachineObstacle, result: FinishResult,
                   entries: list[dict[str, Any]], toolpaths: dict[str, Linked],
                   tools: dict[str, Tool], made: RunMemo | None = None) -> dict[str, Any]:
    """Per path ``machine_blocked_points`` in ``entries``; finish.json's ``machine``
    (``made``: the last run's, where they hold, ``run_memo``; this run's recorded)."""
    blocked_paths = []
    for entry, path in zip(entries, result.paths, strict=True):
        blocked = None if made is None else made.blocked(path)
        if blocked is None:
            tool = tools.get(path.path.operation, result.tool)
            blocked = np.flatnonzero(obstacle.posture_blocked(tool, path.tip,
                                                              path.axis)).tolist()
            if made is not None:
                made.margins[path.path.name] = (path, blocked)
        entry["machine_blocked_points"] = blocked
        if blocked:
            blocked_paths.append(path.path.name)
    operations: dict[str, Any] = {}
    measure = []  # the operations measured here, on forked processes
    for op, (tp, _, _) in toolpaths.items():
        known = None if made is None else made.operations.get(op)
        if known is None or known.linked[0] is not tp \
                or known.machine is None or not made.machine_valid:  # type: ignore[union-attr]
            measure.append(op)
        operations[op] = None if known is None else known.machine
    found = map_forked(lambda k: operation_clearance(obstacle, tools[measure[k]],
                                                     toolpaths[measure[k]][0]),
                       len(measure), costs=[float(len(toolpaths[op][0])) for op in measure],
                       keep=obstacle)
    for op, clearance in zip(measure, found, strict=True):
        operations[op] = clearance
        known = None if made is None else made.operations.get(op)
        if known is not None and known.linked[0] is toolpaths[op][0]:
            known.machine = clearance
    stats = obstacle.stats
    return {"margin_mm": obstacle.margin, "step_mm": obstacle.model.step,
            "paths_blocked": blocked_paths, "operations": operations,
            "poses_checked": int(stats["poses"]),
            "distance_queries": int(stats["distance_queries"])}


def _design_scene(spec: Any, source: str, scene: str, opts: FinishOptions,
                  design: Impeller | None, made: RunMemo | None
                  ) -> tuple[Any, ImpellerSurfaces, dict[str, Any], CollisionScene]:
    """``(impeller or None, surfaces, meshes by role, design scene)`` of the spec: the
    built solid's meshes (``"solid"``) or the closed-form surfaces' (``"surfaces"``);
    ``made``: the last run's when they are of the same design (``run_memo``)."""
    key = (source, scene, opts.tessellation_mm)
    if made is not None and made.design is not None and made.design[0] == key and (
            design is None or made.design[1] is design):
        made.count("design_scene")
        return made.design[1], made.design[2], made.design[3], made.design[4]
    if scene == "solid":
        from geometry.impeller import Impeller

        impeller = design if design is not None else Impeller(spec)
        surfaces = impeller.surfaces
        meshes = solid_meshes(impeller, opts.tessellation_mm)
    else:
        impeller, surfaces = None, build_surfaces(spec)
        meshes = surface_meshes(surfaces, SURFACE_MESH_SPACING)
    collision = CollisionScene(meshes)
    if made is not None:
        made.design, made.stl = (key, impeller, surfaces, meshes, collision), None
    return impeller, surfaces, meshes, collision


def _scene_stl(meshes: dict[str, Any], made: RunMemo | None) -> bytes:
    """``scene.stl`` of the collision meshes (the last run's, same scene)."""
    if made is not None and made.stl is not None:
        return made.stl
    merged = trimesh.util.concatenate(list(meshes.values()))
    assert isinstance(merged, trimesh.Trimesh)
    stl = merged.export(file_type="stl")
    assert isinstance(stl, bytes)
    if made is not None:
        made.stl = stl
    return stl


def _write_apt(path: Path, toolpath: Any, header: str, known: MadeOperation | None) -> None:
    """One operation's APT file (``known``: the text of the last run's same operation)."""
    if known is None or known.apt is None or known.apt[0] != header:
        text = format_apt([toolpath], header=header)
        if known is not None:
            known.apt = (header, text)
    else:
        text = known.apt[1]
    write_text_atomic(path, text)


def _plots(stage: Path, entries: list[dict[str, Any]], result: FinishResult,
           made: RunMemo | None) -> None:
    """The angular displacement plot of every passage-0 path (``made``: the last
    run's of the same plans copied)."""
    named: dict[str, list[PathResult]] = {}
    for entry, path in zip(entries, result.paths, strict=True):
        if path.path.passage == 0:
            entry["plot"] = f"plots/{path.path.name}.png"
            named.setdefault(path.path.name, []).append(path)
    drawn = []
    for name, paths in named.items():
        png = stage / f"plots/{name}.png"
        known = None if made is None else made.plot(name, paths)
        if known is not None:
            png.parent.mkdir(parents=True, exist_ok=True)
            png.write_bytes(known)
        else:  # pieces of one pass share its file: the last one's plot
            drawn.append((paths[-1].joints_before, paths[-1].joints_after, png, name))
    plot_angular_displacements(drawn)
    if made is not None:
        made.plots.update({name: (named[name], png.read_bytes()) for _, _, png, name in drawn})


def run_finish(spec: str | Path, machine: str | Path, tool: str, out: str | Path, *,
               options: FinishOptions | None = None,
               library: str | Path | None = None, scene: str = "solid", plots: bool = True,
               progress: bool | None = None, fillet_tool: str | None = None,
               stock: str | Path | None = None, machine_obstacle: bool = True,
               design: Impeller | None = None, design_distance: DesignDistance | None = None,
               keep: PassTrim | None = None, prefix: str = "finish",
               memo: PlanMemo | None = None,
               **fields: Any) -> dict[str, Any]:
    """Five-axis finishing of an impeller: APT per operation, finish.json, plots.

    Parameters
    ----------
    spec : str or Path
        Impeller spec TOML.
    machine : str or Path
        Machine TOML (its kinematics define the A and C whose reversals are removed).
    tool : str
        Tool name in the library (or ``library.toml:name``; see ``resolve_tool``).
    out : str or Path
        Output folder.
    options : FinishOptions, optional
        The finishing options (default ``FinishOptions()``; mm, deg).
    library : str or Path, optional
        Tool library (default: fixtures/tools/library.toml).
    scene : str
        ``"solid"``: check against the meshes of the built solid (what the STL
        export writes); ``"surfaces"``: against meshes of the closed-form surfaces
        (no fillets; quick studies).
    plots : bool
        Write the angular displacement PNGs.
    progress : bool, optional
        Show a progress bar (default: when stderr is a terminal).
    fillet_tool : str, optional
        Ball-end mill (radius at most the fillet radius) of the fillet pencil
        passes, operation ``fillet`` (default: no fillet operation).
    stock : str or Path, optional
        The in-process stock (a verified ``stock.npz``, or anything ``impeller-cam
        verify --stock`` takes: a spec's blank, a closed mesh): shank and holder
        keep ``stock_clearance_mm`` from its material beyond ``clearance_mm -
        stock_clearance_mm`` from the design (``scene="solid"`` only).
    machine_obstacle : bool
        With a machine file that has a ``[model]``: every posture, motion and link is
        also checked against the machine's components (``cam.finishing.
        machine_obstacle``; the part's solid from ``stock``, else the spec's blank).
    design : Impeller, optional
        The spec's impeller, already built (``geometry.impeller.Impeller``; the
        chain's, which verified the rough stock with it): its solid and meshes are
        reused (``scene="solid"``; default: built here).
    design_distance : DesignDistance, optional
        The signed distance from ``design.mesh()``, already built (with ``stock``:
        the excess material's depth; default: built here).
    keep : PassTrim, optional
        The points of passage 0's junction, blade and hub passes to machine
        (``plan_finishing``'s ``keep``; the chain's rest operation: where the rough
        stock holds too much, ``cam.run.rest``); default all (or what the swarf
        passes leave).
    prefix : str
        Name of the APT files, ``{prefix}_{operation}.apt`` (``"rest"``: the chain's
        rest operation).
    memo : PlanMemo, optional
        Pass plans kept from an earlier run (recalled instead of planned) and where
        this run's are recorded (``plan_memo``; the chain's rest operation).
    **fields
        Fields of ``FinishOptions`` (mm, deg) replacing those of ``options``, checked
        like a ``[machining.finish]`` table (unknown names refused).

    Returns
    -------
    dict
        The content of finish.json.

    Raises
    ------
    InputError
        Bad spec, machine, tool or option; a ball that does not fit; an unreachable
        posture. Nothing is written then.
    """
    opts = options if options is not None else FinishOptions()
    if fields:
        opts = FinishOptions.from_mapping({**opts.as_dict(), **fields})
    if scene not in SCENE_SOURCES:
        raise InputError("unknown collision scene source", field="--scene", value=scene,
                         accepted=", ".join(SCENE_SOURCES))
    from postproc.kinematics import kinematics_for
    from postproc.machine import load_machine

    the_tool = resolve_tool(tool, library)
    if the_tool.shape != "ball":
        raise InputError("five-axis finishing needs a ball-end mill", field="-t",
                         value=the_tool.name, accepted="a tool of type 'ball'")
    the_machine = load_machine(machine)
    kins = kinematics_for(the_machine)
    the_spec = load_spec(spec)
    fillet = None if fillet_tool is None else resolve_tool(fillet_tool, library)
    if fillet is not None:
        check_fillet_tool(fillet, float(the_spec.fillet_radius))
    the_stock = None
    if stock is not None:
        if scene != "solid":
            raise InputError("an in-process stock needs the solid scene", field="--stock",
                             value=str(stock), accepted="--scene solid (the default)")
        from cam.verify.sources import load_stock

        # a .npz keeps its own resolution; a blank or mesh is cast at half a voxel
        the_stock = load_stock(str(stock), 0.5 * opts.stock_voxel_mm)
    made = None if memo is None else memo.run
    if made is not None:
        made.start()
    impeller, surfaces, meshes, collision = _design_scene(the_spec, str(spec), scene, opts,
                                                        design, made)
    if the_stock is not None:
        collision = _stock_scene(the_stock, impeller, collision, opts, design_distance)
    stock_scene = collision if isinstance(collision, StockScene) else None
    obstacle = None
    if machine_obstacle and the_machine.model is not None:
        collision = obstacle = _machine_obstacle(the_machine.model, kins, collision,
                                                 the_stock, spec)
    if made is not None:
        made.begin(None if obstacle is None else obstacle.part)
    bar = progress_bar(progress)
    with bar if bar is not None else nullcontext():
        task = bar.add_task("finishing", total=None) if bar is not None else None

        def report(done: int, total: int, name: str) -> None:
            if bar is not None:
                bar.update(task, completed=done, total=total, description=name)

        edges = None
        if opts.edge_passes:  # first: the point passes leave to them what they finish
            edges = plan_edges(surfaces, the_tool, kins, collision, opts, scene_source=scene,
                               progress=report, memo=memo)
        flank, plan_opts, left = swarf_setup(surfaces, the_tool, kins, collision, opts,
                                              scene, report, edges)
        if left is not None:
            if keep is not None:
                raise InputError("a pass trim and swarf passes cannot be combined",
                                 field="blade_strategy", value=opts.blade_strategy,
                                 accepted="\"point\" or \"swarf\" with a pass trim")
            keep = left
        # the reach check asks the machine and the part's solid: passed once, passed again
        reached = (str(machine), the_tool.name, repr(plan_opts.as_dict()), repr(keep))
        reach = None if obstacle is None or made is not None and made.machine_valid \
            and reached in made.reach else partial(check_machine_reach, obstacle, the_tool,
                                                   options=opts, machine=str(machine))
        result = plan_finishing(surfaces, the_tool, kins, collision, plan_opts,
                                scene_source=scene, progress=report, keep=keep, before=reach,
                                memo=memo)
        if made is not None and obstacle is not None:
            made.reach.add(reached)
        cut_short: list[dict[str, Any]] = list(result.extra.get("cut_short", []))
        result_kept = result.extra.get("kept")
        result = FinishResult(result.paths, the_tool, opts, scene)
        toolpaths = finish_toolpaths(result, surfaces, collision, kins, made)
        tools = {op: the_tool for op in toolpaths}
        swarf_entry = None
        if flank is not None:
            swarf_entry = {**flank.extra["swarf"], "point_passes": result_kept}
            if flank.paths:
                toolpaths.update(finish_toolpaths(flank, surfaces, collision, kins, made))
                tools.update({op: the_tool for op in flank.operations()})
                result = FinishResult([*result.paths, *flank.paths], the_tool, opts, scene)
        if edges is not None:
            toolpaths.update(finish_toolpaths(edges, surfaces, collision, kins, made))
            tools.update({op: the_tool for op in edges.operations()})
            cut_short += edges.extra["cut_short"]
            result = FinishResult([*result.paths, *edges.paths], the_tool, opts, scene)
        if fillet is not None:
            pencil = plan_fillet(surfaces, fillet, the_tool.radius, kins, collision, opts,
                                 scene_source=scene, progress=report, memo=memo)
            toolpaths.update(finish_toolpaths(pencil, surfaces, collision, kins, made))
            tools.update({op: fillet for op in pencil.operations()})
            cut_short += pencil.extra["cut_short"]
            result = FinishResult([*result.paths, *pencil.paths], the_tool, opts, scene)
        link_collisions = checked_links(collision, tools, toolpaths, opts, made)
    summary = result.summary()
    entries = summary.pop("path_entries")
    summary["left_out_points"] = int(sum(len(e["left_out"]) for e in cut_short))
    summary["dropped_paths"] = [e["path"] for e in cut_short if e["dropped"]]
    stock_entry = (_engagement(stock_scene, result, entries, tools)
                   if stock_scene is not None else None)
    machine_entry = (None if obstacle is None
                     else _machine_entry(obstacle, result, entries, toolpaths, tools, made))
    with staged_directory(out) as stage:
        operations = {}
        for op, (toolpath, air, links) in toolpaths.items():
            name = f"{prefix}_{op}.apt"
            _write_apt(stage / name, toolpath, f"impeller-cam {prefix}: {op}, tool "
                       f"{tools[op].name}", None if made is None else made.operations.get(op))
            operations[op] = {"apt": name, "tool": _tool_entry(tools[op]),
                              "paths": sum(e["operation"] == op for e in entries),
                              "poses": len(toolpath), "link_poses": int(air.sum()),
                              "link_collisions": link_collisions[op],
                              "link_kinds": {
                                  k: sum(1 for x in links if x["kind"] == k)
                                  for k in ("feed", "direct", "clearance", "retract",
                                            "demoted")},
                              "links": links}
        if plots:
            _plots(stage, entries, result, made)
        (stage / "scene.stl").write_bytes(_scene_stl(meshes, made))
        document = {
            "format": "impeller-cam finish 1",
            "spec": str(spec),
            "machine": str(machine),
            "tool": _tool_entry(the_tool),
            "scene": scene,
            "stock": None if stock is None else {"source": str(stock), **(stock_entry or {})},
            "options": opts.as_dict(),
            "paper": PAPER,
            "summary": summary,
            "link_collisions": int(sum(link_collisions.values())),
            "machine_model": machine_entry,
            "swarf": swarf_entry,
            "cut_short": cut_short,
            "operations": operations,
            "paths": entries,
        }
        if fillet is None and the_spec.fillet_radius > 0:
            document["fillet_note"] = (
                f"the fillets (radius {the_spec.fillet_radius:g} mm) are not finished: no "
                f"fillet tool (a ball of diameter <= {2.0 * the_spec.fillet_radius:g} mm; "
                "--fillet-tool, or in the chain the tool library's largest such ball)")
        write_text_atomic(stage / "finish.json", json.dumps(document, indent=2) + "\n")
    return document
