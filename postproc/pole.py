"""Feed moves past the C axis: which of them keep their inverse branch.

A table-tilting machine reaches a tool axis off its C axis in two ways (tilt ``t``
with rotation ``c``, or ``-t`` with ``c + pi``). The post picks one per pose by least
rotary travel (``postproc.kinematics.branching``); inside a feed move, though, a
branch change is a tilt through 0, the tool axis through the C axis, and the
linearisation (``postproc.linearise``) can only follow it when the move's great
circle passes there. ``keeps_branch`` says which moves must stay on their branch;
the post (``posting``) and the finishing links (``cam.finishing.linking``, which
check their rapids in the post's joints) pass it to ``Kinematics.inverse``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from postproc.linearise import arc_distance

__all__ = ["keeps_branch"]


def keeps_branch(axis: NDArray[np.float64], moving: NDArray[np.bool_],
                 angular: float) -> NDArray[np.bool_]:
    """Moves that must stay on one inverse branch: they keep off the C axis.

    A table-tilting machine reaches an axis off the C axis with tilt ``t`` and rotation
    ``c`` or with ``-t`` and ``c + pi``. Changing branch inside a move turns the tilt
    through 0, i.e. the tool axis through the C axis; a feed move follows the great
    circle between its two axes, so it may change branch only when that arc passes
    within ``angular`` of the C axis (either pole). Near the pole the move then stays
    on its branch and C turns fast while the axis moves little, which the
    linearisation follows within tolerance.

    Parameters
    ----------
    axis : (n, 3) float64
        Unit tool axes of the poses, in any frame whose Z is the C axis (W).
    moving : (n,) bool
        ``moving[i]``: the move into pose ``i`` is a cut (feed, plunge, retract);
        ``moving[0]`` is ignored.
    angular : float
        Angular tolerance of the linearisation, rad.

    Returns
    -------
    (n,) bool
        ``out[i]``: the move into pose ``i`` must keep the branch of pose ``i - 1``;
        ``out[0]`` is False.
    """
    axis = np.asarray(axis, dtype=np.float64)
    out = np.zeros(len(axis), dtype=bool)
    rows = np.flatnonzero(np.asarray(moving, dtype=bool)[1:]) + 1
    if rows.size == 0:
        return out
    a0, a1 = axis[rows - 1], axis[rows]
    poles = np.broadcast_to(np.array([[[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]]]), (len(rows), 2, 3))
    out[rows] = arc_distance(poles, a0, a1).min(axis=1) > angular
    return out
