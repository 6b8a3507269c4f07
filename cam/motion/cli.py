"""``impeller-cam motion ...``: S-curve, positioning-time search, servo, cycle time.

A typer sub-app; the lead mounts it with ``app.add_typer(motion_app, name="motion")``.
Module-level imports stay light (typer only); numpy, scipy and dask load inside the
commands. Every command prints a short text summary, or one JSON object with
``--json``. Bad input raises ``InputError`` (exit code 2 through ``cam.cli.main``).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Annotated, Any

import typer

motion_app = typer.Typer(
    name="motion",
    help="Machine motion: S-curve indexing, positioning-time search, servo lag, cycle time.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)

JsonFlag = Annotated[bool, typer.Option("--json", help="Print one JSON object on stdout.")]


def _emit(data: dict[str, Any], as_json: bool, lines: list[str]) -> None:
    if as_json:
        typer.echo(json.dumps(data, indent=2, sort_keys=True, allow_nan=False))
    else:
        for line in lines:
            typer.echo(line)


def _finite(value: float) -> float | None:
    return value if math.isfinite(value) else None


@motion_app.command("scurve")
def scurve_command(
    stroke: Annotated[float, typer.Option("--stroke", help="Move length, mm.")],
    vmax: Annotated[float, typer.Option("--vmax", help="Maximum velocity, mm/s.")],
    amax_up: Annotated[float, typer.Option("--amax-up", help="Maximum acceleration, mm/s^2.")],
    amax_down: Annotated[
        float, typer.Option("--amax-down", help="Maximum deceleration (magnitude), mm/s^2.")
    ],
    s_factor: Annotated[float, typer.Option("--s-factor", help="S factor (tj = S x period).")],
    pid_period: Annotated[
        float, typer.Option("--pid-period", help="PID update period, s.")
    ] = 250e-6,
    as_json: JsonFlag = False,
) -> None:
    """Plan one seven-segment asymmetric S-curve move."""
    from cam.motion.scurve import plan_scurve

    profile = plan_scurve(stroke, vmax, amax_up, amax_down, s_factor, pid_period)
    data = {
        "duration_s": float(profile.duration[0]),
        "peak_velocity": float(profile.peak_velocity[0]),
        "peak_acceleration": float(profile.peak_acceleration[0]),
        "peak_deceleration": float(profile.peak_deceleration[0]),
        "segment_durations_s": [float(v) for v in profile.durations[0]],
        "jerk_time_s": s_factor * pid_period,
        "reaches_vmax": bool(profile.peak_velocity[0] >= vmax * (1 - 1e-12)),
        "units": {"peak_velocity": "mm/s", "peak_acceleration": "mm/s^2",
                  "peak_deceleration": "mm/s^2"},
    }
    _emit(data, as_json, [
        f"duration           {data['duration_s']:.6f} s",
        f"peak velocity      {data['peak_velocity']:.3f} mm/s",
        f"peak acceleration  {data['peak_acceleration']:.1f} mm/s^2",
        f"peak deceleration  {data['peak_deceleration']:.1f} mm/s^2",
    ])


@motion_app.command("optimize")
def optimize_command(
    plant: Annotated[Path, typer.Option("--plant", help="Plant TOML (TDOF model).")],
    stroke: Annotated[float, typer.Option("--stroke", help="Move length, mm.")],
    s_min: Annotated[float, typer.Option(help="Smallest S factor.")] = 0.0,
    s_max: Annotated[float, typer.Option(help="Largest S factor.")] = 115.0,
    s_step: Annotated[float, typer.Option(help="S factor step.")] = 2.5,
    a_min: Annotated[float, typer.Option(help="Smallest Amaxu and |Amaxd|, mm/s^2.")] = 10000.0,
    a_max: Annotated[float, typer.Option(help="Largest Amaxu and |Amaxd|, mm/s^2.")] = 30000.0,
    a_step: Annotated[float, typer.Option(help="Acceleration step, mm/s^2.")] = 500.0,
    v_min: Annotated[float, typer.Option(help="Smallest Vmax, mm/s.")] = 200.0,
    v_max: Annotated[float, typer.Option(help="Largest Vmax, mm/s.")] = 500.0,
    v_step: Annotated[float, typer.Option(help="Vmax step, mm/s.")] = 5.0,
    scheduler: Annotated[
        str | None, typer.Option("--scheduler", help="Address of a running Dask scheduler.")
    ] = None,
    workers: Annotated[
        int, typer.Option(help="Local Dask worker processes (0: no Dask, this process).")
    ] = 2,
    plots: Annotated[
        Path | None, typer.Option("--plots", help="Folder for fig9_time_vs_s.png and "
                                  "fig10_time_over_av.png.")
    ] = None,
    as_json: JsonFlag = False,
) -> None:
    """Search (Amaxu, Amaxd, Vmax, S) for the shortest positioning time (seed 000)."""
    from cam.motion.optimise import Grid, optimise, value_range
    from cam.motion.plant import load_plant
    from cam.motion.positioning import settling_from_dict

    model, document = load_plant(plant)
    settling = settling_from_dict(document, plant)
    accel = value_range(a_min, a_max, a_step, "--a-min/--a-max/--a-step")
    grid = Grid(value_range(s_min, s_max, s_step, "--s-min/--s-max/--s-step"), accel,
                accel.copy(), value_range(v_min, v_max, v_step, "--v-min/--v-max/--v-step"))
    import sys

    bar = None
    progress = None
    if sys.stderr.isatty():  # a progress bar for people, silence for CI and pipes
        from rich.progress import Progress

        bar = Progress(transient=True)
        task = bar.add_task(f"{grid.size} profiles", total=None)

        def progress(done: int, total: int) -> None:
            bar.update(task, completed=done, total=total)

        bar.start()
    try:
        result = optimise(model, stroke, grid, settling, pid_period=settling.dt,
                          scheduler=scheduler, workers=workers, progress=progress)
    finally:
        if bar is not None:
            bar.stop()
    data = result.as_dict()
    data["settling"] = {"output": settling.output, "band": settling.band,
                        "pid_period_s": settling.dt}
    if plots is not None:
        from cam.motion.plots import plot_time_over_av, plot_time_vs_s

        data["plots"] = [str(plot_time_vs_s(result, plots / "fig9_time_vs_s.png")),
                         str(plot_time_over_av(result, plots / "fig10_time_over_av.png"))]
    times = data["positioning_time_s"]
    best, sym = result.best, result.best_symmetric
    _emit(data, as_json, [
        f"profiles searched   {result.grid.size}",
        f"best                {times['best']:.4f} s  (Amaxu {best.amax_up:.0f}, "
        f"Amaxd {best.amax_down:.0f} mm/s^2, Vmax {best.vmax:.0f} mm/s, S {best.s_factor:g})",
        f"best symmetric      {times['best_symmetric']:.4f} s  (A {sym.amax_up:.0f} mm/s^2, "
        f"Vmax {sym.vmax:.0f} mm/s, S {sym.s_factor:g})",
        f"all maxima, S = 22  {times['case_max']:.4f} s",
        f"improvement         {100 * data['improvement_vs_case_max']:.1f} %",
    ])


@motion_app.command("servo")
def servo_command(
    machine: Annotated[Path, typer.Option("--machine", "-m", help="Machine TOML.")],
    axis: Annotated[str, typer.Option("--axis", help="Rotary axis with servo data.")] = "C",
    linear: Annotated[
        list[str] | None, typer.Option("--linear", help="Linear axes to match (repeatable).")
    ] = None,
    omega: Annotated[
        list[float] | None,
        typer.Option("--omega", help="Angular velocities, rad/s (default: the paper's "
                     "0.5 pi .. 4 pi).")
    ] = None,
    feed: Annotated[
        float, typer.Option("--feed", help="Feed at the cutting point F_C, mm/min.")
    ] = 200.0,
    program: Annotated[
        Path | None, typer.Option("--program", help="NC program: predict tool-tip deviation.")
    ] = None,
    as_json: JsonFlag = False,
) -> None:
    """Best K_FFP per linear axis, torque saturation and smallest radius (seed 004)."""
    import numpy as np

    from cam.motion.feeddrive import (
        alpha_th,
        axis_from_servo,
        best_kffp,
        beta_th,
        saturation_omega,
        smallest_radius,
    )
    from impeller_cam.errors import InputError
    from postproc.machine import load_machine

    mach = load_machine(machine)
    specs = mach.axes
    if axis not in specs or not specs[axis].servo:
        raise InputError("axis has no servo table", file=machine, field=f"axes.{axis}.servo",
                         value=axis, accepted=", ".join(n for n in specs if specs[n].servo))
    rot = axis_from_servo(axis, dict(specs[axis].servo), specs[axis].rotary, machine)
    names = linear if linear else [n for n in specs if specs[n].servo and not specs[n].rotary]
    lin = {}
    for name in names:
        if name not in specs or not specs[name].servo:
            raise InputError("axis has no servo table", file=machine,
                             field=f"axes.{name}.servo", value=name)
        lin[name] = axis_from_servo(name, dict(specs[name].servo), specs[name].rotary, machine)
    omegas = omega if omega else list(np.pi * np.array([0.5, 1.0, 1.5, 2.0, 3.0, 4.0]))
    table = []
    for w in omegas:
        row: dict[str, Any] = {"omega_rad_s": float(w), "alpha_th_rad": float(alpha_th(rot, w))}
        for name, model in lin.items():
            row[f"beta_th_{name}_rad"] = float(beta_th(model, w))
            try:
                row[f"best_kffp_{name}_percent"] = best_kffp(rot, model, w)
            except InputError:
                row[f"best_kffp_{name}_percent"] = None
        table.append(row)
    data: dict[str, Any] = {"axis": axis, "best_kffp": table, "feed_mm_min": feed}
    lines = [f"axis {axis}: K_FFP {rot.k_ffp:g} %, J + J1 = {rot.total_inertia:g} kg m^2"]
    if math.isfinite(rot.torque_limit):
        w_sat = saturation_omega(rot)
        data["saturation_omega_rad_s"] = w_sat
        data["smallest_radius_mm"] = smallest_radius(w_sat, feed)
        lines.append(f"torque saturation at omega = {w_sat:.3f} rad/s; smallest radius "
                     f"R_C = {data['smallest_radius_mm']:.3f} mm at F_C = {feed:g} mm/min")
    for row in table:
        best = ", ".join(f"{n} {row[f'best_kffp_{n}_percent']:.2f} %"
                         if row[f"best_kffp_{n}_percent"] is not None else f"{n} -"
                         for n in lin)
        lines.append(f"omega {row['omega_rad_s']:7.3f} rad/s: Best K_FFP {best}")
    if program is not None:
        from cam.motion.axis_models import machine_axis_models
        from cam.motion.program_servo import corner_smoothing_time, simulate_program
        from postproc.nc_reader import read_nc

        models = machine_axis_models(mach)
        report = simulate_program(read_nc(program, machine=mach), mach, models=models,
                                  corner_smoothing=corner_smoothing_time(models.models))
        data["program"] = report.as_dict()
        lines.append(f"program: max contour error "
                     f"{data['program']['max_contour_error_mm']:.4f} mm at line "
                     f"{data['program']['worst_line']} (RMS over feed "
                     f"{data['program']['rms_contour_error_feed_mm']:.4f} mm)")
    _emit(data, as_json, lines)


@motion_app.command("time")
def time_command(
    program: Annotated[Path, typer.Argument(help="NC program.")],
    machine: Annotated[Path, typer.Option("--machine", "-m", help="Machine TOML.")],
    as_json: JsonFlag = False,
) -> None:
    """Cycle time of an NC program under the machine's velocity/acceleration/jerk limits."""
    from cam.motion.blending import blended_program_time
    from cam.motion.cycle_time import format_seconds, program_cycle_time
    from cam.motion.program_servo import machine_corner_smoothing, program_joints
    from postproc.machine import load_machine
    from postproc.nc_reader import read_nc

    mach = load_machine(machine)
    prog = read_nc(program, machine=mach)
    joints = program_joints(prog, mach)
    times = program_cycle_time(prog, mach, joints)
    blended = blended_program_time(prog, mach, joints,
                                   smoothing=machine_corner_smoothing(mach))
    data = times.as_dict()
    data["program"] = str(program)
    data["blended_time_s"] = blended.total
    data["blend_tolerance_mm"] = blended.tolerance
    _emit(data, as_json, [
        f"blocks             {data['blocks']}",
        f"blended time       {format_seconds(blended.total)} "
        f"({blended.total:.2f} s, look-ahead blending within G64 P{blended.tolerance:g})",
        f"cycle time         {format_seconds(times.limited_total)} "
        f"({times.limited_total:.2f} s, jerk-limited, exact stop)",
        f"nominal time       {format_seconds(times.nominal_total)} "
        f"({times.nominal_total:.2f} s, length / feed)",
    ])


