"""Tangent approaches and departures: a pass entered and left along its own tangent.

``Linker.escape`` finds the shortest clear point ``E = tip + L d`` a pass is entered
from and left to (``d`` along the tool axis, the contact normal or between): a
straight move from ``E`` meets the pass at about 90 degrees, a corner the control
takes at nearly rest and at its axes' full acceleration, on the part (issue 26: after
the stepovers, the largest predicted contour errors on the part sat at these
lead-ins). A CAM system enters along the pass's tangent instead, on a quarter arc:

* **Departure**: from the pass's last tip along its last chord ``t``, a quarter turn
  of radius ``R`` in the plane of ``t`` and ``d`` to the point ``O = tip + R s + R d``
  (``s``: ``t`` made normal to ``d``), arriving along ``d``; the cubic Bezier with
  the circle's control points (``P1 = tip + k R t``, ``P2 = O - k R d``,
  ``k = 4 (sqrt 2 - 1) / 3``), so its curvature is ``1 / R`` within 0.03 %.
* **Approach**: the departure of the reversed pass, run backwards (from ``O`` behind
  the pass's first tip down onto it along its first chord).

``R`` is ``L`` (the escape's length), else ``L / 2``; the first whose point ``O`` keeps
the rapid clearance (as the escape's points) and whose arc is free as a cut (the
cutter shrunk by the rules' allowance, shank and holder ``clearance`` away) replaces
the escape point: the link then ends (or starts) at ``O``. The tool axis is the
pass's end axis at the outer point ``O``, as on the straight move; along the arc it
carries the pass's axis rate out of the pass (``blend_curve`` with ``rate0`` the pass's
tool-axis change per mm of tip at that end, ``rate1`` zero, both ends the pass's end
axis). On a table-tilting machine the linear joints carry the part's rotation, so an
arc whose axis stops turning where it meets the pass leaves a joint-space corner
there, a corner the control rounds although the tip path is tangent (issue 26: 46-64
um of predicted contour error on the first blocks of finish_edge's departures, 24 um
from the blade, about 20 um of it into the part). The axis swings out by at most
``4 h |rate| / 9`` (``h`` the arc's Bezier reach) and back. Where neither arc is
clear, the straight move is kept.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from cam.finishing.stepover_blend import blend_curve

if TYPE_CHECKING:
    from collections.abc import Sequence

    from cam.finishing.linking import Linker, PassEnds
    from cam.finishing.stepover_blend import Stepover

__all__ = ["LEAD_POINTS", "LEAD_REACHES", "Lead", "tangent_approach", "tangent_departure",
           "tangent_leads"]

Array = NDArray[np.float64]
#: A lead's postures: tips and unit tool axes, (LEAD_POINTS, 3) each.
Lead = tuple[Array, Array]
#: Moves an approach or departure arc is made of (a quarter turn: ~11 degrees each).
LEAD_POINTS = 8
#: Arc radii tried, in units of the escape's length.
LEAD_REACHES = (1.0, 0.5)
#: Control-point distance of a cubic Bezier quarter circle, in radii.
QUARTER = 4.0 * (math.sqrt(2.0) - 1.0) / 3.0


def _unit(v: Array) -> Array | None:
    length = float(np.linalg.norm(v))
    return None if length < 1e-9 else np.asarray(v / length)


def _leaving(tip: Array, axis: Array) -> tuple[Array, Array] | None:
    """Direction of the chord from ``tip[1]`` to ``tip[0]`` and the tool axis's change
    per mm along it (1/mm): how a pass leaves its posture 0; None for a zero chord."""
    chord = tip[0] - tip[1]
    length = float(np.linalg.norm(chord))
    if length < 1e-9:
        return None
    return np.asarray(chord / length), np.asarray((axis[0] - axis[1]) / length)


def _arc(linker: Linker, tip: Array, along: Array, axis: Array, rate: Array,
         escape: Array) -> tuple[Array, Array, Array] | None:
    """The first clear quarter arc from ``tip`` (leaving along ``along``, the tool axis
    turning at ``rate`` per mm of tip) turning to the escape direction: its end point
    ``O``, its tips and tool axes (``O`` last, with ``axis`` again), or None."""
    d = _unit(escape - tip)
    if d is None:
        return None
    side = _unit(along - float(along @ d) * d)
    if side is None:
        return None
    length = float(np.linalg.norm(escape - tip))
    r = linker.rules
    for scale in LEAD_REACHES:
        radius = scale * length
        outer = tip + radius * (side + d)
        report = linker.scene.check_postures(r.tool, outer[None], axis[None],
                                             cutter_allowance=-r.clearance,
                                             clearance_cap=r.clearance)
        if bool(report.blocked(r.clearance)[0]):
            continue
        arc, axes = blend_curve(tip, along, outer, d, axis, axis, QUARTER * radius,
                                LEAD_POINTS, rate0=rate, rate1=np.zeros(3))
        path = np.vstack([tip[None], arc])
        if linker.feed_free(path, np.vstack([axis[None], axes])):
            return outer, arc, axes
    return None


def tangent_approach(linker: Linker, p: PassEnds, entry: Array
                     ) -> tuple[Array, Array, Array] | None:
    """The tangent approach into pass ``p`` instead of the straight one from ``entry``.

    Parameters
    ----------
    linker : Linker
        Collision scene and rules of the checks.
    p : PassEnds
        The pass entered (at least two postures).
    entry : (3,) float64
        ``Linker.escape``'s point of the straight approach, mm.

    Returns
    -------
    start : (3,) float64
        The arc's outer point: the link ends there.
    tips, axes : (LEAD_POINTS, 3) float64
        The arc's tips and unit tool axes after ``start``, the pass's first posture
        last.
    None
        The pass is too short or no arc is clear (keep the straight move).
    """
    if len(p.tip) < 2:
        return None
    leave = _leaving(p.tip, p.axis)  # backwards: the arc is built as a departure
    found = None if leave is None else _arc(linker, p.tip[0], leave[0], p.axis[0],
                                            leave[1], entry)
    if found is None:
        return None
    outer, arc, axes = found
    return outer, np.vstack([arc[-2::-1], p.tip[:1]]), np.vstack([axes[-2::-1], p.axis[:1]])


def tangent_departure(linker: Linker, p: PassEnds, exit_point: Array
                      ) -> tuple[Array, Array, Array] | None:
    """The tangent departure from pass ``p`` instead of the straight one to
    ``exit_point``: the arc's outer point (the link starts there) and its tips and
    tool axes after the pass's last posture, the outer point last; None as
    ``tangent_approach``."""
    if len(p.tip) < 2:
        return None
    leave = _leaving(p.tip[:-3:-1], p.axis[:-3:-1])
    return None if leave is None else _arc(linker, p.tip[-1], leave[0], p.axis[-1],
                                           leave[1], exit_point)


def tangent_leads(linker: Linker, passes: Sequence[PassEnds],
                  starts: Sequence[tuple[Array, float] | None],
                  ends: Sequence[tuple[Array, float] | None],
                  stepover: Sequence[Stepover | None]
                  ) -> tuple[list[tuple[Array, float] | None], list[tuple[Array, float] | None],
                             tuple[list[Lead | None], list[Lead | None]]]:
    """The passes' tangent approaches and departures where they are clear.

    Parameters
    ----------
    linker : Linker
    passes : sequence of PassEnds
    starts, ends : sequence of ((3,) float64, float) or None
        ``Linker.escape``'s entry and exit point per pass and its length, mm.
    stepover : sequence of Stepover or None
        ``stepover[k]``: pass k goes on into pass k + 1 at feed (no departure from k,
        no approach into k + 1).

    Returns
    -------
    starts, ends : list of ((3,) float64, float) or None
        The entry and exit points, an arc's outer point where it is clear.
    leads : (list, list) of ((LEAD_POINTS, 3), (LEAD_POINTS, 3)) float64 or None
        Per pass the approach's tips and tool axes (the pass's first posture last) and
        the departure's (the exit point last); None: the straight move.
    """
    last = len(passes) - 1
    new_starts, new_ends = list(starts), list(ends)
    approaches: list[Lead | None] = [None] * len(passes)
    departures: list[Lead | None] = [None] * len(passes)
    for k, p in enumerate(passes):
        start, end = starts[k], ends[k]
        if start is not None and not (k and stepover[k - 1] is not None):
            found = tangent_approach(linker, p, start[0])
            if found is not None:
                new_starts[k], approaches[k] = (found[0], start[1]), (found[1], found[2])
        if end is not None and not (k < last and stepover[k] is not None):
            found = tangent_departure(linker, p, end[0])
            if found is not None:
                new_ends[k], departures[k] = (found[0], end[1]), (found[1], found[2])
    return new_starts, new_ends, (approaches, departures)
