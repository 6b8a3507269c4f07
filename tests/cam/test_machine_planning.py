"""The machine model as an obstacle of the planners (issue 29, planning side)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import trimesh

from cam.collision import CollisionScene
from cam.finishing.interference import check_path
from cam.finishing.machine_obstacle import MACHINE_ROLE, MachineObstacle, operation_clearance
from cam.finishing.options import FinishOptions
from cam.finishing.repair import PostureRules, repair_postures
from cam.tools import resolve_tool
from cam.verify.machine_check import check_program, machine_scene, part_solid, pose_distance
from cam.verify.machine_query import MachineClearance, joint_path_samples
from cam.verify.sources import load_stock
from postproc.kinematics import kinematics_for
from postproc.machine import load_machine
from postproc.nc_reader import read_nc

ROOT = Path(__file__).resolve().parents[2]
TRUNNION = ROOT / "fixtures" / "machines" / "trunnion-500.toml"
NINE_BLADE = ROOT / "fixtures" / "impellers" / "nine_blade" / "spec.toml"
SHORT_TOOL = resolve_tool("ball4_taper")  # gauge line 125 mm above the tip

#: Fillet poses of the main job on trunnion-500 (X Y Z mm, A C deg) where the
#: spindle head came within ~2.5 mm of the rotary table with the short ball4_taper
#: (the pair's clearance is 3 mm): the table tilted 87-88 deg under the head.
_NC = np.array([
    [23.8464, -22.4215, 70.5566, -87.4607, -39.5349],
    [23.0667, -23.2145, 71.2313, -87.7896, -40.9164],
    [22.2636, -24.0168, 71.8713, -88.1185, -42.2978],
])
#: ... three NC lines (447-449 of finish_fillet.ngc) and the poses half-way between
CLOSE = np.array([_NC[0], 0.5 * (_NC[0] + _NC[1]), _NC[1], 0.5 * (_NC[1] + _NC[2]),
                  _NC[2]])


def _joints(rows: np.ndarray) -> np.ndarray:
    out = np.asarray(rows, dtype=np.float64).copy()
    out[:, 3:] = np.radians(out[:, 3:])
    return out


@pytest.fixture(scope="module")
def trunnion() -> dict[str, Any]:
    machine = load_machine(TRUNNION)
    kins = kinematics_for(machine)
    part = part_solid(load_stock(str(NINE_BLADE), 1.0))
    assert machine.model is not None
    scene = machine_scene(machine.model, SHORT_TOOL, None, part=part)
    return {"machine": machine, "kins": kins, "part": part, "scene": scene}


def test_the_query_gives_the_verifiers_distances(trunnion: dict[str, Any]) -> None:
    """Exact distances are pose_distance's to 1e-6 mm; the others are lower bounds
    at or above the pair's clearance."""
    scene, kins = trunnion["scene"], trunnion["kins"]
    rng = np.random.default_rng(29)
    poses = np.vstack([_joints(CLOSE), np.column_stack([
        rng.uniform(-60, 60, 25), rng.uniform(-40, 40, 25), rng.uniform(40, 120, 25),
        np.radians(rng.uniform(-100, 0, 25)), np.radians(rng.uniform(-180, 180, 25))])])
    query = MachineClearance(scene, kins)
    every = query.query(poses, cap=math.inf)
    assert every.exact.all()
    cheap = query.query(poses)
    for row, joints in enumerate(poses):
        for k, (i, j, clearance) in enumerate(scene.pairs):
            true = pose_distance(scene, kins, i, j, joints)
            assert every.distance[row, k] == pytest.approx(true, abs=1e-6)
            if cheap.exact[row, k]:
                assert cheap.distance[row, k] == pytest.approx(true, abs=1e-6)
            else:
                assert clearance <= cheap.distance[row, k] <= true + 1e-9
    head_table = query.names.index(("spindle_head", "rotary_table"))
    close = every.distance[:len(CLOSE), head_table]
    assert np.all((close > 1.5) & (close < 3.0))  # below the 3 mm clearance
    assert np.all(every.margin[:len(CLOSE)] < 0.0)


