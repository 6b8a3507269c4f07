"""Cutter-centre paths of the five-axis finishing (M3 step 1), in the workpiece frame W.

* **Junction paths**: the ball centre on the intersection of the blade side surface
  offset by the tool radius R and the hub offset by R, leading to trailing edge. Per
  camber parameter u we solve ``hub.signed_distance(blade.offset(u, v, side, R)) = R``
  for the span parameter v (vectorised bisection, then secant polish): this is the
  Newton system ``blade_offset(u, v) = hub_offset(s, phi)`` in (v, s, phi) reduced
  to one unknown, because a point is on the hub offset exactly when its distance from
  the surface of revolution is R (s and phi are then the foot point's parameters).
  The ball centre is therefore at R from the blade (offset along its normal) and at R
  from the hub (signed distance) to the solver tolerance.
* **Blade-side passes** from the junction up to the blade tip (v = 0) at constant
  fractions of the span, the number of passes from the scallop stepover.
* **Hub passes** running leading to trailing edge across the passage:
  ``phi = (1 - lambda) phi_a(s) + lambda phi_b(s)`` on the hub offset between the two
  junction paths of the passage (M4's interpolation, used here for finishing).

Only passage 0 is computed; the others are exact rotations (``rotate_path``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from cam.finishing.spacing import chord_spacing, refined_spacing
from geometry.revolved import RevolvedSurface
from geometry.surfaces import BladeSurface, ImpellerSurfaces, rotation_z
from impeller_cam.errors import InputError

__all__ = [
    "CutterPath",
    "blade_distance",
    "body_distance",
    "Wall",
    "blade_passes",
    "hub_foot",
    "junction_path",
    "passage_walls",
    "rotate_path",
    "subset_path",
]

Array = NDArray[np.float64]
_BISECTIONS = 22
_SECANT_STEPS = 4
_COARSE = 48
#: Span parameter below the hub where the junction search stops (rulings extend).
_V_BELOW_HUB = 1.25
#: Step of the finite differences of the offset surface along v.
_FD_V = 1e-5
#: Contour parameter margin that counts as "at the end of the hub contour".
_S_EDGE = 1e-9
_EDGE_STEPS = 8


def _unit(a: Array) -> Array:
    return np.asarray(a / np.linalg.norm(a, axis=-1, keepdims=True))


@dataclass(frozen=True)
class Wall:
    """One blade side that bounds a passage.

    Attributes
    ----------
    blade : BladeSurface
    side : int
        +1 pressure, -1 suction.
    label : str
        ``"blade0.pressure"``, ``"splitter0.suction"``, ...
    """

    blade: BladeSurface
    side: int
    label: str

    def curve_u(self, u: Array) -> Array:
        """Camber-curve parameter of this blade's own ``u``."""
        return np.asarray(self.blade.u_start + u * (1.0 - self.blade.u_start))

    def own_u(self, curve_u: Array) -> Array:
        """This blade's ``u`` of a camber-curve parameter, clipped to [0, 1]."""
        return np.clip((curve_u - self.blade.u_start) / (1.0 - self.blade.u_start), 0.0, 1.0)

    def tip_points(self, curve_u: Array) -> Array:
        """Points of this side on the blade tip (v = 0) at camber-curve parameters, (n, 3)."""
        return self.blade.side(self.own_u(curve_u), 0.0, self.side)


