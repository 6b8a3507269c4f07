"""Cycle time of a joint-space program under per-axis velocity, acceleration, jerk limits.

Every block moves all axes together along a straight line in joint space,
``q(s) = q0 + s dq``, ``0 <= s <= 1``. Axis ``i`` limits the path parameter's rate to
``v_i / |dq_i|``, its acceleration to ``a_i / |dq_i|`` and its jerk to ``j_i / |dq_i|``;
the slowest axis decides. The programmed feed is an upper bound of the path speed:

* G94 (mm/min): ``ds/dt <= F / (60 L)`` with ``L`` the XYZ length of the block, or, for a
  purely rotary block, its rotary length in degrees (LinuxCNC's rule);
* G93 (inverse time): ``ds/dt <= F / 60`` (the block takes 1/F minutes);
* rapids: no feed bound (the axes' velocity limits only).

Two times per block:

* ``nominal``: length / feed (for rapids: at the slowest axis's velocity limit) - what a
  CAM system reports, no acceleration;
* ``limited``: the jerk-limited, time-optimal rest-to-rest S-curve (``scurve``) of the
  block under those limits - exact stop at every block (G61): an upper bound of what a
  controller with blending (G64) needs.

``index_moves_time`` times fixed-orientation index moves (3+2 re-orientation) the same
way, each as one synchronised rapid.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from cam.motion.scurve import plan_scurve
from impeller_cam.errors import InputError
from postproc.program import FeedMode, MachineProgram, Motion

if TYPE_CHECKING:
    from postproc.machine import Machine


def axis_limits(machine: Machine) -> tuple[NDArray[np.float64], ...]:
    """Velocity, acceleration and jerk limits ``(5,)`` each, internal units (jerk may be inf)."""
    specs = list(machine.axes.values())
    vel = np.array([s.velocity for s in specs], dtype=np.float64)
    acc = np.array([s.acceleration for s in specs], dtype=np.float64)
    jerk = np.array([s.jerk for s in specs], dtype=np.float64)
    for name, values in (("velocity", vel), ("acceleration", acc)):
        bad = ~(np.isfinite(values) & (values > 0))
        if np.any(bad):
            axis = specs[int(np.flatnonzero(bad)[0])].name
            raise InputError("a finite limit > 0 is needed to time a program",
                             file=machine.source, field=f"axes.{axis}.{name}",
                             value=float(values[bad][0]), accepted="a number > 0")
    return vel, acc, jerk


def rotary_mask(machine: Machine) -> NDArray[np.bool_]:
    """True for the rotary joint columns ``(5,)``."""
    return np.array([s.rotary for s in machine.axes.values()], dtype=np.bool_)


def synchronised_times(
    delta: NDArray[np.float64],
    velocity: NDArray[np.float64],
    acceleration: NDArray[np.float64],
    jerk: NDArray[np.float64],
    rate_bound: NDArray[np.float64] | None = None,
) -> NDArray[np.float64]:
    """Rest-to-rest time of synchronised straight joint moves, s.

    Parameters
    ----------
    delta : (n, m) float64
        Joint displacement of each move, internal units.
    velocity, acceleration, jerk : (m,) float64
        Axis limits (jerk may be ``inf``: trapezoidal).
    rate_bound : (n,) float64, optional
        Extra bound on ``ds/dt`` (the feed), 1/s; ``inf`` for none.

    Returns
    -------
    (n,) float64
        0 for moves that do not move.
    """
    span = np.abs(np.asarray(delta, dtype=np.float64))
    moving = span.max(axis=1) > 0.0 if span.size else np.zeros(len(span), dtype=bool)
    out = np.zeros(len(span))
    if not np.any(moving):
        return out
    span = span[moving]
    with np.errstate(divide="ignore"):
        v = np.min(velocity / span, axis=1)
        a = np.min(acceleration / span, axis=1)
        j = np.min(jerk / span, axis=1)
    if rate_bound is not None:
        v = np.minimum(v, rate_bound[moving])
    tj = np.where(np.isfinite(j), a / j, 0.0)
    profiles = plan_scurve(1.0, v, a, a, tj, pid_period=1.0)
    out[moving] = profiles.duration
    return out


@dataclass(frozen=True)
class CycleTime:
    """Times of a program's blocks.

    Attributes
    ----------
    nominal : (n,) float64
        Length / feed per block (rapids at the velocity limits), s.
    limited : (n,) float64
        Jerk-limited exact-stop time per block, s.
    line : (n,) int64
        Source line of each block.
    """

    nominal: NDArray[np.float64]
    limited: NDArray[np.float64]
    line: NDArray[np.int64]

    @property
    def nominal_total(self) -> float:
        """Sum of the nominal times, s."""
        return float(self.nominal.sum())

    @property
    def limited_total(self) -> float:
        """Sum of the jerk-limited times, s (the cycle time estimate)."""
        return float(self.limited.sum())

    def as_dict(self) -> dict[str, object]:
        """JSON-ready summary.

        Returns
        -------
        dict
            Cycle time (s), nominal time, the slowest block's line.
        """
        slow = int(np.argmax(self.limited - self.nominal)) if len(self.line) else -1
        return {
            "cycle_time_s": self.limited_total,
            "nominal_time_s": self.nominal_total,
            "blocks": len(self.line),
            "slowest_block_line": int(self.line[slow]) if slow >= 0 else None,
        }


def path_rate_bound(
    program: MachineProgram, delta: NDArray[np.float64], rotary: NDArray[np.bool_]
) -> NDArray[np.float64]:
    """Feed bound on ``ds/dt`` per block, 1/s (``inf`` for rapids)."""
    linear_length = np.linalg.norm(delta[:, ~rotary], axis=1)
    rotary_length = np.degrees(np.linalg.norm(delta[:, rotary], axis=1))
    length = np.where(linear_length > 0.0, linear_length, rotary_length)
    feed = program.feed
    rapid = program.motion == Motion.RAPID
    inverse = program.feed_mode == FeedMode.INVERSE_TIME
    bad = ~rapid & ~(np.isfinite(feed) & (feed > 0.0))
    if np.any(bad):
        i = int(np.flatnonzero(bad)[0])
        raise InputError("a feed block needs a feed > 0", field=f"line {program.line[i]}",
                         value=float(feed[i]), accepted="an F word > 0 before G1")
    with np.errstate(divide="ignore", invalid="ignore"):
        bound = np.where(inverse, feed / 60.0, feed / 60.0 / length)
    return np.where(rapid, np.inf, bound)


def program_cycle_time(program: MachineProgram, machine: Machine,
                       joints: NDArray[np.float64] | None = None) -> CycleTime:
    """Nominal and jerk-limited times of every block of a joint-space program.

    Parameters
    ----------
    program : MachineProgram
    machine : Machine
        Axis limits in internal units (``Machine.axes[n].velocity`` ...).
    joints : (n, 5) float64, optional
        Joint targets to use instead of ``program.joints`` (e.g. after mapping
        tool-centre-point blocks to joints, ``program_servo.program_joints``).

    Returns
    -------
    CycleTime
    """
    vel, acc, jerk = axis_limits(machine)
    targets = program.joints if joints is None else joints
    path = np.vstack([program.start[None, :], targets])
    delta = np.diff(path, axis=0)
    rotary = rotary_mask(machine)
    bound = path_rate_bound(program, delta, rotary)
    limited = synchronised_times(delta, vel, acc, jerk, bound)
    span = np.abs(delta)
    with np.errstate(divide="ignore", invalid="ignore"):
        fastest = np.min(np.where(span > 0, vel / span, np.inf), axis=1)
        rate = np.minimum(fastest, bound)
        nominal = np.where(span.max(axis=1) > 0, 1.0 / rate, 0.0)
    return CycleTime(nominal=nominal, limited=limited, line=program.line.copy())


def index_moves_time(
    start: NDArray[np.float64], end: NDArray[np.float64], machine: Machine
) -> NDArray[np.float64]:
    """Time of fixed-orientation index moves (synchronised rapids), s.

    Parameters
    ----------
    start, end : (n, 5) float64
        Joints before and after each index move, internal units.
    machine : Machine

    Returns
    -------
    (n,) float64
        Jerk-limited rest-to-rest time of each move.
    """
    vel, acc, jerk = axis_limits(machine)
    delta = np.asarray(end, dtype=np.float64) - np.asarray(start, dtype=np.float64)
    if delta.ndim != 2 or delta.shape[1] != len(vel):
        raise ValueError(f"start/end must be (n, {len(vel)}), not {delta.shape}")
    if not np.all(np.isfinite(delta)):
        raise InputError("index move joints must be finite", field="joints",
                         value=float(delta[~np.isfinite(delta)][0]) if delta.size else None)
    return synchronised_times(delta, vel, acc, jerk)


def format_seconds(seconds: float) -> str:
    """``h:mm:ss.s`` for reports."""
    if not math.isfinite(seconds):
        return "inf"
    hours, rest = divmod(seconds, 3600.0)
    minutes, secs = divmod(rest, 60.0)
    return f"{int(hours)}:{int(minutes):02d}:{secs:04.1f}"
