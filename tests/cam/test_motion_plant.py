"""TDOF plant (seed 000, M5): state space, exact ZOH simulation, closed-form residual,
positioning time, identification from the fixture response CSV."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
import scipy.signal

from cam.motion.identify import (
    identify,
    read_response_csv,
    synthetic_response,
)
from cam.motion.plant import TwoMassPlant, load_plant, residual_modes, simulate
from cam.motion.positioning import (
    Settling,
    positioning_times,
    residual_coefficients,
    settling_time_modal,
    settling_time_sampled,
)
from cam.motion.scurve import plan_scurve, sample_scurve
from impeller_cam.errors import InputError

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures" / "motion"
DT = 250e-6


@pytest.fixture(scope="module")
def plant() -> TwoMassPlant:
    return load_plant(FIXTURES / "indexing_table.toml")[0]


def _command(profile_args: tuple[float, ...], horizon: float) -> tuple[Any, Any, Any]:
    profile = plan_scurve(*profile_args)
    t = np.arange(int(round(horizon / DT))) * DT
    _, acc, vel, pos = sample_scurve(profile, t)
    return profile, t, np.stack([pos[0], vel[0], acc[0]], axis=1)


def test_fixture_parameters_and_modes(plant: TwoMassPlant) -> None:
    assert plant.table_mass == 11.0  # the paper's table
    # motor side from the paper's 3,475 rev/s^2 at 1.3 N m and a 10 mm lead
    j_total = 1.3 / (3475 * 2 * np.pi)
    m_equiv = j_total * (2 * np.pi / 0.010) ** 2
    assert plant.motor_mass == pytest.approx(m_equiv - 11.0, rel=0.03)
    freqs = plant.natural_frequencies()
    # the lightly damped table mode sits at ~1 / (the paper's optimum jerk time 26.25 ms)
    assert freqs.min() == pytest.approx(1 / (105 * 250e-6), rel=0.02)


def test_static_gains(plant: TwoMassPlant) -> None:
    # constant command: table at the command, acceleration zero
    for output, gain in (("position", 1.0), ("acceleration", 0.0)):
        a, b, c, d = plant.state_space(output)  # type: ignore[arg-type]
        dc = -c @ np.linalg.solve(a, b[:, :1]) + d[:, :1]
        assert dc[0, 0] == pytest.approx(gain, abs=1e-9)


def test_rigid_servo_limit_is_table_on_spring() -> None:
    # a very stiff servo holds the motor side: table mode -> sqrt(k / m2)
    stiff = TwoMassPlant(12.5, 11.0, 7.3e5, 0.0, 1e13, 1e7, 1.0)
    expected = np.sqrt(7.3e5 / 11.0) / (2 * np.pi)
    assert stiff.natural_frequencies().min() == pytest.approx(expected, rel=1e-3)


def test_zoh_simulation_equals_lsim(plant: TwoMassPlant) -> None:
    _, t, u = _command((20.0, 500.0, 30000.0, 20000.0, 22.0), 0.2)
    ours = simulate(plant, u, DT, "acceleration")
    _, reference, _ = scipy.signal.lsim(plant.state_space("acceleration"), u, t, interp=False)
    assert np.max(np.abs(ours - reference)) <= 1e-9 * np.max(np.abs(reference))
    many = simulate(plant, np.stack([u, 2 * u]), DT, "position")
    assert np.allclose(many[1], 2 * many[0], rtol=1e-12, atol=1e-12)


def test_closed_form_residual_matches_fine_simulation(plant: TwoMassPlant) -> None:
    # the continuous response after the move, from the modal closed form, against the
    # ZOH simulation with a fine step (converges as dt -> 0)
    args = (20.0, 400.0, 25000.0, 15000.0, 30.0)
    profile = plan_scurve(*args)
    coefficients, rates = residual_coefficients(plant, profile, "acceleration")
    fine = 2e-6
    t = np.arange(int(round((profile.duration[0] + 0.1) / fine))) * fine
    _, acc, vel, pos = sample_scurve(profile, t)
    y = simulate(plant, np.stack([pos[0], vel[0], acc[0]], axis=1), fine, "acceleration")
    after = t >= profile.duration[0]
    tau = t[after] - profile.duration[0]
    closed = np.real(np.exp(np.outer(tau, rates)) @ coefficients[0])
    assert np.max(np.abs(closed - y[after])) <= 2e-3 * np.max(np.abs(y))


def test_trapezoid_limit_is_continuous(plant: TwoMassPlant) -> None:
    # phi(lambda d) -> 1 as the jerk time -> 0: S = 1e-9 equals S = 0
    a = residual_coefficients(plant, plan_scurve(20.0, 500.0, 3e4, 2e4, 0.0))[0]
    b = residual_coefficients(plant, plan_scurve(20.0, 500.0, 3e4, 2e4, 1e-9))[0]
    assert np.allclose(a, b, rtol=1e-6, atol=1e-6)


def test_settling_single_mode_by_hand() -> None:
    # e(tau) = 1000 exp(-10 tau) cos(2 pi 20 tau); band 100: last sample above the band
    rates = np.array([-10 + 2j * np.pi * 20])
    coefficients = np.array([[1000.0 + 0j]])
    dt = 1e-4
    tau = np.arange(20000) * dt
    e = 1000 * np.exp(-10 * tau) * np.cos(2 * np.pi * 20 * tau)
    last = np.flatnonzero(np.abs(e) > 100)[-1]
    got = settling_time_modal(coefficients, rates, 100.0, dt)[0]
    assert got == pytest.approx((last + 1) * dt, abs=1e-12)
    assert settling_time_sampled(e[None, :], 0, 0.0, 100.0, dt)[0] == pytest.approx(got)
    # envelope bound: the response is inside the band after ln(10) / 10 s
    assert got <= np.log(10) / 10 + dt


def test_positioning_closed_form_agrees_with_simulation(plant: TwoMassPlant) -> None:
    settling = Settling()
    for args in ((20.0, 500.0, 3e4, 3e4, 22.0), (20.0, 375.0, 14000.0, 14000.0, 105.0),
                 (20.0, 300.0, 3e4, 1e4, 60.0)):
        profile, _, u = _command(args, 0.5)
        closed = positioning_times(plant, profile, settling)
        y = simulate(plant, u, DT, "acceleration")
        end = int(np.ceil(profile.duration[0] / DT))
        sampled = settling_time_sampled(y[None, :], end, 0.0, settling.band, DT)[0]
        sampled += end * DT - profile.duration[0]
        assert closed.settling[0] == pytest.approx(sampled, abs=2.5 * DT)
    position = Settling(output="position", band=0.005)
    t = positioning_times(plant, plan_scurve(20.0, 500.0, 3e4, 3e4, 22.0), position)
    assert np.all(np.isfinite(t.positioning))


def test_residual_modes_are_stable_pairs(plant: TwoMassPlant) -> None:
    rates, weights = residual_modes(plant)
    assert len(rates) == 2 and np.all(rates.real < 0) and np.all(rates.imag > 0)


def test_load_plant_errors(tmp_path: Path) -> None:
    bad = tmp_path / "p.toml"
    bad.write_text("[plant]\nmotor_mass = 1\ntable_mass = -2\n")
    with pytest.raises(InputError) as info:
        load_plant(bad)
    assert info.value.field == "plant.table_mass"
    bad.write_text("[plant]\nmass = 1\n")
    with pytest.raises(InputError, match="unknown key"):
        load_plant(bad)
    with pytest.raises(InputError, match="not found"):
        load_plant(tmp_path / "missing.toml")


def test_fixture_csv_is_the_documented_synthetic_response(plant: TwoMassPlant) -> None:
    stored = read_response_csv(FIXTURES / "indexing_response.csv")
    again = synthetic_response(plant)
    assert stored.dt == pytest.approx(250e-6)
    assert np.max(np.abs(stored.measured - again.measured)) <= 1e-5
    assert np.max(np.abs(stored.command - again.command)) <= 1e-5


def test_identification_recovers_the_parameters(plant: TwoMassPlant) -> None:
    measured = read_response_csv(FIXTURES / "indexing_response.csv")
    start = plant.with_parameters(stiffness=plant.stiffness * 1.4, damping=plant.damping * 0.6,
                                  servo_stiffness=plant.servo_stiffness * 0.7,
                                  servo_damping=plant.servo_damping * 1.3)
    fit = identify(measured, start)
    for name, tolerance in (("stiffness", 0.03), ("damping", 0.05),
                            ("servo_stiffness", 0.03), ("servo_damping", 0.15)):
        assert getattr(fit.plant, name) == pytest.approx(getattr(plant, name), rel=tolerance)
    # the table mode that decides settling within 0.5 %, the servo mode within 2 %
    assert fit.plant.natural_frequencies()[0] == pytest.approx(
        plant.natural_frequencies()[0], rel=0.005)
    assert fit.plant.natural_frequencies() == pytest.approx(plant.natural_frequencies(),
                                                            rel=0.02)
    # residual at the noise level (2 % of the peak) and no better: nothing over-fitted
    peak = np.max(np.abs(measured.measured))
    assert 0.015 * peak <= fit.rms_residual <= 0.025 * peak


def test_read_response_csv_errors(tmp_path: Path) -> None:
    path = tmp_path / "r.csv"
    path.write_text("time_s,command_position_mm\n" + "".join(f"{i},{i}\n" for i in range(20)))
    with pytest.raises(InputError, match="measured column"):
        read_response_csv(path)
    rows = "".join(f"{0.1 * i * (1 + (i == 5))},{i},0\n" for i in range(20))
    path.write_text("time_s,command_position_mm,table_acceleration_mm_s2\n" + rows)
    with pytest.raises(InputError, match="equal steps"):
        read_response_csv(path)


def test_settling_table() -> None:
    from cam.motion.positioning import settling_from_dict

    assert settling_from_dict({}) == Settling()
    got = settling_from_dict({"settling": {"output": "position", "band": 0.005}})
    assert got.output == "position" and got.band == 0.005
    with pytest.raises(InputError):
        settling_from_dict({"settling": {"output": "jerk"}})
    with pytest.raises(InputError):
        settling_from_dict({"settling": {"band": -1.0}})
    with pytest.raises(InputError, match="unknown key"):
        settling_from_dict({"settling": {"width": 1.0}})