@dataclass
class CutterPath:
    """One finishing pass: ideal ball-centre points and what the postures need.

    Attributes
    ----------
    name : str
        ``"p0.junction.blade0.pressure"``, ``"p0.blade.blade1.suction.03"``, ...
    operation : str
        ``"junction"``, ``"blade"`` or ``"hub"`` (one APT file each).
    passage : int
    centre : (n, 3) float64
        Ideal ball centres, mm, leading to trailing edge.
    normal : (n, 3) float64
        Unit contact normal the tool axis must not be collinear with (hub normal for
        junction and hub passes, blade side normal for blade passes).
    reference_axis : (n, 3) float64
        Unit initial tool axis: the ruling of the offset blade surface, towards the
        shroud (hub passes: the two walls' rulings interpolated).
    away : (n, 3) float64
        Unit outward normal of the wall the axis is turned away from.
    opposite_tip : (n, 3) float64
        Point F on the opposite wall's tip (eq. 7: ``Cmax = acos(EC.EF / |EC||EF|)``).
    curve_u : (n,) float64
        Camber-curve parameter of each point.
    blade_contact, hub_contact : (n, 3) float64 or None
        Contact points of the ball (junction paths; hub passes: hub only).
    open_end : bool
        The pass ends where the tool meets an obstacle (hub passes ahead of a
        splitter): if its last postures cannot be made to meet every rule, the pass
        may be shortened there (``plan.finish_path``, reported).
    """

    name: str
    operation: str
    passage: int
    centre: Array
    normal: Array
    reference_axis: Array
    away: Array
    opposite_tip: Array
    curve_u: Array
    blade_contact: Array | None = None
    hub_contact: Array | None = None
    blade_v: Array | None = None
    wall: Wall | None = None
    open_end: bool = False

    def __len__(self) -> int:
        return len(self.centre)

    @property
    def tangent(self) -> Array:
        """Unit feed direction at each point (central differences), (n, 3)."""
        return _unit(np.gradient(self.centre, axis=0))


def blade_distance(wall: Wall, points: Array, u0: Array, v0: Array,
                   iterations: int = 8) -> Array:
    """Distance of points from a blade side surface near ``(u0, v0)``, mm, ``(n,)``.

    Foot point by Gauss-Newton on ``min |side(u, v) - p|`` (central-difference
    Jacobian, u kept in [0, 1]: the side surface ends at the blade edges),
    independent of the offset construction used to build the paths.
    """
    u, v = np.array(u0, dtype=np.float64), np.array(v0, dtype=np.float64)
    h = 1e-6
    for _ in range(iterations):
        foot = wall.blade.side(u, v, wall.side)
        du = (wall.blade.side(u + h, v, wall.side) - wall.blade.side(u - h, v, wall.side)) / (2 * h)
        dv = (wall.blade.side(u, v + h, wall.side) - wall.blade.side(u, v - h, wall.side)) / (2 * h)
        r = points - foot
        a11 = np.einsum("ij,ij->i", du, du)
        a12 = np.einsum("ij,ij->i", du, dv)
        a22 = np.einsum("ij,ij->i", dv, dv)
        b1 = np.einsum("ij,ij->i", du, r)
        b2 = np.einsum("ij,ij->i", dv, r)
        det = a11 * a22 - a12 * a12
        u = np.clip(u + (a22 * b1 - a12 * b2) / det, 0.0, 1.0)  # the surface ends at the edges
        v = v + (a11 * b2 - a12 * b1) / det
    return np.asarray(np.linalg.norm(points - wall.blade.side(u, v, wall.side), axis=1))


