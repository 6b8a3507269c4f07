"""How much of a fillet a set of ball postures leaves: samples on the fillet surface.

``fillet_samples`` places points on the rolling-ball fillet of one passage wall
(``fillet_grid`` arcs of its sections, leading- to trailing-edge tip, edges
included; moved onto the union of the rolling balls where the arcs fold, as the
solid's faces are: ``geometry.fillet.trim_fold``); ``material_left`` gives, per
sample, how far the surface lies outside the swept balls: ``min_j |x - q_j| - r``
over ball centres q_j densified along each pass (linear between postures, at most
``step`` apart). Zero or negative: the ball reached the point; positive: the
thickness (along the nearest ball's normal) of the material a pass left there.
Independent of the verification's dexels (used to judge the fillet passes on the
fillet alone, docs/finishing.md).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from cam.finishing.fillet_paths import fillet_section, wall_interval
from cam.finishing.paths import Wall
from geometry.fillet import rolling_ball, trim_fold
from geometry.outline import blade_loop
from geometry.surfaces import BladeSurface, ImpellerSurfaces

__all__ = ["densify", "edge_samples", "fillet_samples", "material_left"]

Array = NDArray[np.float64]


def fillet_samples(surfaces: ImpellerSurfaces, wall: Wall, along: int, across: int,
                   margin: float = 0.0) -> Array:
    """Points on the fillet of ``wall``'s blade between its two edge tips, ``(m, 3)``.

    Parameters
    ----------
    surfaces : ImpellerSurfaces
    wall : Wall
    along : int
        Sections from the leading-edge tip to the trailing-edge tip.
    across : int
        Points per section arc, blade contact to hub contact.
    margin : float
        Loop-parameter margin left out at both tips (0: up to the tips).
    """
    start, end = wall_interval(wall.side, 8)
    step = np.sign(end - start) * margin
    section = fillet_section(surfaces, wall,
                             np.linspace(start + step, end - step, along))
    radius = float(surfaces.spec.fillet_radius)
    angle = section.theta[:, None] * np.linspace(0.0, 1.0, across)[None, :]
    grid = section.centre[:, None, :] + radius * (
        np.cos(angle)[..., None] * section.e1[:, None, :]
        + np.sin(angle)[..., None] * section.e2[:, None, :])
    return np.asarray(trim_fold(grid, section.centre, radius).reshape(-1, 3))


def edge_samples(surfaces: ImpellerSurfaces, blade: BladeSurface, edge: str, radius: float,
                 along: int, across: int) -> Array:
    """Points on a blade edge's outline pieces above the ball-and-hub contact, ``(m, 3)``.

    ``along`` points over the edge's three pieces (suction to pressure side), ``across``
    span levels from the tip (v = 0) down to where a ball of ``radius`` touches the
    edge and the hub (below it lies the fillet, the fillet passes' part).
    """
    spec = surfaces.spec
    loop = blade_loop(blade, spec.leading_edge, spec.trailing_edge)
    pieces = loop[5:8] if edge == "leading_edge" else loop[1:4]
    p = np.linspace(0.0, 1.0, max(along // 3, 2))
    depth = 2.0 * radius + float(np.max(blade.thickness(np.linspace(0, 1, 11)))) + 1.0
    out = []
    for piece in pieces:
        u = piece.u_of(p)
        span = np.linalg.norm(blade.camber(u, 1.0) - blade.camber(u, 0.0), axis=-1)
        low = rolling_ball(piece, surfaces.hub, radius, p, 1.0 + depth / span).v
        v = low[:, None] * np.linspace(0.0, 1.0, across)[None, :]
        out.append(piece.point(np.repeat(p, across), v.ravel()))
    return np.asarray(np.concatenate(out))


def densify(centres: Array, step: float) -> Array:
    """Points on the polyline ``centres`` at most ``step`` apart (ends kept), ``(k, 3)``."""
    out = [centres[:1]]
    for a, b in zip(centres[:-1], centres[1:], strict=True):
        count = max(int(np.ceil(np.linalg.norm(b - a) / step)), 1)
        t = np.linspace(0.0, 1.0, count + 1)[1:, None]
        out.append(a + t * (b - a))
    return np.asarray(np.concatenate(out))


def material_left(samples: Array, passes: list[Array], radius: float,
                  step: float = 0.02) -> Array:
    """Material outside the swept balls at each sample, mm, ``(m,)``.

    Parameters
    ----------
    samples : (m, 3) float64
        Points on the surface, mm.
    passes : list of (n, 3) float64
        Ball centres of each pass (final postures: tip + r axis), mm.
    radius : float
        Ball radius r, mm.
    step : float
        Largest spacing of the densified centres, mm (the error of the result is at
        most ``step**2 / (8 r)``).
    """
    centres = np.concatenate([densify(p, step) for p in passes])
    distance, _ = cKDTree(centres).query(samples)
    return np.asarray(distance - radius)
