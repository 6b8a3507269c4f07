"""The impeller B-rep with rolling-ball fillets (geometry.outline/fillet/solids/assembly).

Acceptance on the `small` fixture (6 blades, fillet 1 mm, round LE, cut TE): one valid
closed solid that survives a STEP round trip, STL volume = STEP volume within 0.5 %,
watertight STL, symmetric under a rotation by one pitch (exact point-to-B-rep
distances, not limited by the tessellation), every face with a role, fillet faces
that are the rolling-ball envelope (distance to the centre line = r_f within 1e-3 mm)
and tangent to blade and hub. Closed-form rolling-ball cases are checked by hand.
"""

from __future__ import annotations

import math
import re
import shutil
from pathlib import Path

import numpy as np
import pytest
import trimesh
from OCP.BRep import BRep_Tool
from OCP.BRepAdaptor import BRepAdaptor_Curve
from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeVertex
from OCP.BRepExtrema import BRepExtrema_DistShapeShape
from OCP.BRepTools import BRepTools
from OCP.GeomAPI import GeomAPI_ProjectPointOnSurf
from OCP.GeomLProp import GeomLProp_SLProps
from OCP.gp import gp_Pnt
from OCP.OCP.collections import (
    IndexedDataMap_TopoDS_Shape_List_TopoDS_Shape_TopTools_ShapeMapHasher as EdgeFaceMap,
)
from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE
from OCP.TopExp import TopExp
from OCP.TopoDS import TopoDS, TopoDS_Face
from scipy.spatial import cKDTree

from geometry.brep import compound, is_valid, solids_of, volume
from geometry.export import read_step, write_step
from geometry.fillet import (
    FilletTrack,
    _v_limit,
    blade_tracks,
    fold_ratio,
    rolling_ball,
    section_parameters,
)
from geometry.impeller import Impeller
from geometry.mesh import collapse_short_edges, triangulate_faces
from geometry.outline import OutlineSegment, blade_loop, blade_outline
from geometry.revolved import RevolvedSurface
from geometry.solids import coons_grid
from geometry.surfaces import rotation_z
from impeller_cam.errors import InputError

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures" / "impellers"


def _fixture_copy(name: str, out: Path, fillet: float) -> Path:
    """Copy of a fixture with another fillet radius."""
    shutil.copytree(FIXTURES / name, out, dirs_exist_ok=True)
    text = (out / "spec.toml").read_text()
    text = re.sub(r"fillet_radius_mm = [0-9.]+", f"fillet_radius_mm = {fillet}", text)
    (out / "spec.toml").write_text(text)
    return out / "spec.toml"


@pytest.fixture(scope="module")
def small() -> Impeller:
    impeller = Impeller.from_spec(FIXTURES / "small" / "spec.toml", fillets=True)
    assert impeller.solid is not None
    return impeller


# -- closed-form pieces --------------------------------------------------------------

def _plane_blade(alpha: float) -> OutlineSegment:
    """Blade plane rising from the line (y = 0, z = 5) at angle ``alpha`` from the hub
    plane z = 5; points at distance ``20 v`` from that line (v = 1 on the hub), normal
    on the +y side."""
    d = np.array([0.0, math.cos(alpha), math.sin(alpha)])
    n = np.array([0.0, math.sin(alpha), -math.cos(alpha)])

    def point(p: np.ndarray, v: np.ndarray) -> np.ndarray:
        p, v = np.broadcast_arrays(np.asarray(p, float), np.asarray(v, float))
        x = 10.0 + 20.0 * p
        base = np.stack([x, np.zeros_like(x), np.full_like(x, 5.0)], axis=-1)
        return base + (20.0 * (1.0 - v))[..., None] * d

    def normal(p: np.ndarray, v: np.ndarray) -> np.ndarray:
        return np.broadcast_to(n, np.broadcast(np.asarray(p), np.asarray(v)).shape + (3,))

    return OutlineSegment("pressure", "side", lambda p: np.asarray(p), point, normal)


