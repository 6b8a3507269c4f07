"""Acceptance: LinuxCNC's own interpreter runs our programs and they reproduce the CL.

Every linuxcnc program posted here goes through rs274 (tests/rs274_runner.py); its
canonical moves, mapped back through the forward kinematics, must reproduce the APT
poses within the chordal tolerance, and dense sampling between blocks must keep the
tip within the tolerance of the CL segment.
"""

from __future__ import annotations

from math import radians
from pathlib import Path

import numpy as np
import pytest

from cam.cli import main
from postproc.apt import read_apt
from postproc.machine import load_machine
from postproc.posting import Role, post_toolpaths
from postproc.posts import PostOptions, get_post
from postproc.program import FeedMode, Motion
from tests.postproc.post_check import check_against_rs274, interpret

ROOT = Path(__file__).resolve().parents[2]
SIM = ROOT / "fixtures" / "machines" / "xyzac-trt.toml"
TRUNNION = ROOT / "fixtures" / "machines" / "trunnion-500.toml"
OPS = ROOT / "fixtures" / "apt" / "post_impeller_ops.apt"
OVER = ROOT / "fixtures" / "apt" / "post_overtravel.apt"


def _post(machine_path: Path, options: PostOptions, apt: Path = OPS):
    toolpaths = read_apt(apt)
    machine = load_machine(machine_path)
    posted = post_toolpaths(toolpaths, machine, options, source=apt.name)
    return toolpaths, posted, get_post("linuxcnc").write(posted, options)


@pytest.mark.parametrize("tcp", [False, True], ids=["joint", "tcp"])
@pytest.mark.parametrize("tolerance", [0.01, 0.002])
def test_rs274_reproduces_cl_poses(tmp_path: Path, tcp: bool, tolerance: float) -> None:
    options = PostOptions(tcp=tcp, chordal_tolerance=tolerance)
    toolpaths, posted, text = _post(SIM, options)
    run = interpret(text, tmp_path)
    found = check_against_rs274(posted, toolpaths, run)
    assert found["checked_blocks"] > 50  # the spiral's simultaneous blocks were sampled
    if not tcp:
        # the joint-mode spiral needs inserted blocks to stay within the tolerance
        assert np.count_nonzero(posted.role == Role.INSERTED) > 0


def test_rs274_trunnion_conventional_directions(tmp_path: Path) -> None:
    options = PostOptions(chordal_tolerance=0.005, angular_tolerance=radians(0.25))
    toolpaths, posted, text = _post(TRUNNION, options)
    check_against_rs274(posted, toolpaths, interpret(text, tmp_path))


def test_crossing_a_zero_and_winding_c_has_no_rotary_jump(tmp_path: Path) -> None:
    """The spiral's axis passes through +Z (A = 0) while C turns 400 degrees."""
    toolpaths, posted, text = _post(SIM, PostOptions())
    run = interpret(text, tmp_path)
    spiral = posted.operation == 1
    feeds = spiral & (posted.blocks.motion == Motion.LINEAR)
    a = run.position[feeds, 3]
    c = run.position[feeds, 5]
    assert a.min() < -15.0 and a.max() > 15.0  # A crosses zero
    assert c.max() - c.min() > 360.0  # C winds more than a turn, unwound
    step = np.abs(np.diff(run.position[feeds][:, [3, 5]], axis=0))
    assert step.max() < 10.0  # no jumps (the CL records are 6.8 deg of C apart)
    assert np.all(np.diff(c) >= 0.0)  # C turns one way only
    # simultaneous blocks are inverse time with an F on every one
    assert np.all(posted.blocks.feed_mode[feeds][1:-1] == FeedMode.INVERSE_TIME)
    assert posted.blocks.feed_mode[feeds][-1] == FeedMode.UNITS_PER_MINUTE  # the retract


def test_3p2_segments_only_turn_rotaries_in_safety_blocks(tmp_path: Path) -> None:
    toolpaths, posted, text = _post(SIM, PostOptions())
    check_against_rs274(posted, toolpaths, interpret(text, tmp_path))
    rough = np.flatnonzero(posted.operation == 0)
    joints = posted.machine_joints[rough]
    turned = np.flatnonzero(np.abs(np.diff(joints[:, 3:], axis=0)).max(axis=1) > 1e-12) + 1
    assert np.all(np.isin(posted.role[rough][turned], [Role.ORIENT]))
    # every orientation is preceded by a retract to the Z limit (tool length 0)
    for i in rough[turned]:
        assert posted.role[i - 1] == Role.RETRACT
        assert posted.machine_joints[i - 1, 2] == pytest.approx(120.0)
    cutting = rough[posted.blocks.motion[rough] == Motion.LINEAR]
    assert np.all(posted.blocks.feed_mode[cutting] == FeedMode.UNITS_PER_MINUTE)


def test_over_travel_exits_2_and_writes_nothing(tmp_path: Path, capsys) -> None:
    out = tmp_path / "over.ngc"
    code = main(["post", str(OVER), "-m", str(SIM), "-o", str(out)])
    assert code == 2
    assert not out.exists()
    assert list(tmp_path.iterdir()) == []
    message = capsys.readouterr().err
    # names the APT record (line 11 of the file), the axis, the value and the limit
    assert "record 11" in message and "axis A" in message
    assert "-110" in message or "-109.99" in message
    assert "-100" in message


def test_over_travel_keeps_an_existing_file(tmp_path: Path) -> None:
    out = tmp_path / "keep.ngc"
    out.write_text("old\n")
    assert main(["post", str(OVER), "-m", str(SIM), "-o", str(out)]) == 2
    assert out.read_text() == "old\n"
