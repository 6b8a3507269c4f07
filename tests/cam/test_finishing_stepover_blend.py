"""Tangent stepover blends (cam.finishing.stepover_blend): closed-form geometry of the
blend and the predicted contour error at a zig-zag corner with and without it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cam.finishing.stepover_blend import BLEND_POINTS, blend_curve
from cam.motion.program_servo import simulate_program
from postproc.machine import load_machine
from postproc.nc_reader import parse_nc_document
from postproc.program import MachineProgram, Motion

MACHINE = load_machine("fixtures/machines/trunnion-500.toml")
UP = np.array([0.0, 0.0, 1.0])


def _circle_curvature(p0: np.ndarray, p1: np.ndarray, p2: np.ndarray) -> float:
    """Curvature of the circle through three points, 1/mm."""
    a, b, c = (float(np.linalg.norm(p1 - p0)), float(np.linalg.norm(p2 - p1)),
               float(np.linalg.norm(p2 - p0)))
    area2 = float(np.linalg.norm(np.cross(p1 - p0, p2 - p0)))
    return 2.0 * area2 / (a * b * c)


@pytest.mark.parametrize(("step", "reach"), [(1.5, 2.25), (1.5, 1.5), (3.0, 1.5), (0.8, 0.4)])
def test_a_u_turn_blend_is_tangent_to_both_passes_with_the_closed_form_curvature(
        step: float, reach: float) -> None:
    """Pass a leaves along +x at the origin, pass b starts ``step`` away along -x: the
    Bezier U-turn leaves and arrives tangentially, bulges ``0.75 h`` beyond the ends,
    has end curvature ``2 c / (3 h^2)`` and stays in the passes' plane."""
    start, end = np.zeros(3), np.array([0.0, step, 0.0])
    leave, enter = np.array([1.0, 0.0, 0.0]), np.array([-1.0, 0.0, 0.0])
    tip, axis = blend_curve(start, leave, end, enter, UP, UP, reach, count=4000)
    np.testing.assert_allclose(tip[-1], end, atol=1e-12)
    first = (tip[0] - start) / np.linalg.norm(tip[0] - start)
    last = (tip[-1] - tip[-2]) / np.linalg.norm(tip[-1] - tip[-2])
    assert float(first @ leave) > math.cos(math.radians(0.5))
    assert float(last @ enter) > math.cos(math.radians(0.5))
    assert float(tip[:, 0].max()) == pytest.approx(0.75 * reach, rel=1e-6)
    np.testing.assert_allclose(tip[:, 2], 0.0, atol=1e-12)
    kappa = _circle_curvature(start, tip[0], tip[1])
    assert kappa == pytest.approx(2.0 * step / (3.0 * reach**2), rel=2e-3)
    np.testing.assert_allclose(axis, np.tile(UP, (len(axis), 1)), atol=1e-12)


def test_the_blend_turns_the_tool_axis_from_rest_to_rest() -> None:
    """The axis follows the great circle at the smoothstep of the parameter: its angle
    to the first axis is ``theta (3 s^2 - 2 s^3)``, so it starts and ends at rest."""
    theta = math.radians(8.0)
    axis1 = np.array([math.sin(theta), 0.0, math.cos(theta)])
    _, axis = blend_curve(np.zeros(3), np.array([1.0, 0, 0]), np.array([0, 1.0, 0]),
                          np.array([-1.0, 0, 0]), UP, axis1, 1.0, count=BLEND_POINTS)
    s = np.linspace(0.0, 1.0, BLEND_POINTS + 1)[1:]
    angle = np.arccos(np.clip(axis @ UP, -1.0, 1.0))
    np.testing.assert_allclose(angle, theta * (3 * s**2 - 2 * s**3), atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(axis, axis=1), 1.0, atol=1e-12)


