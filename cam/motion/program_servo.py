"""Contour error of a whole joint-space program at the tool tip (M6 on our programs).

1. Joint targets: the program's joints; blocks under tool-centre-point control carry
   the tool tip, mapped to joints through the table-tilting-rotary kinematics.
2. Commanded motion in time (``feed_profile``): ``"lookahead"`` (default) is the
   control's look-ahead (``cam.motion.lookahead``): the path speed planned over the
   blocks, continuous, its changes jerk-limited S-curve phases at the axes' limits,
   corners blended within ``G64 P``, so the joint velocities are continuous.
   ``"block"`` runs each feed block at its own constant speed over the interpolator's
   time (look-ahead blending under the feed and the axes' limits, never faster than
   length / feed: ``commanded_durations``), joints interpolated linearly and sampled
   at ``dt``, so the joint velocities jump at every block end;
   rapids as rest-to-rest trapezoids at the axes' limits. Acceleration and
   deceleration come from each axis's own smoothing filter (Ts, the controller's
   acc/dec after interpolation) inside the feed-drive model. A
   rapid ends in position (the controls' in-position check after positioning): the
   command holds for ``settle_time`` after every rapid and before every rapid, so a
   rapid's corner is not cut into the following feed block.
3. Every axis is simulated through its feed-drive model (``feeddrive.simulate_axis``,
   torque saturation included): identified from ``[axes.N.servo]`` or the stated
   default (``cam.motion.axis_models``); no axis is a perfect follower.
4. Commanded and simulated joints go through the machine's forward kinematics to tool
   tips and tool axes in the workpiece frame. Per sample: the *contour* error, the
   distance of the simulated tip from the commanded tip *path* (the closest point of
   the commanded polyline in a window of samples around the instant as long as the
   axes' lag: the normal deviation; a lag along the path is not a shape error), the
   *tool-axis* error, the angle between the simulated tool axis and the commanded one
   at that closest point, degrees, and the *tracking* error (distance from the
   commanded tip at the same instant: a common lag shows here but leaves no mark).
   Per block the largest of each over the block's samples.
5. K_FFP recommendation: the Best K_FFP method generalised to a program. The reference
   is the rotary axis that lags most (largest ``alpha_th / omega``); every linear axis
   gets the K_FFP whose phase lag at the program's characteristic angular frequency
   equals the reference's ramp lag, every other rotary axis the K_FFP that gives it
   the reference's ramp lag. The characteristic frequency is the RMS
   angular velocity of the rotary axes during feed blocks (a point on a table turning
   at omega moves X/Y sinusoidally at omega).
6. Where it shapes the part (``contact``, ``cam.motion.surface_error``): on the blocks
   whose ball touches the design surface, the deviation of the simulated ball centre
   along the surface normal (a deviation along the surface leaves no mark).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Literal

import numpy as np
from numpy.typing import NDArray

from cam.motion.axis_models import AxisModels, machine_axis_models
from cam.motion.cycle_time import program_cycle_time
from cam.motion.feeddrive import FeedDriveAxis, simulate_axis
from cam.motion.kffp_advice import characteristic_omega, recommend_kffp
from impeller_cam.errors import InputError
from postproc.program import MachineProgram, Motion

if TYPE_CHECKING:
    from cam.motion.surface_error import BlockContact
    from postproc.machine import Machine

__all__ = ["FEED_PROFILES", "MAX_SAMPLES", "PIECE_SAMPLES", "PROGRAM_DT", "ServoReport",
           "characteristic_omega", "commanded_durations", "commanded_motion",
           "corner_smoothing_time",
           "machine_corner_smoothing",
           "program_joints", "rapid_profiles", "recommend_kffp", "settle_time",
           "simulate_program"]

#: Default controller period of the program simulation, s.
PROGRAM_DT = 2.5e-4

#: Largest number of time samples simulated (memory guard: the main job's 4.2 M-sample
#: fillet program peaked at 2.0 GB, about 0.5 kB a sample; 12 M samples is 3 h 20 min of
#: program at the chain's 1 ms step, about 6 GB).
MAX_SAMPLES = 12_000_000
#: Samples simulated at once: a longer program is simulated in pieces split at its
#: rapids, where the axes are at rest (``servo_pieces``).
PIECE_SAMPLES = 1_000_000

#: How the control runs the feed across blocks (``simulate_program``).
FeedProfile = Literal["lookahead", "block"]
FEED_PROFILES: tuple[str, ...] = ("lookahead", "block")


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


def corner_smoothing_time(models: dict[int, FeedDriveAxis]) -> float:
    """Post-interpolation smoothing the control's corner speeds allow for, s.

    The largest ``Ts`` of the axes: a control with acc/dec after interpolation slows
    at corners so that its filter keeps them within ``G64 P`` (docs/motion.md 6.2;
    ``simulate_program``'s ``corner_smoothing``).
    """
    return max([a.ts for a in models.values()], default=0.0)


def machine_corner_smoothing(machine: Machine) -> float:
    """``corner_smoothing_time`` of ``machine``'s axis models, s; 0 without servo data.

    The cycle-time model (``cam.motion.breakdown``) and the servo prediction plan the
    look-ahead's corners with this one value, so the time reported is the time of the
    motion whose contour error is predicted.
    """
    from cam.motion.axis_models import machine_axis_models

    if not any(spec.servo for spec in machine.axes.values()):
        return 0.0
    return corner_smoothing_time(machine_axis_models(machine).models)


def settle_time(models: dict[int, FeedDriveAxis]) -> float:
    """Time the axes need to come into position after a stop, s.

    ``Ts + Ta + 4 / Kpp`` of the slowest axis: the smoothing and averaging windows
    pass, then four position-loop time constants (e^-4 < 2 %).
    """
    return max([a.ts + a.ta + 4.0 / a.kpp for a in models.values()], default=0.0)


@dataclass
class ServoReport:
    """Predicted contour error of a program, every axis modelled.

    Attributes
    ----------
    line : (n,) int64
        Source line of each block.
    deviation : (n,) float64
        Largest contour error (normal distance of the simulated tip from the commanded
        tip path) inside each block, mm.
    tool_axis : (n,) float64
        Largest tool-axis error inside each block, degrees.
    tracking : (n,) float64
        Largest tracking error (distance from the commanded tip at the same instant)
        inside each block, mm.
    tip : (n, 3) float64
        Commanded tool tip at each block's end, workpiece frame, mm.
    feed_rms : float
        RMS contour error over the samples of feed blocks, mm.
    axis_lag : dict of str -> float
        Largest |command - actual| per axis (mm or rad).
    saturated : dict of str -> bool
        Axis hit its torque limit during a feed block (a rapid may saturate: it ends
        in position before the next cut).
    recommended_kffp : dict of str -> float or None
        Best K_FFP per axis, percent (None: no K_FFP in range matches).
    deviation_recommended, tool_axis_recommended : (n,) float64 or None
        The per-block contour and tool-axis errors again with the recommended K_FFP.
    feed_rms_recommended : float or None
    omega : float
        Characteristic angular frequency used for the recommendation, rad/s.
    reference_axis : str or None
    model_source : dict of str -> str
        Per axis: ``"identified"`` or the default it got (``axis_models``).
    surface, surface_recommended : (n,) float64 or None
        With a ``BlockContact``: the largest deviation of the simulated ball centre
        along the design surface's normal inside each block in contact (zero
        elsewhere), mm, with the machine's and the recommended K_FFP
        (``cam.motion.surface_error``).
    surface_rms, surface_rms_recommended : float or None
        RMS of that deviation over the samples of the blocks in contact, mm.
    gouge : (n,) float64 or None
        With a ``BlockContact``, machine K_FFP: the largest part of it that points
        into the part (a gouge; the rest leaves material standing), mm.
    """

    line: NDArray[np.int64]
    deviation: NDArray[np.float64]
    tool_axis: NDArray[np.float64]
    tracking: NDArray[np.float64]
    tip: NDArray[np.float64]
    feed_rms: float
    axis_lag: dict[str, float]
    saturated: dict[str, bool]
    recommended_kffp: dict[str, float | None]
    deviation_recommended: NDArray[np.float64] | None
    tool_axis_recommended: NDArray[np.float64] | None
    feed_rms_recommended: float | None
    omega: float
    reference_axis: str | None
    model_source: dict[str, str] = field(default_factory=dict)
    surface: NDArray[np.float64] | None = None
    surface_recommended: NDArray[np.float64] | None = None
    surface_rms: float | None = None
    surface_rms_recommended: float | None = None
    gouge: NDArray[np.float64] | None = None

    @property
    def default_axes(self) -> list[str]:
        """Axes modelled by the stated default (no servo data in the machine file)."""
        return [n for n, s in self.model_source.items() if s != "identified"]

    def as_dict(self) -> dict[str, object]:
        """JSON-ready summary (per-block arrays as worst lines).

        Returns
        -------
        dict
            Largest and RMS contour error (mm), the worst line, K_FFP advice.
        """
        worst = int(np.argmax(self.deviation)) if len(self.deviation) else -1
        out: dict[str, object] = {
            "max_contour_error_mm": float(self.deviation.max()) if worst >= 0 else 0.0,
            "rms_contour_error_feed_mm": self.feed_rms,
            "max_tool_axis_error_deg": float(self.tool_axis.max()) if worst >= 0 else 0.0,
            "max_tracking_error_mm": float(self.tracking.max()) if worst >= 0 else 0.0,
            "worst_line": int(self.line[worst]) if worst >= 0 else None,
            "axis_lag": self.axis_lag,
            "saturated": self.saturated,
            "recommended_kffp_percent": self.recommended_kffp,
            "omega_rad_s": self.omega,
            "reference_axis": self.reference_axis,
            "axis_models": self.model_source,
        }
        if self.deviation_recommended is not None and len(self.deviation_recommended):
            out["max_contour_error_recommended_mm"] = float(self.deviation_recommended.max())
            out["rms_contour_error_feed_recommended_mm"] = self.feed_rms_recommended
        return out


#: Fractions of a rapid's duration at which its trapezoid is sampled as knots.
RAPID_SHAPE = np.linspace(0.0, 1.0, 33)[1:-1]


def rapid_profiles(delta: NDArray[np.float64], machine: Machine
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Rest-to-rest trapezoids of rapid blocks at the machine's limits.

    The path parameter ``u`` (0..1) is bounded by ``v_k / |dq_k|`` and
    ``a_k / |dq_k|`` over the axes; the block accelerates at the bound, cruises,
    decelerates (a triangle when the cruise speed is not reached).

    Parameters
    ----------
    delta : (r, 5) float64
        Joint change of each rapid, mm and rad.

    Returns
    -------
    duration : (r,) float64
        s.
    shape : (r, len(RAPID_SHAPE)) float64
        ``u`` at the times ``RAPID_SHAPE * duration``.
    """
    from cam.motion.cycle_time import axis_limits

    vel, acc, _ = axis_limits(machine)
    size = np.abs(delta)
    with np.errstate(divide="ignore"):
        v = np.min(np.where(size > 0, vel / size, np.inf), axis=1)
        a = np.min(np.where(size > 0, acc / size, np.inf), axis=1)
    moving = np.isfinite(v)
    v, a = np.where(moving, v, 1.0), np.where(moving, a, 1.0)
    v = np.minimum(v, np.sqrt(a))  # a triangle when the cruise speed is not reached
    ramp = v / a
    duration = np.where(moving, 1.0 / v + ramp, 0.0)
    t = RAPID_SHAPE[None, :] * duration[:, None]
    left = np.maximum(duration[:, None] - t, 0.0)
    u = np.where(t < ramp[:, None], 0.5 * a[:, None] * t**2,
                 np.where(left < ramp[:, None], 1.0 - 0.5 * a[:, None] * left**2,
                          0.5 * v[:, None] * ramp[:, None] + v[:, None] * (t - ramp[:, None])))
    return duration, np.clip(u, 0.0, 1.0)


