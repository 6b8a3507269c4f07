"""The toolpath: tool poses in the workpiece frame W, the currency between CAM and post.

A ``Toolpath`` is one operation: arrays of tool tips and tool axes with a feed
and a move kind per pose. It is what APT CLDATA files hold (one operation per
``LOADTL``/operation block), so paths from other CAM systems can be posted and ours
can be read by them. It lives in ``postproc`` because the APT reader/writer and the
post-processors consume it; ``cam`` produces it.

Conventions (see docs/architecture.md): ``tip`` is the lowest point of the tool on
its axis, ``axis`` is the unit vector from the tip towards the spindle, lengths in
mm, feeds in mm/min at this boundary object.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import IntEnum

import numpy as np
from numpy.typing import NDArray


class MoveKind(IntEnum):
    """What a pose's incoming move is."""

    RAPID = 0
    FEED = 1
    PLUNGE = 2
    RETRACT = 3


@dataclass(frozen=True)
class Cutter:
    """The APT ``CUTTER/`` description.

    Attributes
    ----------
    diameter : float
        Cutter diameter, mm.
    corner_radius : float
        Corner radius, mm (half the diameter: a ball-end mill).
    length : float
        Cutting length, mm (0: not given).
    """

    diameter: float
    corner_radius: float = 0.0
    length: float = 0.0

    @property
    def is_ball(self) -> bool:
        """True when the corner radius is half the diameter (a ball-end mill)."""
        return abs(self.corner_radius - 0.5 * self.diameter) < 1e-9


@dataclass
class Toolpath:
    """One operation's tool poses in the workpiece frame.

    Attributes
    ----------
    tip : (n, 3) float64
        Tool tip positions, mm.
    axis : (n, 3) float64
        Unit tool axis vectors, tip towards spindle.
    feed : (n,) float64
        Feed of the move that ends at each pose, mm/min; NaN for rapids.
    kind : (n,) int8
        ``MoveKind`` of the move that ends at each pose.
    segment : (n,) int32
        Index of the fixed-orientation (3+2) segment a pose belongs to, or -1 for
        simultaneous five-axis poses. Poses of one segment share one axis.
    name : str
        Operation name (appears in comments and reports).
    tool_number : int
        ``LOADTL`` number.
    cutter : Cutter or None
        ``CUTTER/`` description.
    spindle_rpm : float or None
        ``SPINDL/`` speed, rev/min, clockwise when positive.
    coolant : bool
        ``COOLNT/ON`` requested.
    source_records : (n,) int32
        For poses read from a file, the 1-based line number of their GOTO record;
        -1 for poses made in memory.
    link : (n,) bool
        Rapid moves that are *checked links*: the planner collision-checked the move
        into this pose as the machine executes a rapid in joint mode (every joint
        linear between the two poses' joints, the post's inverse kinematics), so the
        post writes it as one joint-mode ``G0`` with no safe retract around it
        (``$$ LINK`` before ``RAPID`` in APT). Plain rapids (False) keep the post's
        retract to safe Z when they turn a rotary axis.
    """

    tip: NDArray[np.float64]
    axis: NDArray[np.float64]
    feed: NDArray[np.float64]
    kind: NDArray[np.int8]
    segment: NDArray[np.int32] = field(default_factory=lambda: np.zeros(0, np.int32))
    name: str = "operation"
    tool_number: int = 1
    cutter: Cutter | None = None
    spindle_rpm: float | None = None
    coolant: bool = False
    source_records: NDArray[np.int32] = field(default_factory=lambda: np.zeros(0, np.int32))
    link: NDArray[np.bool_] = field(default_factory=lambda: np.zeros(0, bool))

    def __post_init__(self) -> None:
        self.tip = np.ascontiguousarray(self.tip, dtype=np.float64).reshape(-1, 3)
        n = len(self.tip)
        self.axis = np.ascontiguousarray(self.axis, dtype=np.float64).reshape(-1, 3)
        self.feed = np.ascontiguousarray(self.feed, dtype=np.float64).reshape(-1)
        self.kind = np.ascontiguousarray(self.kind, dtype=np.int8).reshape(-1)
        if len(self.segment) == 0:
            self.segment = np.full(n, -1, np.int32)
        self.segment = np.ascontiguousarray(self.segment, dtype=np.int32).reshape(-1)
        if len(self.source_records) == 0:
            self.source_records = np.full(n, -1, np.int32)
        self.source_records = np.ascontiguousarray(self.source_records, dtype=np.int32)
        if len(self.link) == 0:
            self.link = np.zeros(n, bool)
        self.link = np.ascontiguousarray(self.link, dtype=bool).reshape(-1)
        for label, arr in (
            ("axis", self.axis),
            ("feed", self.feed),
            ("kind", self.kind),
            ("segment", self.segment),
            ("source_records", self.source_records),
            ("link", self.link),
        ):
            if len(arr) != n:
                raise ValueError(f"Toolpath.{label} has {len(arr)} rows, tip has {n}")
        if np.any(self.link & (self.kind != MoveKind.RAPID)):
            row = int(np.flatnonzero(self.link & (self.kind != MoveKind.RAPID))[0])
            raise ValueError(f"Toolpath.link row {row}: only a rapid move can be a checked link")
        norms = np.linalg.norm(self.axis, axis=1)
        if n and not np.all(np.abs(norms - 1.0) < 1e-6):
            bad = int(np.argmax(np.abs(norms - 1.0)))
            raise ValueError(f"Toolpath.axis row {bad} is not a unit vector: {self.axis[bad]}")

    def __len__(self) -> int:
        return len(self.tip)
