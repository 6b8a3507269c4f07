"""Tests of the collision service (cam.collision): closed-form cases, the mesh and
sphere-cover bounds, identical answers to the plain fcl loop, motion subdivision."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

from cam.collision import (
    CollisionScene,
    motion_bound,
    plain_fcl_check,
    rotations_to,
    subdivide_motion,
    tool_geometry,
)
from cam.collision.broad_phase import axis_spheres, inscribed_radii, surface_samples
from cam.collision.synthetic import impeller_meshes
from cam.collision.tool_mesh import arc_polygon, grown_profile, segments_profile
from cam.tools import Tool, resolve_tool
from impeller_cam.errors import InputError

BALL = resolve_tool("ball6_taper")  # R 3, flutes 15, 2 deg taper to r 5 at 65, holder 65..145
FLAT = resolve_tool("flat10")  # R 5, flutes 22, shank r 5 to 45, holder 45..120
UP = np.array([[0.0, 0.0, 1.0]])


def box(lo: tuple[float, float, float], hi: tuple[float, float, float]) -> trimesh.Trimesh:
    """Axis-aligned box mesh from its corners, mm."""
    lo_a, hi_a = np.asarray(lo, float), np.asarray(hi, float)
    mesh = trimesh.creation.box(extents=hi_a - lo_a)
    mesh.apply_translation(0.5 * (lo_a + hi_a))
    return mesh


@pytest.fixture(scope="module")
def floor_scene() -> CollisionScene:
    """The plane z = 0 (top of a 200 x 200 x 10 slab)."""
    return CollisionScene({"floor": box((-100, -100, -10), (100, 100, 0))})


@pytest.fixture(scope="module")
def impeller_scene() -> CollisionScene:
    """A small synthetic impeller: 5 blades + 5 splitters + hub."""
    return CollisionScene(impeller_meshes(blades=5))


# -- tool meshes ---------------------------------------------------------------------


def test_arc_polygon_circumscribes_with_stated_excess() -> None:
    points, excess = arc_polygon((0.0, 3.0), 3.0, -0.5 * math.pi, 0.0, math.radians(7.5))
    radius = np.linalg.norm(points - [0.0, 3.0], axis=1)
    assert excess == pytest.approx(3.0 * (1.0 / math.cos(math.radians(3.75)) - 1.0), rel=1e-12)
    assert radius.min() == pytest.approx(3.0, abs=1e-12)  # the two tangent points
    assert radius.max() == pytest.approx(3.0 + excess, abs=1e-12)
    # every edge is tangent to the arc: its distance from the centre is exactly R
    a, b = points[:-1], points[1:]
    t = np.einsum("ij,ij->i", [0.0, 3.0] - a, b - a) / np.einsum("ij,ij->i", b - a, b - a)
    foot = a + t[:, None] * (b - a)
    assert np.allclose(np.linalg.norm(foot - [0.0, 3.0], axis=1), 3.0, atol=1e-12)


@pytest.mark.parametrize("name", ["ball6_taper", "flat10", "bull10r2", "ball4_taper",
                                  "ball6_flank3"])
def test_part_meshes_closed_and_circumscribing(name: str) -> None:
    tool = resolve_tool(name)
    parts = tool_geometry(tool)
    assert list(parts) == ["cutter", "shank", "holder"]
    for part in parts.values():
        mesh = part.mesh
        assert mesh.is_watertight and mesh.volume > 0
        # containment: every cross-section of the mesh encloses the true circle
        z_lo, z_hi = mesh.vertices[:, 2].min(), mesh.vertices[:, 2].max()
        for z in np.linspace(z_lo, z_hi, 103)[1:-1]:
            segments = trimesh.intersections.mesh_plane(mesh, [0, 0, 1], [0, 0, z])
            a, b = segments[:, 0, :2], segments[:, 1, :2]
            ab = b - a
            t = np.clip(-np.einsum("ij,ij->i", a, ab) / np.einsum("ij,ij->i", ab, ab), 0, 1)
            nearest = np.linalg.norm(a + t[:, None] * ab, axis=1).min()
            assert nearest >= _true_radius(tool, part.name, np.array([z]))[0] - 1e-9
        # stated excess: no mesh vertex farther than ``excess`` outside the true outline
        r = np.hypot(mesh.vertices[:, 0], mesh.vertices[:, 1])
        z = mesh.vertices[:, 2]
        if part.name == "cutter":
            outside = _outside_cutter(tool, r, z)
        else:
            outside = r - _true_radius(tool, part.name, z)  # radial, >= normal distance
        assert outside.max() <= part.excess + 1e-9
        assert outside.max() >= 0.5 * part.excess  # the bound is not loose either


def _outside_cutter(tool: Tool, r: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Distance of meridian points (r, z) outside the true cutter outline (<= 0 inside).

    Above the tangent height the flutes' side (cylinder or cone of half-angle a):
    ``(r - r(z)) cos a``; below it the corner arc or the flat bottom.
    """
    big, rc, a = tool.radius, tool.corner_radius, tool.flute_half_angle
    side = (r - tool.flank_radius_at(z)) * np.cos(a)
    foot = z + side * np.sin(a)  # the perpendicular's foot on the side line
    corner = np.hypot(r - (big - rc), z - rc) - rc
    return np.where(foot >= tool.flank_start, side, np.where(r <= big - rc, -z, corner))


