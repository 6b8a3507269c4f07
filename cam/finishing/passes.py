"""All finishing paths of one passage: junctions, blade-side passes, hub passes.

**Hub passes** run leading to trailing edge across the passage:
``phi = (1 - lambda) phi_a(s) + lambda phi_b(s)`` on the hub offset between the two
junction paths of the passage (M4's interpolation, used here for finishing), with
``ceil(widest passage / stepover)`` steps; the axis is the two walls' rulings, turned
to the pass's angle, interpolated with the same lambda.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from cam.finishing.paths import (
    CutterPath,
    blade_passes,
    hub_foot,
    junction_path,
    passage_walls,
)
from cam.finishing.posture import rotate_about_z
from geometry.revolved import RevolvedSurface
from geometry.surfaces import ImpellerSurfaces
from impeller_cam.errors import InputError

__all__ = ["hub_passes", "passage_paths"]

Array = NDArray[np.float64]


def _unit(a: Array) -> Array:
    return np.asarray(a / np.linalg.norm(a, axis=-1, keepdims=True))


def hub_passes(first: CutterPath, second: CutterPath, hub: RevolvedSurface, radius: float,
               stepover: float, passage: int = 0, label: str = "",
               s_limits: tuple[float, float] | None = None) -> list[CutterPath]:
    """Hub passes between two junction paths of a passage, leading to trailing edge.

    Parameters
    ----------
    first, second : CutterPath
        Junction paths of the -theta wall (its pressure side) and the +theta wall.
    s_limits : (float, float), optional
        Restrict the hub meridional parameter range (splitter inlet region).
    """
    sa, pa = hub_foot(hub, first.centre)
    sb, pb = hub_foot(hub, second.centre)
    for s_path, name in ((sa, first.name), (sb, second.name)):
        inside = (s_path > 0.0) & (s_path < 1.0)  # feet beyond the contour ends are clipped
        if np.any(np.diff(s_path[inside]) <= 0):
            raise InputError("the junction path does not advance along the hub contour",
                             field="meridional.hub", value=name,
                             accepted="a hub contour the blade root crosses once")
    ia = np.flatnonzero((sa > 0.0) & (sa < 1.0))
    ib = np.flatnonzero((sb > 0.0) & (sb < 1.0))
    if len(ia) < 2 or len(ib) < 2:
        return []
    first, second = _subset(first, ia), _subset(second, ib)
    sa, pa, sb, pb = sa[ia], pa[ia], sb[ib], pb[ib]
    pa, pb = np.unwrap(pa), np.unwrap(pb)
    lo, hi = max(sa[0], sb[0]), min(sa[-1], sb[-1])
    if s_limits is not None:
        lo, hi = max(lo, s_limits[0]), min(hi, s_limits[1])
    if hi <= lo:
        return []
    count = max(len(first), len(second))
    s = np.linspace(lo, hi, count)
    phi_a = np.interp(s, sa, pa)
    phi_b = np.interp(s, sb, pb)
    # the +theta wall lies less than a turn ahead of the -theta wall
    turns = np.floor((phi_b[0] - phi_a[0]) / (2.0 * math.pi))
    phi_b = phi_b - 2.0 * math.pi * turns
    pb = pb - 2.0 * math.pi * turns
    width = hub.meridian(s)[:, 1] * (phi_b - phi_a)
    passes = int(math.ceil(float(width.max()) / stepover))
    axis_a = _interp_rows(s, sa, rotate_about_z(first.reference_axis, -pa))
    axis_b = _interp_rows(s, sb, rotate_about_z(second.reference_axis, -pb))
    away_a = _interp_rows(s, sa, rotate_about_z(first.away, -pa))
    away_b = _interp_rows(s, sb, rotate_about_z(second.away, -pb))
    tip_a = _interp_rows(s, sa, first.opposite_tip)
    tip_b = _interp_rows(s, sb, second.opposite_tip)
    curve_u = np.interp(s, sa, first.curve_u)
    out = []
    for k in range(1, passes):
        lam = k / passes
        phi = (1.0 - lam) * phi_a + lam * phi_b
        centre = hub.offset(s, phi, radius)
        axis = _unit(rotate_about_z((1.0 - lam) * axis_a + lam * axis_b, phi))
        near_first = lam < 0.5
        away = rotate_about_z(away_a if near_first else away_b, phi)
        out.append(CutterPath(
            name=f"p{passage}.hub{label}.{k:02d}", operation="hub", passage=passage,
            centre=centre, normal=hub.normal(s, phi), reference_axis=axis, away=_unit(away),
            opposite_tip=tip_a if near_first else tip_b, curve_u=curve_u,
            hub_contact=hub.point(s, phi),
        ))
    return out


def _subset(path: CutterPath, index: NDArray[np.intp]) -> CutterPath:
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


def _interp_rows(x: Array, xp: Array, rows: Array) -> Array:
    return np.stack([np.interp(x, xp, rows[:, j]) for j in range(rows.shape[1])], axis=1)


def passage_paths(surfaces: ImpellerSurfaces, radius: float, spacing: float,
                  stepover: float, *, blade: bool = True, hub: bool = True
                  ) -> list[CutterPath]:
    """All finishing paths of passage 0: junctions, then blade passes, then hub passes.

    Raises
    ------
    InputError
        The ball is smaller than the fillet radius (it would cut into the fillet),
        or it does not fit between blade and hub.
    """
    fillet = surfaces.spec.fillet_radius
    if radius < fillet - 1e-9:
        raise InputError(
            f"the ball (radius {radius:g} mm) is smaller than the fillet radius "
            f"{fillet:g} mm: its junction path would cut into the fillet",
            field="tool", value=2.0 * radius,
            accepted=f"a ball of diameter >= {2.0 * fillet:g} mm")
    pairs = passage_walls(surfaces)
    junctions: list[tuple[CutterPath, CutterPath]] = []
    for a, b in pairs:
        junctions.append((junction_path(a, b, surfaces.hub, radius, spacing),
                          junction_path(b, a, surfaces.hub, radius, spacing)))
    out: list[CutterPath] = [p for pair in junctions for p in pair]
    if blade:
        for a, b in pairs:
            out += blade_passes(a, b, surfaces.hub, radius, stepover, spacing)
            out += blade_passes(b, a, surfaces.hub, radius, stepover, spacing)
    if hub:
        if len(junctions) == 1:
            out += hub_passes(*junctions[0], surfaces.hub, radius, stepover)
        else:
            (ja, js), (jp, jb) = junctions
            out += hub_passes(ja, js, surfaces.hub, radius, stepover, label="a")
            out += hub_passes(jp, jb, surfaces.hub, radius, stepover, label="b")
            # inlet region ahead of the splitter: between the main blades
            s_split = min(hub_foot(surfaces.hub, js.centre)[0][0],
                          hub_foot(surfaces.hub, jp.centre)[0][0])
            margin = 2.0 * radius / surfaces.hub.length
            out += hub_passes(ja, jb, surfaces.hub, radius, stepover, label="i",
                              s_limits=(0.0, s_split - margin))
    return out
