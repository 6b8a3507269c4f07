"""A tool axis that turns at a continuous rate along a finishing pass (issue 26).

After the posture search, the eq. 7 remedy, the posture repair and the removal of
reverse movements, the rotary joints of a pass may change their rate abruptly from one
posture to the next (a repair blended in over a few millimetres, a remedy step, an
unevenly spaced stretch). On the machine such a kink is a step in the A/C velocity;
through the rotary axes' lever arm it becomes a corner of the linear axes' path (Y and
Z reversing for one block) that the servos round off by tens of microns on the part
(cam/motion/surface_error.py).

``smooth_axis_rate`` replaces A and C by their local-linear Gaussian smoothing against
the ball-centre arc length (``local_linear``): a constant rate is kept exactly, a kink of
the rate becomes a change spread over a few kernel widths. The ball centres are kept
(tips ``centre - R axis``), so the surface the ball cuts does not change. Every changed
posture and motion is checked again with the existing checks (``interference.check_path``,
the posture rules of ``repair``): a posture whose smoothed version interferes or breaks
a rule is held at its old value, with the smoothing faded out around it
(``fade``), and the pass is checked again (a few rounds). A result that interferes
where the old one did not, with more reverse movements of A or C or with more moves
turning faster than the pass allows (``posture.axis_breaks``), is never kept: the old
postures are. The smoothing never reaches across such a fast move (a hub pass's side
change in the air): the stretches between them are smoothed each on its own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from cam.finishing.interference import InterferenceResult, check_path
from cam.finishing.options import FinishOptions
from cam.finishing.posture import axis_breaks
from cam.finishing.repair import PostureRules, offenders
from cam.finishing.reversals import count_reversals
from cam.tools import Tool
from postproc.kinematics import Kinematics

if TYPE_CHECKING:
    from cam.collision import CollisionScene

__all__ = ["AxisSmoothing", "fade", "local_linear", "rate_jumps", "smooth_axis_rate"]

Array = NDArray[np.float64]
#: Rounds of smooth -> check -> hold the offenders.
_ROUNDS = 3
#: Kernel support in widths (weights beyond are below exp(-8)).
_SUPPORT = 4.0
#: The smoothing fades in over this many widths away from a held posture.
_FADE = 2.0
#: Rows of the kernel matrix computed at once.
_CHUNK = 512
#: Joint changes below this are no change, rad.
_NO_CHANGE = 1e-9


@dataclass
class AxisSmoothing:
    """What ``smooth_axis_rate`` did to one pass.

    Attributes
    ----------
    interference : InterferenceResult
        Check of the final postures (the input's when nothing changed).
    joints : (n, 5) float64
        Final joints (X Y Z mm, A C rad).
    held : (k,) intp
        Postures held at their old joints because their smoothed posture (or a motion
        from or to it) interfered or broke a rule.
    max_change_deg : float
        Largest change of A or C, deg.
    rate_jump_before, rate_jump_after : float
        Largest change of the A/C rate between consecutive moves, deg per mm
        (``rate_jumps``).
    status : str
        ``"smoothed"``, ``"unchanged"`` (nothing to do) or ``"kept"`` (the smoothed
        pass was worse by a check: the old postures are kept).
    """

    interference: InterferenceResult
    joints: Array
    held: NDArray[np.intp]
    max_change_deg: float
    rate_jump_before: float
    rate_jump_after: float
    status: str

    def summary(self) -> dict[str, object]:
        """finish.json's ``axis_rate_smoothing`` entry of a path (deg, deg per mm)."""
        return {"status": self.status, "held_points": len(self.held),
                "max_change_deg": round(self.max_change_deg, 6),
                "rate_jump_before_deg_per_mm": round(self.rate_jump_before, 6),
                "rate_jump_after_deg_per_mm": round(self.rate_jump_after, 6)}


def arc_length(centre: Array) -> Array:
    """Cumulative ball-centre path length, ``(n,)`` mm from 0."""
    return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(centre, axis=0), axis=1))])


def local_linear(arc: Array, values: Array, width: float) -> Array:
    """Local-linear Gaussian kernel smoothing of ``values`` over ``arc``.

    At each ``arc[i]`` a straight line is fitted to the samples by weighted least
    squares with weights ``exp(-(arc[j] - arc[i])^2 / (2 width^2))``; its value there
    is the result. Values linear in ``arc`` are reproduced exactly (also at the
    ends); a kink of the slope is spread over a few widths.

    Parameters
    ----------
    arc : (n,) float64
        Non-decreasing path length, mm.
    values : (n,) or (n, k) float64
        Samples (e.g. A and C in rad).
    width : float
        Kernel standard deviation, mm (> 0).

    Returns
    -------
    ndarray
        Smoothed values, the shape of ``values``.
    """
    y = np.asarray(values, dtype=np.float64)
    flat = y.reshape(len(arc), -1)
    out = np.empty_like(flat)
    for start in range(0, len(arc), _CHUNK):
        rows = slice(start, min(start + _CHUNK, len(arc)))
        d = arc[None, :] - arc[rows, None]                      # (m, n) mm
        w = np.exp(-0.5 * (d / width) ** 2) * (np.abs(d) <= _SUPPORT * width)
        s0 = w.sum(axis=1)
        s1 = (w * d).sum(axis=1)
        s2 = (w * d * d).sum(axis=1)
        t0 = w @ flat                                           # (m, k)
        t1 = (w * d) @ flat
        det = s0 * s2 - s1 * s1
        ok = det > 1e-12 * np.maximum(s0 * s2, 1e-300)
        safe = np.where(ok, det, 1.0)
        linear = (s2[:, None] * t0 - s1[:, None] * t1) / safe[:, None]
        out[rows] = np.where(ok[:, None], linear, t0 / s0[:, None])
    return out.reshape(y.shape)


