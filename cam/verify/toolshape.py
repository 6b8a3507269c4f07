"""A tool as convex primitives of revolution, the shapes the dexel kernels sweep.

Every primitive lives in the tool frame (tip at the origin, axis +Z) and is one
quadric region clipped by a slab of heights ``zlo <= z <= zhi``:

* a **frustum** ``|rho| <= r0 + k (z - zlo)`` (a cylinder when ``k = 0``);
* a **sphere cap** ``|rho|^2 + (z - zc)^2 <= R^2``.

Both are written as one quadratic form ``Q(y) = |y_perp|^2 + alpha z^2 + beta z + gamma
<= 0`` (``y_perp``: the part of ``y`` normal to the axis), which is what
``cam.verify.kernels`` intersects with dexel rays. Each primitive is convex, so its
sweep along a straight move is convex and a dexel line meets it in one interval.

Shapes:

* ball end: the ball ``[0, 2R]`` (only its part below the flutes' side, ``[0, h_t]``,
  when the flutes are shorter than ``2R``) + the flutes' side ``[h_t, flute]``, a
  cylinder or, for tapered flutes (``Tool.flute_taper_deg``), the cone tangent to the
  ball at ``h_t = Tool.flank_start``: exact (the ball above ``h_t`` lies inside the
  side);
* flat end: cylinder (or cone) ``[0, flute]``: exact;
* bull-nose: the torus corner (up to the tangent of tapered flutes) is replaced by
  ``corner_segments`` frusta whose vertex radii are pushed out by half the chord
  sagitta, so the profile error is below the sagitta ``rc (1 - cos(pi / (4 n)))``
  (n = 8, rc = 2 mm: 0.0096 mm); the flat bottom and the side above are exact;
* shank and holder: the frusta of ``Tool.shank_segments()`` and ``Tool.holder``: exact.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cam.tools import Tool

#: Columns of a primitive row: alpha, beta, gamma, zlo, zhi, rmax.
PRIMITIVE_COLUMNS = ("alpha", "beta", "gamma", "zlo", "zhi", "rmax")
#: Frusta replacing a bull-nose corner.
CORNER_SEGMENTS = 8
#: Levels of cutter primitives swept along longer sub-moves (``ToolShape.cutter_level``).
LEVELS = 2
#: mm: a flute side is not split into a piece shorter than this.
MIN_LEVEL_PIECE = 0.5
#: Level bits of a move that sweeps the whole tool (``cam.verify.motion.ToolMoves.part``).
ALL_LEVELS = 0x7F


def frustum(z0: float, z1: float, r0: float, r1: float) -> NDArray[np.float64]:
    """Primitive row of a frustum: radius ``r0`` at height ``z0`` to ``r1`` at ``z1``.

    ``Q = |rho|^2 - (r0 + k (z - z0))^2`` with ``k = (r1 - r0) / (z1 - z0)``.
    """
    k = (r1 - r0) / (z1 - z0)
    c = r0 - k * z0  # radius = k z + c
    return np.array([-k * k, -2.0 * k * c, -c * c, z0, z1, max(r0, r1)])


def sphere_cap(zc: float, radius: float, zlo: float, zhi: float) -> NDArray[np.float64]:
    """Primitive row of a sphere of ``radius`` centred at height ``zc``, clipped to a slab."""
    return np.array([1.0, -2.0 * zc, zc * zc - radius * radius, zlo, zhi, radius])


@dataclass(frozen=True)
class ToolShape:
    """A tool split into cutting and non-cutting convex primitives.

    Attributes
    ----------
    cutter : (m, 6) float64
        Primitives that remove material (columns ``PRIMITIVE_COLUMNS``).
    body : (k, 6) float64
        Shank and holder primitives: checked against the stock, never cut.
    reach : float
        Largest distance of a cutter point from the tip, mm (bounds the error of
        a tilted axis, see ``cam.verify.motion``).
    body_reach : float
        The same for the whole tool including the holder, mm.
    profile_error : float
        Largest distance of the primitive outline from the true cutter outline, mm
        (0 for ball and flat end mills).
    cutter_level : (m,) int8
        Level of each cutter primitive: ``l > 0`` when it reaches no farther than
        ``reach / 2**l`` from the tip (the ball, the lower part of the flutes; a flute
        side is split at those heights), swept along sub-moves for that reach
        (``cam.verify.motion``); 0: along the sub-moves for ``reach``, with the body.
    level_reach : tuple of float
        Largest distance from the tip of a point of level ``l``'s primitives, mm, at
        index ``l - 1`` (0 when the level has none).
    """

    cutter: NDArray[np.float64]
    body: NDArray[np.float64]
    reach: float
    body_reach: float
    profile_error: float
    cutter_level: NDArray[np.int8] = field(default_factory=lambda: np.zeros(0, np.int8))
    level_reach: tuple[float, ...] = ()


def _radius(row: NDArray[np.float64], z: float) -> float:
    """Radius of a primitive at height ``z`` (0 outside it), mm."""
    alpha, beta, gamma = (float(v) for v in row[:3])
    return math.sqrt(max(-(alpha * z * z + beta * z + gamma), 0.0))


def _levelled(cutter: NDArray[np.float64], reach: float
              ) -> tuple[NDArray[np.float64], NDArray[np.int8]]:
    """The cutter's primitives with frusta split where their reach crosses
    ``reach / 2**l`` (``l = 1..LEVELS``), and the level of each: the largest ``l``
    with the piece within ``reach / 2**l`` of the tip (0: none)."""
    rows: list[NDArray[np.float64]] = []
    for row in cutter:
        zlo, zhi = float(row[3]), float(row[4])
        cuts = []
        if row[0] <= 0.0:  # a frustum: z^2 + r^2 is convex in z; split where it rises
            for lv in range(LEVELS, 0, -1):
                limit = reach / 2.0**lv
                a, b, c = 1.0 - row[0], -row[1], -(row[2] + limit * limit)
                disc = b * b - 4.0 * a * c
                if disc <= 0.0:
                    continue
                z = (-b + math.sqrt(disc)) / (2.0 * a)
                if zlo + MIN_LEVEL_PIECE < z < zhi - MIN_LEVEL_PIECE \
                        and math.hypot(zlo, _radius(row, zlo)) < limit:
                    cuts.append(z)
        ends = [zlo, *sorted(cuts), zhi]
        for z0, z1 in zip(ends[:-1], ends[1:], strict=True):
            piece = row.copy()
            if len(ends) > 2:
                piece[3], piece[4] = z0, z1
                piece[5] = max(_radius(row, z0), _radius(row, z1))
            rows.append(piece)
    levels = []
    for piece in rows:
        lv = 0
        while lv < LEVELS and primitive_reach(piece) <= reach / 2.0 ** (lv + 1):
            lv += 1
        levels.append(lv)
    return np.vstack(rows), np.array(levels, np.int8)


def merged_levels(cutter: NDArray[np.float64]) -> NDArray[np.float64]:
    """The cutter's primitives with the pieces ``tool_shape`` split a flute side into
    joined again (the same solid, fewer primitives: for moves of the whole tool)."""
    rows = [cutter[0].copy()] if len(cutter) else []
    for row in cutter[1:]:
        last = rows[-1]
        if np.array_equal(last[:3], row[:3]) and last[4] == row[3]:
            last[4], last[5] = row[4], max(last[5], row[5])
        else:
            rows.append(row.copy())
    return np.vstack(rows) if rows else np.zeros((0, 6))


def primitive_reach(row: NDArray[np.float64]) -> float:
    """Largest distance of a point of a primitive (a ``PRIMITIVE_COLUMNS`` row: sphere
    or frustum) from the tip, mm. ``z^2 + r(z)^2`` is linear in ``z`` on a sphere and
    convex on a frustum, so it is largest at one of the slab's ends."""
    alpha, beta, gamma, zlo, zhi = (float(v) for v in row[:5])
    return max(math.sqrt(max(z * z - (alpha * z * z + beta * z + gamma), z * z))
               for z in (zlo, zhi))


