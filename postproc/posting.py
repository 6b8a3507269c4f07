"""Toolpaths + machine -> the dialect-neutral posted program shared by all dialects.

``post_toolpaths`` does everything that does not depend on the G-code dialect:

1. inverse kinematics of every CL pose (continuous branch, C unwound, travel limits
   checked with the APT record named in the error; a feed move keeps its branch
   unless its tool axis passes the C axis, ``pole.keeps_branch``),
2. rotary linearisation of simultaneous feed moves (``postproc.linearise``),
3. safe retract and re-orientation before the first operation, at tool changes and
   before every rapid move that turns a rotary axis, except checked links
   (``Toolpath.link``: one joint-mode rapid, as their planner checked it),
4. feeds: G93 inverse time for simultaneous moves, G94 mm/min for linear ones,
   G0 for rapids (``postproc.feeds``),
5. a final travel check of every block, including inserted and safety blocks.

Program coordinates (see docs/postprocessors.md): in joint mode X, Y, Z are the tool
tip in machine coordinates (tool-length compensation G43 active, G54 = machine zero)
and A, C the rotary joints. Under tool-centre-point control X, Y, Z are the tool tip
in the kinematics' world frame (the workpiece frame W shifted by the C rotation
point, ``kins.world_from_workpiece``), A, C still the joints. Safety blocks (retract,
orient, position) are always joint-mode blocks.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from enum import IntEnum
from math import degrees, pi, radians, sqrt
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from impeller_cam.errors import InputError
from impeller_cam.tolerances import DEFAULT_TOLERANCES
from postproc.feeds import ROTARY_STILL, block_feeds
from postproc.kinematics import kinematics_for
from postproc.kinematics.base import Kinematics
from postproc.linearise import lever_bound, linearise
from postproc.pole import keeps_branch
from postproc.posts.numbers import modal_changes, quantise
from postproc.program import FeedMode, MachineProgram, Motion
from postproc.safe_retract import guarded_rapids, safety_joints
from postproc.toolpath import Cutter, MoveKind, Toolpath

if TYPE_CHECKING:
    from postproc.machine import Machine
    from postproc.posts.base import PostOptions


class Role(IntEnum):
    """Why a block is in the program."""

    PATH = 0  # ends on an APT pose
    INSERTED = 1  # added by the rotary linearisation, ends on the CL segment
    RETRACT = 2  # safe retract to the retract height (joint mode)
    ORIENT = 3  # rotary re-orientation at the retract height
    POSITION = 4  # X/Y positioning above the next pose at the retract height


@dataclass(frozen=True)
class OperationInfo:
    """What the dialect writes at the start of an operation.

    Attributes
    ----------
    name : str
        Operation name (raw; dialects sanitise it).
    tool_number : int
        Tool of the operation.
    cutter : Cutter or None
        Cutter description.
    spindle_rpm : float or None
        Spindle speed, rev/min, clockwise when positive; None: leave the spindle as is.
    coolant : bool
        Flood coolant on.
    first_block : int
        Index of the operation's first block.
    tool_change : bool
        The operation starts with a tool change (after its first, retract, block).
    """

    name: str
    tool_number: int
    cutter: Cutter | None
    spindle_rpm: float | None
    coolant: bool
    first_block: int
    tool_change: bool


@dataclass
class PostedProgram:
    """A posted program before formatting: blocks, their origin and the operations.

    Attributes
    ----------
    machine : Machine
        The target machine.
    options : PostOptions
        The options it was posted with.
    blocks : MachineProgram
        ``joints`` holds the programmed words (X, Y, Z mm; A, C rad; NaN where
        unknown and not ``present``), plus motion, feed mode, F word, TCP flag and
        tool per block. ``line`` is -1 (set by the reader of the written file).
    present : (n, 5) bool
        Words the block programs (the others keep their value).
    machine_joints : (n, 5) float64
        Machine joints at the end of each block, tool length 0 (NaN where unknown).
    record : (n,) int64
        APT record (line) of the pose a block moves to; -1 for safety blocks.
    role : (n,) int8
        ``Role`` of each block.
    operation : (n,) int32
        Index into ``operations``.
    operations : tuple of OperationInfo
        One per posted operation.
    source : str
        Name of the CL source (file name) for the header comment.
    """

    machine: Machine
    options: PostOptions
    blocks: MachineProgram
    present: NDArray[np.bool_]
    machine_joints: NDArray[np.float64]
    record: NDArray[np.int64]
    role: NDArray[np.int8]
    operation: NDArray[np.int32]
    operations: tuple[OperationInfo, ...]
    source: str = ""

    def __len__(self) -> int:
        return len(self.record)

    def simultaneous(self, index: int) -> bool:
        """Whether operation ``index`` has simultaneous five-axis blocks (linear moves at
        inverse-time feed: the rotary axes move with the cut).

        Parameters
        ----------
        index : int
            Operation index (``operations`` order).

        Returns
        -------
        bool
        """
        rows = self.operation == index
        return bool(np.any(rows & (self.blocks.motion == Motion.LINEAR)
                           & (self.blocks.feed_mode == FeedMode.INVERSE_TIME)))


@dataclass
class _Chunk:
    """Blocks of one stretch, as parallel arrays (see PostedProgram)."""

    joints: NDArray[np.float64]
    words: NDArray[np.float64]
    present: NDArray[np.bool_]
    motion: NDArray[np.int8]
    feed: NDArray[np.float64]
    length: NDArray[np.float64]
    record: NDArray[np.int64]
    role: NDArray[np.int8]
    tcp: NDArray[np.bool_]
    tool_length: NDArray[np.float64]


def _concat(chunks: list[_Chunk]) -> _Chunk:
    return _Chunk(*(np.concatenate([getattr(c, f) for c in chunks])
                    for f in _Chunk.__dataclass_fields__))


def rounding_error(decimals: int, lever: float, tcp: bool) -> tuple[float, float]:
    """Worst tip (mm) and axis (rad) error from rounding the words to ``decimals``.

    A linear word is off by at most ``0.5e-d`` mm, a rotary word by ``0.5e-d`` deg,
    which moves the tip by up to ``lever`` times that angle (joint mode only).
    """
    half = 0.5 * 10.0 ** (-decimals)
    angle = sqrt(2.0) * radians(half)
    tip = sqrt(3.0) * half + (0.0 if tcp else angle * lever)
    return tip, angle


def _safety_blocks(
    before: NDArray[np.float64] | None,
    target: NDArray[np.float64],
    z_before: float,
    z_after: float,
    length_before: float,
    length_after: float,
) -> _Chunk:
    """Retract, orient and position blocks from ``before`` (or unknown) to ``target``."""
    joints = safety_joints(np.full(5, np.nan) if before is None else before, target,
                           z_before, z_after)
    known = before is not None
    present = np.array([
        [known, known, True, known, known],
        [known, known, True, True, True],
        [True, True, True, True, True],
    ])
    nan = np.nan
    return _Chunk(
        joints=joints, words=joints.copy(), present=present,
        motion=np.full(3, Motion.RAPID, np.int8), feed=np.full(3, nan),
        length=np.zeros(3), record=np.full(3, -1, np.int64),
        role=np.array([Role.RETRACT, Role.ORIENT, Role.POSITION], np.int8),
        tcp=np.zeros(3, bool), tool_length=np.array([length_before, length_after, length_after]),
    )


def _validate(toolpaths: list[Toolpath], machine: Machine, options: PostOptions) -> None:
    if not toolpaths or all(len(tp) == 0 for tp in toolpaths):
        raise InputError("nothing to post: no GOTO records", field="GOTO",
                         accepted="at least one operation with GOTO records")
    if options.tcp and not machine.tcp:
        raise InputError("the machine has no tool-centre-point control", file=machine.source,
                         field="tcp", value=False, accepted="tcp = true in the machine file, "
                         "or post without --tcp")
    for tp in toolpaths:
        if tp.tool_number < 0 or tp.tool_number > 99999:
            raise InputError("tool number out of range", field="LOADTL", value=tp.tool_number,
                             accepted="0..99999")


def post_toolpaths(
    toolpaths: list[Toolpath],
    machine: Machine,
    options: PostOptions,
    *,
    kins: Kinematics | None = None,
    source: str = "",
) -> PostedProgram:
    """Post CL toolpaths for a machine into dialect-neutral blocks.

    Parameters
    ----------
    toolpaths : list of Toolpath
        Operations in order, poses in W.
    machine : Machine
        Target machine (kinematics, limits, TCP capability).
    options : PostOptions
        Tolerances, TCP, safety and number format.
    kins : Kinematics, optional
        Kinematics to use (default ``kinematics_for(machine)``).
    source : str
        Name of the CL source for the header comment.

    Returns
    -------
    PostedProgram

    Raises
    ------
    InputError
        Over-travel (``OverTravelError``, naming the APT record, axis, value and
        limit), a feed move without feed, a tolerance finer than the number format
        allows, a move that cannot be linearised, TCP on a machine without it.
    """
    _validate(toolpaths, machine, options)
    kins = kinematics_for(machine) if kins is None else kins
    world = getattr(kins, "world_from_workpiece", None)
    lower, upper = machine.limits()
    z_max = float(upper[2])
    velocity = np.array([spec.velocity for spec in machine.axes.values()], dtype=np.float64)
    ez = np.array([0.0, 0.0, 1.0, 0.0, 0.0])

    def z_safe(length: float) -> float:
        return options.retract_z if options.retract_z is not None else z_max - length

    chunks: list[_Chunk] = []
    operations: list[OperationInfo] = []
    operation_of: list[NDArray[np.int32]] = []
    n_blocks = 0
    prev_q: NDArray[np.float64] | None = None  # joints at the end of the last block
    prev_pose: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None
    prev_tool: int | None = None
    active_length = 0.0
    for tp in toolpaths:
        if len(tp) == 0:
            continue
        length = float(options.tool_lengths.get(tp.tool_number, 0.0))
        records = tp.source_records.astype(np.int64)
        previous = None if prev_q is None else prev_q + length * ez
        # feed moves stay on their inverse branch unless their axis passes the C axis
        keep = keeps_branch(tp.axis, tp.kind != MoveKind.RAPID, options.angular_tolerance)
        q = kins.inverse(tp.tip, tp.axis, tool_length=length, previous=previous,
                         records=records, keep_branch=keep if keep.any() else None) - length * ez
        tool_change = options.tool_change and tp.tool_number != prev_tool
        if prev_q is None:
            active_length = 0.0 if options.tool_change else length
        rotary_moves = prev_q is None or bool(
            np.abs(q[0, 3:] - prev_q[3:]).max() > ROTARY_STILL)
        safe_start = options.safe_retract and (prev_q is None or tool_change or rotary_moves)
        first_block = n_blocks
        op_chunks: list[_Chunk] = []
        if safe_start:
            op_chunks.append(_safety_blocks(prev_q, q[0], z_safe(active_length),
                                            z_safe(length), active_length, length))
        elif tool_change and prev_q is not None:
            # the tool change needs a retract even when safe_retract is off
            op_chunks.append(_safety_blocks(prev_q, prev_q, z_safe(active_length),
                                            z_safe(length), active_length, length))
        # poses with the move into pose 0 as segment 1 when its start is a known CL pose
        anchored = prev_pose is not None and not safe_start and not tool_change
        if anchored and prev_pose is not None and prev_q is not None:
            tips = np.vstack([prev_pose[0], tp.tip])
            axes = np.vstack([prev_pose[1], tp.axis])
            joints = np.vstack([prev_q, q])
        else:
            start_q = op_chunks[-1].joints[-1] if op_chunks else q[0]
            start_tip, start_axis = kins.forward(start_q[None, :])
            tips = np.vstack([start_tip, tp.tip])
            axes = np.vstack([start_axis, tp.axis])
            joints = np.vstack([start_q, q])
        kinds = np.concatenate([[MoveKind.RAPID], tp.kind]).astype(np.int8)
        feeds = np.concatenate([[np.nan], tp.feed])
        recs = np.concatenate([[-1], records])
        cutting = kinds != MoveKind.RAPID
        step = np.abs(np.diff(joints[:, 3:], axis=0, prepend=joints[:1, 3:])).max(axis=1)
        check = cutting & (step > ROTARY_STILL)
        if not anchored:
            check[1] = False  # from a safety block or an unknown start: no CL segment
        lever = lever_bound(kins, joints)
        tip_err, axis_err = rounding_error(options.decimals, lever, options.tcp)
        chordal = options.chordal_tolerance - tip_err
        angular = options.angular_tolerance - axis_err
        if chordal < 0.25 * options.chordal_tolerance or angular < 0.25 * options.angular_tolerance:
            raise InputError(
                f"tolerance too fine for {options.decimals} decimals (rounding alone moves the "
                f"tip {tip_err:.2g} mm and the axis {degrees(axis_err):.2g} deg)",
                field="--tolerance", value=options.chordal_tolerance,
                accepted=f"a tolerance >= {4 * tip_err:.2g} mm and angular tolerance >= "
                f"{degrees(4 * axis_err):.2g} deg, or more decimals",
            )
        lin = linearise(kins, tips, axes, joints, check, chordal, angular, tcp=options.tcp,
                        singular_tilt=DEFAULT_TOLERANCES.singular_tilt, records=recs,
                        where=f"{source + ': ' if source else ''}operation {tp.name}")
        seg = lin.segment
        motion = np.where(kinds[seg] == MoveKind.RAPID, Motion.RAPID, Motion.LINEAR)
        # checked links: joint-mode rapids, as their planner checked them
        link = np.concatenate([[False], tp.link])[seg] & ~lin.inserted
        words = lin.joints.copy()
        tcp = np.full(len(seg), options.tcp) & ~link
        if options.tcp:
            cl_tip = lin.tip
            words[tcp, :3] = (world(cl_tip) if world is not None else cl_tip)[tcp]
        path = _Chunk(
            joints=lin.joints, words=words, present=np.ones((len(seg), 5), bool),
            motion=motion.astype(np.int8), feed=feeds[seg], length=lin.tip_length,
            record=recs[seg], role=np.where(lin.inserted, Role.INSERTED, Role.PATH).astype(np.int8),
            tcp=tcp, tool_length=np.full(len(seg), length),
        )
        # safe retract before rapids that turn a rotary axis inside the operation
        # (not before checked links: their planner checked the joint move itself)
        if options.safe_retract:
            path = _guard_rapids(path, z_safe(length), length, link)
        op_chunks.append(path)
        op = _concat(op_chunks)
        chunks.append(op)
        operation_of.append(np.full(len(op.record), len(operations), np.int32))
        operations.append(OperationInfo(
            name=tp.name, tool_number=tp.tool_number, cutter=tp.cutter,
            spindle_rpm=tp.spindle_rpm, coolant=tp.coolant, first_block=first_block,
            tool_change=tool_change,
        ))
        n_blocks += len(op.record)
        prev_q = op.joints[-1]
        prev_pose = (tp.tip[-1:], tp.axis[-1:])
        prev_tool = tp.tool_number
        active_length = length
    if options.safe_retract and prev_q is not None:
        final = _safety_blocks(prev_q, prev_q, z_safe(active_length), z_safe(active_length),
                               active_length, active_length)
        end = _Chunk(*(getattr(final, f)[:1] for f in _Chunk.__dataclass_fields__))
        chunks.append(end)
        operation_of.append(np.full(1, len(operations) - 1, np.int32))
    blocks = _concat(chunks)
    operation = np.concatenate(operation_of)
    _check_travel(machine, blocks)
    keep = _not_repeated(blocks, options.decimals)
    blocks = _Chunk(*(getattr(blocks, f)[keep] for f in _Chunk.__dataclass_fields__))
    operation = operation[keep]
    firsts = np.searchsorted(operation, np.arange(len(operations)))
    operations = [replace(op, first_block=int(first)) for op, first in zip(operations, firsts,
                                                                          strict=True)]
    joint_step = np.diff(blocks.joints, axis=0, prepend=blocks.joints[:1])
    joint_step = np.where(np.isfinite(joint_step), joint_step, 0.0)
    mode, f_word = block_feeds(blocks.motion, blocks.feed, blocks.length, joint_step,
                               velocity, blocks.record)
    tool = np.array([operations[int(k)].tool_number for k in range(len(operations))],
                    dtype=np.int32)[operation]
    # the retract that opens a tool change still runs with the previous tool (0: none)
    for k, info in enumerate(operations):
        first = info.first_block
        if info.tool_change and first < len(tool) and blocks.role[first] == Role.RETRACT:
            tool[first] = operations[k - 1].tool_number if k else 0
    program = MachineProgram(
        joints=blocks.words, motion=blocks.motion, feed_mode=mode, feed=f_word,
        line=np.full(len(blocks.record), -1, np.int64), tcp=blocks.tcp, tool_number=tool,
        start=np.full(5, np.nan),
    )
    return PostedProgram(
        machine=machine, options=options, blocks=program, present=blocks.present,
        machine_joints=blocks.joints, record=blocks.record, role=blocks.role,
        operation=operation, operations=tuple(operations), source=source,
    )


def _guard_rapids(path: _Chunk, z: float, length: float,
                  link: NDArray[np.bool_] | None = None) -> _Chunk:
    """Insert retract / orient / position before each rapid that turns a rotary axis.

    Rows flagged in ``link`` (checked links, ``Toolpath.link``) are left as they are.
    """
    guarded = guarded_rapids(path.joints, path.motion == Motion.RAPID, link)
    if len(guarded) == 0:
        return path
    pieces: list[_Chunk] = []
    start = 0
    fields = _Chunk.__dataclass_fields__
    for j in guarded:
        pieces.append(_Chunk(*(getattr(path, f)[start:j] for f in fields)))
        pieces.append(_safety_blocks(path.joints[j - 1], path.joints[j], z, z, length, length))
        start = int(j)
    pieces.append(_Chunk(*(getattr(path, f)[start:] for f in fields)))
    return _concat(pieces)


def _not_repeated(blocks: _Chunk, decimals: int) -> NDArray[np.bool_]:
    """Rows that change a word as written with ``decimals`` (or switch TCP): the others go.

    A block whose words all print as in the block before would be an empty move
    (and ``G1`` without an axis word is an error in RS274/NGC).
    """
    n = len(blocks.record)
    words = as_degrees(blocks.words)
    known = np.isfinite(words) & blocks.present
    changed = np.zeros(n, dtype=bool)
    for j in range(5):
        q = quantise(np.where(known[:, j], words[:, j], 0.0), decimals)
        changed |= modal_changes(q, known[:, j])
    switch = np.concatenate([[True], blocks.tcp[1:] != blocks.tcp[:-1]]) if n else changed
    return np.asarray(changed | switch, dtype=np.bool_)


def _check_travel(machine: Machine, blocks: _Chunk) -> None:
    """Travel check of every block with the gauge length added to Z (known rows only)."""
    physical = blocks.joints.copy()
    physical[:, 2] += blocks.tool_length
    lower, upper = machine.limits()
    # unknown words (program start) do not move: test them at an in-range value
    physical = np.where(np.isfinite(physical), physical, np.clip(0.0, lower, upper))
    path = blocks.record >= 0
    machine.check_limits(physical[path], blocks.record[path])
    machine.check_limits(physical[~path])


def as_degrees(words: NDArray[np.float64]) -> NDArray[np.float64]:
    """Program words in user units: X, Y, Z mm and A, C degrees, ``(n, 5)``."""
    out = np.array(words, dtype=np.float64, copy=True)
    out[:, 3:] *= 180.0 / pi
    return out


__all__ = [
    "FeedMode",
    "OperationInfo",
    "PostedProgram",
    "Role",
    "as_degrees",
    "post_toolpaths",
    "rounding_error",
]
