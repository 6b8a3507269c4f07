"""Reverse movements of the machine axes and their removal (M3 steps 4-5).

A *reverse movement* of an axis along a path is a sign change of its increments
(the "angular displacement curve" of the paper): between two consecutive moves the
axis stops and turns back. Increments smaller than a dead band are no movement and
neither start nor end a run.

Removal (the paper's section 4.2, Fig. 9): with ``dir`` the overall direction of the
axis along the path, every increment that goes the other way is shifted by
``dir * phi_L``, ``phi_L`` = the largest reversed increment plus a small minimum shift,
so the displacement curve moves one way; the positions rebuilt from the shifted
increments are smoothed by least squares with cubic B-splines (four basis functions
by default, on the normalised arc length of the ball-centre path); the smoothed
curve is checked again and the shift-and-smooth repeated until it is monotone.
By default (``scope="local"``) this is done on a window around each reversed range,
keeping the window's ends (seed 001 adjusts "the angular positions corresponding to
the regions where reverse movements presented"); ``scope="path"`` fits one cubic
over the whole path.

If it is still not monotone after the allowed rounds, the least-squares fit of the
original positions is done with the B-spline coefficients constrained to be monotone (non-negative
coefficient differences, ``scipy.optimize.nnls``); a B-spline function with monotone
coefficients is monotone, so this ends the iteration with a guaranteed result.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.interpolate import BSpline, make_lsq_spline
from scipy.optimize import nnls

__all__ = [
    "SmoothingResult",
    "count_reversals",
    "direction",
    "end_fixed_lsq_cubic",
    "lsq_cubic",
    "monotone_lsq_cubic",
    "reversal_points",
    "reversed_windows",
    "shift_reversed",
    "shift_reversed_keep_ends",
    "smooth_monotone",
    "uniform_knots",
]

Array = NDArray[np.float64]


def _moves(values: Array, deadband: float) -> tuple[NDArray[np.intp], Array]:
    """Indices and signs of the increments larger than ``deadband``."""
    d = np.diff(np.asarray(values, dtype=np.float64))
    index = np.flatnonzero(np.abs(d) > deadband)
    return index, np.sign(d[index])


def reversal_points(values: Array, deadband: float = 0.0) -> NDArray[np.intp]:
    """Point indices where an axis turns back along the path.

    Parameters
    ----------
    values : (n,) float64
        Axis positions along the path (mm or rad).
    deadband : float
        Increments with ``|d| <= deadband`` are not movements.

    Returns
    -------
    (k,) intp
        For every reversal, the index of the point at which the reversed move starts
        (the axis stopped there and went back).
    """
    index, sign = _moves(values, deadband)
    change = np.flatnonzero(sign[1:] != sign[:-1])
    return np.asarray(index[change + 1], dtype=np.intp)


def count_reversals(values: Array, deadband: float = 0.0) -> int:
    """Number of reverse movements (sign changes of the increments beyond the dead band).

    Parameters
    ----------
    values : (n,) float64
        An axis along a path (rad or mm).
    deadband : float
        Increments smaller than this (same unit) are no movement.

    Returns
    -------
    int
    """
    return int(len(reversal_points(values, deadband)))


def direction(values: Array) -> float:
    """Overall direction of an axis along the path: +1 or -1 (ties: +1)."""
    values = np.asarray(values, dtype=np.float64)
    net = float(values[-1] - values[0])
    if net == 0.0:
        net = float(np.sum(np.sign(np.diff(values))))
    return -1.0 if net < 0 else 1.0


def shift_reversed(values: Array, sense: float, min_shift: float,
                   deadband: float = 0.0) -> tuple[Array, float]:
    """Shift reversed increments by ``sense * phi_L`` so the curve moves one way (Fig. 9).

    Parameters
    ----------
    values : (n,) float64
    sense : float
        +1 or -1, the direction the axis must move.
    min_shift : float
        Least ``phi_L``; also the least size of a shifted increment.
    deadband : float
        Reversed increments within the dead band are left alone.

    Returns
    -------
    shifted : (n,) float64
        Positions rebuilt from the shifted increments, placed at the constant offset
        that fits ``values`` best in least squares (the paper leaves the anchor open;
        a constant keeps the curve monotone and halves the drift of a first-point
        anchor).
    phi_l : float
        The shift used (0 when nothing was reversed).
    """
    values = np.asarray(values, dtype=np.float64)
    d = np.diff(values)
    wrong = d * sense < -deadband
    if not wrong.any():
        return values.copy(), 0.0
    phi_l = float(np.max(np.abs(d[wrong]))) + min_shift
    d = d.copy()
    d[wrong] += sense * phi_l
    rebuilt = np.concatenate([[0.0], np.cumsum(d)])
    # anchor: the constant offset that fits the original positions best (keeps it monotone)
    return rebuilt + float(np.mean(values - rebuilt)), phi_l


def shift_reversed_keep_ends(values: Array, sense: float, min_shift: float,
                             deadband: float = 0.0) -> tuple[Array, float] | None:
    """``shift_reversed`` for a window that must join the untouched curve at both ends.

    The reversed increments are shifted by ``sense * phi_L`` as in Fig. 9; the
    increments that already go the right way are then scaled by one factor so that
    the window's net travel, hence both end positions, is kept. Returns None when
    the window's net travel is too small to absorb the shifted increments (a wider
    window is needed).
    """
    values = np.asarray(values, dtype=np.float64)
    d = np.diff(values)
    wrong = d * sense < -deadband
    if not wrong.any():
        return values.copy(), 0.0
    phi_l = float(np.max(np.abs(d[wrong]))) + min_shift
    shifted = d.copy()
    shifted[wrong] += sense * phi_l
    right = ~wrong
    room = sense * (float(np.sum(d)) - float(np.sum(shifted[wrong])))
    have = sense * float(np.sum(d[right]))
    if room <= 0.0 or have <= 0.0:
        return None
    shifted[right] *= room / have
    return np.concatenate([[values[0]], values[0] + np.cumsum(shifted)]), phi_l


def uniform_knots(basis_functions: int, degree: int = 3) -> Array:
    """Clamped knot vector on [0, 1] with ``basis_functions`` cubic B-splines."""
    interior = np.linspace(0.0, 1.0, basis_functions - degree + 1)[1:-1]
    return np.concatenate([np.zeros(degree + 1), interior, np.ones(degree + 1)])


def lsq_cubic(t: Array, values: Array, basis_functions: int = 4) -> BSpline:
    """Least-squares cubic B-spline ``B(t)`` with ``basis_functions`` basis functions.

    Parameters
    ----------
    t : (n,) float64
        Strictly increasing parameters in [0, 1] (normalised arc length).
    values : (n,) float64
    """
    return make_lsq_spline(t, values, uniform_knots(basis_functions), k=3)


def monotone_lsq_cubic(t: Array, values: Array, sense: float,
                       basis_functions: int = 4) -> BSpline:
    """Least-squares cubic B-spline whose coefficients are monotone in ``sense``.

    Coefficients ``c_j = c_0 + sense * sum_{i <= j} delta_i`` with ``delta >= 0``;
    ``c_0 = p - q`` (p, q >= 0); solved by non-negative least squares.
    """
    knots = uniform_knots(basis_functions)
    design = BSpline.design_matrix(t, knots, 3).toarray()
    m = basis_functions
    lower = np.tril(np.ones((m, m - 1)), -1) * sense  # column j adds delta_j from c_{j+1} on
    columns = np.column_stack([design.sum(axis=1), -design.sum(axis=1), design @ lower])
    scale = float(np.max(np.abs(values))) or 1.0
    solution, _ = nnls(columns, np.asarray(values) / scale, maxiter=50 * columns.shape[1])
    coeffs = (solution[0] - solution[1]) + lower @ solution[2:]
    return BSpline(knots, coeffs * scale, 3)


@dataclass
class SmoothingResult:
    """What ``smooth_monotone`` did to one axis.

    Attributes
    ----------
    values : (n,) float64
        The new positions (the input when there was nothing to do).
    rounds : int
        Shift-and-smooth rounds made.
    phi_l : list of float
        The shift phi_L of each round.
    method : str
        ``"none"``, ``"shift+lsq-local"`` (windows around the reversed ranges),
        ``"shift+lsq"`` (whole path) or ``"monotone-lsq"`` (the fallback).
    """

    values: Array
    rounds: int
    phi_l: list[float]
    method: str


def end_fixed_lsq_cubic(t: Array, values: Array, targets: Array,
                        basis_functions: int = 4) -> Array:
    """Least-squares cubic B-spline through the end points of ``values``, at ``t``.

    Clamped uniform knots on ``[t[0], t[-1]]``: the first and last coefficients are
    the end values of ``values`` (a clamped B-spline interpolates them), the others
    fit ``targets`` (the shifted positions) in least squares. The smoothed stretch
    therefore joins the untouched curve on both sides.

    Parameters
    ----------
    t : (n,) float64
        Strictly increasing, n >= 2.
    values : (n,) float64
        Positions before the shift (their ends are kept).
    targets : (n,) float64
        Positions to fit.

    Returns
    -------
    (n,) float64
        The spline at ``t``.
    """
    u = (t - t[0]) / (t[-1] - t[0])
    design = BSpline.design_matrix(np.clip(u, 0.0, 1.0), uniform_knots(basis_functions),
                                   3).toarray()
    ends = values[0] * design[:, 0] + values[-1] * design[:, -1]
    inner = design[:, 1:-1]
    coeffs, *_ = np.linalg.lstsq(inner, targets - ends, rcond=None)
    return np.asarray(ends + inner @ coeffs)


def reversed_windows(values: Array, sense: float, deadband: float, grow: int
                     ) -> list[tuple[int, int]]:
    """Stretches of points to smooth around the reverse movements, ``[(a, b), ...]``.

    A *reversed range* is a run of increments against ``sense`` (beyond the dead
    band), points ``i0 .. i1``; its window adds ``grow * max(i1 - i0, 4)`` points on
    each side (clipped to the path); overlapping windows are merged.
    """
    d = np.diff(values)
    wrong = np.flatnonzero(d * sense < -deadband)
    if not wrong.size:
        return []
    runs = np.split(wrong, np.flatnonzero(np.diff(wrong) > 1) + 1)
    n = len(values)
    windows: list[tuple[int, int]] = []
    for run in runs:
        i0, i1 = int(run[0]), int(run[-1]) + 1
        pad = grow * max(i1 - i0, 4)
        a, b = max(i0 - pad, 0), min(i1 + pad, n - 1)
        if windows and a <= windows[-1][1]:
            windows[-1] = (windows[-1][0], max(b, windows[-1][1]))
        else:
            windows.append((a, b))
    return windows


def smooth_monotone(t: Array, values: Array, *, basis_functions: int = 4,
                    min_shift: float = 1e-4, deadband: float = 0.0,
                    max_rounds: int = 20, scope: str = "local") -> SmoothingResult:
    """Remove the reverse movements of one axis (shift, least-squares, repeat).

    ``scope="local"`` (default; seed 001: "the angular positions corresponding to the
    regions where reverse movements presented ... are adjusted and approximated by
    least squares cubic B-splines"): in round k, every reversed range with a window of
    k times its length on each side (``reversed_windows``) is shifted by phi_L
    keeping the window's end positions (``shift_reversed_keep_ends``) and replaced by
    the least-squares cubic B-spline with ``basis_functions`` basis functions through
    the window's end points (``end_fixed_lsq_cubic``); the rest of the curve is
    untouched. ``scope="path"``: the shift and the fit cover the whole path (one cubic
    over the path with four basis functions). Either way, if the curve is still not
    monotone after ``max_rounds``, the monotone least-squares fit of the whole path
    ends it.

    Parameters
    ----------
    t : (n,) float64
        Strictly increasing path parameter in [0, 1].
    values : (n,) float64
        Axis positions along the path.
    basis_functions : int
        Cubic B-spline basis functions (paper: 4).
    min_shift : float
        Least phi_L.
    deadband : float
        Increments within it are no movement.
    max_rounds : int
        Rounds before the monotone-coefficient fallback.
    scope : str
        ``"local"`` or ``"path"``.

    Returns
    -------
    SmoothingResult
        ``count_reversals(result.values, deadband) == 0``.
    """
    values = np.asarray(values, dtype=np.float64)
    if count_reversals(values, deadband) == 0:
        return SmoothingResult(values.copy(), 0, [], "none")
    sense = direction(values)
    current = values
    shifts: list[float] = []
    for round_ in range(1, max_rounds + 1):
        if scope == "path":
            shifted, phi_l = shift_reversed(current, sense, min_shift, deadband)
            current = np.asarray(lsq_cubic(t, shifted, basis_functions)(t))
        else:
            current = current.copy()
            phi_l = 0.0
            for a, b in reversed_windows(current, sense, deadband, round_):
                if b - a < basis_functions:  # too short for the fit: a straight ramp
                    current[a:b + 1] = np.interp(t[a:b + 1], [t[a], t[b]],
                                                 [current[a], current[b]])
                    continue
                window = current[a:b + 1]
                kept = shift_reversed_keep_ends(window, sense, min_shift, deadband)
                if kept is None:  # not enough travel in the window yet: wider next round
                    continue
                shifted, phi = kept
                phi_l = max(phi_l, phi)
                current[a:b + 1] = end_fixed_lsq_cubic(t[a:b + 1], window, shifted,
                                                       basis_functions)
        shifts.append(phi_l)
        if count_reversals(current, deadband) == 0:
            method = "shift+lsq" if scope == "path" else "shift+lsq-local"
            return SmoothingResult(current, round_, shifts, method)
    fitted = np.asarray(monotone_lsq_cubic(t, values, sense, basis_functions)(t))
    if count_reversals(fitted, deadband) != 0:  # rounding of a flat stretch: make it exact
        fitted = sense * np.maximum.accumulate(sense * fitted)
    return SmoothingResult(fitted, max_rounds, shifts, "monotone-lsq")
