"""Options of the five-axis finishing (M3), one validated frozen dataclass.

Angles are degrees here (they are user options at the CLI boundary) and converted
to radians where they are used; lengths are mm.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any, Literal, get_args

from impeller_cam.errors import InputError
from impeller_cam.options import options_from_mapping
from impeller_cam.tolerances import DEFAULT_TOLERANCES

__all__ = ["BLADE_STRATEGIES", "FinishOptions", "scallop_stepover"]

#: How the blade sides are finished (``FinishOptions.blade_strategy``).
BladeStrategy = Literal["point", "swarf", "swarf_or_point"]
#: The accepted values of ``blade_strategy`` (the schema's enum).
BLADE_STRATEGIES: tuple[str, ...] = get_args(BladeStrategy)


def scallop_stepover(radius: float, scallop: float) -> float:
    """Stepover of a ball-end mill for a scallop height on a flat surface, mm.

    ``w = 2 sqrt(h (d - h))`` with ``d = 2 R`` the tool diameter and ``h`` the
    allowed scallop height (M4; exact for a plane: the two ball circles of radius R
    at distance w meet at height h above the surface).

    Parameters
    ----------
    radius : float
        Ball radius R, mm.
    scallop : float
        Allowed scallop height h, mm, ``0 < h < R``.

    Returns
    -------
    float
        Stepover w, mm.
    """
    if not 0.0 < scallop < radius:
        raise InputError("scallop height must be positive and below the ball radius",
                         field="scallop_mm", value=scallop,
                         accepted=f"0 < h < {radius:g} mm")
    return 2.0 * math.sqrt(scallop * (2.0 * radius - scallop))


@dataclass(frozen=True)
class FinishOptions:
    """Everything the finishing run can be told (defaults follow the papers).

    Attributes
    ----------
    point_spacing_mm : float
        Largest distance between consecutive cutter-centre points, mm.
    chordal_tolerance_mm : float or None
        Largest distance of the straight moves between consecutive ball centres
        from the ideal centre path, mm: each path's spacing is lowered below
        ``point_spacing_mm`` from its curvature (cam/finishing/spacing.py). None:
        the spacing is ``point_spacing_mm``.
    scallop_mm : float
        Allowed scallop height of the blade-side and hub passes, mm.
    allowance_mm : float
        Material the junction, blade and hub passes leave on the faces, mm: their
        ball centres run ``R + allowance_mm`` from the design (0: finishing; > 0: a
        semi-finish, e.g. the chain's rest operation, ``cam.run.rest``).
    rest_machining : bool
        Chain only (``cam.run.rest``): where finishing left postures out near verified
        rough stock more than ``rest_threshold_mm`` beyond the finishing allowance,
        semi-finish there and finish those passes again (false: finishing meets the
        rough stock as it is).
    rest_threshold_mm : float
        Chain only: rough-stock material beyond the finishing allowance that, near
        postures finishing left out, calls for the rest operation, mm.
    c_tilt_deg : float
        Initial rotation of the ruling axis about the C (impeller) axis away from
        the blade, deg (the paper: "about 1 ~ 2 degrees").
    min_normal_angle_deg : float
        Smallest angle between the tool axis and the contact normal, deg; below it
        the axis is leaned in the feed direction (the ball tip has no cutting speed).
    max_lead_deg, max_tilt_deg : float
        Limits of the lead (in the feed plane) and tilt (across it) of the axis
        from the hub contact normal, deg; violations are reported, never clamped.
    basis_functions : int
        Cubic B-spline basis functions of the least-squares smoothing (paper: 4).
    smoothing_scope : str
        ``"local"``: shift and smooth a window around each reversed range (seed 001),
        ``"path"``: the whole path at once (cam/finishing/reversals.py).
    phi_l_deg : float
        Smallest shift phi_L of a reversed increment, deg (the shift is at least
        the reversed increment itself, so the shifted curve moves one way).
    max_smoothing_iterations : int
        Shift-and-smooth rounds before the monotone least-squares fallback.
    reversal_deadband_deg : float
        Increments of A or C smaller than this do not count as movements, deg.
    linear_deadband_mm : float
        The same for X, Y, Z, mm.
    delta_c_deg : float
        Step dC of the interference remedy (eq. 7 procedure), deg.
    tilt_search_deg : float
        Largest tilt of the cone search that repairs postures the eq. 7 remedy
        cannot (cam/finishing/repair.py), deg; beyond ``repair.PREFERRED_TILT_DEG``
        (10) only for postures no smaller tilt repairs.
    tilt_search_step_deg : float
        Step of the cone angle in that search, deg.
    tilt_directions : int
        Tilt directions tried on each cone ring (the first: away from the wall).
    repair_margin_mm : float
        A repaired posture must clear the part by ``clearance_mm`` plus this, mm
        (room for the blend towards its neighbours).
    repair_blend_mm : float
        Least path length over which a repair is blended into the A and C curves, mm.
    repair_rounds : int
        Search-and-blend rounds before the remaining postures are reported.
    max_axis_turn_deg_per_mm : float
        Fastest turn of the tool axis along a hub pass, deg per mm of ball-centre path.
        A hub pass whose axis turns faster between two postures (it changes side,
        e.g. across the C axis where a small axis change is a large C change) is
        split there: the tool lifts, turns in the air and comes back
        (``posture.axis_breaks``, finish.json ``axis_breaks``). nine_blade's hub
        passes turn by at most 1.47 deg/mm (docs/finishing.md).
    axis_rate_smoothing_mm : float
        Width of the smoothing of A and C against the ball-centre path length after the
        repair (cam/finishing/axis_smoothing.py: the axis turns at a continuous rate;
        changed postures are checked again), mm; 0: off.
    cutter_allowance_mm : float
        The cutter is checked shrunk by this much against the faces a pass drives so
        that the ball may touch the surfaces it cuts (must exceed the scene tessellation
        error), mm; at most the verifier's gouge tolerance (``Tolerances.gouge``).
        0.035 leaves fillet postures out (the ball of the fillet's radius touches the
        tessellated fillet deeper). Against the other faces ``undriven_allowance_mm``:
        there the allowance only let the flutes cut (the splitter's outlet tip corners,
        0.052 mm gouges at 0.1 mm).
    undriven_allowance_mm : float
        The cutter is checked shrunk by this much (at most ``cutter_allowance_mm``)
        against the faces a pass does not drive: a blade pass's tip face and edges, the
        other walls (cam/finishing/driven.py; the splitter's outlet gouges), mm. At
        least the scene's tessellation error (the chordal deflection).
    clearance_mm : float
        Required clearance of shank and holder from the part, mm.
    stock_clearance_mm : float
        With an in-process stock (``run_finish(stock=...)``): clearance of shank and
        holder from the stock material farther than ``clearance_mm -
        stock_clearance_mm`` from the design (the rest is covered by ``clearance_mm``
        from the design), mm (cam/finishing/stock_clearance.py).
    stock_voxel_mm : float
        Voxel edge of the stock's collision mesh, mm (the clearance from it is
        conservative by at most a voxel diagonal).
    clearance_exact_mm : float
        Posture clearances up to this are exact (fcl distance); larger ones are
        reported as a guaranteed lower bound (at least this), which saves most
        distance queries. Must be at least ``clearance_mm``. The motion between
        postures is only compared with ``clearance_mm``: exact below that.
    motion_step_mm, motion_step_deg : float
        Subdivision of the motion between consecutive postures for the continuous
        collision check (bound reported in finish.json).
    retract_clearance_mm : float
        Links retract along the tool axis until the tip is this far outside the
        shroud envelope, mm.
    link_step_deg : float
        Largest rotation about the impeller axis between the points of a link that
        found no checked way (the post retracts around each step), deg.
    departure_mm : float
        Shortest departure from and approach to a pass at the cutting feed, mm
        (longer, up to 16 times, where the grown cutter is not yet clear;
        docs/finishing.md "Links").
    zigzag : bool
        Run every second pass of each passage backwards (cam/finishing/order.py).
    feed_link_mm : float
        Consecutive passes whose ends are at most this far apart are joined by one
        move at the cutting feed (the zig-zag stepover; checked as a cut, else linked
        as usual), mm; 0: never.
    passages : int or None
        Number of passages to machine (default all; the others are rotations).
    blade_passes, hub_passes : bool
        Generate the blade-side and hub passes (junction paths always).
    edge_passes : bool
        Generate the passes round the leading edge and a round trailing edge
        (``edge_paths``; operation ``edge``).
    tessellation_mm : float
        Tessellation of the collision meshes, mm.
    blade_strategy : str
        ``"point"``: the blade sides are point milled (the passes above);
        ``"swarf"``: flank milled along their rulings where the predicted deviation is
        within the swarf tolerances (operation ``swarf``, cam/finishing/swarf_plan.py),
        no blade point milling; ``"swarf_or_point"``: the same, and the blade passes
        not wholly inside the swarf-cut band are point milled.
    swarf_overcut_mm, swarf_undercut_mm : float
        Largest predicted overcut and undercut of a swarf-cut ruling, mm.
    swarf_ruling_step_mm : float
        Largest distance between consecutive swarf rulings at the blade tip, mm.
    """

    point_spacing_mm: float = 0.25
    chordal_tolerance_mm: float | None = None
    scallop_mm: float = 0.02
    allowance_mm: float = 0.0
    rest_machining: bool = True
    rest_threshold_mm: float = 1.0
    c_tilt_deg: float = 1.5
    min_normal_angle_deg: float = 5.0
    max_lead_deg: float = 45.0
    max_tilt_deg: float = 80.0
    basis_functions: int = 4
    smoothing_scope: str = "local"
    phi_l_deg: float = 0.01
    max_smoothing_iterations: int = 20
    reversal_deadband_deg: float = 1e-5
    linear_deadband_mm: float = 1e-5
    delta_c_deg: float = 1.0
    tilt_search_deg: float = 30.0
    tilt_search_step_deg: float = 1.0
    tilt_directions: int = 16
    repair_margin_mm: float = 0.05
    repair_blend_mm: float = 5.0
    repair_rounds: int = 6
    max_axis_turn_deg_per_mm: float = 5.0
    axis_rate_smoothing_mm: float = 3.0
    cutter_allowance_mm: float = 0.05
    undriven_allowance_mm: float = 0.02
    clearance_mm: float = DEFAULT_TOLERANCES.clearance
    stock_clearance_mm: float = DEFAULT_TOLERANCES.clearance
    stock_voxel_mm: float = 0.5
    clearance_exact_mm: float = 3.0
    motion_step_mm: float = 0.5
    motion_step_deg: float = 0.5
    retract_clearance_mm: float = 5.0
    link_step_deg: float = 5.0
    departure_mm: float = 1.0
    zigzag: bool = True
    feed_link_mm: float = 5.0
    passages: int | None = None
    blade_passes: bool = True
    hub_passes: bool = True
    edge_passes: bool = True
    tessellation_mm: float = DEFAULT_TOLERANCES.tessellation
    blade_strategy: BladeStrategy = "point"
    swarf_overcut_mm: float = 0.01
    swarf_undercut_mm: float = 0.03
    swarf_ruling_step_mm: float = 1.0

    def __post_init__(self) -> None:
        positive = ("point_spacing_mm", "scallop_mm", "min_normal_angle_deg", "max_lead_deg",
                    "max_tilt_deg", "phi_l_deg", "reversal_deadband_deg",
                    "linear_deadband_mm", "delta_c_deg", "tilt_search_deg",
                    "tilt_search_step_deg", "repair_blend_mm", "motion_step_mm",
                    "motion_step_deg", "retract_clearance_mm", "link_step_deg", "departure_mm",
                    "tessellation_mm", "stock_voxel_mm", "swarf_ruling_step_mm",
                    "max_axis_turn_deg_per_mm", "rest_threshold_mm")
        for name in positive:
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise InputError("must be a positive number", field=name, value=value,
                                 accepted="a finite number > 0")
        for name in ("c_tilt_deg", "cutter_allowance_mm", "undriven_allowance_mm",
                     "clearance_mm", "repair_margin_mm",
                     "feed_link_mm", "stock_clearance_mm", "swarf_overcut_mm",
                     "swarf_undercut_mm", "axis_rate_smoothing_mm", "allowance_mm"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value >= 0):
                raise InputError("must be a number >= 0", field=name, value=value,
                                 accepted="a finite number >= 0")
        if self.cutter_allowance_mm > DEFAULT_TOLERANCES.gouge:
            raise InputError("lets the planner accept postures the verification reports as "
                             "gouges", field="cutter_allowance_mm",
                             value=self.cutter_allowance_mm,
                             accepted=f"a number >= 0 and <= the gouge tolerance "
                                      f"{DEFAULT_TOLERANCES.gouge} mm")
        chordal = self.chordal_tolerance_mm
        if chordal is not None and not (isinstance(chordal, int | float)
                                        and not isinstance(chordal, bool)
                                        and math.isfinite(chordal) and chordal > 0):
            raise InputError("must be a positive number", field="chordal_tolerance_mm",
                             value=chordal, accepted="a finite number > 0 (mm) or none")
        if not self.clearance_exact_mm >= self.clearance_mm:
            raise InputError("must be at least clearance_mm", field="clearance_exact_mm",
                             value=self.clearance_exact_mm,
                             accepted=f">= {self.clearance_mm:g} mm")
        if not self.stock_clearance_mm <= self.clearance_mm:
            raise InputError("must be at most clearance_mm (the clearance from the design)",
                             field="stock_clearance_mm", value=self.stock_clearance_mm,
                             accepted=f"<= {self.clearance_mm:g} mm")
        if self.blade_strategy not in BLADE_STRATEGIES:
            raise InputError("unknown blade strategy", field="blade_strategy",
                             value=self.blade_strategy, accepted=", ".join(BLADE_STRATEGIES))
        if self.smoothing_scope not in ("local", "path"):
            raise InputError("unknown smoothing scope", field="smoothing_scope",
                             value=self.smoothing_scope, accepted="local, path")
        if not isinstance(self.basis_functions, int) or self.basis_functions < 4:
            raise InputError("a cubic B-spline needs at least 4 basis functions",
                             field="basis_functions", value=self.basis_functions,
                             accepted="an integer >= 4")
        if not isinstance(self.max_smoothing_iterations, int) or \
                self.max_smoothing_iterations < 1:
            raise InputError("must be a positive integer", field="max_smoothing_iterations",
                             value=self.max_smoothing_iterations, accepted="an integer >= 1")
        for name, least in (("tilt_directions", 1), ("repair_rounds", 0)):
            value = getattr(self, name)
            if not isinstance(value, int) or isinstance(value, bool) or value < least:
                raise InputError("must be an integer", field=name, value=value,
                                 accepted=f"an integer >= {least}")
        if self.passages is not None and (not isinstance(self.passages, int)
                                          or self.passages < 1):
            raise InputError("must be a positive integer", field="passages",
                             value=self.passages, accepted="an integer >= 1 or none (all)")

    @classmethod
    def from_mapping(cls, values: dict[str, Any]) -> FinishOptions:
        """Build from keyword options, naming an unknown key in an ``InputError``.

        Parameters
        ----------
        values : dict
            Field name -> value (a ``[machining.finish]`` table, CLI options).

        Returns
        -------
        FinishOptions
        """
        return options_from_mapping(cls, values, "finishing")

    def as_dict(self) -> dict[str, Any]:
        """The options as a JSON-ready dict (boundary units: mm, deg).

        Returns
        -------
        dict
        """
        return asdict(self)