def _true_radius(tool: Tool, part: str, z: np.ndarray) -> np.ndarray:
    if part == "cutter":
        return tool.radius_at(np.clip(z, 0, None))
    segments = tool.shank_segments() if part == "shank" else tool.holder
    out = np.zeros_like(z)
    for seg in segments:
        inside = (z >= seg.z0 - 1e-12) & (z <= seg.z1 + 1e-12)
        t = np.clip((z - seg.z0) / (seg.z1 - seg.z0), 0, 1)
        out = np.where(inside, np.maximum(out, seg.r0 + t * (seg.r1 - seg.r0)), out)
    return out


def test_cutter_offset_is_exact_for_a_ball() -> None:
    grown = tool_geometry(BALL, cutter_offset=0.5)["cutter"]
    shrunk = tool_geometry(BALL, cutter_offset=-0.5)["cutter"]
    assert grown.mesh.vertices[:, 2].min() == pytest.approx(-0.5, abs=1e-12)
    assert shrunk.mesh.vertices[:, 2].min() == pytest.approx(0.5, abs=1e-12)
    assert grown.corner_centre_height == pytest.approx(3.0)
    assert shrunk.corner_centre_height == pytest.approx(3.0)
    for part, radius in ((grown, 3.5), (shrunk, 2.5)):
        below = part.mesh.vertices[part.mesh.vertices[:, 2] < 3.0 - 1e-9]
        distance = np.linalg.norm(below - [0, 0, 3.0], axis=1)
        assert distance.min() >= radius - 1e-9
        assert distance.max() <= radius + part.excess + 1e-9
    with pytest.raises(InputError):
        tool_geometry(BALL, cutter_offset=-3.0)


def test_axis_spheres_cover_the_part_mesh() -> None:
    rng = np.random.default_rng(3)
    for tool in (BALL, FLAT, resolve_tool("bull10r2")):
        for part in tool_geometry(tool).values():
            heights, radii = axis_spheres(
                part.profile, part.radial_scale, 0.25, part.corner_centre_height
            )
            tri = part.mesh.triangles
            a, b = rng.random((2, 20, len(tri), 1))
            flip = (a + b) > 1
            a, b = np.where(flip, 1 - a, a), np.where(flip, 1 - b, b)
            points = tri[None, :, 0] + a * (tri[None, :, 1] - tri[None, :, 0])
            points = (points + b * (tri[None, :, 2] - tri[None, :, 0])).reshape(-1, 3)
            points = np.vstack([points, part.mesh.vertices])
            centres = np.column_stack([np.zeros((len(heights), 2)), heights])
            gap = np.linalg.norm(points[:, None, :] - centres[None], axis=2) - radii[None]
            assert gap.min(axis=1).max() <= 1e-9
            assert radii.max() <= part.profile[:, 0].max() * part.radial_scale + 0.25 + 1e-9


def test_inscribed_radii_hand_case() -> None:
    part = tool_geometry(BALL)["cutter"]
    inner = inscribed_radii(part.profile, np.array([3.0, 1.0, 14.0, 20.0]), part.arc_excess)
    # at the ball centre the inscribed ball is the ball (less the polygon excess)
    assert inner[0] == pytest.approx(3.0 - part.arc_excess, abs=1e-9)
    assert inner[1] == pytest.approx(1.0 - part.arc_excess, abs=1e-9)  # nearest: the tip
    assert inner[2] == pytest.approx(1.0 - part.arc_excess, abs=1e-9)  # nearest: the top
    assert inner[3] == 0.0  # outside the cutter


def test_profile_depth_hand_case() -> None:
    """Signed depth of a point in a revolved profile: a cylinder r 5, 0 <= z <= 10."""
    from cam.collision.triangle_bvh import profile_depth as _depth

    profile = np.array([[0.0, 0.0], [5.0, 0.0], [5.0, 10.0], [0.0, 10.0]])
    tip, axis = np.array([1.0, 2.0, 3.0]), np.array([0.0, 0.0, 1.0])
    # meridian (rho, h) = (3, 4): 2 mm from the side, 4 from the bottom -> depth 2
    assert _depth(profile, tip, axis, 1.0 + 3.0, 2.0, 3.0 + 4.0) == pytest.approx(2.0)
    # (6, 4): 1 mm outside the side -> -1
    assert _depth(profile, tip, axis, 1.0, 2.0 + 6.0, 3.0 + 4.0) == pytest.approx(-1.0)
    # (0, 9.5) on the axis: 0.5 mm below the top; the axis itself is not a surface
    assert _depth(profile, tip, axis, 1.0, 2.0, 3.0 + 9.5) == pytest.approx(0.5)
    # (2, -1): below the bottom -> -1
    assert _depth(profile, tip, axis, 1.0, 2.0 + 2.0, 3.0 - 1.0) == pytest.approx(-1.0)
    # tilted axis: the same point in the rotated frame
    t = math.radians(30.0)
    tilted = np.array([math.sin(t), 0.0, math.cos(t)])
    across = np.array([math.cos(t), 0.0, -math.sin(t)])
    point = tip + 4.0 * tilted + 3.0 * across
    assert _depth(profile, tip, tilted, *point) == pytest.approx(2.0)


