"""The motion stage: cycle times, the UMR index moves, the servo lag (``motion/``).

* Cycle time of every NC program (``cam.motion.breakdown``): look-ahead blending
  within ``G64 P`` under the machine's limits, split into cutting, air (rapids,
  approaches, departures) and rotary-link time; the exact-stop bound and the nominal
  length / feed time.
* Indexing: the A/C index moves between UMRs (and passages) of the rough programs,
  each timed as a synchronised rapid with the machine's limits, and the paper's
  S-curve input search (M5, ``cam.motion.optimise``) on the bundled indexing-table
  plant (impeller_cam/data/motion/indexing_table.toml, a copy of fixtures/motion/: the
  machine file has no TDOF model of its axes). The stroke searched is the longest index
  move, measured as its X/Y/Z travel or the arc its A/C rotation sweeps at the
  impeller's outer radius, whichever is longer (the plant is a linear table: an
  approximation, said so in motion.json).
  The grid is coarse by default (S 0..115 step 5, A 10,000..30,000 step
  5,000, V 200..500 step 50: 4,200 profiles, seconds) - ``indexing_grid = "paper"``
  searches the paper's 4.8 million. Case I, best symmetric and best asymmetric
  positioning times; the chosen profile is the best asymmetric one.
* Servo: the feed-drive prediction (M6, ``cam.motion.program_servo``) of every
  finishing program, all five axes modelled (``cam.motion.axis_models``): contour
  error per NC line (``contour_<program>.csv``), max / median / RMS per program with the
  machine's K_FFP and with the Best K_FFP, and the contour-error map on the blade
  (``contour_map.png``, meridional view). The control's corner speeds allow for the
  drives' smoothing (``corner_smoothing``: the largest Ts of the axes), as a control
  with acc/dec after interpolation plans them (docs/motion.md 6.2).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cam.run.stages import Context, nc_programs
from impeller_cam.atomic import staged_directory, write_text_atomic
from impeller_cam.data import data_path

__all__ = ["COARSE_GRID", "SERVO_DT", "index_moves", "motion_outputs"]

#: (start, stop, step) of S, A (both), V of the coarse indexing grid.
COARSE_GRID = ((0.0, 115.0, 5.0), (10000.0, 30000.0, 5000.0), (200.0, 500.0, 50.0))
#: Controller period of the servo simulation, s (coarser than the 250 us default:
#: the feed-drive time constants are >= 5 ms; 1 ms keeps the chain quick).
SERVO_DT = 1e-3
#: The indexing-table plant shipped in the package (a copy of fixtures/motion/).
PLANT = data_path("motion", "indexing_table.toml")


def index_moves(joints: NDArray[np.float64], start: NDArray[np.float64]
                ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Joints before and after every block that turns a rotary axis (A, C).

    Parameters
    ----------
    joints : (n, 5) float64
        Block targets X, Y, Z (mm), A, C (rad).
    start : (5,) float64
        Joints before the first block.

    Returns
    -------
    before, after : (m, 5) float64
    """
    path = np.vstack([np.asarray(start, np.float64)[None], joints])
    turn = np.abs(np.diff(path[:, 3:], axis=0)).max(axis=1) > 1e-9
    return path[:-1][turn], path[1:][turn]


def _grid(kind: str) -> Any:
    from cam.motion.optimise import Grid, paper_grid, value_range

    if kind == "paper":
        return paper_grid()
    (s0, s1, ds), (a0, a1, da), (v0, v1, dv) = COARSE_GRID
    accel = value_range(a0, a1, da, "amax")
    return Grid(value_range(s0, s1, ds, "s"), accel, accel.copy(), value_range(v0, v1, dv, "v"))


