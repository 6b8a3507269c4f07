"""Tool postures: validation, tool-frame rotations and motion subdivision.

A posture is ``tip (3,)`` and unit ``axis (3,)`` in the scene (workpiece) frame;
the tool frame has the tip at the origin and the axis along +Z. Tools are solids
of revolution, so any rotation that takes +Z onto the axis places the tool; the
minimal one (about ``z x axis``) is used.

Motion between consecutive postures is modelled as a linear tip move and a
great-circle (constant angular rate) turn of the axis, and is sampled so that
no sub-step moves the tip more than ``max_step_mm`` or turns the axis more than
``max_step_rad``. A tool point at distance at most ``L`` from the tip then moves at
most ``D = max_step_mm + 2 L sin(max_step_rad / 2)`` within a sub-step, and any
intermediate position is within

``bound = max_step_mm / 2 + 2 L sin(max_step_rad / 4)``

of the same point at the nearer sub-sample (``motion_bound``): a contact between
sub-samples implies a sub-sample at which the tool is within ``bound`` of the scene.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from impeller_cam.errors import InputError

#: Largest accepted deviation of an axis vector from unit length.
AXIS_UNIT_TOLERANCE = 1e-6
#: Largest axis turn between two consecutive postures that has a unique great circle.
MAX_TURN = math.radians(179.0)


def validate_postures(
    tip: ArrayLike, axis: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Check and convert postures.

    Parameters
    ----------
    tip, axis : (n, 3) array-like
        Tool tips (mm) and unit axes; a single ``(3,)`` posture is accepted.

    Returns
    -------
    tip, axis : (n, 3) float64
        Copies; the axes renormalised (they were unit within 1e-6 already).
    """
    t = np.atleast_2d(np.asarray(tip, dtype=np.float64))
    a = np.atleast_2d(np.asarray(axis, dtype=np.float64))
    if t.ndim != 2 or t.shape[1] != 3 or a.shape != t.shape:
        raise InputError(
            "tip and axis must be (n, 3) arrays of the same shape",
            field="tip/axis",
            value=f"{t.shape} and {a.shape}",
            accepted="(n, 3) and (n, 3)",
        )
    if not (np.isfinite(t).all() and np.isfinite(a).all()):
        raise InputError("tip and axis must be finite", field="tip/axis", accepted="finite numbers")
    norm = np.linalg.norm(a, axis=1)
    bad = np.flatnonzero(np.abs(norm - 1.0) > AXIS_UNIT_TOLERANCE)
    if bad.size:
        raise InputError(
            "tool axis is not a unit vector",
            field=f"axis[{int(bad[0])}]",
            value=a[bad[0]].tolist(),
            accepted=f"|axis| = 1 within {AXIS_UNIT_TOLERANCE:g}",
        )
    return t.copy(), a / norm[:, None]