def body_distance(blade: BladeSurface, points: Array, iterations: int = 10) -> Array:
    """Distance of points from a blade's material (leading edge included), mm, ``(n,)``.

    The blade (round edges) is the set of points within ``d(u) / 2`` of its camber
    surface, u in [0, 1]: distance = ``|p - R(u*, v*)| - d(u*) / 2`` at the foot point
    on the camber surface (coarse grid, then Gauss-Newton with u kept in [0, 1], v
    free: the rulings extend below the hub). Near a side this is the side distance
    (to the thickness variation); ahead of a round leading edge it is the distance
    to its half-circle cap (which the solid follows to about 0.011 mm); a cut edge
    lies inside this model, so the distance is then an underestimate (safe for
    trimming passes that must keep clear of the blade).
    """
    points = np.asarray(points, dtype=np.float64)
    ug, vg = np.meshgrid(np.linspace(0.0, 1.0, 41), np.linspace(-0.1, 1.3, 15), indexing="ij")
    grid = blade.camber(ug.ravel(), vg.ravel())
    nearest = np.argmin(np.linalg.norm(points[:, None, :] - grid[None, :, :], axis=2), axis=1)
    u, v = ug.ravel()[nearest], vg.ravel()[nearest]
    for _ in range(iterations):
        foot = blade.camber(u, v)
        du, dv = blade.camber_derivatives(u, v)
        r = points - foot
        a11 = np.einsum("ij,ij->i", du, du)
        a12 = np.einsum("ij,ij->i", du, dv)
        a22 = np.einsum("ij,ij->i", dv, dv)
        b1 = np.einsum("ij,ij->i", du, r)
        b2 = np.einsum("ij,ij->i", dv, r)
        det = a11 * a22 - a12 * a12
        u = np.clip(u + (a22 * b1 - a12 * b2) / det, 0.0, 1.0)
        v = v + (a11 * b2 - a12 * b1) / det
    return np.asarray(np.linalg.norm(points - blade.camber(u, v), axis=1)
                      - 0.5 * blade.thickness(u))


def subset_path(path: CutterPath, index: NDArray[np.intp]) -> CutterPath:
    """The path restricted to the points ``index`` (every per-point array)."""
    def take(a: Array) -> Array:
        return np.asarray(a[index])

    def take_optional(a: Array | None) -> Array | None:
        return None if a is None else take(a)

    return replace(path, centre=take(path.centre), normal=take(path.normal),
                   reference_axis=take(path.reference_axis), away=take(path.away),
                   opposite_tip=take(path.opposite_tip), curve_u=take(path.curve_u),
                   blade_contact=take_optional(path.blade_contact),
                   hub_contact=take_optional(path.hub_contact),
                   blade_v=take_optional(path.blade_v))


def rotate_path(path: CutterPath, passage: int, pitch: float) -> CutterPath:
    """The same path in another passage: every point and vector turned about +Z."""
    rot = rotation_z(passage * pitch)

    def turn(a: Array) -> Array:
        return np.asarray(a @ rot.T)

    def turn_optional(a: Array | None) -> Array | None:
        return None if a is None else turn(a)

    name = path.name.replace(f"p{path.passage}.", f"p{passage}.", 1)
    return replace(
        path, name=name, passage=passage, centre=turn(path.centre), normal=turn(path.normal),
        reference_axis=turn(path.reference_axis), away=turn(path.away),
        opposite_tip=turn(path.opposite_tip), blade_contact=turn_optional(path.blade_contact),
        hub_contact=turn_optional(path.hub_contact),
    )


def passage_walls(surfaces: ImpellerSurfaces) -> list[tuple[Wall, Wall]]:
    """Wall pairs of passage 0, each ``(wall at -theta, wall at +theta)``.

    Without splitters: blade 0 pressure side and blade 1 suction side. With a
    splitter: (blade 0 pressure, splitter 0 suction), (splitter 0 pressure, blade 1
    suction). With one blade, blade 0 bounds its own passage on both sides.
    """
    blades = surfaces.blades
    first = Wall(blades[0], +1, "blade0.pressure")
    second_blade = blades[1] if len(blades) > 1 else blades[0]
    last = Wall(second_blade, -1, f"blade{1 if len(blades) > 1 else 0}.suction")
    if not surfaces.splitters:
        return [(first, last)]
    splitter = surfaces.splitters[0]
    return [(first, Wall(splitter, -1, "splitter0.suction")),
            (Wall(splitter, +1, "splitter0.pressure"), last)]


