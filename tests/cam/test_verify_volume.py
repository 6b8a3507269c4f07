"""Tri-dexel material removal against closed forms and brute-force references."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cam.tools import Segment, Tool
from cam.verify.kernels import swept_interval
from cam.verify.stock import Stock
from cam.verify.toolshape import frustum, sphere_cap, tool_shape

UP = np.array([0.0, 0.0, 1.0])


def _tool(shape: str, diameter: float, corner: float | None = None, flute: float = 12.0) -> Tool:
    radius = 0.5 * diameter
    corner = {"ball": radius, "flat": 0.0}.get(shape, corner)
    assert corner is not None
    return Tool(
        name=f"{shape}{diameter:g}", number=1, shape=shape, diameter=diameter,
        corner_radius=corner, flute_length=flute, shank_diameter=diameter, stickout=30.0,
        holder=(Segment("holder", 30.0, 50.0, 8.0, 10.0),),
    )


def _polyline(stock: Stock, tool: Tool, points: list[tuple[float, float, float]]) -> None:
    pts = np.asarray(points, dtype=np.float64)
    n = len(pts) - 1
    stock.sweep(pts[:-1], np.diff(pts, axis=0), np.tile(UP, (n, 1)),
                np.arange(n, dtype=np.int32), tool_shape(tool))


def ball_slot_volume(radius: float, length: float, e: float) -> float:
    """Ball-end slot below a flat top: centre line ``e`` below the top, ``length`` long.

    Cross-section: half disc + rectangle 2R x e; ends: quarter spheres + half cylinders
    of height e (the plunge at the start lies inside the end cap).
    """
    r = radius
    section = 0.5 * math.pi * r * r + 2.0 * r * e
    ends = 2.0 * (math.pi * r**3 / 3.0 + 0.5 * math.pi * r * r * e)
    return length * section + ends


@pytest.mark.parametrize(("pitch", "tolerance"), [(0.1, 0.005), (0.05, 0.002)])
def test_ball_slot_matches_closed_form(pitch: float, tolerance: float) -> None:
    r, length, e = 3.0, 12.0, 1.0
    stock = Stock.box([-12.0, -6.0, -8.0], [12.0, 6.0, 0.0], pitch)
    before = stock.volume()
    assert before == pytest.approx(24 * 12 * 8, rel=1e-12)
    tip_z = -e - r
    _polyline(stock, _tool("ball", 2 * r), [(-6, 0, 5.0), (-6, 0, tip_z), (6, 0, tip_z)])
    removed = before - stock.volume()
    expected = ball_slot_volume(r, length, e)
    assert removed == pytest.approx(expected, rel=tolerance)


def pocket_volume(width: float, height: float, radius: float, depth: float) -> float:
    """Flat-end pocket: tool centres fill a w x h rectangle -> rounded rectangle x depth."""
    area = (width + 2 * radius) * (height + 2 * radius) - (4.0 - math.pi) * radius**2
    return area * depth


@pytest.mark.parametrize(("pitch", "tolerance"), [(0.1, 0.005), (0.05, 0.002)])
def test_flat_pocket_matches_closed_form(pitch: float, tolerance: float) -> None:
    r, depth = 2.0, 1.5
    w, h = 8.0, 5.0
    stock = Stock.box([-10.0, -8.0, -5.0], [10.0, 8.0, 0.0], pitch)
    before = stock.volume()
    z = -depth
    # plunge in the middle, zig-zag rows 2.5 mm apart (< 2R: no islands), then the contour
    path = [(0, 0, 3.0), (0, 0, z), (-4, -2.5, z)]
    for i, y in enumerate(np.arange(-2.5, 2.51, 2.5)):
        xs = (-4, 4) if i % 2 == 0 else (4, -4)
        path += [(xs[0], y, z), (xs[1], y, z)]
    path += [(-4, 2.5, z), (-4, -2.5, z), (4, -2.5, z), (4, 2.5, z), (-4, 2.5, z), (-4, 2.5, 3.0)]
    _polyline(stock, _tool("flat", 2 * r), path)
    removed = before - stock.volume()
    assert removed == pytest.approx(pocket_volume(w, h, r, depth), rel=tolerance)


def test_bullnose_slot_within_profile_bound() -> None:
    """Bull-nose slot below a flat top; the corner frusta stay within the stated bound."""
    r, rc, e, length = 3.0, 1.0, 0.5, 10.0
    tool = _tool("bullnose", 2 * r, corner=rc)
    shape = tool_shape(tool)
    assert 0 < shape.profile_error < 0.005
    stock = Stock.box([-10.0, -6.0, -4.0], [10.0, 6.0, 0.0], 0.05)
    before = stock.volume()
    depth = rc + e
    _polyline(stock, tool, [(-5, 0, 2.0), (-5, 0, -depth), (5, 0, -depth)])
    # section: bottom flat 2(R - rc) wide, two quarter discs rc, rectangle 2R x e above
    section = 2 * (r - rc) * rc + 0.5 * math.pi * rc * rc + 2 * r * e
    # ends: half of the tool solid of revolution below the top surface
    lower = (math.pi * (r - rc) ** 2 * rc + math.pi**2 * (r - rc) * rc * rc / 2
             + 2 / 3 * math.pi * rc**3)
    ends = lower + math.pi * r * r * e
    expected = length * section + ends
    perimeter_area = length * (2 * r + 2 * depth) + 2 * math.pi * r * depth
    bound = shape.profile_error * perimeter_area
    assert abs(before - stock.volume() - expected) <= bound + 0.002 * expected


def test_initial_stock_volumes_and_save_load(tmp_path) -> None:  # type: ignore[no-untyped-def]
    cyl = Stock.cylinder(20.0, 10.0, 0.1, bore=3.0)
    assert cyl.volume() == pytest.approx(math.pi * (100 - 9) * 10, rel=2e-3)
    _polyline(cyl, _tool("ball", 4.0), [(-12, 0, 12), (-12, 0, 7), (12, 0, 7)])
    cyl.owners = [("a.ngc", 3), ("b.ngc", 12)]
    saved = cyl.save(tmp_path / "s.npz")
    back = Stock.load(saved)
    assert back.volume() == pytest.approx(cyl.volume(), rel=1e-12)
    assert back.owners == cyl.owners and back.pitch == cyl.pitch
    import zipfile

    with zipfile.ZipFile(saved) as archive:  # a deflated .npz (numpy.load reads it)
        assert all(i.compress_type == zipfile.ZIP_DEFLATED for i in archive.infolist())
        assert sum(i.compress_size for i in archive.infolist()) < sum(
            i.file_size for i in archive.infolist())
    for a, b in zip(cyl.grids, back.grids, strict=True):
        pa, _, ma = a.ends()
        pb, _, mb = b.ends()
        np.testing.assert_array_equal(pa, pb)
        np.testing.assert_array_equal(ma, mb)


def test_mesh_stock_matches_analytic_cylinder() -> None:
    import trimesh

    mesh = trimesh.creation.revolve(
        np.array([[3.0, 0.0], [10.0, 0.0], [10.0, 10.0], [3.0, 10.0], [3.0, 0.0]]), sections=720
    )
    from_mesh = Stock.from_mesh(mesh.vertices, mesh.faces, 0.1)
    analytic = Stock.cylinder(20.0, 10.0, 0.1, bore=3.0)
    assert from_mesh.volume() == pytest.approx(mesh.volume, rel=2e-3)
    assert from_mesh.volume() == pytest.approx(analytic.volume(), rel=2e-3)


def test_cut_ends_remember_their_move() -> None:
    stock = Stock.box([-5.0, -5.0, -5.0], [5.0, 5.0, 0.0], 0.25)
    shape = tool_shape(_tool("flat", 2.0))
    stock.sweep(np.array([[0.0, 0.0, -1.0]]), np.zeros((1, 3)), UP[None], np.array([7], np.int32),
                shape)
    points, normals, moves = stock.grids[2].ends()
    tops = (normals[:, 2] > 0) & (np.hypot(points[:, 0], points[:, 1]) < 0.9)
    assert np.all(moves[tops] == 7)
    assert np.allclose(points[tops, 2], -1.0)
    assert np.all(moves[(normals[:, 2] < 0)] == -1)


def _brute_interval(prim: np.ndarray, tip: np.ndarray, move: np.ndarray, axis: np.ndarray,
                    origin: np.ndarray, k: int) -> tuple[float, float]:
    """Ray interval inside the swept primitive by dense sampling of s and t."""
    ts = np.linspace(-20, 20, 4001)
    inside = np.zeros_like(ts, dtype=bool)
    alpha, beta, gamma, zlo, zhi = prim[:5]
    for s in np.linspace(0.0, 1.0, 201):
        pts = origin[None, :] + ts[:, None] * np.eye(3)[k][None, :] - tip - s * move
        z = pts @ axis
        perp = pts - z[:, None] * axis
        q = np.sum(perp * perp, axis=1) + alpha * z * z + beta * z + gamma
        inside |= (q <= 0) & (z >= zlo) & (z <= zhi)
    if not inside.any():
        return math.inf, -math.inf
    return float(ts[inside].min()), float(ts[inside].max())


@settings(max_examples=40, deadline=None)
@given(
    kind=st.sampled_from(["sphere", "cylinder", "cone"]),
    seed=st.integers(0, 10_000),
    k=st.integers(0, 2),
)
def test_swept_interval_matches_sampling(kind: str, seed: int, k: int) -> None:
    rng = np.random.default_rng(seed)
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    tip = rng.uniform(-2, 2, 3)
    move = rng.uniform(-4, 4, 3)
    prim = {"sphere": sphere_cap(2.0, 2.0, 0.0, 2.0), "cylinder": frustum(1.0, 6.0, 2.0, 2.0),
            "cone": frustum(2.0, 7.0, 1.0, 3.0)}[kind]
    origin = rng.uniform(-3, 3, 3)
    origin[k] = 0.0
    coeffs, zw, zu, zd = _swept_coefficients(prim, tip, move, axis, origin, k)
    zlo, zhi = prim[3:5]
    ta, tb = swept_interval(*coeffs, zw, zu, zd, zlo, zhi, np.empty((2, 2)))
    ra, rb = _brute_interval(prim, tip, move, axis, origin, k)
    if not math.isfinite(ra):
        # the sampled points are all outside: the exact interval can only be thin
        step = 40 / 4000 + float(np.linalg.norm(move)) / 200 + 1e-3
        assert not tb > ta or tb - ta < 2 * step
        return
    assert tb > ta
    # every sampled inside point is inside the exact interval (sampling only shrinks it)
    assert ta <= ra + 1e-9 and rb <= tb + 1e-9
    # the exact ends are tight: just inside them the swept primitive holds the ray's
    # point, just outside it does not (a convex body swept along a line is convex); the
    # pointwise oracle minimises the quadric over the move's s exactly, so grazing ends
    # (where the interval moves like a square root of s) need no sampling
    eps = 1e-4
    for t, inside in ((ta + eps, True), (tb - eps, True), (ta - eps, False), (tb + eps, False)):
        assert _inside_swept(prim, tip, move, axis, origin, k, t) == inside, (t, inside)


def _inside_swept(prim: np.ndarray, tip: np.ndarray, move: np.ndarray, axis: np.ndarray,
                  origin: np.ndarray, k: int, t: float) -> bool:
    """Whether the ray's point at ``t`` lies in the primitive at some s of the move.

    For a fixed point the quadric Q(s) of the point in the tool frame at s is a
    quadratic in s and the height z(s) is linear: the minimum of Q over the s range
    where z stays within the primitive's heights (and 0 <= s <= 1) decides.
    """
    alpha, beta, gamma, zlo, zhi = (float(v) for v in prim[:5])
    p = origin + t * np.eye(3)[k]

    def q_and_z(s: float) -> tuple[float, float]:
        d = p - tip - s * move
        z = float(d @ axis)
        return float(d @ d) - z * z + alpha * z * z + beta * z + gamma, z

    (q0, z0), (qh, _), (q1, z1) = q_and_z(0.0), q_and_z(0.5), q_and_z(1.0)
    a = 2 * q1 - 4 * qh + 2 * q0
    b = q1 - q0 - a
    s_lo, s_hi = 0.0, 1.0
    dz = z1 - z0
    if abs(dz) < 1e-15:
        if not zlo <= z0 <= zhi:
            return False
    else:
        sa, sb = sorted(((zlo - z0) / dz, (zhi - z0) / dz))
        s_lo, s_hi = max(s_lo, sa), min(s_hi, sb)
        if s_lo > s_hi:
            return False
    candidates = [s_lo, s_hi]
    if a > 0 and s_lo < -b / (2 * a) < s_hi:
        candidates.append(-b / (2 * a))
    return min(a * s * s + b * s + q0 for s in candidates) <= 0.0


def _swept_coefficients(
    prim: np.ndarray, tip: np.ndarray, move: np.ndarray, axis: np.ndarray, origin: np.ndarray,
    k: int,
) -> tuple[tuple[float, ...], float, float, float]:
    """Q(t, s) coefficients and the tool-frame height terms of one ray (module doc)."""
    w = origin - tip
    zu, zd, zw = axis[k], axis @ move, axis @ w
    u_p, d_p, w_p = np.eye(3)[k] - zu * axis, move - zd * axis, w - zw * axis
    alpha, beta, gamma = prim[:3]
    return (
        (u_p @ u_p + alpha * zu * zu, -(u_p @ d_p) - alpha * zu * zd, d_p @ d_p + alpha * zd * zd,
         w_p @ u_p + alpha * zw * zu + 0.5 * beta * zu,
         -(w_p @ d_p) - alpha * zw * zd - 0.5 * beta * zd,
         w_p @ w_p + alpha * zw * zw + beta * zw + gamma),
        float(zw), float(zu), float(zd),
    )


def _interval_per_s(coeffs: tuple[float, ...], zw: float, zu: float, zd: float, zlo: float,
                    zhi: float, samples: int = 401) -> tuple[float, float]:
    """Union over sampled s of the exact ray interval at that s (Q quadratic in t, qa > 0)."""
    qa, qb, qc, qd, qe, qf = coeffs
    lo, hi = math.inf, -math.inf
    for s in np.linspace(0.0, 1.0, samples):
        b, c = 2.0 * (qb * s + qd), qc * s * s + 2.0 * qe * s + qf
        disc = b * b - 4.0 * qa * c
        if disc < 0.0:
            continue
        t0, t1 = (-b - math.sqrt(disc)) / (2 * qa), (-b + math.sqrt(disc)) / (2 * qa)
        za, zb = (zlo - zw + zd * s) / zu, (zhi - zw + zd * s) / zu
        t0, t1 = max(t0, min(za, zb)), min(t1, max(za, zb))
        if t1 >= t0:
            lo, hi = min(lo, t0), max(hi, t1)
    return lo, hi


def test_swept_interval_of_a_short_move_along_the_ray() -> None:
    # nine_blade finish_hub.ngc line 43 at sweep tolerance 0.005 mm: a 0.009 mm
    # sub-move, the shank frustum on a ray 11 degrees off its axis. The tangency line
    # dQ/ds = 0 had coefficients ~1e-5 and its "root" (t = 57.6, Q = 78 there) was
    # taken, so the shank seemed to run 8.6 mm into the stock.
    coeffs = (0.037548816056039935, -3.959904518903945e-05, 7.577838520395827e-05,
              -4.1335703954436385, 0.0022248357110362443, 429.6142315673146)
    zw, zu, zd = -31.95963243460435, 0.9804483375416728, 0.003066997772569557
    ta, tb = swept_interval(*coeffs, zw, zu, zd, 15.0, 65.0, np.empty((2, 2)))
    ra, rb = _interval_per_s(coeffs, zw, zu, zd, 15.0, 65.0)
    assert (ra, rb) == pytest.approx((84.0597, 98.8963), abs=1e-3)
    assert (ta, tb) == pytest.approx((ra, rb), abs=1e-4)


@settings(max_examples=200, deadline=None)
@given(
    seed=st.integers(0, 100_000),
    length=st.floats(1e-7, 0.05),
    off_axis_deg=st.floats(6.0, 40.0),
    kind=st.sampled_from(["sphere", "cylinder", "shank", "holder"]),
)
def test_swept_interval_of_short_moves_matches_per_s_intervals(
    seed: int, length: float, off_axis_deg: float, kind: str
) -> None:
    # Short sub-moves are what a fine sweep tolerance makes; rays near the tool axis
    # make the conic's t^2 term small. Shapes and distances as on a real tool.
    rng = np.random.default_rng(seed)
    prim = {"sphere": sphere_cap(3.0, 3.0, 0.0, 3.0), "cylinder": frustum(3.0, 30.0, 3.0, 3.0),
            "shank": frustum(15.0, 65.0, 3.0, 4.75), "holder": frustum(65.0, 105.0, 10.0, 13.0)
            }[kind]
    k = int(rng.integers(3))
    e_k = np.eye(3)[k]
    side = np.cross(e_k, rng.normal(size=3))
    side /= np.linalg.norm(side)
    theta = math.radians(off_axis_deg)
    axis = math.cos(theta) * e_k + math.sin(theta) * side
    axis *= rng.choice([-1.0, 1.0])
    tip = rng.uniform(-100.0, 100.0, 3)
    move = rng.normal(size=3)
    move *= length / np.linalg.norm(move)
    radial = rng.normal(size=3)
    radial -= (radial @ axis) * axis
    radial *= rng.uniform(0.0, 1.2 * prim[5]) / np.linalg.norm(radial)
    origin = tip + rng.uniform(prim[3] - 5.0, prim[4] + 5.0) * axis + radial
    origin[k] = 0.0
    coeffs, zw, zu, zd = _swept_coefficients(prim, tip, move, axis, origin, k)
    assert coeffs[0] > 0.0
    ta, tb = swept_interval(*coeffs, zw, zu, zd, prim[3], prim[4], np.empty((2, 2)))
    ra, rb = _interval_per_s(coeffs, zw, zu, zd, prim[3], prim[4])
    # s sampling: a ray grazing the surface can move its ends by length / sin(angle)
    slack = 1e-6 + 50.0 * length
    if not math.isfinite(ra):
        assert not tb > ta or tb - ta <= slack
        return
    assert ta == pytest.approx(ra, abs=slack)
    assert tb == pytest.approx(rb, abs=slack)


def test_rays_through_mesh_edges_and_vertices_count_once() -> None:
    import trimesh

    box = trimesh.creation.box(extents=[2.0, 2.0, 2.0])  # face diagonals pass through rays
    stock = Stock.from_mesh(box.vertices, box.faces, 0.4)
    for grid in stock.grids:
        assert grid.volume() == pytest.approx(8.0, rel=1e-12)
        assert np.all(grid.count[grid.count > 0] == 1)


def test_blank_profile_of_a_spec_contour() -> None:
    from cam.verify.sources import blank_profile

    t = np.linspace(0.0, 0.5 * np.pi, 30)  # a smooth shroud: quarter ellipse, z and r
    contour = np.column_stack([24.0 - 15.0 * np.sin(t), 35.0 - 13.0 * np.cos(t)])
    profile = blank_profile(contour, 1.0, 4.0)
    assert profile[0].tolist() == [4.0, 0.0] and profile[-1].tolist() == [4.0, 0.0]
    assert profile[:, 0].max() == pytest.approx(36.0)
    assert profile[:, 1].max() == pytest.approx(25.0)
    assert profile[2, 1] == pytest.approx(10.0, abs=1e-3)  # outlet: horizontal shroud
    # every offset point lies 1 mm from the contour polyline (r, z)
    line = contour[:, ::-1]
    a, b = line[:-1], line[1:]
    for p in profile[3:-3]:
        t = np.clip(np.sum((p - a) * (b - a), axis=1) / np.sum((b - a) ** 2, axis=1), 0, 1)
        gap = np.min(np.linalg.norm(p - (a + t[:, None] * (b - a)), axis=1))
        assert gap == pytest.approx(1.0, abs=0.05)


def test_blank_profile_turns_the_inlet_face_and_nose() -> None:
    """With the hub: a flat inlet face at the blade top + allowance, the nose above it
    at its final contour (hand-made contours: horizontal-entry shroud, vertical nose)."""
    from cam.verify.sources import blank_profile

    shroud = np.array([[20.0, 22.0], [15.0, 22.0], [10.0, 25.0], [9.0, 35.0]])  # z, r
    hub = np.array([[30.0, 9.0], [25.0, 9.0], [20.0, 9.0], [5.0, 18.0], [4.0, 39.0]])
    profile = blank_profile(shroud, 1.0, 4.0, hub, blade_top=21.0)
    assert profile[0].tolist() == [4.0, 0.0] and profile[-1].tolist() == [4.0, 0.0]
    assert profile[:, 0].max() == pytest.approx(40.0)  # hub rim 39 + allowance
    # inlet face at max(offset shroud inlet z = 20, blade top 21 + 1) = 22
    face = profile[np.isclose(profile[:, 1], 22.0)]
    assert face[:, 0].min() == pytest.approx(9.0) and face[:, 0].max() == pytest.approx(23.0)
    # the nose above the face is the hub contour itself (no allowance), then the bore
    assert [9.0, 25.0] in profile.tolist() and [9.0, 30.0] in profile.tolist()
    assert profile[:, 1].max() == pytest.approx(30.0)
    assert profile[-2].tolist() == [4.0, 30.0]


def test_signed_distance_of_a_box() -> None:
    import trimesh

    from cam.verify.deviation import DesignDistance

    box = trimesh.creation.box(extents=[10.0, 10.0, 10.0])
    distance = DesignDistance(box.vertices, box.faces, max_edge=2.0)
    points = np.array([[0, 0, 6.0], [0, 0, 4.5], [7, 0, 0], [0, -5.2, 1], [6, 6, 0]])
    expected = [1.0, -0.5, 2.0, 0.2, math.sqrt(2.0)]
    assert distance(points) == pytest.approx(expected, abs=1e-9)


def test_ray_parity_inside_of_a_box_and_a_sphere() -> None:
    """Closed-form insides: the box exactly, the sphere away from its facets' chord."""
    import trimesh

    from cam.verify.inside import MeshParity

    rng = np.random.default_rng(7)
    points = rng.uniform(-7.0, 7.0, size=(20000, 3))
    box = trimesh.creation.box(extents=[10.0, 10.0, 10.0])
    parity = MeshParity(np.asarray(box.vertices)[np.asarray(box.faces)])
    assert np.array_equal(parity.inside(points), np.all(np.abs(points) < 5.0, axis=1))
    # rays through shared edges and vertices count once: points on the box's diagonals
    diagonal = np.linspace(-6.0, 6.0, 49)[:, None] * np.array([[1.0, 1.0, 1.0]]) + 1e-3
    assert np.array_equal(parity.inside(diagonal), np.all(np.abs(diagonal) < 5.0, axis=1))
    sphere = trimesh.creation.icosphere(subdivisions=4, radius=5.0)
    parity = MeshParity(np.asarray(sphere.vertices)[np.asarray(sphere.faces)])
    radius = np.linalg.norm(points, axis=1)
    clear = np.abs(radius - 5.0) > 0.05  # the facets' chord error is below 0.02 mm
    assert np.array_equal(parity.inside(points[clear]), radius[clear] < 5.0)


