"""Cycle time with look-ahead blending (``G64 P``): blocks are not stopped at.

A controller with blending keeps moving through block ends: it rounds each corner
within the path tolerance and plans the speed over many blocks ahead. This model
does the same on the joint-space program, in four steps:

1. **Normalised joint space.** Each joint ``q_k`` is divided by its velocity limit,
   ``y_k = q_k / v_k``; a block is a straight segment in y of length ``L`` (2-norm)
   and unit direction ``d``. Along it the path speed ``sigma = |dy/dt|`` is bounded by
   the axes (``|d_k| sigma <= 1``) and the feed, the path acceleration by
   ``alpha_k / |d_k|`` (``alpha_k = a_k / v_k``) and the path jerk by
   ``(j_k / v_k) / |d_k|``. Consecutive collinear blocks with the same bounds are one
   segment (a control's look-ahead runs through them without any constraint).
2. **Corner speed** (our reading of a parabolic blend, as LinuxCNC's planner blends
   within ``G64 P``): at path speed ``sigma`` through a corner, the joint velocity
   changes by ``sigma (d2 - d1)``; at the axes' accelerations this takes
   ``T = sigma tau``, ``tau = max_k |d2_k - d1_k| / alpha_k``, and the blend's
   deviation from the corner is ``|dv| T / 8`` (per unit: the linear joints' change
   in mm/s against ``P`` mm, the rotary joints' in rad/s against ``P`` read in the
   rotary words' unit, degrees), so ``sigma^2 tau |v (d2 - d1)|_lin / 8 <= P``; the
   blend also uses at most half of either segment: ``sigma^2 tau <= min(L1, L2)``.
3. **Look-ahead**: the largest junction speeds reachable forwards from rest at the
   program start and backwards from rest at its end, under each segment's
   acceleration and jerk bounds (``_reach``).
4. **Segment time**: from its entry to its exit speed, each segment accelerates to
   a peak, cruises and decelerates; each speed change is an S-curve phase that starts
   and ends at zero acceleration (``T(dv) = dv / A + A / J`` when the acceleration
   limit is reached, ``2 sqrt(dv / J)`` otherwise; distance ``(v0 + v1) / 2 T``).
   Without a jerk limit this is the time-optimal trapezoid.

Because phases start and end at zero acceleration, a speed change cannot continue
across a corner: with jerk limits this is slightly pessimistic on programs whose
accelerations span many short non-collinear blocks. The model ignores the small
shortening of the path by the blends (at most ``P`` per corner).

Checked against closed forms (a line split into collinear blocks takes the time of
one line; a 90-degree corner, tests/cam/test_motion_blending.py) and against Ruckig
for single moves.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numba import njit
from numpy.typing import NDArray

from cam.motion.cycle_time import axis_limits, path_rate_bound, rotary_mask
from postproc.program import MachineProgram

if TYPE_CHECKING:
    from postproc.machine import Machine

__all__ = ["BlendedTime", "SpeedPlan", "blended_program_time", "blended_times",
           "plan_speeds", "DEFAULT_TOLERANCE_MM"]

Array = NDArray[np.float64]
#: The path tolerance of our LinuxCNC programs (``G64 P0.01``), mm.
DEFAULT_TOLERANCE_MM = 0.01
#: Blocks whose directions differ by less than this (radians in y) are collinear.
COLLINEAR = 1e-9
_BISECTIONS = 100


@njit(cache=True)
def _phase_time(dv: float, acc: float, jerk: float) -> float:
    """Duration of a speed change ``dv >= 0`` from and to zero acceleration, s."""
    if dv <= 0.0:
        return 0.0
    if not math.isfinite(jerk):
        return dv / acc
    if dv >= acc * acc / jerk:
        return dv / acc + acc / jerk
    return 2.0 * math.sqrt(dv / jerk)


@njit(cache=True)
def _phase_distance(v0: float, v1: float, acc: float, jerk: float) -> float:
    """Distance of the speed change from ``v0`` to ``v1`` (point-symmetric phase)."""
    return 0.5 * (v0 + v1) * _phase_time(abs(v1 - v0), acc, jerk)


@njit(cache=True)
def _reach(v: float, length: float, vmax: float, acc: float, jerk: float) -> float:
    """Highest speed reachable from ``v`` within ``length`` (at most ``vmax``)."""
    if _phase_distance(v, vmax, acc, jerk) <= length:
        return vmax
    lo, hi = v, vmax
    for _ in range(_BISECTIONS):
        mid = 0.5 * (lo + hi)
        if _phase_distance(v, mid, acc, jerk) <= length:
            lo = mid
        else:
            hi = mid
    return lo


@njit(cache=True)
def _segment_peak(v0: float, v1: float, length: float, vmax: float, acc: float,
                  jerk: float) -> float:
    """Highest speed of the shortest motion over ``length`` from ``v0`` to ``v1``."""
    if _phase_distance(v0, vmax, acc, jerk) + _phase_distance(vmax, v1, acc, jerk) <= length:
        return vmax
    lo, hi = max(v0, v1), vmax
    for _ in range(_BISECTIONS):
        mid = 0.5 * (lo + hi)
        if _phase_distance(v0, mid, acc, jerk) + _phase_distance(mid, v1, acc, jerk) \
                <= length:
            lo = mid
        else:
            hi = mid
    return lo


@njit(cache=True)
def _segment_time(v0: float, v1: float, length: float, vmax: float, acc: float,
                  jerk: float) -> float:
    """Shortest time over ``length`` from speed ``v0`` to ``v1`` (both feasible)."""
    if length <= 0.0:
        return 0.0
    peak = _segment_peak(v0, v1, length, vmax, acc, jerk)
    up = _phase_time(peak - v0, acc, jerk)
    down = _phase_time(peak - v1, acc, jerk)
    rest = length - _phase_distance(v0, peak, acc, jerk) - _phase_distance(peak, v1, acc, jerk)
    cruise = rest / peak if peak > 0.0 and rest > 0.0 else 0.0
    return up + down + cruise


@njit(cache=True)
def _plan(length: Array, vmax: Array, acc: Array, jerk: Array, corner: Array
          ) -> tuple[Array, Array, Array]:
    """Time, entry and exit speed of each segment; ``corner[i]``: speed limit at the
    end of segment i."""
    n = len(length)
    end = np.empty(n)
    # backwards from rest at the end
    after = 0.0
    for i in range(n - 1, -1, -1):
        end[i] = after
        if i > 0:
            after = min(corner[i - 1], vmax[i - 1], vmax[i],
                        _reach(after, length[i], vmax[i], acc[i], jerk[i]))
    # forwards from rest at the start
    out = np.empty(n)
    entry = np.empty(n)
    leave = np.empty(n)
    before = 0.0
    for i in range(n):
        exit_speed = min(end[i], _reach(before, length[i], vmax[i], acc[i], jerk[i]))
        out[i] = _segment_time(before, exit_speed, length[i], vmax[i], acc[i], jerk[i])
        entry[i] = before
        leave[i] = exit_speed
        before = exit_speed
    return out, entry, leave


@dataclass(frozen=True)
class SpeedPlan:
    """The look-ahead plan of consecutive blocks in normalised joint space ``y = q / v``.

    Attributes
    ----------
    moving : (k,) int64
        Indices of the blocks that move.
    segment : (k,) int64
        Segment (collinear run of blocks with the same bounds) of each moving block.
    length : (k,) float64
        Length of each moving block in y, s (y is joint / velocity limit).
    seg_length, vmax, acc, jerk : (s,) float64
        Per segment: length in y, bounds on the path speed (1), acceleration (1/s) and
        jerk (1/s^2).
    direction : (s, m) float64
        Unit direction of each segment in y.
    tau : (s - 1,) float64
        Per corner: joint-velocity change per unit path speed over the axes'
        accelerations, ``max_k |d2_k - d1_k| / alpha_k``, s (0: no corner).
    time, entry, exit : (s,) float64
        Per segment: duration (s), path speed at its start and at its end (1).
    """

    moving: NDArray[np.int64]
    segment: NDArray[np.int64]
    length: Array
    seg_length: Array
    vmax: Array
    acc: Array
    jerk: Array
    direction: Array
    tau: Array
    time: Array
    entry: Array
    exit: Array

    def peak(self) -> Array:
        """Highest path speed inside each segment ``(s,)`` (the plan's cruise speed)."""
        return np.array([_segment_peak(a, b, L, v, c, j) for a, b, L, v, c, j in
                         zip(self.entry, self.exit, self.seg_length, self.vmax,
                             self.acc, self.jerk, strict=True)], dtype=np.float64)


@dataclass(frozen=True)
class BlendedTime:
    """Per-block times of a program under look-ahead blending.

    Attributes
    ----------
    time : (n,) float64
        Time of each block, s (a segment's time shared by its collinear blocks in
        proportion to their lengths).
    tolerance : float
        Path tolerance ``P`` used, mm (rotary: the same number in degrees).
    """

    time: Array
    tolerance: float

    @property
    def total(self) -> float:
        """Sum of the block times, s."""
        return float(self.time.sum())


def plan_speeds(delta: Array, velocity: Array, acceleration: Array, jerk: Array,
                rotary: NDArray[np.bool_], rate_bound: Array,
                tolerance: float = DEFAULT_TOLERANCE_MM,
                smoothing: float = 0.0) -> SpeedPlan | None:
    """The look-ahead speed plan of consecutive straight joint moves, rest to rest.

    Parameters as ``blended_times``, and

    smoothing : float
        Time of the control's acc/dec after interpolation that the corner speed
        allows for, s (0: none, the module's corner model). A velocity change ``dv``
        smoothed over ``Ts`` rounds the corner by ``|dv| Ts / 8`` more, so the corner
        speed keeps ``|dv| (T + Ts) / 8 <= P`` (the blend's ``T = sigma tau``), as a
        control with a post-interpolation filter slows at corners (Fanuc's corner
        deceleration by the axes' allowable speed difference).

    Returns
    -------
    SpeedPlan or None
        None when no block moves.
    """
    delta = np.asarray(delta, dtype=np.float64)
    y = delta / velocity
    length = np.linalg.norm(y, axis=1)
    moving = np.flatnonzero(length > 0.0)
    if not moving.size:
        return None
    y, length = y[moving], length[moving]
    d = y / length[:, None]
    span = np.abs(d)
    alpha = acceleration / velocity
    with np.errstate(divide="ignore", over="ignore"):
        vmax = np.minimum(1.0 / span.max(axis=1), rate_bound[moving] * length)
        acc = np.min(np.where(span > 0, alpha / span, np.inf), axis=1)
        jrk = np.min(np.where(span > 0, (jerk / velocity) / span, np.inf), axis=1)
    # merge collinear runs with the same bounds into segments
    turn = np.linalg.norm(d[1:] - d[:-1], axis=1)
    same = (turn < COLLINEAR) & np.isclose(vmax[1:], vmax[:-1], rtol=1e-12, atol=0.0)
    segment = np.concatenate([[0], np.cumsum(~same)])
    count = int(segment[-1]) + 1
    seg_length = np.bincount(segment, weights=length, minlength=count)
    first = np.searchsorted(segment, np.arange(count))
    seg_vmax, seg_acc, seg_jerk, seg_d = vmax[first], acc[first], jrk[first], d[first]
    # corner speeds between segments
    change = seg_d[1:] - seg_d[:-1]
    with np.errstate(divide="ignore", invalid="ignore"):
        tau = np.max(np.abs(change) / alpha, axis=1)
        scale = np.where(rotary, math.pi / 180.0, 1.0)
        lin = np.linalg.norm((velocity * change)[:, ~rotary], axis=1) / tolerance
        rot = np.linalg.norm((velocity * change)[:, rotary], axis=1) / (
            tolerance * scale[rotary][0] if rotary.any() else 1.0)
        dev = np.maximum(lin, rot) / 8.0
        room = np.minimum(seg_length[1:], seg_length[:-1])
        # sigma^2 tau dev + sigma Ts dev <= 1 (blend and smoothing), sigma^2 tau <= room
        a, b = tau * dev, smoothing * dev
        within = np.where(b > 0, 2.0 / (b + np.sqrt(b * b + 4.0 * a)), 1.0 / np.sqrt(a))
        corner = np.minimum(within, np.sqrt(room / tau))
    corner = np.where(tau > 0, corner, np.inf)
    corner = np.concatenate([corner, [0.0]]).astype(np.float64)
    seg_len: Array = np.asarray(seg_length, dtype=np.float64)
    seg_vmax, seg_acc = np.asarray(seg_vmax, np.float64), np.asarray(seg_acc, np.float64)
    seg_jerk = np.asarray(seg_jerk, np.float64)
    seg_time, entry, leave = _plan(seg_len, seg_vmax, seg_acc, seg_jerk, corner)
    return SpeedPlan(moving=moving, segment=segment, length=length, seg_length=seg_len,
                     vmax=seg_vmax, acc=seg_acc, jerk=seg_jerk, direction=seg_d,
                     tau=np.where(tau > 0, tau, 0.0), time=seg_time, entry=entry,
                     exit=leave)


def blended_times(delta: Array, velocity: Array, acceleration: Array, jerk: Array,
                  rotary: NDArray[np.bool_], rate_bound: Array,
                  tolerance: float = DEFAULT_TOLERANCE_MM, smoothing: float = 0.0) -> Array:
    """Blended time of consecutive straight joint moves starting and ending at rest.

    Parameters
    ----------
    delta : (n, m) float64
        Joint displacement of each block, internal units (mm, rad).
    velocity, acceleration, jerk : (m,) float64
        Axis limits (jerk may be ``inf``).
    rotary : (m,) bool
        Rotary joints (tolerance read in degrees).
    rate_bound : (n,) float64
        Bound on the block parameter's rate ``ds/dt`` (the feed; ``inf`` for none), 1/s.
    tolerance : float
        Path tolerance ``P`` (``G64 P``), mm; rotary joints: degrees.
    smoothing : float
        Post-interpolation smoothing the corner speeds allow for, s (``plan_speeds``).

    Returns
    -------
    (n,) float64
        Time per block, s; 0 for blocks that do not move.
    """
    out = np.zeros(len(delta))
    plan = plan_speeds(delta, velocity, acceleration, jerk, rotary, rate_bound, tolerance,
                       smoothing)
    if plan is None:
        return out
    share = plan.length / plan.seg_length[plan.segment]
    out[plan.moving] = plan.time[plan.segment] * share
    return out


def blended_program_time(program: MachineProgram, machine: Machine,
                         joints: Array | None = None,
                         tolerance: float = DEFAULT_TOLERANCE_MM,
                         smoothing: float = 0.0) -> BlendedTime:
    """Blended times of every block of a joint-space program (from rest to rest).

    Parameters
    ----------
    program : MachineProgram
    machine : Machine
    joints : (n, 5) float64, optional
        Joint targets instead of ``program.joints`` (TCP blocks mapped to joints).
    tolerance : float
        ``G64 P``, mm.
    smoothing : float
        Post-interpolation smoothing the corner speeds allow for, s (``plan_speeds``).

    Returns
    -------
    BlendedTime
        Per-block blended durations, s.
    """
    vel, acc, jerk = axis_limits(machine)
    targets = program.joints if joints is None else joints
    path = np.vstack([program.start[None, :], targets])
    delta = np.diff(path, axis=0)
    delta = np.where(np.isfinite(delta), delta, 0.0)
    rotary = rotary_mask(machine)
    bound = path_rate_bound(program, delta, rotary)
    return BlendedTime(blended_times(delta, vel, acc, jerk, rotary, bound, tolerance,
                                     smoothing), tolerance)
