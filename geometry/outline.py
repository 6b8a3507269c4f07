"""The closed outline of one blade, as G1 segments of a surface X(p, v) with outward normals.

A spanwise section of a blade (fixed v) is a closed curve: pressure side, trailing
edge, suction side, leading edge. Each piece is an :class:`OutlineSegment`, a
surface ``X(p, v)`` (p in [0, 1] along the piece, v the blade's span parameter:
0 at the shroud, 1 at the hub, > 1 extends the rulings into the hub) with its
outward unit normal ``n(p, v)``:

* ``pressure`` / ``suction``: the side surfaces ``R +/- d/2 N`` with
  ``u = (1 - p) u_a + p u_b`` (``u_a = 0``, ``u_b = 1`` next to round edges);
* ``round`` edge: the half-round cap ``R(u_e, v) + d/2 (cos(pi p) N + sin(pi p) T)``,
  T the unit camber tangent (orthogonal to N) pointing out of the blade, plus a
  small Hermite correction making it tangent-plane continuous with both sides
  (:func:`_cap`); it is cut into three pieces (thirds of its parameter) so that
  the blade tip over it is a four-sided patch;
* ``cut`` edge with broken corners: the sides stop at ``u_b = 1 - rho_c / |R_u|``
  (``|R_u|`` at the hub, so the corner is ``rho_c`` long there), a quarter-round
  ``corner`` of radius ``rho_c`` (:func:`edge_break`) turns the side normal into T,
  and the flat ``face`` joins the two corners. Every segment is smooth and every
  junction tangent-continuous, so the rolling ball of a fillet is defined everywhere.

At the junction of two segments both use the same point *and the same normal*
(cap and corner normals are overridden at their ends by the neighbour's normal),
so the rolling-ball solutions of neighbours coincide at their common section. The
override is a kink of the normal field of at most a few tenths of a degree.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from geometry.surfaces import BladeSurface

__all__ = ["EDGE_BREAK_FRACTION", "EDGE_BREAK_MIN", "OutlineSegment", "blade_outline",
           "edge_break"]

_FD = 1e-6
Array = NDArray[np.float64]
#: Corner radius of a cut edge as a fraction of the half thickness there.
EDGE_BREAK_FRACTION = 0.15
#: Smallest corner radius of a cut edge, mm.
EDGE_BREAK_MIN = 0.05


def _unit(a: Array) -> Array:
    return np.asarray(a / np.linalg.norm(a, axis=-1, keepdims=True))


def _slerp(a: Array, b: Array, f: Array) -> Array:
    """Great-circle interpolation between unit vectors ``a`` and ``b`` at fraction ``f``."""
    cos = np.clip(np.einsum("...i,...i->...", a, b), -1.0, 1.0)
    angle = np.arccos(cos)[..., None]
    f = np.asarray(f, float)[..., None]
    small = angle < 1e-9
    s = np.where(small, 1.0, np.sin(angle))
    wa = np.where(small, 1.0 - f, np.sin((1.0 - f) * angle) / s)
    wb = np.where(small, f, np.sin(f * angle) / s)
    return _unit(wa * a + wb * b)


@dataclass(frozen=True)
class OutlineSegment:
    """One piece of a blade's outline.

    Attributes
    ----------
    role : str
        Face role of the piece: pressure, suction, leading_edge, trailing_edge.
    kind : str
        ``side``, ``cap`` (half round), ``corner`` (quarter round of a cut edge) or
        ``face`` (flat part of a cut edge).
    u_of : callable
        ``u(p)``: the blade parameter u of the piece at p.
    point : callable
        ``X(p, v) -> (..., 3)`` mm.
    normal : callable
        ``n(p, v) -> (..., 3)`` outward unit normal.
    """

    role: str
    kind: str
    u_of: Callable[[Array], Array]
    point: Callable[[Array, Array], Array]
    normal: Callable[[Array, Array], Array]


def _fd_normal(
    point: Callable[[Array, Array], Array], p: Array, v: Array, hint: Array
) -> Array:
    """Unit normal of X(p, v) from central differences, oriented along ``hint``."""
    d_p = point(p + _FD, v) - point(p - _FD, v)
    d_v = point(p, v + _FD) - point(p, v - _FD)
    n = _unit(np.cross(d_p, d_v))
    sign = np.sign(np.einsum("...i,...i->...", n, hint))
    return np.asarray(n * np.where(sign == 0, 1.0, sign)[..., None])


def _tangent(blade: BladeSurface, u: Array, v: Array) -> Array:
    """Unit camber tangent at (u, v), orthogonal to N, pointing towards +u."""
    r_u, _ = blade.camber_derivatives(u, v)
    n = blade.normal(u, v)
    t = r_u - np.einsum("...i,...i->...", r_u, n)[..., None] * n
    return _unit(t)


def _pv(p: Array, v: Array) -> tuple[Array, Array]:
    a, b = np.broadcast_arrays(np.asarray(p, float), np.asarray(v, float))
    return a, b


def edge_break(blade: BladeSurface, u: float) -> float:
    """Corner radius ``rho_c`` of a cut edge at ``u``, mm.

    ``max(EDGE_BREAK_MIN, EDGE_BREAK_FRACTION * d/2)``, at most 0.45 d/2.
    """
    half = 0.5 * float(blade.thickness(u))
    return float(min(max(EDGE_BREAK_MIN, EDGE_BREAK_FRACTION * half), 0.45 * half))


def _trim(blade: BladeSurface, u: float) -> float:
    """Side-surface end parameter next to a cut edge at ``u`` (0 or 1)."""
    r_u, _ = blade.camber_derivatives(u, 1.0)
    du = edge_break(blade, u) / float(np.linalg.norm(r_u))
    return u - du if u >= 0.5 else u + du


def _side(blade: BladeSurface, side: int, u_a: float, u_b: float) -> OutlineSegment:
    role = "pressure" if side > 0 else "suction"

    def u_of(p: Array) -> Array:
        p = np.asarray(p, float)
        return np.asarray((1.0 - p) * u_a + p * u_b)

    return OutlineSegment(
        role,
        "side",
        u_of,
        lambda p, v: blade.side(u_of(p), v, side),
        lambda p, v: _side_normal(blade, u_of(p), v, side),
    )


def _side_normal(blade: BladeSurface, u: Array, v: Array, side: int) -> Array:
    """Side-surface normal with ``u`` kept 1e-6 inside [0, 1].

    :meth:`BladeSurface.side_normal` takes central differences; at u = 0 or 1 they
    would straddle the end of the thickness law and bend the normal by up to a
    tenth of a degree. Evaluating 1e-6 inside moves it by about 1e-6 rad instead.
    """
    uu = np.clip(np.asarray(u, float), _FD, 1.0 - _FD)
    return blade.side_normal(uu, v, side)


def _side_direction(blade: BladeSurface, u: float, v: Array, side: int, sign: float) -> Array:
    """Unit tangent of a side's u-line at ``u``, towards ``sign * u`` (one-sided, 2nd order)."""
    uu = np.full(np.shape(v), u)
    h = -sign * 1e-5
    d = (3.0 * blade.side(uu, v, side) - 4.0 * blade.side(uu + h, v, side)
         + blade.side(uu + 2.0 * h, v, side))
    return _unit(d)


