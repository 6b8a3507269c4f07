"""Identify TDOF plant parameters from a measured response (seed 000, section II.B).

The paper identifies its table model from the accelerometer response to a step
excitation. Here any commanded move will do: a CSV gives the command and the measured
table acceleration (or position) on a uniform time grid, and
``scipy.optimize.least_squares`` fits chosen plant parameters (default: the spring,
the damper and the two servo gains; the masses come from the data sheet) so that the
exact sampled-data simulation (``cam.motion.plant.simulate``) matches the measurement.
Parameters are fitted as logarithms, so they stay positive.

CSV columns (header row, any order, comma separated; docs/formats.md):
``time_s``, ``command_position_mm`` (required), ``command_velocity_mm_s``,
``command_acceleration_mm_s2`` (optional: else central differences of the position),
and ``table_acceleration_mm_s2`` or ``table_position_mm`` (the measurement).
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from cam.motion.plant import PARAMETERS, Output, TwoMassPlant, simulate
from cam.motion.scurve import PAPER_PID_PERIOD, plan_scurve, sample_scurve
from impeller_cam.atomic import write_text_atomic
from impeller_cam.errors import InputError

#: Plant parameters fitted by default.
DEFAULT_FREE: tuple[str, ...] = ("stiffness", "damping", "servo_stiffness", "servo_damping")

_MEASURED = {"table_acceleration_mm_s2": "acceleration", "table_position_mm": "position"}


@dataclass(frozen=True)
class MeasuredResponse:
    """A measured move on a uniform grid.

    Attributes
    ----------
    time : (n,) float64
        s, uniform step ``dt``.
    command : (n, 3) float64
        Commanded position (mm), velocity (mm/s), acceleration (mm/s^2).
    measured : (n,) float64
        Table acceleration (mm/s^2) or position (mm).
    output : {"acceleration", "position"}
    dt : float
        s.
    """

    time: NDArray[np.float64]
    command: NDArray[np.float64]
    measured: NDArray[np.float64]
    output: Output
    dt: float


def read_response_csv(path: str | Path) -> MeasuredResponse:
    """Read a measured response CSV.

    Raises
    ------
    InputError
        Missing file or column, a non-number, fewer than 10 rows, a non-uniform or
        non-increasing time column.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise InputError("response file not found", file=path) from None
    rows = list(csv.reader(line for line in io.StringIO(text) if not line.startswith("#")))
    if not rows:
        raise InputError("empty file", file=path, accepted="a CSV with a header row")
    header = [h.strip() for h in rows[0]]
    body = rows[1:]
    for required in ("time_s", "command_position_mm"):
        if required not in header:
            raise InputError("missing column", file=path, field=required,
                             accepted="columns time_s, command_position_mm and "
                             "table_acceleration_mm_s2 or table_position_mm")
    measured_cols = [c for c in _MEASURED if c in header]
    if not measured_cols:
        raise InputError("missing measured column", file=path,
                         field="table_acceleration_mm_s2",
                         accepted="table_acceleration_mm_s2 or table_position_mm")
    if len(body) < 10:
        raise InputError("too few rows", file=path, value=len(body), accepted=">= 10 rows")
    data = np.empty((len(body), len(header)))
    for i, row in enumerate(body):
        if len(row) != len(header):
            raise InputError(f"row {i + 2} has {len(row)} fields", file=path,
                             accepted=f"{len(header)} fields like the header")
        for j, cell in enumerate(row):
            try:
                data[i, j] = float(cell)
            except ValueError:
                raise InputError(f"row {i + 2}: not a number", file=path, field=header[j],
                                 value=cell, accepted="a number") from None
    if not np.all(np.isfinite(data)):
        raise InputError("not a finite number", file=path, accepted="finite numbers")
    col = {name: data[:, header.index(name)] for name in header}
    time = col["time_s"]
    steps = np.diff(time)
    dt = float(np.mean(steps))
    if not (dt > 0.0 and np.all(np.abs(steps - dt) <= 1e-6 * dt + 1e-12)):
        raise InputError("time must increase in equal steps", file=path, field="time_s",
                         accepted="a uniform, increasing time grid")
    pos = col["command_position_mm"]
    vel = col.get("command_velocity_mm_s")
    vel = np.gradient(pos, dt) if vel is None else vel
    acc = col.get("command_acceleration_mm_s2")
    acc = np.gradient(vel, dt) if acc is None else acc
    measured_name = measured_cols[0]
    return MeasuredResponse(time=time, command=np.stack([pos, vel, acc], axis=1),
                            measured=col[measured_name],
                            output=_MEASURED[measured_name],  # type: ignore[arg-type]
                            dt=dt)