def _indexing(ctx: Context, machine: Any, stage: Path) -> dict[str, Any]:
    from cam.motion.cycle_time import index_moves_time
    from cam.motion.optimise import optimise
    from cam.motion.plant import load_plant
    from cam.motion.plots import plot_time_over_av, plot_time_vs_s
    from cam.motion.positioning import settling_from_dict
    from postproc.nc_reader import read_nc

    before, after = [], []
    for entry in nc_programs(ctx, "rough"):
        program = read_nc(ctx.out / entry["nc"], machine=machine)
        b, a = index_moves(program.joints, program.start)
        before.append(b)
        after.append(a)
    start, end = np.concatenate(before), np.concatenate(after)
    out: dict[str, Any] = {"index_moves": int(len(start))}
    if not len(start):
        return out
    times = index_moves_time(start, end, machine)
    delta = end - start
    out.update({
        "machine_time_s": float(times.sum()),
        "longest_move_s": float(times.max()),
        "largest_A_deg": float(np.degrees(np.abs(delta[:, 3]).max())),
        "largest_C_deg": float(np.degrees(np.abs(delta[:, 4]).max())),
    })
    from geometry.spec import load_spec

    spec = load_spec(ctx.spec)
    radius = float(max(spec.hub_contour[:, 1].max(), spec.shroud_contour[:, 1].max()))
    arc = radius * np.abs(delta[:, 3:]).max(axis=1)
    stroke = float(np.maximum(np.linalg.norm(delta[:, :3], axis=1), arc).max())
    if not (PLANT.is_file() and stroke > 0):
        out["optimisation"] = None
        out["note"] = "no indexing plant bundled or no linear stroke: search skipped"
        return out
    plant, document = load_plant(PLANT)
    settling = settling_from_dict(document, PLANT)
    grid = _grid(ctx.settings.indexing_grid)
    result = optimise(plant, stroke, grid, settling, pid_period=settling.dt, workers=0)
    data = result.as_dict()
    positioning = data["positioning_time_s"]
    n = len(start)
    out.update({
        "plant": "indexing_table.toml (bundled: impeller_cam/data/motion, a copy of "
                 "fixtures/motion)",
        "stroke_mm": stroke,
        "stroke_basis": "longest index move: X/Y/Z travel or the arc its A/C rotation "
                        f"sweeps at the impeller's outer radius ({radius:.1f} mm)",
        "grid": ctx.settings.indexing_grid,
        "grid_note": ("coarse grid (4,200 profiles) so that the stage takes seconds; "
                      "indexing_grid = \"paper\" searches the paper's grid")
        if ctx.settings.indexing_grid == "coarse" else "the paper's grid",
        "case_I_s": positioning["case_max"],
        "best_symmetric_s": positioning["best_symmetric"],
        "best_asymmetric_s": positioning["best"],
        "chosen": "best_asymmetric",
        "chosen_profile": data["best"],
        "improvement_vs_case_I": data["improvement_vs_case_max"],
        "total_case_I_s": n * positioning["case_max"],
        "total_chosen_s": n * positioning["best"],
        "optimisation": data,
        "plots": ["indexing_time_vs_s.png", "indexing_time_over_av.png"],
    })
    plot_time_vs_s(result, stage / "indexing_time_vs_s.png")
    plot_time_over_av(result, stage / "indexing_time_over_av.png")
    return out


def _rms(values: NDArray[np.float64]) -> float:
    return float(np.sqrt(np.mean(values**2))) if len(values) else 0.0


