"""Feed words: inverse time (G93) for simultaneous moves, mm/min (G94) for linear ones.

Under G93 a block's F is the reciprocal of its duration in minutes. The duration of a
simultaneous block is the length of the real tool-tip path in the workpiece frame
divided by the programmed feed (so the tip moves over the part at the programmed
feed, whatever the joints do), but never shorter than the slowest joint needs at its
velocity limit (a block that turns the table under a resting tip still takes time).
Pure linear blocks (rotary joints unchanged) keep mm/min under G94; rapids have no F.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from impeller_cam.errors import InputError
from postproc.program import FeedMode, Motion

#: Rotary step (rad) below which a block counts as purely linear.
ROTARY_STILL = 1e-12


def block_feeds(
    motion: NDArray[np.int8],
    feed: NDArray[np.float64],
    tip_length: NDArray[np.float64],
    joint_step: NDArray[np.float64],
    velocity: NDArray[np.float64],
    records: NDArray[np.int64] | None = None,
) -> tuple[NDArray[np.int16], NDArray[np.float64]]:
    """Feed mode and F word of each block.

    Parameters
    ----------
    motion : (n,) int8
        ``Motion`` of each block.
    feed : (n,) float64
        Programmed (CL) feed of each block, mm/min; ignored for rapids.
    tip_length : (n,) float64
        Length of the tool-tip path of each block in W, mm.
    joint_step : (n, 5) float64
        Joint change over each block (mm, rad).
    velocity : (5,) float64
        Axis velocity limits, mm/s and rad/s.
    records : (n,) int64, optional
        APT record of each block, for error messages.

    Returns
    -------
    feed_mode : (n,) int16
        ``FeedMode``: G93 for feed blocks that turn a rotary axis, G94 otherwise
        (rapids carry the mode in force before them).
    f_word : (n,) float64
        mm/min under G94, 1/min under G93, NaN for rapids.

    Raises
    ------
    InputError
        A feed block without a positive finite feed.
    """
    motion = np.asarray(motion)
    n = len(motion)
    cutting = motion != Motion.RAPID
    bad = cutting & ~(np.isfinite(feed) & (feed > 0.0))
    if bad.any():
        row = int(np.flatnonzero(bad)[0])
        record = None if records is None else int(records[row])
        raise InputError(
            f"feed move {row}" + (f" (record {record})" if record is not None else "")
            + " has no positive feed rate",
            field="FEDRAT", value=float(feed[row]), accepted="FEDRAT/ f with f > 0 mm/min",
        )
    rotary = np.abs(joint_step[:, 3:]).max(axis=1) > ROTARY_STILL if n else np.zeros(0, bool)
    inverse = cutting & rotary
    mode = np.where(inverse, FeedMode.INVERSE_TIME, FeedMode.UNITS_PER_MINUTE).astype(np.int16)
    # rapids keep the mode of the cutting block before them (modal G93/G94)
    index = np.where(cutting, np.arange(n), -1)
    index = np.maximum.accumulate(index) if n else index
    mode = np.where(index >= 0, mode[np.maximum(index, 0)], FeedMode.UNITS_PER_MINUTE)
    mode = mode.astype(np.int16)
    with np.errstate(divide="ignore", invalid="ignore"):
        path_minutes = tip_length / feed
        joint_minutes = (np.abs(joint_step) / velocity[None, :]).max(axis=1) / 60.0
    minutes = np.maximum(path_minutes, joint_minutes)
    f_word = np.full(n, np.nan)
    f_word[~inverse & cutting] = feed[~inverse & cutting]
    f_word[inverse] = 1.0 / minutes[inverse]
    return mode, f_word
