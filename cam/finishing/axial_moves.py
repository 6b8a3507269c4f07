"""An operation's way in to its first pass and out of its last: rapid where clear, else feed.

An operation starts on the clearance cylinder (``Envelope``) on its first pass's tool
axis and comes down that axis to the pass's approach point; it ends going out along
its last pass's axis to the cylinder. As one rapid that line runs the whole tool --
the cutter over the whole fluted length, shank and holder -- through whatever lies on
it: in the chain, the roughed stock's skin. nine_blade with ``ball6_flank3`` (45 mm of
flutes) came in radially over the inlet face to its first hub pass, and the
verification found a rapid in stock (16.4 mm3, 4.2 mm deep): the rapid's check
(``Linker.rapid_free``: the cutter grown by the rapid clearance, against the design
and the excess stock) had refused the move, but it was written as a rapid all the
same, unflagged, and the as-a-cut check of air moves (which lets the cutter cut the
stock) passed it.

Here the line is split: a checked rapid as far along it as is clear (the largest of
``FRACTIONS`` of its length from the cylinder's end), the rest at half the cutting
feed, a move the operation's link check then checks as a cut (the cutter may cut the
stock there, as any feed move; shank and holder keep their clearance). Where no
fraction is clear the whole line is fed. A rapid in the toolpath is thus always a
checked one or one the post guards with its safe retract (a turn of a rotary axis).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from postproc.kinematics.base import OverTravelError
from postproc.toolpath import MoveKind

if TYPE_CHECKING:
    from cam.finishing.linking import Linker

__all__ = ["FRACTIONS", "AxialMove", "axial_moves"]

Array = NDArray[np.float64]
#: Shares of the line, from its cylinder end, tried as a rapid (largest first).
FRACTIONS = (1.0, 0.9, 0.75, 0.5, 0.25)


@dataclass(frozen=True)
class AxialMove:
    """One move of the way in or out.

    Attributes
    ----------
    tip : (3,) float64
        End of the move, mm (the axis is the line's).
    kind : MoveKind
        ``RAPID`` (a checked link), ``PLUNGE`` (in at feed) or ``RETRACT`` (out at feed).
    feed : float
        mm/min; NaN for the rapid.
    link : bool
        A checked rapid (``Toolpath.link``).
    joints : (2, 5) float64 or None
        The rapid's joints at its two ends (as it was checked); None for feed moves.
    """

    tip: Array
    kind: MoveKind
    feed: float
    link: bool
    joints: Array | None


def axial_moves(linker: Linker, start: Array, end: Array, axis: Array, reference: Array,
                inward: bool) -> list[AxialMove]:
    """The moves from ``start`` to ``end`` along the fixed tool axis ``axis``.

    Parameters
    ----------
    linker : Linker
        Its rapid check (``rapid_free``), inverse kinematics and cutting feed.
    start, end : (3,) float64
        Tips, mm: inward from the cylinder point to the approach point, outward from
        the departure point to the cylinder point.
    axis : (3,) float64
        Unit tool axis (the same at both ends).
    reference : (5,) float64
        Joints of the pass's end posture (branch and C winding).
    inward : bool
        Coming in (the rapid first, then feed) or going out (feed first, then the
        rapid).

    Returns
    -------
    list of AxialMove
        One checked rapid over the whole line where it is clear; else the rapid over
        the largest clear fraction from the cylinder's end and the rest at half the
        feed; else the whole line at half the feed.
    """
    outer = start if inward else end
    inner = end if inward else start
    axes = np.stack([axis, axis])
    half = 0.5 * linker.rules.feed
    feed_kind = MoveKind.PLUNGE if inward else MoveKind.RETRACT
    for share in FRACTIONS:
        point = outer + share * (inner - outer)
        pair = np.stack([outer, point]) if inward else np.stack([point, outer])
        try:
            joints = linker.inverse(pair, axes, reference)
        except OverTravelError:
            continue
        if not linker.rapid_free(joints):
            continue
        rapid = AxialMove(pair[1], MoveKind.RAPID, math.nan, True, joints)
        if share == 1.0:
            return [rapid]
        fed = AxialMove(end if inward else point, feed_kind, half, False, None)
        return [rapid, fed] if inward else [fed, rapid]
    return [AxialMove(end, feed_kind, half, False, None)]
