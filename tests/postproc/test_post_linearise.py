"""Rotary linearisation: geometry helpers, a hand-computed split count, dense sampling."""

from __future__ import annotations

from math import acos, ceil, cos, log2, radians
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from impeller_cam.errors import InputError
from postproc.kinematics import kinematics_for
from postproc.linearise import (
    SAMPLES,
    arc_distance,
    joints_near,
    linear_joints,
    linearise,
    segment_distance,
    slerp,
)
from postproc.machine import load_machine

ROOT = Path(__file__).resolve().parents[2]
SIM = load_machine(ROOT / "fixtures" / "machines" / "xyzac-trt.toml")
KINS = kinematics_for(SIM)


def test_slerp_midpoint_and_ends() -> None:
    a0 = np.array([[1.0, 0.0, 0.0]])
    a1 = np.array([[0.0, 1.0, 0.0]])
    mid = slerp(a0, a1, np.array([0.5]))
    assert np.allclose(mid, [[np.sqrt(0.5), np.sqrt(0.5), 0.0]])
    assert np.allclose(slerp(a0, a1, np.array([0.0])), a0)
    assert np.allclose(slerp(a0, a0, np.array([0.3])), a0)


def test_segment_distance_hand_cases() -> None:
    s0, s1 = np.array([[0.0, 0.0, 0.0]]), np.array([[10.0, 0.0, 0.0]])
    points = np.array([[[5.0, 3.0, 4.0], [-3.0, 4.0, 0.0], [12.0, 0.0, 0.0]]])
    assert np.allclose(segment_distance(points, s0, s1), [[5.0, 5.0, 2.0]])
    # a zero-length segment is a point
    assert np.allclose(segment_distance(points[:, :1], s0, s0), [[np.sqrt(50.0)]])


def test_arc_distance_cone_against_great_circle() -> None:
    """Axis tilted 30 deg turning 90 deg about Z, against the great circle of its ends.

    Hand computation: a0 = (0, 1/2, sqrt3/2), a1 = (1/2, 0, sqrt3/2),
    n = a0 x a1 / |.| = (0.6547, 0.6547, -0.3780); the cone midpoint
    m = (sin30 sin45, sin30 cos45, cos30) = (0.35355, 0.35355, 0.86603);
    m . n = 0.46291 - 0.32733 = 0.13558 -> asin = 7.7925 deg.
    """
    a0 = np.array([[0.0, 0.5, np.sqrt(3) / 2]])
    a1 = np.array([[0.5, 0.0, np.sqrt(3) / 2]])
    m = np.array([[[np.sqrt(0.5) / 2, np.sqrt(0.5) / 2, np.sqrt(3) / 2]]])
    assert np.degrees(arc_distance(m, a0, a1))[0, 0] == pytest.approx(7.7925, abs=1e-3)
    # beyond the arc's end the distance is to the nearer end
    beyond = np.array([[[1.0, 0.0, 0.0]]])
    assert np.degrees(arc_distance(beyond, a0, a1))[0, 0] == pytest.approx(60.0, abs=1e-9)


@settings(max_examples=50, deadline=None)
@given(st.floats(-90.0, 40.0), st.floats(-720.0, 720.0), st.floats(-40, 40), st.floats(-40, 40))
def test_linear_joints_inverts_forward(a_deg: float, c_deg: float, x: float, y: float) -> None:
    joints = np.array([[x, y, 20.0, radians(a_deg), radians(c_deg)]])
    tip, axis = KINS.forward(joints)
    assert np.allclose(linear_joints(KINS, tip, joints[:, 3:]), joints[:, :3], atol=1e-9)
    near = joints_near(KINS, tip, axis, joints, 1e-9)
    if abs(a_deg) > 1e-6:
        assert np.allclose(near, joints, atol=1e-8)


