"""Contour error with every axis modelled (issue 26): closed forms and the paper's test."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from cam.motion.axis_models import AxisModels, machine_axis_models
from cam.motion.feeddrive import FeedDriveAxis, load_feed_drives
from cam.motion.program_servo import commanded_durations, simulate_program
from cam.motion.schema import FeedDriveFile
from cam.motion.synchronisation import circle_sweep, saturation_figures
from cam.motion.tomlio import read_toml
from impeller_cam.errors import InputError
from impeller_cam.schema import validate
from postproc.machine import load_machine
from postproc.program import MachineProgram, Motion

ROOT = Path(__file__).resolve().parents[2]
SUZUKI = ROOT / "fixtures" / "motion" / "suzuki_table1.toml"


@pytest.fixture(scope="module")
def machine():  # type: ignore[no-untyped-def]
    return load_machine(ROOT / "fixtures" / "machines" / "trunnion-500.toml")


def _program(joints: np.ndarray, feed: float, start: np.ndarray) -> MachineProgram:
    n = len(joints)
    return MachineProgram(joints=joints, motion=np.full(n, Motion.LINEAR),
                          feed_mode=np.full(n, 94), feed=np.full(n, feed),
                          line=np.arange(1, n + 1), tcp=np.zeros(n, dtype=bool),
                          tool_number=np.ones(n, dtype=np.int32), start=start)


def _identical(machine, axis: FeedDriveAxis) -> AxisModels:  # type: ignore[no-untyped-def]
    specs = list(machine.axes.values())
    models = {c: FeedDriveAxis(**{**axis.__dict__, "name": s.name, "rotary": s.rotary})
              for c, s in enumerate(specs)}
    return AxisModels(models=models, source={s.name: "identified" for s in specs})


def test_every_axis_is_modelled(machine) -> None:  # type: ignore[no-untyped-def]
    models = machine_axis_models(machine)
    assert len(models.models) == 5
    assert models.source["Z"] == "default: matched to Y"  # Y lags more than X (Ts)
    assert models.source["A"] == "default: matched to C"
    z, a = models.models[2], models.models[3]
    # the machine's limit: the torque that gives the file's acceleration
    spec_a = machine.axes["A"]
    assert a.torque_limit == pytest.approx(a.total_inertia * spec_a.acceleration, rel=1e-12)
    assert z.torque_limit == pytest.approx(
        z.total_inertia * machine.axes["Z"].acceleration * 1e-3, rel=1e-12)
    assert (z.kpp, z.ts, z.ta, z.tp, z.k_ffp) == (60.0, 0.064, 0.015, 0.005, 100.0)


def test_no_servo_data_is_refused(machine) -> None:  # type: ignore[no-untyped-def]
    from dataclasses import replace
    from types import MappingProxyType

    bare = replace(machine, axes={n: replace(s, servo=MappingProxyType({}))
                                  for n, s in machine.axes.items()})
    with pytest.raises(InputError, match="no axis has servo data"):
        machine_axis_models(bare)


@pytest.mark.parametrize("turn", [False, True])
def test_identical_gains_straight_line_has_no_contour_error(machine, turn: bool) -> None:  # type: ignore[no-untyped-def]
    # identical linear loops keep the actual joints on the commanded joint line, so
    # the tip stays on the commanded tip path and the lag is along it. With the table
    # still (A, C at -0.3, 0.8 rad) the tip path in W is a straight line: zero contour
    # error (rounding). With all five joints moving the tip path is curved in W; what
    # remains is the polyline's chords and the overshoot past the path's end, which
    # runs along the end tangent, not along the curve (< 1 um).
    drives = load_feed_drives(SUZUKI)
    axis = drives["Y"]  # Ts 64 ms, Ta 15 ms, Tp 5 ms, K_FFP 100 %, no torque limit
    start = np.array([0.0, 0.0, 20.0, -0.3, 0.8]) if not turn else np.array(
        [0.0, 0.0, 20.0, 0.0, 0.0])
    program = _program(np.array([[30.0, -20.0, 10.0, -0.3, 0.8]]), 1200.0, start)
    report = simulate_program(program, machine, recommend=False,
                              models=_identical(machine, axis))
    assert report.tracking.max() > 0.1  # the axes lag ...
    assert report.deviation.max() < (1e-3 if turn else 1e-9)  # ... along the path only
    assert report.tool_axis.max() < (1e-3 if turn else 1e-9)


@pytest.mark.parametrize("k_ffp", [0.0, 50.0])
def test_identical_gains_circle_radius_decrease(machine, k_ffp: float) -> None:  # type: ignore[no-untyped-def]
    # X/Y on a circle of R = 20 mm at omega = v / R; every axis the same loop:
    # position gain Kpp, velocity feed-forward K_FFP, velocity PI on J s^2 + C s:
    #   T_v = (Kvp s + Kvi) / (J s^2 + (C + Kvp) s + Kvi)
    #   G = T_v (Kpp + K_FFP/100 s) / (s + Kpp T_v)   (Ts = Ta = Tp = 0)
    # steady state: the radius shrinks to R |G(j omega)|
    axis = FeedDriveAxis(name="X", rotary=False, kpp=30.0, kvp=4700.0, kvi=0.274,
                         inertia=5.0, viscous=5.0, ts=0.0, ta=0.0, tp=0.0, k_ffp=k_ffp)
    radius, feed, n = 20.0, 3000.0, 720
    angle = np.linspace(0.0, 2.0 * np.pi, n + 1)[1:]
    joints = np.zeros((n, 5))
    joints[:, 0], joints[:, 1], joints[:, 2] = radius * np.cos(angle), \
        radius * np.sin(angle), 10.0
    program = _program(joints, feed, np.array([radius, 0.0, 10.0, 0.0, 0.0]))
    report = simulate_program(program, machine, recommend=False,
                              models=_identical(machine, axis))
    chord = 2.0 * radius * math.sin(math.pi / n)
    omega = feed / 60.0 / (n * chord) * 2.0 * math.pi  # at the feed between start and end
    s = 1j * omega
    tv = (axis.kvp * s + axis.kvi) / (axis.inertia * s**2 + (axis.viscous + axis.kvp) * s
                                      + axis.kvi)
    gain = abs(tv * (axis.kpp + k_ffp / 100.0 * s) / (s + axis.kpp * tv))
    expected = radius * (1.0 - gain)
    sagitta = radius * (1.0 - math.cos(math.pi / n))  # the command's own chord error
    # steady state: the second half's blocks at the feed (the program brakes to rest
    # at its end: the interpolator's blended times), less the lag's last few blocks
    durations = commanded_durations(program, machine, joints)
    cruise = np.flatnonzero(np.isclose(durations, chord / (feed / 60.0), rtol=1e-9))
    cruise = cruise[(cruise >= n // 2) & (cruise < cruise.max() - 10)]
    assert len(cruise) > n // 4
    steady = report.deviation[cruise]
    assert expected > 20 * sagitta
    assert np.median(steady) == pytest.approx(expected + sagitta / 2, rel=0.03)
    assert steady.max() - steady.min() < 0.05 * expected + sagitta


@pytest.fixture(scope="module")
def circle():  # type: ignore[no-untyped-def]
    doc = validate(FeedDriveFile, read_toml(SUZUKI, "feed-drive"), SUZUKI)
    assert doc.circle_test is not None
    return load_feed_drives(SUZUKI), doc.circle_test


def test_best_kffp_beats_machine_kffp_at_every_omega(circle) -> None:  # type: ignore[no-untyped-def]
    drives, test = circle
    assert min(test.omega) == pytest.approx(math.pi) and max(test.omega) == pytest.approx(
        3.2 * math.pi)
    points = circle_sweep(drives, test, dt=2e-4)
    assert len(points) == len(test.omega) * len(test.load_inertia)
    for p in points:
        assert p.best_amplitude < p.machine_amplitude
        assert p.best_amplitude < 0.01  # microns once the lags are matched
    # the mismatch grows with omega (Eq. 7: (alpha - beta) R_W sin(omega t))
    first = [p.machine_amplitude for p in points if p.total_inertia == points[0].total_inertia]
    assert np.all(np.diff(first) > 0)


def test_saturation_figures(circle) -> None:  # type: ignore[no-untyped-def]
    drives, test = circle
    figures = saturation_figures(drives["C"], test)
    assert figures[0].limit_acceleration == pytest.approx(725.0 / 5.9, rel=1e-12)  # 122.9
    for f in figures:
        # the paper's accelerations are its saturation speeds over Ts = 0.064 s ...
        assert f.paper_acceleration_from_omega == pytest.approx(f.paper_acceleration,
                                                                abs=0.1)
        # ... and exceed what 725 N m gives the inertia alone
        assert f.paper_torque > 725.0
        # the simulated drive saturates before the ideal follower (loop overshoot)
        assert f.model_omega < f.limit_omega < f.paper_omega


def test_identify_drive_recovers_the_axis_from_the_fixture() -> None:
    # the fixture is Table 1's C (J 4.2, C 5, Ta 15 ms, Tp 5 ms) + 0.001 deg noise;
    # start 30 % / 100 % / 30 % / 50 % off and fit what the paper identifies
    from dataclasses import replace

    from cam.motion.identify import read_response_csv
    from cam.motion.identify_drive import identify_drive

    true = load_feed_drives(SUZUKI)["C"]
    response = read_response_csv(ROOT / "fixtures" / "motion" / "feed_drive_response.csv")
    start = replace(true, inertia=1.3 * true.inertia, viscous=2.0 * true.viscous,
                    ta=0.7 * true.ta, tp=1.5 * true.tp)
    fit = identify_drive(response, start)
    assert fit.axis.ta == pytest.approx(true.ta, rel=0.01)
    assert fit.axis.tp == pytest.approx(true.tp, rel=0.02)
    assert fit.axis.inertia == pytest.approx(true.inertia, rel=0.02)
    assert fit.axis.viscous == pytest.approx(true.viscous, rel=0.1)
    assert fit.rms_residual == pytest.approx(1e-3, rel=0.1)  # down to the noise


def test_identify_drive_needs_a_position() -> None:
    from cam.motion.identify import read_response_csv
    from cam.motion.identify_drive import identify_drive

    response = read_response_csv(ROOT / "fixtures" / "motion" / "indexing_response.csv")
    with pytest.raises(InputError, match="measured axis position"):
        identify_drive(response, load_feed_drives(SUZUKI)["C"])