def commanded_motion(
    program: MachineProgram, machine: Machine, joints: NDArray[np.float64], dt: float,
    settle: float = 0.0, durations: NDArray[np.float64] | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Sample the commanded joints at ``dt``: feed blocks at constant speed over their
    durations, rapids as trapezoids at the machine's limits (``rapid_profiles``).

    Parameters
    ----------
    settle : float
        In-position hold, s, added after every rapid block and every block followed
        by a rapid (counted to that block).
    durations : (n,) float64, optional
        Nominal block times, s (default: ``program_cycle_time(...).nominal``).

    Returns
    -------
    time : (m,) float64
    command : (m, 5) float64
    block_end : (n,) float64
        End time of each block (hold included), s.
    """
    times = program_cycle_time(program, machine, joints).nominal if durations is None \
        else durations
    rapid = program.motion == Motion.RAPID
    times = times.copy()
    path = np.vstack([program.start[None, :], joints])
    shape = np.zeros((len(joints), len(RAPID_SHAPE)))
    if rapid.any():
        times[rapid], shape[rapid] = rapid_profiles(np.diff(path, axis=0)[rapid], machine)
    stop = rapid | np.concatenate([rapid[1:], [False]])
    ends = np.cumsum(times + settle * stop)
    begin = np.concatenate([[0.0], ends[:-1]])
    # knots: inside each block (rapids follow their trapezoid), its arrival, its hold
    inner_t = begin[:, None] + RAPID_SHAPE[None, :] * times[:, None]
    inner_q = path[:-1, None, :] + shape[:, :, None] * (path[1:, None, :] - path[:-1, None, :])
    keep = np.broadcast_to(rapid[:, None], shape.shape)
    knots_t = np.concatenate([[0.0], inner_t[keep], begin + times, ends])
    knots_q = np.vstack([program.start[None, :], inner_q[keep], joints, joints])
    order = np.argsort(knots_t, kind="stable")
    knots_t, knots_q = knots_t[order], knots_q[order]
    tail = 0.5  # let the axes settle after the last block
    m = int(math.ceil((ends[-1] + tail) / dt)) + 1
    if m > MAX_SAMPLES:
        raise InputError("program too long to simulate at this step", field="dt",
                         value=dt, accepted=f"a larger step (needs {m} samples)")
    t = np.arange(m, dtype=np.float64) * dt
    command = np.empty((m, knots_q.shape[1]))
    for c in range(knots_q.shape[1]):
        command[:, c] = np.interp(t, knots_t, knots_q[:, c])
    return t, command, ends


def commanded_durations(program: MachineProgram, machine: Machine,
                        joints: NDArray[np.float64]) -> NDArray[np.float64]:
    """Feed blocks' durations as the interpolator runs them, s.

    The look-ahead blending time (``blending.blended_program_time``: the feed, the
    axes' velocity, acceleration and jerk limits, corner speeds within ``G64 P``), never
    below the nominal length / feed. A block whose nominal time would need more than
    the machine's acceleration (a G93 block at ten times its neighbours' rate) is
    stretched as the control stretches it.
    """
    from cam.motion.blending import blended_program_time

    nominal = program_cycle_time(program, machine, joints).nominal
    blended = blended_program_time(program, machine, joints).time
    return np.maximum(nominal, blended)


def _block_index(t: NDArray[np.float64], ends: NDArray[np.float64]) -> NDArray[np.int64]:
    return np.minimum(np.searchsorted(ends, t, side="left"), len(ends) - 1)


def simulate_program(
    program: MachineProgram, machine: Machine, dt: float = PROGRAM_DT,
    recommend: bool = True, models: AxisModels | None = None,
    feed_profile: FeedProfile = "lookahead", contact: BlockContact | None = None,
    corner_smoothing: float = 0.0,
) -> ServoReport:
    """Simulate every axis of ``program`` and predict the contour error at the tool.

    Parameters
    ----------
    program : MachineProgram
    machine : Machine
    dt : float
        Controller period, s.
    recommend : bool
        Also compute the Best K_FFP per axis and the contour error with it.
    models : AxisModels, optional
        The axes' feed-drive models (default: ``machine_axis_models(machine)``).
    feed_profile : {"lookahead", "block"}
        The control's look-ahead feed profile (joint velocities continuous) or every
        feed block at its own constant speed (module doc, step 2).
    contact : BlockContact, optional
        Blocks whose ball touches the design surface and its normals: the report
        then also gives the error along the surface normal (``surface``).
    corner_smoothing : float
        Look-ahead only: post-interpolation smoothing (s) the control's corner speeds
        allow for (``blending.plan_speeds``'s ``smoothing``; 0: none).

    Returns
    -------
    ServoReport
    """
    from cam.motion.contour import contour_error
    from cam.motion.servo_pieces import ErrorSums, contact_rows, program_pieces, sub_program
    from postproc.kinematics import kinematics_for

    if len(program) == 0:
        raise InputError("the program has no motion blocks", field="program")
    if feed_profile not in FEED_PROFILES:
        raise InputError("unknown feed profile", field="feed_profile", value=feed_profile,
                         accepted=" or ".join(FEED_PROFILES))
    models = machine_axis_models(machine) if models is None else models
    axes = models.models
    joints = program_joints(program, machine)
    settle = settle_time(axes)
    durations = commanded_durations(program, machine, joints)
    omega = characteristic_omega(program, machine, joints, durations)
    recommended: dict[str, float | None] = {}
    reference = None
    runs: dict[str, dict[int, FeedDriveAxis]] = {"machine": axes}
    if recommend and omega > 0.0:
        recommended, reference = recommend_kffp(axes, omega, models.source)
        runs["tuned"] = {c: m if recommended.get(m.name) is None else
                         m.with_kffp(float(recommended[m.name]))  # type: ignore[arg-type]
                         for c, m in axes.items()}
    n = len(program)
    sums = {key: ErrorSums(n) for key in runs}
    lag = {m.name: 0.0 for m in axes.values()}
    saturated = {m.name: False for m in axes.values()}
    window = int(math.ceil(settle / dt)) + 1
    rapid = program.motion == Motion.RAPID
    stops = rapid | np.concatenate([rapid[1:], [False]])
    rapids = np.flatnonzero(rapid)
    for first, stop in program_pieces(program.motion, durations + settle * stops, dt,
                                      PIECE_SAMPLES):
        # the pass before the piece as its warm-up (servo_pieces)
        warm = int(rapids[rapids < first][-1]) if first > 0 else 0
        piece = sub_program(program, joints, warm, stop)
        if feed_profile == "lookahead":
            from cam.motion.lookahead import lookahead_motion

            t, command, ends = lookahead_motion(piece, machine, piece.joints, dt, settle,
                                                max_samples=MAX_SAMPLES,
                                                smoothing=corner_smoothing)
        else:
            t, command, ends = commanded_motion(piece, machine, piece.joints, dt, settle,
                                                durations[warm:stop])
        # a piece's last block holds before the next piece's rapid: its tail does
        ends[-1] += settle if stop < n else 0.0
        index = _block_index(t, ends)
        feed_samples = (piece.motion == Motion.LINEAR)[index]
        for key, chosen in runs.items():
            actual = command.copy()
            for column, model in chosen.items():
                response = simulate_axis(model, command[:, column], dt)
                actual[:, column] = response.position
                if key == "machine":
                    saturated[model.name] |= bool(response.saturated[feed_samples].any())
                    lag[model.name] = max(lag[model.name], float(
                        np.max(np.abs(response.position - command[:, column]))))
            error = contour_error(machine, command, actual, window, (warm == 0, stop == n))
            sums[key].add(first, stop, index, feed_samples, error,
                          contact_rows(contact, warm, stop), skip=first - warm,
                          keep=None if stop == n else t <= ends[-1])
            del actual, error
    tip, _ = kinematics_for(machine).forward(joints)
    got, tuned = sums["machine"], sums.get("tuned")
    return ServoReport(
        line=program.line.copy(), deviation=got.contour, tool_axis=got.tool_axis,
        tracking=got.tracking, tip=tip, feed_rms=got.feed_rms, axis_lag=lag,
        saturated=saturated, recommended_kffp=recommended,
        deviation_recommended=None if tuned is None else tuned.contour,
        tool_axis_recommended=None if tuned is None else tuned.tool_axis,
        feed_rms_recommended=None if tuned is None else tuned.feed_rms,
        omega=omega, reference_axis=reference, model_source=dict(models.source),
        surface=None if contact is None else got.surface,
        surface_recommended=None if contact is None or tuned is None else tuned.surface,
        surface_rms=None if contact is None else got.surface_rms,
        gouge=None if contact is None else got.gouge,
        surface_rms_recommended=None if contact is None or tuned is None else
        tuned.surface_rms,
    )
