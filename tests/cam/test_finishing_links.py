"""Finishing links (cam/finishing/linking.py) on a small synthetic part.

Two passes half a turn apart above a cylinder: the link between them turns C by
180 deg. It must be one checked-link rapid in the APT (checked along the machine's
joint line) and one rotary ``G0`` in the NC with no retract between the passes, and
rs274 must accept the program. A part in the way of every checked link forces the
retract fallback, which finish.json-style reports name.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import trimesh

from cam.collision import CollisionScene
from cam.finishing.lead_blend import LEAD_POINTS
from cam.finishing.linking import Envelope, Linker, LinkRules, PassEnds
from cam.finishing.stepover_blend import (
    BLEND_POINTS,
    BLEND_REACHES,
    HUB_SAMPLE_MM,
    hub_dip,
    hub_dip_limit,
)
from cam.tools import resolve_tool
from geometry.revolved import RevolvedSurface
from postproc.apt import format_apt, parse_apt
from postproc.kinematics import kinematics_for
from postproc.machine import load_machine
from postproc.posting import Role, as_degrees, post_toolpaths
from postproc.posts import PostOptions, get_post
from postproc.program import Motion
from postproc.toolpath import Cutter, MoveKind
from tests.postproc.post_check import check_against_rs274, interpret, with_records

ROOT = Path(__file__).resolve().parents[2]
SIM = load_machine(ROOT / "fixtures" / "machines" / "xyzac-trt.toml")
KINS = kinematics_for(SIM)
TOOL = resolve_tool("ball4_taper")


def _rotate(points: np.ndarray, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return points @ np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]).T


def _passes() -> list[PassEnds]:
    """Pass 1 at x = 40 above a cylinder; pass 2 the same turned half a turn, reversed."""
    axis = np.array([0.0, math.sin(1.0), math.cos(1.0)])  # A = -57 deg (+57: over travel)
    tip = np.array([[40.0, y, 35.0] for y in np.linspace(-5.0, 5.0, 11)])
    out: list[PassEnds] = []
    for angle in (0.0, math.pi):
        t = _rotate(tip, angle)
        a = np.tile(_rotate(axis[None], angle), (len(t), 1))
        if angle:
            t, a = t[::-1], a[::-1]
        q = KINS.inverse(t, a)
        up = np.array([0.0, 0.0, 1.0])
        out.append(PassEnds(f"pass {len(out)}", t, a, up, up, q[0], q[-1]))
    return out


def _linker(scene: CollisionScene) -> Linker:
    rules = LinkRules(tool=TOOL, feed=1000.0, departure=2.0, clearance=0.5,
                      cutter_allowance=0.05, step_mm=0.5, step_rad=math.radians(0.5),
                      envelope=Envelope(30.0, 45.0), longest=TOOL.length + 500.0,
                      turn_step=math.radians(5.0))
    return Linker(scene, KINS, rules)


def _cylinder(radius: float, top: float) -> CollisionScene:
    mesh = trimesh.creation.cylinder(radius=radius, height=top)
    mesh.apply_translation([0.0, 0.0, 0.5 * top])
    return CollisionScene({"hub": mesh})


def test_half_turn_link_is_one_checked_move_and_one_rotary_block(tmp_path: Path) -> None:
    toolpath, air, links = _linker(_cylinder(20.0, 30.0)).join(
        "finish two sides", _passes(), tool_number=1, cutter=Cutter(4.0, 2.0, 15.0),
        spindle_rpm=12000.0)
    assert [link["kind"] for link in links] == ["direct"]
    cut = np.flatnonzero(toolpath.kind == MoveKind.FEED)
    gap = np.arange(cut[9] + 1, cut[10])  # between the passes' feed moves
    kinds = toolpath.kind[gap].tolist()
    # tangent departure and approach (lead_blend), one checked rapid between them
    assert kinds == [MoveKind.RETRACT] * LEAD_POINTS + [MoveKind.RAPID] + \
        [MoveKind.PLUNGE] * LEAD_POINTS
    link = gap[LEAD_POINTS]
    assert toolpath.link[link], "the half turn is a checked link"
    assert air[gap].all() and not air[cut].any()
    # the departure: a quarter arc of radius 2 mm (the escape's length) up to the axis
    assert np.linalg.norm(toolpath.tip[link - 1] - toolpath.tip[gap[0] - 1]) == \
        pytest.approx(2.0 * math.sqrt(2.0))
    assert (toolpath.feed[gap[gap != link]] == 1000.0).all()
    # APT: one GOTO for the link; NC: one rotary G0, no retract inside the operation
    text = format_apt([toolpath])
    assert text.count("$$ LINK") == int(toolpath.link.sum())
    back = with_records(parse_apt(text))
    options = PostOptions()
    posted = post_toolpaths(back, SIM, options)
    rows = np.flatnonzero(posted.record >= 0)
    inside = posted.role[int(rows[0]):int(rows[-1]) + 1]
    assert not np.isin(inside, [Role.RETRACT, Role.ORIENT, Role.POSITION]).any()
    c = as_degrees(posted.machine_joints)[:, 4]
    turning = np.flatnonzero(np.abs(np.diff(c)) > 1.0) + 1
    turning = turning[posted.record[turning] >= 0]
    assert len(turning) == 1
    row = int(turning[0])
    assert posted.blocks.motion[row] == Motion.RAPID
    assert abs(c[row] - c[row - 1]) == pytest.approx(180.0, abs=1e-6)
    np.testing.assert_allclose(posted.machine_joints[row, :4],
                               posted.machine_joints[row - 1, :4], atol=1e-6)
    check_against_rs274(posted, back, interpret(get_post("linuxcnc").write(posted, options),
                                                tmp_path))


def test_no_clear_link_falls_back_to_the_retract_and_says_so() -> None:
    # a ring at the passes' height: the turn about the axis meets it whatever the height
    ring = trimesh.creation.annulus(r_min=38.0, r_max=42.0, height=200.0)
    ring.apply_translation([0.0, 0.0, 100.0 + 40.0])
    hub = trimesh.creation.cylinder(radius=20.0, height=30.0)
    hub.apply_translation([0.0, 0.0, 15.0])
    scene = CollisionScene({"hub": hub, "shroud": ring})
    passes = _passes()
    linker = _linker(scene)
    linker.escape = lambda tip, axis, normal: (tip + 2.0 * axis, 2.0)  # type: ignore[method-assign]
    toolpath, _, links = linker.join("blocked", passes, tool_number=1,
                                     cutter=Cutter(4.0, 2.0, 15.0), spindle_rpm=None)
    assert [link["kind"] for link in links] == ["retract"]
    cut = np.flatnonzero(toolpath.kind == MoveKind.FEED)
    gap = np.arange(cut[9] + 1, cut[10])
    # the turn about the part axis: plain rapids in steps of at most 5 deg, which the
    # post guards with its retract to safe Z
    turning = gap[np.abs(np.einsum("ij,ij->i", toolpath.axis[gap], toolpath.axis[gap - 1])
                         - 1.0) > 1e-9]
    assert len(turning) >= 36
    assert not toolpath.link[turning].any()
    assert (toolpath.kind[turning] == MoveKind.RAPID).all()


def test_adjacent_zigzag_passes_step_over_at_feed() -> None:
    """Two passes 1.5 mm apart over a plate, the second reversed: one feed move joins
    them (no departure, rapid or approach); with a rib between them it cannot."""
    plate = trimesh.creation.box(extents=(60.0, 60.0, 10.0))
    plate.apply_translation([40.0, 0.0, 25.0])  # top face at z = 30
    axis = np.array([0.0, 0.0, 1.0])
    passes = []
    for k, x in enumerate((38.0, 39.5)):
        tip = np.array([[x, y, 30.0] for y in np.linspace(-8.0, 8.0, 9)])
        if k:
            tip = tip[::-1]
        a = np.tile(axis, (len(tip), 1))
        q = KINS.inverse(tip, a)
        passes.append(PassEnds(f"pass {k}", tip, a, axis, axis, q[0], q[-1]))
    rules = replace(_linker(CollisionScene({"hub": plate})).rules, feed_link=5.0)
    linker = Linker(CollisionScene({"hub": plate}), KINS, rules)
    toolpath, air, links = linker.join("plate", passes, tool_number=1,
                                       cutter=Cutter(4.0, 2.0, 15.0), spindle_rpm=None)
    assert [link["kind"] for link in links] == ["feed"]
    assert links[0]["approach_mm"] == pytest.approx(1.5)
    assert links[0]["blend_reach_mm"] == pytest.approx(BLEND_REACHES[0] * 1.5)
    cut = np.flatnonzero(toolpath.kind == MoveKind.FEED)
    step = cut[7] + 1  # the first pass has 8 feed moves after its first point
    moves = slice(step, step + BLEND_POINTS)  # the blend, ending at the next pass
    assert (toolpath.kind[moves] == MoveKind.PLUNGE).all() and air[moves].all()
    np.testing.assert_allclose(toolpath.tip[step + BLEND_POINTS - 1], passes[1].tip[0])
    np.testing.assert_allclose(toolpath.tip[step - 1], passes[0].tip[-1])
    # tangent to both passes: from the first pass's last chord to the second's first
    # no turn sharper than a 12th of the U-turn's 180 degrees plus the Bezier's spread
    path = toolpath.tip[step - 2:step + BLEND_POINTS + 1]
    chords = np.diff(path, axis=0)
    chords /= np.linalg.norm(chords, axis=1, keepdims=True)
    turns = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", chords[1:], chords[:-1]),
                                         -1.0, 1.0)))
    assert turns.sum() == pytest.approx(180.0, abs=1e-6) and turns.max() < 30.0
    np.testing.assert_allclose(path[:, 2], 30.0, atol=1e-12)  # on the plate's top
    assert path[:, 1].max() < 8.0 + 0.75 * BLEND_REACHES[0] * 1.5 + 1e-9
    # a rib standing between the two ends: linked the usual way
    rib = trimesh.creation.box(extents=(0.6, 4.0, 6.0))
    rib.apply_translation([38.75, 8.0, 33.0])
    blocked = Linker(CollisionScene({"hub": plate, "blade": rib}), KINS, rules)
    _, _, links = blocked.join("plate", passes, tool_number=1,
                               cutter=Cutter(4.0, 2.0, 15.0), spindle_rpm=None)
    assert links[0]["kind"] != "feed"


def _box(lo: tuple[float, float, float], hi: tuple[float, float, float]) -> trimesh.Trimesh:
    box = trimesh.creation.box(extents=np.subtract(hi, lo))
    box.apply_translation(0.5 * np.add(lo, hi))
    return box


def test_a_pass_end_whose_holder_collides_is_left_without_gouging_the_overhang() -> None:
    """Issue 28: the ball on a floor under an overhang whose edge lies 0.5 mm inside the
    ball's cylinder, the holder in a slab (no departure keeps it clear). Straight up the
    axis the ball would cut the overhang (the splitter's gouges in verification); the
    departure is the shortest one whose moves out keep the cutter out of the part."""
    tool_top = 30.0 + TOOL.flute_length
    scene = CollisionScene({
        "hub": _box((20.0, -20.0, 20.0), (60.0, 20.0, 30.0)),  # floor, top z = 30
        "blade": _box((20.0, -10.0, tool_top + 1.0), (39.5, 10.0, tool_top + 5.0)),
        "shroud": _box((0.0, -40.0, 130.0), (80.0, 40.0, 135.0)),  # the holder's
    })
    linker = _linker(scene)
    linker.rules = replace(linker.rules, envelope=Envelope(60.0, 50.0))
    tip = np.array([40.0, 0.0, 30.0])
    up = np.array([0.0, 0.0, 1.0])
    away = np.array([1.0, 0.0, 0.0])  # from the overhang's edge
    r = linker.rules

    def cutter_blocked(moves: np.ndarray) -> bool:
        report = scene.check_motion(TOOL, moves, np.tile(up, (len(moves), 1)),
                                    max_step_mm=r.step_mm, max_step_deg=0.5,
                                    parts=("cutter",), cutter_allowance=r.cutter_allowance,
                                    clearance=False)
        return bool(report.blocked().any())

    # the posture: the cutter clear as a cut, the holder not; straight up gouges
    assert not cutter_blocked(np.stack([tip, tip]))
    assert scene.check_postures(TOOL, tip[None], up[None], parts=("holder",)).collides[0]
    assert cutter_blocked(np.stack([tip, tip + 20.0 * up]))
    found = linker.escape(tip, up, away)
    assert found is not None, "no departure keeps the cutter out of the part"
    point, length = found
    assert length == pytest.approx(r.departure)
    np.testing.assert_allclose(point, tip + r.departure * away, atol=1e-12)
    assert not cutter_blocked(np.stack([tip, point, point + 20.0 * up]))
    # with the overhang out of the way the axis is the first candidate again
    scene = CollisionScene({"hub": scene.meshes["hub"], "shroud": scene.meshes["shroud"]})
    linker = Linker(scene, KINS, linker.rules)
    found = linker.escape(tip, up, away)
    assert found is not None
    np.testing.assert_allclose(found[0], tip + r.departure * up, atol=1e-12)


@pytest.mark.parametrize(("step_mm", "driven", "feed"), [
    (1.0, ("blade",), True), (3.0, ("blade",), True), (4.0, ("blade",), False),
    (3.0, None, True), (1.0, ("hub",), True), (3.0, ("hub",), False)])
def test_a_stepover_chord_may_dip_into_a_convex_surface_as_deep_as_the_cuts(
        step_mm: float, driven: tuple[str, ...] | None, feed: bool) -> None:
    """Two pass ends on a cylinder of radius 30 (axis along x), the tool along the
    normal: the tip's chord between them (the blend's too: its control points lie off
    the ends along x) dips ``c**2 / (8 R)`` into it (1, 3, 4 mm: 0.004, 0.0375,
    0.067 mm). A stepover is checked as the postures it joins: the cutter shrunk by
    the cutting allowance (0.05 mm) against a role the passes drive (or every role when
    they are not known), by the undriven allowance (0.02 mm) against the others."""
    radius = 30.0
    # 20 mm long: the pass ends span x = -5 to 5 (the tool outside the radius, clear of
    # the end caps); a longer body only costs the scene's build time
    body = trimesh.creation.cylinder(radius=radius, height=20.0, sections=1440)
    body.apply_transform(trimesh.transformations.rotation_matrix(math.pi / 2, [0, 1, 0]))
    assert abs(float(body.bounds[1][0]) - 10.0) < 1e-9  # axis along x
    ends = []
    for phi in (0.3, 0.3 + step_mm / radius):
        normal = np.array([0.0, math.sin(phi), math.cos(phi)])
        tip = np.array([[x, *(radius * normal[1:])] for x in np.linspace(-5.0, 5.0, 6)])
        ends.append((tip, np.tile(normal, (len(tip), 1)), normal))
    a_tip, a_axis, a_normal = ends[0]
    b_tip, b_axis, b_normal = ends[1][0][::-1], ends[1][1], ends[1][2]
    qa, qb = KINS.inverse(a_tip, a_axis), KINS.inverse(b_tip, b_axis)
    first = PassEnds("pass 0", a_tip, a_axis, a_normal, a_normal, qa[0], qa[-1],
                     driven=driven)
    second = PassEnds("pass 1", b_tip, b_axis, b_normal, b_normal, qb[0], qb[-1],
                      driven=driven)
    linker = _linker(CollisionScene({"blade": body}))
    rules = replace(linker.rules, feed_link=5.0, undriven_allowance=0.02)
    linker = Linker(linker.scene, KINS, rules)
    dip = step_mm ** 2 / (8.0 * radius)
    limit = rules.cutter_allowance if driven is None or "blade" in driven else 0.02
    assert (dip < limit) == feed
    assert (linker.feed_link(first, second) is not None) is feed


def _sphere_hub(radius: float) -> RevolvedSurface:
    """A hub that is a sphere about the origin (contour from near the pole outwards)."""
    theta = np.linspace(0.05, 1.2, 200)
    return RevolvedSurface(np.column_stack([radius * np.cos(theta), radius * np.sin(theta)]), 1)


@pytest.mark.parametrize("chord", [0.5, 2.0, 3.0])
def test_hub_dip_of_a_straight_stepover_over_a_spherical_hub_is_the_sagitta(
        chord: float) -> None:
    """Tips on the sphere (R 30 mm), the axis along its normal: the move's tip is
    straight and its axis on the great circle, so the ball centre at the middle lies
    ``R cos(alpha) + r`` from the sphere's centre (alpha half the angle between the
    ends): the ball dips ``R - sqrt(R**2 - c**2 / 4)`` into the hub, the tip chord's
    sagitta; samples 0.1 mm apart see it within ``0.1**2 / (8 r)``."""
    big, ball = 30.0, 2.0
    hub = _sphere_hub(big)
    half = 0.5 * chord / big / math.sin(0.4)
    normals = np.array([[math.sin(0.4) * math.cos(p), math.sin(0.4) * math.sin(p),
                         math.cos(0.4)] for p in (-half, half)])
    true_chord = float(np.linalg.norm(big * (normals[1] - normals[0])))
    expected = big - math.sqrt(big ** 2 - true_chord ** 2 / 4.0)
    found = hub_dip(hub, big * normals, normals, ball, math.radians(0.5))
    assert expected - HUB_SAMPLE_MM ** 2 / (8.0 * ball) - 1e-6 <= found <= expected + 1e-6
    # a move off the contour (beyond its outer end) is not counted
    far = np.array([[0.0, 0.0, -1.0]] * 2)
    assert hub_dip(hub, np.array([[0.0, 0.0, -40.0], [0.0, 1.0, -40.0]]), far, ball,
                   math.radians(0.5)) == -math.inf


@pytest.mark.parametrize(("chord", "exact", "feed"), [
    (2.0, True, True), (3.0, True, False), (3.0, False, True)])
def test_a_stepover_over_the_hub_dips_no_deeper_than_the_exact_limit(
        chord: float, exact: bool, feed: bool) -> None:
    """Two one-posture passes on a spherical hub (R 30 mm, fine mesh), tool along the
    normal, a straight stepover between them: the mesh check at the cutting allowance
    (0.05 mm) lets a 3 mm chord through (the tip's chord dips 0.0375 mm), the exact
    check of the ball against the closed-form hub does not (it dips as deep, over
    ``hub_dip_limit(2)`` = 0.029 mm); 2 mm (0.017 mm) passes both."""
    big = 30.0
    hub = _sphere_hub(big)
    body = trimesh.creation.icosphere(subdivisions=6, radius=big)
    # at colatitude 1 rad about the y axis (A -57 deg, as _passes): C turns 4.5 and
    # 6.8 deg over the 2 and 3 mm stepovers (within FEED_LINK_TURN)
    half = 0.5 * chord / big / math.sin(1.0)
    passes = []
    for k, p in enumerate((-half, half)):
        n = np.array([math.sin(1.0) * math.cos(0.5 * math.pi + p),
                      math.sin(1.0) * math.sin(0.5 * math.pi + p), math.cos(1.0)])
        q = KINS.inverse((big * n)[None], n[None])
        passes.append(PassEnds(f"pass {k}", (big * n)[None], n[None], n, n, q[0], q[-1],
                               driven=("hub",)))
    linker = _linker(CollisionScene({"hub": body}))
    rules = replace(linker.rules, feed_link=5.0, undriven_allowance=0.02,
                    hub=hub if exact else None)
    linker = Linker(linker.scene, KINS, rules)
    assert 0.0 < hub_dip_limit(TOOL.corner_radius) < 0.05
    assert (linker.feed_link(passes[0], passes[1]) is not None) is feed


class _Counted(CollisionScene):
    """A scene that counts its motion checks."""

    def __init__(self, meshes: dict[str, trimesh.Trimesh]) -> None:
        super().__init__(meshes)
        self.motions = 0

    def check_motion(self, *args: Any, **kwargs: Any) -> Any:
        self.motions += 1
        return super().check_motion(*args, **kwargs)


def test_a_rapid_asked_again_is_answered_as_before_without_a_check() -> None:
    """``join`` builds an operation again after raising a link and asks the links it
    keeps again: the same joints get the same answer, from the first check."""
    ring = trimesh.creation.annulus(r_min=38.0, r_max=42.0, height=200.0)
    ring.apply_translation([0.0, 0.0, 100.0 + 40.0])
    hub = trimesh.creation.cylinder(radius=20.0, height=30.0)
    hub.apply_translation([0.0, 0.0, 15.0])
    passes = _passes()
    turn = np.stack([passes[0].joints_end, passes[1].joints_start])
    climb = np.stack([passes[0].joints_end,
                      passes[0].joints_end + np.array([0.0, 0.0, 10.0, 0.0, 0.0])])
    for meshes, expected in (({"hub": hub}, True), ({"hub": hub, "shroud": ring}, False)):
        scene = _Counted(meshes)
        linker = _linker(scene)
        assert linker.rapid_free(turn) is expected
        assert scene.motions == 1
        assert linker.rapid_free(turn.copy()) is expected  # asked again: no check
        assert scene.motions == 1
        assert linker.rapid_free(climb) is _linker(scene)._rapid_free(climb)
        assert scene.motions == 3  # other joints: checked (and the fresh linker's check)