@motion_app.command("identify")
def identify_command(
    response: Annotated[Path, typer.Option("--response", help="Measured response CSV.")],
    plant: Annotated[
        Path | None, typer.Option("--plant", help="Plant TOML: starting values (TDOF fit).")
    ] = None,
    machine: Annotated[
        Path | None, typer.Option("--machine", "-m", help="Machine TOML (feed-drive fit).")
    ] = None,
    axis: Annotated[
        str | None, typer.Option("--axis", help="Axis whose feed drive is fitted "
                                 "(starting values: its servo table or the default).")
    ] = None,
    free: Annotated[
        list[str] | None,
        typer.Option("--free", help="Parameter to fit (repeatable; default: stiffness, "
                     "damping, servo_stiffness, servo_damping; with --axis: J, C, Ta, Tp).")
    ] = None,
    as_json: JsonFlag = False,
) -> None:
    """Fit a TDOF plant (--plant) or an axis's feed drive (--machine, --axis) to a
    measured response."""
    from cam.motion.identify import DEFAULT_FREE, identify, read_response_csv
    from cam.motion.plant import PARAMETERS, load_plant
    from impeller_cam.errors import InputError

    if axis is not None or machine is not None:
        _identify_drive(response, machine, axis, free, as_json)
        return
    if plant is None:
        raise InputError("nothing to fit", field="--plant",
                         accepted="--plant PLANT.toml, or --machine M.toml --axis NAME")
    start, _ = load_plant(plant)
    fit = identify(read_response_csv(response), start, tuple(free) if free else DEFAULT_FREE)
    values = {name: float(getattr(fit.plant, name)) for name in PARAMETERS}
    frequencies = [float(f) for f in fit.plant.natural_frequencies()]
    data: dict[str, Any] = {
        "plant": values,
        "free": list(fit.free),
        "rms_residual": fit.rms_residual,
        "relative_rms": fit.relative_rms,
        "natural_frequencies_hz": frequencies,
        "damping_ratios": [float(z) for z in fit.plant.damping_ratios()],
    }
    lines = ["[plant]"] + [f"{name} = {value:.6g}" for name, value in values.items()]
    lines.append(f"# relative RMS residual {fit.relative_rms:.4f}; modes "
                 + ", ".join(f"{f:.2f} Hz" for f in frequencies))
    _emit(data, as_json, lines)


