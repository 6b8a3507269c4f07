"""The machine check of a motion follows the inverse solutions continuously (issue 28).

A path whose axis passes by the C axis (the splitter's outlet ends) changes the sign of
A in the joints the post computes; the tilt-sign branches of ``inverse_branches`` jump
C by about 180 deg there, a move no program makes, and never contain the one it does.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from cam.finishing.machine_obstacle import continuous_branches
from postproc.kinematics import kinematics_for
from postproc.machine import load_machine

ROOT = Path(__file__).resolve().parents[2]


def _turn(a: np.ndarray) -> np.ndarray:
    """Angles modulo a turn into (-pi, pi]."""
    return np.angle(np.exp(1j * a))


@pytest.mark.parametrize("machine", ["trunnion-500.toml", "xyzac-trt.toml"])
def test_branches_followed_through_the_c_axis(machine: str) -> None:
    kins = kinematics_for(load_machine(ROOT / "fixtures" / "machines" / machine))
    n = 12  # no posture at the pole: one step passes it, 0.6 deg aside
    lean = np.linspace(-0.3, 0.3, n)
    axis = np.column_stack([lean, np.full(n, 0.01), np.ones(n)])
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    tip = np.column_stack([np.linspace(60.0, 62.0, n), np.zeros(n), np.full(n, 10.0)])
    raw = kins.inverse_branches(tip, axis)
    # the raw tilt-sign branches jump C by about a half turn where the axis passes
    assert np.abs(_turn(np.diff(raw[0, :, 4]))).max() > math.radians(120.0)
    paired = continuous_branches(raw)
    for row in paired:
        assert np.abs(_turn(np.diff(row[:, 4]))).max() < math.radians(60.0)
        assert np.abs(np.diff(row[:, 3])).max() < math.radians(5.0)
    # per posture the same two solutions, only their order changed
    same = np.isclose(paired[0], raw[0]).all(axis=1) & np.isclose(paired[1], raw[1]).all(axis=1)
    swapped = np.isclose(paired[0], raw[1]).all(axis=1) & np.isclose(paired[1], raw[0]).all(axis=1)
    assert np.all(same | swapped)
    # the joints the post computes are one of the two sequences
    post = kins.inverse(tip, axis)
    match = [np.allclose(post[:, 3], row[:, 3], atol=1e-9)
             and np.allclose(_turn(post[:, 4] - row[:, 4]), 0.0, atol=1e-9) for row in paired]
    assert any(match)


def test_branches_away_from_the_c_axis_are_unchanged() -> None:
    kins = kinematics_for(load_machine(ROOT / "fixtures" / "machines" / "trunnion-500.toml"))
    n = 12
    tilt = np.radians(np.linspace(20.0, 40.0, n))
    axis = np.column_stack([np.sin(tilt), np.zeros(n), np.cos(tilt)])
    tip = np.column_stack([np.linspace(30.0, 40.0, n), np.zeros(n), np.full(n, 5.0)])
    raw = kins.inverse_branches(tip, axis)
    assert np.array_equal(continuous_branches(raw), raw)


@pytest.mark.parametrize("aside_deg", [0.2, 0.6, 3.0])
def test_branches_follow_the_posts_rule_given_the_axes(aside_deg: float) -> None:
    """Given the axes, a move stays on its branch unless its great circle passes within
    the angular tolerance (0.5 deg) of the C axis, as the post's ``keeps_branch``
    says: one of the two sequences is always the post's joints for a cut."""
    from impeller_cam.tolerances import DEFAULT_TOLERANCES
    from postproc.pole import keeps_branch

    kins = kinematics_for(load_machine(ROOT / "fixtures" / "machines" / "trunnion-500.toml"))
    n = 12
    lean = np.linspace(-0.3, 0.3, n)
    axis = np.column_stack([lean, np.full(n, math.tan(math.radians(aside_deg))), np.ones(n)])
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    tip = np.column_stack([np.linspace(60.0, 62.0, n), np.zeros(n), np.full(n, 10.0)])
    keep = keeps_branch(axis, np.ones(n, dtype=bool), DEFAULT_TOLERANCES.angular)
    assert keep[1:].all() == (aside_deg > 0.5)
    post = kins.inverse(tip, axis, keep_branch=keep)
    followed = continuous_branches(kins.inverse_branches(tip, axis), axis)
    match = [np.allclose(post[:, 3], row[:, 3], atol=1e-9)
             and np.allclose(_turn(post[:, 4] - row[:, 4]), 0.0, atol=1e-9)
             for row in followed]
    assert any(match)
    # outside the tolerance C turns about a half turn along the path and A keeps its
    # sign; inside it A changes sign and C barely moves
    for row in followed:
        turn = abs(float(np.sum(_turn(np.diff(row[:, 4])))))
        flips = bool(np.any(np.sign(row[1:, 3]) != np.sign(row[:-1, 3])))
        assert (turn > math.radians(150.0)) == (aside_deg > 0.5)
        assert flips == (aside_deg <= 0.5)
