"""B-rep faces of the blades (with fillets) and of the hub body, each with its role.

Every face is a B-spline built directly from points sampled on the closed-form
surfaces (:mod:`geometry.brep`); no boolean operation is involved.

* **Blade** (:func:`blade_faces`): per outline segment (:mod:`geometry.outline`) the
  lateral face from the tip (v = 0) down to the rolling ball's blade contact, and
  the fillet face through the ball's cross-section arcs (:mod:`geometry.fillet`);
  the tip (role ``shroud``) is a ruled face between the pressure and suction tip
  curves plus one Coons patch per edge region (leading / trailing edge).
* **Hub body** (:func:`hub_body_faces`): the hub surface of revolution (an exact
  B-spline copy of the contour spline, revolved: parameters ``(phi, s)``) cut into
  one passage-wide sector per main blade along a mid-passage curve, each sector
  trimmed by the holes bounded by its blades' hub-contact loops (edges built *on*
  the hub surface from 2-D curves in ``(phi, s)``); rim sectors, the nose and back
  annuli and the bore.

Faces that share a boundary sample identical points with identical parameters, so
their boundary curves coincide and sewing closes the shell.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from OCP.BRep import BRep_Tool
from OCP.BRepBuilderAPI import (
    BRepBuilderAPI_MakeEdge,
    BRepBuilderAPI_MakeFace,
    BRepBuilderAPI_MakeWire,
    BRepBuilderAPI_Transform,
)
from OCP.BRepLib import BRepLib
from OCP.BRepTools import BRepTools
from OCP.Geom import (
    Geom_BSplineCurve,
    Geom_Circle,
    Geom_CylindricalSurface,
    Geom_Surface,
    Geom_SurfaceOfRevolution,
)
from OCP.gp import gp_Ax1, gp_Ax2, gp_Ax3, gp_Dir, gp_Pln, gp_Pnt, gp_Trsf
from OCP.ShapeFix import ShapeFix_Face
from OCP.TopoDS import TopoDS, TopoDS_Edge, TopoDS_Face, TopoDS_Shape, TopoDS_Solid, TopoDS_Wire
from scipy.interpolate import BSpline, CubicSpline
from scipy.spatial import cKDTree

from geometry.brep import (
    Array1_gp_Pnt,
    GeometryBuildError,
    _knots,
    bspline_curve_2d,
    face_from_grid,
    face_signature,
    faces_of,
)
from geometry.fillet import FilletTrack, fillet_grid, loop_spine
from geometry.outline import OutlineSegment
from geometry.revolved import RevolvedSurface

__all__ = ["BladeFaces", "RoleSolid", "SolidSampling", "blade_faces",
           "Hole", "hub_body_faces", "hub_surface", "match_roles", "rotated"]

Array = NDArray[np.float64]
#: One hole of a hub sector: per outline segment in loop order ``(p, phi, s)`` of the
#: hub contacts, each ``(n,)``.
Hole = list[tuple[Array, Array, Array]]
_Z_AXIS = gp_Ax1(gp_Pnt(0, 0, 0), gp_Dir(0, 0, 1))


@dataclass(frozen=True)
class SolidSampling:
    """How densely the closed-form surfaces are sampled into B-spline faces.

    Attributes
    ----------
    side : int
        Samples along u of a pressure / suction face (and its fillet).
    cap : int
        Samples across each third of a round edge.
    corner, face : int
        Samples across a broken corner / the flat face of a cut edge.
    span : int
        Samples along the span (v) of a blade face.
    arc : int
        Samples across a fillet (along its circular cross-section).
    """

    side: int = 97
    cap: int = 13
    corner: int = 13
    face: int = 9
    span: int = 9
    arc: int = 9

    def per_kind(self) -> dict[str, int]:
        """Samples along each outline segment kind."""
        return {"side": self.side, "cap": self.cap, "corner": self.corner, "face": self.face}


@dataclass
class RoleSolid:
    """A solid and the role of each of its faces (parallel lists)."""

    solid: TopoDS_Solid
    faces: list[TopoDS_Face]
    roles: list[str]


@dataclass
class BladeFaces:
    """Faces of one blade above the hub (and its fillet), with roles.

    Attributes
    ----------
    faces, roles : list
        Lateral faces (one per outline segment), fillet faces (one per segment,
        when the radius is > 0) and tip faces (role ``shroud``).
    tracks : list of FilletTrack
        The rolling-ball (or footprint) tracks, one per outline segment, in loop order.
    """

    faces: list[TopoDS_Face]
    roles: list[str]
    tracks: list[FilletTrack]


def coons_grid(bottom: Array, top: Array, left: Array, right: Array, x: Array,
               y: Array) -> Array:
    """``(n_x, n_y, 3)`` bilinearly blended (Coons) patch through four boundary rows.

    ``bottom``/``top`` are ``(n_x, 3)``, ``left``/``right`` ``(n_y, 3)``; corners must
    agree (``bottom[0] == left[0]``, ``bottom[-1] == right[0]``, ``top[0] == left[-1]``,
    ``top[-1] == right[-1]``). ``x (n_x,)`` and ``y (n_y,)`` in [0, 1] are the sample
    parameters of the rows (the blending weights).
    """
    x = np.asarray(x, float)[:, None, None]
    y = np.asarray(y, float)[None, :, None]
    ruled_y = (1.0 - y) * bottom[:, None] + y * top[:, None]
    ruled_x = (1.0 - x) * left[None] + x * right[None]
    corners = ((1.0 - x) * (1.0 - y) * bottom[0] + x * (1.0 - y) * bottom[-1]
               + (1.0 - x) * y * top[0] + x * y * top[-1])
    grid = ruled_y + ruled_x - corners
    grid[:, 0], grid[:, -1], grid[0], grid[-1] = bottom, top, left, right
    return np.asarray(grid)


def _tip_edge_face(tips: list[Array], x: Array, y: Array) -> TopoDS_Face:
    """Tip face of an edge region from the tip rows of its three pieces.

    A Coons patch: bottom the straight chord between the two sides' tip ends
    (the end ruling of the ruled tip face), top the middle piece (cap third or flat
    face, parameters ``x``), left / right the first / last piece (parameters ``y``).
    """
    first, middle, last = tips[0], tips[1], tips[2][::-1]
    chord = first[0] + x[:, None] * (last[0] - first[0])
    grid = coons_grid(chord, middle, first, last, x, y)
    return face_from_grid(grid, x, y, 3, 3)


def blade_faces(outline: list[OutlineSegment], tracks: list[FilletTrack], radius: float,
                sampling: SolidSampling | None = None) -> BladeFaces:
    """B-spline faces of one blade from its tip (v = 0) down to the fillet (or hub).

    Per outline segment: the lateral face on ``p x [0, v_c(p)]`` (v_c: the blade
    contact of the rolling ball, or the footprint on the hub when ``radius == 0``)
    and, when ``radius > 0``, the fillet face through the cross-section arcs
    (:func:`geometry.fillet.fillet_grid`, trimmed to the union of the rolling balls
    of the whole loop where it folds). Neighbouring faces sample identical
    boundary points with identical parameters, so their boundary curves coincide.
    The tip: a ruled face between the pressure and suction tip curves plus one face
    per edge region (a planar half disc for a round edge, a ruled face between the
    two broken corners for a cut edge).
    """
    sampling = sampling or SolidSampling()
    faces: list[TopoDS_Face] = []
    roles: list[str] = []
    tau = np.linspace(0.0, 1.0, sampling.span)
    arc_t = np.linspace(0.0, 1.0, sampling.arc)
    tips = []
    spine = loop_spine(tracks) if radius > 0 else None
    for segment, track in zip(outline, tracks, strict=True):
        p = track.p
        grid = segment.point(p[:, None] * np.ones_like(tau), track.v[:, None] * tau[None, :])
        grid[:, -1] = track.blade_contact
        faces.append(face_from_grid(grid, p, tau, 3, 3))
        roles.append(segment.role)
        tips.append(grid[:, 0])
        if radius > 0:
            faces.append(face_from_grid(fillet_grid(track, radius, sampling.arc, spine), p,
                                        arc_t))
            roles.append("fillet")
    sides = [k for k, s in enumerate(outline) if s.kind == "side"]
    if len(sides) != 2 or sides[0] != 0:
        raise GeometryBuildError("a blade outline must start with the pressure side")
    pressure, suction = tips[0], tips[sides[1]][::-1]
    faces.append(face_from_grid(np.stack([pressure, suction], axis=1), tracks[0].p,
                                np.array([0.0, 1.0]), 3, 1))
    roles.append("shroud")
    for lo, hi in ((1, sides[1]), (sides[1] + 1, len(outline))):
        if hi - lo != 3:
            raise GeometryBuildError("an edge region of a blade outline must have 3 pieces")
        faces.append(_tip_edge_face(tips[lo:hi], tracks[lo + 1].p, tracks[lo].p))
        roles.append("shroud")
    return BladeFaces(faces, roles, tracks)


def rotated(faces: list[TopoDS_Face], angle: float) -> list[TopoDS_Face]:
    """Copies of ``faces`` rotated by ``angle`` rad about +Z."""
    trsf = gp_Trsf()
    trsf.SetRotation(_Z_AXIS, angle)
    out = []
    for face in faces:
        shape = BRepBuilderAPI_Transform(face, trsf, True).Shape()
        out.append(TopoDS.Face(shape))
    return out


#: How far (mm, and in parameters) a sewn face's middle point and parameter range may
#: be from its input face's to be taken as that face without measuring it.
_SAME_FACE = 1e-9


def _middle_key(face: TopoDS_Face) -> NDArray[np.float64]:
    """``(7,)`` the surface point at the middle of a face's parameter range (mm) and
    that range ``(u0, u1, v0, v1)``: microseconds, where ``face_signature``
    integrates over the face."""
    u0, u1, v0, v1 = BRepTools.UVBounds_s(face)
    point = BRep_Tool.Surface_s(face).Value(0.5 * (u0 + u1), 0.5 * (v0 + v1))
    return np.array([point.X(), point.Y(), point.Z(), u0, u1, v0, v1])


def match_roles(shape: TopoDS_Shape, faces: list[TopoDS_Face], roles: list[str]) -> list[str]:
    """Roles of the faces of a sewn shape, matched to the input faces.

    Sewing keeps the faces' surfaces: a sewn face whose middle point and parameter
    range (``_middle_key``) are those of exactly one input face, within
    ``_SAME_FACE``, is that face. Any other (a face whose range sewing or the solid's
    fix changed) is matched by centroid and area (``face_signature``), as every face
    was before; none of those close enough is an error.
    """
    middles = np.array([_middle_key(f) for f in faces])
    tree = cKDTree(middles[:, :3])
    signatures: tuple[NDArray[np.float64], cKDTree] | None = None
    out = []
    for face in faces_of(shape):
        middle = _middle_key(face)
        scale = _SAME_FACE * max(1.0, float(np.abs(middle).max()))
        same = [i for i in tree.query_ball_point(middle[:3], scale)
                if float(np.abs(middles[i, 3:] - middle[3:]).max()) <= scale]
        if len(same) == 1:
            out.append(roles[same[0]])
            continue
        if signatures is None:
            keys = np.array([face_signature(f) for f in faces])
            signatures = (keys, cKDTree(keys[:, :3]))
        keys, signature_tree = signatures
        key = face_signature(face)
        near = signature_tree.query_ball_point(
            key[:3], 1e-3 * max(1.0, float(np.abs(key[:3]).max())))
        err = [float(np.abs(keys[i] - key).max()) for i in near]
        if not err or min(err) > 1e-4 * max(1.0, abs(key[3])):
            raise GeometryBuildError("sewing changed a face; its role is unknown")
        out.append(roles[near[int(np.argmin(err))]])
    return out


def _exact_contour_curve(hub: RevolvedSurface) -> Geom_BSplineCurve:
    """The hub contour spline as an exact B-spline curve in the XZ meridian plane.

    Its parameter is the contour parameter s of :class:`RevolvedSurface`.
    """
    parts = [BSpline.from_power_basis(CubicSpline(hub.nodes, hub.contour[:, i])) for i in (0, 1)]
    coef = np.column_stack([parts[0].c, parts[1].c])
    poles = Array1_gp_Pnt(1, len(coef))
    for i, (z, r) in enumerate(coef, start=1):
        poles.SetValue(i, gp_Pnt(float(r), 0.0, float(z)))
    knots, mults = _knots(np.asarray(parts[0].t))
    return Geom_BSplineCurve(poles, knots, mults, 3)


def hub_surface(hub: RevolvedSurface) -> Geom_SurfaceOfRevolution:
    """The hub as an OCC surface of revolution with ``(U, V) = (phi, s)`` exactly."""
    return Geom_SurfaceOfRevolution(_exact_contour_curve(hub), _Z_AXIS)


def _pcurve_edge(surface: Geom_Surface, uv: Array, p: Array, degree: int = 3) -> TopoDS_Edge:
    """Edge on ``surface`` along the 2-D B-spline interpolating ``uv (n, 2)`` over ``p``."""
    curve = bspline_curve_2d(uv, p, degree)
    maker = BRepBuilderAPI_MakeEdge(curve, surface)
    if not maker.IsDone():
        raise GeometryBuildError("could not make a hub edge from its parameter curve")
    edge = maker.Edge()
    if not BRepLib.BuildCurves3d_s(edge, 1e-7):
        raise GeometryBuildError("could not build the 3-D curve of a hub edge")
    return edge


def _wire(edges: list[TopoDS_Edge], what: str) -> TopoDS_Wire:
    maker = BRepBuilderAPI_MakeWire()
    for edge in edges:
        maker.Add(edge)
    if not maker.IsDone():
        raise GeometryBuildError(f"{what} does not close into a wire")
    return maker.Wire()


def _fixed(face: TopoDS_Face) -> TopoDS_Face:
    fixer = ShapeFix_Face(face)
    fixer.FixOrientation()
    fixer.Perform()
    return TopoDS.Face(fixer.Face())


def hub_sector_face(surface: Geom_Surface, boundary: Array, s: Array, pitch: float,
                    holes: list[Hole]) -> TopoDS_Face:
    """One passage-wide sector of the hub face, with the holes of its blade(s).

    Parameters
    ----------
    surface : Geom_Surface
        :func:`hub_surface`.
    boundary : (n,) float64
        Angle phi_B(s) of the sector's upper boundary at ``s``, rad; the lower one is
        ``phi_B(s) - pitch``.
    s : (n,) float64
        Contour parameters from 0 (nose) to 1 (rim).
    holes : list of list of (p, phi, s)
        Per hole, per outline segment in loop order: parameters and the hub
        contacts' angle (already inside the sector) and contour parameter.
    """
    lo = np.column_stack([boundary - pitch, s])
    hi = np.column_stack([boundary, s])
    outer = [
        _pcurve_edge(surface, lo, s),
        _pcurve_edge(surface, np.stack([lo[-1], hi[-1]]), np.array([0.0, 1.0]), 1),
        _pcurve_edge(surface, hi, s),
        _pcurve_edge(surface, np.stack([hi[0], lo[0]]), np.array([0.0, 1.0]), 1),
    ]
    maker = BRepBuilderAPI_MakeFace(surface, _wire(outer, "a hub sector boundary"), True)
    if not maker.IsDone():
        raise GeometryBuildError("could not make a hub sector face")
    face = _fixed(maker.Face())
    maker = BRepBuilderAPI_MakeFace(face)
    for loop in holes:
        edges = [_pcurve_edge(surface, np.column_stack([phi, s_c]), p) for p, phi, s_c in loop]
        maker.Add(TopoDS.Wire(_wire(edges, "the hub contacts of a blade").Reversed()))
    if not maker.IsDone():
        raise GeometryBuildError("could not add the blade holes to the hub face")
    return _fixed(maker.Face())


def _circle(radius: float, z: float) -> Geom_Circle:
    return Geom_Circle(gp_Ax2(gp_Pnt(0, 0, z), gp_Dir(0, 0, 1), gp_Dir(1, 0, 0)), radius)


def _annulus(z: float, outer: float, inner: float, start: float, pitch: float,
             count: int) -> TopoDS_Face:
    """Planar annulus at height z: outer circle as ``count`` arcs from ``start``."""
    circle = _circle(outer, z)
    arcs = [BRepBuilderAPI_MakeEdge(circle, start + k * pitch, start + (k + 1) * pitch).Edge()
            for k in range(count)]
    plane = gp_Pln(gp_Pnt(0, 0, z), gp_Dir(0, 0, 1))
    maker = BRepBuilderAPI_MakeFace(plane, _wire(arcs, "an annulus"), True)
    hole = _wire([BRepBuilderAPI_MakeEdge(_circle(inner, z)).Edge()], "a bore circle")
    maker.Add(TopoDS.Wire(hole.Reversed()))
    if not maker.IsDone():
        raise GeometryBuildError("could not make a planar hub face")
    return _fixed(maker.Face())


def _cylinder(radius: float, a: float, b: float, z0: float, z1: float) -> TopoDS_Face:
    surface = Geom_CylindricalSurface(gp_Ax3(gp_Pnt(0, 0, 0), gp_Dir(0, 0, 1),
                                             gp_Dir(1, 0, 0)), radius)
    maker = BRepBuilderAPI_MakeFace(surface, a, b, z0, z1, 1e-7)
    if not maker.IsDone():
        raise GeometryBuildError("could not make a cylindrical hub face")
    return maker.Face()


def hub_body_faces(hub: RevolvedSurface, bore_radius: float, pitch: float, count: int,
                   boundary: Array, s: Array,
                   holes: list[Hole]) -> tuple[list[TopoDS_Face],
                                                                            list[str]]:
    """Faces of the hub body: ``count`` hub sectors with holes, rim sectors, nose, back, bore.

    The hub face is split into passage-wide sectors between rotated copies of the
    curve ``phi_B(s)`` (a mid-passage curve that follows the blades' wrap, so no
    blade hole crosses a sector boundary even when a blade wraps more than a
    pitch). Sector k is sector 0 (:func:`hub_sector_face`, holes ``holes``)
    rotated by ``k * pitch``; the rim cylinder is split at the same angles, the
    nose and back annuli have matching arcs, the bore is one cylinder.

    Returns
    -------
    faces, roles : list, list of str
        Roles ``hub``, ``rim``, ``nose``, ``back``, ``bore``.
    """
    (z0, r0), (z1, r1) = hub.contour[0], hub.contour[-1]
    if not (0.0 < bore_radius < min(r0, r1)):
        raise GeometryBuildError("bore radius must be inside the hub contour")
    if z1 <= 0.0 or z0 <= 0.0:
        raise GeometryBuildError("the hub contour must stay above the back face z = 0")
    sector = hub_sector_face(hub_surface(hub), boundary, s, pitch, holes)
    rim = _cylinder(r1, boundary[-1] - pitch, boundary[-1], 0.0, z1)
    faces: list[TopoDS_Face] = []
    roles: list[str] = []
    for k in range(count):
        faces.extend(rotated([sector, rim], k * pitch) if k else [sector, rim])
        roles.extend(["hub", "rim"])
    faces.append(_annulus(z0, r0, bore_radius, boundary[0] - pitch, pitch, count))
    faces.append(_annulus(0.0, r1, bore_radius, boundary[-1] - pitch, pitch, count))
    faces.append(_cylinder(bore_radius, 0.0, 2.0 * math.pi, 0.0, z0))
    roles.extend(["nose", "back", "bore"])
    return faces, roles
