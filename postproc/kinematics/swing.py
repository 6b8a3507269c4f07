"""Where a rotary axis would have to turn faster than the machine allows.

Near the singular tool axis (on the C axis) a small change of tool axis needs a large
change of C; ``inverse`` keeps C at the singular pose itself, but the poses around it
can still ask for a C swing that the axis cannot follow in the time the move takes.
This module finds those moves; it does not change them (the caller decides: slow the
feed, re-plan the path, or accept the deviation).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from impeller_cam.errors import InputError

if TYPE_CHECKING:
    from postproc.machine import Machine


def rotary_rates(
    joints: NDArray[np.float64],
    seconds: NDArray[np.float64],
    start: NDArray[np.float64] | None = None,
) -> NDArray[np.float64]:
    """Mean speed of each joint over each move, units per second.

    Parameters
    ----------
    joints : (n, m) float64
        Joint targets, internal units.
    seconds : (n,) float64
        Duration of the move ending at each row, s.
    start : (m,) float64, optional
        Joints before row 0. Without it, row 0 has no move and gets rate 0.

    Returns
    -------
    (n, m) float64
        ``|d joint| / seconds``; ``inf`` for a move of zero duration that changes the
        joint, 0 for one that does not.
    """
    joints = np.asarray(joints, dtype=np.float64)
    before = np.empty_like(joints)
    if len(joints):
        before[1:] = joints[:-1]
        before[0] = joints[0] if start is None else np.asarray(start, dtype=np.float64)
    step = np.abs(joints - before)
    duration = np.asarray(seconds, dtype=np.float64).reshape(-1, 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        rate = np.where(step > 0.0, step / duration, 0.0)
    return rate


def c_swing_report(
    joints: NDArray[np.float64],
    seconds: NDArray[np.float64],
    machine: Machine,
    start: NDArray[np.float64] | None = None,
) -> list[dict[str, Any]]:
    """Moves where a rotary axis (C, and the tilt axis) exceeds its velocity limit.

    Parameters
    ----------
    joints : (n, 5) float64
        Joint targets, X, Y, Z mm, tilt and C rad (e.g. from ``inverse``).
    seconds : (n,) float64
        Duration of the move ending at each row, s (>= 0).
    machine : Machine
        Supplies the axis names and velocity limits.
    start : (5,) float64, optional
        Joints before row 0; without it row 0 is not checked.

    Returns
    -------
    list of dict
        One entry per offending (row, axis), ordered by row then axis:
        ``{"index": i, "axis": "C", "required_deg_s": float, "limit_deg_s": float,
        "delta_deg": float}`` (``required_deg_s`` is ``inf`` for a zero-time move).
    """
    joints = np.asarray(joints, dtype=np.float64).reshape(-1, 5)
    seconds = np.asarray(seconds, dtype=np.float64).reshape(-1)
    if len(seconds) != len(joints):
        raise InputError(
            "one move duration per joint row is needed",
            field="seconds",
            value=len(seconds),
            accepted=f"{len(joints)} durations",
        )
    if (seconds < 0.0).any() or np.isnan(seconds).any():
        row = int(np.flatnonzero(~(seconds >= 0.0))[0])
        raise InputError(
            f"move {row} has a negative or NaN duration",
            field="seconds",
            value=float(seconds[row]),
            accepted="durations >= 0 s",
        )
    specs = list(machine.axes.values())
    columns = [k for k, spec in enumerate(specs) if spec.rotary]
    rates = rotary_rates(joints, seconds, start)
    limits = np.array([specs[k].velocity for k in columns])
    over = rates[:, columns] > limits
    if start is None and len(joints):
        over[0] = False
    before = np.vstack([joints[:1] if start is None else np.reshape(start, (1, 5)), joints[:-1]])
    report: list[dict[str, Any]] = []
    for row, j in zip(*np.nonzero(over), strict=True):
        column = columns[j]
        report.append(
            {
                "index": int(row),
                "axis": specs[column].name,
                "required_deg_s": float(np.degrees(rates[row, column])),
                "limit_deg_s": float(np.degrees(limits[j])),
                "delta_deg": float(np.degrees(joints[row, column] - before[row, column])),
            }
        )
    return report
