"""Broad phase, part 1: surface samples and the sphere covers of the tool parts.

**Surface samples.** Every point of every triangle lies within a *covering
radius* ``h`` of a sample: triangles whose longest edge ``L`` exceeds the sample
spacing ``e`` are split into ``k = ceil(L / e)`` similar sub-triangles per side
(a barycentric grid); any point of a triangle with longest edge ``l`` is within
``l / sqrt(3)`` of one of its corners, so ``h = max(l) / sqrt(3) <= e / sqrt(3)``.
The samples seed the distance grids (``distance_grid``).

**Sphere covers.** A tool part (a solid of revolution) is covered by spheres
centred on its axis: the axis range is cut into slabs; the part mesh inside a
slab lies within the sphere centred on the axis that encloses the slab's rings
(radius ``rho``). The slab height ``s = 2 sqrt(2 r slack + slack^2)`` (r the
largest part radius) keeps ``rho`` within about ``slack`` of the part radius.
The ball of a ball end mill is one slab, so its sphere is the ball itself.

**Inscribed balls.** Each sphere centre also gets the radius of the largest ball
around it inside the *true* part; a surface point closer than that is inside
the part mesh (used for definite hits, ``exact_phase``).

With a lower bound ``d_lo`` of the distance from a centre to the scene,
``d_lo - rho > 0`` for every sphere proves the part mesh clear of the scene.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

from cam.collision.distance_grid import DistanceGrid
from cam.collision.triangle_bvh import TriangleBVH

#: Grid nodes within this many grid spacings of the surface get exact distances.
EXACT_BAND = 6.0
#: The outer grid (``outer_grid``): spacing, margin beyond the surface and sample
#: spacing, mm. The margin covers a tool's reach from a tip near the surface (the
#: library's longest assemblies: about 150 mm).
OUTER_SPACING, OUTER_MARGIN, OUTER_SAMPLES = 4.0, 160.0, 2.0


def grid_frame(
    vertices: NDArray[np.float64], spacing: float, margin: float
) -> tuple[NDArray[np.float64], tuple[int, int, int]]:
    """Origin and shape of a grid covering ``vertices`` plus ``margin`` (mm)."""
    lo = vertices.min(axis=0) - margin
    hi = vertices.max(axis=0) + margin
    shape = np.ceil((hi - lo) / spacing).astype(np.int64) + 1
    return lo, (int(shape[0]), int(shape[1]), int(shape[2]))


def surface_grid(
    bvh: TriangleBVH,
    sample_spacing: float,
    origin: NDArray[np.float64],
    shape: tuple[int, int, int],
    spacing: float,
) -> DistanceGrid:
    """Distance grid of one mesh (its triangles in ``bvh``) on a given frame.

    The grid is that of ``DistanceGrid.from_samples`` on ``surface_samples`` of the
    triangles (the same nodes marked, the same bounding box, bit for bit), but the
    samples are marked as they are made (``_mark_samples``) instead of first being
    stored (millions of points for the large flat triangles of the back face).

    Parameters
    ----------
    bvh : TriangleBVH
        The mesh's triangles (exact distances in the band of ``EXACT_BAND`` grid
        spacings).
    sample_spacing : float
        Surface sample spacing for the distance transform, mm.
    origin, shape, spacing
        The grid frame (see ``grid_frame``).
    """
    tri = np.ascontiguousarray(bvh.tris, dtype=np.float64)
    levels, covering = _sample_levels(tri, sample_spacing)
    marked = np.ones(shape, dtype=bool)  # EDT measures the distance to False cells
    box = np.empty((2, 3))
    _mark_samples(tri, levels, np.asarray(origin, dtype=np.float64), float(spacing), marked,
                  box)
    return DistanceGrid.from_marked(marked, covering, origin, spacing, box[0], box[1],
                                    EXACT_BAND * spacing, bvh.distances)


def outer_grid(tris: NDArray[np.float64]) -> DistanceGrid:
    """A coarse distance grid of all ``(t, 3, 3)`` triangles reaching far beyond them.

    The scene's grids reach ``grid_margin`` (10 mm) beyond the scene; beyond that
    their bound is the distance to the scene's bounding box, which is loose around
    a conical impeller (a holder above the nose is 20 mm from the box, 40 mm from
    the part). This grid (``OUTER_SPACING``, ``OUTER_MARGIN``) gives a bound there
    (``DistanceGrid.part_bounds(..., outer=)``); exact distances in its band.
    """
    bvh = TriangleBVH(tris)
    origin, shape = grid_frame(tris.reshape(-1, 3), OUTER_SPACING, OUTER_MARGIN)
    return surface_grid(bvh, OUTER_SAMPLES, origin, shape, OUTER_SPACING)


def _sample_levels(tri: NDArray[np.float64], spacing: float
                   ) -> tuple[NDArray[np.int64], float]:
    """Per triangle ``(t, 3, 3)`` the split count ``k`` of ``surface_samples``, and the
    covering radius (mm)."""
    edges = np.linalg.norm(tri[:, [1, 2, 0]] - tri, axis=2)
    longest = edges.max(axis=1)
    k = np.maximum(1, np.ceil(longest / spacing - 1e-12)).astype(np.int64)
    covering = float((longest / k).max() / math.sqrt(3.0)) if len(k) else 0.0
    return k, covering


@numba.njit(cache=True, nogil=True)
def _mark_samples(
    tri: NDArray[np.float64],
    levels: NDArray[np.int64],
    origin: NDArray[np.float64],
    spacing: float,
    marked: NDArray[np.bool_],
    box: NDArray[np.float64],
) -> None:  # pragma: no cover - compiled
    """Clear ``marked`` at the node nearest to each sample of ``surface_samples``.

    The samples are the triangle corners and, for a triangle of level ``k > 1``,
    ``base + (i / k) (b - base) + (j / k) (c - base)``, ``i + j <= k``, evaluated in
    the same order as ``surface_samples`` (the same floating-point values).
    ``box`` gets the samples' ``(min, max)`` per axis, mm.
    """
    for a in range(3):
        box[0, a] = np.inf
        box[1, a] = -np.inf
    p = np.empty(3)
    for t in range(tri.shape[0]):
        level = levels[t]
        for c in range(3):
            _mark(tri[t, c, 0], tri[t, c, 1], tri[t, c, 2], origin, spacing, marked, box)
        if level <= 1:
            continue
        for i in range(level + 1):
            for j in range(level + 1 - i):
                fa = i / level
                fb = j / level
                for a in range(3):
                    base = tri[t, 0, a]
                    p[a] = (base + fa * (tri[t, 1, a] - base)) + fb * (tri[t, 2, a] - base)
                _mark(p[0], p[1], p[2], origin, spacing, marked, box)


@numba.njit(cache=True, nogil=True, inline="always")
def _mark(x: float, y: float, z: float, origin: NDArray[np.float64], spacing: float,
          marked: NDArray[np.bool_], box: NDArray[np.float64]) -> None:  # pragma: no cover
    q = (x, y, z)
    for a in range(3):
        box[0, a] = min(box[0, a], q[a])
        box[1, a] = max(box[1, a], q[a])
    i = int(np.rint((x - origin[0]) / spacing))
    j = int(np.rint((y - origin[1]) / spacing))
    k = int(np.rint((z - origin[2]) / spacing))
    marked[i, j, k] = False


def surface_samples(
    vertices: NDArray[np.float64], faces: NDArray[np.int64], spacing: float
) -> tuple[NDArray[np.float64], float]:
    """Sample a triangle surface to a covering radius of at most ``spacing / sqrt(3)``.

    Returns
    -------
    points : (m, 3) float64
        The mesh vertices plus barycentric grid points of the triangles longer
        than ``spacing``, mm.
    covering_radius : float
        ``max over (sub-)triangles of longest edge / sqrt(3)``, mm.
    """
    v = np.asarray(vertices, dtype=np.float64)
    tri = v[np.asarray(faces, dtype=np.int64)]
    edges = np.linalg.norm(tri[:, [1, 2, 0]] - tri, axis=2)
    longest = edges.max(axis=1)
    k = np.maximum(1, np.ceil(longest / spacing - 1e-12)).astype(np.int64)
    covering = float((longest / k).max() / math.sqrt(3.0)) if len(k) else 0.0
    points = [tri.reshape(-1, 3)]
    for level in np.unique(k[k > 1]):
        group = tri[k == level]
        i, j = np.meshgrid(np.arange(level + 1), np.arange(level + 1), indexing="ij")
        keep = (i + j) <= level
        a = (i[keep] / level)[None, :, None]
        b = (j[keep] / level)[None, :, None]
        base = group[:, None, 0]
        grid = base + a * (group[:, None, 1] - base) + b * (group[:, None, 2] - base)
        points.append(grid.reshape(-1, 3))
    return np.vstack(points), covering


def axis_spheres(
    profile: NDArray[np.float64], radial_scale: float, slack: float, whole_below: float = -math.inf
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Spheres on the tool axis that cover a revolved, circumscribed part mesh.

    The axis range is cut into equal slabs; the mesh inside a slab is the
    revolution of the profile clipped to the slab, whose extreme points are the
    rings through the clipped profile's vertices. The sphere of a slab is
    centred on the axis at the height that minimises its radius (a convex 1-D
    problem, solved by ternary search); its radius is computed exactly for that
    centre, so the cover holds whatever the search accuracy.

    Parameters
    ----------
    profile : (k, 2) float64
        Meridian polyline ``(r, z)`` of the part (axis to axis), mm.
    radial_scale : float
        Mesh vertex radius over profile radius (``sec(pi/N)``).
    slack : float
        Slab height is ``2 sqrt(2 r slack + slack^2)`` with r the largest part
        radius, so a slab's sphere exceeds its radius by about ``slack``, mm.
    whole_below : float
        Heights below this form one slab, mm (the ball of a ball end mill: its
        sphere is then the ball itself and is tight at the tip).

    Returns
    -------
    heights : (m,) float64
        Sphere centres as heights above the tip, mm.
    radii : (m,) float64
        Sphere radii, mm.
    """
    r = profile[:, 0] * radial_scale
    z = profile[:, 1]
    z_lo, z_hi = float(z.min()), float(z.max())
    height = 2.0 * math.sqrt(2.0 * float(r.max()) * slack + slack * slack)
    first: list[float] = []  # the ball (below its centre) as one slab
    if z_lo < whole_below < z_hi:
        first, z_lo = [z_lo], whole_below
    count_rest = max(1, math.ceil((z_hi - z_lo) / height - 1e-12))
    bounds = np.concatenate([first, np.linspace(z_lo, z_hi, count_rest + 1)])
    count = len(bounds) - 1
    ra, rb, za, zb = r[:-1], r[1:], z[:-1], z[1:]
    slope = np.abs(zb - za) > 1e-12
    centres = np.empty(count)
    radii = np.empty(count)
    for s in range(count):
        zl, zh = bounds[s], bounds[s + 1]
        pr = [r[(z >= zl) & (z <= zh)]]
        pz = [z[(z >= zl) & (z <= zh)]]
        for zc in (zl, zh):
            cross = slope & (np.minimum(za, zb) <= zc) & (np.maximum(za, zb) >= zc)
            t = (zc - za[cross]) / (zb[cross] - za[cross])
            pr.append(ra[cross] + t * (rb[cross] - ra[cross]))
            pz.append(np.full(int(cross.sum()), zc))
        rr, zz = np.concatenate(pr), np.concatenate(pz)
        lo, hi = float(zz.min()), float(zz.max())
        for _ in range(60):
            m1, m2 = lo + (hi - lo) / 3.0, hi - (hi - lo) / 3.0
            f1 = float(np.max(rr * rr + (zz - m1) ** 2))
            f2 = float(np.max(rr * rr + (zz - m2) ** 2))
            lo, hi = (lo, m2) if f1 <= f2 else (m1, hi)
        centres[s] = 0.5 * (lo + hi)
        radii[s] = math.sqrt(float(np.max(rr * rr + (zz - centres[s]) ** 2)))
    return centres, radii


