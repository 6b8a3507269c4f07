"""Seven-segment asymmetric S-curve (seed 000, M5): closed forms, limits, Ruckig."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cam.motion.scurve import PAPER_PID_PERIOD, plan_scurve, sample_scurve
from impeller_cam.errors import InputError


def test_case_one_closed_form() -> None:
    # all phases exist: Tacc = V/A + tj, D = V * Tacc, cruise = (X - D) / V
    p = plan_scurve(20.0, 500.0, 30000.0, 30000.0, 22.0)
    tj = 22 * 250e-6
    t_acc = 500 / 30000 + tj
    expected = 2 * t_acc + (20 - 500 * t_acc) / 500
    assert p.duration[0] == pytest.approx(expected, abs=1e-15)
    assert p.durations[0] == pytest.approx(
        [tj, 500 / 30000 - tj, tj, (20 - 500 * t_acc) / 500, tj, 500 / 30000 - tj, tj],
        abs=1e-15)
    assert p.peak_velocity[0] == 500.0
    assert p.peak_acceleration[0] == 30000.0 and p.peak_deceleration[0] == 30000.0
    assert p.jerk[0, 0] == pytest.approx(30000 / tj)


def test_trapezoid_s_zero_asymmetric() -> None:
    p = plan_scurve(20.0, 500.0, 30000.0, 20000.0, 0.0)
    cruise = (20 - 500**2 / 2 * (1 / 30000 + 1 / 20000)) / 500
    assert p.duration[0] == pytest.approx(500 / 30000 + 500 / 20000 + cruise, abs=1e-15)
    assert np.all(p.jerk[0] == 0.0)


def test_triangle_no_cruise() -> None:
    # S = 0 and a short stroke: v = sqrt(2 X / (1/Au + 1/Ad))
    p = plan_scurve(1.0, 500.0, 30000.0, 10000.0, 0.0)
    v = math.sqrt(2.0 / (1 / 30000 + 1 / 10000))
    assert p.peak_velocity[0] == pytest.approx(v, rel=1e-14)
    assert p.duration[0] == pytest.approx(v / 30000 + v / 10000, rel=1e-14)
    assert p.durations[0, 3] == pytest.approx(0.0, abs=1e-15)


def test_pure_jerk_degenerate() -> None:
    # neither Amax nor Vmax reached: D(v) = 2 v sqrt(v tj / A) = X
    x, a, s = 0.01, 30000.0, 115.0
    tj = s * PAPER_PID_PERIOD
    v = (x / (2 * math.sqrt(tj / a))) ** (2 / 3)
    p = plan_scurve(x, 500.0, a, a, s)
    assert p.peak_velocity[0] == pytest.approx(v, rel=1e-12)
    assert p.peak_acceleration[0] == pytest.approx(math.sqrt(v * a / tj), rel=1e-12)
    assert p.peak_acceleration[0] < a
    assert p.duration[0] == pytest.approx(4 * math.sqrt(v * tj / a), rel=1e-12)
    assert p.boundary_position[0, -1] == pytest.approx(x, abs=1e-15)


def test_negative_stroke_mirrors_and_zero_stroke() -> None:
    p = plan_scurve([7.0, -7.0, 0.0], 300.0, 20000.0, 15000.0, 40.0)
    assert p.duration[0] == p.duration[1]
    assert np.allclose(p.boundary_position[1], -p.boundary_position[0])
    assert p.duration[2] == 0.0 and p.boundary_position[2, -1] == 0.0


def test_vectorised_equals_one_by_one() -> None:
    rng = np.random.default_rng(3)
    args = [rng.uniform(0.1, 40, 50), rng.uniform(100, 600, 50), rng.uniform(5e3, 3e4, 50),
            rng.uniform(5e3, 3e4, 50), rng.uniform(0, 120, 50)]
    together = plan_scurve(args[0], args[1], args[2], args[3], args[4])
    for i in range(50):
        alone = plan_scurve(*(a[i] for a in args))
        assert np.array_equal(alone.durations[0], together.durations[i])


@pytest.mark.parametrize("field,args", [
    ("vmax", (20, 0.0, 1e4, 1e4, 10)),
    ("amax_up", (20, 500, -1.0, 1e4, 10)),
    ("amax_down", (20, 500, 1e4, math.inf, 10)),
    ("s_factor", (20, 500, 1e4, 1e4, -2.5)),
    ("stroke", (math.nan, 500, 1e4, 1e4, 10)),
])
def test_bad_input_names_the_field(field: str, args: tuple[float, ...]) -> None:
    with pytest.raises(InputError) as info:
        plan_scurve(*args)
    assert info.value.field == field


@settings(max_examples=150, deadline=None)
@given(
    stroke=st.floats(1e-4, 200.0),
    vmax=st.floats(1.0, 2000.0),
    au=st.floats(100.0, 1e5),
    ad=st.floats(100.0, 1e5),
    s=st.floats(0.0, 400.0),
)
def test_end_position_and_limits(stroke: float, vmax: float, au: float, ad: float,
                                 s: float) -> None:
    p = plan_scurve(stroke, vmax, au, ad, s)
    assert abs(p.boundary_position[0, -1] - stroke) <= 1e-9
    assert np.all(p.durations >= 0.0)
    assert p.peak_velocity[0] <= vmax * (1 + 1e-12)
    assert p.peak_acceleration[0] <= au * (1 + 1e-12)
    assert p.peak_deceleration[0] <= ad * (1 + 1e-12)
    tj = s * PAPER_PID_PERIOD
    if tj > 0:
        assert np.max(np.abs(p.jerk[0, :3])) <= au / tj * (1 + 1e-9)
        assert np.max(np.abs(p.jerk[0, 4:])) <= ad / tj * (1 + 1e-9)
    t = np.linspace(0.0, p.duration[0], 801)
    j, a, v, x = sample_scurve(p, t)
    assert np.all(v >= -1e-9 * vmax) and np.max(v) <= vmax * (1 + 1e-12)
    assert np.max(a) <= au * (1 + 1e-12) and np.min(a) >= -ad * (1 + 1e-12)
    assert np.all(np.diff(x[0]) >= -1e-12)
    assert abs(x[0, -1] - stroke) <= 1e-9
    # continuity of the samples at every segment boundary
    switch = p.switch_times[0]
    for k in range(1, 7):
        _, a2, v2, x2 = sample_scurve(p, np.array([switch[k] - 1e-12, switch[k] + 1e-12]))
        assert abs(x2[0, 1] - x2[0, 0]) <= 1e-9 + 4e-12 * vmax
        assert abs(v2[0, 1] - v2[0, 0]) <= 1e-6 * max(vmax, 1.0)


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
    result = ruckig.Ruckig(1).calculate(inp, trajectory)
    assert result == ruckig.Result.Working
    return float(trajectory.duration)


def test_symmetric_matches_ruckig_time_optimal() -> None:
    rng = np.random.default_rng(11)
    checked = 0
    while checked < 60:
        stroke, vmax = rng.uniform(1, 100), rng.uniform(50, 600)
        amax, s = rng.uniform(5e3, 3e4), rng.uniform(1, 115)
        tj = s * PAPER_PID_PERIOD
        p = plan_scurve(stroke, vmax, amax, amax, s)
        if not (np.all(p.durations[0] > 0)):  # the test is for profiles with all phases
            continue
        assert abs(p.duration[0] - _ruckig_duration(stroke, vmax, amax, amax / tj)) <= 1e-9
        checked += 1
