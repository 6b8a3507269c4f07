"""Posture repair after the eq. 7 remedy: cone search and monotone absorption."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

from cam.collision import CollisionScene
from cam.finishing.interference import check_path, resolve_interference
from cam.finishing.options import FinishOptions
from cam.finishing.posture import angle_between
from cam.finishing.repair import (
    PostureRules,
    absorb_monotone,
    cone_axes,
    repair_postures,
    rule_violations,
)
from cam.finishing.reversals import count_reversals
from cam.tools import resolve_tool
from postproc.kinematics import kinematics_for
from postproc.machine import load_machine

ROOT = Path(__file__).resolve().parents[2]
MACHINE = ROOT / "fixtures" / "machines" / "xyzac-trt.toml"
TOOL = resolve_tool("ball4_taper")  # R 2, flutes 10, 1.5 deg neck


def test_cone_axes_have_the_cone_angle_and_start_away_from_the_wall() -> None:
    axis = np.array([[0.0, 0.0, 1.0], [0.6, 0.0, 0.8]])
    away = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    cone = cone_axes(axis, away, math.radians(7.0), 12)
    assert cone.shape == (2, 12, 3)
    for i in range(2):
        angles = np.degrees(angle_between(np.repeat(axis[i:i + 1], 12, axis=0), cone[i]))
        assert angles == pytest.approx(np.full(12, 7.0), abs=1e-9)
    # direction 0 leans towards the wall normal: (sin 7, 0, cos 7) for the upright axis
    s, c = math.sin(math.radians(7.0)), math.cos(math.radians(7.0))
    assert cone[0, 0] == pytest.approx([s, 0.0, c], abs=1e-12)


def test_absorb_monotone_hand_case() -> None:
    # increasing curve 0..9 (1 mm per step), anchor at 8 moved back to 6.5, ramp >= 2 mm
    values = np.arange(10.0)
    arc = np.arange(10.0)
    out = absorb_monotone(values, np.array([8]), np.array([6.5]), arc, blend=2.0)
    # ramp in: back 2 mm to index 6 (6 <= 6.5): affine remap of 6..8 onto 6..6.5
    assert out[:7] == pytest.approx(values[:7])
    assert out[6:9] == pytest.approx([6.0, 6.25, 6.5])
    # ramp out: the path ends 1 mm on; the old curve there (9) is ahead of 6.5, so the
    # ramp returns to it (shorter than the blend: no room)
    assert out[9] == pytest.approx(9.0)
    # a target ahead of the end: the end is shifted whole (no old value to return to)
    out = absorb_monotone(values, np.array([8]), np.array([9.5]), arc, blend=2.0)
    assert out[8:] == pytest.approx([9.5, 10.5])
    assert out[:6] == pytest.approx(values[:6])
    assert np.all(np.diff(out) > 0)


def test_absorb_monotone_returns_to_the_old_curve_between_far_anchors() -> None:
    values = np.linspace(0.0, 30.0, 31)
    arc = np.arange(31.0)
    out = absorb_monotone(values, np.array([5, 25]), np.array([6.0, 24.0]), arc, blend=3.0)
    assert out[5] == pytest.approx(6.0) and out[25] == pytest.approx(24.0)
    assert out[:2] == pytest.approx(values[:2])
    assert out[10:21] == pytest.approx(values[10:21])  # untouched between the ramps
    assert np.all(np.diff(out) > 0)


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**31 - 1), st.sampled_from([1.0, -1.0]))
def test_absorb_monotone_never_creates_a_reversal(seed: int, sense: float) -> None:
    rng = np.random.default_rng(seed)
    n = 60
    values = sense * np.cumsum(rng.uniform(0.0, 0.2, n))  # monotone, with flat steps
    values[rng.integers(0, n, 5)] += 0.0
    arc = np.cumsum(rng.uniform(0.1, 1.0, n))
    index = np.unique(rng.integers(0, n, rng.integers(1, 6)))
    targets = values[index] + rng.normal(0.0, 1.0, len(index))
    out = absorb_monotone(values, index, targets, arc, blend=float(rng.uniform(0.0, 10.0)))
    assert count_reversals(out, 1e-12) == 0
    assert sense * (out[-1] - out[0]) >= -1e-12
    # anchors whose targets are monotone among themselves are met exactly
    ordered = sense * np.maximum.accumulate(sense * targets)
    assert out[index] == pytest.approx(ordered, abs=1e-9)


@pytest.fixture(scope="module")
def plate_scene() -> CollisionScene:
    """A plate x in [-1, 0], y in [-50, 50], z in [0, 20]."""
    plate = trimesh.creation.box(extents=[1.0, 100.0, 20.0])
    plate.apply_translation([-0.5, 0.0, 10.0])
    return CollisionScene({"wall": plate}, grid_spacing=2.0)


def test_axis_along_c_needs_the_cone_search(plate_scene: CollisionScene) -> None:
    """An axis parallel to C: turning C cannot move the neck off the plate; tilting can.

    Ball centres 2.6 mm from the plate: upright, the neck at the plate top (17 mm
    above the tip) is 2 + 7 tan 1.5 deg = 2.183 mm from the axis, 0.417 mm from the
    plate, below the 0.5 mm clearance.
    """
    kins = kinematics_for(load_machine(MACHINE))
    options = FinishOptions()
    n = 21
    centre = np.column_stack([np.full(n, 2.6), np.linspace(-10.0, 10.0, n), np.full(n, 5.0)])
    lean = math.radians(2.0)  # leaned along the feed so A is not singular
    axis = np.tile([0.0, math.sin(lean), math.cos(lean)], (n, 1))
    first = resolve_interference(plate_scene, TOOL, centre, axis, +1.0,
                                 np.full(n, math.radians(30.0)), options)
    assert first.smaller_tool_needed  # dC up to Cmax does not help
    joints = kins.inverse(first.tip, first.axis)
    rules = PostureRules(centre, np.tile([1.0, 0.0, 0.0], (n, 1)),
                         np.tile([0.0, 1.0, 0.0], (n, 1)), np.tile([1.0, 0.0, 0.0], (n, 1)),
                         hub_contact=False)
    result = repair_postures(plate_scene, TOOL, kins, rules, first, joints, options)
    assert result.unresolved.size == 0
    assert not result.interference.smaller_tool_needed
    assert result.interference.clearance.min() >= options.clearance_mm
    assert result.tilted.size > 0
    assert 0.0 < result.max_tilt <= math.radians(options.tilt_search_deg) + 1e-12
    # the ball centres are kept and A, C stay free of reverse movements
    final = result.interference
    assert final.tip + TOOL.radius * final.axis == pytest.approx(centre, abs=1e-9)
    again = kins.inverse(final.tip, final.axis)
    deadband = math.radians(options.reversal_deadband_deg)
    assert count_reversals(again[:, 3], deadband) == 0
    assert count_reversals(again[:, 4], deadband) == 0
    # the independent re-check of the final postures agrees
    check = check_path(plate_scene, TOOL, final.tip, final.axis, options)
    assert not check.smaller_tool_needed
    # and it leaned away from the plate (+x), not into it
    assert np.all(final.axis[:, 0] >= -1e-12)


def test_rule_violations_normal_angle_and_lead() -> None:
    options = FinishOptions(min_normal_angle_deg=5.0, max_lead_deg=45.0)
    normal = np.tile([0.0, 0.0, 1.0], (3, 1))
    tangent = np.tile([1.0, 0.0, 0.0], (3, 1))
    rules = PostureRules(np.zeros((3, 3)), normal, tangent, tangent, hub_contact=True)

    def leaned(deg: float) -> list[float]:
        return [math.sin(math.radians(deg)), 0.0, math.cos(math.radians(deg))]

    axis = np.array([leaned(3.0), leaned(20.0), leaned(47.0)])
    assert rule_violations(axis, rules, options).tolist() == [True, False, True]
    blade = PostureRules(np.zeros((3, 3)), normal, tangent, tangent, hub_contact=False)
    assert rule_violations(axis, blade, options).tolist() == [True, False, False]


def test_a_tall_wall_needs_more_than_ten_degrees_of_tilt() -> None:
    """The splitter's outlet pattern (issue 28): an axis almost parallel to C beside a
    wall as tall as the tool, so turning C cannot help and the holder needs a tilt
    beyond 10 deg.

    Ball centres 2.6 mm from a plate 110 mm high: the holder's 50 mm collar (radius 25
    from 85 mm above the tip) keeps ``clearance_mm`` only if ``85 sin(theta) >= 25 -
    2.6 + 0.55``, theta >= 16 deg. The cone search up to 10 deg leaves every posture
    unresolved; the default search (up to ``tilt_search_deg``) repairs them all,
    the ball centres kept and A and C free of reverse movements.
    """
    tall = trimesh.creation.box(extents=[1.0, 100.0, 110.0])
    tall.apply_translation([-0.5, 0.0, 55.0])
    scene = CollisionScene({"wall": tall}, grid_spacing=2.0)
    kins = kinematics_for(load_machine(MACHINE))
    n = 21
    centre = np.column_stack([np.full(n, 2.6), np.linspace(-10.0, 10.0, n), np.full(n, 5.0)])
    lean = math.radians(2.0)
    axis = np.tile([0.0, math.sin(lean), math.cos(lean)], (n, 1))
    rules = PostureRules(centre, np.tile([1.0, 0.0, 0.0], (n, 1)),
                         np.tile([0.0, 1.0, 0.0], (n, 1)), np.tile([1.0, 0.0, 0.0], (n, 1)),
                         hub_contact=False)

    def repaired(options: FinishOptions) -> tuple[object, object]:
        first = resolve_interference(scene, TOOL, centre, axis, +1.0,
                                     np.full(n, math.radians(30.0)), options)
        assert first.smaller_tool_needed  # dC up to Cmax does not help
        joints = kins.inverse(first.tip, first.axis)
        return first, repair_postures(scene, TOOL, kins, rules, first, joints, options)

    _, capped = repaired(FinishOptions(tilt_search_deg=10.0))
    assert capped.unresolved.size == n  # nothing within 10 deg
    options = FinishOptions()
    assert options.tilt_search_deg >= 20.0
    _, result = repaired(options)
    assert result.unresolved.size == 0
    final = result.interference
    assert not final.smaller_tool_needed
    assert final.clearance.min() >= options.clearance_mm
    assert math.radians(16.0) <= result.max_tilt <= math.radians(options.tilt_search_deg) + 1e-12
    assert final.tip + TOOL.radius * final.axis == pytest.approx(centre, abs=1e-9)
    again = kins.inverse(final.tip, final.axis)
    deadband = math.radians(options.reversal_deadband_deg)
    assert count_reversals(again[:, 3], deadband) == 0
    assert count_reversals(again[:, 4], deadband) == 0
    assert not check_path(scene, TOOL, final.tip, final.axis, options).smaller_tool_needed


def test_the_wide_search_resumes_where_the_narrow_one_stopped() -> None:
    """``repair_postures``'s wide run starts its first round from the rings the narrow
    run's first round checked: the same targets, cone angles and ring state as a wide
    search from the first ring, with fewer collision queries (a wall as tall as the
    tool beside axes almost along C, and a lower wall where 10 deg suffice)."""
    from dataclasses import replace

    from cam.finishing.repair import PREFERRED_TILT_DEG, _search

    kins = kinematics_for(load_machine(MACHINE))
    n = 21
    for height in (110.0, 40.0):
        wall = trimesh.creation.box(extents=[1.0, 100.0, height])
        wall.apply_translation([-0.5, 0.0, 0.5 * height])
        scene = CollisionScene({"wall": wall}, grid_spacing=2.0)
        centre = np.column_stack([np.full(n, 2.6), np.linspace(-10.0, 10.0, n),
                                  np.full(n, 5.0)])
        lean = math.radians(2.0)
        axis = np.tile([0.0, math.sin(lean), math.cos(lean)], (n, 1))
        rules = PostureRules(centre, np.tile([1.0, 0.0, 0.0], (n, 1)),
                             np.tile([0.0, 1.0, 0.0], (n, 1)), np.tile([1.0, 0.0, 0.0], (n, 1)),
                             hub_contact=False)
        options = FinishOptions()
        narrow = replace(options, tilt_search_deg=PREFERRED_TILT_DEG)
        joints = kins.inverse(centre - TOOL.radius * axis, axis)
        index = np.arange(n)
        calls = [0]
        check = scene.check_postures

        def counted(*args: object, calls: list[int] = calls, check: object = check,
                    **kwargs: object) -> object:
            calls[0] += 1
            return check(*args, **kwargs)  # type: ignore[operator]

        scene.check_postures = counted  # type: ignore[method-assign]
        *_, rings = _search(scene, TOOL, kins, axis, joints, rules, index, narrow)
        calls[0] = 0
        fresh = _search(scene, TOOL, kins, axis, joints, rules, index, options)
        from_scratch = calls[0]
        calls[0] = 0
        resumed = _search(scene, TOOL, kins, axis, joints, rules, index, options, rings)
        for a, b in zip(fresh[:3], resumed[:3], strict=True):
            assert np.array_equal(a, b, equal_nan=True)
        for name in ("theta_min", "rotary", "cost"):
            assert np.array_equal(getattr(fresh[3], name), getattr(resumed[3], name))
        assert calls[0] < from_scratch