@pytest.mark.parametrize("alpha_deg", [90.0, 60.0, 120.0])
def test_rolling_ball_between_two_planes_matches_hand_computation(alpha_deg: float) -> None:
    # hub z = 5 (contour at constant z), blade plane at angle alpha. The ball of radius
    # r touches the blade at distance s = r (1 + cos a) / sin a from the corner line
    # (= r / tan(a/2)); its centre is r above the hub: z_c = 5 + r.
    alpha, r = math.radians(alpha_deg), 1.5
    hub = RevolvedSurface(np.column_stack([np.full(7, 5.0), np.linspace(2.0, 60.0, 7)]), +1)
    p = np.linspace(0.0, 1.0, 5)
    track = rolling_ball(_plane_blade(alpha), hub, r, p, np.full(5, 1.5))
    s = r * (1.0 + math.cos(alpha)) / math.sin(alpha)
    assert np.allclose(track.v, 1.0 - s / 20.0, atol=1e-9)
    assert np.allclose(track.centre[:, 2], 5.0 + r, atol=1e-8)
    expected_y = s * math.cos(alpha) + r * math.sin(alpha)
    assert np.allclose(track.centre[:, 1], expected_y, atol=1e-8)
    assert np.allclose(track.hub_contact, track.centre - [0.0, 0.0, r], atol=1e-8)
    assert np.allclose(track.hub_normal, [0.0, 0.0, 1.0], atol=1e-12)


def test_rolling_ball_of_radius_zero_is_the_footprint() -> None:
    hub = RevolvedSurface(np.column_stack([np.full(7, 5.0), np.linspace(2.0, 60.0, 7)]), +1)
    track = rolling_ball(_plane_blade(math.radians(70.0)), hub, 0.0, np.array([0.0, 1.0]),
                         np.full(2, 1.5))
    assert np.allclose(track.v, 1.0, atol=1e-9)
    assert np.allclose(track.blade_contact, track.hub_contact, atol=1e-8)


def test_ball_that_cannot_fit_names_the_fillet_radius() -> None:
    hub = RevolvedSurface(np.column_stack([np.full(7, 5.0), np.linspace(2.0, 60.0, 7)]), +1)
    with pytest.raises(InputError) as error:  # blade 20 mm high, ball 25 mm
        rolling_ball(_plane_blade(math.radians(90.0)), hub, 25.0, np.array([0.5]),
                     np.array([1.5]))
    assert error.value.field == "blade.fillet_radius_mm"


def test_section_parameters_are_symmetric_and_end_clustered() -> None:
    p = section_parameters(13)
    assert p[0] == 0.0 and p[-1] == 1.0 and np.all(np.diff(p) > 0)
    assert np.allclose(1.0 - p[::-1], p, atol=1e-15, rtol=0)
    assert np.diff(p)[0] < np.diff(p)[6]


def test_coons_grid_reproduces_its_boundaries_and_bilinear_patches() -> None:
    x, y = np.linspace(0, 1, 5), section_parameters(4)
    a, b, c, d = (np.array(v, float) for v in ([0, 0, 0], [2, 0, 0], [0, 1, 1], [2, 1, 3]))
    bottom, top = a + x[:, None] * (b - a), c + x[:, None] * (d - c)
    left, right = a + y[:, None] * (c - a), b + y[:, None] * (d - b)
    grid = coons_grid(bottom, top, left, right, x, y)
    bilinear = ((1 - x)[:, None, None] * ((1 - y)[None, :, None] * a + y[None, :, None] * c)
                + x[:, None, None] * ((1 - y)[None, :, None] * b + y[None, :, None] * d))
    assert np.allclose(grid, bilinear, atol=1e-12)


@pytest.mark.parametrize("edges", [("round", "cut"), ("cut", "round")])
def test_outline_is_a_g1_loop(small: Impeller, edges: tuple[str, str]) -> None:
    blade = small.surfaces.blades[0]
    outline = blade_loop(blade, *edges)
    v = np.linspace(0.0, 1.05, 8)
    one, zero, eps = np.ones(8), np.zeros(8), 1e-6
    for k, segment in enumerate(outline):
        nxt = outline[(k + 1) % len(outline)]
        assert np.abs(segment.point(one, v) - nxt.point(zero, v)).max() < 1e-12
        # geometric normals just inside both pieces agree (tangent-plane continuity)
        a, b = segment.normal(one - eps, v), nxt.normal(zero + eps, v)
        assert np.degrees(np.arccos(np.clip((a * b).sum(-1), -1, 1))).max() < 0.01
    kinds = [s.kind for s in outline]
    assert kinds.count("side") == 2 and len(outline) == 8