def _identify_drive(response: Path, machine: Path | None, axis: str | None,
                    free: list[str] | None, as_json: bool) -> None:
    """``motion identify --machine --axis``: an [axes.N.servo] table from a response."""
    from cam.motion.axis_models import machine_axis_models
    from cam.motion.identify import read_response_csv
    from cam.motion.identify_drive import DRIVE_FREE, identify_drive, servo_table
    from impeller_cam.errors import InputError
    from postproc.machine import load_machine

    if machine is None or axis is None:
        raise InputError("a feed-drive fit needs both --machine and --axis",
                         field="--axis" if axis is None else "--machine",
                         accepted="--machine M.toml --axis NAME")
    mach = load_machine(machine)
    models = machine_axis_models(mach)
    named = models.by_name()
    if axis not in named:
        raise InputError("no such axis", file=machine, field="--axis", value=axis,
                         accepted=", ".join(named))
    fit = identify_drive(read_response_csv(response), named[axis],
                         tuple(free) if free else DRIVE_FREE)
    table = servo_table(fit.axis)
    data: dict[str, Any] = {"axis": axis, "start": models.source[axis], "servo": table,
                            "free": list(fit.free), "rms_residual": fit.rms_residual,
                            "relative_rms": fit.relative_rms}
    lines = [f"[axes.{axis}.servo]"] + [f"{k} = {v:.6g}" for k, v in table.items()]
    lines.append(f"# fitted {', '.join(fit.free)} from {response.name} (start: "
                 f"{models.source[axis]}); RMS residual {fit.rms_residual:.4g} "
                 f"({'deg' if fit.axis.rotary else 'mm'}), relative {fit.relative_rms:.2e}")
    _emit(data, as_json, lines)


