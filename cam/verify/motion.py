"""NC program + machine -> straight fixed-axis tool moves in the workpiece frame.

Interpolation follows the controller:

* **joint mode** (``tcp`` False): all five joints move linearly; the tip and the axis
  in W follow the forward kinematics of the interpolated joints (a curve when a
  rotary axis turns);
* **TCP mode** (``tcp`` True, LinuxCNC M428 / G43.4): the programmed X, Y, Z are the
  tip in the kinematics' world frame and move linearly; A and C move linearly; the
  machine joints come from the kinematics (for the over-travel check).

Error bound of the sweep
------------------------
A block whose axis turns is cut into ``n`` sub-moves; each is swept as a straight
move between the true sub-move end tips with the axis fixed at the true axis of the
sub-move's mid parameter. At any parameter the swept tool differs from the true tool
by at most ``e_chord + reach * e_angle``: ``e_chord`` is the distance of the true tip
from the straight sub-move (zero in TCP mode and for blocks with fixed rotaries),
``e_angle`` the angle between the true axis and the fixed one, and ``reach`` the
largest distance of a cutter point from the tip (a rotation by ``e_angle`` about the
tip moves no cutter point further than ``reach * e_angle``). The Hausdorff distance
between swept and true removed volumes is therefore at most that sum. ``n`` is chosen
so that ``reach * e_angle <= tol/2`` and ``e_chord <= tol/2``, both measured at the
sub-move's quarter points (for the near-uniform rotation inside one block the
largest deviation of the axis from the mid axis is at the sub-move ends, and the
sagitta of the tip path at its middle) and doubled until they hold.

The bound holds per primitive with its own reach: the ball and the lower flutes need
several times fewer sub-moves than the flutes' top. ``ToolShape`` gives each cutter
primitive a level ``l`` (within ``reach / 2**l`` of the tip; flute sides are split
there) and each level its reach (``level_reach``). With ``level_reach``, level ``l`` is
swept along chunks of ``2**l`` sub-moves, halved on a block until every chunk passes
the sub-moves' test for that reach, each chunk before the sub-moves it spans (higher
levels first); the sub-moves sweep level 0 and the body (``ToolMoves.part``). A block's
ends keep its id either way; what changes is the order in which the pieces meet a ray
inside a chunk, and the longest cut of one entry along a ray (a chunk is longer).

Time: G94 blocks take ``length / F`` (length of the X, Y, Z path; of the rotary path in
degrees when the linear axes do not move, LinuxCNC's rule); G93 blocks ``1 / F``
minutes; rapids the longest axis travel over that axis's maximum velocity.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cam.verify.toolshape import ALL_LEVELS
from postproc.program import FeedMode, MachineProgram, Motion

#: Sub-moves per block at most (guards against a runaway subdivision).
MAX_SUBMOVES = 4096


@dataclass
class ToolMoves:
    """The straight fixed-axis moves of one program.

    Attributes
    ----------
    tips : (m, 3) float64
        Start tip of each sub-move, mm, workpiece frame W.
    moves : (m, 3) float64
        Tip displacement of each sub-move, mm.
    axes : (m, 3) float64
        Unit tool axis held during each sub-move.
    block : (m,) int64
        Block (row of the MachineProgram) of each sub-move.
    end_tip, end_axis : (b, 3) float64
        Tool pose at the end of each block.
    joints : (b, 5) float64
        Machine joints at the end of each block (TCP blocks mapped to joints).
    duration : (b,) float64
        Block durations, s.
    overtravel : list of dict
        Over-travel findings: ``block``, ``axis``, ``value``, ``limit`` (user units).
    part : (m,) int8
        Levels each entry sweeps (bit ``l``: the primitives of level ``l``,
        ``ToolShape.cutter_level``; level 0 holds the body): a sub-move has bit 0 and
        the bits of every level not swept along chunks on its block (``ALL_LEVELS``:
        the whole tool), a chunk only its level's bit.
    """

    tips: NDArray[np.float64]
    moves: NDArray[np.float64]
    axes: NDArray[np.float64]
    block: NDArray[np.int64]
    end_tip: NDArray[np.float64]
    end_axis: NDArray[np.float64]
    joints: NDArray[np.float64]
    duration: NDArray[np.float64]
    overtravel: list[dict[str, Any]] = field(default_factory=list)
    part: NDArray[np.int8] | None = None


def _angles(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Angles between unit vectors row by row, rad (stable for small angles)."""
    cross = np.linalg.norm(np.cross(a, b), axis=-1)
    dot = np.sum(a * b, axis=-1)
    angles: NDArray[np.float64] = np.arctan2(cross, dot)
    return angles


