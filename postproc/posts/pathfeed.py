"""Path feeds (mm/min) for controls that are not given inverse-time feeds.

``postproc.posting`` gives every block that turns a rotary axis an inverse-time F
(``1 / minutes``). A Heidenhain TNC has no inverse-time mode, and a Sinumerik may be
set up for path feed (``feed = path`` in the machine file); for them the block's
duration is turned back into a feed along the path the control measures:

* under tool-centre-point control (``TRAORI``, ``FUNCTION TCPM F TCP``): the length
  of the straight tool-tip path in the workpiece frame;
* in joint mode: the length of the X, Y, Z path, or, when the linear axes do not
  move, the rotary travel in degrees (the rule LinuxCNC and the verifier use).

``F = length / minutes`` keeps each block's duration (and so the axis-velocity
limits the post applied) exactly; the tip moves over the part at the APT feed.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from postproc.kinematics import kinematics_for
from postproc.program import FeedMode, Motion

if TYPE_CHECKING:
    from postproc.posting import PostedProgram


def block_lengths(program: PostedProgram) -> NDArray[np.float64]:
    """Path length of every block as the control measures it, ``(n,)`` mm (or deg).

    The first block (unknown start) and blocks starting from unknown words get 0.
    """
    blocks = program.blocks
    n = len(program)
    kins = kinematics_for(program.machine)
    joints = program.machine_joints
    finite = np.isfinite(joints).all(axis=1)
    tip = np.full((n, 3), np.nan)
    if finite.any():
        tip[finite], _ = kins.forward(joints[finite])
    words = blocks.joints
    linear = np.zeros(n)
    rotary = np.zeros(n)
    if n > 1:
        step = np.diff(words, axis=0)
        joint_linear = np.linalg.norm(step[:, :3], axis=1)
        tcp_linear = np.linalg.norm(np.diff(tip, axis=0), axis=1)
        linear[1:] = np.where(blocks.tcp[1:], tcp_linear, joint_linear)
        rotary[1:] = np.degrees(np.linalg.norm(step[:, 3:], axis=1))
    linear = np.where(np.isfinite(linear), linear, 0.0)
    rotary = np.where(np.isfinite(rotary), rotary, 0.0)
    return np.where(linear > 1e-9, linear, rotary)


def path_feeds(program: PostedProgram,
               decimals: int) -> tuple[NDArray[np.int16], NDArray[np.float64]]:
    """Feed mode (all ``UNITS_PER_MINUTE``) and F (mm/min, NaN for rapids) per block.

    Parameters
    ----------
    program : PostedProgram
        The posted program (inverse-time F on blocks that turn a rotary axis).
    decimals : int
        Digits of the F word: an F that would print as 0 is raised to the smallest
        printable value (a block that short takes longer than posted, never less).

    Returns
    -------
    mode : (n,) int16
    feed : (n,) float64
    """
    blocks = program.blocks
    inverse = (blocks.feed_mode == FeedMode.INVERSE_TIME) & (blocks.motion == Motion.LINEAR)
    feed = blocks.feed.copy()
    if inverse.any():
        length = block_lengths(program)
        feed[inverse] = np.maximum(length[inverse] * blocks.feed[inverse], 10.0**-decimals)
    mode = np.full(len(program), int(FeedMode.UNITS_PER_MINUTE), dtype=np.int16)
    return mode, feed
