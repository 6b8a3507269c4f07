"""Choosing the inverse branch and the C winding along a whole path.

A table-tilting machine reaches every tool axis off its C axis in two ways: tilt
``t`` with rotation ``c``, or tilt ``-t`` with rotation ``c + pi``; and every ``c``
also as ``c + 2 pi k``. This module picks, for a path of ``n`` poses, one branch and
one winding per pose so that

1. every pose lies inside the axis limits (the caller says which branch is feasible at
   which pose; the C range is enforced here through the winding),
2. the total rotary travel ``sum |dT| + |dC|`` (radians) from the previous joints, or
   from the first pose when there are none, is least over all branch sequences,
3. C is unwound: each C is the winding nearest to the C before it; only when that
   winding leaves the C range is the nearest winding inside the range taken (a
   re-wind, visible as a C step of 2 pi in the result and in ``c_swing_report``),
4. at singular poses (tool axis on the C axis, C undefined) C keeps its previous
   value; singular poses before the first defined C take that first C,
5. where the caller asks for it (``keep``: feed moves whose tool axis does not pass
   the C axis), the move into a pose stays on the branch of the pose before: a
   branch change turns the tilt through 0, i.e. the tool axis through the C axis,
   which such a move does not do (``postproc.pole.keeps_branch``).

Rule 2 is a Viterbi dynamic programme over the two branches (two states per pose,
four transitions), run in numba: linear in ``n``, no Python loop per pose. Ties go
to staying on the same branch, then to branch 0 (tilt >= 0).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

_TWO_PI = 2.0 * math.pi


@njit(cache=True)
def _wind(c_raw: float, reference: float, c_min: float, c_max: float) -> float:
    """The winding ``c_raw + 2 pi k`` nearest ``reference`` inside ``[c_min, c_max]``.

    NaN when no winding of ``c_raw`` lies in the range.
    """
    k = math.floor((reference - c_raw) / _TWO_PI + 0.5)
    c = c_raw + k * _TWO_PI
    if c >= c_min and c <= c_max:
        return c
    k_low = math.ceil((c_min - c_raw) / _TWO_PI)
    k_high = math.floor((c_max - c_raw) / _TWO_PI)
    if k_low > k_high:
        return math.nan
    k = min(max(k, k_low), k_high)
    return c_raw + k * _TWO_PI


@njit(cache=True)
def _least_travel(
    tilt: NDArray[np.float64],
    c_raw: NDArray[np.float64],
    feasible: NDArray[np.bool_],
    singular: NDArray[np.bool_],
    keep: NDArray[np.bool_],
    has_previous: bool,
    previous_tilt: float,
    previous_c: float,
    c_min: float,
    c_max: float,
) -> tuple[NDArray[np.int8], NDArray[np.float64], int]:
    n = tilt.shape[1]
    branch = np.zeros(n, dtype=np.int8)
    c_out = np.zeros(n, dtype=np.float64)
    if n == 0:
        return branch, c_out, -1
    inf = math.inf
    start = 0
    if not has_previous:
        start = -1
        for i in range(n):
            if not singular[i]:
                start = i
                break
        if start == -1:  # every pose singular and nothing before: C nearest 0
            c0 = _wind(0.0, 0.0, c_min, c_max)
            if math.isnan(c0):
                return branch, c_out, 0
            for i in range(n):
                branch[i] = 0 if feasible[0, i] else 1
                if not feasible[branch[i], i]:
                    return branch, c_out, i
                c_out[i] = c0
            return branch, c_out, -1
    cost = np.full(2, inf)
    c_state = np.full((n, 2), math.nan)
    back = np.zeros((n, 2), dtype=np.int8)
    for b in range(2):
        if not feasible[b, start]:
            continue
        if has_previous:
            if singular[start]:
                c = previous_c
            else:
                c = _wind(c_raw[b, start], previous_c, c_min, c_max)
            step = abs(tilt[b, start] - previous_tilt) + abs(c - previous_c)
        else:
            c = _wind(c_raw[b, start], 0.0, c_min, c_max)
            step = 0.0
        if not math.isnan(c):
            cost[b] = step
            c_state[start, b] = c
    if cost[0] == inf and cost[1] == inf:
        return branch, c_out, start
    new_cost = np.empty(2)
    for i in range(start + 1, n):
        new_cost[0] = inf
        new_cost[1] = inf
        for b in range(2):
            if not feasible[b, i]:
                continue
            for k in range(2):
                p = b if k == 0 else 1 - b
                if cost[p] == inf:
                    continue
                if k == 1 and keep[i] and not singular[i] and not singular[i - 1]:
                    continue
                c_prev = c_state[i - 1, p]
                if singular[i]:
                    c = c_prev
                else:
                    c = _wind(c_raw[b, i], c_prev, c_min, c_max)
                if math.isnan(c):
                    continue
                total = cost[p] + abs(tilt[b, i] - tilt[p, i - 1]) + abs(c - c_prev)
                if total < new_cost[b]:
                    new_cost[b] = total
                    back[i, b] = p
                    c_state[i, b] = c
        if new_cost[0] == inf and new_cost[1] == inf:
            return branch, c_out, i
        cost[0] = new_cost[0]
        cost[1] = new_cost[1]
    b = 0 if cost[0] <= cost[1] else 1
    for i in range(n - 1, start - 1, -1):
        branch[i] = b
        c_out[i] = c_state[i, b]
        b = back[i, b]
    for i in range(start):
        branch[i] = branch[start]
        c_out[i] = c_out[start]
    return branch, c_out, -1


def least_travel_path(
    tilt: NDArray[np.float64],
    c_raw: NDArray[np.float64],
    feasible: NDArray[np.bool_],
    singular: NDArray[np.bool_],
    c_range: tuple[float, float],
    previous: tuple[float, float] | None = None,
    keep: NDArray[np.bool_] | None = None,
) -> tuple[NDArray[np.int8], NDArray[np.float64], int]:
    """Pick a branch and an unwound C per pose (see the module docstring for the rule).

    Parameters
    ----------
    tilt : (2, n) float64
        Tilt joint (A or B) of each branch, rad.
    c_raw : (2, n) float64
        C joint of each branch, any winding, rad.
    feasible : (2, n) bool
        Whether the branch's tilt and linear axes are inside their limits at the pose.
    singular : (n,) bool
        Poses whose tool axis lies on the C axis (C undefined).
    c_range : (float, float)
        C limits, rad (``-inf``/``inf`` for a continuous axis).
    previous : (float, float), optional
        Tilt and C joints before the first pose, rad.
    keep : (n,) bool, optional
        ``keep[i]``: the move from pose ``i - 1`` into pose ``i`` keeps the branch
        (unless one of the two poses is singular); ``keep[0]`` is ignored. Default:
        no such constraint.

    Returns
    -------
    branch : (n,) int8
        Chosen branch per pose (0 or 1).
    c : (n,) float64
        Unwound C per pose, rad.
    failed : int
        -1 on success, else the first pose at which no branch fits the limits.
    """
    has_previous = previous is not None
    previous_tilt, previous_c = previous if previous is not None else (0.0, 0.0)
    n = np.shape(singular)[0]
    kept = np.zeros(n, dtype=np.bool_) if keep is None else np.asarray(keep, dtype=np.bool_)
    if kept.shape != (n,):
        raise ValueError(f"keep has shape {kept.shape}, expected ({n},)")
    return _least_travel(  # type: ignore[no-any-return]
        np.ascontiguousarray(tilt, dtype=np.float64),
        np.ascontiguousarray(c_raw, dtype=np.float64),
        np.ascontiguousarray(feasible, dtype=np.bool_),
        np.ascontiguousarray(singular, dtype=np.bool_),
        np.ascontiguousarray(kept),
        has_previous,
        float(previous_tilt),
        float(previous_c),
        float(c_range[0]),
        float(c_range[1]),
    )


def wind_into_range(c_raw: float, reference: float, c_range: tuple[float, float]) -> float:
    """The winding of ``c_raw`` nearest ``reference`` inside ``c_range`` (NaN if none)."""
    return float(_wind(float(c_raw), float(reference), float(c_range[0]), float(c_range[1])))