def _zigzag(blend: bool, step: float = 1.5, feed: float = 1500.0) -> MachineProgram:
    """Two 30 mm passes along x, ``step`` apart in y, joined at feed (straight or by the
    blend), posted in machine joints at A = C = 0 on the trunnion machine."""
    a = np.array([[x, 0.0, 20.0] for x in np.linspace(-15.0, 15.0, 11)])
    b = np.array([[x, step, 20.0] for x in np.linspace(15.0, -15.0, 11)])
    points = [a]
    if blend:
        tip, _ = blend_curve(a[-1], np.array([1.0, 0.0, 0.0]), b[0],
                             np.array([-1.0, 0.0, 0.0]), UP, UP, 1.5 * step)
        points.append(tip[:-1])
    points.append(b)
    p = np.vstack(points)
    text = ["G21 G90 G94 G64 P0.01", f"G0 X{p[0, 0]:.4f} Y{p[0, 1]:.4f} Z50 A0 C0",
            f"G1 Z{p[0, 2]:.4f} F{feed:.1f}"]
    text += [f"X{q[0]:.4f} Y{q[1]:.4f} Z{q[2]:.4f}" for q in p[1:]]
    text += ["G0 Z50", "M30"]
    return parse_nc_document("\n".join(text), "zigzag.ngc", machine=MACHINE).program


def test_a_blended_stepover_halves_the_contour_error_of_the_zigzag_corner() -> None:
    """The predicted contour error (all five axes' feed drives, look-ahead) over the
    stepover: a straight stepover's two 90-degree corners, where the control slows to
    nearly rest and turns at the axes' full acceleration, against the blend's gentle
    U-turn at the same feed. Both programs cut the same passes. The control plans its
    corner speeds allowing for the drives' 64 ms smoothing, as the chain's motion stage
    does (without it the smoothing cuts the blend's tight U-turn at speed, 244 um,
    deeper than the stop at the corner, 164 um)."""
    worst = {}
    for blend in (False, True):
        program = _zigzag(blend)
        report = simulate_program(program, MACHINE, dt=1e-3, recommend=False,
                                  corner_smoothing=0.064)
        feed = program.motion == Motion.LINEAR
        # the stepover region: from the first pass's last block to the second's first
        lines = program.line[feed]
        turn = slice(int(np.flatnonzero(lines == 4 + 9)[0]),
                     int(np.flatnonzero(lines == 4 + 11 + (BLEND_POINTS - 1) * blend)[0]) + 1)
        worst[blend] = float(report.deviation[feed][turn].max())
    assert worst[False] > 0.04  # the sharp corner: 55 um
    assert worst[True] < 0.6 * worst[False]


def test_the_blend_carries_the_passes_axis_rates_through_its_ends() -> None:
    """With the passes' axis rates (per mm of tip path) the blend's axis leaves and
    arrives at those rates: no rotary-rate jump, hence no joint-space corner, at its
    ends. Pass a turns its axis about y at 0.01 rad/mm going +x; pass b, reversed,
    turns it back at the same rate going -x."""
    theta = 0.02
    axis0 = np.array([math.sin(theta), 0.0, math.cos(theta)])
    axis1 = np.array([math.sin(theta + 0.005), 0.0, math.cos(theta + 0.005)])
    rate0 = 0.01 * np.array([math.cos(theta), 0.0, -math.sin(theta)])
    rate1 = -0.01 * np.array([math.cos(theta + 0.005), 0.0, -math.sin(theta + 0.005)])
    start, end = np.zeros(3), np.array([0.0, 1.5, 0.0])
    tip, axis = blend_curve(start, np.array([1.0, 0, 0]), end, np.array([-1.0, 0, 0]),
                            axis0, axis1, 2.25, count=20000, rate0=rate0, rate1=rate1)
    first = (axis[0] - axis0) / np.linalg.norm(tip[0] - start)
    last = (axis[-1] - axis[-2]) / np.linalg.norm(tip[-1] - tip[-2])
    np.testing.assert_allclose(first, rate0, atol=2e-5)
    np.testing.assert_allclose(last, rate1, atol=2e-5)
    np.testing.assert_allclose(np.linalg.norm(axis, axis=1), 1.0, atol=1e-12)