def fade(arc: Array, held: NDArray[np.intp], width: float) -> Array:
    """Share of the smoothing applied at each posture, ``(n,)`` in [0, 1].

    0 at the held postures, rising smoothly (a cubic smoothstep) to 1 at
    ``_FADE * width`` mm of path from the nearest one; 1 everywhere without any.
    """
    share = np.ones(len(arc))
    if held.size == 0:
        return share
    distance = np.min(np.abs(arc[:, None] - arc[held][None, :]), axis=1)
    x = np.clip(distance / (_FADE * width), 0.0, 1.0)
    return np.asarray(np.minimum(share, x * x * (3.0 - 2.0 * x)))


def rate_jumps(arc: Array, rotary: Array) -> float:
    """Largest change of the rotary rate between consecutive moves, deg per mm.

    Parameters
    ----------
    arc : (n,) float64
        Path length, mm.
    rotary : (n, k) float64
        Rotary joints, rad.
    """
    if len(arc) < 3:
        return 0.0
    step = np.maximum(np.diff(arc), 1e-9)
    rate = np.diff(rotary, axis=0) / step[:, None]
    return float(np.degrees(np.abs(np.diff(rate, axis=0)).max()))


def _postures(kins: Kinematics, rotary: Array, joints: Array, centre: Array,
              radius: float) -> tuple[Array, Array, Array]:
    """Tips, axes and joints of postures with these A and C, ball centres kept."""
    trial = joints.copy()
    trial[:, 3:5] = rotary
    axis = kins.forward(trial)[1]
    axis = axis / np.linalg.norm(axis, axis=1, keepdims=True)
    tip = centre - radius * axis
    return tip, axis, kins.inverse(tip, axis)


def _reversals(joints: Array, deadband: float) -> int:
    return count_reversals(joints[:, 3], deadband) + count_reversals(joints[:, 4], deadband)


def _target(arc: Array, rotary: Array, width: float, splits: NDArray[np.intp]) -> Array:
    """``local_linear`` of each stretch between the moves ``splits`` (``i -> i + 1``)."""
    out = rotary.copy()
    bounds = np.concatenate([[0], splits + 1, [len(arc)]])
    for first, end in zip(bounds[:-1], bounds[1:], strict=True):
        if end - first >= 3:
            out[first:end] = local_linear(arc[first:end], rotary[first:end], width)
    return out


def smooth_axis_rate(scene: CollisionScene, tool: Tool, kins: Kinematics, rules: PostureRules,
                     inter: InterferenceResult, joints: Array, options: FinishOptions,
                     max_turn: float = math.inf) -> AxisSmoothing:
    """Smooth the rate of A and C along one pass, never into a collision (module docstring).

    Parameters
    ----------
    scene : CollisionScene
    tool : Tool
        The ball-end mill (radius R, mm).
    kins : Kinematics
    rules : PostureRules
        The pass's ball centres and posture rules.
    inter : InterferenceResult
        The pass's current postures and their check.
    joints : (n, 5) float64
        Their joints (X Y Z mm, A C rad).
    options : FinishOptions
        ``axis_rate_smoothing_mm`` is the kernel width (0: off).
    max_turn : float
        Fastest turn of the axis along the pass, rad per mm of ball-centre path
        (``posture.axis_breaks``); faster moves split the smoothing.

    Returns
    -------
    AxisSmoothing
    """
    width = options.axis_rate_smoothing_mm
    arc = arc_length(rules.centre)
    before = rate_jumps(arc, joints[:, 3:5])
    empty = np.zeros(0, dtype=np.intp)
    unchanged = AxisSmoothing(inter, joints, empty, 0.0, before, before, "unchanged")
    if width <= 0 or len(arc) < 3:
        return unchanged
    splits = axis_breaks(rules.centre, inter.axis, max_turn)
    target = _target(arc, joints[:, 3:5], width, splits)
    if np.abs(target - joints[:, 3:5]).max() < _NO_CHANGE:
        return unchanged
    deadband = math.radians(options.reversal_deadband_deg)
    old_bad = np.zeros(len(arc), dtype=bool)
    old_bad[offenders(inter, rules, options)] = True
    held = np.flatnonzero(old_bad)
    for _ in range(_ROUNDS):
        share = fade(arc, held, width)
        rotary = joints[:, 3:5] + share[:, None] * (target - joints[:, 3:5])
        tip, axis, new_joints = _postures(kins, rotary, joints, rules.centre, tool.radius)
        checked = check_path(scene, tool, tip, axis, options)
        checked.delta_c, checked.steps, checked.c_max = inter.delta_c, inter.steps, inter.c_max
        new_bad = np.zeros(len(arc), dtype=bool)
        new_bad[offenders(checked, rules, options)] = True
        fresh = np.flatnonzero(new_bad & ~old_bad)
        if not fresh.size:
            if _reversals(new_joints, deadband) > _reversals(joints, deadband) or \
                    len(axis_breaks(rules.centre, axis, max_turn)) > len(splits):
                break
            change = float(np.degrees(np.abs(new_joints[:, 3:5] - joints[:, 3:5]).max()))
            return AxisSmoothing(checked, new_joints, held, change, before,
                                 rate_jumps(arc, new_joints[:, 3:5]), "smoothed")
        held = np.union1d(held, fresh)
    return AxisSmoothing(inter, joints, held, 0.0, before, before, "kept")