def test_smallest_over_a_sampled_path_is_the_brute_force_minimum(
        trunnion: dict[str, Any]) -> None:
    scene, kins = trunnion["scene"], trunnion["kins"]
    query = MachineClearance(scene, kins)
    samples = joint_path_samples(_joints(CLOSE), scene.step, query.rho)
    distance, pair, row = query.smallest(samples)
    brute = min((pose_distance(scene, kins, i, j, q), r)
                for r, q in enumerate(samples) for i, j, _ in scene.pairs)
    assert distance == pytest.approx(brute[0], abs=1e-6)
    assert row == brute[1]
    assert pair == ("spindle_head", "rotary_table")
    assert query.queries < len(samples) * len(scene.pairs) / 4  # most pairs skipped
    # handed the caller's own query of the same samples, the same answer
    again = MachineClearance(scene, kins)
    assert again.smallest(samples, again.query(samples)) == (distance, pair, row)


def _program(tmp_path: Path, rows: np.ndarray) -> Path:
    lines = ["G21 G90 G94", "G0 Z375", "G0 A{:.4f} C{:.4f}".format(*rows[0, 3:])]
    lines += ["G1 X{:.4f} Y{:.4f} Z{:.4f} A{:.4f} C{:.4f} F1000".format(*r) for r in rows]
    lines += ["G0 Z375", "M30"]
    path = tmp_path / "close.ngc"
    path.write_text("\n".join(lines) + "\n")
    return path


def _far_scene() -> CollisionScene:
    """A part scene the tool never meets (the test is about the machine alone)."""
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    box.apply_translation((0.0, 0.0, -2000.0))
    return CollisionScene({"hub": box})


def test_a_machine_collision_is_repaired_or_named(tmp_path: Path,
                                                  trunnion: dict[str, Any]) -> None:
    """Postures the verifier flags as machine_collision collide in the planner's scene
    (role "machine"); the posture repair tilts them clear of the machine, and the
    verifier then finds no machine_collision on the repaired postures."""
    kins, machine = trunnion["kins"], trunnion["machine"]
    flagged = check_program(trunnion["scene"], kins, read_nc(_program(tmp_path, CLOSE),
                                                             machine=machine), "close.ngc")
    assert {tuple(e.details["components"]) for e in flagged.events} == {
        ("spindle_head", "rotary_table")}

    obstacle = MachineObstacle(_far_scene(), machine.model, kins, trunnion["part"])
    tip, axis = kins.forward(_joints(CLOSE))
    options = FinishOptions(clearance_mm=0.5)
    report = obstacle.check_postures(SHORT_TOOL, tip, axis)
    assert report.collides.all() and set(report.hit_role) == {MACHINE_ROLE}

    inter = check_path(obstacle, SHORT_TOOL, tip, axis, options)
    assert inter.smaller_tool_needed
    centre = tip + SHORT_TOOL.radius * axis
    tangent = np.gradient(centre, axis=0)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    normal = np.cross(tangent, axis)  # the contact normal across the axis: 90 deg away
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    rules = PostureRules(centre, normal, tangent, normal, hub_contact=False)
    joints = kins.inverse(tip, axis)
    repaired = repair_postures(obstacle, SHORT_TOOL, kins, rules, inter, joints, options)
    fixed = np.setdiff1d(np.arange(len(tip)), repaired.unresolved)
    assert fixed.size, "the repair must tilt some posture clear of the machine"
    margin = obstacle.posture_margin(SHORT_TOOL, repaired.interference.tip,
                                     repaired.interference.axis)
    assert np.all(margin[fixed] >= obstacle.margin)
    if not repaired.unresolved.size:  # every posture clear: so says the verifier
        rows = repaired.joints.copy()
        rows[:, 3:] = np.degrees(rows[:, 3:])
        again = check_program(trunnion["scene"], kins,
                              read_nc(_program(tmp_path, rows), machine=machine), "fixed")
        assert not again.events
        assert again.smallest >= 3.0


