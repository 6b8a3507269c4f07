"""Tangent approaches and departures (cam.finishing.lead_blend): tangent at the pass,
curvature zero where they meet it, above the pass's tangent plane, the tool axis's
rate carried out of the pass, and checked."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import trimesh

from cam.collision import CollisionScene
from cam.finishing.lead_blend import LEAD_POINTS, QUARTER, tangent_approach, tangent_departure
from cam.finishing.linking import Envelope, Linker, LinkRules, PassEnds
from cam.tools import resolve_tool
from postproc.kinematics import kinematics_for
from postproc.machine import load_machine

ROOT = Path(__file__).resolve().parents[2]
KINS = kinematics_for(load_machine(ROOT / "fixtures" / "machines" / "xyzac-trt.toml"))
TOOL = resolve_tool("ball4_taper")
UP = np.array([0.0, 0.0, 1.0])


def _plate_pass(*extra: trimesh.Trimesh, tilt_rate: float = 0.0) -> tuple[Linker, PassEnds]:
    """A pass along +y on a plate's top (z = 30), the tool vertical at its middle and
    tilting about x at ``tilt_rate`` rad per mm of tip; extra obstacles."""
    plate = trimesh.creation.box(extents=(60.0, 60.0, 10.0))
    plate.apply_translation([40.0, 0.0, 25.0])
    meshes = {"hub": plate} | {f"blade{k}": m for k, m in enumerate(extra)}
    rules = LinkRules(tool=TOOL, feed=1000.0, departure=2.0, clearance=0.5,
                      cutter_allowance=0.05, step_mm=0.5, step_rad=math.radians(0.5),
                      envelope=Envelope(30.0, 45.0), longest=TOOL.length + 500.0,
                      turn_step=math.radians(5.0))
    tip = np.array([[40.0, y, 30.0] for y in np.linspace(-8.0, 8.0, 9)])
    theta = tilt_rate * tip[:, 1]
    axis = np.stack([np.zeros_like(theta), -np.sin(theta), np.cos(theta)], axis=1)
    q = KINS.inverse(tip, axis)
    return Linker(CollisionScene(meshes), KINS, rules), PassEnds("p", tip, axis, axis[0],
                                                                  axis[-1], q[0], q[-1])


def _turns(path: np.ndarray) -> np.ndarray:
    chords = np.diff(path, axis=0)
    chords /= np.linalg.norm(chords, axis=1, keepdims=True)
    return np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", chords[1:], chords[:-1]),
                                        -1.0, 1.0)))


def test_the_approach_is_a_quarter_circle_onto_the_pass_along_its_tangent() -> None:
    """Escape point 2 mm above the first tip, the pass along +y: the approach starts at
    ``O = tip - R y + R z`` (R = 2) and runs on the quarter circle about ``tip + R z``
    (Bezier: radius within 0.03 %) onto the tip, arriving along the pass: no chord turns
    more than the arc's 90 / 8 degrees plus its half-chord, none dips below the top."""
    linker, p = _plate_pass()
    found = tangent_approach(linker, p, p.tip[0] + 2.0 * UP)
    assert found is not None
    outer, curve, axes = found
    assert len(curve) == LEAD_POINTS
    np.testing.assert_allclose(axes, np.tile(UP, (LEAD_POINTS, 1)), atol=1e-15)
    np.testing.assert_allclose(outer, p.tip[0] + np.array([0.0, -2.0, 2.0]), atol=1e-12)
    np.testing.assert_allclose(curve[-1], p.tip[0], atol=1e-12)
    centre = p.tip[0] + 2.0 * UP
    np.testing.assert_allclose(np.linalg.norm(curve - centre, axis=1), 2.0, rtol=3e-4)
    path = np.vstack([outer[None], curve, p.tip[1:3]])
    turns = _turns(path)
    assert turns.max() < 90.0 / LEAD_POINTS + 0.5 * 90.0 / LEAD_POINTS + 1.0
    assert float(path[:, 2].min()) >= 30.0 - 1e-12
    np.testing.assert_allclose(path[:, 0], 40.0, atol=1e-12)


