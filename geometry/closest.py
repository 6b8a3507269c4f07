"""Closest points of two parametric surfaces: grid search, then bounded damped Newton.

The local refinement the paper takes from Layegh et al. (M4, d_min): a coarse grid of
surface b in a k-d tree is queried with the grid of surface a, and the best distinct
candidates seed a projected (box-bounded) Levenberg-damped Newton minimisation of the
squared distance on the four surface parameters ``(u_a, v_a, u_b, v_b)``. Derivatives are
central differences of one vectorised surface call. Used by ``geometry.figures``
(passage width d_min, clearances).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

__all__ = [
    "PASSAGE_GRID",
    "PASSAGE_STARTS",
    "ClosestPair",
    "SampledSurface",
    "Surface",
    "closest_points",
    "grid_candidates",
    "parameter_grid",
    "refine_pair",
    "sample_grid",
]

#: Surface in parameters: ``f(u, v) -> (..., 3)`` points, mm (u, v broadcast).
Surface = Callable[[NDArray[np.float64], NDArray[np.float64]], NDArray[np.float64]]

#: Default coarse grid (nu, nv) of the passage-width search.
PASSAGE_GRID = (49, 13)
#: Local solves started from the best distinct grid candidates.
PASSAGE_STARTS = 4
#: Parameter step of the central differences in the local Newton solve.
_FD = 1e-4
_NEWTON_ITERATIONS = 60
#: Newton stops when no parameter moves more than this, or when the predicted decrease of
#: the squared distance is below this fraction of it.
NEWTON_XTOL = 1e-13
_NEWTON_FTOL = 1e-14

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


def parameter_grid(
    nu: int, v_range: tuple[float, float], nv: int
) -> tuple[NDArray[Any], NDArray[Any]]:
    """Flattened ``(nu * nv,)`` u and v of a grid on ``[0, 1] x v_range`` (u-major)."""
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
        if moved < NEWTON_XTOL:
            break
    return x


@dataclass(frozen=True)
class SampledSurface:
    """A surface sampled on its coarse search grid."""

    surface: Surface
    u: NDArray[np.float64]
    v: NDArray[np.float64]
    points: NDArray[np.float64]
    normals: NDArray[np.float64] | None
    rows: int
    spacing: float  # largest grid-cell diagonal, mm


def sample_grid(
    surface: Surface, normal: Surface | None, nu: int, nv: int, v_range: tuple[float, float]
) -> SampledSurface:
    """Sample ``surface`` (and its outward ``normal``, if given) on an ``nu x nv`` grid."""
    u, v = parameter_grid(nu, v_range, nv)
    points = np.asarray(surface(u, v))
    rows = len(u) // nu
    cells = points.reshape(nu, rows, 3)
    step_u = np.linalg.norm(np.diff(cells, axis=0), axis=-1).max()
    step_v = np.linalg.norm(np.diff(cells, axis=1), axis=-1).max() if rows > 1 else 0.0
    normals = None if normal is None else np.asarray(normal(u, v))
    return SampledSurface(surface, u, v, points, normals, rows, float(np.hypot(step_u, step_v)))


def grid_candidates(
    sa: SampledSurface, sb: SampledSurface
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


def refine_pair(
    sa: SampledSurface,
    sb: SampledSurface,
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
    sa = sample_grid(a, normal_a, grid[0], grid[1], v_range)
    sb = sample_grid(b, normal_b, (grid_b or grid)[0], grid[1], v_range)
    candidates = grid_candidates(sa, sb)
    return None if candidates is None else refine_pair(sa, sb, candidates, v_range, starts)
