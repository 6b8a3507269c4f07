"""Reverse movements of the machine axes and their removal (M3 steps 4-5).

A *reverse movement* of an axis along a path is a sign change of its increments
(the "angular displacement curve" of the paper): between two consecutive moves the
axis stops and turns back. Increments smaller than a dead band are no movement and
neither start nor end a run.

Removal (the paper's section 4.2, Fig. 9): with ``dir`` the overall direction of the
axis along the path, every increment that goes the other way is shifted by
``dir * phi_L``, ``phi_L`` = the largest reversed increment plus a small minimum shift,
so the whole displacement curve moves one way; the positions rebuilt from the
shifted increments are smoothed by least squares with cubic B-splines (four basis
functions by default, i.e. no interior knot; ``scipy.interpolate.make_lsq_spline``
on the normalised arc length of the ball-centre path); the smoothed curve is checked
again and the shift-and-smooth repeated until it is monotone.

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
    "lsq_cubic",
    "monotone_lsq_cubic",
    "reversal_points",
    "shift_reversed",
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
    """Number of reverse movements (sign changes of the increments beyond the dead band)."""
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
        ``"none"``, ``"shift+lsq"`` or ``"monotone-lsq"`` (the fallback).
    """

    values: Array
    rounds: int
    phi_l: list[float]
    method: str


def smooth_monotone(t: Array, values: Array, *, basis_functions: int = 4,
                    min_shift: float = 1e-4, deadband: float = 0.0,
                    max_rounds: int = 20) -> SmoothingResult:
    """Remove the reverse movements of one axis (shift, least-squares, repeat).

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
        shifted, phi_l = shift_reversed(current, sense, min_shift, deadband)
        shifts.append(phi_l)
        current = np.asarray(lsq_cubic(t, shifted, basis_functions)(t))
        if count_reversals(current, deadband) == 0:
            return SmoothingResult(current, round_, shifts, "shift+lsq")
    fitted = np.asarray(monotone_lsq_cubic(t, values, sense, basis_functions)(t))
    if count_reversals(fitted, deadband) != 0:  # rounding of a flat stretch: make it exact
        fitted = sense * np.maximum.accumulate(sense * fitted)
    return SmoothingResult(fitted, max_rounds, shifts, "monotone-lsq")