def test_c_turn_under_a_resting_tip_needs_the_hand_computed_number_of_blocks() -> None:
    """A = 0, C turns 40 deg while the tip stays at radius r = 50 mm from the C axis.

    Joint interpolation moves the tip along the chord, so a block turning C by d
    deviates by the sagitta r (1 - cos(d/2)). With tolerance 0.01 mm:
    d <= 2 acos(1 - 0.01/50) = 2.292 deg -> at least 40/2.292 = 17.5 -> 18 blocks;
    halving gives the next power of two, 32 (16 blocks deviate by 0.0119 mm).
    """
    r, turn, tol = 50.0, 40.0, 0.01
    minimum = ceil(turn / (2.0 * np.degrees(acos(1.0 - tol / r))))
    assert minimum == 18
    expected = 2 ** ceil(log2(minimum))
    assert r * (1 - cos(radians(turn / expected / 2))) <= tol < r * (
        1 - cos(radians(turn / (expected / 2) / 2)))
    tip = np.array([[r, 0.0, 20.0], [r, 0.0, 20.0]])
    axis = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]])
    joints = np.array([[0.0, 0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0, radians(turn)]])
    joints[:, :3] = linear_joints(KINS, tip, joints[:, 3:])
    out = linearise(KINS, tip, axis, joints, np.array([False, True]), tol, radians(0.5))
    assert len(out.joints) == expected == 32
    assert np.allclose(np.diff(np.degrees(out.joints[:, 4])), turn / expected)
    assert out.inserted.sum() == expected - 1 and not out.inserted[-1]


def _spiral(n: int = 40):
    s = np.linspace(0.0, 1.0, n)
    phi = np.radians(400.0) * s
    tilt = np.radians(-20.0 + 40.0 * s)
    axis = np.stack([np.sin(tilt) * np.sin(phi), np.sin(tilt) * np.cos(phi), np.cos(tilt)], 1)
    tip = np.stack([30 * np.cos(phi), 30 * np.sin(phi), 20 + 5 * s], 1)
    return tip, axis


@pytest.mark.parametrize("tcp", [False, True])
@pytest.mark.parametrize("tol", [0.02, 0.005])
def test_dense_sampling_stays_within_tolerance(tcp: bool, tol: float) -> None:
    tip, axis = _spiral()
    joints = KINS.inverse(tip, axis)
    angular = radians(0.5)
    out = linearise(KINS, tip, axis, joints, np.ones(len(tip), bool), tol, angular, tcp=tcp)
    q = np.vstack([joints[:1], out.joints])
    t = np.linspace(0.0, 1.0, 10 * (SAMPLES + 1) + 1)
    samples = q[:-1, None, :] + t[None, :, None] * np.diff(q, axis=0)[:, None, :]
    s_tip, s_axis = KINS.forward(samples.reshape(-1, 5))
    seg = out.segment
    d_axis = arc_distance(s_axis.reshape(len(seg), -1, 3), axis[seg - 1], axis[seg])
    assert d_axis.max() <= angular
    use = d_axis.max() / angular
    if not tcp:
        d_tip = segment_distance(s_tip.reshape(len(seg), -1, 3), tip[seg - 1], tip[seg])
        assert d_tip.max() <= tol
        use = max(use, d_tip.max() / tol)
    assert use > 0.1  # not grossly over-refined (halving cuts a deviation ~4 times)
    # every block ends on its CL segment, on the record at the end of a segment
    end_tip, _ = KINS.forward(out.joints)
    if not tcp:
        assert np.allclose(end_tip, out.tip, atol=1e-9)
    assert np.allclose(out.tip[~out.inserted], tip[1:], atol=1e-12)


def test_rewind_inside_a_feed_move_is_an_input_error() -> None:
    tip = np.array([[30.0, 0.0, 20.0], [30.0, 0.0, 20.0]])
    axis = np.array([[0.0, 0.5, np.sqrt(0.75)]] * 2)
    joints = KINS.inverse(tip, axis)
    joints[1, 4] += 2 * np.pi  # a full C turn between two equal poses
    joints[1, :3] = linear_joints(KINS, tip[1:], joints[1:, 3:])
    with pytest.raises(InputError, match="record 7"):
        linearise(KINS, tip, axis, joints, np.array([False, True]), 0.01, radians(0.5),
                  records=np.array([5, 7]))