def _cap(blade: BladeSurface, u: float, role: str) -> OutlineSegment:
    """Round edge at u (0: leading edge, 1: trailing edge), pressure -> suction.

    The half circle ``R(u, v) + d/2 (cos(pi p) N + sin(pi p) T_out)`` plus a cubic
    Hermite correction ``p (1-p)^2 a_0 + p^2 (p-1) a_1`` that is zero at both ends
    and turns the end tangents into the sides' own u-directions: the cap is then
    tangent-plane continuous (G1) with both sides even where the thickness varies
    (where it is constant the correction is a few micrometres at most).
    """
    out = 1.0 if u >= 0.5 else -1.0
    rho = 0.5 * float(blade.thickness(u))
    speed = np.pi * rho

    def frame(v: Array) -> tuple[Array, Array]:
        uu = np.full(np.shape(v), u)
        return blade.normal(uu, v), out * _tangent(blade, uu, v)

    def direction(p: Array, v: Array) -> Array:
        n, t = frame(v)
        a = np.pi * p[..., None]
        return np.asarray(np.cos(a) * n + np.sin(a) * t)

    def point(p: Array, v: Array) -> Array:
        p, v = _pv(p, v)
        n, t = frame(v)
        a0 = speed * (_side_direction(blade, u, v, +1, out) - t)
        a1 = speed * (-_side_direction(blade, u, v, -1, out) + t)
        q = p[..., None]
        return np.asarray(blade.camber(np.full(p.shape, u), v) + rho * direction(p, v)
                          + q * (1.0 - q) ** 2 * a0 + q**2 * (q - 1.0) * a1)

    def normal(p: Array, v: Array) -> Array:
        p, v = _pv(p, v)
        return _fd_normal(point, p, v, direction(p, v))

    return OutlineSegment(role, "cap", lambda p: np.full(np.shape(p), u), point, normal)


