"""Kinematics: hand-computed cases, the LinuxCNC formulas, branches, singularity, limits."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from numpy import cos, radians, sin

from impeller_cam.errors import InputError
from postproc.kinematics import (
    OverTravelError,
    available_kinematics,
    c_swing_report,
    kinematics_for,
    register_kinematics,
)
from postproc.kinematics import registry as registry_module
from postproc.machine import PivotOffsets, ideal_machine, load_machine

MACHINES = Path(__file__).resolve().parents[2] / "fixtures" / "machines"


def _kins(kind: str = "xyzac-trt", conventional: bool = False, **pivot: float):
    return kinematics_for(ideal_machine(kind, PivotOffsets(**pivot), conventional))


def _angle_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.sum(a * b, axis=1))


# ------------------------------------------------------------------ hand-computed cases
def test_forward_tilt_90_about_x_default_directions() -> None:
    # A = +90 deg turns the table right-handed about +X: the table's +Y points up.
    # Machine point (0, 0, 10) then touches table point (0, 10, 0).
    tip, axis = _kins().forward(np.array([[0.0, 0.0, 10.0, radians(90.0), 0.0]]))
    np.testing.assert_allclose(tip, [[0.0, 10.0, 0.0]], atol=1e-12)
    np.testing.assert_allclose(axis, [[0.0, 1.0, 0.0]], atol=1e-15)


def test_forward_tilt_90_with_pivot_offsets() -> None:
    # Pivot at (0, 20, 10) (xyzac-trt sim). Machine origin relative to pivot:
    # (0, -20, -10); un-tilting by -90 deg about X gives (0, -10, 20); plus pivot:
    # table point (0, 10, 30).
    kins = _kins(y_offset=20.0, z_offset=10.0)
    tip, _ = kins.forward(np.array([[0.0, 0.0, 0.0, radians(90.0), 0.0]]))
    np.testing.assert_allclose(tip, [[0.0, 10.0, 30.0]], atol=1e-12)


@pytest.mark.parametrize(("conventional", "expected"), [(False, -10.0), (True, 10.0)])
def test_forward_c_90_both_directions(conventional: bool, expected: float) -> None:
    # Default: C = +90 deg turns the table counter-clockwise seen from +Z, so the
    # machine point (10, 0, 0) sits over table point (0, -10, 0); conventional: (0, 10, 0).
    tip, axis = _kins(conventional=conventional).forward(
        np.array([[10.0, 0.0, 0.0, 0.0, radians(90.0)]])
    )
    np.testing.assert_allclose(tip, [[0.0, expected, 0.0]], atol=1e-12)
    np.testing.assert_allclose(axis, [[0.0, 0.0, 1.0]], atol=1e-15)


def test_tool_axis_formula_of_method_m2() -> None:
    # A tool axis T = (x, y, z): C brings T into the Y-Z plane, phi_z = acos(y / f),
    # f = sqrt(x^2 + y^2); A brings it onto +Z, phi_x = acos(z / e), e = sqrt(y^2+z^2)
    # after the C turn. Hand case T = (1, 1, sqrt 2)/2: f = sqrt(2)/2, phi_z = 45 deg;
    # after C, T = (0, 1, 1)/sqrt 2 so phi_x = 45 deg.
    axis = np.array([[0.5, 0.5, math.sqrt(2.0) / 2.0]])
    branches = _kins().inverse_branches(np.zeros((1, 3)), axis)
    np.testing.assert_allclose(np.degrees(branches[0, 0, 3:]), [45.0, 45.0], atol=1e-12)
    np.testing.assert_allclose(np.degrees(branches[1, 0, 3:]), [-45.0, -135.0], atol=1e-12)


def test_tool_length_moves_the_controlled_point_up_the_spindle() -> None:
    kins = _kins(y_offset=20.0, z_offset=10.0)
    joints = np.array([[5.0, -3.0, 40.0, radians(-35.0), radians(130.0)]])
    tip_at_tip, axis = kins.forward(joints)
    lifted = joints.copy()
    lifted[0, 2] += 25.0
    tip_long, axis_long = kins.forward(lifted, tool_length=25.0)
    np.testing.assert_allclose(tip_long, tip_at_tip, atol=1e-12)
    np.testing.assert_allclose(axis_long, axis, atol=1e-15)


# ------------------------------------------------------------ same meaning as LinuxCNC
def _lcnc_xyzac_forward(j: np.ndarray, pins: dict, conventional: bool) -> np.ndarray:
    """xyzacKinematicsForward of LinuxCNC trtfuncs.c / trtfuncs_math.h, term by term."""
    xr, yr, zr = pins["x_rot_point"], pins["y_rot_point"], pins["z_rot_point"]
    dy, dz = pins["y_offset"], pins["z_offset"] + pins["tool_offset"]
    con = 1.0 if conventional else -1.0
    x_, y_, z_, a, c = j[:, 0], j[:, 1], j[:, 2], radians(j[:, 3]), radians(j[:, 4])
    x = (
        cos(c) * (x_ - xr)
        - con * sin(c) * cos(a) * (y_ - dy - yr)
        + sin(c) * sin(a) * (z_ - dz - zr)
        - con * sin(c) * dy
        + xr
    )
    y = (
        con * sin(c) * (x_ - xr)
        + cos(c) * cos(a) * (y_ - dy - yr)
        - con * cos(c) * sin(a) * (z_ - dz - zr)
        + cos(c) * dy
        + yr
    )
    z = con * sin(a) * (y_ - dy - yr) + cos(a) * (z_ - dz - zr) + dz + zr
    return np.stack([x, y, z], axis=1)


def _lcnc_xyzac_inverse(p: np.ndarray, a_deg, c_deg, pins: dict, conventional: bool):
    """xyzacKinematicsInverse of LinuxCNC trtfuncs.c / trtfuncs_math.h, term by term."""
    xr, yr, zr = pins["x_rot_point"], pins["y_rot_point"], pins["z_rot_point"]
    dy, dz = pins["y_offset"], pins["z_offset"] + pins["tool_offset"]
    con = 1.0 if conventional else -1.0
    a, c = radians(a_deg), radians(c_deg)
    px, py, pz = p[:, 0] - xr, p[:, 1] - yr, p[:, 2] - zr
    x = cos(c) * px + con * sin(c) * py + xr
    y = (
        -con * sin(c) * cos(a) * px
        + cos(c) * cos(a) * py
        + con * sin(a) * pz
        - cos(a) * dy
        - con * sin(a) * dz
        + dy
        + yr
    )
    z = (
        sin(c) * sin(a) * px
        - con * cos(c) * sin(a) * py
        + cos(a) * pz
        + con * sin(a) * dy
        - cos(a) * dz
        + dz
        + zr
    )
    return np.stack([x, y, z], axis=1)


def _lcnc_xyzbc_forward(j: np.ndarray, pins: dict, conventional: bool) -> np.ndarray:
    """xyzbcKinematicsForward of LinuxCNC trtfuncs.c / trtfuncs_math.h, term by term."""
    xr, yr, zr = pins["x_rot_point"], pins["y_rot_point"], pins["z_rot_point"]
    dx, dz = pins["x_offset"], pins["z_offset"] + pins["tool_offset"]
    con = 1.0 if conventional else -1.0
    x_, y_, z_, b, c = j[:, 0], j[:, 1], j[:, 2], radians(j[:, 3]), radians(j[:, 4])
    x = (
        cos(c) * cos(b) * (x_ - dx - xr)
        - con * sin(c) * (y_ - yr)
        + con * cos(c) * sin(b) * (z_ - dz - zr)
        + cos(c) * dx
        + xr
    )
    y = (
        con * sin(c) * cos(b) * (x_ - dx - xr)
        + cos(c) * (y_ - yr)
        + sin(c) * sin(b) * (z_ - dz - zr)
        + con * sin(c) * dx
        + yr
    )
    z = -con * sin(b) * (x_ - dx - xr) + cos(b) * (z_ - dz - zr) + dz + zr
    return np.stack([x, y, z], axis=1)


PINS = {
    "x_rot_point": 1.0,
    "y_rot_point": 2.0,
    "z_rot_point": 5.0,
    "x_offset": 3.0,
    "y_offset": 20.0,
    "z_offset": 11.0,
    "tool_offset": 7.0,
}


def _random_joints(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    joints_deg = np.column_stack(
        [rng.uniform(-150, 150, (n, 3)), rng.uniform(-120, 120, n), rng.uniform(-720, 720, n)]
    )
    return joints_deg


@pytest.mark.parametrize("conventional", [False, True])
def test_xyzac_matches_linuxcnc_forward_and_inverse(conventional: bool) -> None:
    pivot = PivotOffsets(**{k: v for k, v in PINS.items() if k not in ("tool_offset", "x_offset")})
    kins = kinematics_for(ideal_machine("xyzac-trt", pivot, conventional))
    joints_deg = _random_joints(200, seed=3)
    joints = joints_deg.copy()
    joints[:, 3:] = radians(joints_deg[:, 3:])
    length = PINS["tool_offset"]
    tip, axis = kins.forward(joints, tool_length=length)
    # LinuxCNC's world pose = tip + rot point + tool offset along table Z (G43 adds it)
    world = _lcnc_xyzac_forward(joints_deg, PINS, conventional)
    expected = world - kins.world_from_workpiece(np.zeros((1, 3))) - [0.0, 0.0, length]
    np.testing.assert_allclose(tip, expected, atol=1e-10)
    back = _lcnc_xyzac_inverse(world, joints_deg[:, 3], joints_deg[:, 4], PINS, conventional)
    np.testing.assert_allclose(back, joints[:, :3], atol=1e-10)
    mine = kins.inverse(tip, axis, tool_length=length)
    np.testing.assert_allclose(
        _lcnc_xyzac_inverse(
            world, np.degrees(mine[:, 3]), np.degrees(mine[:, 4]), PINS, conventional
        ),
        mine[:, :3],
        atol=1e-10,
    )


@pytest.mark.parametrize("conventional", [False, True])
def test_xyzbc_matches_linuxcnc_forward(conventional: bool) -> None:
    pivot = PivotOffsets(**{k: v for k, v in PINS.items() if k not in ("tool_offset", "y_offset")})
    kins = kinematics_for(ideal_machine("xyzbc-trt", pivot, conventional))
    joints_deg = _random_joints(200, seed=4)
    joints = joints_deg.copy()
    joints[:, 3:] = radians(joints_deg[:, 3:])
    tip, axis = kins.forward(joints, tool_length=PINS["tool_offset"])
    world = _lcnc_xyzbc_forward(joints_deg, PINS, conventional)
    expected = world - [1.0, 2.0, 5.0] - [0.0, 0.0, PINS["tool_offset"]]
    np.testing.assert_allclose(tip, expected, atol=1e-10)
    # tool axis = the coefficients of joint Z in LinuxCNC's forward map
    b, c = joints[:, 3], joints[:, 4]
    con = 1.0 if conventional else -1.0
    np.testing.assert_allclose(
        axis, np.column_stack([con * cos(c) * sin(b), sin(c) * sin(b), cos(b)]), atol=1e-15
    )
    # and the inverse lands on the same joints (C is wound next to the original)
    back = kins.inverse(tip, axis, tool_length=PINS["tool_offset"], previous=joints[0])
    tip_back, _ = kins.forward(back, tool_length=PINS["tool_offset"])
    np.testing.assert_allclose(tip_back, tip, atol=1e-10)


# ------------------------------------------------------------------ branch selection
def test_inverse_picks_the_branch_inside_the_a_limits() -> None:
    machine = load_machine(MACHINES / "xyzac-trt.toml")  # A -100 .. +50 deg
    kins = kinematics_for(machine)
    tilt = radians(70.0)
    axis = np.array([[0.0, sin(tilt), cos(tilt)]])
    joints = kins.inverse(np.array([[0.0, 0.0, 5.0]]), axis)
    assert np.degrees(joints[0, 3]) == pytest.approx(-70.0, abs=1e-12)
    assert np.degrees(joints[0, 4]) == pytest.approx(180.0, abs=1e-12)
    tip, axis_back = kins.forward(joints)
    np.testing.assert_allclose(tip, [[0.0, 0.0, 5.0]], atol=1e-12)
    np.testing.assert_allclose(axis_back, axis, atol=1e-15)


def test_inverse_starts_next_to_previous_joints() -> None:
    kins = _kins()
    axis = np.array([[sin(0.3) * sin(0.2), cos(0.3) * sin(0.2), cos(0.2)]])
    # the pose: tilt +0.2 at C 0.3 rad, or tilt -0.2 at C 0.3 - pi (any winding).
    # From (A -0.2, C 720 deg - 2.74 rad) the negative branch wound next to 720 deg costs
    # 0.1 rad of travel; the positive branch 0.4 + 3.04 rad.
    previous = np.array([0.0, 0.0, 0.0, -0.2, 4 * math.pi - 2.74])
    joints = kins.inverse(np.zeros((1, 3)), axis, previous=previous)
    assert joints[0, 3] == pytest.approx(-0.2, abs=1e-12)
    assert joints[0, 4] == pytest.approx(4 * math.pi + 0.3 - math.pi, abs=1e-12)
    # from (A +0.1, C -360 deg) the positive branch wins, wound next to -360 deg
    previous = np.array([0.0, 0.0, 0.0, 0.1, -2 * math.pi])
    joints = kins.inverse(np.zeros((1, 3)), axis, previous=previous)
    assert joints[0, 3] == pytest.approx(0.2, abs=1e-12)
    assert joints[0, 4] == pytest.approx(-2 * math.pi + 0.3, abs=1e-12)


def _crossing_path(half: int = 120, dwell: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """Tool axis swinging through the C axis while its azimuth turns 540 deg.

    The tilt falls from 30 deg to 0 while the azimuth turns 0 .. 270 deg, rests on the C
    axis for ``dwell`` more poses, then rises to 30 deg on the far side (tilt -30 in the
    same plane) while the azimuth turns on to 540 deg: 2.25 deg of azimuth per pose.
    """
    s = np.concatenate(
        [np.linspace(0.0, 1.0, half + 1), np.ones(dwell), 1.0 + np.linspace(0.0, 1.0, half + 1)[1:]]
    )
    tilt = radians(30.0) * (1.0 - s)
    azimuth = 1.5 * math.pi * s
    axis = np.column_stack([sin(azimuth) * sin(tilt), cos(azimuth) * sin(tilt), cos(tilt)])
    axis[half : half + dwell + 1] = [0.0, 0.0, 1.0]  # exactly on the C axis: C undefined
    tip = np.column_stack([20.0 * cos(azimuth), 20.0 * sin(azimuth), 10.0 + 5.0 * s])
    return tip, axis


@pytest.mark.parametrize("conventional", [False, True])
def test_path_through_singularity_keeps_c_and_unwinds(conventional: bool) -> None:
    kins = _kins(conventional=conventional, y_offset=20.0, z_offset=10.0)
    tip, axis = _crossing_path()
    joints = kins.inverse(tip, axis)
    steps = np.abs(np.diff(joints[:, 3:], axis=0))
    # no rotary jumps: C steps 2.25 deg per pose as the azimuth does, except the one
    # catch-up step after the dwell, where C waited one pose on the singular point
    assert np.degrees(steps.max()) == pytest.approx(4.5, abs=1e-9)
    assert np.count_nonzero(np.degrees(steps[:, 1]) > 2.25 + 1e-9) == 1
    # C is unwound: it turns through 540 deg in total, not wrapped to +-180
    assert abs(np.degrees(joints[-1, 4] - joints[0, 4])) == pytest.approx(540.0, abs=1e-9)
    # the singular dwell keeps the C of the pose before it, and A is exactly 0 there
    np.testing.assert_array_equal(joints[120:125, 4], joints[119, 4])
    np.testing.assert_array_equal(joints[120:125, 3], 0.0)
    # A passes through 0 continuously: it changes sign exactly once
    signs = np.sign(joints[:, 3])
    assert np.count_nonzero(np.diff(signs[signs != 0.0])) == 1
    tip_back, axis_back = kins.forward(joints)
    np.testing.assert_allclose(tip_back, tip, atol=1e-9)
    assert _angle_between(axis_back, axis).max() < 1e-12


def test_leading_singular_poses_take_the_first_defined_c() -> None:
    kins = _kins()
    axis = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [1.0, 0.0, 1.0]])
    joints = kins.inverse(np.zeros((3, 3)), axis)
    np.testing.assert_allclose(joints[:, 4], math.pi / 2, atol=1e-15)
    np.testing.assert_allclose(joints[:2, 3], 0.0, atol=0)


def test_all_singular_path_keeps_previous_c_or_zero() -> None:
    kins = _kins()
    up = np.tile([0.0, 0.0, 1.0], (3, 1))
    np.testing.assert_array_equal(kins.inverse(np.zeros((3, 3)), up)[:, 3:], 0.0)
    previous = np.array([0.0, 0.0, 0.0, 0.3, -7.0])
    joints = kins.inverse(np.zeros((3, 3)), up, previous=previous)
    np.testing.assert_array_equal(joints[:, 4], -7.0)
    np.testing.assert_array_equal(joints[:, 3], 0.0)


def _turning_axis(n: int = 61, turn_deg: float = 300.0) -> np.ndarray:
    azimuth = np.linspace(0.0, radians(turn_deg), n)
    tilt = radians(20.0)
    return np.column_stack(
        [sin(azimuth) * sin(tilt), cos(azimuth) * sin(tilt), np.full(n, cos(tilt))]
    )


def test_finite_c_range_rewinds_inside_the_limits() -> None:
    # C +-200 deg and A 0 .. 90 deg: turning the tool axis 300 deg about the C axis
    # needs one re-wind of C by 360 deg (5 deg per pose: the step is 355 deg)
    machine = ideal_machine(
        "xyzac-trt", limits={"A": (0.0, radians(90.0)), "C": (-radians(200.0), radians(200.0))}
    )
    joints = kinematics_for(machine).inverse(np.zeros((61, 3)), _turning_axis())
    assert np.all(np.abs(joints[:, 4]) <= radians(200.0) + 1e-12)
    np.testing.assert_allclose(joints[:, 3], radians(20.0), atol=1e-12)
    steps = np.degrees(np.diff(joints[:, 4]))
    assert np.count_nonzero(np.abs(steps) > 180.0) == 1
    assert steps[np.abs(steps) > 180.0][0] == pytest.approx(5.0 - 360.0, abs=1e-9)


def test_finite_c_range_prefers_a_branch_flip_to_a_rewind() -> None:
    # with A free both ways the least-travel rule flips the branch instead:
    # 40 deg of A + 180 deg of C (220 deg) beats a 355 deg re-wind of C
    machine = ideal_machine("xyzac-trt", limits={"C": (-radians(200.0), radians(200.0))})
    joints = kinematics_for(machine).inverse(np.zeros((61, 3)), _turning_axis())
    assert np.all(np.abs(joints[:, 4]) <= radians(200.0) + 1e-12)
    flips = np.flatnonzero(np.diff(np.sign(joints[:, 3])))
    assert len(flips) == 1
    k = flips[0]
    assert np.degrees(abs(joints[k + 1, 4] - joints[k, 4])) == pytest.approx(175.0, abs=1e-9)


# ------------------------------------------------------------------ limits and errors
def test_pose_out_of_limits_names_index_axis_value_and_limit() -> None:
    machine = load_machine(MACHINES / "xyzac-trt.toml")
    kins = kinematics_for(machine)
    tilt = np.radians([10.0, 20.0, 110.0, 30.0])
    axis = np.column_stack([np.zeros(4), sin(tilt), cos(tilt)])
    with pytest.raises(OverTravelError) as caught:
        kins.inverse(np.zeros((4, 3)), axis, records=np.array([11, 12, 13, 14]))
    error = caught.value
    # +110 misses A <= +50 by 60 deg; -110 misses A >= -100 by 10 deg: the smaller miss
    assert (error.index, error.record, error.axis) == (2, 13, "A")
    assert error.value == pytest.approx(-110.0, abs=1e-9)
    assert error.limit == pytest.approx(-100.0)
    assert isinstance(error, InputError)
    text = str(error)
    assert "pose 2 (record 13)" in text and "axis A" in text
    assert "-110.000000 deg" in text and "minimum -100.000000 deg" in text
    assert "xyzac-trt.toml" in text


def test_tip_out_of_linear_limits() -> None:
    machine = load_machine(MACHINES / "xyzac-trt.toml")  # X -200 .. 200 mm
    kins = kinematics_for(machine)
    tip = np.array([[0.0, 0.0, 0.0], [250.0, 0.0, 0.0]])
    axis = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]])
    with pytest.raises(OverTravelError) as caught:
        kins.inverse(tip, axis)
    assert (caught.value.index, caught.value.axis) == (1, "X")
    assert caught.value.value == pytest.approx(250.0)
    assert caught.value.limit == 200.0


def test_bad_poses_are_input_errors() -> None:
    kins = _kins()
    with pytest.raises(InputError, match="zero-length"):
        kins.inverse(np.zeros((2, 3)), np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 0.0]]))
    with pytest.raises(InputError, match=r"\(n, 3\)"):
        kins.inverse(np.zeros((2, 3)), np.zeros((3, 3)))


def test_empty_path() -> None:
    assert _kins().inverse(np.zeros((0, 3)), np.zeros((0, 3))).shape == (0, 5)


# ------------------------------------------------------------------ C swing report
def test_c_swing_report_hand_case() -> None:
    machine = load_machine(MACHINES / "xyzac-trt.toml")  # A and C: 30 deg/s
    joints = np.zeros((3, 5))
    joints[1, 4] = radians(90.0)  # 90 deg in 1 s: 90 deg/s > 30
    joints[2, 4] = radians(100.0)  # 10 deg in 1 s: fine
    joints[2, 3] = radians(-45.0)  # 45 deg in 1 s: 45 deg/s > 30
    report = c_swing_report(joints, np.array([0.0, 1.0, 1.0]), machine)
    assert [(r["index"], r["axis"]) for r in report] == [(1, "C"), (2, "A")]
    assert report[0]["required_deg_s"] == pytest.approx(90.0)
    assert report[0]["limit_deg_s"] == pytest.approx(30.0)
    assert report[1]["delta_deg"] == pytest.approx(-45.0)


def test_c_swing_report_near_singular_pass() -> None:
    # the tool axis passes 0.5 deg from the C axis: C swings ~180 deg within a few poses
    machine = load_machine(MACHINES / "trunnion-500.toml")  # C 180 deg/s
    kins = kinematics_for(machine)
    u = np.linspace(-1.0, 1.0, 201)
    axis = np.column_stack([np.full_like(u, radians(0.5)), u * radians(10.0), np.ones_like(u)])
    joints = kins.inverse(np.zeros((201, 3)), axis)
    report = c_swing_report(joints, np.full(201, 0.01), machine)
    assert report, "a pass this close to the C axis must exceed 180 deg/s"
    assert {r["axis"] for r in report} == {"C"}
    # the azimuth of the axis, atan2(x, y), unwrapped, gives the C rate by hand
    azimuth = np.unwrap(np.arctan2(axis[:, 0], axis[:, 1]))
    rate = np.degrees(np.abs(np.diff(azimuth))) / 0.01
    assert [r["index"] for r in report] == list(np.flatnonzero(rate > 180.0) + 1)
    np.testing.assert_allclose([r["required_deg_s"] for r in report], rate[rate > 180.0])


def test_c_swing_report_checks_durations() -> None:
    machine = load_machine(MACHINES / "xyzac-trt.toml")
    with pytest.raises(InputError, match="duration"):
        c_swing_report(np.zeros((2, 5)), np.array([1.0, -1.0]), machine)
    with pytest.raises(InputError, match="one move duration"):
        c_swing_report(np.zeros((2, 5)), np.array([1.0]), machine)


# ------------------------------------------------------------------ registry
def test_registry_lists_built_ins_and_rejects_unknown() -> None:
    assert {"xyzac-trt", "xyzbc-trt"} <= set(available_kinematics())
    machine = ideal_machine()
    kins = kinematics_for(machine)
    assert kins.name == "xyzac-trt" and kins.joint_names == ("X", "Y", "Z", "A", "C")
    from dataclasses import replace

    with pytest.raises(InputError, match="unknown kinematics") as caught:
        kinematics_for(replace(machine, kinematics="xyzab-nope"))
    assert "xyzac-trt" in str(caught.value)


def test_register_kinematics_plugin_and_duplicate() -> None:
    try:

        @register_kinematics("test-dummy")
        class Dummy:
            joint_names = ("X", "Y", "Z", "A", "C")

            def __init__(self, machine: object) -> None:
                self.machine = machine

        assert "test-dummy" in available_kinematics()
        assert Dummy.name == "test-dummy"  # type: ignore[attr-defined]
        with pytest.raises(ValueError, match="already registered"):
            register_kinematics("test-dummy")(type("Other", (), {}))
    finally:
        registry_module._REGISTRY.pop("test-dummy", None)