# -- the small impeller --------------------------------------------------------------

def test_step_roundtrip_and_stl_volume(small: Impeller, tmp_path: Path) -> None:
    step = small.export_step(tmp_path / "i.step")
    stl = small.export_stl(tmp_path / "i.stl", tolerance=0.02)
    found = solids_of(read_step(step))
    assert len(found) == 1 and is_valid(found[0])
    mesh = trimesh.load_mesh(stl)
    assert mesh.is_watertight
    assert abs(mesh.volume - volume(found[0])) / volume(found[0]) < 0.005
    assert abs(volume(found[0]) - volume(small.solid)) / volume(small.solid) < 1e-6


def test_step_output_is_deterministic(small: Impeller, tmp_path: Path) -> None:
    a = write_step(small.solid, tmp_path / "a.step").read_bytes()
    b = write_step(small.solid, tmp_path / "b.step").read_bytes()
    assert a == b
    assert b"1970-01-01T00:00:00" in a


def test_every_face_has_a_role_and_every_segment_its_fillet(small: Impeller) -> None:
    counts = small.role_counts()
    assert sum(counts.values()) == len(small.built.part.faces)
    for role in ("hub", "pressure", "suction", "leading_edge", "trailing_edge", "shroud",
                 "back", "bore", "rim", "nose"):
        assert counts[role] >= 1, role
    segments = sum(len(t) for t in small.built.tracks)
    assert segments == 6 * 8  # round LE: 3 cap pieces; cut TE: corner, face, corner
    assert counts["fillet"] == segments


def _exact_distance(points: np.ndarray, faces: list[TopoDS_Face], face_of_vertex: np.ndarray,
                    tree: cKDTree) -> np.ndarray:
    """Distance of each point to the B-rep faces near it (BRepExtrema, exact): the faces
    of the mesh vertices within 1 mm and of the 20 nearest vertices."""
    out = []
    for q in points:
        _, nearest = tree.query(q, k=20)
        near = sorted({int(face_of_vertex[i])
                       for i in [*tree.query_ball_point(q, 1.0), *nearest]})
        vertex = BRepBuilderAPI_MakeVertex(gp_Pnt(*map(float, q))).Vertex()
        dist = BRepExtrema_DistShapeShape(vertex, compound([faces[i] for i in near]))
        assert dist.IsDone()
        out.append(dist.Value())
    return np.array(out)


def test_rotation_by_pitch_maps_the_solid_onto_itself(small: Impeller) -> None:
    # Mesh vertices lie exactly on the B-rep faces; rotated by 2 pi / N they must lie
    # on the B-rep again: exact point-to-face distances (BRepExtrema) to the faces
    # whose mesh vertices are within 1 mm, so the tessellation does not limit the test.
    faces = small.built.part.faces
    parts = triangulate_faces(small.solid, faces, 0.05, 0.5)
    vertices = np.vstack([v for v, _ in parts])
    face_of_vertex = np.concatenate([np.full(len(v), i) for i, (v, _) in enumerate(parts)])
    rng = np.random.default_rng(7)
    picked = vertices[rng.choice(len(vertices), 250, replace=False)]
    rotated = picked @ rotation_z(small.spec.pitch).T
    dist = _exact_distance(rotated, faces, face_of_vertex, cKDTree(vertices))
    assert float(dist.max()) < 0.01


def _surface_normal(face: TopoDS_Face, point: np.ndarray) -> np.ndarray:
    surface = BRep_Tool.Surface_s(face)
    projector = GeomAPI_ProjectPointOnSurf(gp_Pnt(*map(float, point)), surface)
    u, v = projector.LowerDistanceParameters()
    props = GeomLProp_SLProps(surface, u, v, 1, 1e-9)
    return np.array(props.Normal().Coord())