def _blade_chordal(wall: Wall, hub: RevolvedSurface, radius: float, stepover: float,
                   u0: Array, top0: Array, spacing: float, tolerance: float) -> float:
    """Spacing along the top blade pass that keeps every pass's chords within
    ``tolerance``, mm (at most ``spacing``).

    Per pass the allowed chord comes from its own curvature; the passes share u, so
    a pass that is longer than the top one per unit of u gets proportionally longer
    chords: the allowed chord is divided by the largest such ratio.
    """
    def measure(step: float) -> float:
        u = _resample(u0, top0, step)
        v_junction = _solve_v(wall, hub, radius, u)
        span = np.linalg.norm(wall.blade.side(u, 0.0, wall.side)
                              - wall.blade.side(u, v_junction, wall.side), axis=1)
        count = int(math.ceil(float(span.max()) / stepover))
        top = wall.blade.offset(u, np.zeros_like(u), wall.side, radius)
        top_step = np.maximum(np.linalg.norm(np.diff(top, axis=0), axis=1), 1e-300)
        allowed, ratio = math.inf, 1.0
        for k in range(count + 1):
            curve = wall.blade.offset(u, v_junction * (1.0 - k / count), wall.side, radius)
            allowed = min(allowed, chord_spacing(curve, tolerance, math.inf))
            ratio = max(ratio, float((np.linalg.norm(np.diff(curve, axis=0), axis=1)
                                      / top_step).max()))
        return min(spacing, allowed / ratio)

    return refined_spacing(measure, spacing)


def _offset_v_direction(wall: Wall, u: Array, v: Array, radius: float) -> Array:
    """Unit direction of the offset surface along v, towards the shroud (v decreasing)."""
    up = wall.blade.offset(u, v - _FD_V, wall.side, radius)
    down = wall.blade.offset(u, v + _FD_V, wall.side, radius)
    return _unit(up - down)


def _solve_v(wall: Wall, hub: RevolvedSurface, radius: float, u: Array) -> Array:
    """Span parameter of the junction ball centre at each ``u`` (see module docstring)."""

    def gap(v: Array) -> Array:
        return np.asarray(hub.signed_distance(wall.blade.offset(u, v, wall.side, radius))
                          - radius)

    lo = np.zeros_like(u)
    hi = np.full_like(u, _V_BELOW_HUB)
    g_lo, g_hi = gap(lo), gap(hi)
    if np.any(g_lo <= 0) or np.any(g_hi >= 0):
        bad = int(np.flatnonzero((g_lo <= 0) | (g_hi >= 0))[0])
        raise InputError(
            f"a ball of radius {radius:g} mm does not fit between the {wall.label} side "
            f"and the hub at u = {u[bad]:.4f}",
            field="tool", value=2.0 * radius,
            accepted="a tool whose radius is below the blade height")
    for _ in range(_BISECTIONS):
        mid = 0.5 * (lo + hi)
        positive = gap(mid) > 0
        lo = np.where(positive, mid, lo)
        hi = np.where(positive, hi, mid)
    # secant polish inside the final bracket
    a, b = lo, hi
    ga, gb = gap(a), gap(b)
    v = 0.5 * (a + b)
    for _ in range(_SECANT_STEPS):
        denom = np.where(np.abs(gb - ga) > 1e-300, gb - ga, 1.0)
        v = np.clip(b - gb * (b - a) / denom, np.minimum(lo, hi), np.maximum(lo, hi))
        a, ga, b, gb = b, gb, v, gap(v)
    return np.asarray(v)


def _resample(u_coarse: Array, points: Array, spacing: float) -> Array:
    """u values evenly spaced in arc length along ``points`` (spacing <= ``spacing``)."""
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    count = max(int(math.ceil(1.01 * arc[-1] / spacing)) + 1, 4)
    return np.asarray(np.interp(np.linspace(0.0, arc[-1], count), arc, u_coarse))


def _chordal(curve: Callable[[Array], Array], u0: Array, c0: Array, spacing: float,
             tolerance: float | None) -> float:
    """Spacing of a path from its chordal tolerance (``spacing``: the cap), mm.

    ``curve(u)`` evaluates the path at parameters ``u``; ``u0, c0`` a coarse
    sampling of it. The curvature is measured on the curve densely sampled
    (``spacing.refined_spacing``, ``spacing.chord_spacing``).
    """
    if tolerance is None:
        return spacing
    chordal = tolerance

    def measure(step: float) -> float:
        return chord_spacing(curve(_resample(u0, c0, step)), chordal, spacing)

    return refined_spacing(measure, spacing)


