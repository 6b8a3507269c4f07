"""A and C at a continuous rate along a pass (cam/finishing/axis_smoothing.py)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

from cam.collision import CollisionScene
from cam.finishing.axis_smoothing import (
    arc_length,
    fade,
    local_linear,
    rate_jumps,
    smooth_axis_rate,
)
from cam.finishing.interference import check_path
from cam.finishing.options import FinishOptions
from cam.finishing.posture import axis_breaks
from cam.finishing.repair import PostureRules
from cam.finishing.reversals import count_reversals
from cam.tools import resolve_tool
from postproc.kinematics import kinematics_for
from postproc.machine import load_machine

ROOT = Path(__file__).resolve().parents[2]
MACHINE = ROOT / "fixtures" / "machines" / "xyzac-trt.toml"
TOOL = resolve_tool("ball4_taper")  # R 2


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_local_linear_keeps_a_constant_rate_exactly(seed: int) -> None:
    rng = np.random.default_rng(seed)
    arc = np.cumsum(rng.uniform(0.2, 4.0, 50))
    values = np.column_stack([0.3 - 0.02 * arc, 1.0 + 0.05 * arc])
    out = local_linear(arc, values, float(rng.uniform(0.5, 6.0)))
    assert out == pytest.approx(values, abs=1e-9)  # ends included


def test_local_linear_rounds_a_kink_of_the_rate_by_the_closed_form() -> None:
    """A rate step ``delta`` at s = 0: ``x = delta * max(s, 0)``. On a fine even grid
    the smoothing is the Gaussian expectation: at the kink ``delta sigma / sqrt(2 pi)``
    above, and the rate ``delta Phi(s / sigma)``, so consecutive moves h mm apart
    differ in rate by at most ``delta h / (sigma sqrt(2 pi))``."""
    h, sigma, delta = 0.05, 3.0, math.radians(2.0)  # rad per mm
    arc = np.arange(-40.0, 40.0 + h / 2, h)
    values = delta * np.maximum(arc, 0.0)
    out = local_linear(arc, values, sigma)
    kink = int(np.argmin(np.abs(arc)))
    assert out[kink] - values[kink] == pytest.approx(delta * sigma / math.sqrt(2 * math.pi),
                                                     rel=1e-3)
    inner = slice(200, -200)  # away from the ends (lines there are kept exactly anyway)
    assert out[inner][:20] == pytest.approx(values[inner][:20], abs=1e-12)
    bound = math.degrees(delta) * h / (sigma * math.sqrt(2 * math.pi))
    assert rate_jumps(arc, values[:, None]) == pytest.approx(math.degrees(delta) / h * h,
                                                             rel=1e-9)
    assert rate_jumps(arc[inner], out[inner, None]) <= 1.001 * bound


def test_fade_is_zero_at_held_points_and_one_two_widths_away() -> None:
    arc = np.arange(0.0, 20.0, 0.5)
    share = fade(arc, np.array([10]), 2.0)  # held at 5 mm, fades in over 4 mm
    assert share[10] == 0.0
    assert share[np.abs(arc - 5.0) >= 4.0] == pytest.approx(1.0)
    assert np.all(np.diff(share[10:]) >= 0) and np.all(np.diff(share[:11]) <= 0)
    assert fade(arc, np.zeros(0, dtype=np.intp), 2.0) == pytest.approx(1.0)


def _kinked_pass(n: int = 41) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Ball centres along y (1 mm apart), the axis leaned along the feed by
    ``20 deg + 0.5 deg/mm`` before y = 0 and ``+ 2 deg/mm`` after: a kink of the A rate."""
    y = np.linspace(-20.0, 20.0, n)
    lean = np.radians(20.0 + 0.5 * np.minimum(y, 0.0) + 2.0 * np.maximum(y, 0.0))
    centre = np.column_stack([np.full(n, 30.0), y, np.full(n, 5.0)])
    axis = np.column_stack([np.zeros(n), np.sin(lean), np.cos(lean)])
    return centre, axis, np.degrees(lean)


def _rules(centre: np.ndarray) -> PostureRules:
    n = len(centre)
    return PostureRules(centre, np.tile([1.0, 0.0, 0.0], (n, 1)),
                        np.tile([0.0, 1.0, 0.0], (n, 1)), np.tile([1.0, 0.0, 0.0], (n, 1)),
                        hub_contact=False)


def _smoothed(scene: Any, kins: Any, options: FinishOptions, centre: np.ndarray,
              axis: np.ndarray) -> tuple[np.ndarray, Any, np.ndarray, Any]:
    """The pass (ball centres, axes) checked in ``scene`` and smoothed: tips, the
    interference, joints and the result (asserted clean before, smoothed after)."""
    tip = centre - TOOL.radius * axis
    inter = check_path(scene, TOOL, tip, axis, options)
    assert not inter.smaller_tool_needed
    joints = kins.inverse(tip, axis)
    result = smooth_axis_rate(scene, TOOL, kins, _rules(centre), inter, joints, options)
    assert result.status == "smoothed"
    return tip, inter, joints, result


