"""Identify a feed-drive axis (seed 004's model) from a measured step or ramp response.

The paper sets Kpp, Kvp, Kvi, K_FFP and Ts in the NC and determines J, C, Ta and Tp
"to be matched with the transient state of the motion" (section 4.5). This module
does that by least squares: the measured axis position of a commanded move (a step,
a ramp, any move) is compared with ``feeddrive.simulate_axis`` of the same command,
and the chosen parameters (default ``J, C, Ta, Tp``) are fitted as logarithms (they
stay positive) with ``scipy.optimize.least_squares``; the rest stay at their starting
values (the machine file's servo table, or the stated default of an unidentified
axis, ``axis_models``).

The CSV is the measured-response format of ``cam.motion.identify`` (docs/formats.md):
``time_s``, ``command_position_mm`` and ``table_position_mm`` (the measured axis
position). A linear axis in mm; a rotary axis in degrees (the NC's unit; the columns
keep their names).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cam.motion.feeddrive import FeedDriveAxis, simulate_axis
from cam.motion.identify import MeasuredResponse
from impeller_cam.errors import InputError

__all__ = ["DRIVE_FREE", "DRIVE_PARAMETERS", "DriveIdentification", "identify_drive",
           "servo_table", "synthetic_drive_response"]

#: Servo keys of the machine file -> FeedDriveAxis attribute, for the fitted values.
DRIVE_PARAMETERS: dict[str, str] = {
    "Kpp": "kpp", "Kvp": "kvp", "Kvi": "kvi", "J": "inertia", "J1": "load_inertia",
    "C": "viscous", "K_FFP": "k_ffp", "Ts": "ts", "Ta": "ta", "Tp": "tp",
}
#: Fitted by default: what the paper identifies (the rest are NC set values).
DRIVE_FREE: tuple[str, ...] = ("J", "C", "Ta", "Tp")


@dataclass(frozen=True)
class DriveIdentification:
    """A fitted feed-drive axis and the quality of the fit.

    Attributes
    ----------
    axis : FeedDriveAxis
    rms_residual : float
        RMS of measured - simulated position, mm (linear) or degrees (rotary).
    relative_rms : float
        ``rms_residual`` over the RMS of the measured motion (position minus its start).
    free : tuple of str
        Fitted servo keys.
    """

    axis: FeedDriveAxis
    rms_residual: float
    relative_rms: float
    free: tuple[str, ...]


def _unit(axis: FeedDriveAxis) -> float:
    """CSV unit per model unit: degrees per rad (rotary) or 1 (mm)."""
    return math.degrees(1.0) if axis.rotary else 1.0


def identify_drive(response: MeasuredResponse, initial: FeedDriveAxis,
                   free: tuple[str, ...] = DRIVE_FREE) -> DriveIdentification:
    """Fit ``free`` servo parameters of ``initial`` to a measured position response.

    Parameters
    ----------
    response : MeasuredResponse
        ``output == "position"`` (``table_position_mm``), mm or degrees.
    initial : FeedDriveAxis
        Starting values; parameters not in ``free`` stay fixed.
    free : tuple of str
        Servo keys from ``DRIVE_PARAMETERS``.

    Raises
    ------
    InputError
        A measured acceleration instead of a position, an unknown key, a starting
        value of 0 for a fitted key.
    """
    from scipy.optimize import least_squares

    if response.output != "position":
        raise InputError("a feed-drive fit needs the measured axis position",
                         field="table_position_mm", value=response.output,
                         accepted="a CSV with a table_position_mm column")
    for key in free:
        if key not in DRIVE_PARAMETERS:
            raise InputError("unknown servo parameter", field="free", value=key,
                             accepted=", ".join(DRIVE_PARAMETERS))
        if getattr(initial, DRIVE_PARAMETERS[key]) <= 0.0:
            raise InputError("a fitted parameter needs a starting value > 0",
                             field=f"axes.{initial.name}.servo.{key}", value=0.0,
                             accepted="a value > 0 in the machine file")
    unit = _unit(initial)
    command = response.command[:, 0] / unit
    measured = response.measured / unit
    motion = measured - measured[0]
    scale = float(np.sqrt(np.mean(motion**2))) or 1.0

    def model(log_values: NDArray[np.float64]) -> FeedDriveAxis:
        values: dict[str, Any] = {DRIVE_PARAMETERS[k]: float(math.exp(v))
                                  for k, v in zip(free, log_values, strict=True)}
        return replace(initial, **values)

    def residual(log_values: NDArray[np.float64]) -> NDArray[np.float64]:
        simulated = simulate_axis(model(log_values), command, response.dt).position
        return (simulated - measured) / scale

    start = np.log([getattr(initial, DRIVE_PARAMETERS[k]) for k in free])
    fit = least_squares(residual, start, method="trf", x_scale=1.0, diff_step=1e-4,
                        xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=300)
    rms = float(np.sqrt(np.mean((fit.fun * scale) ** 2)))
    return DriveIdentification(axis=model(fit.x), rms_residual=rms * unit,
                               relative_rms=rms / scale, free=tuple(free))


def servo_table(axis: FeedDriveAxis) -> dict[str, float]:
    """The machine file's ``[axes.N.servo]`` keys of ``axis``."""
    out = {key: float(getattr(axis, name)) for key, name in DRIVE_PARAMETERS.items()}
    if math.isfinite(axis.torque_limit):
        out["torque_limit"] = axis.torque_limit
    if axis.screw_lead is not None:
        out["screw_lead"] = axis.screw_lead
    return out


def synthetic_drive_response(axis: FeedDriveAxis, speed: float, duration: float = 0.5,
                             dt: float = 1e-3, noise: float = 1e-3, seed: int = 11
                             ) -> MeasuredResponse:
    """A "measured" ramp response: ``speed`` (mm/s or deg/s) from rest at t = 0.05 s.

    The position is the simulated axis plus Gaussian noise of standard deviation
    ``noise`` (mm or degrees; an encoder's resolution), ``default_rng(seed)``.
    """
    unit = _unit(axis)
    t = np.arange(int(round(duration / dt)) + 1, dtype=np.float64) * dt
    command = speed * np.maximum(t - 0.05, 0.0)
    position = simulate_axis(axis, command / unit, dt).position * unit
    rng = np.random.default_rng(seed)
    measured = position + rng.normal(0.0, noise, position.shape)
    velocity = np.gradient(command, dt)
    triple = np.stack([command, velocity, np.gradient(velocity, dt)], axis=1)
    return MeasuredResponse(time=t, command=triple, measured=measured, output="position",
                            dt=dt)

