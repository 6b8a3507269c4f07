"""Hub passes whose tool axis changes side near the C axis (issue 28).

On an AC trunnion a tool axis a few degrees off the C axis is a large C turn away
from its mirror image across the axis. The splitter's first hub pass ended with its
lean flipping within 2 mm (axis (0.077, -0.191, 0.979) -> (0.111, 0.099, 0.989), 17
deg): the feed move could not be posted. The planner now cuts such a pass where the
axis turns faster than ``max_axis_turn_deg_per_mm`` (``posture.axis_breaks``), the
pieces are linked through the air (``order.ordered_passes``, ``PassEnds.from_air``),
and the post keeps feed moves on their inverse branch (``pole.keeps_branch``).
"""

from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

from cam.collision import CollisionScene
from cam.finishing.linking import Envelope, Linker, LinkRules
from cam.finishing.options import FinishOptions
from cam.finishing.order import ordered_passes
from cam.finishing.posture import axis_breaks, axis_pieces, axis_turn_rate
from cam.tools import resolve_tool
from impeller_cam.errors import InputError
from postproc.apt import format_apt, parse_apt
from postproc.kinematics import kinematics_for
from postproc.machine import load_machine
from postproc.posting import post_toolpaths
from postproc.posts import PostOptions, get_post
from postproc.toolpath import Cutter, MoveKind
from tests.postproc.post_check import check_against_rs274, interpret, with_records

ROOT = Path(__file__).resolve().parents[2]
SIM = load_machine(ROOT / "fixtures" / "machines" / "xyzac-trt.toml")
KINS = kinematics_for(SIM)
TOOL = resolve_tool("ball4_taper")


def _tilted(tilt_deg: float, azimuth_deg: float) -> np.ndarray:
    t, a = math.radians(tilt_deg), math.radians(azimuth_deg)
    return np.array([math.sin(t) * math.cos(a), math.sin(t) * math.sin(a), math.cos(t)])


def test_turn_rate_breaks_and_pieces_hand_case() -> None:
    """Centres 2 mm apart; the axis turns 2, 2, 16, 2 deg: rate 1, 1, 8, 1 deg/mm."""
    centre = np.array([[2.0 * k, 0.0, 0.0] for k in range(5)])
    tilt = np.array([0.0, 2.0, 4.0, 20.0, 22.0])
    axis = np.stack([_tilted(t, 90.0) for t in tilt])
    rate = np.degrees(axis_turn_rate(centre, axis))
    np.testing.assert_allclose(rate, [1.0, 1.0, 8.0, 1.0], atol=1e-9)
    assert axis_breaks(centre, axis, math.radians(5.0)).tolist() == [2]
    assert axis_breaks(centre, axis, math.radians(8.5)).tolist() == []
    pieces = axis_pieces(5, np.array([2]))
    assert [p.tolist() for p in pieces] == [[0, 1, 2], [3, 4]]
    # a single posture between two breaks (or at an end) is no piece
    assert [p.tolist() for p in axis_pieces(5, np.array([0, 1]))] == [[2, 3, 4]]
    assert [p.tolist() for p in axis_pieces(5, np.zeros(0, np.intp))] == [[0, 1, 2, 3, 4]]


def test_option_default_and_validation() -> None:
    assert FinishOptions().max_axis_turn_deg_per_mm == 5.0
    with pytest.raises(InputError, match="max_axis_turn_deg_per_mm"):
        FinishOptions(max_axis_turn_deg_per_mm=0.0)


@settings(max_examples=40, deadline=None)
@given(st.integers(3, 30), st.lists(st.integers(0, 28), max_size=6))
def test_pieces_cover_every_move_but_the_breaks(count: int, raw: list[int]) -> None:
    """Every move of the pass not at a break lies in exactly one piece; no break does."""
    breaks = np.unique([b for b in raw if b < count - 1]).astype(np.intp)
    pieces = axis_pieces(count, breaks)
    inside = [int(i) for p in pieces for i in p[:-1]]  # move i -> i + 1 of a piece
    assert sorted(inside) == [i for i in range(count - 1) if i not in set(breaks.tolist())]
    for p in pieces:
        assert len(p) >= 2 and np.all(np.diff(p) == 1)


def _flip_pass() -> SimpleNamespace:
    """A hub-like pass over a plate whose lean flips across the C axis.

    Eleven postures 2 mm apart along -Y at x = 47.5 on the plate's top (z = 6.5):
    the axis leans 12 deg towards azimuth -68 deg, tilting up to 11.9 deg, then, at
    the sixth posture, 8.6 deg towards azimuth +42 deg (the splitter's postures 46/47
    of p0.huba.01): a 17 deg turn within 2 mm.
    """
    n = 11
    tip = np.array([[47.5, -56.0 - 2.0 * k, 6.5] for k in range(n)])
    axis = np.stack([_tilted(12.0 - 0.02 * k, -68.0) for k in range(5)]
                    + [_tilted(8.6 + 0.02 * k, 42.0) for k in range(n - 5)])
    centre = tip + TOOL.radius * axis
    joints = KINS.inverse(tip, axis)
    normal = np.tile([0.0, 0.0, 1.0], (n, 1))
    path = SimpleNamespace(name="p0.hub.01", passage=0, operation="hub", wall=None, normal=normal,
                           away=normal)
    breaks = axis_breaks(centre, axis, math.radians(FinishOptions().max_axis_turn_deg_per_mm))
    return SimpleNamespace(path=path, tip=tip, axis=axis, joints_after=joints, breaks=breaks,
                           piece_of=None)


