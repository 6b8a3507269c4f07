"""Checked links (``Toolpath.link``): one joint-mode rapid, no safe retract around it.

A pass, a short departure along the tool axis, a link that turns the part half a turn
about its axis (C by 180 deg) and the approach to a second pass. Marked as a checked
link, the turn is one collision-checked move in the APT and one rotary ``G0`` in the
NC with no retract to safe Z; unmarked, the post keeps its retract. Every program
runs through LinuxCNC's rs274.
"""

from __future__ import annotations

from math import degrees, pi
from pathlib import Path

import numpy as np
import pytest

from postproc.apt import format_apt, parse_apt
from postproc.kinematics import kinematics_for
from postproc.machine import load_machine
from postproc.posting import Role, as_degrees, post_toolpaths
from postproc.posts import PostOptions, get_post
from postproc.program import Motion
from postproc.toolpath import Cutter, MoveKind, Toolpath
from tests.postproc.post_check import check_against_rs274, interpret, with_records

ROOT = Path(__file__).resolve().parents[2]
SIM = load_machine(ROOT / "fixtures" / "machines" / "xyzac-trt.toml")


def _rotate(points: np.ndarray, angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return points @ np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]).T


def half_turn_link(marked: bool = True) -> Toolpath:
    """Pass 1 on one side of the part, a checked link turning C by 180 deg, pass 2."""
    # tilted 57 deg: A = -57 deg; the other branch (A = +57) is beyond A's +50 deg
    axis = np.array([0.0, np.sin(1.0), np.cos(1.0)])
    one = np.array([[30.0, y, 20.0] for y in np.linspace(-4.0, 4.0, 5)])
    depart = one[-1] + 2.0 * axis
    two = _rotate(one, pi)[::-1]  # starts where the half turn takes the departure
    axis_two = _rotate(axis[None], pi)[0]
    approach = two[0] + 2.0 * axis_two
    tips = np.vstack([one[0] + 2.0 * axis, one, depart, approach, two, two[-1] + 2.0 * axis_two])
    axes = np.vstack([axis] * 7 + [axis_two] * 7)
    kinds = ([MoveKind.RAPID, MoveKind.PLUNGE] + [MoveKind.FEED] * 4 + [MoveKind.RETRACT]
             + [MoveKind.RAPID, MoveKind.PLUNGE] + [MoveKind.FEED] * 4 + [MoveKind.RETRACT])
    feeds = np.where(np.array(kinds) == MoveKind.RAPID, np.nan, 800.0)
    link = np.zeros(len(tips), bool)
    link[7] = marked
    return Toolpath(tip=tips, axis=axes, feed=feeds, kind=np.array(kinds, np.int8),
                    name="finish two sides", tool_number=1, cutter=Cutter(6.0, 3.0, 30.0),
                    spindle_rpm=12000.0, link=link)


def test_the_link_survives_the_apt_round_trip() -> None:
    path = half_turn_link()
    text = format_apt([path])
    assert text.count("$$ LINK") == 1
    assert "$$ LINK\nRAPID\nGOTO/" in text
    back = parse_apt(text)[0]
    np.testing.assert_array_equal(back.link, path.link)
    assert back.kind[7] == MoveKind.RAPID


def test_link_needs_a_rapid() -> None:
    path = half_turn_link()
    with pytest.raises(ValueError, match="only a rapid"):
        Toolpath(tip=path.tip, axis=path.axis, feed=np.full(len(path), 500.0),
                 kind=np.full(len(path), MoveKind.FEED, np.int8), link=path.link)


@pytest.mark.parametrize("tcp", [False, True], ids=["joint", "tcp"])
def test_a_half_turn_link_is_one_rotary_rapid_without_retract(tmp_path: Path,
                                                               tcp: bool) -> None:
    options = PostOptions(tcp=tcp)
    toolpaths = with_records(parse_apt(format_apt([half_turn_link()])))
    posted = post_toolpaths(toolpaths, SIM, options)
    path_rows = np.flatnonzero(posted.record >= 0)
    inside = slice(int(path_rows[0]), int(path_rows[-1]) + 1)
    # no retract, orientation or positioning block between the first and last pose
    assert not np.isin(posted.role[inside], [Role.RETRACT, Role.ORIENT, Role.POSITION]).any()
    words = as_degrees(posted.machine_joints)
    turn = np.abs(np.diff(words[:, 4]))
    big = np.flatnonzero(turn > 1.0) + 1
    assert len(big) == 1, "the half turn is one block"
    row = int(big[0])
    assert posted.blocks.motion[row] == Motion.RAPID
    assert turn[row - 1] == pytest.approx(180.0, abs=1e-6)
    # the joint move is the rotation the planner checked: X, Y, Z and A stay
    np.testing.assert_allclose(posted.machine_joints[row, :4],
                               posted.machine_joints[row - 1, :4], atol=1e-9)
    assert not posted.blocks.tcp[row]
    text = get_post("linuxcnc").write(posted, options)
    run = interpret(text, tmp_path)  # rs274 accepts it
    check_against_rs274(posted, toolpaths, run)


def test_an_unmarked_rotary_rapid_keeps_its_safe_retract(tmp_path: Path) -> None:
    options = PostOptions()
    toolpaths = with_records([half_turn_link(marked=False)])
    posted = post_toolpaths(toolpaths, SIM, options)
    path_rows = np.flatnonzero(posted.record >= 0)
    inside = posted.role[int(path_rows[0]):int(path_rows[-1]) + 1]
    assert (inside == Role.RETRACT).sum() == 1
    check_against_rs274(posted, toolpaths,
                        interpret(get_post("linuxcnc").write(posted, options), tmp_path))


def test_the_joint_move_of_the_link_is_a_rotation_about_the_part_axis() -> None:
    """Forward kinematics along the posted joint line: the tip stays on its circle."""
    kins = kinematics_for(SIM)
    path = half_turn_link()
    q = kins.inverse(path.tip[6:8], path.axis[6:8])
    t = np.linspace(0.0, 1.0, 37)[:, None]
    tips, _ = kins.forward(q[0] + t * (q[1] - q[0]))
    radius = np.hypot(tips[:, 0], tips[:, 1])
    np.testing.assert_allclose(radius, radius[0], atol=1e-9)
    np.testing.assert_allclose(tips[:, 2], tips[0, 2], atol=1e-9)
    assert degrees(abs(q[1, 4] - q[0, 4])) == pytest.approx(180.0)
