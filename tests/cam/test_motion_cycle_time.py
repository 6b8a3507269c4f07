"""Cycle time under axis velocity/acceleration/jerk limits; servo lag of a program."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from cam.motion.axis_models import machine_axis_models
from cam.motion.cycle_time import index_moves_time, program_cycle_time
from cam.motion.feeddrive import best_kffp
from cam.motion.program_servo import commanded_durations, program_joints, simulate_program
from impeller_cam.errors import InputError
from postproc.kinematics import kinematics_for
from postproc.machine import load_machine
from postproc.nc_reader import read_nc
from postproc.program import FeedMode, MachineProgram, Motion

MACHINES = Path(__file__).resolve().parents[2] / "fixtures" / "machines"


@pytest.fixture(scope="module")
def machine():  # type: ignore[no-untyped-def]
    return load_machine(MACHINES / "trunnion-500.toml")


@pytest.fixture(scope="module")
def unmatched(machine):  # type: ignore[no-untyped-def]
    """trunnion-500 at Table 1's set point: X's K_FFP 100 % (lags 25 ms, Y and C 32 ms)."""
    from dataclasses import replace
    from types import MappingProxyType

    x = machine.axes["X"]
    axes = dict(machine.axes)
    axes["X"] = replace(x, servo=MappingProxyType({**x.servo, "K_FFP": 100.0}))
    return replace(machine, axes=MappingProxyType(axes))


def _program(joints: np.ndarray, motion: int, feed: float, mode: int = 94,
             start: np.ndarray | None = None, tcp: bool = False) -> MachineProgram:
    n = len(joints)
    return MachineProgram(joints=joints, motion=np.full(n, motion),
                          feed_mode=np.full(n, mode), feed=np.full(n, feed),
                          line=np.arange(1, n + 1), tcp=np.full(n, tcp),
                          tool_number=np.ones(n, dtype=np.int32),
                          start=np.zeros(5) if start is None else start)


def test_feed_block_by_hand(machine) -> None:  # type: ignore[no-untyped-def]
    # X 100 mm at 600 mm/min; X limits 600 mm/s, 5000 mm/s^2, 50000 mm/s^3
    prog = _program(np.array([[100.0, 0, 0, 0, 0]]), Motion.LINEAR, 600.0)
    times = program_cycle_time(prog, machine)
    assert times.nominal[0] == pytest.approx(10.0, rel=1e-15)
    v, a, j = 0.1, 50.0, 500.0  # in path units (1/s, ...)
    tj = a / j
    phase = 2 * math.sqrt(v * tj / a)  # acceleration limit not reached
    assert times.limited[0] == pytest.approx(2 * phase + (1 - v * phase) / v, rel=1e-12)


def test_rapid_block_by_hand(machine) -> None:  # type: ignore[no-untyped-def]
    prog = _program(np.array([[100.0, 0, 0, 0, 0]]), Motion.RAPID, math.nan)
    times = program_cycle_time(prog, machine)
    assert times.nominal[0] == pytest.approx(100.0 / 600.0)
    # v^2 / a + v tj = 1 with a = 50, tj = 0.1 -> v = 5 = a tj: T = 2 (v / a + tj)
    assert times.limited[0] == pytest.approx(0.4, rel=1e-12)


def test_inverse_time_and_rotary_block(machine) -> None:  # type: ignore[no-untyped-def]
    prog = _program(np.array([[50.0, 0, 0, 0, 0]]), Motion.LINEAR, 2.0, FeedMode.INVERSE_TIME)
    assert program_cycle_time(prog, machine).nominal[0] == pytest.approx(30.0)
    # rotary-only G94 block: the feed is in deg/min
    prog = _program(np.array([[0, 0, 0, 0, math.radians(90.0)]]), Motion.LINEAR, 900.0)
    assert program_cycle_time(prog, machine).nominal[0] == pytest.approx(6.0)
    with pytest.raises(InputError, match="feed"):
        program_cycle_time(_program(np.array([[1.0, 0, 0, 0, 0]]), Motion.LINEAR, 0.0),
                           machine)


def test_index_moves(machine) -> None:  # type: ignore[no-untyped-def]
    # C alone turns 180 deg: C limits 180 deg/s, 1800 deg/s^2, 18000 deg/s^3
    end = np.array([[0, 0, 0, 0, math.pi], [0, 0, 0, 0, 0]])
    t = index_moves_time(np.zeros((2, 5)), end, machine)
    v, a, tj = 1.0, 10.0, 0.1  # path units: 180 deg = 1
    assert t[1] == 0.0
    assert t[0] == pytest.approx(2 * (v / a + tj) + (1 - v * (v / a + tj)) / v, rel=1e-12)


def test_cycle_time_of_an_nc_file(machine, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    nc = tmp_path / "p.ngc"
    nc.write_text("G21 G90 G94\nG0 X0 Y0 Z0 A0 C0\nG1 X100 F600\nG0 X0\nM2\n")
    prog = read_nc(nc)
    times = program_cycle_time(prog, machine, program_joints(prog, machine))
    assert times.nominal_total == pytest.approx(10.0 + 100.0 / 600.0)
    assert times.limited_total > times.nominal_total


def test_tcp_blocks_map_to_joints(machine) -> None:  # type: ignore[no-untyped-def]
    tips = np.array([[10.0, 5.0, 20.0], [12.0, -3.0, 18.0]])
    angles = np.array([[math.radians(-30.0), math.radians(40.0)],
                       [math.radians(-10.0), math.radians(-75.0)]])
    prog = _program(np.hstack([tips, angles]), Motion.LINEAR, 500.0, tcp=True)
    joints = program_joints(prog, machine)
    tip, _ = kinematics_for(machine).forward(joints)
    assert np.allclose(tip, tips, atol=1e-9)


def _circle(machine, sign: float, n: int = 400, feed: float = 3000.0) -> MachineProgram:  # type: ignore[no-untyped-def]
    th = np.linspace(0.0, 2 * np.pi, n + 1)[1:]
    joints = np.zeros((n, 5))
    joints[:, 0], joints[:, 1], joints[:, 2], joints[:, 4] = 8 * np.cos(th), \
        sign * 8 * np.sin(th), 10.0, th
    return _program(joints, Motion.LINEAR, feed, start=np.array([8.0, 0, 10.0, 0, 0]))


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_program_servo_deviation_and_kffp(unmatched, sign: float) -> None:  # type: ignore[no-untyped-def]
    # C turns once while X/Y circle with R_W = 8 mm: with one sign the tool tip runs
    # round a circle in W, with the other it stays put in W (the paper's relative
    # motion: the lag mismatch alpha - beta is all that moves it). The machine at
    # Table 1's K_FFP (100 %): the paper's unmatched X, which the Best K_FFP matches.
    machine = unmatched
    program = _circle(machine, sign)
    report = simulate_program(program, machine)
    assert report.default_axes == ["Z", "A"]
    # C turns 2 pi over the blocks' commanded times (the blended interpolator slows
    # the 400 corners below the feed; nominally C's 180 deg/s makes it 2 s)
    durations = commanded_durations(program, machine, program.joints)
    assert durations.sum() >= 2.0 - 1e-9
    # the RMS rotary speed lies between the mean and the fastest block's
    fastest = float(np.max((2 * np.pi / len(durations)) / durations))
    assert 2 * math.pi / durations.sum() - 1e-12 <= report.omega <= fastest + 1e-12
    axes = machine_axis_models(machine).by_name()
    assert report.reference_axis == "C"
    assert report.recommended_kffp["X"] == pytest.approx(
        best_kffp(axes["C"], axes["X"], report.omega), rel=1e-9)
    assert np.all(np.isfinite(report.deviation)) and np.all(report.deviation <= report.tracking
                                                            + 1e-12)
    # steady state (second half): the recommended K_FFP cuts the contour error
    steady = slice(200, 400)
    assert report.deviation_recommended is not None
    assert np.median(report.deviation_recommended[steady]) < 0.2 * np.median(
        report.deviation[steady])
    tips, _ = kinematics_for(machine).forward(program.joints)
    if np.ptp(tips, axis=0).max() < 1e-9:
        # Eq. (7): the shape error's amplitude is |alpha - beta| R_W (X lags least)
        from cam.motion.feeddrive import alpha_th, beta_th

        w = float(np.median((2 * np.pi / len(durations)) / durations[steady]))
        mismatch = abs(float(alpha_th(axes["C"], w) - beta_th(axes["X"], w))) * 8
        assert report.deviation[steady].max() == pytest.approx(mismatch, rel=0.25)
