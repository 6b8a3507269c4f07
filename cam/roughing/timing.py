"""Cycle time of a roughing program, nominal and under the machine's limits.

Both times work on the joint-space program (X, Y, Z, A, C from the machine's inverse
kinematics) and the tool-tip path:

* **nominal**: feed moves take tip length / feed (plunges and ramps at
  ``plunge_feed_ratio`` of the feed), rapids and index moves the slowest axis's
  ``|dq_i| / v_i`` (no acceleration): what a CAM system quotes, and what the paper's
  Table 1 lists.
* **limited**: rapids, retracts to the safe height and A/C index moves are
  rest-to-rest, jerk-limited synchronised moves (``cam.motion.cycle_time
  .synchronised_times``, the S-curve planner of M5). Chains of feed moves are timed by
  a look-ahead velocity planner (forward and backward pass, numba): on each block the
  tip speed is bounded by the feed, by every axis's velocity limit
  (``v <= v_i L / |dq_i|``, which is where simultaneous rotary motion slows a
  five-axis path) and its acceleration limit (``a <= a_i L / |dq_i|``); at each
  junction the change of every axis velocity must be reachable with that axis's
  acceleration within one interpolation period ``junction_period`` (1 ms, LinuxCNC's
  servo period); chains start and end at rest. Jerk enters the rest-to-rest moves
  only: the contouring planner is trapezoidal (a lower bound for a jerk-limited
  controller).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numba
import numpy as np
from numpy.typing import NDArray

from cam.motion.cycle_time import axis_limits, synchronised_times
from postproc.toolpath import MoveKind

if TYPE_CHECKING:
    from postproc.machine import Machine

__all__ = ["JUNCTION_PERIOD", "block_times", "trapezoid_time"]

#: Interpolation period for the junction velocity jumps, s.
JUNCTION_PERIOD = 1e-3


@numba.njit(cache=True)
def trapezoid_time(length: float, v0: float, v1: float, vmax: float, amax: float) -> float:
    """Time to travel ``length`` from speed ``v0`` to ``v1`` with ``|a| <= amax``,
    ``v <= vmax`` (trapezoidal profile; ``v0, v1`` must be reachable), s."""
    if length <= 0.0:
        return 0.0
    peak2 = amax * length + 0.5 * (v0 * v0 + v1 * v1)
    peak = min(vmax, math.sqrt(peak2))
    peak = max(peak, max(v0, v1))
    t_up = (peak - v0) / amax
    t_down = (peak - v1) / amax
    cruise = length - (peak * peak - v0 * v0) / (2.0 * amax) - (peak * peak - v1 * v1) / (
        2.0 * amax)
    if cruise < 0.0:
        cruise = 0.0
    return t_up + t_down + cruise / peak


@numba.njit(cache=True)
def _plan_chain(length: NDArray[np.float64], vmax: NDArray[np.float64],
                amax: NDArray[np.float64], vjunction: NDArray[np.float64]
                ) -> NDArray[np.float64]:
    """Times of one chain of blocks starting and ending at rest (look-ahead planner)."""
    n = length.shape[0]
    v = np.zeros(n + 1)  # speed at the block boundaries
    for b in range(1, n):
        v[b] = min(vjunction[b - 1], vmax[b - 1], vmax[b])
    v[0] = 0.0
    v[n] = 0.0
    for b in range(n):  # forward: reachable from the start
        reach = math.sqrt(v[b] * v[b] + 2.0 * amax[b] * length[b])
        if v[b + 1] > reach:
            v[b + 1] = reach
    for b in range(n - 1, -1, -1):  # backward: able to stop
        reach = math.sqrt(v[b + 1] * v[b + 1] + 2.0 * amax[b] * length[b])
        if v[b] > reach:
            v[b] = reach
    out = np.empty(n)
    for b in range(n):
        out[b] = trapezoid_time(length[b], v[b], v[b + 1], vmax[b], amax[b])
    return out


def _chain_times(length: NDArray[np.float64], delta: NDArray[np.float64],
                 feed: NDArray[np.float64], vel: NDArray[np.float64],
                 acc: NDArray[np.float64], junction_period: float) -> NDArray[np.float64]:
    span = np.abs(delta)
    safe_len = np.maximum(length, 1e-12)
    rate = span / safe_len[:, None]  # joint units per mm of tip path
    with np.errstate(divide="ignore"):
        vmax = np.minimum(feed, np.min(np.where(rate > 0, vel / rate, np.inf), axis=1))
        amax = np.min(np.where(rate > 0, acc / rate, np.inf), axis=1)
    amax = np.where(np.isfinite(amax), amax, np.max(acc))
    direction = delta / safe_len[:, None]
    jump = np.abs(np.diff(direction, axis=0))
    with np.errstate(divide="ignore"):
        vj = np.min(np.where(jump > 0, acc * junction_period / jump, np.inf), axis=1)
    times = _plan_chain(np.ascontiguousarray(length), np.ascontiguousarray(vmax),
                        np.ascontiguousarray(amax), np.ascontiguousarray(vj))
    # blocks with no tip motion but rotary motion: at the rotary velocity limits
    still = length <= 1e-12
    if np.any(still):
        times[still] = np.max(span[still] / vel, axis=1)
    return np.asarray(times)


def block_times(tip: NDArray[np.float64], joints: NDArray[np.float64],
                kind: NDArray[np.int8], feed_mm_min: float, plunge_ratio: float,
                machine: Machine, junction_period: float = JUNCTION_PERIOD
                ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Nominal and limited time of every move, s (the move ending at each pose).

    Parameters
    ----------
    tip : (n, 3) float64
        Tool tips, W, mm.
    joints : (n, 5) float64
        Machine joints of the poses (mm, rad).
    kind : (n,) int8
        ``MoveKind`` of the move ending at each pose (the first pose's move is 0 s).
    feed_mm_min : float
        Cutting feed, mm/min.
    plunge_ratio : float
        Plunge/ramp feed as a share of the cutting feed.
    machine : Machine

    Returns
    -------
    nominal, limited : (n,) float64
    """
    vel, acc, jerk = axis_limits(machine)
    n = len(tip)
    nominal = np.zeros(n)
    limited = np.zeros(n)
    if n < 2:
        return nominal, limited
    delta = np.diff(joints, axis=0)
    length = np.linalg.norm(np.diff(tip, axis=0), axis=1)
    k = kind[1:]
    feed = np.where(k == MoveKind.PLUNGE, plunge_ratio, 1.0) * feed_mm_min / 60.0
    rapid = k == MoveKind.RAPID
    with np.errstate(divide="ignore", invalid="ignore"):
        rapid_nominal = np.max(np.abs(delta) / vel, axis=1)
    nominal[1:] = np.where(rapid, rapid_nominal, length / feed)
    limited_moves = np.zeros(n - 1)
    if np.any(rapid):
        limited_moves[rapid] = synchronised_times(delta[rapid], vel, acc, jerk)
    cutting = ~rapid
    edges = np.flatnonzero(np.diff(np.concatenate([[0], cutting.astype(np.int8), [0]])))
    for a, b in zip(edges[::2], edges[1::2], strict=True):
        limited_moves[a:b] = _chain_times(length[a:b], delta[a:b], feed[a:b], vel, acc,
                                          junction_period)
    limited[1:] = limited_moves
    return nominal, limited