def test_surface_samples_cover_within_radius() -> None:
    mesh = box((0, 0, 0), (7, 3, 2))
    points, covering = surface_samples(mesh.vertices, mesh.faces, 0.5)
    assert covering <= 0.5 / math.sqrt(3) + 1e-12
    rng = np.random.default_rng(5)
    probe, _ = trimesh.sample.sample_surface(mesh, 500, seed=rng.integers(1 << 30))
    nearest = np.linalg.norm(probe[:, None] - points[None], axis=2).min(axis=1)
    assert nearest.max() <= covering + 1e-12


def test_grid_bounds_are_valid_and_exact_distances_agree_with_trimesh(
    impeller_scene: CollisionScene,
) -> None:
    hub = impeller_scene.meshes["hub"]
    rng = np.random.default_rng(8)
    lo, hi = hub.bounds
    points = lo - 15 + rng.random((3000, 3)) * (hi - lo + 30)  # inside and outside the grid
    exact = impeller_scene.triangles["hub"].distances(points, 1e9)
    _, reference, _ = trimesh.proximity.closest_point(hub, points[:300])
    assert np.allclose(exact[:300], reference, atol=1e-9)
    grid = impeller_scene.grids["hub"]
    bound = grid.part_bounds(points, np.tile([0.0, 0.0, 1.0], (3000, 1)), np.zeros(1), np.zeros(1))
    assert np.all(bound <= exact + 1e-12)
    near = exact < 3.0  # within the exact band the bound loses at most the cell diagonal
    assert near.sum() > 100
    assert np.all(exact[near] - bound[near] <= math.sqrt(3.0) * grid.spacing + 1e-3)
    whole = impeller_scene.whole.part_bounds(
        points, np.tile([0.0, 0.0, 1.0], (3000, 1)), np.zeros(1), np.zeros(1)
    )
    assert np.all(whole <= bound + 1e-12)


# -- postures ------------------------------------------------------------------------


