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
from postproc.pole import keeps_branch

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


def _tilted(tilt_deg: float, azimuth_deg: float) -> np.ndarray:
    """Unit axis ``tilt_deg`` off +Z towards azimuth ``azimuth_deg`` (from +X)."""
    t, a = radians(tilt_deg), radians(azimuth_deg)
    return np.array([np.sin(t) * np.cos(a), np.sin(t) * np.sin(a), np.cos(t)])


def test_keeps_branch_only_off_the_pole() -> None:
    """A feed move keeps its branch unless its great circle passes the C axis.

    Hand cases: 10 deg tilt at azimuths 0 and 180 deg: the arc runs through the pole
    (distance 0); azimuths 180 and 270: the arc's closest point to the pole is its
    midpoint, tilt atan(tan 10 cos 45) = 7.10 deg; a move at a fixed axis (the last)
    is a rapid here, so it is free.
    """
    axes = np.array([_tilted(10, 0), _tilted(10, 180), _tilted(10, 270), _tilted(10, 270)])
    moving = np.array([False, True, True, False])
    keep = keeps_branch(axes, moving, radians(0.5))
    assert keep.tolist() == [False, False, True, False]
    mid = (axes[1] + axes[2]) / np.linalg.norm(axes[1] + axes[2])
    assert np.degrees(np.arccos(mid[2])) == pytest.approx(
        np.degrees(np.arctan(np.tan(radians(10)) * np.cos(radians(45)))), abs=1e-9)
    # with a tolerance wider than that closest approach the move may change branch
    assert not keeps_branch(axes, moving, radians(7.2))[2]


def _pose_pair(tilt0: float, az0: float, tilt1: float, az1: float, step: float = 2.0):
    axis = np.stack([_tilted(tilt0, az0), _tilted(tilt1, az1)])
    tip = np.array([[47.66, -64.14, 6.63], [47.66, -64.14 - step, 6.50]])
    return tip, axis


def test_lean_flip_near_a0_posts_on_one_branch() -> None:
    """Issue 28's feed move: the axis turns 17 deg past the C axis within 2 mm.

    (0.077, -0.191, 0.979) -> (0.111, 0.099, 0.989), tilt 11.9 -> 8.5 deg, the great
    circle 6 deg off the pole. The least-travel branch choice changed branch there
    (A -11.9 -> +8.6), which no split can linearise (the tilt would pass 0, the axis
    through the pole, 6 deg off the arc). Kept on one branch, C turns by about 110 deg
    while the axis moves 17 deg, and every block keeps the tolerances.
    """
    axis = np.array([[0.077072, -0.190875, 0.978584], [0.111314, 0.098743, 0.988868]])
    axis /= np.linalg.norm(axis, axis=1)[:, None]
    tip = np.array([[47.663250, -64.144373, 6.626507], [47.267144, -66.129689, 6.497209]])
    free = KINS.inverse(tip, axis)
    assert np.sign(free[0, 3]) != np.sign(free[1, 3])  # the old choice: a branch change
    with pytest.raises(InputError, match=r"hub.apt: operation finish_hub, segment to pose 1 "
                       r"\(record 62\).* turn by 20\.4\d\d and 70\.4"):
        linearise(KINS, tip, axis, free, np.array([False, True]), 0.01, radians(0.5),
                  records=np.array([61, 62]), where="hub.apt: operation finish_hub")
    keep = keeps_branch(axis, np.array([False, True]), radians(0.5))
    joints = KINS.inverse(tip, axis, keep_branch=keep)
    assert np.sign(joints[0, 3]) == np.sign(joints[1, 3])
    assert abs(np.degrees(joints[1, 4] - joints[0, 4])) == pytest.approx(110.0, abs=5.0)
    _assert_within(tip, axis, joints, 0.01, radians(0.5))


def _assert_within(tip, axis, joints, tol, angular) -> None:
    out = linearise(KINS, tip, axis, joints, np.ones(len(tip), bool), tol, angular)
    q = np.vstack([joints[:1], out.joints])
    assert np.all(np.sign(q[:, 3]) == np.sign(q[0, 3]))  # one branch throughout
    t = np.linspace(0.0, 1.0, 10 * (SAMPLES + 1) + 1)
    samples = q[:-1, None, :] + t[None, :, None] * np.diff(q, axis=0)[:, None, :]
    s_tip, s_axis = KINS.forward(samples.reshape(-1, 5))
    seg = out.segment
    d_axis = arc_distance(s_axis.reshape(len(seg), -1, 3), axis[seg - 1], axis[seg])
    d_tip = segment_distance(s_tip.reshape(len(seg), -1, 3), tip[seg - 1], tip[seg])
    assert d_axis.max() <= angular
    assert d_tip.max() <= tol


@settings(max_examples=25, deadline=None)
@given(st.floats(2.0, 25.0), st.floats(-180.0, 180.0), st.floats(2.0, 25.0),
       st.floats(60.0, 170.0))
def test_feed_moves_past_the_pole_post_within_tolerance(
        tilt0: float, az0: float, tilt1: float, turn: float) -> None:
    """Random feed moves whose axis swings round the C axis (1-25 deg tilt, 60-170 deg
    of azimuth): kept on their branch, they linearise within both tolerances."""
    tip, axis = _pose_pair(tilt0, az0, tilt1, az0 + turn)
    keep = keeps_branch(axis, np.array([False, True]), radians(0.5))
    if not keep[1]:  # the arc passes the pole: either branch is allowed
        return
    joints = KINS.inverse(tip, axis, keep_branch=keep)
    _assert_within(tip, axis, joints, 0.01, radians(0.5))