class _Poser:
    """Tool pose at a fraction of a block, for joint-mode and TCP blocks."""

    def __init__(
        self, kins: Any, program: MachineProgram, tool_length: float, start_at_first: bool
    ) -> None:
        self.kins = kins
        self.tool_length = tool_length
        joints = np.vstack([program.start[None, :], program.joints])
        if start_at_first and len(program):
            joints[0] = joints[1]
        self.tcp = program.tcp
        # world-frame offset of W: tip_W = world - offset (zero for a machine without one)
        world = getattr(kins, "world_from_workpiece", None)
        self.offset = np.zeros(3) if world is None else np.asarray(world(np.zeros((1, 3))))[0]
        # pose at each block end (index 0: start); TCP rows keep their programmed tip
        tip, axis = kins.forward(joints, tool_length)
        tcp_rows = np.concatenate([[False], program.tcp])
        tip[tcp_rows] = joints[tcp_rows, :3] - self.offset
        if start_at_first and len(program):
            tip[0], axis[0] = tip[1], axis[1]
        # the machine joints at each block end: a TCP row's X, Y, Z are a tip, not
        # joints, so a joint-mode block that starts where a TCP block ended (M429,
        # TRAFOOF, G49 after TCP) starts from the joints of that tip
        true = joints.copy()
        if tcp_rows.any():
            true[tcp_rows, :3] = linear_joints_for(kins, tip[tcp_rows], joints[tcp_rows],
                                                   tool_length)
            if start_at_first and len(program):
                true[0] = true[1]
        self.joints_prog = true
        self.tip = tip
        self.axis = axis

    def at(self, block: NDArray[np.int64], frac: NDArray[np.float64]
           ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Tip and axis (n, 3) inside blocks ``block`` at fractions ``frac``."""
        j0 = self.joints_prog[block]
        j1 = self.joints_prog[block + 1]
        joints = j0 + frac[:, None] * (j1 - j0)
        tip, axis = self.kins.forward(joints, self.tool_length)
        tcp = self.tcp[block]
        if tcp.any():
            lin = self.tip[block] + frac[:, None] * (self.tip[block + 1] - self.tip[block])
            tip[tcp] = lin[tcp]
        return tip, axis

    def machine_joints(self, block: NDArray[np.int64], frac: NDArray[np.float64]
                       ) -> NDArray[np.float64]:
        """Machine joints (n, 5) at fractions of blocks (TCP tips mapped through kinematics)."""
        j0 = self.joints_prog[block]
        j1 = self.joints_prog[block + 1]
        joints: NDArray[np.float64] = j0 + frac[:, None] * (j1 - j0)
        tcp = self.tcp[block]
        if tcp.any():
            tip, _ = self.at(block[tcp], frac[tcp])
            joints[tcp, :3] = linear_joints_for(self.kins, tip, joints[tcp], self.tool_length)
        return joints


def linear_joints_for(
    kins: Any, tip: NDArray[np.float64], joints: NDArray[np.float64], tool_length: float
) -> NDArray[np.float64]:
    """X, Y, Z joints (n, 3) that put the tip at ``tip`` for the rotary joints given.

    For fixed rotary joints the forward map is affine in X, Y, Z: ``tip = M J + c``.
    ``M`` and ``c`` come from four forward evaluations, so this works for any
    registered kinematics.
    """
    n = len(tip)
    probe = np.repeat(joints[:, None, :], 4, axis=1).copy()
    probe[:, :, :3] = 0.0
    for c in range(3):
        probe[:, c + 1, c] = 1.0
    out, _ = kins.forward(probe.reshape(-1, 5), tool_length)
    out = out.reshape(n, 4, 3)
    c0 = out[:, 0, :]
    m = np.stack([out[:, c + 1, :] - c0 for c in range(3)], axis=2)  # (n, 3, 3) columns
    return np.linalg.solve(m, (tip - c0)[:, :, None])[:, :, 0]


def _block_durations(
    program: MachineProgram, machine: Any, joints: NDArray[np.float64]
) -> NDArray[np.float64]:
    delta = np.diff(joints, axis=0)
    linear = np.linalg.norm(delta[:, :3], axis=1)
    rotary = np.degrees(np.linalg.norm(delta[:, 3:], axis=1))
    length = np.where(linear > 1e-12, linear, rotary)
    with np.errstate(divide="ignore", invalid="ignore"):
        feed_time = np.where(
            program.feed_mode == int(FeedMode.INVERSE_TIME),
            60.0 / program.feed,
            60.0 * length / program.feed,
        )
        velocity = np.array([spec.velocity for spec in machine.axes.values()], np.float64)
        rapid_time = np.max(np.abs(delta) / velocity[None, :], axis=1)
    rapid = program.motion == int(Motion.RAPID)
    out = np.where(rapid, rapid_time, feed_time)
    return np.where(np.isfinite(out), out, 0.0)


def _overtravel(
    machine: Any,
    joints: NDArray[np.float64],
    block: NDArray[np.int64],
    block_start: NDArray[np.float64],
) -> list[dict[str, Any]]:
    """Largest over-travel per block and axis (user units).

    A block counts when it drives an axis beyond a limit, i.e. further out than the
    axis was at the block's start (a block coming back from beyond a limit is not a
    new over-travel; the block that went there is reported).
    """
    lower, upper = machine.limits()
    excess = np.maximum(lower - joints, joints - upper)
    start = block_start[block]
    excess_start = np.maximum(lower - start, start - upper)
    bad = (excess > 1e-9) & (excess > excess_start + 1e-9)
    worst: dict[tuple[int, int], int] = {}
    for row, col in zip(*np.nonzero(bad), strict=True):
        key = (int(block[row]), int(col))
        if key not in worst or excess[row, col] > excess[worst[key], col]:
            worst[key] = int(row)
    found: list[dict[str, Any]] = []
    names = list(machine.axes)
    for (b, col), row in sorted(worst.items()):
        value = float(joints[row, col])
        limit = float(upper[col] if value > upper[col] else lower[col])
        rotary = names[col] in ("A", "B", "C")
        found.append(
            {
                "block": b,
                "axis": names[col],
                "value": float(np.degrees(value)) if rotary else value,
                "limit": float(np.degrees(limit)) if rotary else limit,
                "unit": "deg" if rotary else "mm",
            }
        )
    return found


def _spans(owner: NDArray[np.int64], n: NDArray[np.int64]
           ) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """``n[i]`` items for each ``owner[i]``: every item's owner and its index among
    its owner's (0 .. n - 1)."""
    first = np.cumsum(n) - n
    return np.repeat(owner, n), np.arange(int(n.sum())) - np.repeat(first, n)


