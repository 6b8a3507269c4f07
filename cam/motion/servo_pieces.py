"""A long program simulated piece by piece, split where the axes are at rest.

Sampled at the controller period a finishing program of an hour is millions of samples
per axis, and the servo simulation holds several arrays of them (command, response,
tool poses, contour vectors). The commanded motion ends in position before and after
every rapid (``program_servo.settle_time``: the command holds until the axes have
settled), so the program falls apart there into pieces whose simulations do not
depend on each other but for what the settling leaves (``e^-4`` of the error at the
stop, a few microns): each piece starts with a rapid from rest and is simulated with
the blocks since the rapid before it as a warm-up (their results taken from the
piece before), which leaves ``e^-8``. Pieces are as long as ``budget`` samples allow
(a piece between two rapids longer than that stays whole); the per-block results are
put back together and the RMS values combined over all samples (``ErrorSums``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from postproc.program import MachineProgram, Motion

if TYPE_CHECKING:
    from cam.motion.contour import ContourError
    from cam.motion.surface_error import BlockContact

__all__ = ["ErrorSums", "contact_rows", "program_pieces", "sub_program"]


def program_pieces(motion: NDArray[np.int8], seconds: NDArray[np.float64], dt: float,
                   budget: int) -> list[tuple[int, int]]:
    """Block ranges ``(first, stop)`` to simulate apart, each starting at a rapid.

    Parameters
    ----------
    motion : (n,) int8
        ``Motion`` of each block.
    seconds : (n,) float64
        Estimated time of each block (holds included), s.
    dt : float
        Sample period, s.
    budget : int
        Samples a piece may take; a piece is cut at the last rapid that keeps it
        within the budget (none: at the first rapid after it).

    Returns
    -------
    list of (int, int)
        Consecutive ranges covering ``0 .. n``.
    """
    n = len(motion)
    clock = np.concatenate([[0.0], np.cumsum(seconds)]) / dt
    cuts: list[int] = [0]
    fits: int | None = None  # the last rapid that keeps the open piece within the budget
    for k in np.flatnonzero(np.asarray(motion) == Motion.RAPID).tolist():
        if k == cuts[-1]:
            continue
        if clock[k] - clock[cuts[-1]] > budget:
            cuts.append(fits if fits is not None else k)
            fits = k if k > cuts[-1] else None
        else:
            fits = k
    if clock[n] - clock[cuts[-1]] > budget and fits is not None and fits > cuts[-1]:
        cuts.append(fits)
    edges = cuts + [n]
    return [(a, b) for a, b in zip(edges[:-1], edges[1:], strict=True) if b > a]


def sub_program(program: MachineProgram, joints: NDArray[np.float64], first: int,
                stop: int) -> MachineProgram:
    """Blocks ``first .. stop`` as a joint-space program from the joints before them.

    ``joints`` are the program's joint targets with tool-centre-point blocks already
    mapped (``program_servo.program_joints``), so the piece has no TCP blocks.
    """
    start = program.start if first == 0 else joints[first - 1]
    rows = slice(first, stop)
    return MachineProgram(joints=joints[rows], motion=program.motion[rows],
                          feed_mode=program.feed_mode[rows], feed=program.feed[rows],
                          line=program.line[rows], tcp=np.zeros(stop - first, bool),
                          tool_number=program.tool_number[rows], start=start)


def contact_rows(contact: BlockContact | None, first: int, stop: int
                 ) -> BlockContact | None:
    """The contact of blocks ``first .. stop`` (None stays None)."""
    if contact is None:
        return None
    from cam.motion.surface_error import BlockContact

    rows = slice(first, stop)
    return BlockContact(gap=contact.gap[rows], normal=contact.normal[rows],
                        contact=contact.contact[rows], radius=contact.radius)


def _block_max(values: NDArray[np.float64], index: NDArray[np.int64], n: int
               ) -> NDArray[np.float64]:
    out = np.zeros(n)
    np.maximum.at(out, index, values)
    return out


@dataclass
class ErrorSums:
    """Per-block maxima and RMS sums of one simulated program, filled piece by piece.

    Attributes
    ----------
    contour, tool_axis, tracking, surface : (n,) float64
        Largest contour (mm), tool-axis (deg), tracking (mm) and surface-normal (mm)
        error inside each block.
    gouge : (n,) float64
        Largest depth of the ball centre's deviation *into* the part along the
        surface normal inside each block, mm (0: it stayed on or off the surface).
    """

    n: int
    contour: NDArray[np.float64] = field(init=False)
    tool_axis: NDArray[np.float64] = field(init=False)
    tracking: NDArray[np.float64] = field(init=False)
    surface: NDArray[np.float64] = field(init=False)
    gouge: NDArray[np.float64] = field(init=False)
    _feed: list[float] = field(default_factory=lambda: [0.0, 0.0])
    _touch: list[float] = field(default_factory=lambda: [0.0, 0.0])

    def __post_init__(self) -> None:
        self.contour, self.tool_axis = np.zeros(self.n), np.zeros(self.n)
        self.tracking, self.surface = np.zeros(self.n), np.zeros(self.n)
        self.gouge = np.zeros(self.n)

    def add(self, first: int, stop: int, index: NDArray[np.int64],
            feed: NDArray[np.bool_], error: ContourError,
            contact: BlockContact | None, skip: int = 0,
            keep: NDArray[np.bool_] | None = None) -> None:
        """One piece's samples: blocks ``first - skip .. stop`` simulated, ``index``
        the samples' block in that run, ``feed`` the samples of feed blocks,
        ``contact`` the run's rows (``contact_rows``); the first ``skip`` blocks
        (a warm-up, simulated with the piece before) and samples outside ``keep``
        (the settling tail after a piece that is not the program's last) are not
        kept."""
        from cam.motion.surface_error import surface_component

        n = stop - first
        keep = (index >= skip) if keep is None else keep & (index >= skip)
        at = index[keep] - skip
        self.contour[first:stop] = _block_max(error.contour[keep], at, n)
        self.tool_axis[first:stop] = _block_max(error.tool_axis[keep], at, n)
        self.tracking[first:stop] = _block_max(error.tracking[keep], at, n)
        counted = feed & keep
        self._feed[0] += float(np.sum(error.contour[counted] ** 2))
        self._feed[1] += float(counted.sum())
        if contact is not None:
            signed = surface_component(error, index, contact)[keep]
            normal = np.abs(signed)
            touching = contact.contact[index][keep]
            self.surface[first:stop] = _block_max(normal, at, n)
            self.gouge[first:stop] = _block_max(np.maximum(-signed, 0.0), at, n)
            self._touch[0] += float(np.sum(normal[touching] ** 2))
            self._touch[1] += float(touching.sum())

    @property
    def feed_rms(self) -> float:
        """RMS contour error over the samples of feed blocks, mm."""
        return float(np.sqrt(self._feed[0] / self._feed[1])) if self._feed[1] else 0.0

    @property
    def surface_rms(self) -> float:
        """RMS surface-normal error over the samples of blocks in contact, mm."""
        return float(np.sqrt(self._touch[0] / self._touch[1])) if self._touch[1] else 0.0
