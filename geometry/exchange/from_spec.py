"""The product's spec -> what the exchange formats hold: section loops and mean lines.

Both writers sample the closed-form blade (:mod:`geometry.surfaces`) at the spec's
own camber points (the camber parameter u of each CSV point), so that an import
finds those points again and rebuilds the same splines:

* sections (BladeGen): per span, the pressure side at every camber point from the
  leading to the trailing edge, the trailing edge, the suction side back, the
  leading edge. A rounded edge adds ``CAP_POINTS`` points of its half-round cap
  (:func:`geometry.outline.blade_outline`), its apex in the middle; a cut edge is
  the straight segment between the two side ends (the solid's small edge breaks are
  a manufacturing detail and are not written);
* mean lines (CFturbo): the camber surface at the same points, and the spec's
  thickness law at its own knots.

Spans run from the hub (0) to the shroud (1): span ``s`` is the blade's ``v = 1 - s``.
A splitter is sampled at the camber points past its leading edge.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from geometry.camber import common_nodes
from geometry.outline import blade_outline
from geometry.spec import ImpellerSpec
from geometry.surfaces import BladeSurface, ImpellerSurfaces, build_surfaces

__all__ = ["CAP_POINTS", "blade_parameters", "mean_lines", "section_loops", "surfaces_of"]

Array = NDArray[np.float64]
#: Points written inside a rounded edge's cap (odd: the apex is one of them).
CAP_POINTS = 9
#: A splitter skips camber points closer than this (in u) to its leading edge.
_SPLITTER_GAP = 0.02


def surfaces_of(spec: ImpellerSpec) -> tuple[ImpellerSurfaces, list[BladeSurface]]:
    """The spec's surfaces and the blades of one set (main blade 0, then its splitter)."""
    surfaces = build_surfaces(spec)
    return surfaces, [surfaces.blades[0], *surfaces.splitters[:1]]


def blade_parameters(spec: ImpellerSpec, blade: BladeSurface) -> Array:
    """The blade's own u at the spec's camber points (a splitter: those past its start)."""
    lines = [spec.shroud_camber, spec.hub_camber]
    if spec.midspan_camber is not None:
        lines.append(spec.midspan_camber)
    nodes = common_nodes(lines)[0]
    if blade.u_start == 0.0:
        return np.asarray(nodes)
    start = blade.u_start
    rest = nodes[nodes > start + _SPLITTER_GAP]
    return np.concatenate([[0.0], (rest - start) / (1.0 - start)])


def section_loops(spec: ImpellerSpec, blade: BladeSurface, spans: Array) -> list[Array]:
    """Open section loops ``(n, 3)`` (cartesian mm) of ``blade`` at each span, hub first."""
    u = blade_parameters(spec, blade)
    outline = blade_outline(blade, "round", "round")
    cap = np.linspace(0.0, 1.0, CAP_POINTS + 2)[1:-1]
    loops = []
    for span in spans:
        v = np.full_like(u, 1.0 - span)
        vc = np.full_like(cap, 1.0 - span)
        parts = [blade.side(u, v, +1)]
        if spec.trailing_edge == "round":
            parts.append(outline[1].point(cap, vc))
        parts.append(blade.side(u[::-1], v, -1))
        if spec.leading_edge == "round":
            parts.append(outline[3].point(cap[::-1], vc))
        loops.append(np.vstack(parts))
    return loops


def mean_lines(spec: ImpellerSpec, blade: BladeSurface, spans: Array) -> list[Array]:
    """Camber points ``(n, 3)`` r, theta, z of ``blade`` at each span, hub first."""
    u = blade_parameters(spec, blade)
    out = []
    for span in spans:
        xyz = blade.camber(u, np.full_like(u, 1.0 - span))
        theta = np.unwrap(np.arctan2(xyz[:, 1], xyz[:, 0]))
        out.append(np.column_stack([np.hypot(xyz[:, 0], xyz[:, 1]), theta, xyz[:, 2]]))
    return out
