"""Derived figures of an impeller: passage width d_min, r_max, rule deviation, clearances.

* ``d_min`` (M4): the shortest distance between the facing faces of adjacent blades
  (pressure side and edges of one, suction side and edges of the next, each blade its
  whole outline from ``geometry.outline``, no fillets; with splitters also main blade to
  splitter), and where it is. A coarse grid search (k-d tree) seeds a
  bounded damped Newton solve on the four surface parameters ``(u_a, v_a, u_b, v_b)``:
  the iterative refinement the paper takes from Layegh et al. (``geometry.closest``).
* ``r_max = (d_min - 2 eta) / (2 k)`` (M4 eq. 1): the largest roughing ball radius,
  ``eta`` the finishing allowance, ``k`` the protection factor (paper: 1.2 < k < 1.5).
* ``rule_deviation``: the largest distance of the camber surface from its ruled
  approximation ``(1 - v) P(u) + v Q(u)`` (closest-point distance; 0 for ruled input).
* ``max_fillet_radius``: two blade-to-hub fillets of radius rho on facing sides meet on
  the passage floor when ``2 rho`` equals the distance between the blades' hub edges
  (exact for blades normal to the hub, an estimate otherwise); a fillet can also not be
  taller than the blade, so the shortest ruling bounds it too.

``check_clearances`` turns the figures into ``InputError`` for a spec whose blades
touch or whose fillet does not fit the passage.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import minimize

from geometry.closest import (
    NEWTON_XTOL,
    PASSAGE_GRID,
    PASSAGE_STARTS,
    ClosestPair,
    SampledSurface,
    Surface,
    closest_points,
    grid_candidates,
    parameter_grid,
    refine_pair,
    sample_grid,
)
from geometry.outline import OutlineSegment, blade_outline
from geometry.surfaces import PRESSURE, SUCTION, BladeSurface, ImpellerSurfaces
from impeller_cam.errors import InputError
from impeller_cam.tolerances import DEFAULT_TOLERANCES, Tolerances

__all__ = [
    "ClosestPair",
    "FacingSides",
    "GeometryFigures",
    "check_clearances",
    "project_on_camber",
    "closest_points",
    "compute_figures",
    "facing_sides",
    "max_ball_radius",
    "minimum_passage_width",
    "PassageWidth",
    "rule_deviation",
]

#: Coarse grid points along an edge cap or face (p direction).
EDGE_GRID_U = 9
#: Default grid of the rule-deviation search.
DEVIATION_GRID = (41, 11)
_PROJECTION_STEPS = 30


@dataclass(frozen=True)
class FacingSides:
    """Two blade sides facing each other across a passage.

    ``index_a`` / ``index_b`` index ``surfaces.all_blades()`` (mains, then splitters),
    so meshes built in that order can be matched (brute-force cross-checks).
    """

    label: str
    a: BladeSurface
    side_a: int
    b: BladeSurface
    side_b: int
    index_a: int
    index_b: int


@dataclass(frozen=True)
class GeometryFigures:
    """Derived figures of an impeller (mm).

    Attributes
    ----------
    blades, splitters : int
        Numbers of main and splitter blades.
    d_min : float
        Minimum passage width between facing blade sides, mm.
    d_min_points : (2, 3) float64
        Where: the point on the first blade (pressure side or its edges), then the one
        on the next blade (suction side or its edges).
    d_min_pair : str
        Which blades and faces, e.g. ``"main pressure / splitter suction (pressure to
        leading_edge)"``.
    r_max : float
        Largest roughing ball radius by M4 eq. (1), mm (negative: no ball fits).
    k : float
        Protection factor used for ``r_max``.
    finishing_allowance : float
        eta used for ``r_max``, mm.
    min_thickness : float
        Smallest blade thickness of the thickness law, mm.
    rule_deviation : float
        Largest distance of the camber surface from its ruled approximation, mm.
    max_fillet_radius : float
        Largest blade-to-hub fillet radius the passage allows, mm.
    """

    blades: int
    splitters: int
    d_min: float
    d_min_points: NDArray[np.float64]
    d_min_pair: str
    r_max: float
    k: float
    finishing_allowance: float
    min_thickness: float
    rule_deviation: float
    max_fillet_radius: float

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready dict, lengths in mm (keys carry the unit).

        Returns
        -------
        dict
        """
        return {
            "blades": self.blades,
            "splitters": self.splitters,
            "d_min_mm": self.d_min,
            "d_min_points_mm": self.d_min_points.tolist(),
            "d_min_pair": self.d_min_pair,
            "r_max_mm": self.r_max,
            "protection_factor_k": self.k,
            "finishing_allowance_mm": self.finishing_allowance,
            "min_thickness_mm": self.min_thickness,
            "rule_deviation_mm": self.rule_deviation,
            "max_fillet_radius_mm": self.max_fillet_radius,
        }


