"""Derived figures of an impeller: passage width d_min, r_max, rule deviation, clearances.

* ``d_min`` (M4): the shortest distance between the facing faces of adjacent blades
  (pressure side and edges of one, suction side and edges of the next, each blade its
  whole outline from ``geometry.outline``, no fillets; with splitters also main blade to
  splitter), and where it is. A coarse grid search (k-d tree) seeds a
  bounded damped Newton solve on the four surface parameters ``(u_a, v_a, u_b, v_b)``:
  the iterative refinement the paper takes from Layegh et al.
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
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import minimize
from scipy.spatial import cKDTree

from geometry.outline import OutlineSegment, blade_outline
from geometry.surfaces import PRESSURE, SUCTION, BladeSurface, ImpellerSurfaces
from impeller_cam.errors import InputError
from impeller_cam.tolerances import DEFAULT_TOLERANCES, Tolerances

__all__ = [
    "ClosestPair",
    "FacingSides",
    "GeometryFigures",
    "check_clearances",
    "closest_points",
    "compute_figures",
    "facing_sides",
    "max_ball_radius",
    "minimum_passage_width",
    "PassageWidth",
    "rule_deviation",
]

#: Surface in parameters: ``f(u, v) -> (..., 3)`` points, mm (u, v broadcast).
Surface = Callable[[NDArray[np.float64], NDArray[np.float64]], NDArray[np.float64]]

#: Default coarse grid (nu, nv) of the passage-width search.
PASSAGE_GRID = (49, 13)
#: Coarse grid points along an edge cap or face (p direction).
EDGE_GRID_U = 9
#: Local solves started from the best distinct grid candidates.
PASSAGE_STARTS = 4
#: Default grid of the rule-deviation search.
DEVIATION_GRID = (41, 11)
#: Parameter step of the central differences in the local Newton solve.
_FD = 1e-4
_NEWTON_ITERATIONS = 60
#: Newton stops when no parameter moves more than this, or when the predicted decrease of
#: the squared distance is below this fraction of it.
_NEWTON_XTOL = 1e-13
_NEWTON_FTOL = 1e-14
_PROJECTION_STEPS = 30


@dataclass(frozen=True)
class ClosestPair:
    """Closest points of two surfaces.

    Attributes
    ----------
    distance : float
        mm.
    points : (2, 3) float64
        The point on surface a, then on surface b.
    params : (2, 2) float64
        ``(u, v)`` of each point.
    """

    distance: float
    points: NDArray[np.float64]
    params: NDArray[np.float64]


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
        """JSON-ready dict, lengths in mm (keys carry the unit)."""
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


def _grid(nu: int, v_range: tuple[float, float], nv: int) -> tuple[NDArray[Any], NDArray[Any]]:
    if v_range[0] == v_range[1]:
        nv = 1
    u, v = np.meshgrid(np.linspace(0, 1, nu), np.linspace(*v_range, nv), indexing="ij")
    return u.reshape(-1), v.reshape(-1)


_Model = tuple[float, NDArray[np.float64], NDArray[np.float64]]
#: 3 x 3 stencil (in steps of ``_FD``) for a point, its gradient and Hessian in (u, v).
_STENCIL_U = np.array([0.0, 1.0, -1.0, 0.0, 0.0, 1.0, 1.0, -1.0, -1.0])
_STENCIL_V = np.array([0.0, 0.0, 0.0, 1.0, -1.0, 1.0, -1.0, 1.0, -1.0])


def _derivatives(
    f: Surface, u: float, v: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Point ``(3,)``, first ``(2, 3)`` and second ``(2, 2, 3)`` derivatives of ``f`` at
    ``(u, v)`` by central differences (one vectorised call)."""
    h = _FD
    p = np.asarray(f(u + h * _STENCIL_U, v + h * _STENCIL_V)).reshape(9, 3)
    first = np.stack([p[1] - p[2], p[3] - p[4]]) / (2 * h)
    uu, vv = (p[1] - 2 * p[0] + p[2]) / h**2, (p[3] - 2 * p[0] + p[4]) / h**2
    uv = (p[5] - p[6] - p[7] + p[8]) / (4 * h**2)
    return p[0], first, np.stack([np.stack([uu, uv]), np.stack([uv, vv])])


