"""Deviation of a surface from the envelope of a moving swarf tool (issue 23).

Between two planned postures the machine moves the tip and turns the axis; in the
workpiece frame this is close to a linear blend of tips and of axes (the rotary
axes' nonlinearity aside), so the sweep is sampled by ``refine`` blended postures
per step. The material left at a surface point is its smallest signed distance
from any tool instance of the sweep: ``min_i d_i(p)``. Negative: the tool cut
below the design surface (overcut); positive: material left (undercut).

The surface is sampled on the rulings of the blended postures (their own u) and, at
each ruling point, across the ruling over the tool radius (``section_points``: the
narrow strip beside a ruling where a tool crossing the surface at a small angle cuts
deepest), and compared with every tool instance within ``window`` instances, which
covers the tool's reach along the pass. The deviation at a ruling point is the
smallest over its section strip.

That strip reaches beyond a pass's end ruling, onto surface the last posture touches,
and so hides the material left *inside* the end ruling where the leaning flank's
contact curve crosses it (on nine_blade 0.02-0.08 mm within one ruling step of 4
passes' ends, at the top and bottom of the band). ``pass_deviation`` is the point-wise
field of one pass: at every surface point between its end rulings the smallest signed
distance of any of its tool instances; it matches the verifier's samples within
0.005 mm there too.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from cam.finishing.flank_tool import FlankTool
from cam.finishing.swarf import RuledPatch, SwarfPostures, section_points

__all__ = ["SweptDeviation", "blend_postures", "pass_deviation", "swept_deviation"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class SweptDeviation:
    """Deviation field of the swept tool on the patch.

    Attributes
    ----------
    u, v : (m,), (k,) float64
        Parameters of the sample grid.
    deviation : (m, k) float64
        ``min_i d_i`` at each sample, mm (< 0 overcut, > 0 undercut).
    """

    u: Array
    v: Array
    deviation: Array

    @property
    def overcut(self) -> float:
        """Largest overcut depth, mm (>= 0)."""
        return float(max(0.0, -self.deviation.min()))

    @property
    def undercut(self) -> float:
        """Largest undercut (material left), mm (>= 0)."""
        return float(max(0.0, self.deviation.max()))


def blend_postures(postures: SwarfPostures, refine: int) -> tuple[Array, Array, Array]:
    """Postures blended linearly between the planned ones, ``refine`` per step.

    Parameters
    ----------
    postures : SwarfPostures
    refine : int
        Sub-steps per planned step (1: the planned postures only).

    Returns
    -------
    u : (m,) float64
    tips, axes : (m, 3) float64
        ``m = (n - 1) refine + 1``; axes renormalised.
    """
    n = len(postures.u)
    s = np.linspace(0.0, n - 1.0, (n - 1) * refine + 1)
    i = np.minimum(np.floor(s).astype(int), n - 2) if n > 1 else np.zeros(len(s), int)
    t = (s - i)[:, None] if n > 1 else np.zeros((len(s), 1))
    j = np.minimum(i + 1, n - 1)

    def lerp(a: Array) -> Array:
        return np.asarray((1 - t) * a[i] + t * a[j])

    u = lerp(postures.u[:, None])[:, 0]
    axes = lerp(postures.axes)
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    return u, lerp(postures.tips), axes


def swept_deviation(patch: RuledPatch, tool: FlankTool, postures: SwarfPostures, *,
                    refine: int = 4, samples: int = 21, window: int = 8) -> SweptDeviation:
    """Signed deviation of the patch from the swept tool.

    Parameters
    ----------
    patch : RuledPatch
    tool : FlankTool
    postures : SwarfPostures
        Planned postures (``plan_postures``).
    refine : int
        Blended postures per planned step.
    samples : int
        Points per ruling (v uniform in [0, 1]).
    window : int
        Tool instances on each side of a ruling compared with its points.

    Returns
    -------
    SweptDeviation
    """
    u, tips, axes = blend_postures(postures, refine)
    v = np.linspace(0.0, 1.0, samples)
    width = float(tool.radius_at(np.array(tool.flute_length)))
    pts = np.stack([section_points(patch, float(ui), v, width) for ui in u])
    return SweptDeviation(u, v, _windowed_min(tool, pts, tips, axes, window).min(axis=2))


def _windowed_min(tool: FlankTool, pts: Array, tips: Array, axes: Array,
                  window: int) -> Array:
    """Smallest signed distance of each point to the tool instances within ``window``
    of its ruling.

    Parameters
    ----------
    pts : (m, ..., 3) float64
        Points, grouped by ruling (first axis), mm.
    tips, axes : (m, 3) float64
        The tool instance of each ruling, mm and unit axes.
    window : int
        Instances on each side compared.

    Returns
    -------
    (m, ...) float64
        ``min_i d_i``, mm (< 0 overcut, > 0 undercut).
    """
    best = np.full(pts.shape[:-1], np.inf)
    m = len(pts)
    lead = (slice(None),) + (None,) * (pts.ndim - 2) + (slice(None),)
    for shift in range(-window, window + 1):
        lo, hi = max(0, -shift), min(m, m - shift)
        if lo >= hi:
            continue
        idx = np.arange(lo, hi)
        d = tool.signed_distance(pts[idx], tips[idx + shift][lead], axes[idx + shift][lead])
        best[idx] = np.minimum(best[idx], d)
    return best


def pass_deviation(point: Callable[[Array, Array], Array], tool: FlankTool,
                   postures: SwarfPostures, run: NDArray[np.intp], *,
                   v_range: tuple[float, float] = (0.0, 1.0), refine: int = 8,
                   samples: int = 21, window: int = 16) -> SweptDeviation:
    """Point-wise deviation of the band of one pass from its own swept tool.

    Parameters
    ----------
    point : callable
        ``point(u, s)`` of the band, ``(..., 3)`` mm (s in [0, 1] along the ruling).
    tool : FlankTool
    postures : SwarfPostures
        The wall's postures.
    run : (r,) intp
        The pass's rulings (consecutive indices, r >= 2).
    v_range : (float, float)
        The part of each ruling sampled (s).
    refine : int
        Blended postures (and surface rulings) per planned step.
    samples : int
        Points per ruling.
    window : int
        Tool instances on each side of a surface ruling compared with it (the
        default reaches two planned steps at ``refine`` 8).

    Returns
    -------
    SweptDeviation
        On the blended rulings between the pass's end rulings (no strip across them):
        ``min_i d_i`` at each point, mm (< 0 overcut, > 0 undercut).
    """
    own = replace(postures, u=postures.u[run], tips=postures.tips[run],
                  axes=postures.axes[run])
    u, tips, axes = blend_postures(own, refine)
    v = np.linspace(v_range[0], v_range[1], samples)
    pts = point(np.repeat(u[:, None], samples, axis=1), np.broadcast_to(v, (len(u), samples)))
    return SweptDeviation(u, v, _windowed_min(tool, pts, tips, axes, window))
