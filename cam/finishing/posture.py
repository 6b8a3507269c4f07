"""Tool postures along a cutter-centre path (M3 step 2, eq. 7).

* Initial axis: the ruling direction of the offset blade surface (towards the
  shroud), then turned about the C (impeller, +Z) axis by ``c_tilt`` away from the
  blade: the sign is the one that moves the top of the tool away from the wall,
  ``sign((e_z x a) . n_wall)``.
* Never collinear with the contact normal: where the angle between axis and
  contact normal is below ``min_angle`` the axis is leaned towards the feed
  direction (a lead angle) just enough to reach it.
* ``lead_tilt``: lead and tilt of the axis from the contact normal in the frame
  (feed direction f, n x f), reported against the configured limits.
* ``c_max`` (eq. 7): ``Cmax = acos(EC . EF / (|EC| |EF|))`` with E the ball
  centre, EC along the initial tool axis and F the opposite wall's tip point: turning
  further would swing the tool across the passage into the opposite blade.
* ``axis_breaks`` / ``axis_pieces``: where the axis turns faster than a bound (deg
  per mm of ball-centre path) between two postures, the pass is cut into pieces
  machined one after the other with a lift in between: a side change of the tool
  (near the C axis a few degrees of axis are a large C turn) happens in the air,
  not inside a feed move.

Every function is vectorised over ``(n, 3)`` rows; angles in radians.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "angle_between",
    "away_sign",
    "axis_breaks",
    "axis_pieces",
    "axis_turn_rate",
    "c_max",
    "enforce_normal_angle",
    "initial_axes",
    "lead_tilt",
    "max_turn_deg_per_mm",
    "rotate_about_z",
]

Array = NDArray[np.float64]
_BISECTIONS = 40


def _unit(a: Array) -> Array:
    return np.asarray(a / np.linalg.norm(a, axis=-1, keepdims=True))


def _dot(a: Array, b: Array) -> Array:
    return np.asarray(np.einsum("ij,ij->i", a, b))


def angle_between(a: Array, b: Array) -> Array:
    """Angle between unit rows of ``a`` and ``b``, rad, ``(n,)`` (atan2 form, exact near 0)."""
    return np.asarray(np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), _dot(a, b)))


def rotate_about_z(vectors: Array, angle: Array | float) -> Array:
    """Rotate rows of ``vectors`` about +Z by ``angle`` (scalar or ``(n,)``), rad."""
    angle = np.broadcast_to(np.asarray(angle, dtype=np.float64), (len(vectors),))
    c, s = np.cos(angle), np.sin(angle)
    out = np.array(vectors, dtype=np.float64, copy=True)
    out[:, 0] = c * vectors[:, 0] - s * vectors[:, 1]
    out[:, 1] = s * vectors[:, 0] + c * vectors[:, 1]
    return out


def away_sign(axis: Array, away: Array) -> float:
    """Sense (+1 / -1) of a rotation about +Z that turns ``axis`` towards ``away``.

    One sign per path (the majority), so that a rotation applied to the whole path
    moves every posture the same way.
    """
    ez_cross = np.stack([-axis[:, 1], axis[:, 0], np.zeros(len(axis))], axis=1)
    return 1.0 if float(np.sum(np.sign(_dot(ez_cross, away)))) >= 0.0 else -1.0


def initial_axes(reference: Array, away: Array, c_tilt: float) -> tuple[Array, float]:
    """Ruling axis turned about the C axis by ``c_tilt`` rad away from the wall.

    Parameters
    ----------
    reference : (n, 3) float64
        Unit ruling directions of the offset blade surface (towards the shroud).
    away : (n, 3) float64
        Outward unit normal of the wall.
    c_tilt : float
        Rotation about +Z, rad (the paper: 1-2 deg).

    Returns
    -------
    axis : (n, 3) float64
    sign : float
        The sense of "away from the wall" about +Z (used again by the remedy).
    """
    sign = away_sign(reference, away)
    return rotate_about_z(reference, sign * c_tilt), sign


def enforce_normal_angle(axis: Array, normal: Array, tangent: Array,
                         min_angle: float) -> tuple[Array, NDArray[np.bool_]]:
    """Lean the axis in the feed direction where it is within ``min_angle`` of the normal.

    ``a(beta) = cos(beta) a + sin(beta) f``, f the unit feed direction made
    perpendicular to a; beta >= 0 is the smallest lean (bisection) giving
    ``angle(a(beta), n) >= min_angle``.

    Returns
    -------
    axis : (n, 3) float64
    changed : (n,) bool
    """
    axis = np.array(axis, dtype=np.float64, copy=True)
    low = angle_between(axis, normal) < min_angle
    if not low.any():
        return axis, low
    a, n, t = axis[low], normal[low], tangent[low]
    f = t - _dot(t, a)[:, None] * a
    norm = np.linalg.norm(f, axis=1)
    # a feed direction along the axis (plunge) leaves no lean direction: use any normal
    fallback = np.cross(a, np.where(np.abs(a[:, [0]]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]]))
    f = np.where(norm[:, None] > 1e-12, f / np.maximum(norm, 1e-300)[:, None], _unit(fallback))
    lo = np.zeros(len(a))
    hi = np.full(len(a), 0.5 * np.pi)
    for _ in range(_BISECTIONS):
        mid = 0.5 * (lo + hi)
        lean = np.cos(mid)[:, None] * a + np.sin(mid)[:, None] * f
        ok = angle_between(lean, n) >= min_angle
        hi = np.where(ok, mid, hi)
        lo = np.where(ok, lo, mid)
    axis[low] = _unit(np.cos(hi)[:, None] * a + np.sin(hi)[:, None] * f)
    return axis, low


def lead_tilt(axis: Array, normal: Array, tangent: Array) -> tuple[Array, Array]:
    """Lead and tilt angles of the axis from the contact normal, rad, each ``(n,)``.

    Frame at the contact: n (normal), f (feed direction projected onto the
    tangent plane), b = n x f. ``lead = atan2(a.f, a.n)``, ``tilt = atan2(a.b, a.n)``.
    """
    f = tangent - _dot(tangent, normal)[:, None] * normal
    f = _unit(f)
    b = np.cross(normal, f)
    an = _dot(axis, normal)
    return np.arctan2(_dot(axis, f), an), np.arctan2(_dot(axis, b), an)


def c_max(centre: Array, initial_axis: Array, opposite_tip: Array) -> Array:
    """Eq. 7: largest allowed turn of the axis towards the opposite wall, rad, ``(n,)``.

    ``Cmax = acos(EC . EF / (|EC| |EF|))``; E the ball centre, EC along the initial
    axis, F the opposite wall's tip point.
    """
    return angle_between(_unit(initial_axis), _unit(opposite_tip - centre))


def axis_turn_rate(centre: Array, axis: Array) -> Array:
    """Turn of the tool axis per mm of ball-centre path between consecutive postures.

    Parameters
    ----------
    centre : (n, 3) float64
        Ball centres, mm.
    axis : (n, 3) float64
        Unit tool axes.

    Returns
    -------
    (n - 1,) float64
        ``angle(a_i, a_{i+1}) / |c_{i+1} - c_i|``, rad/mm (inf for a turn on the spot).
    """
    turn = angle_between(axis[:-1], axis[1:])
    step = np.linalg.norm(np.diff(centre, axis=0), axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        rate = np.where(turn > 0.0, turn / step, 0.0)
    return np.asarray(rate)


def max_turn_deg_per_mm(centre: Array, axis: Array) -> float | None:
    """Fastest ``axis_turn_rate`` of a pass in deg/mm (finish.json), rounded to 1e-4.

    0 for a single posture; None for a turn without moving the ball (infinite rate).
    """
    top = float(np.max(axis_turn_rate(centre, axis), initial=0.0))
    return round(math.degrees(top), 4) if math.isfinite(top) else None


def axis_breaks(centre: Array, axis: Array, max_rate: float) -> NDArray[np.intp]:
    """Moves along which the tool axis turns faster than ``max_rate``.

    Parameters
    ----------
    centre, axis : (n, 3) float64
        Ball centres (mm) and unit tool axes of a pass.
    max_rate : float
        Fastest allowed turn, rad per mm of ball-centre path.

    Returns
    -------
    (k,) intp
        Increasing ``i``: the move from posture ``i`` to ``i + 1`` is too fast.
    """
    return np.asarray(np.flatnonzero(axis_turn_rate(centre, axis) > max_rate), dtype=np.intp)


def axis_pieces(count: int, breaks: NDArray[np.intp]) -> list[NDArray[np.intp]]:
    """Posture indices of the pieces of a pass cut at ``breaks`` (``axis_breaks``).

    A piece of a single posture (two breaks in a row, or one at an end) is dropped:
    a feed move needs two postures, and that posture's ball is a point of the
    neighbouring pieces' scallop anyway.

    Parameters
    ----------
    count : int
        Postures of the pass.
    breaks : (k,) intp
        Moves ``i -> i + 1`` not to be cut.

    Returns
    -------
    list of (m,) intp
        Consecutive indices, in pass order; the whole pass when there is no break.
    """
    bounds = np.concatenate([[0], np.asarray(breaks, dtype=np.intp) + 1, [count]])
    return [np.arange(a, b, dtype=np.intp) for a, b in zip(bounds[:-1], bounds[1:],
                                                           strict=True) if b - a >= 2]