@settings(max_examples=200, deadline=None)
@given(
    st.tuples(*[st.floats(-1, 1, allow_nan=False)] * 3).filter(
        lambda v: bool(np.linalg.norm(v) > 1e-3)
    )
)
def test_rotations_take_z_onto_axis(vector: tuple[float, float, float]) -> None:
    axis = np.asarray(vector)[None] / np.linalg.norm(vector)
    rot = rotations_to(axis)[0]
    assert np.allclose(rot @ [0, 0, 1], axis[0], atol=1e-12)
    assert np.allclose(rot @ rot.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(rot) == pytest.approx(1.0, abs=1e-12)


def test_rotation_of_minus_z() -> None:
    rot = rotations_to(np.array([[0.0, 0.0, -1.0]]))[0]
    assert np.allclose(rot @ [0, 0, 1], [0, 0, -1])
    assert np.linalg.det(rot) == pytest.approx(1.0)


# -- closed-form cases ---------------------------------------------------------------


@pytest.mark.parametrize(
    ("height", "hit"), [(-0.5, True), (-1e-3, True), (0.0, True), (1e-3, False), (0.7, False)]
)
def test_ball_above_plane_vertical(floor_scene: CollisionScene, height: float, hit: bool) -> None:
    report = floor_scene.check_postures(BALL, [[1.0, 2.0, height]], UP)
    assert bool(report.collides[0]) is hit
    assert report.part[0] == (0 if hit else -1)
    assert report.hit_role[0] == ("floor" if hit else None)
    # the shank starts 15 mm above the tip; its lowest mesh point is on the axis
    assert report.clearance[0] == pytest.approx(15.0 + height, abs=1e-9)


@pytest.mark.parametrize("tilt_deg", [20.0, 45.0])
def test_tilted_ball_above_plane(floor_scene: CollisionScene, tilt_deg: float) -> None:
    t = math.radians(tilt_deg)
    axis = np.array([[math.sin(t), 0.0, math.cos(t)]])
    excess = tool_geometry(BALL)["cutter"].excess
    for gap, hit in ((excess + 1e-3, False), (-1e-3, True), (-0.2, True), (0.3, False)):
        centre = np.array([0.0, 0.0, 3.0 + gap])  # lowest point of the true ball at z = gap
        report = floor_scene.check_postures(BALL, centre - 3.0 * axis, axis, clearance=False)
        assert bool(report.collides[0]) is hit, gap
        assert np.isnan(report.clearance[0])


def test_no_postures_give_an_empty_report(floor_scene: CollisionScene) -> None:
    empty = np.zeros((0, 3))
    report = floor_scene.check_postures(BALL, empty, empty)
    assert report.collides.shape == (0,) and report.clearance.shape == (0,)
    assert not report.collides.any()


def test_cutter_allowance_lets_the_ball_touch(floor_scene: CollisionScene) -> None:
    touching = [[0.0, 0.0, -0.01]]
    assert floor_scene.check_postures(BALL, touching, UP).collides[0]
    shrunk = floor_scene.check_postures(BALL, touching, UP, cutter_allowance=0.02)
    assert not shrunk.collides[0]
    # roughing: nothing closer than eta = 0.3 mm
    near = [[0.0, 0.0, 0.2]]
    assert not floor_scene.check_postures(BALL, near, UP).collides[0]
    assert floor_scene.check_postures(BALL, near, UP, cutter_allowance=-0.3).collides[0]
    # clearance threshold (roughing: with cutter_allowance=-eta for the cutter)
    rough = floor_scene.check_postures(
        BALL, [[0.0, 0.0, 0.5], [0.0, 0.0, -14.8], [0.0, 0.0, 2.0]], np.repeat(UP, 3, 0),
        parts=("shank", "holder"),
    )
    assert list(rough.blocked(0.3)) == [False, True, False]  # 2nd: shank 0.2 mm off the floor
    assert list(rough.blocked()) == [False, False, False]
    with pytest.raises(ValueError, match="clearance"):
        floor_scene.check_postures(BALL, near, UP, clearance=False).blocked(0.3)
    # the cutter may be excluded entirely
    skip = floor_scene.check_postures(BALL, touching, UP, parts=("shank", "holder"))
    assert not skip.collides[0]


@pytest.mark.parametrize(("wall_x", "hit"), [(24.0, True), (25.5, False), (26.0, False)])
def test_holder_hits_a_box_wall(wall_x: float, hit: bool) -> None:
    scene = CollisionScene({"part": box((-30, -30, -20), (30, 30, 0)),
                            "wall": box((wall_x, -40, 100), (wall_x + 10, 40, 140))})
    report = scene.check_postures(BALL, [[0.0, 0.0, 5.0]], UP)
    assert bool(report.collides[0]) is hit
    assert report.part[0] == (2 if hit else -1)
    assert report.hit_role[0] == ("wall" if hit else None)
    holder_mesh_radius = 25.0 / math.cos(math.pi / 48)  # a ring vertex lies at phi = 0
    expected = 0.0 if hit else wall_x - holder_mesh_radius
    assert report.clearance[0] == pytest.approx(expected, abs=1e-9)


def test_flat_tool_through_a_slot() -> None:
    def slot(width: float) -> CollisionScene:
        half = 0.5 * width
        return CollisionScene({
            "left": box((-50, -half - 20, -30), (50, -half, 10)),
            "right": box((-50, half, -30), (50, half + 20, 10)),
            "floor": box((-50, -50, -40), (50, 50, -30)),
        })

    mesh_radius = 5.0 / math.cos(math.pi / 48)
    tip = np.array([[-40.0, 0.0, -20.0], [0.0, 0.0, -20.0], [40.0, 0.0, -20.0]])
    axis = np.repeat(UP, 3, axis=0)
    wide = slot(2 * mesh_radius + 0.02)
    along = wide.check_motion(FLAT, tip, axis, max_step_mm=1.0, max_step_deg=1.0)
    assert not along.collides.any()
    # the shank (ring vertex at phi = 90 deg) runs 0.01 mm from the slot walls
    assert np.allclose(along.clearance, 0.01, atol=1e-9)
    narrow = slot(2 * 5.0 - 0.02)  # narrower than the true cutter: must hit a side wall
    report = narrow.check_postures(FLAT, tip, axis)
    assert report.collides.all() and (report.part == 0).all()
    assert set(report.hit_role) == {"left"}
    across = wide.check_motion(
        FLAT, [[0.0, -30.0, -20.0], [0.0, 30.0, -20.0]], np.repeat(UP, 2, 0),
        max_step_mm=0.5, max_step_deg=1.0,
    )
    assert across.collides[0] and across.hit_role[0] == "left"


# -- identical answers to the plain fcl loop -----------------------------------------


def _random_postures(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    radius = rng.uniform(10.0, 45.0, n)
    phi = rng.uniform(0.0, 2 * math.pi, n)
    tip = np.column_stack([radius * np.cos(phi), radius * np.sin(phi), rng.uniform(5, 60, n)])
    axis = rng.normal(size=(n, 3)) + [0.0, 0.0, 1.5]
    return tip, axis / np.linalg.norm(axis, axis=1)[:, None]


@pytest.mark.parametrize(
    "options",
    [
        {},
        {"cutter_allowance": 0.05},
        {"cutter_allowance": -0.5, "parts": ("cutter", "holder")},
        {"cutter_roles": ("hub",), "cutter_allowance": 0.02},
    ],
)
def test_identical_to_plain_fcl_loop(impeller_scene: CollisionScene, options: dict) -> None:
    rng = np.random.default_rng(11)
    tip, axis = _random_postures(rng, 400)
    fast = impeller_scene.check_postures(BALL, tip, axis, clearance=False, **options)
    plain = plain_fcl_check(impeller_scene, BALL, tip, axis, clearance=False, **options)
    assert np.array_equal(fast.collides, plain.collides)
    assert np.array_equal(fast.part, plain.part)
    assert fast.hit_role == plain.hit_role
    assert 0 < fast.collides.sum() < len(tip)  # a real mix of hits and misses
    assert fast.checks["collide"] < len(tip)  # the broad phase decided most


def test_identical_near_the_hub(impeller_scene: CollisionScene) -> None:
    """Finishing-like postures: ball 0-0.3 mm off random hub points."""
    hub = impeller_scene.meshes["hub"]
    rng = np.random.default_rng(12)
    face = rng.choice(np.flatnonzero(hub.face_normals[:, 2] > 0.1), 400)
    centre = hub.triangles_center[face] + (3.0 + rng.uniform(-0.1, 0.3, 400))[:, None] * (
        hub.face_normals[face]
    )
    axis = hub.face_normals[face] + rng.normal(0, 0.3, (400, 3))
    axis /= np.linalg.norm(axis, axis=1)[:, None]
    tip = centre - 3.0 * axis
    for allowance in (0.0, 0.05):
        fast = impeller_scene.check_postures(BALL, tip, axis, cutter_allowance=allowance)
        plain = plain_fcl_check(impeller_scene, BALL, tip, axis, cutter_allowance=allowance)
        assert np.array_equal(fast.collides, plain.collides)
        assert np.array_equal(fast.part, plain.part)
        assert fast.hit_role == plain.hit_role
        assert np.allclose(fast.clearance, plain.clearance, atol=1e-9)


def _radius_at(profile: np.ndarray, height: np.ndarray) -> np.ndarray:
    """Largest radius of a meridian polygon ``(r, z)`` at each height, mm (0 outside)."""
    out = np.zeros_like(height)
    for (r0, z0), (r1, z1) in zip(profile[:-1], profile[1:], strict=True):
        lo, hi = min(z0, z1), max(z0, z1)
        inside = (height >= lo) & (height <= hi)
        t = np.clip((height - z0) / (z1 - z0), 0.0, 1.0) if z1 != z0 else np.ones_like(height)
        r = np.where(z1 != z0, r0 + t * (r1 - r0), max(r0, r1))
        out = np.where(inside, np.maximum(out, r), out)
    return out


def _side_postures(
    scene: CollisionScene, seed: int, allowance: float, part: str, n: int = 40
) -> tuple[np.ndarray, np.ndarray]:
    """Postures whose ``part`` passes within about +-0.3 mm of random surface points.

    A random point p (normal nu) of a random role. Sideways (even postures): an
    axis rising away from the surface (tangent + 0.2-0.6 nu), the part's
    circumscribing profile at most 2 mm above its lowest point at signed distance
    ``U(-0.3, 0.3)`` mm from p on the outer side. End-on (odd postures): the axis
    about along nu (components up to 0.1 off), the part's lowest axis point that
    far above p.
    The ball/shank/holder just touches, just misses or cuts in.
    """
    rng = np.random.default_rng(seed)
    role = scene.roles[int(rng.integers(len(scene.roles)))]
    mesh = scene.meshes[role]
    face = rng.choice(len(mesh.faces), size=n, p=mesh.area_faces / mesh.area_faces.sum())
    a, b = rng.random((2, n))
    flip = a + b > 1
    a, b = np.where(flip, 1 - a, a), np.where(flip, 1 - b, b)
    tri = mesh.triangles[face]
    point = tri[:, 0] + a[:, None] * (tri[:, 1] - tri[:, 0]) + b[:, None] * (tri[:, 2] - tri[:, 0])
    normal = mesh.face_normals[face]
    tangent = np.cross(normal, rng.normal(size=(n, 3)))
    tangent /= np.linalg.norm(tangent, axis=1)[:, None]
    axis = tangent + rng.uniform(0.2, 0.6, n)[:, None] * normal
    axis /= np.linalg.norm(axis, axis=1)[:, None]
    side = normal - np.einsum("ij,ij->i", normal, axis)[:, None] * axis
    side /= np.linalg.norm(side, axis=1)[:, None]
    geometry = scene.tool_model(BALL, -allowance).parts[part]
    z = geometry.profile[:, 1]
    height = z.min() + rng.uniform(0.0, min(2.0, float(np.ptp(z))), n)
    gap = rng.uniform(-0.3, 0.3, n)
    radius = _radius_at(geometry.profile, height) + gap
    tip = point - height[:, None] * axis + radius[:, None] * side
    # every other posture end-on instead: the part's lowest point gap above p
    up = normal + rng.uniform(-0.1, 0.1, (n, 3))
    up /= np.linalg.norm(up, axis=1)[:, None]
    end = np.arange(n) % 2 == 1
    tip[end] = point[end] + gap[end, None] * normal[end] - z.min() * up[end]
    axis[end] = up[end]
    return tip, axis


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 2**31 - 1),
    allowance=st.sampled_from([0.0, 0.03, -0.3]),
    part=st.sampled_from(["cutter", "shank", "holder"]),
)
def test_property_fast_path_equals_plain_loop_near_surfaces(
    impeller_scene: CollisionScene, seed: int, allowance: float, part: str
) -> None:
    """Fast check and plain fcl loop agree posture by posture on near contacts."""
    tip, axis = _side_postures(impeller_scene, seed, allowance, part)
    for parts in ((part,), ("cutter", "shank", "holder")):
        fast = impeller_scene.check_postures(
            BALL, tip, axis, parts=parts, cutter_allowance=allowance, clearance=False
        )
        plain = plain_fcl_check(
            impeller_scene, BALL, tip, axis, parts=parts, cutter_allowance=allowance,
            clearance=False,
        )
        assert np.array_equal(fast.collides, plain.collides)
        assert np.array_equal(fast.part, plain.part)
        assert fast.hit_role == plain.hit_role


