"""3+2 tilted frames: each Unit Machining Region as a 3-axis program in a swivelled frame.

A 3+2 segment (a UMR of the roughing) is a run of blocks of one operation with fixed,
tilted rotary joints between two safety sequences (retract, orient, position). With
the rotary joints fixed, the machine moves the tool tip relative to the part along
straight lines whose direction is the machine X, Y, Z turned into the workpiece:
``tip_W = R p'`` with ``R`` the rotation from machine-axis directions to W at those
rotary positions (``frame_rotation``). The swivelled frame (Sinumerik ``CYCLE800``,
Heidenhain ``PLANE``) has its origin at the workpiece zero and its axes along the
machine axes at the rotary positions, so the tool axis is its +Z and the segment is
a plain 3-axis program in ``p' = R^T tip_W``.

``spatial_angles`` gives the same frame as Heidenhain spatial angles (``PLANE
SPATIAL``: rotations about the fixed X, then Y, then Z axes, ``R = Rz(SPC) Ry(SPB)
Rx(SPA)``); ``rotation_from_spatial`` is its inverse (used by the reader).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from postproc.kinematics import kinematics_for
from postproc.program import Motion

if TYPE_CHECKING:
    from postproc.posting import PostedProgram

#: Rotary joints closer than this count as the same orientation, rad.
STILL = 1e-9


@dataclass(frozen=True)
class Swivel:
    """The 3+2 segments of a program and their frames.

    Attributes
    ----------
    frame : (n,) int64
        Frame index of each block, -1 outside the segments.
    rotary : (k, 2) float64
        Rotary joints (A, C) of each frame, rad.
    rotation : (k, 3, 3) float64
        ``tip_W = rotation @ p'`` for each frame.
    words : (n, 5) float64
        Program words with the segment rows in frame coordinates, mm (A, C NaN there).
    present : (n, 5) bool
        Words the blocks program (A, C absent in the segments).
    """

    frame: NDArray[np.int64]
    rotary: NDArray[np.float64]
    rotation: NDArray[np.float64]
    words: NDArray[np.float64]
    present: NDArray[np.bool_]


def frame_rotation(kins: Any, rotary: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotations ``(k, 3, 3)`` from machine-axis directions to W at rotary joints ``(k, 2)``.

    For fixed rotary joints the forward map is affine in X, Y, Z; its linear part,
    from four forward evaluations, is the rotation (any registered kinematics).
    """
    k = len(rotary)
    probe = np.zeros((k, 4, 5))
    probe[:, :, 3:] = rotary[:, None, :]
    for c in range(3):
        probe[:, c + 1, c] = 1.0
    tip, _ = kins.forward(probe.reshape(-1, 5))
    tip = tip.reshape(k, 4, 3)
    return np.stack([tip[:, c + 1] - tip[:, 0] for c in range(3)], axis=2)


def spatial_angles(rotation: NDArray[np.float64]) -> NDArray[np.float64]:
    """Spatial angles ``(k, 3)`` SPA, SPB, SPC in degrees of rotations ``(k, 3, 3)``."""
    r = rotation
    spb = -np.arcsin(np.clip(r[:, 2, 0], -1.0, 1.0))
    spa = np.arctan2(r[:, 2, 1], r[:, 2, 2])
    spc = np.arctan2(r[:, 1, 0], r[:, 0, 0])
    return np.degrees(np.stack([spa, spb, spc], axis=1))


def rotation_from_spatial(angles_deg: NDArray[np.float64]) -> NDArray[np.float64]:
    """``Rz(SPC) Ry(SPB) Rx(SPA)`` for spatial angles ``(3,)`` in degrees, ``(3, 3)``."""
    a, b, c = np.radians(np.asarray(angles_deg, dtype=np.float64))
    rx = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    ry = np.array([[np.cos(b), 0, np.sin(b)], [0, 1, 0], [-np.sin(b), 0, np.cos(b)]])
    rz = np.array([[np.cos(c), -np.sin(c), 0], [np.sin(c), np.cos(c), 0], [0, 0, 1]])
    return rz @ ry @ rx


def swivel_segments(program: PostedProgram) -> Swivel:
    """Find the 3+2 segments of a posted program and express them in their frames.

    A segment is a maximal run of non-safety blocks of one operation with the same
    tilted rotary joints (A not 0), at least one feed block, preceded and followed by
    a safety block (or the operation's / program's start or end). Simultaneous
    stretches never qualify (their rotaries change inside the run's neighbourhood).
    """
    from postproc.posting import Role

    n = len(program)
    q = program.machine_joints
    op = program.operation
    safety = np.isin(program.role, (Role.RETRACT, Role.ORIENT, Role.POSITION))
    candidate = ~safety & np.isfinite(q).all(axis=1)
    same = np.zeros(n, dtype=bool)
    if n > 1:
        same[1:] = (np.abs(np.diff(np.where(np.isfinite(q[:, 3:]), q[:, 3:], 0.0), axis=0))
                    .max(axis=1) <= STILL) & (op[1:] == op[:-1]) & candidate[1:] & candidate[:-1]
    run = np.cumsum(~same) - 1
    starts = np.flatnonzero(~same)
    ends = np.append(starts[1:], n) - 1
    before_ok = (starts == 0) | safety[np.maximum(starts - 1, 0)] | (
        op[np.maximum(starts - 1, 0)] != op[starts])
    after_ok = (ends == n - 1) | safety[np.minimum(ends + 1, n - 1)] | (
        op[np.minimum(ends + 1, n - 1)] != op[ends])
    feeds = np.bincount(run, weights=(program.blocks.motion == Motion.LINEAR).astype(float),
                        minlength=len(starts)) > 0
    tilted = np.abs(np.where(candidate[starts], q[starts, 3], 0.0)) > STILL
    chosen = candidate[starts] & before_ok & after_ok & feeds & tilted
    frame_of_run = np.where(chosen, np.cumsum(chosen) - 1, -1)
    frame = frame_of_run[run] if n else np.zeros(0, np.int64)
    rotary = q[starts[chosen]][:, 3:]
    kins = kinematics_for(program.machine)
    rotation = frame_rotation(kins, rotary) if len(rotary) else np.zeros((0, 3, 3))
    words = program.blocks.joints.copy()
    present = program.present.copy()
    rows = np.flatnonzero(frame >= 0)
    if len(rows):
        tip, _ = kins.forward(q[rows])
        words[rows, :3] = np.einsum("kji,kj->ki", rotation[frame[rows]], tip)
        words[rows, 3:] = np.nan
        present[rows, 3:] = False
    return Swivel(frame.astype(np.int64), rotary, rotation, words, present)