def test_fillets_are_tangent_to_blade_and_hub(small: Impeller) -> None:
    part = small.built.part
    role_of = list(zip(part.faces, part.roles, strict=True))
    edge_faces = EdgeFaceMap()
    TopExp.MapShapesAndAncestors_s(part.solid, TopAbs_EDGE, TopAbs_FACE, edge_faces)
    worst = {"blade": 0.0, "hub": 0.0}
    checked = {"blade": 0, "hub": 0}
    for i in range(1, edge_faces.Extent() + 1):
        pair = [TopoDS.Face(f) for f in edge_faces.FindFromIndex(i)]
        roles = [next(r for f2, r in role_of if f2.IsSame(f)) for f in pair]
        if roles.count("fillet") != 1 or "shroud" in roles:
            continue
        other = roles[1 - roles.index("fillet")]
        if other == "fillet":
            continue
        kind = "hub" if other == "hub" else "blade"
        curve = BRepAdaptor_Curve(TopoDS.Edge(edge_faces.FindKey(i)))
        for t in np.linspace(0.1, 0.9, 3):
            x = curve.FirstParameter() + t * (curve.LastParameter() - curve.FirstParameter())
            q = np.array(curve.Value(x).Coord())
            a, b = (_surface_normal(f, q) for f in pair)
            angle = math.degrees(math.acos(min(1.0, abs(float(a @ b)))))
            worst[kind] = max(worst[kind], angle)
            checked[kind] += 1
        if sum(checked.values()) > 600:
            break
    assert checked["blade"] > 20 and checked["hub"] > 20
    assert worst["blade"] < 0.5 and worst["hub"] < 0.5, worst


def test_fillet_faces_are_the_rolling_ball_envelope(small: Impeller) -> None:
    # A fillet face's first parameter is its outline segment's p. At 41 values of p
    # per face (most between the construction samples) the closed-form ball centre
    # c(p) is solved again; every face point at (p, t) must lie at r_f from c(p).
    spec, blade = small.spec, small.surfaces.blades[0]
    radius = spec.fillet_radius
    outline = blade_loop(blade, spec.leading_edge, spec.trailing_edge)
    p = np.linspace(0.0, 1.0, 41)
    centres = [rolling_ball(seg, small.surfaces.hub, radius, p,
                            _v_limit(blade, seg.u_of(p), 2 * radius + 3.0)).centre
               for seg in outline]
    errors = []
    for face in small.faces("fillet"):
        _, _, v0, v1 = BRepTools.UVBounds_s(face)
        surface = BRep_Tool.Surface_s(face)
        pts = np.array([[surface.Value(u, v).Coord() for v in np.linspace(v0, v1, 9)]
                        for u in p])
        err = [np.abs(np.linalg.norm(pts - c[:, None], axis=2) - radius).max()
               for c in centres]
        if min(err) < 0.1:  # a fillet face of blade 0
            errors.append(min(err))
    assert len(errors) == len(outline)
    assert max(errors) < 1e-3


def test_no_fillet_faces_without_fillets(tmp_path: Path) -> None:
    impeller = Impeller.from_spec(FIXTURES / "small" / "spec.toml", fillets=False)
    assert is_valid(impeller.solid)
    counts = impeller.role_counts()
    assert counts["fillet"] == 0 and counts["pressure"] == 6
    with_fillets = Impeller.from_spec(_fixture_copy("small", tmp_path / "f0", fillet=0.0))
    assert with_fillets.role_counts()["fillet"] == 0


def test_fillet_too_large_for_the_blade_is_an_input_error(tmp_path: Path) -> None:
    impeller = Impeller.from_spec(_fixture_copy("small", tmp_path / "big", fillet=6.0))
    with pytest.raises(InputError) as error:
        _ = impeller.solid
    assert error.value.field == "blade.fillet_radius_mm"