def test_side_postures_mix_hits_and_misses(impeller_scene: CollisionScene) -> None:
    """The property test's postures are near contacts: both answers occur for each part,
    and the fast path leaves some of them to fcl (the undecided band is exercised)."""
    for part in ("cutter", "shank", "holder"):
        postures = [_side_postures(impeller_scene, s, 0.0, part) for s in range(10)]
        tip = np.concatenate([p[0] for p in postures])
        axis = np.concatenate([p[1] for p in postures])
        plain = plain_fcl_check(impeller_scene, BALL, tip, axis, parts=(part,), clearance=False)
        fast = impeller_scene.check_postures(BALL, tip, axis, parts=(part,), clearance=False)
        assert 0 < plain.collides.sum() < len(tip), part
        assert fast.checks["collide"] > 0 and fast.checks["definite_hits"] > 0, part


def test_clearance_cap_gives_exact_values_below_and_bounds_above(
    impeller_scene: CollisionScene,
) -> None:
    rng = np.random.default_rng(13)
    tip, axis = _random_postures(rng, 200)
    exact = impeller_scene.check_postures(BALL, tip, axis)
    capped = impeller_scene.check_postures(BALL, tip, axis, clearance_cap=2.0)
    below = exact.clearance <= 2.0
    assert below.any() and (~below).any()
    assert np.allclose(capped.clearance[below], exact.clearance[below], atol=1e-9)
    assert np.all(capped.clearance[~below] >= 2.0)  # a lower bound: at least the cap
    assert np.all(capped.clearance[~below] <= exact.clearance[~below] + 1e-9)
    assert np.all(exact.clearance[capped.clearance >= 2.0] >= 2.0 - 1e-9)
    # the cap saves exact-distance work: fewer postures reach the kernel, no more fcl
    assert capped.checks["kernel"] < exact.checks["kernel"]
    assert capped.checks["distance"] <= exact.checks["distance"]


