"""Servo lag of a whole joint-space program, mapped to the tool tip (M6 on our programs).

1. Joint targets: the program's joints; blocks under tool-centre-point control carry
   the tool tip, mapped to joints through the table-tilting-rotary kinematics.
2. Commanded motion in time: blocks at their nominal times (length / feed; rapids at
   the velocity limits, ``cycle_time``), joints interpolated linearly and sampled at
   ``dt``. Acceleration and deceleration come from each axis's own smoothing filter
   (Ts, the controller's acc/dec after interpolation) inside the feed-drive model.
3. Every axis with servo parameters (``Machine.axes[n].servo``) is simulated through
   its feed-drive model (``feeddrive.simulate_axis``, torque saturation included); axes
   without servo data follow their command exactly (reported).
4. Commanded and simulated joints go through the machine's forward kinematics to tool
   tips in the workpiece frame. Two deviations per sample: the *tracking* error (the
   distance to the commanded tip at the same instant: a common lag of all axes shows
   here but leaves no mark) and the *contour* error (the distance to the commanded
   tip path, searched over a window of commanded samples around the instant as long
   as the axes' lag): the as-machined error. Both are reported per block (largest over
   the samples of the block).
5. K_FFP recommendation: the Best K_FFP method generalised to a program. The reference
   is the rotary axis that lags most (largest ``alpha_th / omega``); every other servo
   axis gets the K_FFP whose phase lag at the program's characteristic angular
   frequency equals the reference's ramp lag. The characteristic frequency is the RMS
   angular velocity of the rotary axes during feed blocks (a point on a table turning
   at omega moves X/Y sinusoidally at omega).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numba
import numpy as np
from numpy.typing import NDArray

from cam.motion.cycle_time import program_cycle_time, rotary_mask
from cam.motion.feeddrive import FeedDriveAxis, alpha_th, axis_from_servo, best_kffp, simulate_axis
from impeller_cam.errors import InputError
from postproc.program import MachineProgram, Motion

if TYPE_CHECKING:
    from postproc.machine import Machine

#: Default controller period of the program simulation, s.
PROGRAM_DT = 2.5e-4

#: Largest number of samples simulated (memory guard: 5 axes x 8 bytes each).
MAX_SAMPLES = 20_000_000


def program_joints(program: MachineProgram, machine: Machine) -> NDArray[np.float64]:
    """Joint targets ``(n, 5)``: TCP blocks mapped from tool tip to joints."""
    joints = program.joints.copy()
    if not np.any(program.tcp):
        return joints
    from postproc.kinematics import kinematics_for
    from postproc.kinematics.trt import TableTiltingRotary, trt_inverse_position

    kins = kinematics_for(machine)
    if not isinstance(kins, TableTiltingRotary):
        raise InputError("tool-centre-point blocks need a table-tilting-rotary kinematics",
                         file=machine.source, field="kinematics", value=machine.kinematics)
    rows = np.flatnonzero(program.tcp)
    tip = joints[rows, :3] - kins.rot_point
    joints[rows, :3] = trt_inverse_position(tip, joints[rows, 3], joints[rows, 4],
                                            kins.rot_point, kins.offset, kins.tilt_about,
                                            kins.sign)
    return joints


def servo_axes(machine: Machine) -> dict[int, FeedDriveAxis]:
    """Feed-drive models of the axes with servo data, keyed by joint column."""
    out = {}
    for column, spec in enumerate(machine.axes.values()):
        if spec.servo:
            out[column] = axis_from_servo(spec.name, dict(spec.servo), spec.rotary,
                                          machine.source)
    return out


@dataclass
class ServoReport:
    """Predicted servo lag of a program.

    Attributes
    ----------
    line : (n,) int64
        Source line of each block.
    deviation : (n,) float64
        Largest contour error (distance of the simulated tip from the commanded tip
        path) inside each block, mm.
    tracking : (n,) float64
        Largest tracking error (distance from the commanded tip at the same instant)
        inside each block, mm.
    axis_lag : dict of str -> float
        Largest |command - actual| per simulated axis (mm or rad).
    saturated : dict of str -> bool
        Axis hit its torque limit somewhere.
    recommended_kffp : dict of str -> float or None
        Best K_FFP per axis, percent (None: no K_FFP in range matches).
    deviation_recommended : (n,) float64 or None
        The per-block contour error again with the recommended K_FFP.
    omega : float
        Characteristic angular frequency used for the recommendation, rad/s.
    ideal_axes : list of str
        Axes without servo data (assumed to follow the command).
    """

    line: NDArray[np.int64]
    deviation: NDArray[np.float64]
    tracking: NDArray[np.float64]
    axis_lag: dict[str, float]
    saturated: dict[str, bool]
    recommended_kffp: dict[str, float | None]
    deviation_recommended: NDArray[np.float64] | None
    omega: float
    reference_axis: str | None
    ideal_axes: list[str] = field(default_factory=list)

    def as_dict(self) -> dict[str, object]:
        """JSON-ready summary (per-block arrays as worst lines)."""
        worst = int(np.argmax(self.deviation)) if len(self.deviation) else -1
        out: dict[str, object] = {
            "max_tip_deviation_mm": float(self.deviation.max()) if worst >= 0 else 0.0,
            "max_tracking_error_mm": float(self.tracking.max()) if worst >= 0 else 0.0,
            "worst_line": int(self.line[worst]) if worst >= 0 else None,
            "axis_lag": self.axis_lag,
            "saturated": self.saturated,
            "recommended_kffp_percent": self.recommended_kffp,
            "omega_rad_s": self.omega,
            "reference_axis": self.reference_axis,
            "ideal_axes": self.ideal_axes,
        }
        if self.deviation_recommended is not None and len(self.deviation_recommended):
            out["max_tip_deviation_recommended_mm"] = float(self.deviation_recommended.max())
        return out


def commanded_motion(
    program: MachineProgram, machine: Machine, joints: NDArray[np.float64], dt: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Sample the commanded joints at ``dt`` with blocks at their nominal times.

    Returns
    -------
    time : (m,) float64
    command : (m, 5) float64
    block_end : (n,) float64
        End time of each block, s.
    """
    times = program_cycle_time(program, machine, joints).nominal
    ends = np.cumsum(times)
    knots_t = np.concatenate([[0.0], ends])
    knots_q = np.vstack([program.start[None, :], joints])
    tail = 0.5  # let the axes settle after the last block
    m = int(math.ceil((knots_t[-1] + tail) / dt)) + 1
    if m * 5 > MAX_SAMPLES:
        raise InputError("program too long to simulate at this step", field="dt",
                         value=dt, accepted=f"a larger step (needs {m} samples)")
    t = np.arange(m, dtype=np.float64) * dt
    command = np.empty((m, knots_q.shape[1]))
    for c in range(knots_q.shape[1]):
        command[:, c] = np.interp(t, knots_t, knots_q[:, c])
    return t, command, ends


