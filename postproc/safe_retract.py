"""The post's safe retract around a rapid that turns a rotary axis.

A plain rapid (not a checked link, ``Toolpath.link``) that turns A or C is not written
as one joint move: the post retracts Z to the safe height, orients the rotary axes
there, positions X and Y, and the rapid then goes down to its end
(docs/postprocessors.md). The post (``postproc.posting``) and the finishing planner's
machine check (``cam.finishing.machine_obstacle.operation_clearance``) both move such a
rapid this way, from these two functions.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from postproc.feeds import ROTARY_STILL

__all__ = ["guarded_rapids", "safety_joints"]


def safety_joints(before: NDArray[np.float64], target: NDArray[np.float64], z_before: float,
                  z_after: float) -> NDArray[np.float64]:
    """Joints of the post's retract, orient and position blocks from ``before`` to ``target``.

    Parameters
    ----------
    before, target : (5,) float64
        Joints (X Y Z mm, A C rad) before the guard and of the move's end; NaN in
        ``before`` where unknown (program start).
    z_before, z_after : float
        Safe Z with the tool before and after the guard, mm.

    Returns
    -------
    (3, 5) float64
        Retract (Z up at ``before``'s X Y A C), orient (rotaries to ``target``'s at safe
        Z) and position (X Y to ``target``'s at safe Z); the move then goes down to
        ``target``.
    """
    bx, by, ba, bc = (float(v) for v in before[[0, 1, 3, 4]])
    return np.array([
        [bx, by, z_before, ba, bc],
        [bx, by, z_after, target[3], target[4]],
        [target[0], target[1], z_after, target[3], target[4]],
    ])


def guarded_rapids(joints: NDArray[np.float64], rapid: NDArray[np.bool_],
                   link: NDArray[np.bool_] | None = None) -> NDArray[np.int64]:
    """Rows ``j`` whose move ``j - 1 -> j`` the post guards with a safe retract.

    Rapids that turn a rotary axis, except checked links (``Toolpath.link``: their
    planner checked the joint move itself).

    Parameters
    ----------
    joints : (n, 5) float64
        The moves' joints (X Y Z mm, A C rad).
    rapid : (n,) bool
        Rows reached by a rapid.
    link : (n,) bool, optional
        Rows reached by a checked link.

    Returns
    -------
    (k,) int64
        The guarded rows, ascending.
    """
    if len(joints) < 2:
        return np.zeros(0, np.int64)
    turn = np.abs(np.diff(joints[:, 3:], axis=0)).max(axis=1) > ROTARY_STILL
    if link is not None:
        turn &= ~np.asarray(link, bool)[1:]
    return np.asarray(np.flatnonzero(np.asarray(rapid, bool)[1:] & turn) + 1, np.int64)