def _umr_apt(tmp_path: Path, kins: Any, tool: Any) -> Path:
    """One 3+2-like UMR visit through the close poses, as the roughing writes it."""
    from postproc.apt import write_apt
    from postproc.toolpath import Cutter, MoveKind, Toolpath

    tip, axis = kins.forward(_joints(CLOSE))
    above = tip[0] + 30.0 * axis[0]
    path = Toolpath(tip=np.vstack([above, tip]), axis=np.vstack([axis[:1], axis]),
                    feed=np.array([math.nan] + [500.0] * len(tip)),
                    kind=np.array([MoveKind.RAPID] + [MoveKind.FEED] * len(tip), np.int8),
                    name="rough_umr7", tool_number=tool.number,
                    cutter=Cutter(tool.diameter, tool.corner_radius, tool.flute_length))
    return write_apt(tmp_path / "rough.apt", [path])


def test_a_umr_orientation_the_machine_cannot_take_is_refused(
        tmp_path: Path, trunnion: dict[str, Any]) -> None:
    """The roughing programs are checked as posted: a UMR visit whose orientation
    brings the head within the table's clearance is refused (or reported), naming
    the UMR; with a 20 mm longer tool the same visit passes and rough.json gets its
    clearance."""
    from cam.roughing.machine_fit import check_machine_fit
    from impeller_cam.errors import InputError

    kins, machine = trunnion["kins"], trunnion["machine"]
    apt = _umr_apt(tmp_path, kins, SHORT_TOOL)
    with pytest.raises(InputError, match=r"rough_umr7 \(line \d+\): spindle_head and "
                                         r"rotary_table [12]\.\d\d mm apart, clearance 3\.00"):
        check_machine_fit([apt], TRUNNION, machine, kins, SHORT_TOOL, NINE_BLADE,
                          refuse=True)
    reported = check_machine_fit([apt], TRUNNION, machine, kins, SHORT_TOOL, NINE_BLADE)
    assert reported is not None and reported["machine_collisions"] > 0
    assert reported["notes"][0].startswith("rough_umr7 (line ")
    longer = resolve_tool("ball6_taper")  # gauge line 145 mm above the tip
    entry = check_machine_fit([apt], TRUNNION, machine, kins, longer, NINE_BLADE,
                              refuse=True)
    assert entry is not None and entry["machine_clearance_mm"] >= 3.0
    assert entry["machine_collisions"] == 0
    assert entry["machine_clearance_umr"] == "rough_umr7"


def test_a_plain_rotary_rapid_is_checked_as_the_post_moves_it(
        tmp_path: Path, trunnion: dict[str, Any]) -> None:
    """finish.json's machine entry moves a plain rapid that turns A as the post does
    (safe Z, orient, position, down: ``postproc.safe_retract``), and agrees with the
    verifier on the posted program; the same move as a checked link (one joint move,
    no retract) passes the tool by the mandrel nut, closer."""
    from postproc.posting import post_toolpaths
    from postproc.posts import PostOptions, get_post
    from postproc.toolpath import MoveKind, Toolpath

    kins, machine = trunnion["kins"], trunnion["machine"]
    obstacle = MachineObstacle(_far_scene(), machine.model, kins, trunnion["part"])
    # A from 0 to -80 deg with the tip 70 mm up: half-way (A -30..-50) the tool passes
    # the mandrel nut at ~2.8 mm; both ends are more than 8 mm clear
    joints = _joints(np.array([[23.8, -22.4, 70.0, 0.0, -39.5],
                               [23.8, -22.4, 70.0, -80.0, -39.5]]))
    tip, axis = kins.forward(joints)

    def clearance(link: bool) -> dict[str, Any]:
        path = Toolpath(tip=tip, axis=axis, feed=np.full(2, math.nan),
                        kind=np.full(2, MoveKind.RAPID, np.int8), name="fillet",
                        tool_number=SHORT_TOOL.number, link=np.array([False, link]))
        return operation_clearance(obstacle, SHORT_TOOL, path)

    guarded, straight = clearance(False), clearance(True)
    assert guarded["guarded_rapids"] == 1 and straight["guarded_rapids"] == 0
    assert straight["machine_clearance_mm"] < guarded["machine_clearance_mm"] - 4.0
    assert straight["machine_clearance_pair"] == ["tool", "mandrel_nut"]

    path = Toolpath(tip=tip, axis=axis, feed=np.full(2, math.nan),
                    kind=np.full(2, MoveKind.RAPID, np.int8), name="fillet",
                    tool_number=SHORT_TOOL.number)
    options = PostOptions()
    nc = tmp_path / "fillet.ngc"
    nc.write_text(get_post("linuxcnc").write(post_toolpaths([path], machine, options), options))
    verified = check_program(trunnion["scene"], kins, read_nc(nc, machine=machine), "fillet.ngc")
    assert verified.smallest == pytest.approx(guarded["machine_clearance_mm"], abs=0.05)


