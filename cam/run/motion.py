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
* Servo: the feed-drive prediction (M6, ``cam.motion.program_servo``) of the
  finishing junction program (the one that turns C and A most): Best K_FFP per axis and
  the predicted contour deviation of the tool tip over its feed blocks.
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
        program = read_nc(ctx.out / entry["nc"])
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


def _servo_plot(line: NDArray[np.int64], deviation: NDArray[np.float64],
                tuned: NDArray[np.float64] | None, feed: NDArray[np.bool_], path: Path,
                title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 3.5))
    ax.plot(line[feed], 1000.0 * deviation[feed], lw=0.8, label="machine K_FFP")
    if tuned is not None:
        ax.plot(line[feed], 1000.0 * tuned[feed], lw=0.8, label="Best K_FFP")
    ax.set_xlabel("NC line")
    ax.set_ylabel("contour deviation, um")
    ax.set_title(title)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, format="png", dpi=110, metadata={"Software": None})
    plt.close(fig)


def _servo(ctx: Context, machine: Any, stage: Path) -> dict[str, Any]:
    from cam.motion.program_servo import servo_axes, simulate_program
    from postproc.nc_reader import read_nc
    from postproc.program import Motion

    finish = nc_programs(ctx, "finish")
    if not ctx.settings.servo or not finish:
        return {"program": None, "note": "servo prediction not asked"}
    if not servo_axes(machine):
        return {"program": None, "note": "the machine file has no servo data"}
    entry = next((p for p in finish if p["name"].endswith("junction")), finish[0])
    program = read_nc(ctx.out / entry["nc"])
    report = simulate_program(program, machine, dt=SERVO_DT)
    feed = program.motion == int(Motion.LINEAR)
    dev = report.deviation[feed]
    tuned = report.deviation_recommended
    _servo_plot(report.line, report.deviation, tuned, feed, stage / "servo.png",
                f"predicted servo deviation, {Path(entry['nc']).name}")
    worst = int(np.argmax(dev)) if len(dev) else -1
    out: dict[str, Any] = {
        "program": entry["nc"],
        "dt_s": SERVO_DT,
        "kffp_best": report.recommended_kffp,
        "kffp_machine": {a.name: a.k_ffp for a in servo_axes(machine).values()},
        "reference_axis": report.reference_axis,
        "omega_rad_s": report.omega,
        "max_deviation_mm": float(dev.max()) if len(dev) else 0.0,
        "rms_deviation_mm": float(np.sqrt(np.mean(dev**2))) if len(dev) else 0.0,
        "worst_line": int(report.line[feed][worst]) if worst >= 0 else None,
        "ideal_axes": report.ideal_axes,
        "saturated": report.saturated,
        "plot": "servo.png",
        "note": "contour deviation over feed blocks (rapids excluded); axes without "
                "servo data follow their command",
    }
    if tuned is not None and feed.any():
        out["max_deviation_best_kffp_mm"] = float(tuned[feed].max())
        out["rms_deviation_best_kffp_mm"] = float(np.sqrt(np.mean(tuned[feed] ** 2)))
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