def _block_max(values: NDArray[np.float64], t: NDArray[np.float64],
               ends: NDArray[np.float64]) -> NDArray[np.float64]:
    index = np.searchsorted(ends, t, side="left")
    index = np.minimum(index, len(ends) - 1)
    out = np.zeros(len(ends))
    np.maximum.at(out, index, values)
    return out


@numba.njit(cache=True)
def _contour_distance(
    command: NDArray[np.float64], actual: NDArray[np.float64], back: int, ahead: int,
    out: NDArray[np.float64],
) -> None:  # pragma: no cover - compiled
    m = command.shape[0]
    for k in range(m):
        best = np.inf
        lo = max(k - back, 0)
        hi = min(k + ahead, m - 1)
        px, py, pz = actual[k, 0], actual[k, 1], actual[k, 2]
        for j in range(lo, max(hi, lo + 1)):
            j1 = min(j + 1, m - 1)
            ax, ay, az = command[j, 0], command[j, 1], command[j, 2]
            dx, dy, dz = command[j1, 0] - ax, command[j1, 1] - ay, command[j1, 2] - az
            length2 = dx * dx + dy * dy + dz * dz
            u = 0.0
            if length2 > 0.0:
                u = ((px - ax) * dx + (py - ay) * dy + (pz - az) * dz) / length2
                u = min(max(u, 0.0), 1.0)
            ex, ey, ez = px - ax - u * dx, py - ay - u * dy, pz - az - u * dz
            dist = ex * ex + ey * ey + ez * ez
            if dist < best:
                best = dist
        out[k] = np.sqrt(best)