def test_postures_asked_again_get_the_same_blocked_answer(trunnion: dict[str, Any]) -> None:
    """``posture_blocked`` is ``posture_margin < margin`` on the postures asked, asked
    first in a batch of other postures or alone, reversed or not; the same postures
    asked again are answered without a machine query (the planner's final check of a
    path is asked again for finish.json)."""
    kins, machine = trunnion["kins"], trunnion["machine"]
    rng = np.random.default_rng(19)
    near = _joints(CLOSE)
    rows = np.vstack([near, np.column_stack([
        near[:, :3] + rng.uniform(-20, 20, (len(near), 3)), near[:, 3:] * 0.5])])
    tip, axis = kins.forward(rows)
    obstacle = MachineObstacle(_far_scene(), machine.model, kins, trunnion["part"])
    fresh = MachineObstacle(_far_scene(), machine.model, kins, trunnion["part"])
    blocked = obstacle.posture_blocked(SHORT_TOOL, tip, axis)
    assert blocked[:len(near)].all()  # the head within its clearance of the table
    expected = fresh.posture_margin(SHORT_TOOL, tip, axis) < fresh.margin
    np.testing.assert_array_equal(blocked, expected)
    reverse = fresh.posture_blocked(SHORT_TOOL, tip[::-1], axis[::-1])
    np.testing.assert_array_equal(reverse[::-1], expected)
    asked = obstacle.stats["poses"]
    again = obstacle.posture_blocked(SHORT_TOOL, tip.copy(), axis.copy())
    np.testing.assert_array_equal(again, expected)
    assert obstacle.stats["poses"] == asked  # answered from the first call
    again[:] = False  # the caller's copy: the answer kept is not changed
    np.testing.assert_array_equal(obstacle.posture_blocked(SHORT_TOOL, tip, axis), expected)
    moved = tip.copy()
    moved[0, 2] += 1e-9  # another posture: asked anew
    obstacle.posture_blocked(SHORT_TOOL, moved, axis)
    assert obstacle.stats["poses"] > asked


#: The round-2 rest stepover of the splitter chain (rest2_blade.apt, poses 1199-1202)
#: the post refused: the stepover's tool axis passes 2-3 deg from the C axis, so the
#: feed move stays on its inverse branch and C turns 125 deg in the last move, which
#: carries the holder into the mandrel nut. The nearer (tilt-through-0) solution the
#: planner used to follow does not meet it.
_POLE_TIPS = np.array([[-38.732026, 68.288087, 8.672009], [-39.002003, 67.787385, 8.562375],
                       [-39.181016, 67.214608, 8.552976], [-39.669893, 64.892008, 8.726671]])
_POLE_AXES = np.array([[0.031552, -0.1602, 0.98658], [0.034521, -0.141133, 0.989389],
                       [0.040855, -0.099986, 0.99415], [0.071615, 0.109657, 0.991386]])


