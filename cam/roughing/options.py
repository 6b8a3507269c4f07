"""Roughing options (mm, deg at this boundary) with validation."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

from cam.roughing.layers import LAYERINGS
from impeller_cam.errors import InputError
from impeller_cam.options import options_from_mapping

__all__ = ["FEEDS", "PROGRAM_LAYOUTS", "RoughOptions"]

#: One program per operation (UMR visits as sections) or one per UMR visit.
PROGRAM_LAYOUTS = ("operation", "visit")

#: Feeds of the paper's Table 1, mm/min.
FEEDS = (500.0, 1000.0, 1500.0, 2000.0)


@dataclass(frozen=True)
class RoughOptions:
    """Options of ``run_rough`` / ``plan_roughing``.

    Attributes
    ----------
    scallop_mm : float
        Allowed scallop height h of the stepover ``w = 2 sqrt(h (d - h))``.
    max_depth_mm : float
        Largest cutting depth per layer (a_p); 0 means the tool radius.
    step_along_mm : float
        Spacing of the stations along the passage (CL point spacing along a pass).
    mesh_spacing_mm : float
        Grid spacing of the design meshes triangulated from the closed-form surfaces
        (``design = "surfaces"``).
    design : str
        Design meshes: ``"solid"`` (the B-rep impeller with fillets, default) or
        ``"surfaces"`` (closed-form surfaces, no fillets: faster, for tests).
    tessellation_mm : float
        Chordal tolerance of the solid's design mesh; the ball is grown by it (the
        triangles lie up to that much inside convex faces).
    reach_tolerance_mm : float
        A hub target counts as reached when the dropped ball stops at most this high
        above it (UMR partition).
    min_reach : float
        Share of a station's floor a UMR axis must reach for the station to join it.
    k : float
        Protection factor of eq. 1.
    clearance_mm : float
        Height of link rapids above the stock left so far (blank top or the floor of
        the layers above) and the design, along the link.
    entry_height_mm, entry_angle_deg : float
        Approach clearance: the rapid approach stops this far above the stock at a
        run's start, the entry (ramp or plunge at the plunge feed) cuts from there;
        ramp angle from the frame's horizontal (90 plunges).
    lift_mm : float
        Feed lift along the tool axis at the end of a run before the rapids.
    safe_distance_mm : float
        Retract before index moves: this far beyond the highest point of part and
        blank along the fixed axis.
    plunge_feed_ratio : float
        Plunge/ramp feed as a share of the cutting feed.
    direct_link_mm : float
        Consecutive cutting runs closer than this are joined by one cutting move
        (checked with the drop-cutter) instead of retract / rapid / entry.
    passages : int
        Passages to cut (0: all).
    layers_per_visit : int
        Order of the 3+2 cuts: every UMR cuts this many consecutive layers (from the
        shroud down) in every passage, then the next UMR takes its turn, until the
        hub layer; 0 cuts all layers of a UMR before the next one (UMR-major). The
        tilted shank of one UMR reaches over the neighbouring UMR's part of the
        passage, so that part must be cut down to about the same layer first
        (docs/roughing.md, "Cut order").
    program_layout : str
        ``"operation"``: one APT file (one NC program, one tool call) for the whole
        roughing operation, each UMR visit a section (``$$ OPERATION/``) of it;
        ``"visit"``: one file per UMR visit (the earlier layout).
    umr_layering, baseline_layering : str
        Cutting layers of the 3+2 plan and of the five-axis baseline: ``"depth"``
        (steps of the longest ruling's depth, at most a_p, down every ruling to the
        hub: the paper's three-axis layers "in terms of the milling depth a_p") or
        ``"ruling"`` (eq. 2: ``n1`` equal steps down every ruling, thinner on the
        short ones: the paper's five-axis layers). ``cam.roughing.layers``.
    """

    scallop_mm: float = 0.5
    max_depth_mm: float = 0.0
    step_along_mm: float = 1.0
    mesh_spacing_mm: float = 1.0
    reach_tolerance_mm: float = 1.0
    min_reach: float = 0.8
    k: float = 1.2
    clearance_mm: float = 2.0
    entry_height_mm: float = 1.0
    entry_angle_deg: float = 15.0
    safe_distance_mm: float = 10.0
    plunge_feed_ratio: float = 0.5
    direct_link_mm: float = 10.0
    passages: int = 0
    design: str = "solid"
    tessellation_mm: float = 0.05
    lift_mm: float = 1.0
    layers_per_visit: int = 1
    umr_layering: str = "depth"
    baseline_layering: str = "ruling"
    program_layout: str = "operation"

    def __post_init__(self) -> None:
        positive = ("scallop_mm", "step_along_mm", "mesh_spacing_mm", "reach_tolerance_mm",
                    "k", "clearance_mm", "entry_height_mm", "safe_distance_mm",
                    "plunge_feed_ratio", "direct_link_mm", "tessellation_mm", "lift_mm")
        for name in positive:
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise InputError("option must be a positive number", field=name, value=value,
                                 accepted="a finite number > 0")
        if not (math.isfinite(self.max_depth_mm) and self.max_depth_mm >= 0):
            raise InputError("milling depth must be >= 0", field="max_depth_mm",
                             value=self.max_depth_mm, accepted="0 (tool radius) or a depth > 0")
        if not 0.0 < self.min_reach <= 1.0:
            raise InputError("min_reach must lie in (0, 1]", field="min_reach",
                             value=self.min_reach, accepted="0 < min_reach <= 1")
        if not 0.0 < self.entry_angle_deg <= 90.0:
            raise InputError("entry angle must lie in (0, 90] deg", field="entry_angle_deg",
                             value=self.entry_angle_deg, accepted="0 < angle <= 90")
        if self.design not in ("solid", "surfaces"):
            raise InputError("unknown design mesh source", field="design", value=self.design,
                             accepted="solid, surfaces")
        for name in ("umr_layering", "baseline_layering"):
            if getattr(self, name) not in LAYERINGS:
                raise InputError("unknown layering", field=name, value=getattr(self, name),
                                 accepted=", ".join(LAYERINGS))
        if self.program_layout not in PROGRAM_LAYOUTS:
            raise InputError("unknown program layout", field="program_layout",
                             value=self.program_layout, accepted=", ".join(PROGRAM_LAYOUTS))
        if not (isinstance(self.layers_per_visit, int) and self.layers_per_visit >= 0):
            raise InputError("layers per visit must be a whole number >= 0",
                             field="layers_per_visit", value=self.layers_per_visit,
                             accepted="0 (all layers, UMR-major) or a count")
        if not (isinstance(self.passages, int) and self.passages >= 0):
            raise InputError("passages must be a whole number >= 0", field="passages",
                             value=self.passages, accepted="0 (all) or a count")

    @classmethod
    def from_mapping(cls, options: dict[str, Any]) -> RoughOptions:
        """Build from keyword options, refusing unknown names.

        Parameters
        ----------
        options : dict
            Field name -> value (a ``[machining.rough]`` table, CLI options).

        Returns
        -------
        RoughOptions

        Raises
        ------
        InputError
            An unknown name (with the nearest valid one), a wrong type, a bad range.
        """
        return options_from_mapping(cls, options, "roughing")

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready dict.

        Returns
        -------
        dict
            Field name -> value (mm, deg).
        """
        return asdict(self)
