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
  ``corner`` of radius ``rho_c`` (:func:`edge_break`) turns from the side into the
  flat ``face`` (:func:`_cut`). Every segment is smooth and every junction
  tangent-plane continuous, so the rolling ball of a fillet is defined everywhere.

Normals are the geometric normals of the pieces (central differences of X). At a
junction both pieces give the same point and, to about 1e-4 deg, the same normal;
:func:`geometry.fillet.blade_tracks` copies the end sections so neighbours share
them exactly.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from geometry.surfaces import BladeSurface

__all__ = ["EDGE_BREAK_FRACTION", "EDGE_BREAK_MIN", "OutlineSegment", "blade_loop",
           "blade_outline", "edge_break"]

_FD = 1e-6
Array = NDArray[np.float64]
#: Corner radius of a cut edge as a fraction of the half thickness there.
EDGE_BREAK_FRACTION = 0.15
#: Smallest corner radius of a cut edge, mm.
EDGE_BREAK_MIN = 0.05


def _unit(a: Array) -> Array:
    return np.asarray(a / np.linalg.norm(a, axis=-1, keepdims=True))


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


def _tangent(r_u: Array, n: Array) -> Array:
    """Unit camber tangent, orthogonal to N, pointing towards +u, from the camber's
    u-derivative ``r_u`` and normal ``n`` at (u, v) (``BladeSurface.camber_frame``)."""
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
    if uu.ndim:  # one stacked evaluation
        at = list(blade.side(np.stack([uu, uu + h, uu + 2.0 * h]), np.stack([v, v, v]), side))
    else:  # a 0-d point keeps its own (vector-matrix) rotations, to the bit
        at = [blade.side(uu + k * h, v, side) for k in (0.0, 1.0, 2.0)]
    d = 3.0 * at[0] - 4.0 * at[1] + at[2]
    return _unit(d)


def _cap(blade: BladeSurface, u: float, role: str) -> OutlineSegment:
    """Round edge at u (0: leading edge, 1: trailing edge), pressure -> suction.

    The half circle ``R(u, v) + d/2 (cos(pi p) N + sin(pi p) T_out)`` plus a cubic
    Hermite correction ``p (1-p)^2 a_0 + p^2 (p-1) a_1`` that is zero at both ends
    and turns the end tangents into the sides' own u-directions: the cap is then
    tangent-plane continuous (G1) with both sides (their u-directions leave the plane
    of N and T where the rulings lean or the thickness varies); it moves the cap by
    at most about 0.011 mm on the fixtures.
    """
    out = 1.0 if u >= 0.5 else -1.0
    rho = 0.5 * float(blade.thickness(u))
    speed = np.pi * rho

    def terms(v: Array) -> tuple[Array, ...]:
        """The v-dependent parts: camber point, N, T_out and the corrections a_0, a_1."""
        uu = np.full(np.shape(v), u)
        r, r_u, n = blade.camber_frame(uu, v)
        t = out * _tangent(r_u, n)
        a0 = speed * (_side_direction(blade, u, v, +1, out) - t)
        a1 = speed * (-_side_direction(blade, u, v, -1, out) + t)
        return r, n, t, a0, a1

    def combine(p: Array, parts: tuple[Array, ...]) -> Array:
        r, n, t, a0, a1 = parts
        a = np.pi * p[..., None]
        q = p[..., None]
        return np.asarray(r + rho * (np.cos(a) * n + np.sin(a) * t)
                          + q * (1.0 - q) ** 2 * a0 + q**2 * (q - 1.0) * a1)

    def point(p: Array, v: Array) -> Array:
        p, v = _pv(p, v)
        return combine(p, terms(v))

    def normal(p: Array, v: Array) -> Array:
        # central differences of X(p, v); the v-dependent terms for v, v + h, v - h
        # are evaluated in one stacked call
        p, v = _pv(p, v)
        parts = terms(np.stack([v, v + _FD, v - _FD]))
        mid = tuple(x[0] for x in parts)
        d_p = combine(p + _FD, mid) - combine(p - _FD, mid)
        d_v = combine(p, tuple(x[1] for x in parts)) - combine(p, tuple(x[2] for x in parts))
        n = _unit(np.cross(d_p, d_v))
        a = np.pi * p[..., None]
        hint = np.cos(a) * mid[1] + np.sin(a) * mid[2]
        sign = np.sign(np.einsum("...i,...i->...", n, hint))
        return np.asarray(n * np.where(sign == 0, 1.0, sign)[..., None])

    return OutlineSegment(role, "cap", lambda p: np.full(np.shape(p), u), point, normal)