def test_a_feed_move_past_the_c_axis_is_checked_on_the_posts_branch(
        trunnion: dict[str, Any]) -> None:
    """The planner's motion check follows the branch the post keeps (a feed move whose
    axis keeps off the C axis), and so finds the holder contact finish.json's machine
    entry finds on the same moves; the postures themselves are clear."""
    from cam.finishing.machine_obstacle import continuous_branches
    from impeller_cam.tolerances import DEFAULT_TOLERANCES
    from postproc.pole import keeps_branch
    from postproc.toolpath import MoveKind, Toolpath

    kins, machine = trunnion["kins"], trunnion["machine"]
    axis = _POLE_AXES / np.linalg.norm(_POLE_AXES, axis=1, keepdims=True)
    kind = np.array([MoveKind.PLUNGE] * 3 + [MoveKind.FEED], np.int8)
    keep = keeps_branch(axis, kind != MoveKind.RAPID, DEFAULT_TOLERANCES.angular)
    assert keep[1:].all()  # no move passes within the angular tolerance of the pole
    post = kins.inverse(_POLE_TIPS, axis, keep_branch=keep)
    assert abs(math.degrees(post[-1, 4] - post[-2, 4])) > 100.0  # C turns in one move
    followed = continuous_branches(kins.inverse_branches(_POLE_TIPS, axis), axis)
    assert any(np.allclose(post[:, 3], row[:, 3], atol=1e-9)
               and np.allclose(np.angle(np.exp(1j * (post[:, 4] - row[:, 4]))), 0.0,
                               atol=1e-9) for row in followed)

    obstacle = MachineObstacle(_far_scene(), machine.model, kins, trunnion["part"])
    path = Toolpath(tip=_POLE_TIPS, axis=axis, feed=np.full(4, 1000.0), kind=kind,
                    name="blade", tool_number=SHORT_TOOL.number)
    entry = operation_clearance(obstacle, SHORT_TOOL, path)
    assert entry["machine_collision_moves"] == 1
    assert entry["machine_clearance_pair"] == ["holder", "mandrel_nut"]
    assert not obstacle.posture_blocked(SHORT_TOOL, _POLE_TIPS, axis).any()
    margin = obstacle.motion_margin(SHORT_TOOL, _POLE_TIPS, axis)
    assert margin[-1] < 0.0 and (margin[:-1] >= obstacle.margin).all()
    report = obstacle.check_motion(SHORT_TOOL, _POLE_TIPS, axis, max_step_mm=1.0,
                                   max_step_deg=1.0)
    assert report.collides[-1] and report.hit_role[-1] == MACHINE_ROLE


def test_a_turning_plain_rapid_is_checked_by_the_machine_as_the_post_moves_it(
        trunnion: dict[str, Any]) -> None:
    """A plain rapid that turns the axis (the splitter's fillet program, pose 450: A 23
    -> 14.5 deg, C -88 -> 70 deg on the tilt >= 0 branch) is moved by the post with a
    safe retract, so the links' W-linear check leaves its machine check to
    finish.json's machine entry, which moves it as the post does and finds it clear;
    taken linearly in W on its branch it would sweep the holder through the table."""
    from cam.finishing.linked_ops import check_links
    from postproc.toolpath import MoveKind, Toolpath

    kins, machine = trunnion["kins"], trunnion["machine"]
    tip = np.array([[52.069216, 1.436868, 64.531365], [74.433194, 2.05401, 64.531365]])
    axis = np.array([[-0.389802, -0.013682, 0.920797], [0.235501, -0.085835, 0.968076]])
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    obstacle = MachineObstacle(_far_scene(), machine.model, kins, trunnion["part"])
    assert obstacle.motion_margin(SHORT_TOOL, tip, axis)[0] < 0.0  # the W-linear move
    path = Toolpath(tip=tip, axis=axis, feed=np.full(2, math.nan),
                    kind=np.full(2, MoveKind.RAPID, np.int8), name="fillet",
                    tool_number=SHORT_TOOL.number)
    entry = operation_clearance(obstacle, SHORT_TOOL, path)
    assert entry["guarded_rapids"] == 1 and entry["machine_collision_moves"] == 0
    assert check_links(obstacle, SHORT_TOOL, path, np.ones(2, dtype=bool),
                       FinishOptions()) == 0