@dataclass(frozen=True)
class Identification:
    """A fitted plant and the quality of the fit.

    Attributes
    ----------
    plant : TwoMassPlant
    rms_residual : float
        RMS of measured - simulated, output units.
    relative_rms : float
        ``rms_residual / rms(measured)``.
    free : tuple of str
        The fitted parameters.
    """

    plant: TwoMassPlant
    rms_residual: float
    relative_rms: float
    free: tuple[str, ...]


def identify(
    response: MeasuredResponse,
    initial: TwoMassPlant,
    free: tuple[str, ...] = DEFAULT_FREE,
) -> Identification:
    """Fit ``free`` parameters of ``initial`` to a measured response (least squares).

    Parameters
    ----------
    response : MeasuredResponse
    initial : TwoMassPlant
        Starting values; parameters not in ``free`` stay fixed.
    free : tuple of str
        Names from ``cam.motion.plant.PARAMETERS``.

    Returns
    -------
    Identification
    """
    from scipy.optimize import least_squares

    for name in free:
        if name not in PARAMETERS:
            raise InputError("unknown plant parameter", field="free", value=name,
                             accepted=", ".join(PARAMETERS))
    scale = float(np.sqrt(np.mean(response.measured**2))) or 1.0

    def model(log_values: NDArray[np.float64]) -> TwoMassPlant:
        return initial.with_parameters(**{n: float(math.exp(v)) for n, v in
                                          zip(free, log_values, strict=True)})

    def residual(log_values: NDArray[np.float64]) -> NDArray[np.float64]:
        sim = simulate(model(log_values), response.command, response.dt, response.output)
        return (sim - response.measured) / scale

    start = np.log([max(getattr(initial, n), 1e-12) for n in free])
    fit = least_squares(residual, start, method="trf", x_scale=1.0, xtol=1e-12,
                        ftol=1e-12, gtol=1e-12, max_nfev=400)
    plant = model(fit.x)
    rms = float(np.sqrt(np.mean((fit.fun * scale) ** 2)))
    return Identification(plant=plant, rms_residual=rms, relative_rms=rms / scale,
                          free=tuple(free))


def synthetic_response(
    plant: TwoMassPlant,
    stroke: float = 20.0,
    vmax: float = 500.0,
    amax: float = 30000.0,
    s_factor: float = 22.0,
    duration: float = 0.3,
    dt: float = PAPER_PID_PERIOD,
    noise: float = 0.02,
    seed: int = 7,
) -> MeasuredResponse:
    """A "measured" acceleration response made from known parameters + seeded noise.

    The command is a symmetric S-curve move; the noise is Gaussian with standard
    deviation ``noise`` times the peak simulated table acceleration (accelerometer
    noise), from ``numpy.random.default_rng(seed)``.
    """
    profile = plan_scurve(stroke, vmax, amax, amax, s_factor, dt)
    time = np.arange(int(round(duration / dt)), dtype=np.float64) * dt
    _, acc, vel, pos = sample_scurve(profile, time)
    command = np.stack([pos[0], vel[0], acc[0]], axis=1)
    clean = simulate(plant, command, dt, "acceleration")
    rng = np.random.default_rng(seed)
    measured = clean + rng.normal(0.0, noise * float(np.max(np.abs(clean))), clean.shape)
    return MeasuredResponse(time=time, command=command, measured=measured,
                            output="acceleration", dt=dt)


def write_response_csv(path: str | Path, response: MeasuredResponse) -> Path:
    """Write a response CSV (the format ``read_response_csv`` reads), atomically."""
    name = "table_acceleration_mm_s2" if response.output == "acceleration" else \
        "table_position_mm"
    lines = ["# impeller-cam measured-response CSV (docs/formats.md)",
             f"time_s,command_position_mm,command_velocity_mm_s,"
             f"command_acceleration_mm_s2,{name}"]
    for t, (x, v, a), y in zip(response.time, response.command, response.measured,
                               strict=True):
        lines.append(f"{t:.7f},{x:.9f},{v:.7f},{a:.5f},{y:.5f}")
    return write_text_atomic(path, "\n".join(lines) + "\n")