def test_grown_profile_of_a_cylinder_by_hand() -> None:
    """A cylinder r = 2, z 0..10 grown by 1: r = 3 over z -1..11 (the Minkowski sum's
    outline, its rounded edges inside)."""
    profile = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 10.0], [0.0, 10.0]])
    grown = grown_profile(profile, 1.0, step=0.5)
    assert grown[0].tolist() == [0.0, -1.0] and grown[-1].tolist() == [0.0, 11.0]
    assert np.allclose(grown[1:-1, 0], 3.0)
    assert np.all(np.diff(grown[1:-1, 1]) <= 0.5 + 1e-12)


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**31 - 1), st.floats(0.5, 5.0))
def test_grown_profile_contains_every_point_within_the_distance(seed: int, grow: float
                                                                ) -> None:
    """Points within ``grow`` of the tapered shank and stepped holder of ``BALL`` lie
    inside the grown outline (radius from the axis against the outline's radius at
    that height, linear between its points)."""
    rng = np.random.default_rng(seed)
    for segments in (BALL.shank_segments(), BALL.holder):
        profile = segments_profile(tuple(segments))
        grown = grown_profile(profile, grow)[1:-1]
        side = profile[1:-1]
        z = rng.uniform(side[0, 1], side[-1, 1], 400)
        r = np.interp(z, side[:, 1], side[:, 0]) * rng.uniform(0.0, 1.0, 400)
        offset = rng.normal(size=(400, 2))
        offset *= (grow * rng.uniform(0.0, 1.0, 400) / np.linalg.norm(offset, axis=1))[:, None]
        rho, height = np.abs(r + offset[:, 0]), z + offset[:, 1]
        assert np.all(height >= grown[0, 1] - 1e-12) and np.all(height <= grown[-1, 1] + 1e-12)
        assert np.all(rho <= np.interp(height, grown[:, 1], grown[:, 0]) + 1e-9)