def test_the_departure_mirrors_the_approach() -> None:
    linker, p = _plate_pass()
    found = tangent_departure(linker, p, p.tip[-1] + 2.0 * UP)
    assert found is not None
    outer, curve, _ = found
    np.testing.assert_allclose(outer, p.tip[-1] + np.array([0.0, 2.0, 2.0]), atol=1e-12)
    np.testing.assert_allclose(curve[-1], outer, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(curve - (p.tip[-1] + 2.0 * UP), axis=1), 2.0,
                               rtol=3e-4)
    path = np.vstack([p.tip[-3:], curve])
    assert _turns(path).max() < 90.0 / LEAD_POINTS + 0.5 * 90.0 / LEAD_POINTS + 1.0
    assert float(path[:, 2].min()) >= 30.0 - 1e-12


def test_a_wall_behind_the_pass_start_keeps_the_straight_approach() -> None:
    """A wall 0.2 mm behind the ball at the first tip: both arcs start behind the pass's
    start (2 and 1 mm), the ball in the wall; the straight approach is kept (None)."""
    wall = trimesh.creation.box(extents=(20.0, 2.0, 20.0))
    wall.apply_translation([40.0, -8.0 - 2.0 - 0.2 - 1.0, 40.0])
    linker, p = _plate_pass(wall)
    assert tangent_approach(linker, p, p.tip[0] + 2.0 * UP) is None


def test_the_leads_carry_the_passes_tool_axis_rate_and_end_on_its_axis() -> None:
    """The tool axis tilts about x at 0.01 rad/mm along the pass (0.57 degrees per mm:
    on a table-tilting machine the linear joints carry that rotation). The departure's
    axis leaves the pass's last posture at that rate (no rotary-rate jump, hence no
    joint-space corner where the arc meets the pass) and is the pass's end axis again
    at the outer point, the approach's arrives at the pass's first posture at the
    pass's rate; unit axes, the tip arcs unchanged (the vertical-axis pass's)."""
    rate = 0.01
    linker, p = _plate_pass(tilt_rate=rate)
    flat, q = _plate_pass()
    for lead, end, sign in ((tangent_departure, -1, 1.0), (tangent_approach, 0, -1.0)):
        escape = p.tip[end] + 2.0 * UP
        found = lead(linker, p, escape)
        plain = lead(flat, q, escape)
        assert found is not None and plain is not None
        outer, curve, axes = found
        np.testing.assert_allclose(curve, plain[1], atol=1e-12)
        np.testing.assert_allclose(np.linalg.norm(axes, axis=1), 1.0, atol=1e-12)
        theta = rate * p.tip[end, 1]
        tangent = np.array([0.0, -math.cos(theta), -math.sin(theta)])  # d axis / d theta
        if sign > 0:  # departure: from the pass's last posture out to the outer point
            first = (axes[0] - p.axis[-1]) / np.linalg.norm(curve[0] - p.tip[-1])
            np.testing.assert_allclose(axes[-1], p.axis[-1], atol=1e-15)
        else:  # approach: from the outer point onto the pass's first posture
            first = (p.axis[0] - axes[-2]) / np.linalg.norm(p.tip[0] - curve[-2])
            np.testing.assert_allclose(axes[-1], p.axis[0], atol=1e-15)
        # the axis's Bezier leaves at the pass's rate: its first step over 1/8 of the
        # arc turns it by 3 (1 - s)^2 s h rate (s = 1/8, h = QUARTER R) per that chord
        s, reach = 1.0 / LEAD_POINTS, QUARTER * 2.0
        chord = float(np.linalg.norm(curve[0] - p.tip[-1])) if sign > 0 else \
            float(np.linalg.norm(p.tip[0] - curve[-2]))
        expected = 3.0 * (1.0 - s) ** 2 * s * reach * rate * tangent / chord
        np.testing.assert_allclose(first, expected, rtol=0.01, atol=2e-5)  # + normalising
        swing = np.degrees(np.arccos(np.clip(axes @ p.axis[end], -1.0, 1.0))).max()
        assert 0.0 < swing <= np.degrees(4.0 / 9.0 * reach * rate) + 1e-9
        np.testing.assert_allclose(outer, plain[0], atol=1e-12)
