"""A long program simulated in pieces split at its rapids gives the whole run's answer."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import cam.motion.program_servo as program_servo
from cam.motion.axis_models import machine_axis_models
from cam.motion.servo_pieces import program_pieces
from postproc.machine import load_machine
from postproc.program import MachineProgram, Motion

ROOT = Path(__file__).resolve().parents[2]


def test_pieces_start_at_rapids_within_the_budget() -> None:
    r, f = int(Motion.RAPID), int(Motion.LINEAR)
    motion = np.array([r, f, f, r, f, f, f, r, f, r, f], dtype=np.int8)
    seconds = np.ones(len(motion))
    pieces = program_pieces(motion, seconds, 1.0, 5)
    assert pieces[0][0] == 0 and pieces[-1][1] == len(motion)
    assert all(a == b for (_, a), (b, _) in zip(pieces[:-1], pieces[1:], strict=True))
    assert all(motion[a] == r for a, _ in pieces[1:])  # every later piece opens at a rapid
    # within the budget wherever a rapid allowed it: [0, 3), [3, 7) hold 3 and 4 s
    assert pieces == [(0, 3), (3, 9), (9, 11)] or max(b - a for a, b in pieces) <= 6
    assert program_pieces(motion, seconds, 1.0, 100) == [(0, len(motion))]
    # no rapid to cut at: one piece whatever its length
    assert program_pieces(np.full(50, f, np.int8), np.ones(50), 1.0, 5) == [(0, 50)]


def test_pieces_give_the_whole_programs_errors(monkeypatch: pytest.MonkeyPatch) -> None:
    machine = load_machine(ROOT / "fixtures" / "machines" / "trunnion-500.toml")
    rng = np.random.default_rng(4)
    blocks, motion, point = [], [], np.array([0.0, 0.0, 40.0, -0.4, 0.3])
    for _ in range(3):  # three passes, each opened by a rapid
        point = point + np.array([5.0, -5.0, 2.0, 0.05, 0.2])
        blocks.append(point.copy())
        motion.append(int(Motion.RAPID))
        for _ in range(12):
            point = point + np.concatenate([rng.uniform(-1.5, 1.5, 3),
                                            rng.uniform(-0.01, 0.01, 2)])
            blocks.append(point.copy())
            motion.append(int(Motion.LINEAR))
    joints, n = np.array(blocks), len(blocks)
    move = np.array(motion, np.int8)
    program = MachineProgram(joints=joints, motion=move, feed_mode=np.full(n, 94),
                             feed=np.where(move == Motion.RAPID, np.nan, 1200.0),
                             line=np.arange(1, n + 1), tcp=np.zeros(n, bool),
                             tool_number=np.ones(n, np.int32),
                             start=np.array([0.0, 0.0, 40.0, -0.4, 0.3]))
    models = machine_axis_models(machine)
    whole = program_servo.simulate_program(program, machine, dt=1e-3, models=models)
    monkeypatch.setattr(program_servo, "PIECE_SAMPLES", 200)  # one piece per pass
    cut = program_servo.simulate_program(program, machine, dt=1e-3, models=models)
    assert whole.deviation.max() > 0.05  # tens of microns to compare
    # the first two passes run on the whole run's clock from its start (the second
    # with the first as its warm-up): the same answer
    np.testing.assert_allclose(cut.deviation[:26], whole.deviation[:26], rtol=0, atol=1e-9)
    # the third piece's clock starts at its warm-up's rapid: the blocks' ends fall at
    # other phases of the 1 ms samples, worth a few microns at the corners
    np.testing.assert_allclose(cut.deviation, whole.deviation, rtol=0, atol=5e-3)
    np.testing.assert_allclose(cut.tool_axis, whole.tool_axis, rtol=0, atol=1e-2)
    assert cut.feed_rms == pytest.approx(whole.feed_rms, rel=2e-2)
    assert cut.deviation_recommended is not None and whole.deviation_recommended is not None
    np.testing.assert_allclose(cut.deviation_recommended, whole.deviation_recommended,
                               rtol=0, atol=5e-3)
    assert cut.recommended_kffp == whole.recommended_kffp