def test_clearance_cap_measures_a_piece_nested_in_the_grown_tool() -> None:
    """Above the cap a grown-tool collide that misses proves the clearance, but fcl
    meshes only meet where surfaces cross: a crumb 1 mm from the shank, wholly inside
    the shank grown by the 2 mm cap, is measured (about 1 mm), not passed as >= 2."""
    scene = CollisionScene({"crumb": box((4.9, -0.2, 39.8), (5.3, 0.2, 40.2)),
                            "floor": box((-50, -50, -120), (50, 50, -110))})
    tip = np.zeros((1, 3))
    capped = scene.check_postures(BALL, tip, UP, clearance_cap=2.0)
    exact = scene.check_postures(BALL, tip, UP)
    assert not capped.collides[0]
    assert 0.9 < exact.clearance[0] < 1.1
    assert capped.clearance[0] == pytest.approx(exact.clearance[0], abs=1e-9)


def test_surface_buried_inside_the_cutter_is_not_a_hit() -> None:
    """fcl semantics: a small closed mesh entirely inside the ball touches no surface."""
    scene = CollisionScene({"crumb": box((-0.2, -0.2, 2.8), (0.2, 0.2, 3.2)),
                            "floor": box((-50, -50, -20), (50, 50, -10))})
    fast = scene.check_postures(BALL, [[0.0, 0.0, 0.0]], UP)
    plain = plain_fcl_check(scene, BALL, [[0.0, 0.0, 0.0]], UP)
    assert not plain.collides[0]
    assert not fast.collides[0]


def test_definite_hits_of_pieces_smaller_than_the_part() -> None:
    """A 12 mm block (smaller than the holder) pushed into the holder's side."""
    block = {"block": box((20.0, -6.0, 120.0), (32.0, 6.0, 132.0))}
    scene = CollisionScene(block)
    assert scene.triangles["block"].smallest_component < scene.tool_model(BALL).size["holder"]
    tip = np.array([[0.0, 0.0, 0.0], [-10.0, 0.0, 0.0], [-20.0, 0.0, 0.0]])
    axis = np.repeat(UP, 3, axis=0)
    fast = scene.check_postures(BALL, tip, axis)
    plain = plain_fcl_check(scene, BALL, tip, axis)
    assert list(fast.collides) == [True, False, False]
    assert fast.part[0] == 2 and fast.hit_role[0] == "block"
    assert fast.checks["definite_hits"] == 1 and fast.checks["collide"] == 0
    assert np.array_equal(fast.collides, plain.collides) and fast.hit_role == plain.hit_role
    assert np.allclose(fast.clearance, plain.clearance, atol=1e-9)


def test_tool_without_holder() -> None:
    bare = Tool("bare", 9, "ball", 6.0, 3.0, 12.0, 6.0, 30.0)
    scene = CollisionScene({"floor": box((-50, -50, -10), (50, 50, 0))})
    report = scene.check_postures(bare, [[0.0, 0.0, 1.0]], UP)
    assert not report.collides[0]
    assert report.clearance[0] == pytest.approx(13.0, abs=1e-9)
    only_holder = scene.check_postures(bare, [[0.0, 0.0, -1.0]], UP, parts=("holder",))
    assert not only_holder.collides[0]
    assert len(tool_geometry(Tool("stub", 9, "flat", 6.0, 0.0, 12.0, 6.0, 12.0))) == 1


# -- motion --------------------------------------------------------------------------


def test_subdivision_respects_the_steps() -> None:
    tip = np.array([[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [10.0, 0.0, 0.0]])
    axis = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [math.sin(0.3), 0.0, math.cos(0.3)]])
    sub_tip, sub_axis, starts = subdivide_motion(tip, axis, 0.75, math.radians(2.0))
    assert list(np.diff(starts)) == [14, math.ceil(math.degrees(0.3) / 2.0)]
    assert np.allclose(sub_tip[starts], tip) and np.allclose(sub_axis[starts], axis)
    assert np.linalg.norm(np.diff(sub_tip, axis=0), axis=1).max() <= 0.75 + 1e-12
    turn = np.arccos(np.clip(np.einsum("ij,ij->i", sub_axis[:-1], sub_axis[1:]), -1, 1))
    assert turn.max() <= math.radians(2.0) + 1e-12
    assert np.allclose(np.linalg.norm(sub_axis, axis=1), 1.0)


def test_motion_bound_hand_computed() -> None:
    # L = 100 mm, 1 mm and 1 deg per step: 0.5 + 200 * sin(0.25 deg) = 0.5 + 0.87266
    assert motion_bound(100.0, 1.0, math.radians(1.0)) == pytest.approx(
        0.5 + 200.0 * math.sin(math.radians(0.25)), rel=1e-12
    )
    assert motion_bound(100.0, 1.0, math.radians(1.0)) == pytest.approx(1.37266, abs=1e-5)


