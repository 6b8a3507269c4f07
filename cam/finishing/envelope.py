"""The impeller's bounding cylinder and the moves that leave and go round it.

A finishing pass is left along its tool axis until the tip is outside the cylinder
(``retract_length``); the retract kind of link turns between two such points about
the impeller axis (``stepped_link``). ``cam.finishing.linking`` builds links on these.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from cam.finishing.posture import rotate_about_z
from impeller_cam.errors import InputError

__all__ = ["Envelope", "retract_length", "stepped_link"]

Array = NDArray[np.float64]
_RETRACT_SAMPLES = 2048


class Envelope:
    """Bounding cylinder of the impeller: ``r <= radius``, ``z <= top`` (mm)."""

    def __init__(self, radius: float, top: float) -> None:
        self.radius = float(radius)
        self.top = float(top)

    def outside(self, points: Array) -> NDArray[np.bool_]:
        """Points strictly outside the cylinder (``(..., 3)`` -> ``(...)``)."""
        r = np.hypot(points[..., 0], points[..., 1])
        return np.asarray((r > self.radius) | (points[..., 2] > self.top))


def retract_length(tip: Array, axis: Array, envelope: Envelope, longest: float) -> Array:
    """Shortest move along each axis that takes the tip outside ``envelope``, mm, ``(n,)``.

    Raises
    ------
    InputError
        A tool axis does not leave the envelope within ``longest`` mm.
    """
    t = np.linspace(0.0, longest, _RETRACT_SAMPLES)
    points = tip[:, None, :] + t[None, :, None] * axis[:, None, :]
    out = envelope.outside(points)
    # the first sample from which the tip stays outside
    inside_after = np.flip(np.logical_or.accumulate(np.flip(~out, axis=1), axis=1), axis=1)
    ok = ~inside_after
    if not ok.any(axis=1).all():
        bad = int(np.flatnonzero(~ok.any(axis=1))[0])
        raise InputError("a pass cannot be left along its tool axis", field="tool",
                         value=f"axis {axis[bad].round(4).tolist()} at {tip[bad].round(3)}",
                         accepted=f"a tool axis leaving the part within {longest:g} mm")
    return np.asarray(t[np.argmax(ok, axis=1)])


def stepped_link(a_tip: Array, a_axis: Array, b_tip: Array, b_axis: Array,
                  step: float) -> tuple[Array, Array]:
    """The earlier link's poses between two cylinder points (unchecked rapids).

    The retract point turned about the impeller axis in steps of at most ``step``
    (radius, height and the axis relative to the part unchanged), then the corner
    ``(max r, max z)`` of the two ends: every tip stays outside the cylinder.
    """
    theta_a = math.atan2(a_tip[1], a_tip[0])
    theta_b = math.atan2(b_tip[1], b_tip[0])
    turn = (theta_b - theta_a + math.pi) % (2.0 * math.pi) - math.pi
    count = int(math.ceil(abs(turn) / step))
    tips, axes = [], []
    for k in range(1, count + 1):
        angle = turn * k / count
        tips.append(rotate_about_z(a_tip[None], angle)[0])
        axes.append(rotate_about_z(a_axis[None], angle)[0])
    last_tip = tips[-1] if tips else a_tip
    last_axis = axes[-1] if axes else a_axis
    r = max(math.hypot(last_tip[0], last_tip[1]), math.hypot(b_tip[0], b_tip[1]))
    z = max(float(last_tip[2]), float(b_tip[2]))
    corner = np.array([r * math.cos(theta_b), r * math.sin(theta_b), z])
    if not (np.allclose(corner, last_tip) or np.allclose(corner, b_tip)):
        tips.append(corner)
        mid = last_axis + b_axis
        axes.append(mid / np.linalg.norm(mid) if np.linalg.norm(mid) > 1e-9 else b_axis)
    return np.reshape(tips, (-1, 3)), np.reshape(axes, (-1, 3))
