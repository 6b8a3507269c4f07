"""Stepovers at feed between zig-zag passes: one checked move, blended where it can be.

A zig-zag pass goes on into the next (reversed) pass by a move at the cutting feed
(``LinkRules.feed_link``). A straight stepover meets both passes at a sharp corner
(about 90 degrees each side): the control slows to nearly rest there and turns at its
axes' full acceleration, and where the axes' servo dynamics differ (a real machine's
do) the tip leaves the path in proportion to that acceleration (issue 26: the largest
predicted contour errors of the finishing programs sat at these corners). A CAM
system replaces the corner by a **blend** tangent to both passes:

* **Tip**: the cubic Bezier ``P0 = a_end``, ``P1 = P0 + h t_a``, ``P2 = P3 - h t_b``,
  ``P3 = b_start`` with ``t_a`` the direction pass ``a`` leaves in (its last chord) and
  ``t_b`` the direction pass ``b`` starts in (its first chord): tangent to both passes,
  a U-turn beyond the pass ends when the passes run opposite ways. The end curvature
  is ``2 |t_a x (P3 - P0 - h t_b)| / (3 h^2)`` (for a U-turn over a stepover ``c``,
  ``2 c / (3 h^2)``). The reach ``h`` is tried from the longest
  (``BLEND_REACHES`` times the stepover); the first blend whose checks pass is kept.
* **Tool axis**: the same cubic Bezier on the axes, normalised, its end derivatives
  matched to the passes' axis rates per mm of tip path (``A1 = A0 + h r_a``,
  ``A2 = A3 - h r_b``): on a table-tilting machine the linear joints carry the part's
  rotation (0.8 deg of C per mm of tip is ~1.4 mm of X/Y at 100 mm from the C axis),
  so a blend tangent at the tip but with the axis rate jumping to zero still has a
  joint-space corner at each end, where the control slows to 3 mm/s (measured on
  the main job's blade passes). Without rates (``rate0 = rate1 = None``): the great
  circle at the smoothstep ``3 s^2 - 2 s^3`` (the axis at rest at both ends).
* **Checks** (as the straight stepover): the rotary joints turn at most
  ``FEED_LINK_TURN`` over the move, and the whole move is free as a cut: the cutter
  shrunk by the cutting allowance ``LinkRules.cutter_allowance``
  (``FinishOptions.cutter_allowance_mm``) against the roles either pass drives and by
  at most ``LinkRules.undriven_allowance`` against the others, the rule the postures
  it joins were planned and the cut moves are checked with (``cam.finishing.driven``),
  shank and holder ``clearance`` away. A stepover is no stricter than its ends (a
  stricter one fails at its own first posture: with 0.01 mm, 351 of 367 stepovers
  between nine_blade's swarf_or_point blade pieces did, their flutes 0.01-0.05 mm into
  the blade mesh).
* **The ball's dip into the hub, exactly** (``hub_dip``): the cut postures are
  planned tangent to the closed-form surfaces, a stepover's chord is not: over a
  convex surface of radius R it dips about ``c^2 / (8 R)`` between its ends. Checked only
  against the scene mesh, a stepover may go ``cutter_allowance`` into the mesh and
  the mesh lies up to its tessellation (``tessellation_mm``) inside a convex face:
  0.05 + 0.02 mm into the part, past the verifier's gouge tolerance
  (``Tolerances.gouge``, 0.05 mm; the small chain's blended hub stepovers were
  verified 0.050-0.059 mm deep). Against the hub, a surface of revolution whose
  distance is exact in the meridional plane (``RevolvedSurface.closest_s``), the
  ball centre of the move sampled ``HUB_SAMPLE_MM`` apart must keep
  ``r - hub_dip_limit(r)`` from it, with ``hub_dip_limit = gouge - chordal -
  sweep - HUB_SAMPLE_MM^2 / (8 r)``: the post keeps the NC tip within the chordal
  tolerance (``Tolerances.chordal``, 0.01 mm) of the checked move, the verifier
  sweeps the NC motion within its sweep tolerance (a tenth of its 0.1 mm
  resolution: 0.01 mm), and between two samples ``h`` apart the centre's distance
  from a convex surface (offset radius at least ``r``) drops by at most
  ``h^2 / (8 r)``: 0.05 - 0.01 - 0.01 - 0.0006 = 0.029 mm for a 2 mm ball. The
  blade sides keep the mesh rule (docs/finishing.md, "One cutting allowance for
  stepovers, without gouges").

Where no blend passes, the straight stepover is checked as before; where that fails
too the passes are linked the usual way (departure, link, approach).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from impeller_cam.tolerances import DEFAULT_TOLERANCES
from postproc.kinematics.base import OverTravelError
from postproc.linearise import slerp
from postproc.pole import keeps_branch

if TYPE_CHECKING:
    from cam.finishing.linking import Linker, PassEnds
    from geometry.revolved import RevolvedSurface

__all__ = ["BLEND_POINTS", "BLEND_REACHES", "FEED_LINK_TURN", "HUB_SAMPLE_MM",
           "Stepover", "blend_curve", "feed_stepover", "hub_dip", "hub_dip_limit"]

Array = NDArray[np.float64]
#: Largest A or C turn of a stepover at feed between two passes, rad.
FEED_LINK_TURN = math.radians(10.0)
#: Tangent reaches of the blend tried, in units of the stepover chord (longest first:
#: the gentlest turn; a U-turn's end radius is ``1.5 h^2 / c``).
BLEND_REACHES = (1.5, 1.0, 0.5)
#: Moves a blend is made of (a U-turn: about 15 degrees of turn each).
BLEND_POINTS = 12
#: Spacing of the ball-centre samples of a stepover's exact check against the hub, mm.
HUB_SAMPLE_MM = 0.1
#: The verifier's sweep tolerance at its default 0.1 mm resolution (a tenth of it), mm.
VERIFY_SWEEP_MM = 0.1 * DEFAULT_TOLERANCES.simulation_resolution


@dataclass(frozen=True)
class Stepover:
    """The stepover at feed from one pass's last posture to the next pass's first.

    Attributes
    ----------
    tip, axis : (k, 3) float64
        Postures after ``a``'s last one, the last being ``b``'s first (k = 1: the
        straight stepover).
    reach : float
        Tangent reach ``h`` of the blend, mm (0: straight).
    """

    tip: Array
    axis: Array
    reach: float

    @property
    def blended(self) -> bool:
        """Whether the stepover is a tangent blend (not one straight move)."""
        return self.reach > 0.0


def _direction(p: PassEnds, at_end: bool) -> tuple[Array, Array] | None:
    """Unit direction of a pass's last (``at_end``) or first chord and its tool-axis
    change per mm (1/mm); None if the pass has no chord."""
    if len(p.tip) < 2:
        return None
    pair = slice(-2, None) if at_end else slice(0, 2)
    chord, turn = np.diff(p.tip[pair], axis=0)[0], np.diff(p.axis[pair], axis=0)[0]
    length = float(np.linalg.norm(chord))
    return None if length < 1e-9 else (np.asarray(chord / length), np.asarray(turn / length))


def blend_curve(start: Array, leave: Array, end: Array, enter: Array, axis0: Array,
                axis1: Array, reach: float, count: int = BLEND_POINTS,
                rate0: Array | None = None, rate1: Array | None = None
                ) -> tuple[Array, Array]:
    """The blend's postures: cubic Bezier tip tangent to both passes, axis slerped.

    Parameters
    ----------
    start, end : (3,) float64
        Last tip of the pass left and first tip of the pass entered, mm.
    leave, enter : (3,) float64
        Unit directions the first pass leaves in and the second starts in.
    axis0, axis1 : (3,) float64
        Unit tool axes at ``start`` and ``end``.
    reach : float
        Tangent reach ``h``, mm.
    count : int
        Number of moves.
    rate0, rate1 : (3,) float64, optional
        Tool-axis change per mm of tip path of the pass left (at its end) and of the
        pass entered (at its start), 1/mm: the axis follows a Bezier matching them.

    Returns
    -------
    tip, axis : (count, 3) float64
        Postures at ``s = 1/count .. 1`` (``start`` excluded, ``end`` last).
    """
    s = np.linspace(0.0, 1.0, count + 1)[1:, None]
    p1, p2 = start + reach * leave, end - reach * enter
    tip = ((1 - s) ** 3 * start + 3 * (1 - s) ** 2 * s * p1 + 3 * (1 - s) * s ** 2 * p2
           + s ** 3 * end)
    if rate0 is not None and rate1 is not None:
        a1, a2 = axis0 + reach * rate0, axis1 - reach * rate1
        axis = ((1 - s) ** 3 * axis0 + 3 * (1 - s) ** 2 * s * a1
                + 3 * (1 - s) * s ** 2 * a2 + s ** 3 * axis1)
        axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    else:
        ease = (3.0 * s ** 2 - 2.0 * s ** 3)[:, 0]
        axis = slerp(np.tile(axis0, (count, 1)), np.tile(axis1, (count, 1)), ease)
    tip[-1] = end
    axis[-1] = axis1
    return np.asarray(tip), np.asarray(axis)


def hub_dip_limit(radius: float) -> float:
    """Deepest a stepover's ball may reach into the closed-form hub, mm (module doc).

    ``gouge - chordal - sweep - HUB_SAMPLE_MM**2 / (8 radius)``: the verifier's gouge
    tolerance less the post's chordal tolerance, the verifier's sweep tolerance and
    what the ball centre can approach a convex surface between two samples.

    Parameters
    ----------
    radius : float
        Ball radius, mm (> 0).
    """
    t = DEFAULT_TOLERANCES
    return t.gouge - t.chordal - VERIFY_SWEEP_MM - HUB_SAMPLE_MM ** 2 / (8.0 * radius)


def hub_dip(hub: RevolvedSurface, tip: Array, axis: Array, radius: float,
            step_rad: float) -> float:
    """Deepest the ball reaches into the closed-form hub over a move, mm.

    The move goes through the postures tip-linearly with the axis on the great circle
    (as ``check_motion`` checks it), sampled ``HUB_SAMPLE_MM`` and ``step_rad`` apart.
    Only samples whose ball centre has its foot inside the hub contour count (its
    distance is then exact); beyond the inlet and the rim the part's other faces are
    the mesh check's.

    Parameters
    ----------
    hub : RevolvedSurface
        The hub (normal towards the passage).
    tip, axis : (n, 3) float64
        Postures, n >= 2 (mm; unit axes).
    radius : float
        Ball radius, mm: its centre is ``tip + radius * axis``.
    step_rad : float
        Largest axis turn between samples, rad.

    Returns
    -------
    float
        ``radius`` less the smallest distance of a counted centre from the hub, mm
        (negative: clear by that much; ``-inf``: no sample counted).
    """
    from cam.collision.postures import subdivide_motion

    sub_tip, sub_axis, _ = subdivide_motion(tip, axis, HUB_SAMPLE_MM, step_rad)
    centre = sub_tip + radius * sub_axis
    z, r = centre[:, 2], np.hypot(centre[:, 0], centre[:, 1])
    s = hub.closest_s(z, r)
    inside = (s > 0.0) & (s < 1.0)
    if not inside.any():
        return -math.inf
    foot, normal = hub.meridian(s[inside]), hub.meridian_normal(s[inside])
    distance = ((z[inside] - foot[:, 0]) * normal[:, 0]
                + (r[inside] - foot[:, 1]) * normal[:, 1])
    return float(radius - distance.min())


def _hub_clear(linker: Linker, tip: Array, axis: Array) -> bool:
    """Whether a move's ball stays within ``hub_dip_limit`` of the closed-form hub
    (``LinkRules.hub``; True without one or for a tool without a ball)."""
    r = linker.rules
    radius = float(r.tool.corner_radius)
    if r.hub is None or not radius > 0.0:
        return True
    return hub_dip(r.hub, tip, axis, radius, r.step_rad) <= hub_dip_limit(radius)


def _turn_ok(linker: Linker, a: PassEnds, tips: Array, axes: Array) -> bool:
    """The rotary joints stay within ``FEED_LINK_TURN`` of ``a``'s last over the move
    (and inside the machine's travel: a blend whose axis swings past a rotary limit is
    not a candidate)."""
    moving = np.ones(len(tips), bool)
    moving[0] = False
    keep = keeps_branch(axes, moving, DEFAULT_TOLERANCES.angular)
    try:
        q = linker.kins.inverse(tips, axes, previous=a.joints_end,
                                keep_branch=keep if keep.any() else None)
    except OverTravelError:
        return False
    return float(np.abs(q[1:, 3:] - q[0, 3:]).max()) <= FEED_LINK_TURN


def feed_stepover(linker: Linker, a: PassEnds, b: PassEnds) -> Stepover | None:
    """The stepover at feed from pass ``a`` into pass ``b``, or None (module doc).

    Parameters
    ----------
    linker : Linker
        Its kinematics, collision scene and rules (``feed_link``, the cutting
        allowance ``cutter_allowance``) check the move.
    a, b : PassEnds
        The pass left and the pass entered.

    Returns
    -------
    Stepover or None
        None when the ends are further apart than ``feed_link`` or neither a blend nor
        the straight move passes the checks.
    """
    r = linker.rules
    start, end = a.tip[-1], b.tip[0]
    chord = float(np.linalg.norm(end - start))
    if not 0.0 < chord <= r.feed_link:
        return None
    driven = (None if a.driven is None or b.driven is None
              else tuple(dict.fromkeys((*a.driven, *b.driven))))
    leave, enter = _direction(a, True), _direction(b, False)
    candidates: list[tuple[Array, Array, float]] = []
    if leave is not None and enter is not None:
        for scale in BLEND_REACHES:
            tip, axis = blend_curve(start, leave[0], end, enter[0], a.axis[-1], b.axis[0],
                                    scale * chord, rate0=leave[1], rate1=enter[1])
            candidates.append((tip, axis, scale * chord))
    candidates.append((end[None], b.axis[:1], 0.0))
    for tip, axis, reach in candidates:
        tips = np.vstack([start[None], tip])
        axes = np.vstack([a.axis[-1][None], axis])
        if (_turn_ok(linker, a, tips, axes) and _hub_clear(linker, tips, axes)
                and linker.feed_free(tips, axes, driven=driven)):
            return Stepover(tip=np.asarray(tip, dtype=np.float64),
                            axis=np.asarray(axis, dtype=np.float64), reach=reach)
    return None