def rotations_to(axis: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotation matrices taking the tool's +Z onto each axis.

    Parameters
    ----------
    axis : (n, 3) float64
        Unit axes.

    Returns
    -------
    (n, 3, 3) float64
        ``R @ [0, 0, 1] = axis`` (Rodrigues about ``z x axis``, composed with a
        half turn about X for axes pointing down, to stay well-conditioned).
    """
    # Rodrigues about v = z x b, R = I + [v]x + [v]x^2 / (1 + c), is ill-conditioned
    # near c = -1: axes pointing down are first flipped by F = half turn about X
    # (b = F a has b_z >= 0) and the result is F Q (F z = -z, F F = I).
    n = len(axis)
    flip = axis[:, 2] < 0
    b = np.where(flip[:, None], axis * [1.0, -1.0, -1.0], axis)
    c = b[:, 2]
    vx, vy = -b[:, 1], b[:, 0]  # v = z x b = (-b_y, b_x, 0)
    f = 1.0 / (1.0 + c)
    rot = np.zeros((n, 3, 3))
    rot[:, 0, 0] = 1.0 - f * vy * vy
    rot[:, 0, 1] = f * vx * vy
    rot[:, 0, 2] = vy
    rot[:, 1, 0] = f * vx * vy
    rot[:, 1, 1] = 1.0 - f * vx * vx
    rot[:, 1, 2] = -vx
    rot[:, 2, 0] = -vy
    rot[:, 2, 1] = vx
    rot[:, 2, 2] = 1.0 - f * (vx * vx + vy * vy)
    rot[flip, 1:, :] *= -1.0
    return rot


def motion_bound(reach: float, max_step_mm: float, max_step_rad: float) -> float:
    """Largest approach of the moving tool missed between sub-samples, mm.

    Parameters
    ----------
    reach : float
        Largest distance of a tool (mesh) point from the tip, L, mm.
    max_step_mm : float
        Largest tip move per sub-step, mm.
    max_step_rad : float
        Largest axis turn per sub-step, radians.

    Returns
    -------
    float
        ``max_step_mm / 2 + 2 L sin(max_step_rad / 4)``, mm.
    """
    return 0.5 * max_step_mm + 2.0 * reach * math.sin(0.25 * max_step_rad)


def subdivide_motion(
    tip: NDArray[np.float64],
    axis: NDArray[np.float64],
    max_step_mm: float,
    max_step_rad: float,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]]:
    """Sample the motion through consecutive postures.

    Parameters
    ----------
    tip, axis : (n, 3) float64
        Validated postures, n >= 2.
    max_step_mm : float
        Largest tip move per sub-step, mm (> 0).
    max_step_rad : float
        Largest axis turn per sub-step, radians (> 0).

    Returns
    -------
    sub_tip, sub_axis : (m, 3) float64
        Sub-sampled postures, starting with posture 0 and ending with posture n-1.
    starts : (n,) int64
        Index in the sub-samples of each original posture; segment ``i`` covers
        sub-samples ``starts[i] .. starts[i + 1]`` (both ends included).
    """
    for name, value in (("max_step_mm", max_step_mm), ("max_step_deg", max_step_rad)):
        if not (math.isfinite(value) and value > 0):
            raise InputError("step limit must be positive", field=name, value=value, accepted="> 0")
    a0, a1 = axis[:-1], axis[1:]
    cos = np.clip(np.einsum("ij,ij->i", a0, a1), -1.0, 1.0)
    turn = np.arccos(cos)
    if np.any(turn > MAX_TURN):
        i = int(np.flatnonzero(turn > MAX_TURN)[0])
        raise InputError(
            "axis turns by almost a half turn between consecutive postures",
            field=f"axis[{i}:{i + 2}]",
            value=round(math.degrees(float(turn[i])), 3),
            accepted=f"turns below {math.degrees(MAX_TURN):g} deg",
        )
    move = np.linalg.norm(tip[1:] - tip[:-1], axis=1)
    steps = np.maximum.reduce(
        [np.ones_like(move), np.ceil(move / max_step_mm), np.ceil(turn / max_step_rad)]
    ).astype(np.int64)
    starts = np.concatenate([[0], np.cumsum(steps)])
    segment = np.repeat(np.arange(len(steps)), steps)
    t = (np.arange(starts[-1]) - starts[segment]) / steps[segment]
    sub_tip = tip[segment] + t[:, None] * (tip[segment + 1] - tip[segment])
    theta = turn[segment]
    small = theta < 1e-9
    sin_theta = np.where(small, 1.0, np.sin(theta))
    w0 = np.where(small, 1.0 - t, np.sin((1.0 - t) * theta) / sin_theta)
    w1 = np.where(small, t, np.sin(t * theta) / sin_theta)
    sub_axis = w0[:, None] * axis[segment] + w1[:, None] * axis[segment + 1]
    sub_axis /= np.linalg.norm(sub_axis, axis=1)[:, None]
    return (
        np.vstack([sub_tip, tip[-1:]]),
        np.vstack([sub_axis, axis[-1:]]),
        starts.astype(np.int64),
    )