def _deviations(
    machine: Machine, command: NDArray[np.float64], actual: NDArray[np.float64],
    window: int,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Contour and tracking error of every sample, mm."""
    from postproc.kinematics import kinematics_for

    kins = kinematics_for(machine)
    tip_c, _ = kins.forward(command)
    tip_a, _ = kins.forward(actual)
    contour = np.empty(len(tip_c))
    _contour_distance(np.ascontiguousarray(tip_c), np.ascontiguousarray(tip_a), window,
                      max(window // 4, 1), contour)
    return contour, np.linalg.norm(tip_a - tip_c, axis=1)


def recommend_kffp(
    axes: dict[int, FeedDriveAxis], omega: float
) -> tuple[dict[str, float | None], str | None]:
    """Best K_FFP per axis against the most lagging rotary axis (see module doc)."""
    rotaries = [a for a in axes.values() if a.rotary]
    if not rotaries:
        return {a.name: None for a in axes.values()}, None
    reference = max(rotaries, key=lambda a: float(alpha_th(a, 1.0)))
    out: dict[str, float | None] = {reference.name: reference.k_ffp}
    for axis in axes.values():
        if axis is reference:
            continue
        try:
            out[axis.name] = best_kffp(reference, axis, omega)
        except InputError:
            out[axis.name] = None
    return out, reference.name


def simulate_program(
    program: MachineProgram, machine: Machine, dt: float = PROGRAM_DT,
    recommend: bool = True,
) -> ServoReport:
    """Simulate every servo axis of ``program`` and predict the tool-tip deviation.

    Parameters
    ----------
    program : MachineProgram
    machine : Machine
        With ``servo`` tables on the axes to simulate.
    dt : float
        Controller period, s.
    recommend : bool
        Also compute the Best K_FFP per axis and the deviation with it.

    Returns
    -------
    ServoReport
    """
    if len(program) == 0:
        raise InputError("the program has no motion blocks", field="program")
    axes = servo_axes(machine)
    names = list(machine.axes)
    joints = program_joints(program, machine)
    t, command, ends = commanded_motion(program, machine, joints, dt)

    def run(models: dict[int, FeedDriveAxis]) -> tuple[NDArray[np.float64], dict[str, bool]]:
        actual = command.copy()
        saturated = {}
        for column, model in models.items():
            response = simulate_axis(model, command[:, column], dt)
            actual[:, column] = response.position
            saturated[model.name] = bool(response.saturated.any())
        return actual, saturated

    actual, saturated = run(axes)
    lag_time = max([a.ts + a.ta + 4.0 / a.kpp for a in axes.values()], default=0.0)
    window = int(math.ceil(lag_time / dt)) + 1
    contour, tracking = _deviations(machine, command, actual, window)
    deviation = _block_max(contour, t, ends)
    lag = {axes[c].name: float(np.max(np.abs(actual[:, c] - command[:, c]))) for c in axes}

    rotary = rotary_mask(machine)
    feed_rows = program.motion == Motion.LINEAR
    durations = np.diff(np.concatenate([[0.0], ends]))
    steps = np.diff(np.vstack([program.start[None, :], joints]), axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        rates = np.where(durations[:, None] > 0, steps / durations[:, None], 0.0)[:, rotary]
    weights = durations * feed_rows
    omega = 0.0
    if weights.sum() > 0 and rates.size:
        omega = float(np.sqrt(np.sum(weights[:, None] * rates**2) / weights.sum()))
    recommended: dict[str, float | None] = {}
    reference = None
    deviation_rec = None
    if recommend and axes and omega > 0.0:
        recommended, reference = recommend_kffp(axes, omega)
        tuned = {}
        for column, model in axes.items():
            value = recommended.get(model.name)
            tuned[column] = model if value is None else model.with_kffp(value)
        actual_rec, _ = run(tuned)
        deviation_rec = _block_max(_deviations(machine, command, actual_rec, window)[0], t,
                                   ends)
    return ServoReport(
        line=program.line.copy(), deviation=deviation,
        tracking=_block_max(tracking, t, ends), axis_lag=lag, saturated=saturated,
        recommended_kffp=recommended, deviation_recommended=deviation_rec, omega=omega,
        reference_axis=reference,
        ideal_axes=[names[c] for c in range(len(names)) if c not in axes],
    )
