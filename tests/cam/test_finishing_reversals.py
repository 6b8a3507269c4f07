"""Reverse movements (M3 steps 4-5): detection, shift by phi_L, least-squares cubic
B-splines, and a constructed path with known reversals through the real kinematics."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cam.finishing.options import FinishOptions
from cam.finishing.plan import remove_reversals, reversal_counts
from cam.finishing.reversals import (
    count_reversals,
    direction,
    end_fixed_lsq_cubic,
    lsq_cubic,
    monotone_lsq_cubic,
    reversal_points,
    reversed_windows,
    shift_reversed,
    shift_reversed_keep_ends,
    smooth_monotone,
    uniform_knots,
)
from postproc.kinematics import kinematics_for
from postproc.machine import load_machine

ROOT = Path(__file__).resolve().parents[2]
MACHINE = ROOT / "fixtures" / "machines" / "xyzac-trt.toml"


def test_reversal_points_hand_case() -> None:
    # increments: +1 +1 -1 0 -2 +3 : signs + + - (dead) - + -> reversals at points 2 and 5
    values = np.array([0.0, 1.0, 2.0, 1.0, 1.0, -1.0, 2.0])
    assert reversal_points(values).tolist() == [2, 5]
    assert count_reversals(values) == 2
    assert direction(values) == 1.0


def test_deadband_ignores_noise_but_not_real_moves() -> None:
    values = np.array([0.0, 1.0, 1.0 - 1e-9, 2.0, 3.0])
    assert count_reversals(values, deadband=0.0) == 2
    assert count_reversals(values, deadband=1e-8) == 0


def test_shift_reversed_makes_every_increment_move_one_way() -> None:
    # increments +1, -0.5, +1, -0.2 -> phi_L = 0.5 + 0.1 = 0.6: -0.5 -> +0.1, -0.2 -> +0.4
    values = np.array([0.0, 1.0, 0.5, 1.5, 1.3])
    shifted, phi_l = shift_reversed(values, +1.0, min_shift=0.1)
    assert phi_l == pytest.approx(0.6)
    assert np.diff(shifted) == pytest.approx([1.0, 0.1, 1.0, 0.4])
    # anchored at the least-squares constant offset: mean unchanged
    assert shifted.mean() == pytest.approx(values.mean())


def test_shift_keeping_the_window_ends_hand_case() -> None:
    # increments +1, -0.5, +1, -0.2; phi_L = 0.6: reversed -> +0.1, +0.4 (sum 0.5); the
    # net travel 1.3 leaves 0.8 for the two forward increments (2.0): scaled by 0.4
    values = np.array([0.0, 1.0, 0.5, 1.5, 1.3])
    kept = shift_reversed_keep_ends(values, +1.0, min_shift=0.1)
    assert kept is not None
    shifted, phi_l = kept
    assert phi_l == pytest.approx(0.6)
    assert shifted == pytest.approx([0.0, 0.4, 0.5, 0.9, 1.3])
    # no net travel to absorb the shift: a wider window is needed
    assert shift_reversed_keep_ends(np.array([0.0, 1.0, 0.0]), +1.0, 0.1) is None


def test_end_fixed_lsq_cubic_keeps_the_ends_and_reproduces_a_cubic() -> None:
    t = np.linspace(2.0, 3.0, 40)
    u = t - 2.0
    cubic = 1.0 + u - 2.0 * u**2 + 0.5 * u**3
    assert end_fixed_lsq_cubic(t, cubic, cubic) == pytest.approx(cubic, abs=1e-12)
    noisy = cubic + 0.3 * np.sin(20.0 * u)
    fit = end_fixed_lsq_cubic(t, cubic, noisy)
    assert fit[0] == pytest.approx(cubic[0], abs=1e-12)
    assert fit[-1] == pytest.approx(cubic[-1], abs=1e-12)


def test_reversed_windows_hand_case() -> None:
    # reversed increments 10..12 (points 10..13) and 30: pad k * max(len, 4)
    values = np.arange(50.0)
    values[11:14] = [9.5, 9.0, 8.5]
    values[31] = 29.5
    assert reversal_points(values).tolist() == [10, 13, 30, 31]
    assert reversed_windows(values, +1.0, 0.0, 1) == [(6, 17), (26, 35)]
    assert reversed_windows(values, +1.0, 0.0, 3) == [(0, 43)]  # overlapping: merged


def test_local_shift_and_smooth_converges_where_one_cubic_cannot() -> None:
    """An A curve like the nine-blade upper suction passes: a fast rise to a plateau,
    a 0.07 deg dip near the trailing edge (measured shape, 447 points)."""
    t = np.linspace(0.0, 1.0, 447)
    a = np.radians(-87.0 + 41.0 * (1.0 - np.exp(-6.0 * t))
                   - 0.07 * np.exp(-(((t - 0.9) / 0.03) ** 2)))
    deadband = math.radians(1e-5)
    assert count_reversals(a, deadband) == 2
    local = smooth_monotone(t, a, min_shift=math.radians(0.01), deadband=deadband)
    whole = smooth_monotone(t, a, min_shift=math.radians(0.01), deadband=deadband,
                            scope="path")
    assert local.method == "shift+lsq-local" and local.rounds <= 5
    assert count_reversals(local.values, deadband) == 0
    assert count_reversals(whole.values, deadband) == 0
    # one cubic over the whole path cannot follow the knee: degrees of change
    local_change = np.degrees(np.abs(local.values - a).max())
    whole_change = np.degrees(np.abs(whole.values - a).max())
    assert local_change < 0.1 and whole_change > 1.0
    # outside the windows the curve is untouched
    assert np.array_equal(local.values[:300], a[:300])


def test_four_basis_functions_are_one_cubic() -> None:
    assert uniform_knots(4).tolist() == [0, 0, 0, 0, 1, 1, 1, 1]
    assert uniform_knots(6).tolist() == pytest.approx([0, 0, 0, 0, 1 / 3, 2 / 3, 1, 1, 1, 1])
    t = np.linspace(0.0, 1.0, 50)
    cubic = 2.0 - t + 3.0 * t**2 - 4.0 * t**3
    assert lsq_cubic(t, cubic, 4)(t) == pytest.approx(cubic, abs=1e-12)


def test_monotone_fallback_is_monotone_and_fits_monotone_data_exactly() -> None:
    t = np.linspace(0.0, 1.0, 80)
    rising = t**3  # monotone cubic: the constrained fit is the plain fit
    assert monotone_lsq_cubic(t, rising, +1.0)(t) == pytest.approx(rising, abs=1e-9)
    wavy = np.sin(3 * np.pi * t) + 0.5 * t
    fitted = monotone_lsq_cubic(t, wavy, +1.0)(t)
    assert count_reversals(fitted, 1e-12) == 0


def test_smooth_monotone_removes_known_reversals() -> None:
    t = np.linspace(0.0, 1.0, 475)
    a = np.radians(20.0 * t + 2.0 * np.sin(6.0 * np.pi * t))  # 6 reversals
    assert count_reversals(a) == 6
    result = smooth_monotone(t, a, min_shift=math.radians(0.01), deadband=1e-9)
    assert result.method in ("shift+lsq-local", "monotone-lsq")
    assert count_reversals(result.values, 1e-9) == 0
    assert len(result.phi_l) == result.rounds >= 1
    # nothing to do: unchanged
    assert smooth_monotone(t, t).values.tolist() == t.tolist()


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), basis=st.integers(4, 8),
       wiggle=st.floats(0.0, 5.0))
def test_smooth_monotone_always_ends_monotone(seed: int, basis: int, wiggle: float) -> None:
    rng = np.random.default_rng(seed)
    t = np.sort(rng.uniform(0, 1, 60))
    t = np.unique(np.concatenate([[0.0], t, [1.0]]))
    values = rng.normal(0, 1) * t + wiggle * np.sin(rng.uniform(1, 20) * t) \
        + 0.01 * rng.normal(size=len(t))
    result = smooth_monotone(t, values, basis_functions=basis, min_shift=1e-4,
                             deadband=1e-9, max_rounds=5)
    assert count_reversals(result.values, 1e-9) == 0
    assert np.all(np.isfinite(result.values))


@pytest.fixture(scope="module")
def kins():  # type: ignore[no-untyped-def]
    return kinematics_for(load_machine(MACHINE))


def test_constructed_path_with_known_reversals(kins) -> None:  # type: ignore[no-untyped-def]
    """Axes built from joints with reversals at known points: found, removed, ball kept."""
    n = 301
    t = np.linspace(0.0, 1.0, n)
    # A (tilt) rises with four reversals, C turns one way with one backward swing
    a = np.radians(-60.0 + 20.0 * t + 3.0 * np.sin(4.0 * np.pi * t))
    c = np.radians(30.0 * t - 6.0 * np.sin(2.0 * np.pi * t))
    # the extrema where the increments change sign, from d/dt = 0 (hand computed):
    # A: 20 + 12 pi cos(4 pi t) = 0 -> cos(4 pi t) = -0.53052: 4 pi t = 2.13003, 4.15316 (+2 pi)
    ta = np.array([2.13003, 4.15316, 2.13003 + 2 * np.pi, 4.15316 + 2 * np.pi]) / (4 * np.pi)
    # C: 30 - 12 pi cos(2 pi t) = 0 -> cos(2 pi t) = 0.79577: 2 pi t = 0.65163, 2 pi - 0.65163
    tc = np.array([0.65163, 2 * np.pi - 0.65163]) / (2 * np.pi)
    centre = np.column_stack([40.0 + 10.0 * t, 5.0 * np.sin(t), 20.0 - 5.0 * t])
    joints = np.column_stack([np.zeros((n, 3)), a, c])
    _, axis = kins.forward(joints)
    radius = 2.0
    tip = centre - radius * axis
    joints0 = kins.inverse(tip, axis)
    options = FinishOptions(reversal_deadband_deg=1e-6)
    counts = reversal_counts(joints0, options)
    found = reversal_points(joints0[:, 3], math.radians(1e-6))
    assert counts["A"] == 4
    assert np.abs(t[found] - ta).max() < 1.5 / (n - 1)  # each found at its extremum
    assert counts["C"] == 2
    found_c = reversal_points(joints0[:, 4], math.radians(1e-6))
    assert np.abs(t[found_c] - tc).max() < 1.5 / (n - 1)
    assert counts["X"] + counts["Y"] + counts["Z"] > 0  # linear reversals are reported too
    new_axis, joints1, smoothing = remove_reversals(centre, axis, joints0, kins, radius,
                                                    options)
    after = reversal_counts(joints1, options)
    assert after["A"] == 0 and after["C"] == 0
    assert smoothing["A"].method != "none" and smoothing["C"].method != "none"
    # the ball stays on its path: tips are recomputed from the unchanged centres
    new_tip, check_axis = kins.forward(joints1)
    assert np.abs(check_axis - new_axis).max() < 1e-9
    assert np.linalg.norm(new_tip + radius * new_axis - centre, axis=1).max() < 1e-9