def test_fillet_running_off_the_hub_nose_is_an_input_error(small: Impeller) -> None:
    # the same hub surface, but its contour starts 0.3 mm before the leading-edge root
    hub, blade, spec = small.surfaces.hub, small.surfaces.blades[0], small.spec
    root = blade.camber(0.0, 1.0)
    s_le = float(hub.closest_s(root[2], math.hypot(root[0], root[1])))
    short = RevolvedSurface(hub.meridian(np.linspace(s_le - 0.3 / hub.length, 1.0, 400)), +1)
    outline = blade_loop(blade, spec.leading_edge, spec.trailing_edge)
    samples = {"side": 9, "cap": 5, "corner": 5, "face": 5}
    blade_tracks(blade, hub, outline, spec.fillet_radius, samples)  # fits on the real hub
    with pytest.raises(InputError) as error:
        blade_tracks(blade, short, outline, spec.fillet_radius, samples)
    assert error.value.field == "blade.fillet_radius_mm"
    assert "nose" in str(error.value)


def test_fold_ratio_of_a_circular_centre_line_is_radius_over_circle_radius() -> None:
    # centre line on a circle of radius 4 mm: curvature 1/4, so r_f = 2 gives 0.5
    p = np.linspace(0.0, 1.0, 41)
    a = 1.2 * p
    centre = np.column_stack([4.0 * np.cos(a), 4.0 * np.sin(a), np.zeros_like(a)])
    zeros = np.zeros_like(centre)
    track = FilletTrack("pressure", p, p, centre, zeros, zeros, zeros, zeros, p, p)
    assert fold_ratio(track, 2.0) == pytest.approx(0.5, abs=1e-3)
    straight = FilletTrack("pressure", p, p, np.column_stack([p, p, p]), zeros, zeros, zeros,
                           zeros, p, p)
    assert fold_ratio(straight, 2.0) == pytest.approx(0.0, abs=1e-9)


def test_collapse_short_edges_keeps_a_closed_mesh_closed() -> None:
    # an icosphere with one edge split 1e-7 mm from its end: the tiny edges collapse,
    # the mesh stays watertight and consistently wound, no vertex moves
    sphere = trimesh.creation.icosphere(subdivisions=2, radius=10.0)
    faces = np.asarray(sphere.faces).copy()
    a, b = (int(x) for x in sphere.edges_unique[0])
    new = len(sphere.vertices)
    vertices = np.vstack([sphere.vertices, sphere.vertices[a]
                          + 1e-7 * (sphere.vertices[b] - sphere.vertices[a])])
    split = []
    for f in faces:
        if a in f and b in f:
            i, j = int(np.flatnonzero(f == a)[0]), int(np.flatnonzero(f == b)[0])
            first, second = f.copy(), f.copy()
            if (j - i) % 3 == 1:  # a -> b in this triangle's order
                first[j], second[i] = new, new
            else:
                first[i], second[j] = new, new
            split += [first, second]
        else:
            split.append(f)
    faces = np.array(split)
    before = trimesh.Trimesh(vertices, faces, process=False)
    assert before.is_watertight
    kept, alive = collapse_short_edges(vertices, faces, 1e-5)
    after = trimesh.Trimesh(vertices, kept, process=False)
    assert after.is_watertight and after.is_winding_consistent
    assert len(kept) == len(faces) - 2 and alive.sum() == len(kept)
    assert abs(after.volume - sphere.volume) < 1e-9 * sphere.volume


def test_blade_outline_is_the_loop_with_one_segment_per_role(small: Impeller) -> None:
    blade, spec = small.surfaces.blades[0], small.spec
    outline = blade_outline(blade, spec.leading_edge, spec.trailing_edge)
    loop = blade_loop(blade, spec.leading_edge, spec.trailing_edge)
    assert [s.role for s in outline] == ["pressure", "trailing_edge", "suction", "leading_edge"]
    v = np.linspace(0.0, 1.0, 5)
    # the cut trailing edge: its middle third is the loop's flat face
    te = outline[1].point(np.full(5, 0.5), v)
    assert np.allclose(te, loop[2].point(np.full(5, 0.5), v), atol=1e-12)
    # the suction side runs the other way in the loop
    assert np.allclose(outline[2].point(np.full(5, 0.25), v),
                       loop[4].point(np.full(5, 0.75), v), atol=1e-12)