def max_ball_radius(d_min: float, eta: float, k: float = 1.2) -> float:
    """Largest roughing ball radius ``r_max = (d_min - 2 eta) / (2 k)`` (M4 eq. 1), mm.

    Parameters
    ----------
    d_min : float
        Minimum passage width, mm.
    eta : float
        Finishing allowance, mm (>= 0).
    k : float
        Protection factor (the paper uses 1.2 < k < 1.5); must be >= 1.

    Raises
    ------
    InputError
        ``k < 1`` (no protection) or ``eta < 0``.
    """
    if not (math.isfinite(k) and k >= 1.0):
        raise InputError("protection factor too small", field="k", value=k, accepted="k >= 1")
    if not (math.isfinite(eta) and eta >= 0.0):
        raise InputError("negative allowance", field="eta", value=eta, accepted="eta >= 0 mm")
    return (d_min - 2.0 * eta) / (2.0 * k)


def facing_sides(surfaces: ImpellerSurfaces) -> list[FacingSides]:
    """The pairs of blade sides that bound the passages (one passage, by symmetry).

    Pressure side (+theta) of main blade 0 faces the suction side of the next blade at
    +pitch; with splitters, the splitter at +pitch/2 sits in between and is faced on
    both sides, and the main-to-main pair still bounds the passage upstream of it.
    """
    mains, splits = surfaces.blades, surfaces.splitters
    n = len(mains)
    pairs = [
        FacingSides(
            "main pressure / main suction", mains[0], PRESSURE, mains[1 % n], SUCTION, 0, 1 % n
        )
    ]
    if splits:
        pairs += [
            FacingSides(
                "main pressure / splitter suction", mains[0], PRESSURE, splits[0], SUCTION, 0, n
            ),
            FacingSides(
                "splitter pressure / main suction",
                splits[0],
                PRESSURE,
                mains[1 % n],
                SUCTION,
                n,
                1 % n,
            ),
        ]
    return pairs


def _outward(blade: BladeSurface, side: int) -> Surface:
    return lambda u, v: side * blade.normal(u, v)


@dataclass(frozen=True)
class PassageWidth:
    """Shortest distance across a passage: the closest pair, the blades and their faces.

    Attributes
    ----------
    pair : ClosestPair
        Points ordered as ``sides`` (the +theta blade's face first); ``params`` are the
        outline segments' ``(p, v)``.
    sides : FacingSides
    faces : (str, str)
        Outline roles of the two faces: pressure, suction, leading_edge, trailing_edge.
    """

    pair: ClosestPair
    sides: FacingSides
    faces: tuple[str, str]

    @property
    def distance(self) -> float:
        """The width, mm."""
        return self.pair.distance

    @property
    def label(self) -> str:
        """E.g. ``"main pressure / main suction (leading_edge to suction)"``."""
        return f"{self.sides.label} ({self.faces[0]} to {self.faces[1]})"