def _projected_newton(
    model: Callable[[NDArray[np.float64]], _Model],
    x: NDArray[np.float64],
    lower: NDArray[np.float64],
    upper: NDArray[np.float64],
) -> NDArray[np.float64]:
    """Minimise a smooth function on a box by damped Newton steps.

    Variables on a bound whose gradient points out of the box are held (active set);
    the others take a Levenberg-damped Newton step, clipped to the box, accepted only
    when the value decreases (so the result is never worse than the start).
    """
    f, g, hess = model(x)
    damping = 0.0
    for _ in range(_NEWTON_ITERATIONS):
        free = ~(((x <= lower) & (g > 0)) | ((x >= upper) & (g < 0)))
        if not free.any():
            break
        h_free, g_free = hess[np.ix_(free, free)], g[free]
        scale = max(float(np.abs(np.diag(h_free)).max()), 1e-300)
        trial = None
        for _ in range(40):
            try:
                step = np.linalg.solve(h_free + damping * scale * np.eye(len(g_free)), -g_free)
            except np.linalg.LinAlgError:
                step = None
            if step is not None and float(g_free @ step) < 0:
                if -float(g_free @ step) <= _NEWTON_FTOL * max(f, _NEWTON_FTOL):
                    return x  # converged: no significant decrease left
                candidate = x.copy()
                candidate[free] += step
                candidate = np.clip(candidate, lower, upper)
                result = model(candidate)
                if result[0] < f:
                    trial = candidate, result
                    break
            damping = max(10.0 * damping, 1e-12)
        if trial is None:
            break
        moved = float(np.abs(trial[0] - x).max())
        x, (f, g, hess) = trial
        damping *= 0.1 if damping > 1e-12 else 0.0
        if moved < _NEWTON_XTOL:
            break
    return x


@dataclass(frozen=True)
class _Sampled:
    """A surface sampled on its coarse search grid."""

    surface: Surface
    u: NDArray[np.float64]
    v: NDArray[np.float64]
    points: NDArray[np.float64]
    normals: NDArray[np.float64] | None
    rows: int
    spacing: float  # largest grid-cell diagonal, mm


def _sample(
    surface: Surface, normal: Surface | None, nu: int, nv: int, v_range: tuple[float, float]
) -> _Sampled:
    u, v = _grid(nu, v_range, nv)
    points = np.asarray(surface(u, v))
    rows = len(u) // nu
    cells = points.reshape(nu, rows, 3)
    step_u = np.linalg.norm(np.diff(cells, axis=0), axis=-1).max()
    step_v = np.linalg.norm(np.diff(cells, axis=1), axis=-1).max() if rows > 1 else 0.0
    normals = None if normal is None else np.asarray(normal(u, v))
    return _Sampled(surface, u, v, points, normals, rows, float(np.hypot(step_u, step_v)))


def _grid_candidates(
    sa: _Sampled, sb: _Sampled
) -> tuple[NDArray[np.float64], NDArray[np.intp]] | None:
    """Nearest b grid point of every a grid point (inf where the two do not face)."""
    dist, index = cKDTree(sb.points).query(sa.points)
    dist = np.asarray(dist, dtype=np.float64)
    if sa.normals is not None and sb.normals is not None:
        gap = sb.points[index] - sa.points
        facing = (np.einsum("ij,ij->i", gap, sa.normals) > 0) & (
            np.einsum("ij,ij->i", -gap, sb.normals[index]) > 0
        )
        if not np.any(facing):
            return None
        dist = np.where(facing, dist, np.inf)
    return dist, np.asarray(index)