def test_a_kink_of_the_axis_rate_is_smoothed_and_checked_on_a_real_scene() -> None:
    plate = trimesh.creation.box(extents=[1.0, 100.0, 20.0])
    plate.apply_translation([-0.5, 0.0, 10.0])
    scene = CollisionScene({"wall": plate}, grid_spacing=2.0)
    kins = kinematics_for(load_machine(MACHINE))
    options = FinishOptions()
    centre, axis, _ = _kinked_pass()
    tip, inter, joints, result = _smoothed(scene, kins, options, centre, axis)
    assert result.held.size == 0
    arc = arc_length(centre)
    assert result.rate_jump_before == pytest.approx(rate_jumps(arc, joints[:, 3:5]))
    # the rate step of 1.5 deg/mm at once becomes a ramp: each move changes it by at most
    # the closed form's 1.5 h / (sigma sqrt(2 pi)) (h = 1 mm, sigma 3 mm), with slack for
    # the coarse grid
    bound = 1.5 / (options.axis_rate_smoothing_mm * math.sqrt(2 * math.pi))
    assert result.rate_jump_before == pytest.approx(1.5, rel=0.02)
    assert result.rate_jump_after <= 1.1 * bound
    final = result.interference
    assert final.tip + TOOL.radius * final.axis == pytest.approx(centre, abs=1e-9)  # centres kept
    assert not final.smaller_tool_needed
    again = check_path(scene, TOOL, final.tip, final.axis, options)
    assert not again.smaller_tool_needed
    assert result.joints == pytest.approx(kins.inverse(final.tip, final.axis), abs=1e-9)
    deadband = math.radians(options.reversal_deadband_deg)
    assert count_reversals(result.joints[:, 3], deadband) == 0
    assert count_reversals(result.joints[:, 4], deadband) == 0
    # off: nothing changes
    off = smooth_axis_rate(scene, TOOL, kins, _rules(centre), inter, joints,
                           FinishOptions(axis_rate_smoothing_mm=0.0))
    assert off.status == "unchanged" and off.joints is joints


@dataclass
class _Report:
    collides: np.ndarray
    clearance: np.ndarray
    hit_role: list[Any]
    bound: float = 0.0
    checks: dict[str, int] = field(default_factory=dict)


class _LeanLimitScene:
    """A stand-in scene where a posture near the kink (|y| <= 3 mm) collides as soon as
    its lean grows by more than 0.05 deg over the original one (an obstacle just beside
    the original postures there). Motions never collide."""

    def __init__(self, centre: np.ndarray, lean_deg: np.ndarray, margin: float = 0.05) -> None:
        self.y, self.lean, self.margin = centre[:, 1], lean_deg, margin

    def check_postures(self, tool: Any, tip: np.ndarray, axis: np.ndarray,
                       **_: Any) -> _Report:
        lean = np.degrees(np.arctan2(axis[:, 1], axis[:, 2]))
        near = np.abs(tip[:, 1] + TOOL.radius * axis[:, 1]) <= 3.0 + 1e-9
        bad = near & (lean > self.lean + self.margin)
        return _Report(bad, np.full(len(tip), np.nan), [None] * len(tip))

    def check_motion(self, tool: Any, tip: np.ndarray, axis: np.ndarray, **_: Any) -> _Report:
        m = len(tip) - 1
        return _Report(np.zeros(m, dtype=bool), np.full(m, np.nan), [None] * m)


def test_a_smoothed_posture_that_collides_is_held_and_never_kept() -> None:
    kins = kinematics_for(load_machine(MACHINE))
    options = FinishOptions()
    centre, axis, lean = _kinked_pass()
    scene: Any = _LeanLimitScene(centre, lean)
    tip, inter, joints, result = _smoothed(scene, kins, options, centre, axis)
    near = np.flatnonzero(np.abs(centre[:, 1]) <= 3.0)
    assert set(result.held.tolist()) <= set(near.tolist())
    assert result.held.size > 0
    final = result.interference
    assert not final.collides.any()  # the final postures are checked: none collides
    again = scene.check_postures(TOOL, final.tip, final.axis)
    assert not again.collides.any()
    # held postures keep their joints; far from them the pass is smoothed
    assert result.joints[result.held] == pytest.approx(joints[result.held], abs=1e-9)
    assert np.abs(result.joints[:, 3:5] - joints[:, 3:5]).max() > 1e-4


def test_the_smoothing_never_reaches_across_a_fast_turn() -> None:
    """A jump of the lean by 12 deg in one 1 mm move (a side change the hub passes make
    in the air, ``max_turn`` 5 deg/mm) stays one move: the stretches either side are
    smoothed on their own, the number of breaks is unchanged."""
    kins = kinematics_for(load_machine(MACHINE))
    options = FinishOptions()
    centre, _, lean = _kinked_pass()
    lean = lean + np.where(centre[:, 1] > 10.5, 12.0, 0.0)
    rad = np.radians(lean)
    axis = np.column_stack([np.zeros(len(rad)), np.sin(rad), np.cos(rad)])
    scene: Any = _LeanLimitScene(centre, lean, margin=math.inf)
    tip = centre - TOOL.radius * axis
    inter = check_path(scene, TOOL, tip, axis, options)
    joints = kins.inverse(tip, axis)
    max_turn = math.radians(options.max_axis_turn_deg_per_mm)
    before = axis_breaks(centre, axis, max_turn)
    assert before.tolist() == [30]
    result = smooth_axis_rate(scene, TOOL, kins, _rules(centre), inter, joints, options,
                              max_turn)
    assert result.status == "smoothed"
    assert axis_breaks(centre, result.interference.axis, max_turn).tolist() == [30]
    jump = np.degrees(result.joints[31, 3] - result.joints[30, 3])
    assert abs(jump) == pytest.approx(12.0 + 2.0, abs=0.5)  # the step plus one move's rate