def _fails(tips_q: NDArray[np.float64], axes_q: NDArray[np.float64], reach: float,
           half: float, longest: float = math.inf) -> NDArray[np.bool_]:
    """Straight moves, given the true tips and axes (5, n, 3) at their quarter points,
    whose fixed mid axis or straight tip leave ``half`` at a reach of ``reach`` (module
    doc), or whose tip travels farther than ``longest``."""
    angle = np.max(_angles(axes_q, axes_q[2][None]), axis=0)
    seg = tips_q[4] - tips_q[0]
    length2 = np.maximum(np.sum(seg * seg, axis=1), 1e-300)
    worst = np.zeros(tips_q.shape[1])
    for q in (1, 2, 3):
        rel = tips_q[q] - tips_q[0]
        along = np.sum(rel * seg, axis=1) / length2
        off = rel - along[:, None] * seg
        worst = np.maximum(worst, np.linalg.norm(off, axis=1))
    bad: NDArray[np.bool_] = (reach * angle > half) | (worst > half) | (length2 > longest**2)
    return bad


def _outside(poser: Any, block: NDArray[np.int64], c0: NDArray[np.float64],
             c1: NDArray[np.float64], reach: float, half: float,
             longest: float = math.inf) -> NDArray[np.bool_]:
    """``_fails`` of the moves of ``block`` from parameter ``c0`` to ``c1``."""
    quarter = np.stack([c0, 0.75 * c0 + 0.25 * c1, 0.5 * (c0 + c1), 0.25 * c0 + 0.75 * c1, c1])
    tips_q, axes_q = poser.at(np.tile(block, 5), quarter.ravel())
    return _fails(tips_q.reshape(5, -1, 3), axes_q.reshape(5, -1, 3), reach, half, longest)