def test_bounding_box_is_the_optimal_box_of_the_whole_shape() -> None:
    """``bounding_box`` (analytic faces exactly, B-spline faces only where their pole
    box reaches out) equals ``BRepBndLib.AddOptimal`` of the whole shape: a box with a
    B-spline sphere inside it and one standing out of it (NURBS-converted faces)."""
    from OCP.Bnd import Bnd_Box
    from OCP.BRepBndLib import BRepBndLib
    from OCP.BRepBuilderAPI import BRepBuilderAPI_NurbsConvert
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox, BRepPrimAPI_MakeSphere
    from OCP.gp import gp_Pnt

    from geometry.brep import bounding_box

    def nurbs(shape: object) -> object:
        return BRepBuilderAPI_NurbsConvert(shape, True).Shape()  # type: ignore[call-arg]

    block = BRepPrimAPI_MakeBox(gp_Pnt(-5.0, -5.0, -5.0), 10.0, 10.0, 10.0).Shape()
    inside = nurbs(BRepPrimAPI_MakeSphere(gp_Pnt(0.5, 0.0, 0.0), 2.0).Shape())
    outside = nurbs(BRepPrimAPI_MakeSphere(gp_Pnt(4.0, 1.0, 2.0), 3.0).Shape())
    shape = compound([block, inside, outside])
    reference = Bnd_Box()
    BRepBndLib.AddOptimal_s(shape, reference, False, False)
    expected = np.array([reference.CornerMin().Coord(), reference.CornerMax().Coord()])
    found = bounding_box(shape)
    assert np.allclose(found, expected, rtol=0.0, atol=1e-9)
    assert found[1, 0] == pytest.approx(7.0, abs=1e-6)  # the outer sphere's side
    assert found[0, 0] == pytest.approx(-5.0, abs=1e-9)  # the block's


def test_match_roles_by_middle_point_or_else_by_centroid_and_area() -> None:
    """A sewn face with its input face's surface and parameter range takes that face's
    role; one whose parametrisation changed (the same square on a plane with another
    origin) is matched by centroid and area; one whose geometry changed is an error."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    from OCP.gp import gp_Ax3, gp_Dir, gp_Pln

    from geometry.brep import GeometryBuildError
    from geometry.solids import match_roles

    def square(origin: tuple[float, float, float], u: tuple[float, float],
               v: tuple[float, float]) -> TopoDS_Face:
        plane = gp_Pln(gp_Ax3(gp_Pnt(*origin), gp_Dir(0.0, 0.0, 1.0), gp_Dir(1.0, 0.0, 0.0)))
        return BRepBuilderAPI_MakeFace(plane, u[0], u[1], v[0], v[1]).Face()

    a = square((0.0, 0.0, 0.0), (-1.0, 1.0), (-1.0, 1.0))
    b = square((10.0, 0.0, 0.0), (-1.0, 2.0), (-1.0, 1.0))
    moved = square((5.0, 0.0, 0.0), (-6.0, -4.0), (-1.0, 1.0))  # a, parametrised anew
    assert match_roles(compound([b, a]), [a, b], ["a", "b"]) == ["b", "a"]
    assert match_roles(compound([moved, b]), [a, b], ["a", "b"]) == ["a", "b"]
    smaller = square((0.0, 0.0, 0.0), (-1.0, 0.5), (-1.0, 1.0))
    with pytest.raises(GeometryBuildError, match="sewing changed a face"):
        match_roles(compound([smaller, b]), [a, b], ["a", "b"])


def test_an_inside_out_solid_is_told_from_its_volume_sign() -> None:
    """``solid_from_faces`` refuses an inside-out solid by classifying the point at
    infinity, not by integrating the volume: the verdict agrees with the volume's sign."""
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox

    from geometry.brep import _outward, faces_of, solid_from_faces

    box = BRepPrimAPI_MakeBox(10.0, 20.0, 30.0).Solid()
    inside_out = TopoDS.Solid(box.Reversed())
    assert volume(box) == pytest.approx(6000.0) and volume(inside_out) == pytest.approx(-6000.0)
    assert _outward(box) and not _outward(inside_out)
    sewn = solid_from_faces(faces_of(box), what="box")
    assert _outward(sewn) and volume(sewn) == pytest.approx(6000.0)
