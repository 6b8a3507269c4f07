"""The machine program: joint-space blocks, the common currency of post, read-back,
timing and verification.

Internal units: mm for X, Y, Z; radians for A, B, C. Feeds as the block states them
(``feed_mode`` says which): mm/min under G94, inverse minutes under G93.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

import numpy as np
from numpy.typing import NDArray

#: Column order of ``MachineProgram.joints``.
JOINT_NAMES: tuple[str, ...] = ("X", "Y", "Z", "A", "C")


class Motion(IntEnum):
    """Motion mode of a block."""

    RAPID = 0  # G0
    LINEAR = 1  # G1


class FeedMode(IntEnum):
    """Feed-rate mode of a block."""

    UNITS_PER_MINUTE = 94  # G94, mm/min
    INVERSE_TIME = 93  # G93, 1/min: the block takes 1/F minutes


@dataclass
class MachineProgram:
    """Joint-space motion blocks with their source line numbers.

    Attributes
    ----------
    joints : (n, 5) float64
        Joint targets at the end of each block: X, Y, Z in mm, A, C in radians
        (column order ``JOINT_NAMES``). For blocks programmed under tool-centre-point
        control (``tcp`` True) X, Y, Z are the programmed tool tip in the table frame
        and must be mapped through the machine's kinematics to get joints.
    motion : (n,) int8
        ``Motion`` of each block.
    feed_mode : (n,) int16
        ``FeedMode`` of each block.
    feed : (n,) float64
        F word in force for each block (mm/min or 1/min); NaN for rapids.
    line : (n,) int64
        1-based line number of the block in its source NC file.
    tcp : (n,) bool
        Tool-centre-point control active for the block (G43.4 / M428 TCP kins).
    tool_number : (n,) int32
        Tool in the spindle for the block (0 when none was loaded).
    start : (5,) float64
        Joint position before the first block.
    """

    joints: NDArray[np.float64]
    motion: NDArray[np.int8]
    feed_mode: NDArray[np.int16]
    feed: NDArray[np.float64]
    line: NDArray[np.int64]
    tcp: NDArray[np.bool_]
    tool_number: NDArray[np.int32]
    start: NDArray[np.float64]

    def __post_init__(self) -> None:
        self.joints = np.ascontiguousarray(self.joints, dtype=np.float64).reshape(-1, 5)
        n = len(self.joints)
        self.motion = np.ascontiguousarray(self.motion, dtype=np.int8).reshape(-1)
        self.feed_mode = np.ascontiguousarray(self.feed_mode, dtype=np.int16).reshape(-1)
        self.feed = np.ascontiguousarray(self.feed, dtype=np.float64).reshape(-1)
        self.line = np.ascontiguousarray(self.line, dtype=np.int64).reshape(-1)
        self.tcp = np.ascontiguousarray(self.tcp, dtype=np.bool_).reshape(-1)
        self.tool_number = np.ascontiguousarray(self.tool_number, dtype=np.int32).reshape(-1)
        self.start = np.asarray(self.start, dtype=np.float64).reshape(5)
        for label, arr in (
            ("motion", self.motion),
            ("feed_mode", self.feed_mode),
            ("feed", self.feed),
            ("line", self.line),
            ("tcp", self.tcp),
            ("tool_number", self.tool_number),
        ):
            if len(arr) != n:
                raise ValueError(f"MachineProgram.{label} has {len(arr)} rows, joints has {n}")

    def __len__(self) -> int:
        return len(self.joints)
