"""Blade points the edge passes already finish: the point passes' edge ends (issue 23).

With ``blade_strategy = "swarf_or_point"`` the blade point passes are cut to what the
swarf band leaves (``swarf_plan.point_passes_left``). The band stops short of the
edges, so every point pass kept a stub at each edge end: its last point and, for the
overlap, its neighbour (nine_blade, passage 0, scallop 0.01 mm: 488 of 780 pieces,
1.2-1.4 mm long, 69 s of the blade program's 452.7 s at exact stop). The edge passes
(``edge_paths``) run ``OVERLAP_MM`` back onto both sides at the same scallop
stepover, so those stubs cut again what they cut.

Passage 0's walls are blade 0's pressure side and blade 1's suction side; passage 0's
edge passes wrap blade 0, passage 1's blade 1. The blade passes of every passage are
passage 0's trims turned (``plan.plan_finishing``), so passage 0's trims may leave to
the edge passes what passage 0's edges finish and, when every passage is machined,
what the neighbours' do: passage 0's turned by a pitch (``edge_cover_turns``; in a
run of fewer passages the last one's second wall would find no edge passes there).

``EdgeCover`` says which blade points the *planned* edge passes (their final
postures, pieces cut short left out) finish to the scallop: the material the swept
edge balls leave at the point's contact ``x = c - R n`` (``c`` the blade pass's ball
centre, ``n`` the side's normal) is at most the scallop height, ``min_j |x - q_j| - R
<= scallop`` over the edge balls' centres ``q_j`` densified along each pass
(``fillet_cover.densify``: at most ``step`` apart, an error of at most ``step**2 /
(8 R)``). Those points are left to the edge passes; a point pass keeps the rest.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from cam.finishing.fillet_cover import densify

if TYPE_CHECKING:
    from cam.finishing.options import FinishOptions

__all__ = ["DENSIFY_MM", "EdgeCover", "edge_cover_turns"]

Array = NDArray[np.float64]
#: Largest spacing of the densified edge-ball centres, mm.
DENSIFY_MM = 0.02


class EdgeCover:
    """Which blade points a set of ball passes finishes to a scallop height.

    Parameters
    ----------
    passes : sequence of (n, 3) float64
        Ball centres of each pass (final postures, tip + R axis), mm.
    radius : float
        Ball radius R, mm.
    scallop : float
        Largest material height counted as finished, mm.
    step : float
        Spacing of the densified centres, mm.
    """

    def __init__(self, passes: Sequence[Array], radius: float, scallop: float,
                 step: float = DENSIFY_MM) -> None:
        self.radius = float(radius)
        self.scallop = float(scallop)
        centres = [densify(np.asarray(p, np.float64), step) for p in passes if len(p)]
        self.tree = cKDTree(np.concatenate(centres)) if centres else None

    def __call__(self, centre: Array, normal: Array) -> NDArray[np.bool_]:
        """``(k,)`` bool: the contact of a ball at ``centre`` on the surface of unit
        outward ``normal`` (both ``(k, 3)``, mm) is within the scallop of the passes."""
        contact = np.asarray(centre, np.float64) - self.radius * np.asarray(normal, np.float64)
        if self.tree is None:
            return np.zeros(len(contact), dtype=bool)
        reach = self.radius + self.scallop
        distance, _ = self.tree.query(contact, distance_upper_bound=2.0 * reach)
        return np.asarray(distance - self.radius <= self.scallop)


def edge_cover_turns(options: FinishOptions, blades: int) -> tuple[int, ...]:
    """Pitches by which passage 0's edge passes are turned to cover passage 0's walls:
    ``(-1, 0, 1)`` when every passage is machined (the neighbours' edges: one of them
    finishes passage 0's second wall at its edges), else ``(0,)``."""
    every = options.passages is None or options.passages >= blades
    return (-1, 0, 1) if every else (0,)
