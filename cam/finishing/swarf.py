"""Swarf (flank) milling postures along the rulings of a ruled surface (issue 23).

The side of the tool lies along a ruling, so one pass cuts the whole span. For each
ruling ``u`` of a patch ``S(u, v)`` (v in [0, 1], v = 0 at the top / shroud end,
v = 1 at the bottom / hub end; outward unit normal ``n`` towards the tool):

1. **Tangent-plane posture** (classic single-point-offset positioning): the ruling's
   chord ``g`` (bottom to top), the mid-ruling normal made perpendicular to it, and
   the tool cone laid on the tangent plane along the chord -- axis
   ``a = cos(alpha) g + sin(alpha) n``, tip ``c = P0 + r0 (cos(alpha) n -
   sin(alpha) g)`` with ``P0`` the point of the chord at the tip's height, so the
   ruling's bottom end sits on the flank's lowest point ``h_lo``. On a developable
   patch the tangent plane is constant along the ruling and the tool touches the
   whole ruling: the deviation is 0.
2. **Least-squares refinement**: a small rigid motion of the tool (two translations
   across the ruling, two rotations of the axis) found by ``scipy.optimize``: first
   least squares of the signed distances of the ruling's points from the tool (the
   surface near the ruling, not the chord), then a Nelder-Mead step on the largest
   distance (minimax); when the overcut then exceeds its tolerance the tool is
   moved out along the normal just enough (the range centred in the band
   ``[-overcut, +undercut]`` if it does not fit), trading overcut for undercut.

The per-ruling deviation at a point of the ruling is the smallest signed distance
(``FlankTool.signed_distance``) of the exact surface near it, across the ruling, from
the tool at that posture (``section_gap``): a cylinder laid along a twisted ruling
touches the ruling itself everywhere but cuts into the surface beside it where the
surface normal has turned away from the tool's. ``< 0`` overcut, ``> 0`` undercut.
``cam.finishing.swarf_sweep`` adds the moving tool's envelope. Lengths mm.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares, minimize

from cam.finishing.flank_tool import FlankTool

__all__ = ["RuledPatch", "SwarfPostures", "fit_posture", "plan_postures", "section_gap",
           "section_points", "tangent_posture"]

Array = NDArray[np.float64]
#: Nelder-Mead iterations of the minimax step per ruling.
_MINIMAX_ITERATIONS = 200
#: Points across a ruling in its section neighbourhood (odd).
_SECTION_POINTS = 17


@dataclass(frozen=True)
class RuledPatch:
    """A surface patch to be flank milled, evaluated on parameter arrays.

    Attributes
    ----------
    point : callable
        ``point(u, v) -> (..., 3)`` exact surface points, mm (u, v broadcast).
    normal : callable
        ``normal(u, v) -> (..., 3)`` unit normals pointing out of the material
        (towards the tool).
    """

    point: Callable[[Array, Array], Array]
    normal: Callable[[Array, Array], Array]


@dataclass(frozen=True)
class SwarfPostures:
    """Tool postures along the rulings and their predicted deviations.

    Attributes
    ----------
    u : (n,) float64
        Ruling parameters.
    tips, axes : (n, 3) float64
        Tool tip points (mm) and unit axes (tip towards the holder).
    deviation_min, deviation_max : (n,) float64
        Smallest (most negative: overcut) and largest (undercut) signed distance of
        the ruling's surface points from the tool at its posture, mm.
    top_height : (n,) float64
        Height of the ruling's top end above the tool tip, mm (must be within the
        flutes: ``<= FlankTool.flute_length``).
    """

    u: Array
    tips: Array
    axes: Array
    deviation_min: Array
    deviation_max: Array
    top_height: Array


def _unit(v: Array) -> Array:
    return np.asarray(v / np.linalg.norm(v, axis=-1, keepdims=True))


def tangent_posture(tool: FlankTool, bottom: Array, top: Array,
                    normal: Array) -> tuple[Array, Array]:
    """Tangent-plane posture of the tool along the chord ``bottom -> top``.

    Parameters
    ----------
    tool : FlankTool
    bottom, top : (3,) float64
        Ends of the ruling, mm (the bottom end at the flank's lowest height).
    normal : (3,) float64
        Surface normal towards the tool (made perpendicular to the chord).

    Returns
    -------
    tip, axis : (3,) float64
        Tool tip (mm) and unit axis.
    """
    g = _unit(top - bottom)
    n = _unit(normal - (normal @ g) * g)
    ca, sa = math.cos(tool.half_angle), math.sin(tool.half_angle)
    axis = ca * g + sa * n
    p0 = bottom - (tool.h_lo / ca) * g
    tip = p0 + tool.r0 * (ca * n - sa * g)
    return np.asarray(tip), np.asarray(axis)


def _rotation(vector: Array) -> Array:
    """Rotation matrix of a rotation vector (Rodrigues), 3x3."""
    angle = float(np.linalg.norm(vector))
    if angle < 1e-15:
        return np.eye(3)
    k = vector / angle
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.asarray(np.eye(3) + math.sin(angle) * kx + (1 - math.cos(angle)) * kx @ kx)


def _moved(x: Array, tip: Array, axis: Array, pivot: Array, n: Array,
           b: Array) -> tuple[Array, Array]:
    """The posture moved by ``x = (dn, db, rot_n, rot_b)`` about ``pivot``."""
    rot = _rotation(x[2] * n + x[3] * b)
    new_tip = pivot + rot @ (tip - pivot) + x[0] * n + x[1] * b
    return np.asarray(new_tip), np.asarray(rot @ axis)


def section_gap(tool: FlankTool, points: Array, tip: Array, axis: Array) -> Array:
    """Deviation of each ruling point's cross-section from one tool posture, mm.

    Parameters
    ----------
    tool : FlankTool
    points : (k, j, 3) float64
        Surface points: ``k`` along the ruling, ``j`` across it (the section
        neighbourhood of each ruling point, the ruling itself among them), mm.
    tip, axis : (3,) float64
        The posture.

    Returns
    -------
    (k,) float64
        ``min_j`` of the signed distances: the depth the tool cuts into the surface
        near the ruling point (< 0, overcut) or the gap it leaves (> 0, undercut).
    """
    return np.asarray(tool.signed_distance(points, tip, axis).min(axis=-1))


def fit_posture(tool: FlankTool, points: Array, tip: Array, axis: Array, normal: Array,
                overcut: float, undercut: float) -> tuple[Array, Array]:
    """Refine a posture so the surface near the ruling deviates least from the tool.

    Parameters
    ----------
    tool : FlankTool
    points : (k, j, 3) float64
        Exact surface points along the ruling and across it (``section_gap``), mm.
    tip, axis : (3,) float64
        Starting posture (``tangent_posture``).
    normal : (3,) float64
        Surface normal at the middle of the ruling.
    overcut, undercut : float
        Tolerances (>= 0), mm: an overcut beyond ``overcut`` is shifted into
        undercut (centred in ``[-overcut, +undercut]`` when the range is wider).

    Returns
    -------
    tip, axis : (3,) float64
        The refined posture; the starting one when it is not worse.
    """
    pivot = points[points.shape[0] // 2, points.shape[1] // 2]
    n = _unit(normal - (normal @ axis) * axis)
    b = _unit(np.cross(axis, n))

    def residual(x: Array) -> Array:
        t, a = _moved(x, tip, axis, pivot, n, b)
        return section_gap(tool, points, t, a)

    def spread(x: Array) -> float:
        return float(np.max(np.abs(residual(x))))

    x0 = np.zeros(4)
    if spread(x0) < 1e-9:
        return tip, axis
    lsq = least_squares(residual, x0, x_scale=np.array([0.01, 0.01, 1e-3, 1e-3]),
                        xtol=1e-12, ftol=1e-12)
    x1 = np.asarray(lsq.x)
    mm = minimize(spread, x1, method="Nelder-Mead",
                  options={"maxiter": _MINIMAX_ITERATIONS, "xatol": 1e-7, "fatol": 1e-7,
                           "initial_simplex": x1 + np.vstack([np.zeros(4),
                                                              np.diag([1e-3, 1e-3,
                                                                       1e-4, 1e-4])])})
    best = np.array(min((x0, x1, np.asarray(mm.x)), key=spread))
    d = residual(best)
    low, high = float(d.min()), float(d.max())
    if low < -overcut:
        shift = -overcut - low
        if high + shift > undercut:
            shift = 0.5 * (undercut - overcut) - 0.5 * (low + high)
        best[0] += shift
    return _moved(best, tip, axis, pivot, n, b)


def section_points(patch: RuledPatch, u: float, v: Array, half_width: float,
                   count: int = _SECTION_POINTS) -> Array:
    """Surface points on and across the ruling ``u`` (the section neighbourhoods).

    Parameters
    ----------
    patch : RuledPatch
    u : float
        Ruling parameter.
    v : (k,) float64
        Points along the ruling.
    half_width : float
        Arc length across the ruling on each side, mm (the tool radius: the deepest
        cut of a tool crossing the surface at a small angle lies within it).
    count : int
        Points across (odd: the ruling is the middle one); spaced quadratically,
        densest at the ruling.

    Returns
    -------
    (k, count, 3) float64
    """
    h = 1e-6
    speed = np.linalg.norm(patch.point(np.full_like(v, u + h), v)
                           - patch.point(np.full_like(v, u - h), v), axis=-1) / (2 * h)
    t = np.linspace(-1.0, 1.0, count)
    arc = half_width * np.sign(t) * t * t
    uu = np.clip(u + arc[None, :] / speed[:, None], 0.0, 1.0)
    return np.asarray(patch.point(uu, np.broadcast_to(v[:, None], uu.shape)))


def plan_postures(patch: RuledPatch, tool: FlankTool, u: Array, *, samples: int = 21,
                  overcut: float = 0.01, undercut: float = 0.03,
                  refine: bool = True) -> SwarfPostures:
    """Swarf postures at the rulings ``u`` of a patch and their deviations.

    Parameters
    ----------
    patch : RuledPatch
    tool : FlankTool
    u : (n,) float64
        Ruling parameters, in cutting order.
    samples : int
        Points per ruling (v uniform in [0, 1]) for the fit and the deviation.
    overcut, undercut : float
        Tolerance band (mm) the refinement fits the deviations in.
    refine : bool
        Apply the least-squares refinement (``False``: tangent-plane postures).

    Returns
    -------
    SwarfPostures
        Deviations: ``section_gap`` of each ruling at its posture.
    """
    u = np.asarray(u, dtype=np.float64)
    v = np.linspace(0.0, 1.0, samples)
    normals = patch.normal(u, np.full_like(u, 0.5))
    width = float(tool.radius_at(np.array(tool.flute_length)))
    n = len(u)
    tips, axes = np.empty((n, 3)), np.empty((n, 3))
    dev_min, dev_max, top = np.empty(n), np.empty(n), np.empty(n)
    for i in range(n):
        pts = section_points(patch, float(u[i]), v, width)
        ruling = pts[:, pts.shape[1] // 2]
        tip, axis = tangent_posture(tool, ruling[-1], ruling[0], normals[i])
        if refine:
            tip, axis = fit_posture(tool, pts, tip, axis, normals[i], overcut, undercut)
        gap = section_gap(tool, pts, tip, axis)
        tips[i], axes[i] = tip, axis
        dev_min[i], dev_max[i] = gap.min(), gap.max()
        top[i] = float((ruling[0] - tip) @ axis)
    return SwarfPostures(u, tips, axes, dev_min, dev_max, top)