def _stacked_normal(terms: Callable[[Array], tuple[Array, ...]],
                    combine: Callable[[Array, tuple[Array, ...]], Array],
                    hint: Callable[[Array, tuple[Array, ...]], Array], p: Array,
                    v: Array) -> Array:
    """Unit normal of ``X(p, v) = combine(p, terms(v))`` by central differences.

    The v-dependent ``terms`` are evaluated once for ``v``, ``v + h`` and ``v - h``
    (stacked); the result is oriented along ``hint(p, terms(v))``.
    """
    parts = terms(np.stack([v, v + _FD, v - _FD]))
    mid = tuple(x[0] for x in parts)
    d_p = combine(p + _FD, mid) - combine(p - _FD, mid)
    d_v = combine(p, tuple(x[1] for x in parts)) - combine(p, tuple(x[2] for x in parts))
    n = _unit(np.cross(d_p, d_v))
    sign = np.sign(np.einsum("...i,...i->...", n, hint(p, mid)))
    return np.asarray(n * np.where(sign == 0, 1.0, sign)[..., None])


def _cut(blade: BladeSurface, u: float, role: str, u_b: float) -> list[OutlineSegment]:
    """Cut edge at ``u`` with broken corners: corner (pressure), face, corner (suction).

    In the frame ``R, N, T_out`` of the camber at the sides' end ``u_b`` (h = d(u_b)/2,
    rho_c = :func:`edge_break`): a pressure corner, the quarter circle of centre
    ``R + (h - rho_c) N`` from ``R + h N`` (the pressure side's end) to
    ``R + (h - rho_c) N + rho_c T_out``; the flat face down to
    ``R - (h - rho_c) N + rho_c T_out``; the suction corner, mirror image. The pieces
    meet with the same tangent plane (the section tangent is -N on both sides of a
    corner-face junction and both share the junction line). A Hermite correction
    ``f (1-f)^2 a`` (f = 0 at the side) turns each corner's start tangent from T_out
    into the side's own u-direction, so the corners are G1 with the sides too.
    Corners run side -> face (pressure) and face -> side (suction).
    """
    out = 1.0 if u >= 0.5 else -1.0
    rc = edge_break(blade, u)
    h = 0.5 * float(blade.thickness(u_b))
    speed = 0.5 * np.pi * rc

    def terms(v: Array) -> tuple[Array, ...]:
        uu = np.full(np.shape(v), u_b)
        r, r_u, n = blade.camber_frame(uu, v)
        t = out * _tangent(r_u, n)
        a_p = speed * (_side_direction(blade, u_b, v, +1, out) - t)
        a_s = speed * (_side_direction(blade, u_b, v, -1, out) - t)
        return r, n, t, a_p, a_s

    def face_combine(p: Array, parts: tuple[Array, ...]) -> Array:
        r, n, t = parts[:3]
        return np.asarray(r + rc * t + ((h - rc) * (1.0 - 2.0 * p))[..., None] * n)

    def face_hint(p: Array, parts: tuple[Array, ...]) -> Array:
        return parts[2]

    def face_point(p: Array, v: Array) -> Array:
        p, v = _pv(p, v)
        return face_combine(p, terms(v))

    def face_normal(p: Array, v: Array) -> Array:
        p, v = _pv(p, v)
        return _stacked_normal(terms, face_combine, face_hint, p, v)

    pieces = []
    for side in (+1, -1):

        def frac(p: Array, side: int = side) -> Array:
            return np.asarray(p if side > 0 else 1.0 - p)

        def combine(p: Array, parts: tuple[Array, ...], side: int = side) -> Array:
            r, n, t, a_p, a_s = parts
            f = frac(p, side)[..., None]
            phi = 0.5 * np.pi * f
            a = a_p if side > 0 else a_s
            centre = r + side * (h - rc) * n
            return np.asarray(centre + rc * (np.cos(phi) * side * n + np.sin(phi) * t)
                              + f * (1.0 - f) ** 2 * a)

        def hint(p: Array, parts: tuple[Array, ...], side: int = side) -> Array:
            phi = 0.5 * np.pi * frac(p, side)[..., None]
            return np.asarray(np.cos(phi) * side * parts[1] + np.sin(phi) * parts[2])

        def point(p: Array, v: Array, combine: Callable[..., Array] = combine) -> Array:
            p, v = _pv(p, v)
            return combine(p, terms(v))

        def normal(p: Array, v: Array, combine: Callable[..., Array] = combine,
                   hint: Callable[..., Array] = hint) -> Array:
            p, v = _pv(p, v)
            return _stacked_normal(terms, combine, hint, p, v)

        pieces.append(OutlineSegment(role, "corner", lambda p: np.full(np.shape(p), u_b),
                                     point, normal))
    face = OutlineSegment(role, "face", lambda p: np.full(np.shape(p), u), face_point,
                          face_normal)
    return [pieces[0], face, pieces[1]]


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