def inscribed_radii(
    profile: NDArray[np.float64], heights: NDArray[np.float64], arc_excess: float
) -> NDArray[np.float64]:
    """Radii of balls centred on the axis that lie inside the true part.

    The ball of radius ``rho`` at axis height ``c`` lies in a solid of
    revolution iff the half-disc around ``(0, c)`` lies in its meridian region,
    i.e. ``rho <= distance((0, c), outline)``. The outline is the profile
    polygon (which circumscribes it by at most ``arc_excess``).

    Parameters
    ----------
    profile : (k, 2) float64
        Meridian polyline ``(r, z)``, axis to axis, mm.
    heights : (m,) float64
        Axis heights, mm.
    arc_excess : float
        Largest distance of the polygon outside the true outline, mm.

    Returns
    -------
    (m,) float64
        ``max(distance((0, c), polygon) - arc_excess, 0)``; 0 outside the part.
    """
    a, b = profile[:-1], profile[1:]
    ab = b - a
    length2 = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300)
    p = np.column_stack([np.zeros(len(heights)), heights])
    t = np.clip(np.einsum("mij,ij->mi", p[:, None, :] - a[None], ab) / length2, 0.0, 1.0)
    closest = a[None] + t[..., None] * ab[None]
    distance = np.linalg.norm(p[:, None, :] - closest, axis=2).min(axis=1)
    inside = (heights > profile[:, 1].min()) & (heights < profile[:, 1].max())
    return np.where(inside, np.maximum(distance - arc_excess, 0.0), 0.0)
