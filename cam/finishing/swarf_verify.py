"""A verified swarf pass against its prediction (issue 23).

The verifier (``cam.verify``) sweeps the posted swarf program through a tri-dexel
stock; the interval ends the program made are exact points of the machined surface.
Those on a wall's swarf-cut band are measured here against the exact side surface
(a Gauss-Newton projection onto ``side_segment``: parameters ``(p, v)`` and the signed
distance along the outward normal, ``< 0`` overcut, ``> 0`` undercut) and compared,
pass by pass, with the deviation predicted point by point over the pass's band
(``swarf_sweep.pass_deviation``: the pass's own swept tool against the exact surface,
on the same band with the same inset). Lengths mm.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from cam.finishing.swarf_blade import side_segment
from cam.finishing.swarf_plan import SwarfWall
from cam.finishing.swarf_sweep import pass_deviation

__all__ = ["MeasuredPass", "measure_passes", "passes_of_program", "project_to_side"]

Array = NDArray[np.float64]
#: Gauss-Newton iterations of the projection.
_ITERATIONS = 8
#: Spacing of the projection's seed grid on a pass's band, mm.
_SEED_STEP = 0.2


@dataclass(frozen=True)
class MeasuredPass:
    """One swarf pass: predicted and measured deviation over its rulings (mm).

    Attributes
    ----------
    wall : str
        Wall label.
    first, last : int
        Its first and last ruling (indices of the wall's postures).
    samples : int
        Machined-surface samples measured on its band.
    predicted : (float, float)
        Smallest and largest predicted swept deviation over its rulings.
    measured : (float, float)
        Smallest and largest signed distance of the samples from the exact surface
        (``nan`` without samples).
    mesh : (float, float) or None
        The same from the verifier's design mesh (``DesignDistance``), when given.
    quantiles : (float, float)
        The 0.1 % and 99.9 % quantiles of the measured distances (``nan`` without
        samples).
    """

    wall: str
    first: int
    last: int
    samples: int
    predicted: tuple[float, float]
    measured: tuple[float, float]
    mesh: tuple[float, float] | None = None
    quantiles: tuple[float, float] = (float("nan"), float("nan"))

    @property
    def difference(self) -> float:
        """Largest difference of the two ranges' ends, mm."""
        return float(max(abs(self.measured[0] - self.predicted[0]),
                         abs(self.measured[1] - self.predicted[1])))

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready entry (mm)."""
        return {"wall": self.wall, "rulings": [self.first, self.last],
                "samples": self.samples, "predicted_mm": list(self.predicted),
                "measured_mm": list(self.measured), "difference_mm": self.difference,
                "measured_q001_q999_mm": list(self.quantiles),
                "design_mesh_mm": None if self.mesh is None else list(self.mesh)}


def project_to_side(seg: Any, points: Array, v_max: float = 1.0,
                    grid: tuple[int, int] = (801, 161), within: float = np.inf
                    ) -> tuple[Array, Array, Array, NDArray[np.intp]]:
    """Nearest points of a blade side to ``points``: parameters and signed distance.

    Parameters
    ----------
    seg : OutlineSegment
        The side (``point(p, v)``, ``normal(p, v)`` outward).
    points : (n, 3) float64
        Query points, mm.
    v_max : float
        Largest v of the seed grid.
    grid : (int, int)
        Seed grid size in p and v.
    within : float
        Only points whose nearest seed lies within this distance are projected, mm.

    Returns
    -------
    p, v : (k,) float64
        Parameters of the foot point.
    distance : (k,) float64
        ``(x - S(p, v)) . n``, mm.
    index : (k,) intp
        The points these answers belong to (all of them when ``within`` is inf).
    """
    pg, vg = np.meshgrid(np.linspace(0.0, 1.0, grid[0]), np.linspace(0.0, v_max, grid[1]),
                         indexing="ij")
    gap, nearest = cKDTree(seg.point(pg.ravel(), vg.ravel())).query(points)
    index = np.flatnonzero(gap <= within)
    points, nearest = points[index], nearest[index]
    p, v = pg.ravel()[nearest].copy(), vg.ravel()[nearest].copy()
    h = 1e-6
    for _ in range(_ITERATIONS):
        d_p = (seg.point(p + h, v) - seg.point(p - h, v)) / (2 * h)
        d_v = (seg.point(p, v + h) - seg.point(p, v - h)) / (2 * h)
        r = points - seg.point(p, v)
        a11 = np.einsum("ij,ij->i", d_p, d_p)
        a12 = np.einsum("ij,ij->i", d_p, d_v)
        a22 = np.einsum("ij,ij->i", d_v, d_v)
        b1, b2 = np.einsum("ij,ij->i", d_p, r), np.einsum("ij,ij->i", d_v, r)
        det = a11 * a22 - a12 * a12
        p = p + (a22 * b1 - a12 * b2) / det
        v = v + (a11 * b2 - a12 * b1) / det
    distance = np.einsum("ij,ij->i", points - seg.point(p, v), seg.normal(p, v))
    return p, v, np.asarray(distance), index


def passes_of_program(walls: list[SwarfWall], tips: Array, tolerance: float = 2e-3
                      ) -> list[tuple[int, NDArray[np.intp]]]:
    """The passes of passage 0 a program cuts: runs of rulings whose tip it reaches.

    Parameters
    ----------
    walls : list of SwarfWall
        The prediction (``swarf_walls``).
    tips : (m, 3) float64
        Tool tips of the program (APT poses), mm.
    tolerance : float
        Largest distance of a ruling's planned tip from a program tip, mm.

    Returns
    -------
    list of (int, (k,) intp)
        Wall index and the ruling indices of each pass.
    """
    tree = cKDTree(tips)
    out = []
    for w, sw in enumerate(walls):
        dist, _ = tree.query(sw.result.postures.tips)
        cut = np.flatnonzero(dist < tolerance)
        for run in np.split(cut, np.flatnonzero(np.diff(cut) > 1) + 1):
            if len(run) >= 2:
                out.append((w, run))
    return out


def _length(seg: Any, p0: float, p1: float, v: float) -> float:
    """Length of the side's p-line at ``v`` from p0 to p1, or of its v-line at p0 from
    0 to v when p0 == p1, mm (polyline of 101 points)."""
    t = np.linspace(0.0, 1.0, 101)
    line = seg.point(p0 + t * (p1 - p0), v * t if p0 == p1 else np.full_like(t, v))
    return float(np.linalg.norm(np.diff(line, axis=0), axis=1).sum())


def _project_range(seg: Any, points: Array, lo: float, hi: float, v_max: float,
                   seeds: tuple[int, int], reach: float
                   ) -> tuple[Array, Array, Array, NDArray[np.intp]]:
    """``project_to_side`` over the p range [lo, hi] (reparametrised), points whose
    nearest seed lies within ``reach`` plus a seed step."""
    class _Range:
        def point(self, q: Array, v: Array) -> Array:
            return np.asarray(seg.point(lo + np.asarray(q) * (hi - lo), v))

        def normal(self, q: Array, v: Array) -> Array:
            return np.asarray(seg.normal(lo + np.asarray(q) * (hi - lo), v))

    q, v, d, index = project_to_side(_Range(), points, v_max, seeds,
                                     within=reach + 2.0 * _SEED_STEP)
    return lo + q * (hi - lo), v, d, index


def _predicted(seg: Any, sw: SwarfWall, run: NDArray[np.intp], margin: float) -> Array:
    """``pass_deviation`` of a pass on its band, ``margin`` inside its top and bottom."""
    res = sw.result
    u = res.postures.u

    def point(q: Array, s: Array) -> Array:
        return np.asarray(seg.point(q, s * np.interp(q, u, res.v_bottom)))

    field = pass_deviation(point, res.flank, res.postures, run, samples=61)
    ends = point(field.u, np.ones_like(field.u)) - point(field.u, np.zeros_like(field.u))
    length = np.linalg.norm(ends, axis=1)[:, None]
    inside = ((field.v[None, :] * length >= margin)
              & ((1.0 - field.v[None, :]) * length >= margin))
    return np.asarray(field.deviation[inside])


def measure_passes(walls: list[SwarfWall], passes: list[tuple[int, NDArray[np.intp]]],
                   points: Array, leading_edge: str, trailing_edge: str, *,
                   margin: float = 0.5, reach: float = 0.2,
                   design: Callable[[Array], Array] | None = None,
                   collect: list[Array] | None = None) -> list[MeasuredPass]:
    """Measured against predicted deviation of every pass.

    Parameters
    ----------
    walls : list of SwarfWall
    passes : list of (int, (k,) intp)
        ``passes_of_program``.
    points : (n, 3) float64
        Machined-surface samples the swarf program made (dexel interval ends), mm.
    leading_edge, trailing_edge : str
        The spec's edge shapes.
    margin : float
        Samples this far inside the band's top (the blade tip) and bottom only, mm.
    reach : float
        Samples farther than this from the side belong to other faces, mm.
    design : callable, optional
        Signed distance from the design mesh (``cam.verify.deviation.DesignDistance``):
        the measured samples' range by the verifier's own measure too.
    collect : list, optional
        Receives per pass a ``(k, 6)`` array of the measured samples: ``x, y, z, p, v,
        distance`` (mm; for plots and diagnosis).

    Returns
    -------
    list of MeasuredPass
    """
    out = []
    for w, run in passes:
        sw = walls[w]
        role = "pressure" if sw.wall.side > 0 else "suction"
        seg = side_segment(sw.wall.blade, role, leading_edge, trailing_edge)
        res = sw.result
        u = res.postures.u
        lo, hi = float(u[run[0]]), float(u[run[-1]])
        v_max = float(res.v_bottom.max())
        seeds = (max(int(np.ceil(_length(seg, lo, hi, 0.0) / _SEED_STEP)), 2),
                 max(int(np.ceil(_length(seg, lo, lo, v_max) / _SEED_STEP)), 2))
        p, v, d, index = _project_range(seg, points, lo, hi, v_max, seeds, reach)
        near = index
        bottom = np.interp(p, u, res.v_bottom)
        length = np.linalg.norm(seg.point(p, bottom) - seg.point(p, np.zeros_like(p)), axis=1)
        inset = margin * bottom / np.maximum(length, 1e-9)
        keep = ((p >= lo) & (p <= hi) & (v >= inset) & (v <= bottom - inset)
                & (np.abs(d) < reach))
        predicted = _predicted(seg, sw, run, margin)
        if collect is not None:
            collect.append(np.column_stack([points[near[keep]], p[keep], v[keep], d[keep]]))
        nan = (float("nan"), float("nan"))
        measured = (float(d[keep].min()), float(d[keep].max())) if keep.any() else nan
        mesh = None
        if design is not None:
            m = design(points[near[keep]]) if keep.any() else np.zeros(0)
            mesh = (float(m.min()), float(m.max())) if len(m) else nan
        quantiles = (tuple(float(x) for x in np.quantile(d[keep], [0.001, 0.999]))
                     if keep.any() else nan)
        out.append(MeasuredPass(sw.wall.label, int(run[0]), int(run[-1]), int(keep.sum()),
                                (float(predicted.min()), float(predicted.max())), measured,
                                mesh, (quantiles[0], quantiles[1])))
    return out
