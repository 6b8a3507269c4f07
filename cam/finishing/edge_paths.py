"""Edge finishing: passes that wrap a blade edge from side to side, hub to tip.

The blade-side passes run along the side offset surfaces and stop at the edge; the
round leading edge (and a round trailing edge) between the two sides is left with
the roughing stock (nine_blade's main job: 69 % of the leading-edge samples reached,
up to 3.0 mm left). Each edge pass follows the blade's outline round the edge
(``geometry.outline.blade_loop``: the cap's three pieces, or a cut edge's corner,
face and corner) at one span parameter v, from ``OVERLAP_MM`` back on the suction
side to as far back on the pressure side (so the pass runs over the end of the side
passes), with the ball centre on the outline's offset ``X(p, v) + R n(p, v)``. The
outline is convex round the edge, so the offset ball touches it only at its contact;
between postures the centre moves on the chord, inside the offset, so the points are
at most ``sqrt(8 (R + d/2) chordal)`` apart (0.58 mm for R 3, d 2.5: the chordal
tolerance 0.01 mm).

Span levels: equal steps in v from the ball touching both the outline and the hub
(``geometry.fillet.rolling_ball`` with the tool radius: the junction ball continued
round the edge) up to the tip (v = 0), as many as the scallop stepover needs over the
longest span; the level touching the hub itself is left out (it gouged the small
fixture's leading-edge root in verification), and so is any level whose ball comes
closer than R + ``HUB_CLEARANCE_MM`` to the hub: the root is the fillet passes' part
(they wrap half of each edge from either side). Postures: the blade's ruling at the
edge leaned ``LEAN_DEG`` towards the local outline normal (``reference_axis``: the
flutes lean off the edge), turned about C like the junction paths;
the contact normal turns by about 180 deg along the pass and the axis stays normal to
it (the ball's side cuts). Only passage 0 is computed (its walls' blades); the
others are rotations.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from cam.finishing.fillet_paths import lean_away
from cam.finishing.paths import CutterPath, Wall, passage_walls
from geometry.fillet import rolling_ball
from geometry.outline import OutlineSegment, blade_loop, edge_break
from geometry.surfaces import ImpellerSurfaces
from impeller_cam.tolerances import DEFAULT_TOLERANCES

__all__ = ["EDGE_LEAN_DEG", "HUB_CLEARANCE_MM", "OVERLAP_MM", "SIDE_SHARE", "EdgeLevel",
           "edge_levels", "edge_loop_range", "edge_passes"]

Array = NDArray[np.float64]
#: How far the edge passes run back onto each side, mm.
OVERLAP_MM = 2.0
#: Least distance of an edge pass's ball from the hub, mm: the level touching the hub
#: (the junction ball continued round the edge) gouged the small fixture's leading-edge
#: root by 0.7 mm in verification; the fillet passes' ends cover the root instead.
HUB_CLEARANCE_MM = 0.1
#: Lean of the axis off the edge, deg (towards ``across``, see ``_edge_levels``).
EDGE_LEAN_DEG = 8.0
#: Weight of the contact normal in the lean direction ``edge outward + SIDE_SHARE n``.
SIDE_SHARE = 0.5
#: Coarse samples per outline segment before resampling.
_COARSE = 40
_FD = 1e-6


@dataclass(frozen=True)
class EdgeLevel:
    """One span level of an edge pass, before its lean is chosen.

    Attributes
    ----------
    path : CutterPath
        The pass at ``EDGE_LEAN_DEG`` (operation ``"edge"``).
    ruling : (n, 3) float64
        Unit outline v-tangents at the contacts, towards the shroud.
    across : (n, 3) float64
        Unit lean directions ``edge outward + SIDE_SHARE n`` (normal to nothing in
        particular; ``lean_away`` keeps their part normal to the ruling).
    """

    path: CutterPath
    ruling: Array
    across: Array

    def leaned(self, lean_deg: float) -> CutterPath:
        """The pass with the axis leaned ``lean_deg`` off the ruling towards ``across``."""
        return replace(self.path, reference_axis=lean_away(self.ruling, self.across,
                                                           math.radians(lean_deg)))


def _unit(a: Array) -> Array:
    return np.asarray(a / np.linalg.norm(a, axis=-1, keepdims=True))


def edge_loop_range(loop: list[OutlineSegment], blade_length: float, edge: str
                    ) -> tuple[float, float]:
    """Loop parameters ``(start, end)`` of a pass round ``edge``, suction to pressure.

    ``blade_loop``: ``[pressure, TE x3, suction (reversed), LE x3]``. Leading edge:
    from the suction side's end (L = 5) back ``OVERLAP_MM`` to the pressure side's
    start (L = 8 = 0) on; trailing edge: from the pressure side's end (L = 1),
    round to the suction side's start (L = 4), here run backwards (suction first).
    """
    back = OVERLAP_MM / blade_length
    if edge == "leading_edge":
        return 5.0 - back, 8.0 + back
    return 4.0 + back, 1.0 - back


def _evaluate(loop: list[OutlineSegment], lp: Array, v: Array, radius: float
              ) -> tuple[Array, Array, Array, Array]:
    """Ball centres, contact normals, blade u and rulings at loop parameters ``lp``."""
    count = len(loop)
    wrapped = np.mod(lp, count)
    segment = np.minimum(np.floor(wrapped).astype(np.intp), count - 1)
    p = np.clip(wrapped - segment, 0.0, 1.0)
    centre, normal, ruling = (np.zeros((len(lp), 3)) for _ in range(3))
    u = np.zeros(len(lp))
    for k in np.unique(segment):
        rows = np.flatnonzero(segment == k)
        seg = loop[int(k)]
        normal[rows] = seg.normal(p[rows], v[rows])
        centre[rows] = seg.point(p[rows], v[rows]) + radius * normal[rows]
        ruling[rows] = seg.point(p[rows], v[rows] - _FD) - seg.point(p[rows], v[rows] + _FD)
        u[rows] = seg.u_of(p[rows])
    return centre, normal, u, _unit(ruling)


def _lowest_v(loop: list[OutlineSegment], surfaces: ImpellerSurfaces, blade_u: Array,
              lp: Array, radius: float, depth_v: Array) -> Array:
    """Span parameter where the ball touches outline and hub, at each ``lp``."""
    count = len(loop)
    wrapped = np.mod(lp, count)
    segment = np.minimum(np.floor(wrapped).astype(np.intp), count - 1)
    p = np.clip(wrapped - segment, 0.0, 1.0)
    v = np.zeros(len(lp))
    for k in np.unique(segment):
        rows = np.flatnonzero(segment == k)
        v[rows] = rolling_ball(loop[int(k)], surfaces.hub, radius, p[rows], depth_v[rows]).v
    return v


def edge_passes(surfaces: ImpellerSurfaces, radius: float, stepover: float, spacing: float,
                passage: int = 0) -> list[CutterPath]:
    """``edge_levels``' passes at the default lean ``EDGE_LEAN_DEG``."""
    return [level.path for level in edge_levels(surfaces, radius, stepover, spacing, passage)]