def _beyond_ends(wall: Wall, hub: RevolvedSurface, radius: float, u: Array) -> Array:
    """How far (mm) the junction ball's hub foot lies beyond the nearer contour end.

    Along the contour's end tangents: ``t(1) . (p - c(1))`` past the outlet end and
    ``-t(0) . (p - c(0))`` before the inlet end, the larger of the two; negative
    inside the contour. Smooth in u, so its zero is found by regula falsi.
    """
    centre = wall.blade.offset(u, _solve_v(wall, hub, radius, u), wall.side, radius)
    zr = np.column_stack([centre[:, 2], np.hypot(centre[:, 0], centre[:, 1])])
    ends = hub.meridian(np.array([0.0, 1.0]))
    tangents = hub.meridian_tangent(np.array([0.0, 1.0]))
    before = -(zr - ends[0]) @ tangents[0]
    after = (zr - ends[1]) @ tangents[1]
    return np.asarray(np.maximum(before, after))


def _touching_range(wall: Wall, hub: RevolvedSurface, radius: float) -> tuple[float, float]:
    """Range of u where the junction ball really touches the hub (foot inside the contour).

    Where a blade edge sits on the hub rim or nose, the ball centred on the offset
    intersection would have its hub foot beyond the end of the contour: it touches
    only the hub's tangent extension, not the hub. The path is trimmed there (the
    end found by regula falsi in u); the blade passes above still reach the edge.
    """
    u = np.linspace(0.0, 1.0, _COARSE)
    excess = _beyond_ends(wall, hub, radius, u)
    inside = excess < 0
    if not inside.any():
        raise InputError(f"a ball of radius {radius:g} mm cannot touch the hub next to the "
                         f"{wall.label} side", field="tool", value=2.0 * radius,
                         accepted="a smaller tool")
    first, last = int(np.argmax(inside)), len(u) - 1 - int(np.argmax(inside[::-1]))
    if not inside[first:last + 1].all():
        raise InputError(f"the junction ball leaves the hub contour along the {wall.label} "
                         "side", field="meridional.hub", value=2.0 * radius,
                         accepted="a hub contour under the whole blade root")
    good = np.array([first, last])
    bad = np.clip(good + np.array([-1, 1]), 0, len(u) - 1)
    a, b = u[good], u[bad]
    fa, fb = excess[good], excess[bad]
    crossing = fb > 0  # an end inside [0, 1] needs no search
    for _ in range(_EDGE_STEPS):
        denom = np.where(np.abs(fb - fa) > 1e-300, fb - fa, 1.0)
        mid = np.where(crossing, a - fa * (b - a) / denom, a)
        fm = _beyond_ends(wall, hub, radius, mid)
        inner = fm < 0
        a, fa = np.where(inner, mid, a), np.where(inner, fm, fa)
        b, fb = np.where(inner, b, mid), np.where(inner, fb, fm)
    return float(a[0]), float(a[1])


def hub_foot(hub: RevolvedSurface, centre: Array) -> tuple[Array, Array]:
    z, r = centre[:, 2], np.hypot(centre[:, 0], centre[:, 1])
    return hub.closest_s(z, r), np.arctan2(centre[:, 1], centre[:, 0])