def _cut(blade: BladeSurface, u: float, role: str, u_b: float) -> list[OutlineSegment]:
    """Cut edge at ``u`` with broken corners: corner (pressure), face, corner (suction).

    The sides end at ``u_b``; a corner is the quarter round of radius ``rho_c`` whose
    centre is ``rho_c`` inside the side surface at ``u_b``; it turns from the side
    normal to the out-pointing camber tangent T. The face is the ruled surface
    between the two corners' ends. Corners run side -> face (pressure) and
    face -> side (suction), so the three pieces chain pressure -> suction.
    """
    out = 1.0 if u >= 0.5 else -1.0
    rc = edge_break(blade, u)

    def t_out(v: Array) -> Array:
        return np.asarray(out * _tangent(blade, np.full(np.shape(v), u_b), v))

    def centre(v: Array, side: int) -> Array:
        uu = np.full(np.shape(v), u_b)
        return np.asarray(blade.side(uu, v, side) - rc * blade.side_normal(uu, v, side))

    def ends(v: Array) -> tuple[Array, Array]:
        """Face boundary lines at the pressure and suction corners, each ``(..., 3)``."""
        shift = rc * t_out(v)
        return centre(v, +1) + shift, centre(v, -1) + shift

    def face_point(p: Array, v: Array) -> Array:
        p, v = _pv(p, v)
        e_p, e_s = ends(v)
        return np.asarray((1.0 - p)[..., None] * e_p + p[..., None] * e_s)

    def face_normal(p: Array, v: Array) -> Array:
        p, v = _pv(p, v)
        e_p, e_s = ends(np.stack([v, v + _FD, v - _FD]))
        f = p[..., None]
        d_v = (1.0 - f) * (e_p[1] - e_p[2]) + f * (e_s[1] - e_s[2])
        n = _unit(np.cross(e_s[0] - e_p[0], d_v))
        sign = np.sign(np.einsum("...i,...i->...", n, t_out(v)))
        return np.asarray(n * np.where(sign == 0, 1.0, sign)[..., None])

    face = OutlineSegment(role, "face", lambda p: np.full(np.shape(p), u), face_point,
                          face_normal)

    def corner(side: int) -> OutlineSegment:
        at_face = 1.0 if side > 0 else 0.0  # corner parameter where it meets the face

        def frac(p: Array) -> Array:
            return np.asarray(p if side > 0 else 1.0 - p)

        def point(p: Array, v: Array) -> Array:
            p, v = _pv(p, v)
            uu = np.full(p.shape, u_b)
            d = _slerp(blade.side_normal(uu, v, side), t_out(v), frac(p))
            return np.asarray(centre(v, side) + rc * d)

        def normal(p: Array, v: Array) -> Array:
            p, v = _pv(p, v)
            uu = np.full(p.shape, u_b)
            n_face = face.normal(np.full(p.shape, 0.0 if side > 0 else 1.0), v)
            n = _slerp(blade.side_normal(uu, v, side), n_face, frac(p))
            return np.asarray(np.where((p == at_face)[..., None], n_face, n))

        return OutlineSegment(role, "corner", lambda p: np.full(np.shape(p), u_b), point,
                              normal)

    return [corner(+1), face, corner(-1)]


def _pieces(segment: OutlineSegment, count: int = 3) -> list[OutlineSegment]:
    """``segment`` split into ``count`` equal parameter ranges (chained in order)."""

    def piece(a: float, b: float) -> OutlineSegment:
        def sub(p: Array) -> Array:
            return np.asarray(a + (b - a) * np.asarray(p, float))

        return OutlineSegment(segment.role, segment.kind, lambda p: segment.u_of(sub(p)),
                              lambda p, v: segment.point(sub(p), v),
                              lambda p, v: segment.normal(sub(p), v))

    cuts = np.linspace(0.0, 1.0, count + 1)
    return [piece(float(a), float(b)) for a, b in zip(cuts[:-1], cuts[1:], strict=True)]


def _reversed(segment: OutlineSegment) -> OutlineSegment:
    """The same piece run the other way (p -> 1 - p)."""

    def flip(p: Array) -> Array:
        return np.asarray(1.0 - np.asarray(p, float))

    return OutlineSegment(segment.role, segment.kind, lambda p: segment.u_of(flip(p)),
                          lambda p, v: segment.point(flip(p), v),
                          lambda p, v: segment.normal(flip(p), v))


def blade_outline(blade: BladeSurface, leading_edge: str,
                  trailing_edge: str) -> list[OutlineSegment]:
    """The outline of a blade as segments chained in one closed loop.

    Every edge region has three pieces: the round cap cut in thirds, or corner,
    flat face, corner. Order: pressure (u_a -> u_b), trailing edge pieces (pressure -> suction),
    suction (u_b -> u_a), leading edge pieces (suction -> pressure): segment k ends
    (p = 1) where segment k + 1 starts (p = 0), with the same point and normal.

    Parameters
    ----------
    blade : BladeSurface
    leading_edge, trailing_edge : str
        ``"round"`` or ``"cut"``.
    """
    for shape in (leading_edge, trailing_edge):
        if shape not in ("round", "cut"):
            raise ValueError(f"edge shape must be 'round' or 'cut', not {shape!r}")
    u_a = _trim(blade, 0.0) if leading_edge == "cut" else 0.0
    u_b = _trim(blade, 1.0) if trailing_edge == "cut" else 1.0
    edges = {}
    for u, shape, role, end in ((1.0, trailing_edge, "trailing_edge", u_b),
                                (0.0, leading_edge, "leading_edge", u_a)):
        edges[role] = _pieces(_cap(blade, u, role)) if shape == "round" \
            else _cut(blade, u, role, end)
    leading = [_reversed(s) for s in reversed(edges["leading_edge"])]
    return [_side(blade, +1, u_a, u_b), *edges["trailing_edge"],
            _reversed(_side(blade, -1, u_a, u_b)), *leading]