@motion_app.command("circle")
def circle_command(
    drives: Annotated[Path, typer.Option("--drives", help="Feed-drive TOML with a "
                                         "[circle_test] table.")],
    plot: Annotated[Path | None, typer.Option("--plot", help="Write the shape error vs "
                                              "omega figure (PNG) here.")] = None,
    as_json: JsonFlag = False,
) -> None:
    """The paper's circle test: shape error vs omega with machine and Best K_FFP, and the
    torque-saturation figures (seed 004, Figs. 20-26)."""
    from cam.motion.feeddrive import load_feed_drives
    from cam.motion.schema import FeedDriveFile
    from cam.motion.synchronisation import circle_sweep, saturation_figures
    from cam.motion.tomlio import read_toml
    from impeller_cam.errors import InputError
    from impeller_cam.schema import validate

    doc = validate(FeedDriveFile, read_toml(drives, "feed-drive"), drives)
    test = doc.circle_test
    if test is None:
        raise InputError("no [circle_test] table", file=drives, field="circle_test",
                         accepted="a [circle_test] table (docs/formats.md)")
    axes = load_feed_drives(drives)
    for name in (test.rotary, *test.linear):
        if name not in axes:
            raise InputError("the circle test names an axis the file does not give",
                             file=drives, field="circle_test", value=name,
                             accepted=", ".join(axes))
    points = circle_sweep(axes, test)
    saturation = saturation_figures(axes[test.rotary], test) if math.isfinite(
        axes[test.rotary].torque_limit) else []
    data: dict[str, Any] = {
        "points": [{"total_inertia": p.total_inertia, "omega_rad_s": p.omega,
                    "machine_amplitude_um": 1000.0 * p.machine_amplitude,
                    "best_amplitude_um": 1000.0 * p.best_amplitude,
                    "best_kffp_percent": p.best_kffp, "saturated": p.saturated}
                   for p in points],
        "saturation": [s.__dict__ for s in saturation],
    }
    lines = ["J + J1   omega (rad/s)  machine K_FFP  Best K_FFP  (half-amplitude, um)"]
    lines += [f"{p.total_inertia:6.2f}  {p.omega:8.3f}  {1000 * p.machine_amplitude:12.2f}  "
              f"{1000 * p.best_amplitude:10.2f}" + ("  saturated" if p.saturated else "")
              for p in points]
    for f in saturation:
        lines.append(f"J + J1 = {f.total_inertia:.2f}: limit alone {f.limit_acceleration:.1f} "
                     f"rad/s^2 (omega {f.limit_omega:.2f}); simulated drive saturates at "
                     f"{f.model_omega:.2f} rad/s" + (f"; paper {f.paper_omega:g} rad/s, "
                     f"{f.paper_acceleration:g} rad/s^2" if f.paper_omega else ""))
    if plot is not None:
        from cam.motion.plots import plot_circle_sweep

        plot_circle_sweep(points, plot)
        data["plot"] = str(plot)
    _emit(data, as_json, lines)
