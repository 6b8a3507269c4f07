"""What the finishing linker is told: the rules of its links and the passes it joins.

``LinkRules`` (feeds, clearances, allowances, the continuous checks' steps, the
clearance cylinder, the stepover and hub rules) and ``PassEnds`` (one pass in
machining order with its escape directions and end joints) are the inputs of
``cam.finishing.linking.Linker``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from cam.finishing.envelope import Envelope
    from cam.tools import Tool
    from geometry.revolved import RevolvedSurface

__all__ = ["LinkRules", "PassEnds"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class LinkRules:
    """How links are made and checked (mm, rad, mm/min).

    Attributes
    ----------
    tool : Tool
    feed : float
        Cutting feed; departures and approaches run at it, mm/min.
    departure : float
        Shortest departure and approach, mm.
    clearance : float
        Rapids keep the cutter (grown by it) and shank and holder this far from the
        part, mm; feed moves keep shank and holder this far (as the cuts do).
    cutter_allowance : float
        Departures, approaches and stepovers check the cutter shrunk by this much
        (as the cuts; ``FinishOptions.cutter_allowance_mm``), mm.
    step_mm, step_rad : float
        Subdivision of the continuous collision checks.
    envelope : Envelope
        Clearance cylinder of the clearance links and of the retract fallback.
    longest : float
        Longest retract along a tool axis, mm.
    turn_step : float
        Largest rotation about +Z between points of a fallback link, rad.
    feed_link : float
        Passes whose ends are at most this far apart are joined at feed (a zig-zag
        stepover, blended tangent to both passes where it is clear: ``stepover_blend``;
        checked as a cut), mm; 0: never.
    undriven_allowance : float or None
        Stepovers check the cutter shrunk by at most this much against the roles
        neither pass drives (``PassEnds.driven``), as the postures are
        (``cam.finishing.driven``), mm; None: every role at ``cutter_allowance``.
    hub : RevolvedSurface or None
        The closed-form hub: a stepover's ball may dip into it no deeper than
        ``stepover_blend.hub_dip_limit`` (``stepover_blend.hub_dip``); None: the mesh
        check only.
    """

    tool: Tool
    feed: float
    departure: float
    clearance: float
    cutter_allowance: float
    step_mm: float
    step_rad: float
    envelope: Envelope
    longest: float
    turn_step: float
    feed_link: float = 0.0
    undriven_allowance: float | None = None
    hub: RevolvedSurface | None = None


@dataclass(frozen=True)
class PassEnds:
    """One pass in machining order: postures, the escape directions at its ends.

    Attributes
    ----------
    name : str
    tip, axis : (n, 3) float64
        Postures in machining order (a zig-zag pass already reversed).
    escape_start, escape_end : (3,) float64
        Unit direction away from the surfaces the ball touches at the first and last
        posture (contact normal; at a junction the sum of hub and blade normals).
    joints_start, joints_end : (5,) float64
        Machine joints of the first and last posture (branch and winding reference).
    from_air : bool
        The pass goes on from the previous one past a turn of the tool axis too fast
        for a cut (``posture.axis_breaks``): it is entered from the air, never by a
        feed link.
    driven : tuple of str or None
        Scene roles the pass's ball is meant to touch (``driven.driven_roles``); None:
        not known (a stepover into or out of it checks every role alike).
    """

    name: str
    tip: Array
    axis: Array
    escape_start: Array
    escape_end: Array
    joints_start: Array
    joints_end: Array
    from_air: bool = False
    driven: tuple[str, ...] | None = None
