"""Circular interpolation in the XY plane (G2/G3), linearised within a chordal tolerance.

Formulas (lengths mm, angles rad):

* centre from the R word: chord ``d = |P1 - P0|``, ``h = sqrt(R^2 - (d/2)^2)``,
  ``C = M +/- h n`` with ``M`` the chord midpoint and ``n`` the chord's left normal;
  ``+`` for G3 with R > 0 and for G2 with R < 0 (the long way round);
* sweep from the start and end angles about ``C``, clockwise negative, a full turn
  when the end equals the start, plus ``2 pi (P - 1)`` for ``P`` turns;
* chord count ``k = ceil(|sweep| / dtheta)`` with ``dtheta = 2 acos(1 - tol / r)`` (the
  sagitta of a chord spanning ``dtheta`` on radius ``r`` is ``r (1 - cos(dtheta / 2))``),
  at most a quarter turn per chord;
* the radius goes linearly from the start radius to the end radius (so the last point
  is the programmed end), and every other joint (Z, A, C) linearly with the angle.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from impeller_cam.errors import InputError


def arc_centre_from_radius(x0: float, y0: float, x1: float, y1: float, radius: float,
                           clockwise: bool) -> tuple[float, float] | None:
    """Centre of the XY arc of signed ``radius`` from (x0, y0) to (x1, y1).

    Returns None when no such arc exists (coincident ends, or ``|radius|`` shorter than
    half the chord by more than 1e-6 of it).
    """
    dx, dy = x1 - x0, y1 - y0
    chord = math.hypot(dx, dy)
    r = abs(radius)
    if chord == 0.0 or r == 0.0 or r < 0.5 * chord * (1.0 - 1e-6):
        return None
    h = math.sqrt(max(r * r - 0.25 * chord * chord, 0.0))
    nx, ny = -dy / chord, dx / chord  # left normal of the chord
    left = (not clockwise) == (radius > 0.0)
    sign = 1.0 if left else -1.0
    return 0.5 * (x0 + x1) + sign * h * nx, 0.5 * (y0 + y1) + sign * h * ny


def arc_sweep(x0: float, y0: float, x1: float, y1: float, cx: float, cy: float,
              clockwise: bool, turns: int = 1) -> float:
    """Signed sweep angle (rad, clockwise negative) of an XY arc about (cx, cy)."""
    a0 = math.atan2(y0 - cy, x0 - cx)
    a1 = math.atan2(y1 - cy, x1 - cx)
    two_pi = 2.0 * math.pi
    if clockwise:
        sweep = -((a0 - a1) % two_pi)
    else:
        sweep = (a1 - a0) % two_pi
    if abs(sweep) < 1e-12 or abs(abs(sweep) - two_pi) < 1e-12:
        sweep = -two_pi if clockwise else two_pi
    extra = two_pi * (turns - 1)
    return sweep - extra if clockwise else sweep + extra


def chord_count(radius: float, sweep: float, tolerance: float) -> int:
    """Number of chords so that none deviates from the arc by more than ``tolerance``."""
    if radius <= 0.0:
        return 1
    cos_half = 1.0 - tolerance / radius
    step = 2.0 * math.acos(cos_half) if cos_half > -1.0 else 2.0 * math.pi
    step = min(step, 0.5 * math.pi)
    return max(1, math.ceil(abs(sweep) / step - 1e-9))


def linearise_arc(start: NDArray[np.float64], end: NDArray[np.float64], cx: float, cy: float,
                  sweep: float, tolerance: float) -> NDArray[np.float64]:
    """End points of the chords of an XY arc (with Z and rotaries interpolated).

    Parameters
    ----------
    start, end : (5,) float64
        Joint vectors X, Y, Z, A, C (mm, rad) at the start and end of the arc.
    cx, cy : float
        Arc centre, mm.
    sweep : float
        Signed sweep, rad (``arc_sweep``).
    tolerance : float
        Chordal tolerance, mm.

    Returns
    -------
    (k, 5) float64
        The chord end points; the last row equals ``end``.
    """
    r0 = math.hypot(start[0] - cx, start[1] - cy)
    r1 = math.hypot(end[0] - cx, end[1] - cy)
    k = chord_count(max(r0, r1), sweep, tolerance)
    t = np.arange(1, k + 1, dtype=np.float64) / k
    angle = math.atan2(start[1] - cy, start[0] - cx) + sweep * t
    radius = r0 + (r1 - r0) * t
    out = start[None, :] + (end - start)[None, :] * t[:, None]
    out[:, 0] = cx + radius * np.cos(angle)
    out[:, 1] = cy + radius * np.sin(angle)
    out[-1] = end
    return out


#: Largest difference between the radii to an arc's start and end: 0.005 mm, or 0.1 %
#: of the radius when that is larger (in the spirit of LinuxCNC's arc radius check).
ARC_RADIUS_TOLERANCE_MM = 0.005
ARC_RADIUS_TOLERANCE_REL = 0.001


def arc_block_points(words: Mapping[str, float], start: NDArray[np.float64],
                     end: NDArray[np.float64], *, clockwise: bool, scale: float,
                     centre_incremental: bool, tolerance: float, line: int,
                     source: str) -> NDArray[np.float64]:
    """Chord end points of one XY-plane G2/G3 block.

    Parameters
    ----------
    words : mapping
        The block's words (I, J, R, P as written; K is refused in the XY plane).
    start, end : (5,) float64
        Joints before and after the block, mm and rad.
    clockwise : bool
        G2 (True) or G3.
    scale : float
        mm per program length unit (25.4 under G20).
    centre_incremental : bool
        I, J relative to the start (G91.1, the default) or absolute (G90.1).
    tolerance : float
        Chordal tolerance, mm.
    line, source : int, str
        Where the block is, for error messages.

    Raises
    ------
    InputError
        K word, no centre given, impossible radius, radii to start and end differing by
        more than ``ARC_RADIUS_TOLERANCE_MM`` / ``_REL``, or a bad turn count P.
    """
    def error(message: str, field: str, value: object, accepted: str) -> InputError:
        return InputError(f"line {line}: {message}", file=source, field=field, value=value,
                          accepted=accepted)

    if "K" in words:
        raise error("K word in an XY-plane arc", "K", words["K"], "I, J or R")
    if "R" in words:
        centre = arc_centre_from_radius(start[0], start[1], end[0], end[1],
                                        words["R"] * scale, clockwise)
        if centre is None:
            raise error("no arc of this radius joins the start and end", "R", words["R"],
                        "|R| >= half the chord, start != end")
        cx, cy = centre
    elif "I" in words or "J" in words:
        cx = words.get("I", 0.0) * scale
        cy = words.get("J", 0.0) * scale
        if centre_incremental:
            cx, cy = cx + start[0], cy + start[1]
        r0 = math.hypot(start[0] - cx, start[1] - cy)
        r1 = math.hypot(end[0] - cx, end[1] - cy)
        limit = max(ARC_RADIUS_TOLERANCE_MM, ARC_RADIUS_TOLERANCE_REL * r0)
        if r0 == 0.0 or abs(r1 - r0) > limit:
            raise error(f"radius to the arc end ({r1:.6g} mm) differs from the radius to its "
                        f"start ({r0:.6g} mm)", "I/J", [words.get("I"), words.get("J")],
                        f"radii equal within {ARC_RADIUS_TOLERANCE_MM} mm or "
                        f"{ARC_RADIUS_TOLERANCE_REL:.1%}")
    else:
        raise error("arc without I/J or R", "G2/G3", None, "I and/or J, or R")
    turns = words.get("P", 1.0)
    if turns != int(turns) or turns < 1:
        raise error("arc turn count P must be a positive integer", "P", turns, "P1, P2, ...")
    sweep = arc_sweep(start[0], start[1], end[0], end[1], cx, cy, clockwise, int(turns))
    return linearise_arc(start, end, cx, cy, sweep, tolerance)