def test_signed_distance_sign_where_the_nearest_sheet_faces_inwards() -> None:
    """A closed mesh with a second, inside-out shell beside the part (what a folded
    fillet makes locally): next to that shell the nearest triangle faces inwards and
    the closest-triangle sign alone says 'inside'; ray parity keeps it outside (the
    rays cross the inverted shell twice or not at all)."""
    import trimesh

    from cam.verify.deviation import DesignDistance

    part = trimesh.creation.box(extents=[10.0, 10.0, 10.0])
    flap = trimesh.creation.box(extents=[2.0, 2.0, 2.0])
    flap.apply_translation([9.0, 0.0, 0.0])
    flap.invert()
    mesh = trimesh.util.concatenate([part, flap])
    distance = DesignDistance(mesh.vertices, mesh.faces, max_edge=2.0)
    points = np.array([[10.5, 0.0, 0.0], [9.0, 0.0, 1.5], [4.0, 0.0, 0.0], [7.5, 0.0, 0.0]])
    assert distance(points) == pytest.approx([0.5, 0.5, -1.0, 0.5], abs=1e-9)


def test_blank_profile_turns_the_outlet_beyond_the_blades() -> None:
    """The outer diameter is turned to the blades' largest radius; beyond it a lathe
    reaches the hub: the blank there is the hub contour + allowance out to the rim, not
    a ring of stock up to the shroud's outlet height (hand-made contours as above,
    blades out to r = 36 mm)."""
    from cam.verify.sources import blank_profile

    shroud = np.array([[20.0, 22.0], [15.0, 22.0], [10.0, 25.0], [9.0, 35.0]])  # z, r
    hub = np.array([[30.0, 9.0], [25.0, 9.0], [20.0, 9.0], [5.0, 18.0], [4.0, 39.0]])
    ring = blank_profile(shroud, 1.0, 4.0, hub, blade_top=21.0)
    turned = blank_profile(shroud, 1.0, 4.0, hub, blade_top=21.0, blade_radius=36.0)
    assert ring[:, 0].max() == turned[:, 0].max() == pytest.approx(40.0)
    # the ring: the outer cylinder rises to the offset shroud's outlet height
    assert ring[2, 1] > 9.5
    # turned: every top point beyond r = 36 and within the hub's end (r 39) lies 1 mm
    # above the hub line z = 5 - (r - 18) / 21; the rim beyond keeps its height
    top = turned[(turned[:, 0] > 36.0 + 1e-9) & (turned[:, 0] < 39.5) & (turned[:, 1] > 0.0)]
    hub_z = 5.0 - (top[:, 0] - 18.0) / 21.0
    assert len(top) >= 1
    assert np.all(np.abs(top[:, 1] - hub_z - 1.0) < 0.01)
    assert turned[2].tolist() == [40.0, pytest.approx(top[0, 1])]
    # a vertical step at r = 36 from the hub offset up to the offset shroud's outlet
    step = turned[np.isclose(turned[:, 0], 36.0)]
    assert step[:, 1].min() == pytest.approx(5.0 - 18.0 / 21.0 + 1.0, abs=0.02)
    assert step[:, 1].max() == pytest.approx(ring[2, 1])
    # inside r = 36 the two blanks are the same polygon
    inner = [p for p in ring.tolist() if p[0] <= 36.0 and p[1] > 0.0]
    assert inner == [p for p in turned.tolist() if p[0] < 36.0 - 1e-9 and p[1] > 0.0]
