"""The commanded joint trajectory of a control with look-ahead: the servo's input.

A control running a program under ``G64 P`` (LinuxCNC's trajectory planner, Sinumerik's
and Heidenhain's look-ahead) does not run each block at its own constant speed: it
plans the path speed over many blocks, so the speed never jumps at a block end and
the joint velocities stay continuous. This module turns the look-ahead plan of
``blending.plan_speeds`` (the cycle-time model of the chain: one model for the time
and for the motion) into joint positions sampled in time:

1. **Runs.** Consecutive feed blocks form one run, planned from rest to rest; every
   rapid is a run of its own (a rest-to-rest move at the axes' limits, jerk-limited)
   and ends in position: the command holds for ``settle`` after every rapid and
   before every rapid, as the block-wise model (``program_servo.commanded_motion``).
2. **Path speed.** Inside a run the plan gives each segment (a collinear run of
   blocks with the same bounds, in normalised joint space ``y_k = q_k / v_k``) its
   entry, peak and exit speed; each speed change is the plan's S-curve phase (jerk
   ``+J, 0, -J`` between zero accelerations, at the segment's acceleration and jerk
   bounds), so the path speed is continuous and its acceleration and jerk stay
   within every axis's limits. The joints follow the polyline at that speed.
3. **Corner blends.** At a corner between segments the joint velocities change
   direction at the corner speed ``sigma``. The command blends them with the
   parabolic blend of the plan's corner model: over ``T = sigma tau`` centred on the
   corner the velocity changes linearly, ``dq = dv min(u, T - u)^2 / (2 T)`` is added
   (``u`` the time into the blend, ``dv`` the joints' velocity change); each joint's
   acceleration is ``|dv_k| / T <= a_k``, the corner is cut by ``|dv| T / 8 <= P``
   (the plan's corner speed). The blend is acceleration-limited only (its
   acceleration steps are what the servo's smoothing ``Ts`` then rounds).

Without the blends and the speed plan (``program_servo``'s ``feed_profile="block"``)
every block runs at its own speed and the joint velocities jump at each block end.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numba
import numpy as np
from numpy.typing import NDArray

from cam.motion.blending import DEFAULT_TOLERANCE_MM, SpeedPlan, plan_speeds
from cam.motion.cycle_time import axis_limits, path_rate_bound, rotary_mask
from impeller_cam.errors import InputError
from postproc.program import MachineProgram, Motion

if TYPE_CHECKING:
    from postproc.machine import Machine

__all__ = ["lookahead_motion", "segment_pieces"]

Array = NDArray[np.float64]

#: Time after the last block the axes are simulated to settle, s.
TAIL = 0.5


def segment_pieces(plan: SpeedPlan) -> tuple[Array, Array, Array, Array, Array]:
    """Seven constant-jerk pieces per segment of the plan (speed up, cruise, slow down).

    Returns
    -------
    duration, jerk, acceleration, speed, distance : (s, 7) float64
        Per piece: duration (s), path jerk (1/s^2), and path acceleration (1/s),
        speed (1) and distance along the segment (y units) at its start.
    """
    peak = plan.peak()
    duration = np.zeros((len(peak), 7))
    jerk = np.zeros((len(peak), 7))
    acc0 = np.zeros((len(peak), 7))
    for change, cols, sign in ((peak - plan.entry, (0, 1, 2), 1.0),
                               (peak - plan.exit, (4, 5, 6), -1.0)):
        dv = np.maximum(change, 0.0)
        finite = np.isfinite(plan.jerk)
        with np.errstate(invalid="ignore", divide="ignore"):
            top = np.where(finite, np.minimum(plan.acc, np.sqrt(dv * plan.jerk)),
                           np.where(dv > 0, plan.acc, 0.0))  # peak path acceleration
            ramp = np.where(finite & (top > 0), top / plan.jerk, 0.0)
            hold = np.where(top > 0, dv / np.where(top > 0, top, 1.0) - ramp, 0.0)
        duration[:, cols[0]], duration[:, cols[1]], duration[:, cols[2]] = \
            ramp, np.maximum(hold, 0.0), ramp
        j = np.where(finite, plan.jerk, 0.0)
        jerk[:, cols[0]], jerk[:, cols[2]] = sign * j, -sign * j
        acc0[:, cols[1]], acc0[:, cols[2]] = sign * top, sign * top
    speed = np.zeros((len(peak), 7))
    dist = np.zeros((len(peak), 7))
    speed[:, 0] = plan.entry
    for p in range(6):
        tau, a, j = duration[:, p], acc0[:, p], jerk[:, p]
        speed[:, p + 1] = speed[:, p] + a * tau + 0.5 * j * tau**2
        dist[:, p + 1] = dist[:, p] + speed[:, p] * tau + 0.5 * a * tau**2 + j * tau**3 / 6
        if p == 2:  # the cruise: what the speed changes leave of the segment
            up = dist[:, 3]
            tau7 = duration[:, 4:7]
            down = 0.5 * (peak + plan.exit) * tau7.sum(axis=1)
            rest = np.maximum(plan.seg_length - up - down, 0.0)
            speed[:, 3] = peak
            duration[:, 3] = np.where(peak > 0, rest / np.where(peak > 0, peak, 1.0), 0.0)
    return duration, jerk, acc0, speed, dist


@numba.njit(cache=True)
def _add_blends(t: Array, command: Array, centre: Array, width: Array, dv: Array
                ) -> None:  # pragma: no cover - compiled
    dt = t[1] - t[0]
    for c in range(centre.shape[0]):
        w = width[c]
        if w <= 0.0:
            continue
        first = max(int(math.ceil((centre[c] - 0.5 * w) / dt)), 0)
        last = min(int(math.floor((centre[c] + 0.5 * w) / dt)), t.shape[0] - 1)
        for k in range(first, last + 1):
            u = t[k] - (centre[c] - 0.5 * w)
            r = min(u, w - u)
            if r <= 0.0:
                continue
            f = r * r / (2.0 * w)
            for m in range(command.shape[1]):
                command[k, m] += dv[c, m] * f


def _runs(program: MachineProgram) -> list[tuple[int, int]]:
    """``(first, stop)`` block ranges: each rapid alone, consecutive feed blocks together."""
    rapid = program.motion == Motion.RAPID
    breaks = np.flatnonzero(rapid[1:] | rapid[:-1]) + 1
    edges = np.concatenate([[0], breaks, [len(program)]])
    return [(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:], strict=True) if b > a]


def lookahead_motion(
    program: MachineProgram, machine: Machine, joints: Array, dt: float,
    settle: float = 0.0, tolerance: float = DEFAULT_TOLERANCE_MM,
    max_samples: int = 12_000_000, smoothing: float = 0.0,
) -> tuple[Array, Array, Array]:
    """Sample the commanded joints of a look-ahead control at ``dt`` (module doc).

    Parameters
    ----------
    program : MachineProgram
    machine : Machine
        Axis velocity, acceleration and jerk limits.
    joints : (n, 5) float64
        Joint targets of the blocks (TCP blocks mapped to joints), mm and rad.
    dt : float
        Sample period, s.
    settle : float
        In-position hold after every rapid and before every rapid, s.
    tolerance : float
        ``G64 P``, mm (rotary joints: degrees).
    max_samples : int
        Memory guard on the number of time samples.
    smoothing : float
        Post-interpolation smoothing the corner speeds allow for, s
        (``blending.plan_speeds``; 0: the cycle-time model's corners).

    Returns
    -------
    time : (m,) float64
        s.
    command : (m, 5) float64
        Commanded joints, mm and rad.
    block_end : (n,) float64
        End time of each block (its hold included), s.
    """
    vel, acc, jerk = axis_limits(machine)
    rotary = rotary_mask(machine)
    path = np.vstack([program.start[None, :], joints])
    delta = np.diff(path, axis=0)
    delta = np.where(np.isfinite(delta), delta, 0.0)
    bound = path_rate_bound(program, delta, rotary)
    rapid = program.motion == Motion.RAPID
    stop = rapid | np.concatenate([rapid[1:], [False]])
    ylen = np.linalg.norm(delta / vel, axis=1)
    vertex = np.concatenate([[0.0], np.cumsum(ylen)])  # arc coordinate of block ends
    # pieces of the arc coordinate S(t): start time, duration, jerk, a0, v0, S0
    starts, durs, jerks, accs, speeds, dists = [], [], [], [], [], []
    corner_t, corner_w, corner_dv = [], [], []
    hold_end = np.full(len(program), -1.0)
    segment_end = np.full(len(program), np.nan)  # blocks that end a segment: exact
    clock = 0.0
    for first, stop_at in _runs(program):
        plan = plan_speeds(delta[first:stop_at], vel, acc, jerk, rotary,
                           bound[first:stop_at], tolerance, smoothing)
        if plan is not None:
            dur, jk, a0, v0, s0 = segment_pieces(plan)
            seg_start = vertex[first] + np.concatenate([[0.0], np.cumsum(plan.seg_length)])
            t0 = clock + np.concatenate([[0.0], np.cumsum(dur.ravel())])[:-1]
            starts.append(t0)
            durs.append(dur.ravel())
            jerks.append(jk.ravel())
            accs.append(a0.ravel())
            speeds.append(v0.ravel())
            dists.append((s0 + seg_start[:-1, None]).ravel())
            seg_end = clock + np.cumsum(dur.sum(axis=1))
            clock = float(seg_end[-1])
            last = np.flatnonzero(np.diff(np.append(plan.segment, -1)) != 0)
            segment_end[first + plan.moving[last]] = seg_end[plan.segment[last]]
            # corners: the joint velocity change at the corner speed
            speed = plan.exit[:-1]
            width = np.minimum(speed * plan.tau,
                               np.minimum(plan.time[:-1], plan.time[1:]))
            change = (plan.direction[1:] - plan.direction[:-1]) * vel
            corner_t.append(seg_end[:-1])
            corner_w.append(np.where(plan.tau > 0, width, 0.0))
            corner_dv.append(speed[:, None] * change)
        for i in range(first, stop_at):
            if stop[i]:
                starts.append(np.array([clock]))
                durs.append(np.array([settle]))
                for store in (jerks, accs, speeds):
                    store.append(np.zeros(1))
                dists.append(np.array([vertex[i + 1]]))
                clock += settle
                hold_end[i] = clock
    if not starts:
        raise InputError("the program has no motion blocks", field="program")
    piece_t, piece_d = np.concatenate(starts), np.concatenate(durs)
    piece_j, piece_a = np.concatenate(jerks), np.concatenate(accs)
    piece_v, piece_s = np.concatenate(speeds), np.concatenate(dists)
    m = int(math.ceil((clock + TAIL) / dt)) + 1
    if m > max_samples:
        raise InputError("program too long to simulate at this step", field="dt",
                         value=dt, accepted=f"a larger step (needs {m} samples)")
    t = np.arange(m, dtype=np.float64) * dt
    k = np.clip(np.searchsorted(piece_t, t, side="right") - 1, 0, len(piece_t) - 1)
    tau = np.clip(t - piece_t[k], 0.0, piece_d[k])
    arc = piece_s[k] + piece_v[k] * tau + 0.5 * piece_a[k] * tau**2 + piece_j[k] * tau**3 / 6
    arc = np.minimum(np.maximum.accumulate(arc), vertex[-1])  # rounding: monotone
    command = np.empty((m, path.shape[1]))
    for c in range(path.shape[1]):
        command[:, c] = np.interp(arc, vertex, path[:, c])
    if corner_t:
        _add_blends(t, command, np.concatenate(corner_t), np.concatenate(corner_w),
                    np.vstack(corner_dv))
    # a block ends when the arc coordinate passes its end (and its hold is over)
    reached = np.searchsorted(arc, vertex[1:] - 1e-12 * max(vertex[-1], 1.0), side="left")
    ends = np.where(np.isnan(segment_end), t[np.minimum(reached, m - 1)], segment_end)
    ends = np.where(hold_end >= 0.0, np.maximum(hold_end, ends), ends)
    return t, command, np.maximum.accumulate(ends)