def _plate() -> CollisionScene:
    plate = trimesh.creation.box(extents=(60.0, 60.0, 10.0))
    plate.apply_translation([47.5, -66.0, 1.5])  # top face at z = 6.5
    return CollisionScene({"hub": plate})


@pytest.mark.parametrize("reverse", [False, True])
def test_lean_flip_is_made_in_the_air_and_posts(reverse: bool, tmp_path: Path) -> None:
    """The flip is a break; the two pieces are linked by a lift, never a feed move;
    the operation posts (LinuxCNC, rs274 accepts it) with no feed move that changes
    the inverse branch; run backwards (zig-zag) the same."""
    flip = _flip_pass()
    assert flip.breaks.tolist() == [4]
    first = SimpleNamespace(**{**vars(flip), "path": SimpleNamespace(
        **{**vars(flip.path), "name": "p0.hub.00"})})
    results = [first, flip] if reverse else [flip]
    passes = ordered_passes(results)  # the second pass of a passage runs backwards
    mine = passes[-2:]
    assert [p.from_air for p in mine] == [False, True]
    assert all(p.driven == ("hub", "fillet") for p in mine)  # its stepovers' roles
    assert [len(p.tip) for p in mine] == [6, 5] if reverse else [5, 6]
    rules = LinkRules(tool=TOOL, feed=900.0, departure=1.0, clearance=0.5,
                      cutter_allowance=0.05, step_mm=0.5, step_rad=math.radians(0.5),
                      envelope=Envelope(120.0, 60.0), longest=TOOL.length + 500.0,
                      turn_step=math.radians(5.0), feed_link=5.0)
    toolpath, air, links = Linker(_plate(), KINS, rules).join(
        "finish_hub", mine, tool_number=3, cutter=Cutter(4.0, 2.0, 10.0), spindle_rpm=18000.0)
    assert [link["kind"] for link in links] != ["feed"]
    feed = np.flatnonzero((toolpath.kind == MoveKind.FEED) & ~air)
    turn = np.degrees(np.arccos(np.clip(np.einsum(
        "ij,ij->i", toolpath.axis[feed], toolpath.axis[feed - 1]), -1.0, 1.0)))
    assert turn.max() < 1.0  # no cut turns the axis across the C axis
    back = with_records(parse_apt(format_apt([toolpath])))
    options = PostOptions()
    posted = post_toolpaths(back, SIM, options)
    cut = np.flatnonzero(posted.blocks.motion[1:] != 0) + 1
    a = posted.machine_joints[:, 3]
    changed = np.sign(a[cut]) * np.sign(a[cut - 1]) < 0
    assert not changed.any()
    check_against_rs274(posted, back, interpret(get_post("linuxcnc").write(posted, options),
                                                tmp_path))


def test_the_flip_inside_one_feed_move_posts_on_one_branch(tmp_path: Path) -> None:
    """Left as one feed move (a pass from another CAM system), the flip still posts:
    the move stays on its branch and C turns about 110 deg while the axis turns 17."""
    flip = _flip_pass()
    rules = LinkRules(tool=TOOL, feed=900.0, departure=1.0, clearance=0.5,
                      cutter_allowance=0.05, step_mm=0.5, step_rad=math.radians(0.5),
                      envelope=Envelope(120.0, 60.0), longest=TOOL.length + 500.0,
                      turn_step=math.radians(5.0))
    whole = ordered_passes([SimpleNamespace(**{**vars(flip), "breaks": np.zeros(0, np.intp)})])
    toolpath, _, _ = Linker(_plate(), KINS, rules).join(
        "finish_hub", whole, tool_number=3, cutter=Cutter(4.0, 2.0, 10.0), spindle_rpm=None)
    back = with_records(parse_apt(format_apt([toolpath])))
    options = PostOptions()
    posted = post_toolpaths(back, SIM, options)
    c = np.degrees(posted.machine_joints[:, 4])
    a = posted.machine_joints[:, 3]
    inside = np.flatnonzero(posted.role == 1)  # blocks the linearisation inserted
    assert inside.size > 10
    assert np.all(np.sign(a[inside]) == np.sign(a[inside[0]]))
    assert np.ptp(c[inside]) == pytest.approx(110.0, abs=10.0)
    check_against_rs274(posted, back, interpret(get_post("linuxcnc").write(posted, options),
                                                tmp_path))
