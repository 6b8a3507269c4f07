"""Swarf passes on the pressure and suction sides of an impeller blade (issue 23).

One pass per blade side: the tool's flank along the side's rulings from the blade tip
(v = 0) down to where the tool's ball (or tip) still clears the hub fillet, in the
outline's u range (``geometry.outline.blade_loop``: the side between the edge caps or
broken corners). The band's bottom ``v_b(u)`` is the lowest ruling end for which the
centre of the tool's ball is at least ``max(R_b, r_f)`` above the hub (the ball then
stays inside the rolling ball of the fillet and never cuts the fillet or the hub) --
for the tangent-plane posture first, then raised where the fitted posture's ball
comes nearer (up to ``_HUB_ROUNDS`` times);
the rest of the side (the fillet strip and the edges) is left to point milling.

The deviations are computed against the exact side surface (``BladeSurface.side``),
not a mesh: per ruling (``cam.finishing.swarf.section_gap``) and over the sweep
(``cam.finishing.swarf_sweep``). A ruling is swarf-cuttable when its deviations lie
within ``[-overcut, +undercut]`` and its top end is within the flutes (by a margin:
the neck's clearance). Lengths mm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from cam.finishing.flank_tool import FlankTool
from cam.finishing.swarf import RuledPatch, SwarfPostures, plan_postures
from cam.finishing.swarf_sweep import SweptDeviation, swept_deviation
from geometry.outline import OutlineSegment, blade_loop
from geometry.revolved import RevolvedSurface
from geometry.surfaces import BladeSurface

__all__ = ["BladeSwarfPass", "band_bottom", "plan_blade_side", "side_segment"]

Array = NDArray[np.float64]
#: Bisection steps of the band bottom (v resolution 2^-30).
_BISECTIONS = 30
#: Rounds of raising the band bottom where the fitted posture's ball comes nearer the
#: hub than ``max(R_b, r_f)`` (each re-plans the band).
_HUB_ROUNDS = 3
#: Further clearance of the ball centre from the hub added in such a round, mm.
_HUB_MARGIN = 0.01
#: Grid of the area quadrature (u, v).
_AREA_GRID = (121, 41)


@dataclass(frozen=True)
class BladeSwarfPass:
    """One swarf pass on one blade side and its predicted deviations.

    Attributes
    ----------
    role : str
        ``"pressure"`` or ``"suction"``.
    postures : SwarfPostures
        Tool postures along the rulings (``u`` here is the side segment's p).
    v_bottom : (n,) float64
        Blade v of the band bottom at each ruling (v = 0: blade tip).
    sweep : SweptDeviation
        Deviation of the band from the swept tool, mm.
    cuttable : (n,) bool
        Rulings within tolerance and within the flutes.
    ruling_area : (n,) float64
        Area of the band strip of each ruling (half a step on each side), mm^2.
    side_area : float
        Area of the side (v in [0, 1], the outline's u range), mm^2.
    flank : FlankTool
        The tool the postures are planned for.
    """

    role: str
    postures: SwarfPostures
    v_bottom: Array
    sweep: SweptDeviation
    cuttable: NDArray[np.bool_]
    ruling_area: Array
    side_area: float
    flank: FlankTool

    @property
    def area_share(self) -> float:
        """Share of the side's area (v in [0, 1], the outline's u range) inside the
        band of the cuttable rulings, 0..1."""
        if self.side_area <= 0:
            return 0.0
        return float(self.ruling_area[self.cuttable].sum() / self.side_area)

    def summary(self) -> dict[str, float | int | str]:
        """Per-pass figures for reports (mm, counts, share 0..1).

        Returns
        -------
        dict
        """
        p = self.postures
        return {
            "role": self.role,
            "rulings": len(p.u),
            "cuttable_rulings": int(self.cuttable.sum()),
            "ruling_overcut_mm": float(max(0.0, -p.deviation_min.min())),
            "ruling_undercut_mm": float(max(0.0, p.deviation_max.max())),
            "swept_overcut_mm": self.sweep.overcut,
            "swept_undercut_mm": self.sweep.undercut,
            "max_top_height_mm": float(p.top_height.max()),
            "area_share": self.area_share,
            "side_area_mm2": self.side_area,
        }


def side_segment(blade: BladeSurface, role: str, leading_edge: str,
                 trailing_edge: str) -> OutlineSegment:
    """The pressure or suction side piece of the blade's outline.

    Parameters
    ----------
    blade : BladeSurface
    role : str
        ``"pressure"`` or ``"suction"``.
    leading_edge, trailing_edge : str
        Edge shapes of the spec (``"round"`` or ``"cut"``).

    Returns
    -------
    OutlineSegment
        ``point(p, v)``, outward ``normal(p, v)`` with p in [0, 1] along the side.
    """
    for seg in blade_loop(blade, leading_edge, trailing_edge):
        if seg.role == role and seg.kind == "side":
            return seg
    raise ValueError(f"blade side role must be pressure or suction, not {role!r}")


def band_bottom(seg: OutlineSegment, hub: RevolvedSurface, tool: FlankTool, p: Array,
                fillet_radius: float, margin: Array | float = 0.0) -> Array:
    """Lowest blade v of the swarf band at each ruling p (the ball clears the fillet).

    Parameters
    ----------
    seg : OutlineSegment
        The blade side.
    hub : RevolvedSurface
    tool : FlankTool
    p : (n,) float64
        Rulings.
    fillet_radius : float
        Root fillet radius r_f, mm.
    margin : float or (n,) float64
        Further distance per ruling the ball centre keeps from the hub, mm (what the
        fitted posture came nearer than the tangent-plane one: ``plan_blade_side``).

    Returns
    -------
    (n,) float64
        v_b with the tangent-plane posture along ``[0, v_b]`` keeping the ball centre
        (the tip for a flat end) ``max(R_b, r_f) + margin`` from the hub (bisection).
    """
    need = max(tool.ball_radius, fillet_radius) + np.broadcast_to(
        np.asarray(margin, dtype=np.float64), np.shape(p))
    p = np.asarray(p, dtype=np.float64)
    ca, sa = math.cos(tool.half_angle), math.sin(tool.half_angle)
    top = seg.point(p, np.zeros_like(p))

    def clear(vb: Array) -> NDArray[np.bool_]:
        bottom = seg.point(p, vb)
        normal = seg.normal(p, 0.5 * vb)
        g = _unit(top - bottom)
        n = _unit(normal - np.einsum("ij,ij->i", normal, g)[:, None] * g)
        axis = ca * g + sa * n
        tip = bottom - (tool.h_lo / ca) * g + tool.r0 * (ca * n - sa * g)
        centre = tip + tool.ball_radius * axis
        return np.asarray(hub.signed_distance(centre) >= need)

    lo, hi = np.full(len(p), 0.05), np.ones(len(p))
    done = clear(hi)
    for _ in range(_BISECTIONS):
        mid = 0.5 * (lo + hi)
        ok = clear(mid)
        lo, hi = np.where(ok, mid, lo), np.where(ok, hi, mid)
    return np.asarray(np.where(done, 1.0, lo))


def _unit(v: Array) -> Array:
    return np.asarray(v / np.linalg.norm(v, axis=-1, keepdims=True))


def _band_patch(seg: OutlineSegment, p: Array, v_bottom: Array) -> RuledPatch:
    """The side band ``v in [0, v_b(p)]`` as a patch over ``(p, s)``, s in [0, 1]."""

    def scale(pp: Array) -> Array:
        return np.asarray(np.interp(pp, p, v_bottom))

    def point(pp: Array, s: Array) -> Array:
        pp, s = np.broadcast_arrays(np.asarray(pp, float), np.asarray(s, float))
        return seg.point(pp, s * scale(pp))

    def normal(pp: Array, s: Array) -> Array:
        pp, s = np.broadcast_arrays(np.asarray(pp, float), np.asarray(s, float))
        return seg.normal(pp, s * scale(pp))

    return RuledPatch(point, normal)


def _area(seg: OutlineSegment, p_lo: Array, p_hi: Array, v_bottom: Array,
          p: Array, v_top_only: bool, nu: int = _AREA_GRID[0]) -> Array:
    """Areas of the side over ``p`` in each [p_lo, p_hi], v in [0, v_b] (or [0, 1]), mm^2."""
    nv = _AREA_GRID[1]
    out = np.zeros(len(p_lo))
    for i, (a, b) in enumerate(zip(p_lo, p_hi, strict=True)):
        if b <= a:
            continue
        pp = np.linspace(a, b, nu)
        vb = np.interp(pp, p, v_bottom) if v_top_only else np.ones(nu)
        s = np.linspace(0.0, 1.0, nv)
        pg, sg = np.meshgrid(pp, s, indexing="ij")
        vg = sg * vb[:, None]
        h = 1e-6
        d_p = (seg.point(pg + h, vg) - seg.point(pg - h, vg)) / (2 * h)
        d_v = (seg.point(pg, vg + h) - seg.point(pg, vg - h)) / (2 * h)
        dens = np.linalg.norm(np.cross(d_p, d_v), axis=-1) * vb[:, None]
        out[i] = float(np.trapezoid(np.trapezoid(dens, s, axis=1), pp))
    return out


def plan_blade_side(blade: BladeSurface, hub: RevolvedSurface, role: str, tool: FlankTool,
                    *, leading_edge: str, trailing_edge: str, fillet_radius: float,
                    ruling_step_mm: float = 0.5, overcut: float = 0.01,
                    undercut: float = 0.03, samples: int = 21,
                    refine: bool = True, flute_margin: float = 0.0) -> BladeSwarfPass:
    """Plan and predict the swarf pass on one side of a blade.

    Parameters
    ----------
    blade : BladeSurface
    hub : RevolvedSurface
    role : str
        ``"pressure"`` or ``"suction"``.
    tool : FlankTool
    leading_edge, trailing_edge : str
        Edge shapes (``"round"``, ``"cut"``).
    fillet_radius : float
        Root fillet radius, mm.
    ruling_step_mm : float
        Largest distance between consecutive rulings at the blade tip, mm.
    overcut, undercut : float
        Tolerances (>= 0), mm.
    samples : int
        Points per ruling.
    refine : bool
        Least-squares refinement of the postures.
    flute_margin : float
        The ruling's top end must lie this far below the top of the flutes, mm (the
        neck above them keeps its clearance from the blade tip: ``clearance_mm``).

    Returns
    -------
    BladeSwarfPass
    """
    seg = side_segment(blade, role, leading_edge, trailing_edge)
    dense = np.linspace(0.0, 1.0, 201)
    tip_line = seg.point(dense, np.zeros_like(dense))
    length = float(np.linalg.norm(np.diff(tip_line, axis=0), axis=1).sum())
    p = np.linspace(0.0, 1.0, max(2, int(np.ceil(length / ruling_step_mm)) + 1))
    need = max(tool.ball_radius, fillet_radius)
    margin = np.zeros(len(p))
    for _ in range(_HUB_ROUNDS):
        v_bottom = band_bottom(seg, hub, tool, p, fillet_radius, margin)
        patch = _band_patch(seg, p, v_bottom)
        postures = plan_postures(patch, tool, p, samples=samples, overcut=overcut,
                                 undercut=undercut, refine=refine)
        # the fitted posture may bring the ball nearer the hub than the tangent one
        short = need - hub.signed_distance(postures.tips + tool.ball_radius * postures.axes)
        if not np.any(short > 0):
            break
        margin = np.where(short > 0, margin + short + _HUB_MARGIN, margin)
    sweep = swept_deviation(patch, tool, postures, samples=samples)
    owner = np.rint(np.interp(sweep.u, p, np.arange(len(p)))).astype(int)
    swept_min = np.full(len(p), np.inf)
    swept_max = np.full(len(p), -np.inf)
    np.minimum.at(swept_min, owner, sweep.deviation.min(axis=1))
    np.maximum.at(swept_max, owner, sweep.deviation.max(axis=1))
    cuttable = ((postures.deviation_min >= -overcut) & (postures.deviation_max <= undercut)
                & (swept_min >= -overcut) & (swept_max <= undercut)
                & (postures.top_height <= tool.flute_length - flute_margin))
    # the band strip of each ruling: half a step each way
    half = 0.5 * (p[1] - p[0])
    strips = _area(seg, np.clip(p - half, 0.0, 1.0), np.clip(p + half, 0.0, 1.0), v_bottom,
                   p, True, nu=5)
    side_area = float(_area(seg, np.array([0.0]), np.array([1.0]), v_bottom, p, False)[0])
    return BladeSwarfPass(role, postures, v_bottom, sweep, cuttable, strips, side_area,
                          tool)
