"""Feed-drive model and Best K_FFP (seed 004, M6): formulas by hand, time simulation
against the transfer function, the paper's circle test, torque saturation."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from cam.motion.feeddrive import (
    FeedDriveAxis,
    alpha_th,
    axis_from_servo,
    best_kffp,
    beta_th,
    load_feed_drives,
    moving_average,
    radius_decrease,
    ramp_command,
    saturation_omega,
    simulate_axis,
    smallest_radius,
    transfer,
)
from cam.motion.synchronisation import circle_test
from impeller_cam.errors import InputError

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures" / "motion"
PAPER_OMEGAS = np.pi * np.array([0.5, 1.0, 1.5, 2.0, 3.0, 4.0])


@pytest.fixture(scope="module")
def table1() -> dict[str, FeedDriveAxis]:
    return load_feed_drives(FIXTURES / "suzuki_table1.toml")


def test_table1_fixture(table1: dict[str, FeedDriveAxis]) -> None:
    c = table1["C"]
    assert c.rotary and not table1["X"].rotary
    assert c.total_inertia == pytest.approx(5.9)  # the paper's J + J1
    assert c.torque_limit == 725.0 and c.kpp == 60.0 and c.ts == 0.064
    assert table1["X"].motor_per_unit == pytest.approx(2 * np.pi / 16.0)


def test_transfer_function_by_hand() -> None:
    # no smoothing, no feed-forward, no integral: G = T_v Kpp / (s + Kpp T_v),
    # T_v = Kvp / (J s + C + Kvp)
    axis = FeedDriveAxis("X", False, kpp=30.0, kvp=200.0, kvi=0.0, inertia=2.0, viscous=1.0,
                         ts=0.0, ta=0.0, tp=0.0, k_ffp=0.0)
    s = 5j
    tv = 200.0 / (2.0 * s + 201.0)
    assert complex(transfer(axis, s)) == pytest.approx(tv * 30 / (s + 30 * tv), abs=1e-14)
    w = 5.0
    expected = (1 - abs(tv * 30 / (s + 30 * tv))) * 8.0
    assert float(radius_decrease(axis, w, 8.0)) == pytest.approx(expected, abs=1e-14)
    assert float(beta_th(axis, w)) == pytest.approx(-np.angle(tv * 30 / (s + 30 * tv)))


def test_alpha_th_is_the_ramp_limit(table1: dict[str, FeedDriveAxis]) -> None:
    # Eq. (17): lim s->0 s (1 - G) w / s^2, evaluated numerically, against the closed form
    for k in (100.0, 80.0, 0.0):
        axis = table1["C"].with_kffp(k)
        h = 1e-5
        numeric = 3.0 * (1 - transfer(axis, h)).real / h
        assert float(alpha_th(axis, 3.0)) == pytest.approx(numeric, rel=1e-4)
        assert float(alpha_th(axis, 3.0)) == pytest.approx(
            3.0 * (0.064 / 2 + (1 - k / 100) / 60.0), rel=1e-15)


def test_alpha_th_equals_the_simulated_ramp_lag(table1: dict[str, FeedDriveAxis]) -> None:
    axis = table1["Y"].with_kffp(70.0)
    dt = 1e-4
    command = ramp_command(2.0, 1.5, dt)
    response = simulate_axis(axis, command * 1000.0, dt)  # Y in mm (r = 1 m/rad)
    lag = (command[-1] * 1000.0 - response.position[-1]) / 1000.0
    assert lag == pytest.approx(float(alpha_th(axis, 2.0)), rel=2e-3)


def test_simulation_follows_the_transfer_function(table1: dict[str, FeedDriveAxis]) -> None:
    # steady-state sinusoid: amplitude |G(jw)| and phase angle G(jw)
    axis = table1["X"]
    dt, w = 1e-4, 2 * np.pi
    t = np.arange(int(3.0 / dt)) * dt
    response = simulate_axis(axis, np.sin(w * t), dt)
    last = t >= 2.0
    fit = np.linalg.lstsq(np.stack([np.sin(w * t[last]), np.cos(w * t[last])], axis=1),
                          response.position[last], rcond=None)[0]
    g = complex(transfer(axis, 1j * w))
    assert math.hypot(*fit) == pytest.approx(abs(g), rel=2e-3)
    assert math.atan2(fit[1], fit[0]) == pytest.approx(np.angle(g), abs=2e-3)


def test_moving_average_of_a_ramp() -> None:
    dt, period = 1e-3, 0.05
    t = np.arange(200, dtype=np.float64) * dt
    out = moving_average(3.0 * t, period, dt)
    # after the window: the ramp delayed by period / 2
    assert np.allclose(out[60:], 3.0 * (t[60:] - period / 2), atol=1e-12)


def test_best_kffp_zeroes_the_angle_difference(table1: dict[str, FeedDriveAxis]) -> None:
    c = table1["C"]
    for name in ("X", "Y"):
        for w in PAPER_OMEGAS:
            k = best_kffp(c, table1[name], float(w))
            assert abs(float(alpha_th(c, w) - beta_th(table1[name].with_kffp(k), w))) < 1e-6


def test_best_kffp_shrinks_the_simulated_shape_error(table1: dict[str, FeedDriveAxis]) -> None:
    # the paper's test: R_C = 5 mm, R_W = 8 mm, omega 0.5 pi .. 4 pi, J + J1 = 5.9 kg m^2
    c, x, y = table1["C"], table1["X"], table1["Y"]
    for w in PAPER_OMEGAS:
        default = circle_test(c, x, y, float(w), r_c=5.0, r_w=8.0, dt=2e-4)
        tuned = circle_test(c, x.with_kffp(best_kffp(c, x, float(w))),
                            y.with_kffp(best_kffp(c, y, float(w))), float(w),
                            r_c=5.0, r_w=8.0, dt=2e-4)
        assert tuned.amplitude < default.amplitude
        # Eq. (7) at K_FFP 100 %: amplitude ~ |alpha - beta| R_W (radius compensated)
        mismatch = abs(float(alpha_th(c, w) - beta_th(x, w))) * 8.0
        assert default.amplitude == pytest.approx(mismatch, rel=0.1)


def test_torque_saturation_and_smallest_radius(table1: dict[str, FeedDriveAxis]) -> None:
    c = table1["C"]
    dt = 1e-4
    w_sat = saturation_omega(c, dt)
    duration = 0.3
    below = simulate_axis(c, ramp_command(0.99 * w_sat, duration, dt), dt)
    above = simulate_axis(c, ramp_command(1.01 * w_sat, duration, dt), dt)
    assert not below.saturated.any() and above.saturated.any()
    assert np.max(np.abs(below.torque)) == pytest.approx(0.99 * 725.0, rel=1e-9)
    # Eq. (1) at the limit: R_C = F_C / omega, F_C = 200 mm/min
    r_c = smallest_radius(w_sat, 200.0)
    assert r_c == pytest.approx(200.0 / 60.0 / w_sat, rel=1e-15)
    # the heavier the load, the earlier the saturation (paper: 5.9 / 7.4 / 8.9 kg m^2)
    omegas = [saturation_omega(c.with_load(j1), dt) for j1 in (1.70, 3.24, 4.77)]
    assert omegas[0] > omegas[1] > omegas[2]


def test_servo_mapping_errors() -> None:
    with pytest.raises(InputError, match="missing"):
        axis_from_servo("X", {"Kpp": 60.0}, False)
    with pytest.raises(InputError, match="unknown"):
        axis_from_servo("X", {"Kpp": 60.0, "Kxx": 1.0}, False)
    with pytest.raises(InputError):
        saturation_omega(FeedDriveAxis("X", False, 60, 100, 0, 1, 1, 0.05, 0.01, 0.0))
    with pytest.raises(InputError):
        smallest_radius(5.0, 0.0)
