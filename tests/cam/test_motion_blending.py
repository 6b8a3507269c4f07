"""Cycle time with look-ahead blending (cam/motion/blending.py) against closed forms.

* A straight line split into many collinear blocks takes the time of one line.
* A 90-degree corner within ``G64 P0.01``: two legs at the closed-form corner speed
  ``V_c = sqrt(8 P a / sqrt(2))`` (parabolic blend, both axes at ``a``), each leg an
  acceleration to the feed, a cruise and a deceleration to ``V_c``.
* Single moves: Ruckig's time-optimal jerk-limited duration (and the exact-stop
  model's), for one axis.
* Any program: nominal (no acceleration) <= blended <= exact stop at every block.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cam.motion.blending import blended_times
from cam.motion.cycle_time import synchronised_times

INF = math.inf
# X, Y, Z (mm/s, mm/s^2, mm/s^3), A, C (rad/s ...)
VEL = np.array([200.0, 200.0, 200.0, 3.0, 3.0])
ACC = np.array([2000.0, 2000.0, 2000.0, 20.0, 20.0])
JERK = np.array([50000.0, 50000.0, 50000.0, 500.0, 500.0])
ROTARY = np.array([False, False, False, True, True])


def _phase(dv: float, a: float, j: float) -> float:
    """Closed-form time of a speed change dv from and to zero acceleration."""
    if math.isinf(j):
        return dv / a
    return dv / a + a / j if dv >= a * a / j else 2.0 * math.sqrt(dv / j)


def _leg(length: float, v0: float, v: float, v1: float, a: float, j: float) -> float:
    """Closed-form time of a leg v0 -> v (cruise) -> v1 that reaches its cruise speed."""
    up, down = _phase(v - v0, a, j), _phase(v - v1, a, j)
    rest = length - 0.5 * (v0 + v) * up - 0.5 * (v + v1) * down
    assert rest > 0, "the leg must reach its cruise speed for this closed form"
    return up + down + rest / v


@pytest.mark.parametrize("jerk", [np.full(5, INF), JERK], ids=["trapezoid", "jerk"])
def test_collinear_blocks_take_the_time_of_one_line(jerk: np.ndarray) -> None:
    rng = np.random.default_rng(3)
    direction = np.array([3.0, -1.0, 2.0, 0.0, 0.0])
    cuts = np.sort(rng.uniform(0.0, 1.0, 199))
    pieces = np.diff(np.concatenate([[0.0], cuts, [1.0]]))
    feed = 50.0 / np.linalg.norm(direction[:3])  # 50 mm/s along the line: ds/dt bound
    one = blended_times(direction[None], VEL, ACC, jerk, ROTARY, np.array([feed]))
    many = blended_times(pieces[:, None] * direction[None], VEL, ACC, jerk, ROTARY,
                         feed / pieces)
    assert many.sum() == pytest.approx(one.sum(), rel=1e-9)
    # one line is the closed form: X (3 of sqrt(14) mm per unit) bounds the path's
    # acceleration and jerk, 50 mm/s is reached
    length = float(np.linalg.norm(direction[:3]))
    lever = length / 3.0
    assert one.sum() == pytest.approx(_leg(length, 0.0, 50.0, 0.0, ACC[0] * lever,
                                           jerk[0] * lever), rel=1e-9)


@pytest.mark.parametrize("jerk", [np.full(5, INF), JERK], ids=["trapezoid", "jerk"])
def test_ninety_degree_corner_within_g64_p001(jerk: np.ndarray) -> None:
    tolerance, feed, leg = 0.01, 100.0, 40.0  # mm, mm/s, mm
    delta = np.array([[leg, 0, 0, 0, 0], [0, leg, 0, 0, 0]], dtype=float)
    times = blended_times(delta, VEL, ACC, jerk, ROTARY, np.full(2, feed / leg), tolerance)
    a, j = ACC[0], jerk[0]
    corner = math.sqrt(8.0 * tolerance * a / math.sqrt(2.0))  # 10.64 mm/s
    expected = _leg(leg, 0.0, feed, corner, a, j)
    assert times == pytest.approx([expected, expected], rel=1e-9)
    # the exact stop at the corner is slower, no stop at all (nominal) faster
    stop = _leg(leg, 0.0, feed, 0.0, a, j)
    assert 2 * leg / feed < times.sum() < 2 * stop


def _ruckig_duration(stroke: float, vmax: float, amax: float, jmax: float) -> float:
    ruckig = pytest.importorskip("ruckig")
    inp = ruckig.InputParameter(1)
    inp.current_position = [0.0]
    # Ruckig works best with magnitudes near 1: metres (durations are unchanged)
    inp.target_position = [stroke / 1000.0]
    inp.max_velocity = [vmax / 1000.0]
    inp.max_acceleration = [amax / 1000.0]
    inp.max_jerk = [jmax / 1000.0]
    trajectory = ruckig.Trajectory(1)
    assert ruckig.Ruckig(1).calculate(inp, trajectory) == ruckig.Result.Working
    return float(trajectory.duration)


def test_single_moves_match_ruckig() -> None:
    rng = np.random.default_rng(7)
    for _ in range(40):
        stroke = rng.uniform(0.05, 300.0)
        vel = np.array([rng.uniform(20, 600), *VEL[1:]])
        acc = np.array([rng.uniform(200, 20000), *ACC[1:]])
        jerk = np.array([rng.uniform(1e3, 5e5), *JERK[1:]])
        delta = np.array([[stroke, 0, 0, 0, 0]])
        ours = blended_times(delta, vel, acc, jerk, ROTARY, np.array([INF]))[0]
        assert ours == pytest.approx(_ruckig_duration(stroke, vel[0], acc[0], jerk[0]),
                                     abs=1e-6)
        stop = synchronised_times(delta, vel, acc, jerk)[0]
        assert ours == pytest.approx(stop, rel=1e-9)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(*[st.floats(-50, 50)] * 3, *[st.floats(-1, 1)] * 2,
                          st.floats(5, 300)), min_size=1, max_size=25),
       st.booleans())
def test_blended_lies_between_nominal_and_exact_stop(blocks: list, with_jerk: bool) -> None:
    rows = np.array(blocks)
    delta, speed = rows[:, :5], rows[:, 5]
    length = np.linalg.norm(delta[:, :3], axis=1)
    keep = (length > 1e-3) | (np.abs(delta[:, 3:]).max(axis=1) > 1e-4)
    delta, speed, length = delta[keep], speed[keep], length[keep]
    if not len(delta):
        return
    with np.errstate(divide="ignore"):
        bound = np.where(length > 0, speed / length, INF)
    jerk = JERK if with_jerk else np.full(5, INF)
    with np.errstate(over="ignore"):
        ours = blended_times(delta, VEL, ACC, jerk, ROTARY, bound)
        stop = synchronised_times(delta, VEL, ACC, jerk, bound)
    with np.errstate(divide="ignore", over="ignore"):
        nominal = 1.0 / np.minimum(np.min(np.where(np.abs(delta) > 0, VEL / np.abs(delta),
                                                   INF), axis=1), bound)
    assert np.all(ours >= 0)
    assert ours.sum() <= stop.sum() * (1 + 1e-9) + 1e-12
    assert ours.sum() >= nominal.sum() * (1 - 1e-9)


@pytest.mark.parametrize("smoothing", [0.0, 0.016, 0.064])
def test_corner_speed_allows_for_the_smoothing_after_interpolation(smoothing: float) -> None:
    # a 90-degree X -> Y corner: the joints change by |dv| = sqrt(2) V over the blend's
    # T = V / a, and the smoothing Ts rounds the corner by |dv| Ts / 8 more:
    # sqrt(2) V (V / a + Ts) / 8 = P
    from cam.motion.blending import plan_speeds

    tolerance, feed, leg = 0.01, 100.0, 40.0
    delta = np.array([[leg, 0, 0, 0, 0], [0, leg, 0, 0, 0]], dtype=float)
    plan = plan_speeds(delta, VEL, ACC, np.full(5, INF), ROTARY, np.full(2, feed / leg),
                       tolerance, smoothing)
    assert plan is not None
    a, room = ACC[0], 8.0 * tolerance / math.sqrt(2.0)
    expected = (-smoothing + math.sqrt(smoothing**2 + 4.0 * room / a)) * a / 2.0
    assert plan.exit[0] * VEL[0] == pytest.approx(expected, rel=1e-12)
    speed = plan.exit[0] * VEL[0]
    assert math.sqrt(2.0) * speed * (speed / a + smoothing) / 8.0 == pytest.approx(tolerance)
