"""Joining finishing passes into one ``Toolpath`` per operation.

Every pass is entered and left along its own tool axis: a rapid to the approach
point (the first tip moved back along the axis until it is ``clearance`` mm outside
the impeller's bounding cylinder), a plunge at half the cutting feed, the pass,
and a retract along the last axis to the same kind of point. Between two passes the
link (rapids) first turns the retract point about the impeller axis in steps of at
most ``link_step`` (radius, height and the axis relative to the part unchanged, so
the tip stays outside the cylinder), then moves to the corner point
``(max r, max z)`` of the two link ends, then to the next approach point: every
tip of the link stays outside the cylinder (r or z only grows towards the corner).
Links are collision-checked like the passes and reported separately.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from cam.finishing.posture import rotate_about_z
from impeller_cam.errors import InputError
from postproc.toolpath import Cutter, MoveKind, Toolpath

__all__ = ["Envelope", "join_passes", "retract_length"]

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


def _link(a_tip: Array, a_axis: Array, b_tip: Array, b_axis: Array,
          step: float) -> tuple[Array, Array]:
    """Intermediate link poses from retract point ``a`` to approach point ``b``."""
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


def join_passes(name: str, passes: Sequence[tuple[Array, Array]], envelope: Envelope, *,
                feed: float, link_step: float, longest: float, tool_number: int,
                cutter: Cutter, spindle_rpm: float | None) -> tuple[Toolpath, NDArray[np.bool_]]:
    """One operation: approach, plunge, pass, retract for every pass, linked by rapids.

    Parameters
    ----------
    passes : sequence of (tip (n, 3), axis (n, 3))
        Final postures of each pass, in machining order.
    feed : float
        Cutting feed, mm/min (plunge and retract at half of it).
    link_step : float
        Largest rotation about +Z between link points, rad.
    longest : float
        Longest allowed retract, mm.

    Returns
    -------
    toolpath : Toolpath
    is_link : (m,) bool
        Poses that are approach, retract or link poses (not cutting points).
    """
    tips: list[Array] = []
    axes: list[Array] = []
    kinds: list[NDArray[np.int8]] = []
    feeds: list[Array] = []
    link: list[NDArray[np.bool_]] = []
    previous: tuple[Array, Array] | None = None

    def add(t: Array, a: Array, kind: MoveKind, f: float, is_link: bool) -> None:
        t = np.reshape(t, (-1, 3))
        tips.append(t)
        axes.append(np.reshape(a, (-1, 3)))
        kinds.append(np.full(len(t), int(kind), np.int8))
        feeds.append(np.full(len(t), f))
        link.append(np.full(len(t), is_link))

    for tip, axis in passes:
        ends = retract_length(tip[[0, -1]], axis[[0, -1]], envelope, longest)
        approach = tip[0] + ends[0] * axis[0]
        retract = tip[-1] + ends[1] * axis[-1]
        if previous is not None:
            link_tip, link_axis = _link(previous[0], previous[1], approach, axis[0], link_step)
            if len(link_tip):
                add(link_tip, link_axis, MoveKind.RAPID, math.nan, True)
        add(approach, axis[0], MoveKind.RAPID, math.nan, True)
        add(tip[0], axis[0], MoveKind.PLUNGE, 0.5 * feed, False)
        add(tip[1:], axis[1:], MoveKind.FEED, feed, False)
        add(retract, axis[-1], MoveKind.RETRACT, 0.5 * feed, True)
        previous = (retract, axis[-1])
    axis_all = np.concatenate(axes)
    axis_all = axis_all / np.linalg.norm(axis_all, axis=1, keepdims=True)
    toolpath = Toolpath(
        tip=np.concatenate(tips), axis=axis_all, feed=np.concatenate(feeds),
        kind=np.concatenate(kinds), name=name, tool_number=tool_number, cutter=cutter,
        spindle_rpm=spindle_rpm,
    )
    return toolpath, np.concatenate(link)
