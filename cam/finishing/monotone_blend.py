"""Monotone absorption of repaired postures into an axis curve (step 3 of the posture
repair, ``cam.finishing.repair``).

The chosen joints of repaired postures become anchors; the curve between anchors and
on ramps before and after them is the affine remap of the old curve in proportion to
its own travel, so a curve monotone before stays monotone (``absorb_monotone``).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from cam.finishing.reversals import direction

__all__ = ["absorb_monotone"]

Array = NDArray[np.float64]


def absorb_monotone(values: Array, index: NDArray[np.intp], targets: Array, arc: Array,
                    blend: float, deadband: float = 0.0) -> Array:
    """Move ``values[index]`` to ``targets`` keeping the curve monotone.

    Parameters
    ----------
    values : (n,) float64
        Axis positions along the path, monotone (beyond ``deadband``) in their
        overall direction s.
    index : (m,) intp
        Increasing indices of the anchors.
    targets : (m,) float64
        Wanted positions there. Anchors that go against s relative to the previous
        anchor are raised to it (``s * cummax``): the curve must stay monotone; such
        anchors miss their target and are repaired again in the next round.
    arc : (n,) float64
        Arc length along the path, mm (the ramps are at least ``blend`` long).
    blend : float
        Least length of the ramps before the first and after the last anchor, mm.

    Returns
    -------
    (n,) float64
        Between consecutive anchors (and ramp ends) ``p < q`` the new curve is
        ``T_p + w (T_q - T_p)`` with ``w = (V_i - V_p) / (V_q - V_p)`` (linear in arc
        length where ``V_q == V_p``): monotone because ``w`` is and ``T_q - T_p`` has
        the sign s. Outside the ramps the curve is unchanged; a ramp that would need
        to start before the path start (end) shifts the whole start (end) instead.
    """
    values = np.asarray(values, dtype=np.float64)
    n = len(values)
    s = direction(values)
    sv = s * values
    t = s * np.maximum.accumulate(s * np.asarray(targets, dtype=np.float64))
    st = s * t
    anchors: list[tuple[int, float]] = []
    # ramp in: back at least `blend`, and until the old curve is behind T_0
    first = int(index[0])
    j = first
    while j > 0 and (arc[first] - arc[j] < blend or sv[j] > st[0] - deadband):
        j -= 1
    if j < first:
        if sv[j] > st[0] - deadband:  # reached the path start: shift the start whole
            anchors.append((0, float(values[0] + t[0] - values[first])))
        else:
            anchors.append((j, float(values[j])))
    for k, (i, target) in enumerate(zip(index, t, strict=True)):
        if k:  # back to the old curve between anchors far apart, where it is monotone
            p = int(index[k - 1])
            a = p
            while a < i and (arc[a] - arc[p] < blend or sv[a] < st[k - 1] + deadband):
                a += 1
            b = int(i)
            while b > a and (arc[i] - arc[b] < blend or sv[b] > st[k] - deadband):
                b -= 1
            if p < a < b < i:
                anchors += [(a, float(values[a])), (b, float(values[b]))]
        anchors.append((int(i), float(target)))
    last = int(index[-1])
    j = last
    while j < n - 1 and (arc[j] - arc[last] < blend or sv[j] < st[-1] + deadband):
        j += 1
    if j > last:
        if sv[j] < st[-1] + deadband:  # reached the path end: shift the end whole
            anchors.append((n - 1, float(values[-1] + t[-1] - values[last])))
        else:
            anchors.append((j, float(values[j])))
    out = values.copy()
    out[anchors[0][0]] = anchors[0][1]
    for (p, tp), (q, tq) in zip(anchors[:-1], anchors[1:], strict=True):
        seg = np.arange(p, q + 1)
        span = values[q] - values[p]
        if s * span > 0:
            w = (values[seg] - values[p]) / span
        else:
            w = (arc[seg] - arc[p]) / max(arc[q] - arc[p], 1e-300)
        out[seg] = tp + w * (tq - tp)
    return out