def edge_levels(surfaces: ImpellerSurfaces, radius: float, stepover: float, spacing: float,
                passage: int = 0) -> list[EdgeLevel]:
    """Passes round the leading and trailing edges of passage 0's blades.

    Parameters
    ----------
    surfaces : ImpellerSurfaces
    radius : float
        Ball radius R, mm.
    stepover : float
        Largest step between span levels (along the ruling), mm.
    spacing : float
        Largest distance between consecutive ball centres, mm.

    Returns
    -------
    list of EdgeLevel
        Paths of operation ``"edge"``; per blade (blade 0, splitter 0: the other
        passages' rotations give the others) and edge, the span levels from the hub up
        (``<blade>.<edge>.<k>``). ``normal``: the outline's normal at the contact.
    """
    edges = ["leading_edge", "trailing_edge"]
    out: list[EdgeLevel] = []
    # the -theta wall of each pair: blade 0 (and splitter 0); the rotations give the rest
    for wall, opposite in passage_walls(surfaces):
        name = wall.label.split(".")[0]
        for edge in edges:
            out += _edge_levels(surfaces, wall, opposite, name, edge, radius, stepover,
                                spacing, passage)
    return out


def _edge_levels(surfaces: ImpellerSurfaces, wall: Wall, opposite: Wall, name: str,
                 edge: str, radius: float, stepover: float, spacing: float, passage: int
                 ) -> list[EdgeLevel]:
    blade = wall.blade
    loop = blade_loop(blade, surfaces.spec.leading_edge, surfaces.spec.trailing_edge)
    uu = np.linspace(0.0, 1.0, 41)
    camber = blade.camber(uu, 0.0)
    length = float(np.sum(np.linalg.norm(np.diff(camber, axis=0), axis=1)))
    start, end = edge_loop_range(loop, length, edge)
    depth = 2.0 * radius + float(np.max(blade.thickness(uu))) + 1.0

    def v_limit(u: Array) -> Array:
        span = np.linalg.norm(blade.camber(u, 1.0) - blade.camber(u, 0.0), axis=-1)
        return np.asarray(1.0 + depth / span)

    cuts = [start, *[float(k) for k in range(math.ceil(min(start, end)),
                                             math.floor(max(start, end)) + 1)
                     if min(start, end) < k < max(start, end)][::1 if end > start else -1], end]
    coarse = np.unique(np.concatenate([np.linspace(a, b, _COARSE)
                                       for a, b in zip(cuts[:-1], cuts[1:], strict=True)]))
    coarse = coarse if end > start else coarse[::-1]
    # the chord between postures round the edge (centre radius R + d/2) stays within
    # the chordal tolerance of the offset circle
    u_edge = 0.0 if edge == "leading_edge" else 1.0
    kind = surfaces.spec.leading_edge if edge == "leading_edge" else surfaces.spec.trailing_edge
    bend = radius + (0.5 * float(blade.thickness(u_edge)) if kind == "round"
                     else edge_break(blade, u_edge))
    spacing = min(spacing, math.sqrt(8.0 * bend * DEFAULT_TOLERANCES.chordal))
    _, _, u0, _ = _evaluate(loop, coarse, np.zeros_like(coarse), radius)
    low = _lowest_v(loop, surfaces, u0, coarse, radius, v_limit(u0))
    centre, _, _, _ = _evaluate(loop, coarse, low, radius)
    top, _, _, _ = _evaluate(loop, coarse, np.zeros_like(coarse), radius)
    step = np.maximum(np.linalg.norm(np.diff(centre, axis=0), axis=1),
                      np.linalg.norm(np.diff(top, axis=0), axis=1))
    arc = np.concatenate([[0.0], np.cumsum(step)])
    count = max(int(math.ceil(1.01 * arc[-1] / spacing)) + 1, 4)
    lp = np.interp(np.linspace(0.0, arc[-1], count), arc, coarse)
    _, _, u, _ = _evaluate(loop, lp, np.zeros_like(lp), radius)
    low = _lowest_v(loop, surfaces, u, lp, radius, v_limit(u))
    bottom, _, _, _ = _evaluate(loop, lp, low, radius)
    tip, _, _, _ = _evaluate(loop, lp, np.zeros_like(lp), radius)
    levels = max(int(math.ceil(float(np.linalg.norm(bottom - tip, axis=1).max()) / stepover)),
                 1)
    curve_u = wall.curve_u(u)
    middle = np.full(len(lp), 6.5 if edge == "leading_edge" else 2.5)
    out = []
    for k in range(1, levels + 1):
        v = low * (1.0 - k / levels)
        centre, normal, _, ruling = _evaluate(loop, lp, v, radius)
        if float(surfaces.hub.signed_distance(centre).min()) < radius + HUB_CLEARANCE_MM:
            continue
        _, outward, _, _ = _evaluate(loop, middle, v, radius)
        across = _unit(outward + SIDE_SHARE * normal)
        out.append(EdgeLevel(CutterPath(
            name=f"p{passage}.edge.{name}.{edge}.{k:02d}", operation="edge", passage=passage,
            centre=centre, normal=normal,
            reference_axis=lean_away(ruling, across, math.radians(EDGE_LEAN_DEG)),
            away=across, opposite_tip=opposite.tip_points(curve_u), curve_u=curve_u),
            ruling, across))
    return out