def _refine(
    sa: _Sampled,
    sb: _Sampled,
    candidates: tuple[NDArray[np.float64], NDArray[np.intp]],
    v_range: tuple[float, float],
    starts: int,
) -> ClosestPair:
    """Damped Newton from the ``starts`` best distinct grid candidates; the best result."""
    dist, index = candidates
    rows = sa.rows
    chosen: list[int] = []
    for i in np.argsort(dist, kind="stable"):
        if not np.isfinite(dist[i]) or len(chosen) == starts:
            break
        iu, iv = divmod(int(i), rows)
        if all(abs(iu - c // rows) + abs(iv - c % rows) > 2 for c in chosen):
            chosen.append(int(i))
    a, b = sa.surface, sb.surface
    dims = [0, 1, 2, 3] if v_range[0] != v_range[1] else [0, 2]
    lower = np.array([0.0, v_range[0], 0.0, v_range[0]])[dims]
    upper = np.array([1.0, v_range[1], 1.0, v_range[1]])[dims]

    def full(x: NDArray[np.float64]) -> NDArray[np.float64]:
        out = np.full(4, v_range[0])
        out[dims] = x
        return out

    def model(x: NDArray[np.float64]) -> _Model:
        y = full(x)
        (pa, ja, ha), (pb, jb, hb) = _derivatives(a, y[0], y[1]), _derivatives(b, y[2], y[3])
        r = pa - pb
        jac = np.concatenate([ja, -jb])  # (4, 3): d r / d (u_a, v_a, u_b, v_b)
        hess = 2.0 * jac @ jac.T
        hess[:2, :2] += 2.0 * np.einsum("ijk,k->ij", ha, r)
        hess[2:, 2:] -= 2.0 * np.einsum("ijk,k->ij", hb, r)
        return float(r @ r), 2.0 * (jac @ r)[dims], hess[np.ix_(dims, dims)]

    best: ClosestPair | None = None
    for i in chosen:
        j = int(index[i])
        x0 = np.array([sa.u[i], sa.v[i], sb.u[j], sb.v[j]])[dims]
        y = full(_projected_newton(model, x0, lower, upper))
        points = np.stack([a(y[0:1], y[1:2]), b(y[2:3], y[3:4])]).reshape(2, 3)
        d = float(np.linalg.norm(points[1] - points[0]))
        if best is None or d < best.distance:
            best = ClosestPair(d, points, y.reshape(2, 2))
    assert best is not None  # candidates always hold a finite distance
    return best


def closest_points(
    a: Surface,
    b: Surface,
    *,
    normal_a: Surface | None = None,
    normal_b: Surface | None = None,
    v_range: tuple[float, float] = (0.0, 1.0),
    grid: tuple[int, int] = PASSAGE_GRID,
    grid_b: tuple[int, int] | None = None,
    starts: int = PASSAGE_STARTS,
) -> ClosestPair | None:
    """Closest points of two parametric surfaces over ``u in [0, 1]``, ``v in v_range``.

    Grid search (k-d tree of b's grid, queried with a's grid), then a bounded damped
    Newton minimisation of ``|a(u_a, v_a) - b(u_b, v_b)|^2`` from the ``starts`` best
    distinct candidates. With ``normal_a`` / ``normal_b`` (outward unit normals) only
    pairs that face each other (``(b - a) . n_a > 0`` and ``(a - b) . n_b > 0``) count,
    so a distance through a blade's own material is never taken for a passage width.
    A degenerate ``v_range`` (equal ends) restricts both surfaces to that v curve.
    ``grid`` is the (nu, nv) search grid of a, ``grid_b`` that of b (default: ``grid``).

    Returns
    -------
    ClosestPair or None
        None when normals are given and no grid pair faces each other.
    """
    sa = _sample(a, normal_a, grid[0], grid[1], v_range)
    sb = _sample(b, normal_b, (grid_b or grid)[0], grid[1], v_range)
    candidates = _grid_candidates(sa, sb)
    return None if candidates is None else _refine(sa, sb, candidates, v_range, starts)


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
    samples: dict[tuple[int, str], _Sampled] = {}

    def sampled(index: int, face: OutlineSegment) -> _Sampled:
        if (index, face.role) not in samples:
            nu = grid[0] if face.kind == "side" else EDGE_GRID_U
            samples[index, face.role] = _sample(face.point, face.normal, nu, grid[1], v_range)
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
                candidates = _grid_candidates(sa, sb)
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
        pair = _refine(sa, sb, candidates, v_range, PASSAGE_STARTS)
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
        if moved < _NEWTON_XTOL:
            break
    return np.asarray(np.linalg.norm(ruled.camber(u, v) - points, axis=1))


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
    u, v = _grid(grid[0], (0.0, 1.0), grid[1])

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
    k : float
        Protection factor of M4 eq. (1).
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