def _per_line_csv(path: Path, report: Any, feed: NDArray[np.bool_],
                  contact: Any | None) -> None:
    """Per NC line of the feed blocks: commanded tip, the predicted errors and, with a
    design, the ball's gap to it and the error along its normal (contact blocks)."""
    tuned = report.deviation_recommended
    rows = ["line,tip_x_mm,tip_y_mm,tip_z_mm,contour_um,tool_axis_deg,contour_best_kffp_um,"
            "tool_axis_best_kffp_deg,gap_mm,contact,surface_um,surface_best_kffp_um"]
    for i in np.flatnonzero(feed):
        x, y, z = report.tip[i]
        best = "," if tuned is None else (f"{1000.0 * tuned[i]:.3f},"
                                          f"{report.tool_axis_recommended[i]:.5f}")
        on = ",,,"
        if contact is not None and report.surface is not None:
            tuned_surface = "" if report.surface_recommended is None else \
                f"{1000.0 * report.surface_recommended[i]:.3f}"
            on = (f"{contact.gap[i]:.4f},{int(contact.contact[i])},"
                  f"{1000.0 * report.surface[i]:.3f},{tuned_surface}")
        rows.append(f"{report.line[i]},{x:.4f},{y:.4f},{z:.4f},"
                    f"{1000.0 * report.deviation[i]:.3f},{report.tool_axis[i]:.5f},{best},{on}")
    write_text_atomic(path, "\n".join(rows) + "\n")


def _stats_um(values: NDArray[np.float64], prefix: str) -> dict[str, float | None]:
    """max / RMS / median / 99th percentile of per-block values (mm) in um."""
    if not len(values):
        return {f"{prefix}_{k}_um": None for k in ("max", "rms", "median", "p99")}
    um = 1000.0 * values
    return {f"{prefix}_max_um": float(um.max()), f"{prefix}_rms_um": _rms(um),
            f"{prefix}_median_um": float(np.median(um)),
            f"{prefix}_p99_um": float(np.percentile(um, 99))}


def _design_distance(ctx: Context) -> Any:
    """Signed distance from the design: the run's STL (geometry stage), else the spec."""
    from cam.verify.deviation import DesignDistance
    from cam.verify.sources import load_design

    stl = ctx.out / "geometry" / "impeller.stl"
    vertices, faces, _ = load_design(stl if stl.is_file() else ctx.spec)
    return DesignDistance(vertices, faces)


def _contact(ctx: Context, entry: dict[str, Any], program: Any, machine: Any,
             design: Any) -> Any | None:
    """Contact of each block's ball with the design (``surface_error.block_contact``);
    None without the APT (no cutter) or for a cutter that is not a ball."""
    from cam.motion.program_servo import program_joints
    from cam.motion.surface_error import block_contact
    from postproc.apt import read_apt
    from postproc.kinematics import kinematics_for
    from postproc.program import Motion

    apt = ctx.out / entry["apt"] if entry.get("apt") else None
    if apt is None or not apt.is_file():
        return None
    cutter = read_apt(apt)[0].cutter
    if cutter is None or cutter.corner_radius < 0.5 * cutter.diameter - 1e-9:
        return None
    tip, axis = kinematics_for(machine).forward(program_joints(program, machine))
    return block_contact(tip, axis, program.motion == int(Motion.LINEAR),
                         cutter.corner_radius, design)


def _surface_row(report: Any, contact: Any, feed: NDArray[np.bool_]) -> dict[str, Any]:
    """motion.json entries of the contact / air split (``cam.motion.surface_error``)."""
    air = feed & ~contact.contact
    row: dict[str, Any] = {"ball_radius_mm": contact.radius,
                           "contact_blocks": int(contact.contact.sum()),
                           "air_blocks": int(air.sum())}
    row.update(_stats_um(report.surface[contact.contact], "surface"))
    row["surface_rms_samples_um"] = 1000.0 * float(report.surface_rms or 0.0)
    if report.gouge is not None:
        row.update(_stats_um(report.gouge[contact.contact], "into_part"))
    row.update(_stats_um(report.deviation[contact.contact], "contour_contact"))
    row.update(_stats_um(report.deviation[air], "contour_air"))
    row["air_blocks_error_over_gap"] = int(np.sum(air & (report.deviation > contact.gap)))
    if contact.contact.any():
        worst = np.flatnonzero(contact.contact)[int(np.argmax(report.surface[contact.contact]))]
        row["surface_worst_line"] = int(report.line[worst])
    if report.surface_recommended is not None:
        row.update(_stats_um(report.surface_recommended[contact.contact], "surface_best_kffp"))
        row["surface_rms_samples_best_kffp_um"] = \
            1000.0 * float(report.surface_rms_recommended or 0.0)
    return row


