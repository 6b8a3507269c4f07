"""The look-ahead control's commanded trajectory (cam/motion/lookahead.py): closed forms.

* A 90-degree corner within ``G64 P0.01``: the legs take the blended plan's closed-form
  time (corner speed ``V_c = sqrt(8 P a / sqrt(2))``), the joint velocities are
  continuous, each axis's acceleration stays at its limit (the blend) plus what the
  jerk-limited braking adds inside the blend, and the corner is cut by exactly ``P``.
* A feed change between two collinear blocks (a G93-style jump): the path speed is
  continuous, brakes inside the fast block (look-ahead) and reaches the slow block's
  feed at its start; acceleration and jerk within the axes' limits.
* The servo simulation on both feed profiles.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from cam.motion.blending import blended_program_time, plan_speeds
from cam.motion.cycle_time import axis_limits, path_rate_bound, rotary_mask
from cam.motion.lookahead import lookahead_motion, segment_pieces
from cam.motion.program_servo import simulate_program
from impeller_cam.errors import InputError
from postproc.machine import load_machine
from postproc.program import MachineProgram, Motion

ROOT = Path(__file__).resolve().parents[2]
DT = 1e-5


@pytest.fixture(scope="module")
def machine():  # type: ignore[no-untyped-def]
    return load_machine(ROOT / "fixtures" / "machines" / "trunnion-500.toml")


def _program(joints: np.ndarray, feed: np.ndarray | float, start: np.ndarray
             ) -> MachineProgram:
    n = len(joints)
    return MachineProgram(joints=joints, motion=np.full(n, Motion.LINEAR),
                          feed_mode=np.full(n, 94), feed=np.full(n, 1.0) * feed,
                          line=np.arange(1, n + 1), tcp=np.zeros(n, dtype=bool),
                          tool_number=np.ones(n, dtype=np.int32), start=start)


def _phase(dv: float, a: float, j: float) -> float:
    return dv / a + a / j if dv >= a * a / j else 2.0 * math.sqrt(dv / j)


def _leg(length: float, v0: float, v: float, v1: float, a: float, j: float) -> float:
    """Closed-form time of a leg v0 -> v (cruise) -> v1 that reaches its cruise speed."""
    up, down = _phase(v - v0, a, j), _phase(v - v1, a, j)
    rest = length - 0.5 * (v0 + v) * up - 0.5 * (v + v1) * down
    assert rest > 0
    return up + down + rest / v


def test_ninety_degree_corner(machine) -> None:  # type: ignore[no-untyped-def]
    _, acc, jerk = axis_limits(machine)
    a, j, tol, feed, leg = acc[0], jerk[0], 0.01, 100.0, 40.0  # mm/s^2, mm/s^3, mm, mm/s
    start = np.array([0.0, 0.0, 10.0, 0.0, 0.0])
    program = _program(np.array([[leg, 0, 10, 0, 0], [leg, leg, 10, 0, 0]], dtype=float),
                       60.0 * feed, start)
    t, q, ends = lookahead_motion(program, machine, program.joints, DT)
    corner = math.sqrt(8.0 * tol * a / math.sqrt(2.0))  # commanded speed at the corner
    expected = _leg(leg, 0.0, feed, corner, a, j)
    assert ends == pytest.approx([expected, 2 * expected], abs=2 * DT)
    assert ends == pytest.approx(np.cumsum(blended_program_time(program, machine).time),
                                 abs=2 * DT)
    # velocity continuous: no step, the acceleration within the blend's a plus the
    # jerk-limited braking inside the blend T = V_c / a (a step would be ~V_c / DT)
    v = np.diff(q[:, :2], axis=0) / DT
    acceleration = np.abs(np.diff(v, axis=0)) / DT
    blend = corner / a
    assert acceleration.max() <= a + j * blend
    assert acceleration.max() >= 0.99 * a  # the blend runs at the axes' limit
    assert np.abs(np.diff(v, axis=0)).max() < 0.01 * corner
    # the corner is cut by |dv| T / 8 = sqrt(2) V_c^2 / (8 a) = P
    cut = np.hypot(q[:, 0] - leg, q[:, 1]).min()
    assert cut == pytest.approx(math.sqrt(2.0) * corner**2 / (8.0 * a), rel=1e-6)
    assert cut == pytest.approx(tol, rel=1e-6)
    assert np.abs(q[:, 2:] - start[2:]).max() == 0.0
    assert q[-1] == pytest.approx(program.joints[-1], abs=1e-9)


def test_feed_change_is_continuous_within_the_limits(machine) -> None:  # type: ignore[no-untyped-def]
    vel, acc, jerk = axis_limits(machine)
    # two collinear blocks along (3, 4)/5 in X, Y: 100 mm/s, then 20 mm/s
    unit = np.array([0.6, 0.8, 0.0, 0.0, 0.0])
    start = np.array([0.0, 0.0, 10.0, 0.0, 0.0])
    joints = start + np.outer([40.0, 80.0], unit)
    program = _program(joints, np.array([6000.0, 1200.0]), start)
    # the plan's pieces: speed continuous, path acceleration and jerk within the bounds
    delta = np.diff(np.vstack([start, joints]), axis=0)
    plan = plan_speeds(delta, vel, acc, jerk, rotary_mask(machine),
                       path_rate_bound(program, delta, rotary_mask(machine)))
    assert plan is not None and len(plan.seg_length) == 2
    duration, pjerk, pacc, speed, dist = segment_pieces(plan)
    end_speed = speed + pacc * duration + 0.5 * pjerk * duration**2
    end_acc = pacc + pjerk * duration
    end_dist = dist + speed * duration + 0.5 * pacc * duration**2 + pjerk * duration**3 / 6
    assert end_speed[:, :-1] == pytest.approx(speed[:, 1:], abs=1e-12)
    assert end_speed[0, -1] == pytest.approx(speed[1, 0], abs=1e-12)  # across the blocks
    assert end_dist[:, -1] == pytest.approx(plan.seg_length, rel=1e-9)
    assert np.abs(np.concatenate([pacc, end_acc])).max() <= plan.acc.max() * (1 + 1e-12)
    assert np.abs(pjerk).max() <= plan.jerk.max() * (1 + 1e-12)
    assert duration.sum(axis=1) == pytest.approx(plan.time, rel=1e-12)
    # in mm: Y (0.8 of the path) bounds the path's acceleration and jerk
    a, j = acc[1] / unit[1], jerk[1] / unit[1]
    first = _leg(40.0, 0.0, 100.0, 20.0, a, j)
    second = 40.0 / 20.0 + _phase(20.0, a, j) - 0.5 * 20.0 * _phase(20.0, a, j) / 20.0
    t, q, ends = lookahead_motion(program, machine, joints, DT)
    assert ends == pytest.approx([first, first + second], abs=2 * DT)
    # sampled: the axes' acceleration and jerk within their limits, and the slow
    # block starts at its own feed (the braking ran inside the fast block)
    path = (q[:, :2] - start[:2]) @ unit[:2]
    v = np.gradient(path, DT)
    assert v[int(round(first / DT))] == pytest.approx(20.0, rel=1e-3)
    axis_acc = np.abs(np.diff(q[:, :2], 2, axis=0)) / DT**2
    assert (axis_acc.max(axis=0) <= acc[:2] * (1 + 1e-3)).all()
    axis_jerk = np.abs(np.diff(q[:, :2], 3, axis=0)) / DT**3
    assert (axis_jerk.max(axis=0) <= jerk[:2] * (1 + 1e-2)).all()


def test_rapids_end_in_position(machine) -> None:  # type: ignore[no-untyped-def]
    start = np.array([0.0, 0.0, 50.0, 0.0, 0.0])
    joints = np.array([[10.0, 0, 50, 0, 0.5], [10, 0, 5, 0, 0.5], [30, 0, 5, 0, 0.5]])
    program = _program(joints, 1200.0, start)
    program.motion[0] = Motion.RAPID
    settle = 0.2
    t, q, ends = lookahead_motion(program, machine, joints, 1e-3, settle)
    arrive = int(np.searchsorted(t, ends[0] - settle))
    # held in position for the settling time after the rapid
    assert np.abs(q[arrive:int(ends[0] / 1e-3)] - joints[0]).max() < 1e-9
    assert np.all(np.diff(ends) > 0)


def test_feed_profiles(machine) -> None:  # type: ignore[no-untyped-def]
    start = np.array([0.0, 0.0, 20.0, -0.3, 0.8])
    program = _program(np.array([[30.0, -20.0, 10.0, -0.3, 0.8]]), 1200.0, start)
    block = simulate_program(program, machine, recommend=False, feed_profile="block")
    ahead = simulate_program(program, machine, recommend=False)
    assert block.tracking.max() > 0.1 and ahead.tracking.max() > 0.1
    with pytest.raises(InputError, match="feed profile"):
        simulate_program(program, machine, feed_profile="smooth")  # type: ignore[arg-type]


def test_the_memory_guard_counts_time_samples(machine) -> None:  # type: ignore[no-untyped-def]
    """The guard is on time samples (the main job's hour-long fillet program needs 4.2 M
    at 1 ms and must run): a program needing exactly ``max_samples`` samples runs, one
    sample fewer is refused with the count it needs."""
    start = np.array([0.0, 0.0, 20.0, 0.0, 0.0])
    joints = np.array([[30.0, -20.0, 10.0, 0.0, 0.0], [60.0, -20.0, 10.0, 0.0, 0.0]])
    program = _program(joints, 1200.0, start)
    with pytest.raises(InputError, match="needs") as refused:
        lookahead_motion(program, machine, joints, 1e-3, max_samples=1)
    needs = int(str(refused.value).split("needs ")[1].split(" ")[0].rstrip(")"))
    t, _, _ = lookahead_motion(program, machine, joints, 1e-3, max_samples=needs)
    assert len(t) == needs
    with pytest.raises(InputError, match="too long"):
        lookahead_motion(program, machine, joints, 1e-3, max_samples=needs - 1)