def junction_path(wall: Wall, opposite: Wall, hub: RevolvedSurface, radius: float,
                  spacing: float, passage: int = 0, chordal: float | None = None
                  ) -> CutterPath:
    """Ball-centre path along the hub/``wall`` junction, leading to trailing edge.

    Parameters
    ----------
    wall, opposite : Wall
        The side machined and the wall across the passage.
    hub : RevolvedSurface
    radius : float
        Ball radius R, mm.
    spacing : float
        Largest distance between consecutive centres, mm.
    chordal : float, optional
        Chordal tolerance, mm: the spacing is lowered (for the whole path) so that
        the chords between centres stay within it (``spacing.chord_spacing``).

    Returns
    -------
    CutterPath
        ``blade_contact`` and ``hub_contact`` are the two touching points.
    """
    lo, hi = _touching_range(wall, hub, radius)
    u0 = np.linspace(lo, hi, _COARSE)
    c0 = wall.blade.offset(u0, _solve_v(wall, hub, radius, u0), wall.side, radius)
    spacing = _chordal(lambda u: wall.blade.offset(u, _solve_v(wall, hub, radius, u),
                                                   wall.side, radius),
                       u0, c0, spacing, chordal)
    u = _resample(u0, c0, spacing)
    v = _solve_v(wall, hub, radius, u)
    u = _resample(u, wall.blade.offset(u, v, wall.side, radius), spacing)  # second pass
    v = _solve_v(wall, hub, radius, u)
    centre = wall.blade.offset(u, v, wall.side, radius)
    blade_normal = wall.blade.side_normal(u, v, wall.side)
    s, phi = hub_foot(hub, centre)
    hub_normal = hub.normal(s, phi)
    curve_u = wall.curve_u(u)
    return CutterPath(
        name=f"p{passage}.junction.{wall.label}", operation="junction", passage=passage,
        centre=centre, normal=hub_normal,
        reference_axis=_offset_v_direction(wall, u, v, radius), away=blade_normal,
        opposite_tip=opposite.tip_points(curve_u), curve_u=curve_u,
        blade_contact=wall.blade.side(u, v, wall.side), hub_contact=hub.point(s, phi),
        blade_v=v, wall=wall,
    )


def blade_passes(wall: Wall, opposite: Wall, hub: RevolvedSurface, radius: float,
                 stepover: float, spacing: float, passage: int = 0,
                 chordal: float | None = None) -> list[CutterPath]:
    """Passes up the blade side from the junction to the tip (v = 0), hub to shroud.

    The span from the junction ball's blade contact to the tip is split into
    ``ceil(longest span / stepover)`` equal steps in v at every u, so no two
    neighbouring passes are further apart (along the ruling) than the stepover. The
    passes run over the whole chord, u in [0, 1] (beyond a trimmed junction the lowest
    pass follows the ball touching the hub's tangent extension, above the real hub).

    The passes share their u values, spaced by arc length along the top pass. With a
    chordal tolerance (mm) that spacing is lowered until every pass's chords stay
    within it (``_blade_chordal``).
    """
    u0 = np.linspace(0.0, 1.0, _COARSE)
    top0 = wall.blade.offset(u0, np.zeros_like(u0), wall.side, radius)
    if chordal is not None:
        spacing = _blade_chordal(wall, hub, radius, stepover, u0, top0, spacing, chordal)
    u = _resample(u0, top0, spacing)
    u = _resample(u, wall.blade.offset(u, np.zeros_like(u), wall.side, radius), spacing)
    v_junction = _solve_v(wall, hub, radius, u)
    span = np.linalg.norm(wall.blade.side(u, 0.0, wall.side)
                          - wall.blade.side(u, v_junction, wall.side), axis=1)
    count = int(math.ceil(float(span.max()) / stepover))
    curve_u = wall.curve_u(u)
    out = []
    for k in range(1, count + 1):
        v = v_junction * (1.0 - k / count)
        normal = wall.blade.side_normal(u, v, wall.side)
        out.append(CutterPath(
            name=f"p{passage}.blade.{wall.label}.{k:02d}", operation="blade", passage=passage,
            centre=wall.blade.offset(u, v, wall.side, radius), normal=normal,
            reference_axis=_offset_v_direction(wall, u, v, radius), away=normal,
            opposite_tip=opposite.tip_points(curve_u), curve_u=curve_u,
            blade_v=v, wall=wall,
        ))
    return out