def _servo(ctx: Context, machine: Any, stage: Path) -> dict[str, Any]:
    """Contour error of every finishing program, all five axes modelled (issue 26)."""
    from cam.motion.axis_models import machine_axis_models
    from cam.motion.plots import plot_contour_map
    from cam.motion.program_servo import (
        corner_smoothing_time,
        simulate_program,
    )
    from geometry.spec import load_spec
    from postproc.nc_reader import read_nc
    from postproc.program import Motion

    finish = nc_programs(ctx, "finish")
    if not ctx.settings.servo or not finish:
        return {"program": None, "note": "servo prediction not asked"}
    if not any(spec.servo for spec in machine.axes.values()):
        return {"program": None, "note": "the machine file has no servo data (no "
                "[axes.<NAME>.servo] table: nothing to model the axes on)"}
    models = machine_axis_models(machine)
    corner = corner_smoothing_time(models.models)
    design = _design_distance(ctx)
    programs, tips, errors, tuned_errors = [], [], [], []
    surface_tips, surface_errors = [], []
    for entry in finish:
        program = read_nc(ctx.out / entry["nc"], machine=machine)
        contact = _contact(ctx, entry, program, machine, design)
        report = simulate_program(program, machine, dt=SERVO_DT, models=models,
                                  contact=contact, corner_smoothing=corner)
        feed = program.motion == int(Motion.LINEAR)
        if not feed.any():
            continue
        dev, tuned = report.deviation[feed], report.deviation_recommended
        csv_name = f"contour_{Path(entry['nc']).stem}.csv"
        _per_line_csv(stage / csv_name, report, feed, contact)
        row: dict[str, Any] = {
            "program": entry["nc"], "blocks": int(feed.sum()),
            "max_contour_um": 1000.0 * float(dev.max()),
            "rms_contour_um": 1000.0 * report.feed_rms,
            "median_contour_um": 1000.0 * float(np.median(dev)),
            "p99_contour_um": 1000.0 * float(np.percentile(dev, 99)),
            "worst_line": int(report.line[feed][int(np.argmax(dev))]),
            "max_tool_axis_deg": float(report.tool_axis[feed].max()),
            "omega_rad_s": report.omega,
            "kffp_best": report.recommended_kffp,
            "saturated_in_feed": [a for a, hit in report.saturated.items() if hit],
            "per_line": csv_name,
        }
        tuned_axis = report.tool_axis_recommended
        if tuned is not None and tuned_axis is not None:
            row.update({
                "max_contour_best_kffp_um": 1000.0 * float(tuned[feed].max()),
                "rms_contour_best_kffp_um": 1000.0 * float(report.feed_rms_recommended or 0),
                "median_contour_best_kffp_um": 1000.0 * float(np.median(tuned[feed])),
                "max_tool_axis_best_kffp_deg": float(tuned_axis[feed].max()),
                "p99_contour_best_kffp_um": 1000.0 * float(np.percentile(tuned[feed], 99)),
            })
            tuned_errors.append(tuned[feed])
        if contact is not None and report.surface is not None:
            row["on_the_part"] = _surface_row(report, contact, feed)
            surface_tips.append(report.tip[contact.contact])
            surface_errors.append(report.surface[contact.contact])
        programs.append(row)
        tips.append(report.tip[feed])
        errors.append(dev)
    if not programs:
        return {"program": None, "note": "no feed blocks in the finishing programs"}
    spec = load_spec(ctx.spec)
    plot_contour_map(tips, errors, tuned_errors if len(tuned_errors) == len(errors) else
                     None, spec.hub_contour, spec.shroud_contour, stage / "contour_map.png",
                     "predicted contour error of the finishing programs, per NC block "
                     "(meridional view, all blades)")
    plots = []
    if surface_errors:
        plot_contour_map(surface_tips, surface_errors, None, spec.hub_contour,
                         spec.shroud_contour, stage / "surface_map.png",
                         "error along the surface normal, blocks on the part\n"
                         "(meridional view, all blades)", quantity="normal error")
        plots.append("surface_map.png")
    every = np.concatenate(errors)
    out: dict[str, Any] = {
        "program": "all finishing programs",
        "dt_s": SERVO_DT,
        "feed_profile": "lookahead",
        "corner_smoothing_s": corner,
        "axis_models": models.source,
        "kffp_machine": {a.name: a.k_ffp for a in models.models.values()},
        "max_contour_um": 1000.0 * float(every.max()),
        "programs": programs,
        "plot": "contour_map.png",
        "plots": plots,
        "on_the_part_note": "on_the_part: feed blocks whose commanded ball (tip + R axis) "
                            "lies within 0.02 mm of the design surface; surface_* = the "
                            "simulated ball centre's deviation along the surface normal "
                            "(what the part shows; a deviation along the surface leaves "
                            "no mark), per block the largest; into_part_* = its part "
                            "pointing into the part (a gouge; the rest leaves material "
                            "standing); contour_air_* = the full "
                            "contour error of the other feed blocks (approaches, "
                            "departures, links), air_blocks_error_over_gap = those whose "
                            "error exceeds their gap to the design",
        "note": "contour error = distance of the simulated tool tip from the commanded "
                "tip path (normal to it; lag along the path is not a shape error), "
                "largest per NC block over feed blocks; RMS over the feed samples; every "
                "axis modelled (axis_models: identified or a default matched to the "
                "most lagging identified axis of its kind); Best K_FFP per program at "
                "its characteristic rotary speed; commanded motion: the control's "
                "look-ahead (path speed continuous, jerk-limited at the axes' limits, "
                "corners blended within G64 P, their speeds allowing for the drives' "
                "smoothing corner_smoothing_s)",
    }
    if len(tuned_errors) == len(errors):
        out["max_contour_best_kffp_um"] = 1000.0 * float(np.concatenate(tuned_errors).max())
    return out