def _corner_frusta(radius: float, corner: float, segments: int, end: float = 0.5 * math.pi
                   ) -> tuple[list[Any], float]:
    """Frusta along a bull-nose corner arc (from the bottom to the angle ``end``, rad),
    vertices pushed out by half the sagitta."""
    inner = radius - corner
    angles = np.linspace(0.0, end, segments + 1)
    half_step = 0.5 * end / segments
    sagitta = corner * (1.0 - math.cos(half_step))
    grow = corner + 0.5 * sagitta
    rows = []
    for a0, a1 in zip(angles[:-1], angles[1:], strict=True):
        # profile point at angle a from the bottom: (inner + rc sin a, rc - rc cos a)
        r0 = inner + grow * math.sin(a0)
        r1 = inner + grow * math.sin(a1)
        z0 = corner - corner * math.cos(a0)
        z1 = corner - corner * math.cos(a1)
        rows.append(frustum(z0, z1, r0, r1))
    return rows, sagitta


def tool_shape(tool: Tool, corner_segments: int = CORNER_SEGMENTS) -> ToolShape:
    """Split a ``Tool`` into the convex primitives the dexel kernels sweep.

    Parameters
    ----------
    tool : Tool
        Cutter, shank and holder (lengths in mm).
    corner_segments : int
        Frusta replacing a bull-nose corner (ignored for ball and flat end mills).

    Returns
    -------
    ToolShape
        Spheres, frusta and cylinders along the tool axis (mm).
    """
    radius, corner, flute = tool.radius, tool.corner_radius, tool.flute_length
    start = tool.flank_start  # where the flutes' side (cylinder or cone) begins
    side = (float(tool.flank_radius_at(np.array(start))), tool.flute_top_radius)
    rows: list[NDArray[np.float64]] = []
    error = 0.0
    if tool.shape == "ball":
        # the whole ball when the flutes cover its upper half (the union with the
        # flutes' side is the same tool): its sweep is a capsule, a closed form
        top = 2.0 * radius if flute >= 2.0 * radius else start
        rows.append(sphere_cap(radius, radius, 0.0, top))
        if flute > start:
            rows.append(frustum(start, flute, *side))
    elif tool.shape == "flat" or corner <= 0.0:
        rows.append(frustum(0.0, flute, *side))
    else:
        corner_rows, error = _corner_frusta(radius, corner, corner_segments,
                                            0.5 * math.pi - tool.flute_half_angle)
        rows.extend(corner_rows)
        if flute > start:
            rows.append(frustum(start, flute, *side))
    body_rows = [
        frustum(seg.z0, seg.z1, seg.r0, seg.r1)
        for seg in (*tool.shank_segments(), *tool.holder)
        if seg.z1 > seg.z0
    ]
    cutter = np.vstack(rows)
    body = np.vstack(body_rows) if body_rows else np.zeros((0, 6))
    reach = math.hypot(flute, tool.flute_top_radius)
    top = tool.length
    widest = max([tool.flute_top_radius,
                  *(max(s.r0, s.r1) for s in (*tool.shank_segments(), *tool.holder))])
    cutter, level = _levelled(cutter, reach)
    level_reach = tuple(max((primitive_reach(row) for row in cutter[level == lv]), default=0.0)
                        for lv in range(1, LEVELS + 1))
    return ToolShape(cutter, body, reach, math.hypot(top, widest), error, level, level_reach)
