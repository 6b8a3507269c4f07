"""NC blocks -> tool moves: interpolation, subdivision bound, time, over-travel."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from cam.tools import Segment, Tool
from cam.verify.motion import program_moves
from cam.verify.stock import Stock
from cam.verify.toolshape import ALL_LEVELS, merged_levels, tool_shape
from postproc.kinematics import kinematics_for
from postproc.machine import load_machine
from postproc.program import FeedMode, MachineProgram, Motion

ROOT = Path(__file__).resolve().parents[2]
MACHINE = ROOT / "fixtures" / "machines" / "xyzac-trt.toml"
BALL = Tool(name="ball6", number=1, shape="ball", diameter=6.0, corner_radius=3.0,
            flute_length=12.0, shank_diameter=6.0, stickout=30.0,
            holder=(Segment("holder", 30.0, 50.0, 8.0, 10.0),))


def _program(joints: list[list[float]], *, tcp: bool = False, feed_mode: int = 94,
              feed: float = 600.0, start: list[float] | None = None,
              motion: int = Motion.LINEAR) -> MachineProgram:
    j = np.array(joints, dtype=np.float64)
    j[:, 3:] = np.radians(j[:, 3:])
    n = len(j)
    st = np.zeros(5) if start is None else np.array(start, dtype=np.float64)
    st[3:] = np.radians(st[3:])
    return MachineProgram(
        joints=j, motion=np.full(n, motion, np.int8), feed_mode=np.full(n, feed_mode, np.int16),
        feed=np.full(n, feed), line=np.arange(1, n + 1), tcp=np.full(n, tcp),
        tool_number=np.ones(n, np.int32), start=st,
    )


@pytest.fixture(scope="module")
def machine():  # type: ignore[no-untyped-def]
    m = load_machine(MACHINE)
    return m, kinematics_for(m)


def _cut(stock: Stock, moves, shape) -> None:  # type: ignore[no-untyped-def]
    stock.sweep(moves.tips, moves.moves, moves.axes, moves.block.astype(np.int32), shape)


def test_five_axis_move_matches_dense_reference(machine) -> None:  # type: ignore[no-untyped-def]
    m, kins = machine
    shape = tool_shape(BALL)
    start = [0.0, -4.0, 3.0, 0.0, 0.0]
    program = _program([[6.0, 4.0, 2.0, -25.0, 40.0]], start=start)
    tol = 0.01
    moves = program_moves(program, m, kins, shape.reach, tol, start_at_first=False)
    assert len(moves.tips) > 1  # the turning axis forced a subdivision
    lower, upper = np.array([-10.0, -10.0, -4.0]), np.array([12.0, 10.0, 2.0])
    swept = Stock.box(lower, upper, 0.1)
    before = swept.volume()
    _cut(swept, moves, shape)
    # reference: 600 static tool instances on the true joint-interpolated motion (the
    # tool's farthest point moves < 25 mm: steps < 0.05 mm, scallops < 1e-4 mm)
    frac = np.linspace(0.0, 1.0, 600)
    j0 = np.array(start)
    j0[3:] = np.radians(j0[3:])
    joints = j0 + frac[:, None] * (program.joints[0] - j0)
    tips, axes = kins.forward(joints)
    reference = Stock.box(lower, upper, 0.1)
    reference.sweep(tips, np.zeros_like(tips), axes, np.zeros(len(tips), np.int32), shape)
    removed, expected = before - swept.volume(), before - reference.volume()
    print(f"5-axis block: swept {removed:.3f} mm3, reference {expected:.3f} mm3")
    # swept and true envelopes differ by <= tol: the volume by <= tol * envelope area
    area = 2 * math.pi * 3.0 * 30.0 + 4 * math.pi * 9.0
    assert abs(removed - expected) <= tol * area
    assert removed == pytest.approx(expected, rel=3e-3)
    # the same block swept as one straight fixed-axis move is measurably worse
    crude = Stock.box(lower, upper, 0.1)
    crude.sweep(moves.tips[:1], (moves.tips[-1] + moves.moves[-1] - moves.tips[0])[None],
                moves.axes[len(moves.axes) // 2][None], np.zeros(1, np.int32), shape)
    assert abs(before - crude.volume() - expected) > 3 * abs(removed - expected)


def test_subdivision_meets_the_bound(machine) -> None:  # type: ignore[no-untyped-def]
    m, kins = machine
    program = _program([[10.0, 5.0, 20.0, -30.0, 90.0], [0.0, 0.0, 30.0, -10.0, 0.0]])
    reach, tol = 20.0, 0.02
    moves = program_moves(program, m, kins, reach, tol, start_at_first=False)
    # check against the true motion at 9 points of every sub-move
    for q in np.linspace(0.0, 1.0, 9):
        pos = moves.tips + q * moves.moves
        # true pose at the same fraction of the block
        counts = np.bincount(moves.block)
        index = np.arange(len(moves.block)) - np.repeat(np.cumsum(counts) - counts, counts)
        frac = (index + q) / counts[moves.block]
        joints_all = np.vstack([program.start, program.joints])
        j = joints_all[moves.block] + frac[:, None] * (joints_all[moves.block + 1]
                                                        - joints_all[moves.block])
        tip, axis = kins.forward(j)
        angle = np.arccos(np.clip(np.sum(axis * moves.axes, axis=1), -1, 1))
        error = np.linalg.norm(pos - tip, axis=1) + reach * angle
        assert error.max() <= 1.05 * tol


def test_tcp_block_keeps_the_tip_on_the_programmed_line(machine) -> None:  # type: ignore[no-untyped-def]
    m, kins = machine
    program = _program([[0.0, 0.0, 10.0, 0.0, 0.0], [5.0, 0.0, 10.0, -40.0, 60.0]], tcp=True)
    moves = program_moves(program, m, kins, 15.0, 0.01)
    second = moves.block == 1
    assert second.sum() > 1
    tips = moves.tips[second]
    assert np.allclose(tips[:, 1:], [0.0, 10.0], atol=1e-9)  # on the straight line
    assert np.all(np.diff(tips[:, 0]) > 0)
    assert np.allclose(moves.end_tip[1], [5.0, 0.0, 10.0])
    # the axis at the end: A -40 deg tilts it by 40 deg from +Z
    assert math.degrees(math.acos(moves.end_axis[1][2])) == pytest.approx(40.0)


def test_block_durations(machine) -> None:  # type: ignore[no-untyped-def]
    m, kins = machine
    g94 = _program([[0, 0, 0, 0, 0], [10.0, 0, 0, 0, 0]], feed=600.0)
    moves = program_moves(g94, m, kins, 10.0, 0.01, start_at_first=False)
    assert moves.duration == pytest.approx([0.0, 1.0])  # 10 mm at 600 mm/min
    g93 = _program([[0, 0, 0, 0, 0], [10.0, 0, 0, -10, 0]], feed_mode=int(FeedMode.INVERSE_TIME),
                   feed=2.0)
    moves = program_moves(g93, m, kins, 10.0, 0.01, start_at_first=False)
    assert moves.duration == pytest.approx([30.0, 30.0])  # F2: half a minute per block
    rapid = _program([[0, 0, 0, 0, 0], [0, 0, 40.0, 0, 0]], motion=Motion.RAPID)
    moves = program_moves(rapid, m, kins, 10.0, 0.01, start_at_first=False)
    assert moves.duration[1] == pytest.approx(40.0 / 20.0)  # 1200 mm/min = 20 mm/s


def test_overtravel_is_found_inside_a_tcp_block(machine) -> None:  # type: ignore[no-untyped-def]
    m, kins = machine
    program = _program([[0.0, 0.0, 10.0, 0.0, 0.0], [0.0, 0.0, 10.0, 60.0, 0.0]], tcp=True)
    moves = program_moves(program, m, kins, 10.0, 0.01)
    found = [f for f in moves.overtravel if f["axis"] == "A"]
    assert found and found[0]["block"] == 1
    assert found[0]["limit"] == pytest.approx(50.0)


def test_a_joint_block_after_tcp_starts_at_the_joints_of_the_last_tip(machine) -> None:  # type: ignore[no-untyped-def]
    """M429 / TRAFOOF / G49 after TCP blocks: the next joint-mode block starts where the
    machine is, the joints of the last TCP tip, not at the tip's numbers read as
    joints (which swept a diagonal rapid through the part: issue 21's cross-dialect
    check of the main job's programs)."""
    m, kins = machine
    joints_at_tip = np.array([[3.0, -7.0, 60.0, math.radians(-30.0), math.radians(20.0)]])
    tip, _ = kins.forward(joints_at_tip)
    # joint row, TCP row to that tip, joint row straight up in machine Z (same X, Y, A, C)
    rows = np.array([[3.0, -7.0, 90.0, -30.0, 20.0], [*tip[0], -30.0, 20.0],
                     [3.0, -7.0, 110.0, -30.0, 20.0]])
    rows[:, 3:] = np.radians(rows[:, 3:])
    n = len(rows)
    program = MachineProgram(
        joints=rows, motion=np.full(n, Motion.RAPID, np.int8),
        feed_mode=np.full(n, 94, np.int16), feed=np.full(n, math.nan),
        line=np.arange(1, n + 1), tcp=np.array([False, True, False]),
        tool_number=np.ones(n, np.int32), start=np.zeros(5))
    moves = program_moves(program, m, kins, 10.0, 0.01)
    assert np.allclose(moves.joints[1], joints_at_tip[0], atol=1e-9)
    last = moves.block == 2
    up = moves.moves[last].sum(axis=0)
    axis = moves.axes[last][0]
    # the last block moves the tip along the tool axis only (machine Z), 50 mm
    assert np.linalg.norm(np.cross(up, axis)) < 1e-9
    assert np.linalg.norm(up) == pytest.approx(50.0)


def test_levels_of_the_tool_sweep_their_own_longer_sub_moves(machine) -> None:  # type: ignore[no-untyped-def]
    """With ``level_reach`` a turning block is swept by the ball and the lower flutes
    along chunks of the sub-moves (each within the tolerance for that level's reach,
    ahead of the sub-moves it spans) and by the rest of the tool along the sub-moves;
    the removed volume is the whole tool's on every sub-move within the tolerance's
    share of it."""
    m, kins = machine
    shape = tool_shape(BALL)
    assert list(shape.cutter_level) == [1, 1, 0]  # ball, flutes to 6 mm, the rest
    assert shape.level_reach[0] == pytest.approx(0.5 * shape.reach)
    program = _program([[6.0, 4.0, 2.0, -25.0, 40.0], [0.0, 0.0, 1.0, -5.0, 0.0]],
                       start=[0.0, -4.0, 3.0, 0.0, 0.0])
    tol = 0.01
    plain = program_moves(program, m, kins, shape.reach, tol, start_at_first=False)
    split = program_moves(program, m, kins, shape.reach, tol, start_at_first=False,
                          level_reach=shape.level_reach)
    assert split.part is not None
    fine = (split.part & 1) == 1
    # the sub-moves themselves are unchanged; every block is chunked
    np.testing.assert_array_equal(split.tips[fine], plain.tips)
    np.testing.assert_array_equal(split.moves[fine], plain.moves)
    np.testing.assert_array_equal(split.axes[fine], plain.axes)
    assert set(split.part[fine] & 3) == {1} and set(split.part[~fine]) == {2}
    assert plain.part is not None and set(plain.part) == {ALL_LEVELS}  # the whole tool
    chunks = np.flatnonzero(~fine)
    assert 1 < len(chunks) <= fine.sum() / 2
    ends = split.tips + split.moves
    for i, c in enumerate(chunks):
        # a chunk starts where the sub-move after it starts and ends where the last
        # sub-move before the next chunk (or its block's end) ends
        stop = chunks[i + 1] if i + 1 < len(chunks) else len(split.part)
        last = stop - 1
        assert split.block[c] == split.block[c + 1] == split.block[last]
        np.testing.assert_array_equal(split.tips[c], split.tips[c + 1])
        np.testing.assert_array_equal(ends[c], ends[last])
        # its fixed axis is within tol/2 of the sub-moves' axes, for its level's reach
        # (the quarter-point bound of the module doc)
        angles = np.arccos(np.clip(split.axes[c + 1:stop] @ split.axes[c], -1.0, 1.0))
        assert shape.level_reach[0] * angles.max() <= 0.5 * tol * 1.05
    assert len(split.overtravel) == len(plain.overtravel)
    lower, upper = np.array([-10.0, -10.0, -4.0]), np.array([12.0, 10.0, 2.0])
    one, two = Stock.box(lower, upper, 0.1), Stock.box(lower, upper, 0.1)
    before = one.volume()
    _cut(one, plain, shape)
    two.sweep(split.tips, split.moves, split.axes, split.block.astype(np.int32), shape,
              parts=split.part)
    removed_plain, removed_split = before - one.volume(), before - two.volume()
    assert removed_plain > 10.0
    assert removed_split == pytest.approx(removed_plain, rel=1e-3)


def test_a_flute_side_is_split_where_its_reach_halves() -> None:
    """``tool_shape`` splits the flutes at the heights where their reach is half and a
    quarter of the cutter's; the pieces make the same side."""
    long_ball = Tool(name="ball4_long", number=1, shape="ball", diameter=4.0,
                     corner_radius=2.0, flute_length=24.0, shank_diameter=4.0,
                     stickout=40.0)
    shape = tool_shape(long_ball)
    assert list(shape.cutter_level) == [2, 2, 1, 0]
    cutter = shape.cutter
    assert cutter[1, 3] == 2.0 and cutter[-1, 4] == 24.0
    np.testing.assert_array_equal(cutter[1:-1, 4], cutter[2:, 3])  # end to end
    for row, lv in zip(cutter, shape.cutter_level, strict=True):
        top = math.hypot(row[4], 2.0) if row[0] == 0.0 else row[4]
        assert top <= shape.reach / 2**lv + 1e-9
    assert shape.level_reach == pytest.approx((0.5 * shape.reach, 0.25 * shape.reach))
    # joined again for moves of the whole tool: the unsplit flute side
    whole = merged_levels(cutter)
    assert whole.shape == (2, 6)
    np.testing.assert_array_equal(whole[1], [*cutter[1, :3], 2.0, 24.0, 2.0])


def test_a_chunk_never_runs_far_ahead_of_the_body(machine) -> None:  # type: ignore[no-untyped-def]
    """A long block that turns a little has long sub-moves: its chunks are cut short so
    that the ball never gets more than half the height between its level and the top
    of the flutes ahead of the shank, which is probed on the sub-moves."""
    m, kins = machine
    shape = tool_shape(BALL)
    program = _program([[40.0, 0.0, 2.0, -1.0, 2.0]], start=[-40.0, 0.0, 2.0, 0.0, 0.0])
    split = program_moves(program, m, kins, shape.reach, 0.01, start_at_first=False,
                          level_reach=shape.level_reach)
    assert split.part is not None
    chunk = split.part == 2
    fine = (split.part & 1) == 1
    longest = 0.5 * (shape.reach - shape.level_reach[0])
    assert np.linalg.norm(split.moves[fine], axis=1).max() > longest  # long sub-moves
    assert chunk.any() or set(split.part) == {ALL_LEVELS}
    assert np.all(np.linalg.norm(split.moves[chunk], axis=1) <= longest + 1e-9)