class _HalfSteps:
    """True tips and axes at every half sub-move of every block: ``h = 0 .. 2 count``
    at the parameter ``h / (2 count)`` (even ``h``: the sub-moves' ends, odd: their
    middles), each evaluated once."""

    def __init__(self, poser: Any, count: NDArray[np.int64]) -> None:
        steps = 2 * count + 1
        self.first = np.cumsum(steps) - steps
        block, index = _spans(np.arange(len(count), dtype=np.int64), steps)
        self.tip, self.axis = poser.at(block, index / (2 * count[block]))

    def at(self, block: NDArray[np.int64], h: NDArray[np.int64]
           ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Tips and axes at half steps ``h`` of ``block``."""
        row = self.first[block] + h
        return self.tip[row], self.axis[row]


def _chunk_sizes(poser: Any, half_steps: _HalfSteps, count: NDArray[np.int64],
                 reach: float, start: int, tolerance: float, longest: float
                 ) -> NDArray[np.int64]:
    """Sub-moves per chunk of a level reaching ``reach``: ``start`` (``2**l``), halved
    on the blocks where a chunk leaves the tolerance (the sub-moves' test) or its tip
    travels farther than ``longest`` until none does; 1 on blocks of fewer than two
    sub-moves. A chunk of an even number of sub-moves has its quarter points on half
    steps (``half_steps``); a block's last, shorter chunk may need its own."""
    size = np.where(count >= 2, np.minimum(start, count), 1).astype(np.int64)
    pending = np.flatnonzero(size > 1)
    while len(pending):
        cb, c = _spans(pending, -(-count[pending] // size[pending]))
        j0 = c * size[cb]
        j1 = np.minimum(j0 + size[cb], count[cb])
        span = j1 - j0
        even = span % 2 == 0
        bad = np.zeros(len(cb), np.bool_)
        if even.any():
            h = np.stack([2 * j0, 2 * j0 + span // 2, j0 + j1, 2 * j1 - span // 2, 2 * j1])
            tips_q, axes_q = half_steps.at(np.tile(cb[even], 5), h[:, even].ravel())
            bad[even] = _fails(tips_q.reshape(5, -1, 3), axes_q.reshape(5, -1, 3), reach,
                               0.5 * tolerance, longest)
        odd = ~even
        if odd.any():
            ob = cb[odd]
            bad[odd] = _outside(poser, ob, j0[odd] / count[ob], j1[odd] / count[ob], reach,
                                0.5 * tolerance, longest)
        failing = np.unique(cb[bad])
        size[failing] //= 2
        pending = failing[size[failing] > 1]
    return size


def _counts(poser: Any, n_blocks: int, reach: float, tolerance: float) -> NDArray[np.int64]:
    """Sub-moves per block so that a tool reaching ``reach`` from the tip is swept
    within ``tolerance`` (module doc)."""
    blocks = np.arange(n_blocks, dtype=np.int64)
    # initial subdivision from the axis turn sampled at 8 points per block
    samples = 8
    frac = np.tile(np.linspace(0.0, 1.0, samples + 1), n_blocks)
    rows = np.repeat(blocks, samples + 1)
    _, axis = poser.at(rows, frac)
    axis = axis.reshape(n_blocks, samples + 1, 3)
    turn = _angles(axis[:, :-1], axis[:, 1:]).sum(axis=1)
    half = 0.5 * tolerance
    count = np.maximum(1, np.ceil(reach * turn / tolerance)).astype(np.int64)
    count[turn < 1e-12] = 1
    rotating = (turn >= 1e-12) | ~np.all(
        poser.joints_prog[1:, 3:] == poser.joints_prog[:-1, 3:], axis=1
    )
    # a block that passes keeps its count and would pass again: each round checks only
    # the blocks whose count the round before doubled
    pending = blocks[rotating]
    for _ in range(12):
        if not len(pending):
            break
        cb, index = _spans(pending, count[pending])
        c0 = index / count[cb]
        c1 = (index + 1) / count[cb]
        bad = _outside(poser, cb, c0, c1, reach, half)
        if not bad.any():
            break
        failing = np.unique(cb[bad])
        count[failing] = np.minimum(2 * count[failing], MAX_SUBMOVES)
        pending = failing[count[failing] < MAX_SUBMOVES]
    return np.asarray(count, dtype=np.int64)


def _sequence(count: NDArray[np.int64], chunks: list[NDArray[np.int64]]
              ) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64],
                         NDArray[np.int8]]:
    """Block, start and end sub-move boundary (``j``: the block's parameter
    ``j / count``) and level bits (``ToolMoves.part``) of every entry, in sweep order.

    Per block, ``count`` sub-moves sweep every level but those that level ``l``
    (``chunks[l - 1]`` per block) sweeps along chunks of that many sub-moves, each chunk
    just before the first sub-move it spans, the higher levels first; a level whose
    chunk is one sub-move, or that ``chunks`` does not name, rides on the sub-moves.
    """
    n_blocks = len(count)
    blocks = np.arange(n_blocks, dtype=np.int64)
    sub_block, index = _spans(blocks, count)
    bits = np.full(len(sub_block), ALL_LEVELS, np.int8)
    parts_block, parts_j0, parts_j1, parts_bits, parts_order = \
        [sub_block], [index], [index + 1], [bits], [np.full(len(sub_block), len(chunks) + 1)]
    for lv, chunk in enumerate(chunks, start=1):
        bits[chunk[sub_block] > 1] &= np.int8(ALL_LEVELS & ~(1 << lv))
        ch_block, c = _spans(blocks, np.where(chunk > 1, -(-count // chunk), 0))
        size = chunk[ch_block]
        parts_block.append(ch_block)
        parts_j0.append(c * size)
        parts_j1.append(np.minimum((c + 1) * size, count[ch_block]))
        parts_bits.append(np.full(len(ch_block), 1 << lv, np.int8))
        parts_order.append(np.full(len(ch_block), len(chunks) + 1 - lv))
    block = np.concatenate(parts_block)
    j0 = np.concatenate(parts_j0)
    j1 = np.concatenate(parts_j1)
    order = np.lexsort((np.concatenate(parts_order), j0, block))
    return block[order], j0[order], j1[order], np.concatenate(parts_bits)[order]


def program_moves(
    program: MachineProgram,
    machine: Any,
    kins: Any,
    reach: float,
    tolerance: float,
    tool_length: float = 0.0,
    start_at_first: bool = True,
    level_reach: tuple[float, ...] = (),
) -> ToolMoves:
    """Expand a program into straight fixed-axis sub-moves within ``tolerance``.

    Parameters
    ----------
    program : MachineProgram
        Blocks read from the NC file.
    machine : Machine
        Limits and axis velocities.
    kins : Kinematics
        ``forward(joints, tool_length) -> (tip, axis)`` in W.
    reach : float
        Largest distance of a cutter point from the tip, mm (``ToolShape.reach``).
    tolerance : float
        Bound on the distance between the swept and the true tool, mm (module doc).
    tool_length : float
        See ``Kinematics.forward`` (0: the program commands the tip).
    start_at_first : bool
        The machine position before an NC file is unknown (the reader starts from
        zero joints); True makes the first block a move from its own end pose, so
        the unknown approach neither cuts nor collides. False sweeps it from
        ``program.start``.
    level_reach : tuple of float
        Reach of the tool's primitives of level ``1, 2, ...`` (``ToolShape.level_reach``,
        0: none): on a turning block level ``l`` is swept along chunks of up to ``2**l``
        sub-moves that keep ``tolerance`` for that reach (module doc). Empty: the whole
        tool on every sub-move.

    Returns
    -------
    ToolMoves
        Straight fixed-axis sub-moves (tips mm, axes) tied to their NC lines.
    """
    n_blocks = len(program)
    poser = _Poser(kins, program, tool_length, start_at_first)
    blocks = np.arange(n_blocks, dtype=np.int64)
    count = _counts(poser, n_blocks, reach, tolerance)
    # every entry's ends and middle, and the chunks' tests, from one evaluation of each
    # half sub-move (a sub-move ends where the next starts)
    half_steps = _HalfSteps(poser, count)
    # a level's chunk spans whole sub-moves and keeps the tolerance for its reach; it
    # runs ahead of the body (probed on the sub-moves) by less than half the height
    # between the level and the top of the flutes, so it never cuts stock the body
    # touches before it gets there
    chunks = [_chunk_sizes(poser, half_steps, count, lv_reach, 2**lv, tolerance,
                           0.5 * (reach - lv_reach))
              if 0.0 < lv_reach < reach else np.ones(n_blocks, np.int64)
              for lv, lv_reach in enumerate(level_reach, start=1)]
    sub_block, j0, j1, part = _sequence(count, chunks)
    f1 = j1 / count[sub_block]
    tip0, _ = half_steps.at(sub_block, 2 * j0)
    tip1, _ = half_steps.at(sub_block, 2 * j1)
    _, axis_mid = half_steps.at(sub_block, j0 + j1)
    # over-travel: at every sub-move end (TCP moves can pass a limit between blocks);
    # the chunks end where sub-moves do
    fine = (part & 1) == 1  # the chunks never sweep level 0
    joints_sub = poser.machine_joints(sub_block[fine], f1[fine])
    joints_end = poser.machine_joints(blocks, np.ones(n_blocks))
    all_joints = np.vstack([poser.joints_prog[:1], joints_end])
    return ToolMoves(
        tips=tip0,
        moves=tip1 - tip0,
        axes=axis_mid / np.linalg.norm(axis_mid, axis=1)[:, None],
        block=sub_block,
        end_tip=poser.tip[1:],
        end_axis=poser.axis[1:],
        joints=joints_end,
        duration=_block_durations(program, machine, all_joints),
        overtravel=_overtravel(
            machine, joints_sub, sub_block[fine], poser.machine_joints(blocks, np.zeros(n_blocks))
        ),
        part=part,
    )


def block_poser(
    program: MachineProgram, kins: Any, tool_length: float = 0.0, start_at_first: bool = True
) -> _Poser:
    """The controller's interpolation of ``program`` as ``program_moves`` sees it.

    The result's ``machine_joints(block, frac)`` gives the joints ``(n, 5)`` at fractions
    of blocks (``cam.verify.machine_check`` samples the machine's components with it).
    """
    return _Poser(kins, program, tool_length, start_at_first)