def minimum_passage_width(
    surfaces: ImpellerSurfaces,
    *,
    v_range: tuple[float, float] = (0.0, 1.0),
    grid: tuple[int, int] = PASSAGE_GRID,
) -> PassageWidth:
    """d_min over all facing blades (``facing_sides``): the shortest facing distance.

    Each blade is its whole outline (``geometry.outline.blade_outline``: side surfaces
    and the leading/trailing-edge caps or faces of the spec, no fillets). The faces of
    the first blade that can face the next blade (pressure side and edges) are paired
    with those of the next blade (suction side and edges); ``closest_points`` keeps
    only facing points.

    Parameters
    ----------
    surfaces : ImpellerSurfaces
    v_range : (float, float)
        Span range searched (0 shroud, 1 hub); ``(1, 1)`` gives the width between
        the blades' hub edges.
    grid : (int, int)
        Coarse search grid of a side surface (edges use ``EDGE_GRID_U`` along p).

    Returns
    -------
    PassageWidth
    """
    spec = surfaces.spec
    blades = surfaces.all_blades()
    outlines = {}
    samples: dict[tuple[int, str], SampledSurface] = {}

    def sampled(index: int, face: OutlineSegment) -> SampledSurface:
        if (index, face.role) not in samples:
            nu = grid[0] if face.kind == "side" else EDGE_GRID_U
            samples[index, face.role] = sample_grid(face.point, face.normal, nu, grid[1], v_range)
        return samples[index, face.role]

    found = []
    for f in facing_sides(surfaces):
        for index in (f.index_a, f.index_b):
            if index not in outlines:
                outlines[index] = blade_outline(
                    blades[index], spec.leading_edge, spec.trailing_edge
                )
        for face_a in (x for x in outlines[f.index_a] if x.role != "suction"):
            for face_b in (x for x in outlines[f.index_b] if x.role != "pressure"):
                sa, sb = sampled(f.index_a, face_a), sampled(f.index_b, face_b)
                candidates = grid_candidates(sa, sb)
                if candidates is not None:
                    found.append(
                        (float(candidates[0].min()), sa, sb, candidates, f, face_a, face_b)
                    )
    # Refine in order of the grid distance; skip a face pair whose grid distance minus the
    # two grid spacings (a lower bound of its true distance) exceeds the best found.
    best: PassageWidth | None = None
    for grid_min, sa, sb, candidates, f, face_a, face_b in sorted(found, key=lambda x: x[0]):
        if best is not None and grid_min - sa.spacing - sb.spacing > best.distance:
            continue
        pair = refine_pair(sa, sb, candidates, v_range, PASSAGE_STARTS)
        if best is None or pair.distance < best.distance:
            best = PassageWidth(pair, f, (face_a.role, face_b.role))
    if best is None:
        raise InputError(
            "no blade faces another across the passage",
            file=spec.source,
            field="camber",
            accepted="blades whose pressure side faces the next blade's suction side",
        )
    return best


def _project_on_ruled(
    ruled: BladeSurface, points: NDArray[np.float64], u: NDArray[Any], v: NDArray[Any]
) -> NDArray[np.float64]:
    """Closest-point distance of ``(n, 3)`` points to a ruled camber patch (Gauss-Newton).

    Starts at ``(u, v)``; each step solves the 2x2 normal equations of
    ``R(u, v) - X`` and clips to the patch [0, 1]^2.
    """
    u, v = np.array(u, dtype=np.float64), np.array(v, dtype=np.float64)
    for _ in range(_PROJECTION_STEPS):
        diff = ruled.camber(u, v) - points
        r_u, r_v = ruled.camber_derivatives(u, v)
        a11 = np.einsum("ij,ij->i", r_u, r_u)
        a12 = np.einsum("ij,ij->i", r_u, r_v)
        a22 = np.einsum("ij,ij->i", r_v, r_v)
        b1 = -np.einsum("ij,ij->i", r_u, diff)
        b2 = -np.einsum("ij,ij->i", r_v, diff)
        det = a11 * a22 - a12 * a12
        u_new = np.clip(u + (a22 * b1 - a12 * b2) / det, 0.0, 1.0)
        v_new = np.clip(v + (a11 * b2 - a12 * b1) / det, 0.0, 1.0)
        moved = max(float(np.abs(u_new - u).max()), float(np.abs(v_new - v).max()))
        u, v = u_new, v_new
        if moved < NEWTON_XTOL:
            break
    return np.asarray(np.linalg.norm(ruled.camber(u, v) - points, axis=1))


#: The projection above under a public name (any blade's camber patch; geometry.exchange).
project_on_camber = _project_on_ruled


def rule_deviation(
    surfaces: ImpellerSurfaces, grid: tuple[int, int] = DEVIATION_GRID
) -> tuple[float, NDArray[np.float64]]:
    """Largest distance of the camber surface from its ruled approximation.

    The ruled approximation is ``(1 - v) P(u) + v Q(u)`` through the same shroud and hub
    lines. Every point of a ``grid`` on the camber surface is projected onto it
    (Gauss-Newton), and the largest distance is refined by a bounded local maximisation
    over ``(u, v)`` (Nelder-Mead). Every blade has the same shape; main blade 0 is used.

    Returns
    -------
    (float, (2,) float64)
        The deviation in mm and the ``(u, v)`` where it is largest.
    """
    blade = surfaces.blades[0]
    ruled = BladeSurface(surfaces.shroud_curve, surfaces.hub_curve, blade.thickness, blade.angle)
    u, v = parameter_grid(grid[0], (0.0, 1.0), grid[1])

    def deviation(uv: NDArray[np.float64]) -> NDArray[np.float64]:
        uu, vv = np.atleast_1d(uv[0]), np.atleast_1d(uv[1])
        return _project_on_ruled(ruled, blade.camber(uu, vv), uu, vv)

    values = deviation(np.stack([u, v]))
    i = int(np.argmax(values))
    if values[i] <= DEFAULT_TOLERANCES.length:
        return float(values[i]), np.array([u[i], v[i]])
    fit = minimize(
        lambda x: -float(deviation(x)[0]),
        np.array([u[i], v[i]]),
        bounds=[(0.0, 1.0), (0.0, 1.0)],
        method="Nelder-Mead",
        options={"xatol": 1e-9, "fatol": 1e-12},
    )
    best = max(float(values[i]), -float(fit.fun))
    where = fit.x if -float(fit.fun) >= values[i] else np.array([u[i], v[i]])
    return best, np.asarray(where, dtype=np.float64)


