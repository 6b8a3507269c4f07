"""Contour error: how far a simulated tool pose lies from the commanded *path*.

A servo that lags behind its command along the path leaves no mark on the part; what
the part shows is the deviation normal to the path. For every simulated sample ``k``
the closest point of the commanded tip polyline is searched among the commanded
samples ``k - back .. k + ahead`` (a window as long as the axes' lag: the actual tip
is near where the command was a lag ago). The contour error is the distance to that
point, mm; the tool-axis error is the angle between the simulated tool axis and the
commanded tool axis interpolated at that point, degrees.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numba
import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from postproc.machine import Machine

__all__ = ["ContourError", "contour_error", "path_distance"]


@numba.njit(cache=True)
def _closest_on_path(
    command: NDArray[np.float64], actual: NDArray[np.float64], back: int, ahead: int,
    first: int, last: int,
    distance: NDArray[np.float64], segment: NDArray[np.int64], along: NDArray[np.float64],
) -> None:  # pragma: no cover - compiled
    m = command.shape[0]
    for k in range(m):
        best = np.inf
        best_j = 0
        best_u = 0.0
        lo = max(k - back, 0)
        hi = min(k + ahead, m - 1)
        px, py, pz = actual[k, 0], actual[k, 1], actual[k, 2]
        count = max(hi, lo + 1) - lo
        for i in range(count + 2):
            # the window's segments, then the path's end segments (held samples
            # after a stop are zero-length: an overshoot is judged on the last move)
            if i < count:
                j = lo + i
            elif i == count:
                j = first
            else:
                j = last
            if j < 0:
                continue
            j1 = min(j + 1, m - 1)
            ax, ay, az = command[j, 0], command[j, 1], command[j, 2]
            dx, dy, dz = command[j1, 0] - ax, command[j1, 1] - ay, command[j1, 2] - az
            length2 = dx * dx + dy * dy + dz * dz
            u = 0.0
            if length2 > 0.0:
                u = ((px - ax) * dx + (py - ay) * dy + (pz - az) * dz) / length2
                if j != first:
                    u = max(u, 0.0)
                if j != last:
                    u = min(u, 1.0)
            ex, ey, ez = px - ax - u * dx, py - ay - u * dy, pz - az - u * dz
            dist = ex * ex + ey * ey + ez * ez
            if dist < best:
                best, best_j, best_u = dist, j, u
        distance[k] = np.sqrt(best)
        segment[k] = best_j
        along[k] = best_u


def path_distance(
    command: NDArray[np.float64], actual: NDArray[np.float64], back: int, ahead: int,
    extend: tuple[bool, bool] = (True, True),
) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.float64]]:
    """Distance of each actual point to the commanded polyline (windowed search).

    Parameters
    ----------
    command, actual : (m, 3) float64
        Commanded and simulated points at the same sample times, mm.
    back, ahead : int
        Commanded samples searched before and after each sample's own.
    extend : (bool, bool)
        The path's first / last moving segment extends beyond its end (it is an end
        of the whole path; False for a piece of a longer one).

    Returns
    -------
    distance : (m,) float64
        mm.
    segment : (m,) int64
        Start sample ``j`` of the closest commanded segment.
    along : (m,) float64
        Parameter of the closest point on segment ``j .. j + 1``: 0..1, except on the
        path's first and last moving segments, which extend beyond the path's ends
        (running past the end of the whole path along its tangent is a lag along the
        path, not a shape error).
    """
    m = len(command)
    moving = np.flatnonzero(np.any(np.diff(command, axis=0) != 0.0, axis=1))
    first, last = (int(moving[0]), int(moving[-1])) if len(moving) else (-1, -1)
    first, last = (first if extend[0] else -1), (last if extend[1] else -1)
    distance, segment, along = np.empty(m), np.empty(m, dtype=np.int64), np.empty(m)
    _closest_on_path(np.ascontiguousarray(command, dtype=np.float64),
                     np.ascontiguousarray(actual, dtype=np.float64), int(back),
                     int(ahead), first, last, distance, segment, along)
    return distance, segment, along


@dataclass(frozen=True)
class ContourError:
    """Deviation of a simulated motion from the commanded one, per sample.

    Attributes
    ----------
    contour : (m,) float64
        Tip distance from the commanded tip path, mm.
    tool_axis : (m,) float64
        Angle between simulated and commanded tool axis at the closest path point, deg.
    tracking : (m,) float64
        Tip distance from the commanded tip at the same instant, mm.
    tip : (m, 3) float64
        Commanded tip in the workpiece frame, mm.
    offset : (m, 3) float64
        Simulated tip minus the closest point of the commanded tip path, mm (its
        norm is ``contour``).
    axis_offset : (m, 3) float64
        Simulated tool axis minus the commanded tool axis at that point (unit vectors'
        difference; the ball centre ``R`` above the tip moves by ``R`` times it).
    """

    contour: NDArray[np.float64]
    tool_axis: NDArray[np.float64]
    tracking: NDArray[np.float64]
    tip: NDArray[np.float64]
    offset: NDArray[np.float64]
    axis_offset: NDArray[np.float64]


def contour_error(
    machine: Machine, command: NDArray[np.float64], actual: NDArray[np.float64],
    window: int, extend: tuple[bool, bool] = (True, True),
) -> ContourError:
    """Contour, tool-axis and tracking error of simulated joints against commanded.

    Parameters
    ----------
    machine : Machine
        Forward kinematics to the workpiece frame.
    command, actual : (m, 5) float64
        Commanded and simulated joints (mm, rad) at the same sample times.
    window : int
        Samples searched behind each instant (a quarter of it ahead).
    extend : (bool, bool)
        The motion's start / end is the whole path's (``path_distance``).

    Returns
    -------
    ContourError
        Per-sample contour (mm, normal to the commanded tip path), tool-axis (deg)
        and tracking (mm) errors.
    """
    from postproc.kinematics import kinematics_for

    kins = kinematics_for(machine)
    tip_c, axis_c = kins.forward(command)
    tip_a, axis_a = kins.forward(actual)
    distance, segment, along = path_distance(tip_c, tip_a, window, max(window // 4, 1),
                                             extend)
    nxt = np.minimum(segment + 1, len(axis_c) - 1)
    u = along[:, None]  # beyond 0..1 only past the path's ends: extrapolated
    axis_at = axis_c[segment] * (1.0 - u) + axis_c[nxt] * u
    axis_at /= np.maximum(np.linalg.norm(axis_at, axis=1, keepdims=True), 1e-300)
    cross = np.linalg.norm(np.cross(axis_at, axis_a), axis=1)
    dot = np.einsum("ij,ij->i", axis_at, axis_a)
    closest = tip_c[segment] * (1.0 - u) + tip_c[nxt] * u
    return ContourError(contour=distance, tool_axis=np.degrees(np.arctan2(cross, dot)),
                        tracking=np.linalg.norm(tip_a - tip_c, axis=1), tip=tip_c,
                        offset=tip_a - closest, axis_offset=axis_a - axis_at)