def _joined(pieces: list[OutlineSegment], kind: str) -> OutlineSegment:
    """Chained pieces as one segment: piece k on p in [k/n, (k+1)/n]."""
    n = len(pieces)
    if n == 1:
        return pieces[0]

    def split(p: Array) -> tuple[Array, Array]:
        scaled = np.asarray(p, float) * n
        k = np.clip(np.floor(scaled), 0, n - 1).astype(int)
        return k, scaled - k

    def pick(which: str) -> Callable[[Array, Array], Array]:
        def f(p: Array, v: Array) -> Array:
            p, v = _pv(p, v)
            k, local = split(p)
            out = np.empty(p.shape + (3,))
            for i, piece in enumerate(pieces):
                mask = k == i
                if np.any(mask):
                    out[mask] = getattr(piece, which)(local[mask], v[mask])
            return out

        return f

    def u_of(p: Array) -> Array:
        k, local = split(p)
        out = np.empty(np.shape(p))
        for i, piece in enumerate(pieces):
            mask = k == i
            if np.any(mask):
                out[mask] = piece.u_of(local[mask])
        return out

    return OutlineSegment(pieces[0].role, kind, u_of, pick("point"), pick("normal"))


def blade_outline(blade: BladeSurface, leading_edge: str,
                  trailing_edge: str) -> list[OutlineSegment]:
    """The outline of a blade as one segment per role (for figures such as d_min).

    Order: pressure (u_a -> u_b), trailing edge (pressure -> suction), suction
    (u_a -> u_b), leading edge (pressure -> suction). The geometry is that of
    :func:`blade_loop` (the B-rep's): a cut edge is its corner, face and corner
    joined into one segment of kind ``face`` (each on a third of p), a round edge
    the whole cap (kind ``cap``).
    """
    _check_shapes(leading_edge, trailing_edge)
    u_a = _trim(blade, 0.0) if leading_edge == "cut" else 0.0
    u_b = _trim(blade, 1.0) if trailing_edge == "cut" else 1.0
    edges = {}
    for u, shape, role, end in ((1.0, trailing_edge, "trailing_edge", u_b),
                                (0.0, leading_edge, "leading_edge", u_a)):
        edges[role] = _cap(blade, u, role) if shape == "round" \
            else _joined(_cut(blade, u, role, end), "face")
    return [_side(blade, +1, u_a, u_b), edges["trailing_edge"], _side(blade, -1, u_a, u_b),
            edges["leading_edge"]]


def _check_shapes(*shapes: str) -> None:
    for shape in shapes:
        if shape not in ("round", "cut"):
            raise ValueError(f"edge shape must be 'round' or 'cut', not {shape!r}")


def blade_loop(blade: BladeSurface, leading_edge: str,
               trailing_edge: str) -> list[OutlineSegment]:
    """The outline of a blade as smooth pieces chained in one closed loop (for the B-rep).

    Every edge region has three pieces: the round cap cut in thirds, or corner,
    flat face, corner. Order: pressure (u_a -> u_b), trailing edge pieces
    (pressure -> suction), suction (u_b -> u_a), leading edge pieces (suction ->
    pressure): piece k ends (p = 1) where piece k + 1 starts (p = 0), with the same
    point and tangent plane.

    Parameters
    ----------
    blade : BladeSurface
    leading_edge, trailing_edge : str
        ``"round"`` or ``"cut"``.
    """
    _check_shapes(leading_edge, trailing_edge)
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
