"""Tool postures (M3 step 2, eq. 7) and the finishing options: hand-computed cases."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cam.finishing.options import FinishOptions, scallop_stepover
from cam.finishing.posture import (
    angle_between,
    c_max,
    enforce_normal_angle,
    initial_axes,
    lead_tilt,
    rotate_about_z,
)
from impeller_cam.errors import InputError


def test_scallop_stepover_hand_case() -> None:
    # w = 2 sqrt(h (d - h)), d = 6, h = 0.02: 2 sqrt(0.1196) = 0.691665
    assert scallop_stepover(3.0, 0.02) == pytest.approx(0.6916646, abs=1e-6)
    # the two ball circles at distance w meet exactly h above the plane
    w, r, h = scallop_stepover(2.0, 0.1), 2.0, 0.1
    assert r - math.sqrt(r * r - (w / 2) ** 2) == pytest.approx(h, abs=1e-12)
    with pytest.raises(InputError, match="scallop"):
        scallop_stepover(2.0, 2.5)


def test_options_validate_and_name_the_field() -> None:
    assert FinishOptions().basis_functions == 4
    with pytest.raises(InputError, match="basis_functions"):
        FinishOptions(basis_functions=3)
    with pytest.raises(InputError, match="scallop_mm"):
        FinishOptions(scallop_mm=-1.0)
    with pytest.raises(InputError, match="'colour': unknown finishing option"):
        FinishOptions.from_mapping({"colour": 1})
    with pytest.raises(InputError, match="smoothing_scope"):
        FinishOptions(smoothing_scope="global")
    with pytest.raises(InputError, match="tilt_directions"):
        FinishOptions(tilt_directions=0)
    with pytest.raises(InputError, match="tilt_search_deg"):
        FinishOptions(tilt_search_deg=-1.0)
    with pytest.raises(InputError, match="repair_rounds"):
        FinishOptions(repair_rounds=1.5)  # type: ignore[arg-type]


def test_cutter_allowance_is_within_the_gouge_tolerance() -> None:
    # the planner's shrunk ball must not accept what the verifier calls a gouge
    from impeller_cam import DEFAULT_TOLERANCES

    allowance = FinishOptions().cutter_allowance_mm
    assert DEFAULT_TOLERANCES.tessellation < allowance <= DEFAULT_TOLERANCES.gouge
    with pytest.raises(InputError, match="cutter_allowance_mm.*gouge tolerance"):
        FinishOptions(cutter_allowance_mm=DEFAULT_TOLERANCES.gouge + 0.01)


def test_initial_axis_turns_about_c_away_from_the_wall() -> None:
    # ruling along +X, wall normal +Y: turning about +Z by +1.5 deg moves the top to +Y
    ruling = np.array([[1.0, 0.0, 0.0], [0.0, 0.6, 0.8]])
    away = np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])
    axis, sign = initial_axes(ruling[:1], away[:1], math.radians(1.5))
    assert sign == 1.0
    assert axis[0] == pytest.approx([math.cos(math.radians(1.5)),
                                     math.sin(math.radians(1.5)), 0.0], abs=1e-15)
    # a ruling (0, .6, .8) with the wall on -X... the top must go to -X: sign +1 turns
    # (0, .6) to (-.6 sin, .6 cos): towards -X
    axis, sign = initial_axes(ruling[1:], away[1:], math.radians(2.0))
    assert sign == 1.0 and axis[0, 0] < 0
    assert axis[0, 2] == pytest.approx(0.8)  # A (tilt from Z) unchanged by a C turn


def test_enforce_normal_angle_reaches_the_minimum_exactly() -> None:
    normal = np.array([[0.0, 0.0, 1.0]] * 3)
    tangent = np.array([[1.0, 0.0, 0.0]] * 3)
    axis = np.array([[0.0, 0.0, 1.0], [math.sin(0.02), 0.0, math.cos(0.02)],
                     [0.0, math.sin(0.5), math.cos(0.5)]])
    out, changed = enforce_normal_angle(axis, normal, tangent, math.radians(5.0))
    assert changed.tolist() == [True, True, False]
    assert np.degrees(angle_between(out[:2], normal[:2])) == pytest.approx([5.0, 5.0], abs=1e-9)
    assert out[0] == pytest.approx([math.sin(math.radians(5)), 0, math.cos(math.radians(5))])
    assert out[2] == pytest.approx(axis[2])


def test_lead_and_tilt_hand_case() -> None:
    # normal +Z, feed +X; axis leaned 10 deg forward and 20 deg sideways (towards +Y)
    a = np.array([[math.tan(math.radians(10)), math.tan(math.radians(20)), 1.0]])
    a /= np.linalg.norm(a)
    lead, tilt = lead_tilt(a, np.array([[0.0, 0.0, 1.0]]), np.array([[1.0, 0.0, 0.3]]))
    assert math.degrees(lead[0]) == pytest.approx(10.0)
    assert math.degrees(tilt[0]) == pytest.approx(20.0)


def test_c_max_equation_7() -> None:
    # E at the origin, EC along +Z, F at (1, 0, 1): Cmax = acos(1 / sqrt 2) = 45 deg
    e = np.zeros((1, 3))
    assert math.degrees(c_max(e, np.array([[0.0, 0.0, 2.0]]),
                              np.array([[1.0, 0.0, 1.0]]))[0]) == pytest.approx(45.0)


def test_rotate_about_z() -> None:
    v = np.array([[1.0, 0.0, 0.5]])
    assert rotate_about_z(v, math.pi / 2)[0] == pytest.approx([0.0, 1.0, 0.5], abs=1e-15)