def compute_figures(surfaces: ImpellerSurfaces, k: float = 1.2) -> GeometryFigures:
    """All derived figures of ``surfaces`` (see module docstring).

    Parameters
    ----------
    surfaces : ImpellerSurfaces
        The impeller's closed-form surfaces.
    k : float
        Protection factor of M4 eq. (1).

    Returns
    -------
    GeometryFigures
        d_min, r_max, thickness, rule deviation, largest fillet radius (mm).
    """
    spec = surfaces.spec
    width = minimum_passage_width(surfaces)
    hub_width = minimum_passage_width(surfaces, v_range=(1.0, 1.0))
    u = np.linspace(0.0, 1.0, 1001)
    spans = np.linalg.norm(surfaces.hub_curve(u) - surfaces.shroud_curve(u), axis=1)
    thickness = spec.thickness(np.concatenate([u, spec.thickness_u]))
    deviation, _ = rule_deviation(surfaces)
    return GeometryFigures(
        blades=len(surfaces.blades),
        splitters=len(surfaces.splitters),
        d_min=width.distance,
        d_min_points=width.pair.points,
        d_min_pair=width.label,
        r_max=max_ball_radius(width.distance, spec.finishing_allowance, k),
        k=k,
        finishing_allowance=spec.finishing_allowance,
        min_thickness=float(np.min(thickness)),
        rule_deviation=deviation,
        max_fillet_radius=float(min(0.5 * hub_width.distance, spans.min())),
    )


def _camber_gap(surfaces: ImpellerSurfaces) -> float:
    """Smallest distance between facing camber surfaces (blades of zero thickness), mm."""
    gaps = [math.inf]
    for f in facing_sides(surfaces):
        pair = closest_points(
            f.a.camber,
            f.b.camber,
            normal_a=_outward(f.a, f.side_a),
            normal_b=_outward(f.b, f.side_b),
        )
        gaps.append(math.inf if pair is None else pair.distance)
    return min(gaps)


def check_clearances(
    surfaces: ImpellerSurfaces,
    figures: GeometryFigures | None = None,
    *,
    tolerances: Tolerances = DEFAULT_TOLERANCES,
) -> GeometryFigures:
    """Raise ``InputError`` when neighbouring blades touch or the fillet cannot fit.

    Blades "touch" when d_min is not larger than ``tolerances.chordal`` (a gap below
    the machining tolerance cannot be cut). The error names the spec file, the
    thickness or fillet field, its value and a bound that would be accepted.

    Returns
    -------
    GeometryFigures
        The figures (computed when not given).
    """
    figures = compute_figures(surfaces) if figures is None else figures
    spec = surfaces.spec
    constant = len(set(spec.thickness_mm.tolist())) == 1
    if figures.d_min <= tolerances.chordal:
        gap = _camber_gap(surfaces)
        raise InputError(
            f"neighbouring blades touch ({figures.d_min_pair} gap {figures.d_min:.3f} mm near "
            f"{np.round(figures.d_min_points[0], 2).tolist()})",
            file=spec.source,
            field="blade.thickness_mm" if constant else "blade.thickness.mm",
            value=float(spec.thickness_mm[0]) if constant else spec.thickness_mm.tolist(),
            accepted=f"a thickness well below the {gap:.3f} mm between neighbouring camber "
            f"surfaces",
        )
    if spec.fillet_radius > figures.max_fillet_radius:
        raise InputError(
            "fillet larger than the passage allows",
            file=spec.source,
            field="blade.fillet_radius_mm",
            value=spec.fillet_radius,
            accepted=f"a radius <= {figures.max_fillet_radius:.3f} mm (half the passage "
            f"width at the hub, at most the blade height)",
        )
    return figures