def test_motion_through_a_thin_wall_is_caught() -> None:
    scene = CollisionScene({"wall": box((-0.1, -50, -50), (0.1, 50, 50))})
    tip = np.array([[-10.0, 0.0, 0.0], [10.0, 0.0, 0.0]])
    axis = np.repeat(UP, 2, axis=0)
    ends = scene.check_postures(BALL, tip, axis)
    assert not ends.collides.any()  # both end postures are clear ...
    motion = scene.check_motion(BALL, tip, axis, max_step_mm=1.0, max_step_deg=1.0)
    assert motion.collides[0]  # ... the move between is not:
    assert motion.part[0] == 1  # the shank (r 3.2-5) meets the wall before the ball (r 3)
    assert motion.bound == pytest.approx(
        motion_bound(scene.tool_model(BALL).reach, 1.0, math.radians(1.0))
    )


def test_motion_bound_holds_on_random_motions(impeller_scene: CollisionScene) -> None:
    """A contact at a 20x finer sampling implies a reported contact or clearance <= bound."""
    rng = np.random.default_rng(21)
    start, axis0 = _random_postures(rng, 40)
    step = rng.normal(0, 4.0, (40, 3))
    turn = rng.normal(0, 0.15, (40, 3))
    axis1 = axis0 + turn
    axis1 /= np.linalg.norm(axis1, axis=1)[:, None]
    for i in range(40):
        tip = np.vstack([start[i], start[i] + step[i]])
        axis = np.vstack([axis0[i], axis1[i]])
        coarse = impeller_scene.check_motion(
            BALL, tip, axis, max_step_mm=2.0, max_step_deg=3.0, parts=("shank", "holder")
        )
        fine_tip, fine_axis, _ = subdivide_motion(tip, axis, 0.1, math.radians(0.15))
        fine = impeller_scene.check_postures(
            BALL, fine_tip, fine_axis, parts=("shank", "holder"), clearance=False
        )
        if fine.collides.any():
            assert coarse.collides[0] or coarse.clearance[0] <= coarse.bound


def test_motion_with_known_ends_gives_the_same_answers(impeller_scene: CollisionScene) -> None:
    """``ends`` (the postures' own report, a higher clearance cap) only saves checks."""
    hub = impeller_scene.meshes["hub"]
    rng = np.random.default_rng(23)
    face = np.sort(rng.choice(np.flatnonzero(hub.face_normals[:, 2] > 0.1), 120))
    centre = hub.triangles_center[face] + 3.2 * hub.face_normals[face]
    axis = hub.face_normals[face] + rng.normal(0, 0.3, (120, 3))
    axis /= np.linalg.norm(axis, axis=1)[:, None]
    tip = centre - 3.0 * axis
    options = {"cutter_allowance": 0.05, "clearance_cap": 2.0, "clearance_limits": (2.0,)}
    ends = impeller_scene.check_postures(BALL, tip, axis, **dict(options, clearance_cap=3.0))
    plain = impeller_scene.check_motion(BALL, tip, axis, max_step_mm=2.0, max_step_deg=3.0,
                                        **options)
    known = impeller_scene.check_motion(BALL, tip, axis, max_step_mm=2.0, max_step_deg=3.0,
                                        ends=ends, **options)
    assert np.array_equal(known.collides, plain.collides)
    assert np.array_equal(known.part, plain.part)
    assert known.hit_role == plain.hit_role
    assert np.array_equal(known.clearance < 2.0, plain.clearance < 2.0)
    assert 0 < (plain.collides | (plain.clearance < 2.0)).sum() < len(plain)  # a real mix
    assert known.checks["kernel"] < plain.checks["kernel"]  # the ends were not checked again
    with pytest.raises(InputError, match="ends"):
        impeller_scene.check_motion(BALL, tip[:5], axis[:5], max_step_mm=2.0, max_step_deg=3.0,
                                    ends=ends)


# -- bad input -----------------------------------------------------------------------


def test_bad_input_raises_input_error(floor_scene: CollisionScene) -> None:
    with pytest.raises(InputError, match="unit"):
        floor_scene.check_postures(BALL, [[0, 0, 0]], [[0, 0, 2.0]])
    with pytest.raises(InputError, match="same shape"):
        floor_scene.check_postures(BALL, [[0, 0, 0], [1, 1, 1]], UP)
    with pytest.raises(InputError, match="finite"):
        floor_scene.check_postures(BALL, [[0, 0, math.nan]], UP)
    with pytest.raises(InputError, match="part"):
        floor_scene.check_postures(BALL, [[0, 0, 0]], UP, parts=("flutes",))
    with pytest.raises(InputError, match="role"):
        floor_scene.check_postures(BALL, [[0, 0, 0]], UP, cutter_roles=("blade",))
    with pytest.raises(InputError, match="half turn"):
        floor_scene.check_motion(
            BALL, [[0, 0, 5], [0, 0, 5]], [[0, 0, 1], [0, 0, -1]], max_step_mm=1, max_step_deg=1
        )
    with pytest.raises(InputError, match="positive"):
        floor_scene.check_motion(
            BALL, [[0, 0, 5], [1, 0, 5]], [[0, 0, 1], [0, 0, 1]], max_step_mm=0, max_step_deg=1
        )
    with pytest.raises(InputError, match="at least one mesh"):
        CollisionScene({})
