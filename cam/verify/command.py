"""``impeller-cam verify``: run NC programs through the stock and report what happened.

``run_verify`` reads each NC program (``postproc.nc_reader``), maps its blocks to
tool moves in the workpiece frame (``cam.verify.motion``), sweeps the tool through
the tri-dexel stock (``cam.verify.stock``), and collects events: rapids that cut,
shank or holder touching stock, over-travel, and, with a design, gouges and excess
material (``cam.verify.deviation``). It writes, atomically into ``out``:
verify.json, report.html, verify.junit.xml, stock.npz (the final stock state, the
``--stock`` of a following run) and PNG renders.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cam.verify.deviation import DesignDistance, Deviation, sample_deviation
from cam.verify.events import (
    EVENT_TYPES,
    Event,
    capped,
    deviation_events,
    motion_events,
    sort_events,
)
from cam.verify.machine_check import (
    check_program,
    machine_scene_for,
    machine_summary,
    render_worst_pose,
    scene_summary,
)
from cam.verify.motion import program_moves
from cam.verify.sources import load_design, load_stock
from cam.verify.stock import Stock
from cam.verify.swept import SWEPT, file_digest, record, resume
from cam.verify.toolshape import tool_shape
from impeller_cam.atomic import staged_directory, write_bytes_atomic, write_text_atomic
from impeller_cam.errors import InputError
from impeller_cam.progress import progress_bar
from impeller_cam.tolerances import DEFAULT_TOLERANCES

#: Sub-moves swept per kernel call (progress granularity; each call also scans the
#: grids once for their material bounds, so fewer calls cost less).
BATCH = 20000


@dataclass(frozen=True)
class VerifyOptions:
    """Tolerances of a verification run (mm).

    Attributes
    ----------
    sweep_tolerance : float or None
        Bound on the distance between the swept and the true tool inside a 5-axis
        block (``cam.verify.motion``); ``None``: a tenth of the resolution.
    contact_tolerance : float
        A rapid cut or a shank/holder overlap counts when longer than this along a
        dexel ray.
    gouge_tolerance : float
        Stock surface deeper than this inside the design is a gouge; more than the
        allowance plus this outside it is excess. It must exceed the design mesh's
        tessellation error.
    allowance : float or None
        Finishing allowance; ``None``: the design spec's ``finishing_allowance`` (0
        for a mesh design).
    render : bool
        Write PNG renders (and embed them in report.html).
    render_each_program : bool
        Render the stock after every program (else only after the last one: a chain
        with dozens of roughing programs shows the last state only).
    refuse_short_stock : bool
        Raise ``InputError`` (nothing written) when the initial stock is short of the
        design (``stock_short`` events) instead of reporting it: the chain verifying
        its own blank.
    record : bool
        Also write ``swept.json`` (``cam.verify.swept``): what each program found,
        exactly, for a later run that begins with the same programs to take over.
    """

    sweep_tolerance: float | None = None
    contact_tolerance: float = DEFAULT_TOLERANCES.contact
    gouge_tolerance: float = DEFAULT_TOLERANCES.gouge
    allowance: float | None = None
    render: bool = True
    render_each_program: bool = True
    refuse_short_stock: bool = False
    record: bool = False


def _check_inputs(programs: list[Path], resolution: float) -> None:
    if not programs:
        raise InputError("no NC program given", field="PROGRAM", accepted="one or more NC files")
    for program in programs:
        if not Path(program).is_file():
            raise InputError("NC program not found", file=program, field="PROGRAM")
    if not (np.isfinite(resolution) and 0.005 <= resolution <= 5.0):
        raise InputError(
            "resolution out of range",
            field="--resolution",
            value=resolution,
            accepted="0.005 <= MM <= 5 (default 0.1)",
        )


def _sweep_program(
    stock: Stock, moves: Any, shape: Any, block_offset: int, bar: Any, label: str
) -> NDArray[np.float64]:
    """Sweep all sub-moves; returns per-block stats (removed mm^3, longest cut, overlap)."""
    n_sub = len(moves.tips)
    ids = (moves.block + block_offset).astype(np.int32)
    stats = np.zeros((n_sub, 3))
    task = bar.add_task(label, total=n_sub) if bar is not None else None

    def done(swept: int) -> None:
        if bar is not None:
            bar.update(task, completed=swept)

    # BATCH sub-moves a compiled call; the grids go through the batches independently
    if n_sub:
        stats[:] = stock.sweep(moves.tips, moves.moves, moves.axes, ids, shape, batch=BATCH,
                               done=done, parts=moves.part)
    n_blocks = len(moves.end_tip)
    per_block = np.zeros((n_blocks, 3))
    np.add.at(per_block[:, 0], moves.block, stats[:, 0])
    np.maximum.at(per_block[:, 1], moves.block, stats[:, 1])
    np.maximum.at(per_block[:, 2], moves.block, stats[:, 2])
    return per_block


def _short_stock(work: Stock, distance: DesignDistance, opts: VerifyOptions, program: str,
                 stock: str) -> list[Event]:
    """``stock_short`` events of the initial stock (``cam.verify.shortfall``); with
    ``opts.refuse_short_stock`` an ``InputError`` naming the deepest place instead."""
    from cam.verify.shortfall import below_design_top, stock_short_events

    points, moves = work.surface_points()
    maybe = below_design_top(points, distance.triangles)
    signed, _ = distance.closest(points[maybe])
    found = stock_short_events(points[maybe], signed, moves[maybe], opts.gouge_tolerance,
                               program)
    if found and opts.refuse_short_stock:
        deepest = found[0]
        where = ", ".join(f"{v:.2f}" for v in deepest.position)
        raise InputError(
            f"the stock does not contain the design: short at {len(found)} place(s), up to "
            f"{deepest.amount:.3f} mm inside the part (deepest at x, y, z = {where} mm); "
            "no program can put that material back",
            field="stock", value=stock,
            accepted="a stock that contains the design (a spec's blank: "
                     "geometry.blank.spec_blank_profile)")
    return found


def run_verify(
    programs: list[Path],
    machine: Path,
    tool: str | list[str],
    stock: str,
    design: Path | None,
    resolution: float,
    out: Path,
    *,
    options: VerifyOptions | None = None,
    progress: bool | None = None,
    design_distance: DesignDistance | None = None,
    initial_stock: Stock | None = None,
    previous: Deviation | None = None,
    resume_from: Path | None = None,
) -> Deviation | None:
    """Verify NC programs in sequence on one stock; write the results into ``out``.

    Parameters
    ----------
    programs : list of Path
        NC files, run in order on the same stock.
    machine : Path
        Machine TOML (kinematics, limits).
    tool : str or list of str
        ``-t`` argument: ``NAME`` or ``LIBRARY.toml:NAME``; a list: the tool of each
        program (a chain's finish programs with their fillet tool).
    stock : str
        ``--stock`` argument (``cam.verify.sources.load_stock``).
    design : Path or None
        Impeller spec TOML or closed mesh for gouge/excess/deviation.
    resolution : float
        Dexel spacing, mm (0.1 default, 0.05 supported).
    out : Path
        Output folder.
    options : VerifyOptions, optional
        Tolerances (defaults documented there).
    progress : bool, optional
        Show a progress bar (default: only on a TTY).
    design_distance : DesignDistance, optional
        The signed distance from ``design``, already built (the chain builds the
        design once for both of its runs and its per-face summary); ``design`` then
        only names it, and the allowance comes from ``options``.
    initial_stock : Stock, optional
        The stock to start from, already in memory; it is swept in place and ends as
        the final state (the chain hands the stock its rough run left to its finish
        run instead of saving and loading it). ``stock`` then only names it in
        verify.json.
    previous : Deviation, optional
        The deviation of ``initial_stock`` as it was handed in (what the run that left
        it returned): the ends no program of this run changes keep its distances
        (``cam.verify.deviation.sample_deviation``), the same answers, queried once.
    resume_from : Path, optional
        The folder of an earlier run (``VerifyOptions.record``) that may have swept the
        first programs from the same ``stock`` file: when its record matches
        (``cam.verify.swept.resume``), this run starts from that run's final stock and
        reports those programs from its record, with the results of sweeping them
        (only with ``render_each_program`` off: the stock between them is not kept).

    Returns
    -------
    Deviation or None
        The final stock's surface samples with their signed distance from the design
        and the design face closest to each (``None`` without a design).

    Raises
    ------
    InputError
        Bad input (missing file, unknown tool, malformed program...): nothing written.
    """
    from cam.tools import resolve_tool
    from postproc.kinematics import kinematics_for
    from postproc.machine import load_machine
    from postproc.nc_reader import read_nc

    opts = options or VerifyOptions()
    programs = [Path(p) for p in programs]
    _check_inputs(programs, resolution)
    the_machine = load_machine(machine)
    kins = kinematics_for(the_machine)
    names = list(tool) if isinstance(tool, list) else [tool] * len(programs)
    if len(names) != len(programs):
        raise InputError("one tool per program", field="-t", value=len(names),
                         accepted=f"{len(programs)} tool names")
    the_tools = [resolve_tool(name) for name in names]
    shapes = [tool_shape(t) for t in the_tools]
    read = [read_nc(p, machine=the_machine) for p in programs]  # all programs parse before any work
    design_mesh = (load_design(design) if design is not None and design_distance is None
                   else None)
    work = load_stock(stock, resolution) if initial_stock is None else initial_stock
    start = work  # the stock this run starts from (a resumed run: its head's start)
    sweep_tol = opts.sweep_tolerance or 0.1 * work.pitch
    # how this run starts, as a record holds it (only to write or take one over)
    settings = {"resolution_mm": work.pitch, "sweep_tolerance_mm": sweep_tol,
                "contact_tolerance_mm": opts.contact_tolerance, "render": opts.render,
                "machine_sha256": file_digest(machine)} \
        if opts.record or resume_from is not None else {}
    swept = None
    if resume_from is not None and not opts.render_each_program and Path(stock).is_file():
        swept = resume(Path(resume_from), programs, [t.name for t in the_tools], start,
                       Path(stock), settings)
        if swept is not None:
            work = Stock.load(Path(resume_from) / "stock.npz")
    # one machine scene per tool (the holder and tool solids ride on the spindle)
    scenes = {t.name: machine_scene_for(the_machine, t, start) for t in the_tools}
    scene = scenes[the_tools[0].name] if the_tools else None
    initial = start.volume()
    distance: DesignDistance | None = design_distance
    spec_allowance: float | None = None
    if design_mesh is not None:
        distance = DesignDistance(design_mesh[0], design_mesh[1])
        spec_allowance = design_mesh[2]

    events: list[Event] = []
    if distance is not None and not str(stock).lower().endswith(".npz"):
        # a saved state was checked when its own initial stock was
        events.extend(_short_stock(work, distance, opts, programs[0].name, stock))
    owners: list[tuple[str, int]] = list(work.owners)  # blocks of earlier runs first
    earlier = len(start.owners)
    head = 0 if swept is None else len(swept.programs)
    durations: list[float] = []  # exact, for the record
    machine_pngs: list[str] = []
    summaries: list[dict[str, Any]] = []
    images: list[tuple[str, bytes]] = []
    renders: dict[str, bytes] = {}
    surface: tuple[NDArray[np.float64], NDArray[np.int64]] | None = None
    cycle = 0.0
    first = len(events)  # the programs' own events start here
    bar = progress_bar(progress)
    if bar is not None:
        bar.start()
    try:
        for index, (path, program) in enumerate(zip(programs, read, strict=True)):
            shape = shapes[index]
            scene = scenes[the_tools[index].name]
            if swept is not None and index < head:  # swept by the recorded run
                summaries.append(swept.summaries[index])
                durations.append(swept.durations[index])
                cycle += swept.durations[index]
                events.extend(e for e in swept.events if e.program == path.name)
                png = swept.renders[index]
                machine_pngs.append(f"machine_{index + 1}_{path.stem}.png" if png else "")
                if opts.render and png:
                    renders[machine_pngs[-1]] = png
                    images.append((f"machine at the smallest clearance of {path.name}", png))
                continue
            moves = program_moves(program, the_machine, kins, shape.reach, sweep_tol,
                                  level_reach=shape.level_reach)
            before = work.volume()
            per_block = _sweep_program(work, moves, shape, len(owners), bar, path.name)
            owners.extend((path.name, int(line)) for line in program.line)
            after = work.volume()
            program_events = motion_events(
                path.name, program, moves, per_block, opts.contact_tolerance
            )
            machine_check = None
            if scene is not None:
                machine_check = check_program(scene, kins, program, path.name)
                program_events += machine_check.events
            events.extend(sort_events(program_events))
            duration = float(moves.duration.sum())
            cycle += duration
            durations.append(duration)
            machine_pngs.append("")
            summaries.append({
                "name": path.name,
                "blocks": len(program),
                "sub_moves": int(np.sum(moves.part & 1)) if moves.part is not None
                else len(moves.tips),
                "removed_volume_mm3": round(before - after, 3),
                "cycle_time_s": round(duration, 3),
                **({} if machine_check is None else machine_summary(machine_check)),
            })
            if opts.render and scene is not None and machine_check is not None \
                    and machine_check.pair[0]:
                png = render_worst_pose(scene, kins, machine_check, path.name)
                machine_pngs[-1] = f"machine_{index + 1}_{path.stem}.png"
                renders[machine_pngs[-1]] = png
                images.append((f"machine at the smallest clearance of {path.name}", png))
            if opts.render and (opts.render_each_program or index == len(programs) - 1):
                surface = _stock_surface(work)  # the last one is the final stock's
                png = _render_stock(surface, f"after {path.name}")
                renders[f"stock_{index + 1}_{path.stem}.png"] = png
                images.append((f"stock after {path.name}", png))
    finally:
        if bar is not None:
            bar.stop()
    last = len(events)

    deviation_summary: dict[str, Any] = {}
    deviation: Deviation | None = None
    if distance is not None:
        allowance = opts.allowance if opts.allowance is not None else (spec_allowance or 0.0)
        points, moves_of = work.surface_points()
        deviation = sample_deviation(points, moves_of, distance,
                                    previous if initial_stock is not None else None, earlier)
        deviation_summary = deviation.summary()
        deviation_summary["allowance_mm"] = allowance
        found = deviation_events(
            deviation, owners, opts.gouge_tolerance, allowance, programs[-1].name
        )
        events.extend(sort_events(found))
        if opts.render:
            surface = surface if surface is not None else _stock_surface(work)
            values = _surface_deviation(surface[0], deviation)
            for view in ("iso", "top", "front"):
                png = _render_deviation(surface, values, view, allowance)
                renders[f"deviation_{view}.png"] = png
                images.append((f"deviation from the design ({view})", png))
    elif opts.render:
        surface = surface if surface is not None else _stock_surface(work)
        for view in ("top", "front"):
            png = _render_stock(surface, f"final stock ({view})", view)
            renders[f"stock_final_{view}.png"] = png
            images.append((f"final stock ({view})", png))

    work.owners = owners
    texts = {}
    if opts.record:
        texts[SWEPT] = record(programs, [t.name for t in the_tools], durations, summaries,
                              events[first:last], machine_pngs,
                              {**settings, "start_owners": earlier,
                               "start_sha256": file_digest(stock)
                               if Path(stock).is_file() else None})
    kept, counts = capped(events)
    # events of blocks from an earlier run (a loaded .npz stock) sort first
    order = {p.name: i for i, p in enumerate(programs)}
    type_order = {t: i for i, t in enumerate(EVENT_TYPES)}
    kept.sort(key=lambda e: (order.get(e.program, -1), e.line, type_order[e.type], -e.amount))
    remaining = work.volume()
    result: dict[str, Any] = {
        "format": "impeller-cam verify",
        "version": 1,
        "programs": summaries,
        "machine": str(machine),
        "tool": ", ".join(dict.fromkeys(t.name for t in the_tools)),
        "stock": str(stock),
        "design": None if design is None else str(design),
        "resolution_mm": work.pitch,
        "sweep_tolerance_mm": sweep_tol,
        "contact_tolerance_mm": opts.contact_tolerance,
        "gouge_tolerance_mm": opts.gouge_tolerance,
        "initial_volume_mm3": round(initial, 3),
        "removed_volume_mm3": round(initial - remaining, 3),
        "remaining_volume_mm3": round(remaining, 3),
        "cycle_time_s": round(cycle, 3),
        "event_counts": counts,
        "events": [e.to_json() for e in kept],
        "deviation": deviation_summary,
    }
    if scene is not None:
        result["machine_model"] = scene_summary(scene)
    _write_outputs(Path(out), work, result, kept, [p.name for p in programs], images, renders,
                   texts)
    return deviation


def _write_outputs(
    out: Path,
    work: Stock,
    result: dict[str, Any],
    events: list[Event],
    names: list[str],
    images: list[tuple[str, bytes]],
    renders: dict[str, bytes],
    texts: dict[str, str],
) -> None:
    from cam.verify.report import junit_xml, report_html, verify_json

    with staged_directory(out) as stage:
        write_text_atomic(stage / "verify.json", verify_json(result))
        write_text_atomic(stage / "verify.junit.xml", junit_xml(names, events, 0.0))
        write_text_atomic(stage / "report.html", report_html(result, images))
        work.save(stage / "stock.npz")
        for name, png in sorted(renders.items()):
            write_bytes_atomic(stage / name, png)
        for name, text in texts.items():
            write_text_atomic(stage / name, text)


def _stock_surface(work: Stock) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Render surface of the stock as it is: vertices (v, 3) mm, faces (f, 3)."""
    from cam.verify.surface import stock_surface

    return stock_surface(work.grids[2], work.lower[2], work.upper[2])


def _render_stock(surface: tuple[NDArray[np.float64], NDArray[np.int64]], title: str,
                  view: str = "iso") -> bytes:
    """PNG of a stock surface (``_stock_surface``)."""
    from cam.verify.report import render_mesh

    return render_mesh(surface[0], surface[1], view=view, title=title)


def _surface_deviation(vertices: NDArray[np.float64], deviation: Deviation
                       ) -> NDArray[np.float64] | None:
    """Signed deviation (v,) mm of the dexel sample nearest to each render vertex
    (``None`` without vertices or samples)."""
    from scipy.spatial import cKDTree

    if len(vertices) == 0 or len(deviation.points) == 0:
        return None
    # sliding-midpoint tree without shrunk boxes: built in about a third of the time of
    # the default (median splits) over the tens of millions of samples of a finished
    # stock; a vertex equidistant from two samples may take the other one's colour
    tree = cKDTree(deviation.points, balanced_tree=False, compact_nodes=False)
    _, nearest = tree.query(vertices)
    return np.asarray(deviation.distance[nearest])


def _render_deviation(surface: tuple[NDArray[np.float64], NDArray[np.int64]],
                      values: NDArray[np.float64] | None, view: str, allowance: float
                      ) -> bytes:
    """Stock surface coloured by the signed deviation of the nearest dexel sample
    (``_surface_deviation``)."""
    from cam.verify.report import render_mesh

    vertices, faces = surface
    if values is None:
        return render_mesh(vertices, faces, view=view, title="deviation")
    limit = max(4.0 * max(allowance, 0.05), 0.1)
    return render_mesh(vertices, faces, view=view, scalars=values, limit=limit,
                       title=f"deviation from design ({view}), mm")
