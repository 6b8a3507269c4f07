"""A verified swarf pass against its prediction (issue 23).

The verifier (``cam.verify``) sweeps the posted swarf program through a tri-dexel
stock; the interval ends the program made are exact points of the machined surface.
Those on a wall's swarf-cut band are measured here against the exact side surface
(a Gauss-Newton projection onto ``side_segment``: parameters ``(p, v)`` and the signed
distance along the outward normal, ``< 0`` overcut, ``> 0`` undercut) and compared,
pass by pass, with the deviation the planner predicted (``BladeSwarfPass.sweep``, the
swept tool against the exact surface) over the same rulings. Lengths mm.
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

__all__ = ["MeasuredPass", "measure_passes", "passes_of_program", "project_to_side"]

Array = NDArray[np.float64]
#: Gauss-Newton iterations of the projection.
_ITERATIONS = 8


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
    """

    wall: str
    first: int
    last: int
    samples: int
    predicted: tuple[float, float]
    measured: tuple[float, float]
    mesh: tuple[float, float] | None = None

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
                "design_mesh_mm": None if self.mesh is None else list(self.mesh)}


def project_to_side(seg: Any, points: Array, v_max: float = 1.0,
                    grid: tuple[int, int] = (801, 161)) -> tuple[Array, Array, Array]:
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

    Returns
    -------
    p, v : (n,) float64
        Parameters of the foot point.
    distance : (n,) float64
        ``(x - S(p, v)) . n``, mm.
    """
    pg, vg = np.meshgrid(np.linspace(0.0, 1.0, grid[0]), np.linspace(0.0, v_max, grid[1]),
                         indexing="ij")
    _, nearest = cKDTree(seg.point(pg.ravel(), vg.ravel())).query(points)
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
    return p, v, np.asarray(distance)


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


def measure_passes(walls: list[SwarfWall], passes: list[tuple[int, NDArray[np.intp]]],
                   points: Array, leading_edge: str, trailing_edge: str, *,
                   margin: float = 0.5, reach: float = 0.2,
                   design: Callable[[Array], Array] | None = None) -> list[MeasuredPass]:
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
        ends = seg.point(np.array([lo, hi]), np.zeros(2))
        centre, half = ends.mean(axis=0), 0.5 * float(np.linalg.norm(ends[1] - ends[0]))
        near = np.linalg.norm(points - centre, axis=1) < half + 60.0
        p, v, d = project_to_side(seg, points[near], float(res.v_bottom.max()))
        bottom = np.interp(p, u, res.v_bottom)
        length = np.linalg.norm(seg.point(p, bottom) - seg.point(p, np.zeros_like(p)), axis=1)
        inset = margin * bottom / np.maximum(length, 1e-9)
        keep = ((p >= lo) & (p <= hi) & (v >= inset) & (v <= bottom - inset)
                & (np.abs(d) < reach))
        rows = (res.sweep.u >= lo - 1e-12) & (res.sweep.u <= hi + 1e-12)
        predicted = res.sweep.deviation[rows]
        nan = (float("nan"), float("nan"))
        measured = (float(d[keep].min()), float(d[keep].max())) if keep.any() else nan
        mesh = None
        if design is not None:
            m = design(points[near][keep]) if keep.any() else np.zeros(0)
            mesh = (float(m.min()), float(m.max())) if len(m) else nan
        out.append(MeasuredPass(sw.wall.label, int(run[0]), int(run[-1]), int(keep.sum()),
                                (float(predicted.min()), float(predicted.max())), measured,
                                mesh))
    return out