def motion_outputs(ctx: Context) -> dict[str, Any]:
    """Write motion/motion.json and its PNGs; returns motion.json content."""
    from cam.motion.breakdown import program_file_times
    from postproc.machine import load_machine

    machine = load_machine(ctx.machine)
    programs = []
    for entry in nc_programs(ctx):
        apt = ctx.out / entry["apt"] if entry.get("apt") else None
        times = program_file_times(ctx.out / entry["nc"], apt, machine, entry["operation"])
        programs.append({"nc": entry["nc"], "operation": entry["operation"],
                         "name": entry["name"], **times})
    with staged_directory(ctx.out / "motion") as stage:
        document: dict[str, Any] = {
            "format": "impeller-cam motion 1",
            "machine": str(ctx.machine),
            "programs": programs,
            "total_s": float(sum(p["cycle_time_s"] for p in programs)),
            "total_exact_stop_s": float(sum(p["exact_stop_s"] for p in programs)),
            "total_nominal_s": float(sum(p["nominal_s"] for p in programs)),
            "cycle_time_basis": "look-ahead blending within G64 P (cam/motion/blending.py); "
                                "exact_stop = jerk-limited stop at every block (upper "
                                "bound); nominal = length / feed",
            "indexing": _indexing(ctx, machine, stage),
            "servo": _servo(ctx, machine, stage),
        }
        text = json.dumps(document, indent=2, allow_nan=False,
                          default=lambda x: None if isinstance(x, float) and not
                          math.isfinite(x) else str(x))
        write_text_atomic(stage / "motion.json", text + "\n")
    return document
