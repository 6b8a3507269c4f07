"""Small OpenCASCADE (OCP) toolkit: B-spline faces from point grids, sewing, checks.

Every face the solids are made of is built here from a grid of points sampled on
the closed-form surfaces. The grid is interpolated by a tensor-product B-spline
(scipy's not-a-knot interpolation, first along the cross direction ``t`` then along
the running direction ``p``). Two faces that sample the same points along a common
boundary, with the same running parameters, get *identical* boundary curves (the
first and last poles of a clamped interpolant are the end data points), so sewing
closes the shell without gaps or slivers. Edges on the hub surface are built from
2-D curves in its parameters (:func:`bspline_curve_2d`); they match the fillets'
3-D boundary curves to about 3e-5 mm, inside the sewing tolerance.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray
from OCP.BRep import BRep_Builder
from OCP.BRepBuilderAPI import (
    BRepBuilderAPI_MakeFace,
    BRepBuilderAPI_MakeSolid,
    BRepBuilderAPI_Sewing,
)
from OCP.BRepCheck import BRepCheck_Analyzer
from OCP.BRepClass3d import BRepClass3d_SolidClassifier
from OCP.BRepGProp import BRepGProp
from OCP.Geom import Geom_BSplineCurve, Geom_BSplineSurface
from OCP.Geom2d import Geom2d_BSplineCurve
from OCP.gp import gp_Pnt, gp_Pnt2d
from OCP.GProp import GProp_GProps

try:
    from OCP.OCP.collections import (
        Array1_double,
        Array1_gp_Pnt,
        Array1_gp_Pnt2d,
        Array1_int,
        Array2_gp_Pnt,
    )
except ImportError:  # OCP < 8: the cadquery extra's venv (docs/dependencies.md)
    from OCP.TColgp import TColgp_Array1OfPnt as Array1_gp_Pnt  # type: ignore[no-redef]
    from OCP.TColgp import TColgp_Array1OfPnt2d as Array1_gp_Pnt2d  # type: ignore[no-redef]
    from OCP.TColgp import TColgp_Array2OfPnt as Array2_gp_Pnt  # type: ignore[no-redef]
    from OCP.TColStd import TColStd_Array1OfInteger as Array1_int  # type: ignore[no-redef]
    from OCP.TColStd import TColStd_Array1OfReal as Array1_double  # type: ignore[no-redef]
from OCP.ShapeFix import ShapeFix_Solid
from OCP.TopAbs import TopAbs_FACE, TopAbs_OUT, TopAbs_SHELL, TopAbs_SOLID
from OCP.TopExp import TopExp_Explorer
from OCP.TopoDS import TopoDS, TopoDS_Compound, TopoDS_Face, TopoDS_Shape, TopoDS_Solid
from scipy.interpolate import make_interp_spline

__all__ = [
    "GeometryBuildError",
    "bspline_curve",
    "bspline_curve_2d",
    "bspline_surface",
    "compound",
    "face_from_grid",
    "faces_of",
    "is_valid",
    "solid_from_faces",
    "solids_of",
    "volume",
]


class GeometryBuildError(RuntimeError):
    """A B-rep construction step failed; the message says which and why."""


def _knots(
    full: NDArray[np.float64],
) -> tuple[Array1_double, Array1_int]:
    """Full (clamped) knot vector -> OCC distinct knots and multiplicities."""
    values: list[float] = []
    counts: list[int] = []
    for k in full:
        if values and abs(k - values[-1]) <= 1e-14 * max(1.0, abs(k)):
            counts[-1] += 1
        else:
            values.append(float(k))
            counts.append(1)
    knots = Array1_double(1, len(values))
    mults = Array1_int(1, len(values))
    for i, (k, m) in enumerate(zip(values, counts, strict=True), start=1):
        knots.SetValue(i, k)
        mults.SetValue(i, m)
    return knots, mults


def _interpolate(
    x: NDArray[np.float64], y: NDArray[np.float64], degree: int, axis: int
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Interpolating B-spline of ``y`` over ``x`` along ``axis``: (knots, coefficients)."""
    degree = min(degree, len(x) - 1)
    spline = make_interp_spline(x, y, k=degree, axis=axis)
    return np.asarray(spline.t), np.moveaxis(np.asarray(spline.c), 0, axis)


def bspline_surface(
    grid: NDArray[np.float64],
    p: NDArray[np.float64] | None = None,
    t: NDArray[np.float64] | None = None,
    degree_p: int = 3,
    degree_t: int = 3,
) -> Geom_BSplineSurface:
    """Interpolating tensor-product B-spline surface through a point grid.

    Parameters
    ----------
    grid : (n_p, n_t, 3) float64
        Points, mm; rows run along ``p``, columns along ``t``.
    p, t : (n_p,), (n_t,) float64, optional
        Parameters of the rows / columns (default: uniform in [0, 1]).
    degree_p, degree_t : int
        Degrees (reduced to ``n - 1`` when there are too few points).

    Returns
    -------
    Geom_BSplineSurface
    """
    grid = np.asarray(grid, dtype=np.float64)
    n_p, n_t, _ = grid.shape
    p = np.linspace(0.0, 1.0, n_p) if p is None else np.asarray(p, float)
    t = np.linspace(0.0, 1.0, n_t) if t is None else np.asarray(t, float)
    if not np.all(np.isfinite(grid)):
        raise GeometryBuildError("surface grid contains non-finite points")
    knots_t, coef = _interpolate(t, grid, degree_t, axis=1)
    knots_p, coef = _interpolate(p, coef, degree_p, axis=0)
    poles = Array2_gp_Pnt(1, coef.shape[0], 1, coef.shape[1])
    for i in range(coef.shape[0]):
        for j in range(coef.shape[1]):
            x, y, z = coef[i, j]
            poles.SetValue(i + 1, j + 1, gp_Pnt(float(x), float(y), float(z)))
    kp, mp = _knots(knots_p)
    kt, mt = _knots(knots_t)
    return Geom_BSplineSurface(
        poles, kp, kt, mp, mt, min(degree_p, n_p - 1), min(degree_t, n_t - 1)
    )


def bspline_curve(points: NDArray[np.float64], p: NDArray[np.float64] | None = None,
                  degree: int = 3) -> Geom_BSplineCurve:
    """Interpolating B-spline curve through ``(n, 3)`` points (parameters ``p``)."""
    points = np.asarray(points, dtype=np.float64)
    p = np.linspace(0.0, 1.0, len(points)) if p is None else np.asarray(p, float)
    knots, coef = _interpolate(p, points, degree, axis=0)
    poles = Array1_gp_Pnt(1, len(coef))
    for i, (x, y, z) in enumerate(coef, start=1):
        poles.SetValue(i, gp_Pnt(float(x), float(y), float(z)))
    k, m = _knots(knots)
    return Geom_BSplineCurve(poles, k, m, min(degree, len(points) - 1))


def bspline_curve_2d(points: NDArray[np.float64], p: NDArray[np.float64],
                     degree: int = 3) -> Geom2d_BSplineCurve:
    """Interpolating 2-D B-spline curve through ``(n, 2)`` points over parameters ``p``."""
    points = np.asarray(points, dtype=np.float64)
    knots, coef = _interpolate(np.asarray(p, float), points, degree, axis=0)
    poles = Array1_gp_Pnt2d(1, len(coef))
    for i, (x, y) in enumerate(coef, start=1):
        poles.SetValue(i, gp_Pnt2d(float(x), float(y)))
    k, m = _knots(knots)
    return Geom2d_BSplineCurve(poles, k, m, min(degree, len(points) - 1))


def face_from_grid(
    grid: NDArray[np.float64],
    p: NDArray[np.float64] | None = None,
    t: NDArray[np.float64] | None = None,
    degree_p: int = 3,
    degree_t: int = 3,
    tolerance: float = 1e-7,
) -> TopoDS_Face:
    """A face bounded by the natural boundary of :func:`bspline_surface`."""
    surface = bspline_surface(grid, p, t, degree_p, degree_t)
    maker = BRepBuilderAPI_MakeFace(surface, tolerance)
    if not maker.IsDone():
        raise GeometryBuildError("could not make a face from a B-spline surface")
    return maker.Face()


def solid_from_faces(faces: Sequence[TopoDS_Shape], tolerance: float = 1e-5,
                     what: str = "solid") -> TopoDS_Solid:
    """Sew faces into one closed shell and make an outward-oriented solid.

    Raises
    ------
    GeometryBuildError
        When the faces do not close into one valid solid.
    """
    sewing = BRepBuilderAPI_Sewing(tolerance)
    for face in faces:
        sewing.Add(face)
    sewing.Perform()
    sewn = sewing.SewedShape()
    shells = []
    explorer = TopExp_Explorer(sewn, TopAbs_SHELL)
    while explorer.More():
        shells.append(TopoDS.Shell(explorer.Current()))
        explorer.Next()
    if len(shells) != 1 or sewing.NbFreeEdges() != 0:
        raise GeometryBuildError(
            f"{what}: faces do not close into one shell "
            f"({len(shells)} shells, {sewing.NbFreeEdges()} free edges)"
        )
    maker = BRepBuilderAPI_MakeSolid(shells[0])
    fixer = ShapeFix_Solid(maker.Solid())
    fixer.Perform()
    solid = fixer.Solid()
    if solid.ShapeType() != TopAbs_SOLID:
        found = solids_of(solid)
        if len(found) != 1:
            raise GeometryBuildError(f"{what}: shell did not give one solid")
        solid = found[0]
    solid = TopoDS.Solid(solid)
    # an inside-out solid (negative volume) holds the point at infinity: the
    # classifier says so in a tenth of the time of the volume's integration
    if not _outward(solid):
        raise GeometryBuildError(f"{what}: solid is inside out (non-positive volume)")
    if not is_valid(solid):
        raise GeometryBuildError(f"{what}: BRepCheck_Analyzer rejects the solid")
    return solid


def _outward(solid: TopoDS_Solid) -> bool:
    """Whether ``solid`` bounds a finite region (the point at infinity lies outside)."""
    classifier = BRepClass3d_SolidClassifier(solid)
    classifier.PerformInfinitePoint(1e-7)
    return bool(classifier.State() == TopAbs_OUT)


def faces_of(shape: TopoDS_Shape) -> list[TopoDS_Face]:
    """All faces of ``shape`` in exploration order (deterministic)."""
    out = []
    explorer = TopExp_Explorer(shape, TopAbs_FACE)
    while explorer.More():
        out.append(TopoDS.Face(explorer.Current()))
        explorer.Next()
    return out


def solids_of(shape: TopoDS_Shape) -> list[TopoDS_Solid]:
    """All solids of ``shape``."""
    out = []
    explorer = TopExp_Explorer(shape, TopAbs_SOLID)
    while explorer.More():
        out.append(TopoDS.Solid(explorer.Current()))
        explorer.Next()
    return out


def compound(shapes: Sequence[TopoDS_Shape]) -> TopoDS_Compound:
    """A compound of ``shapes``."""
    builder = BRep_Builder()
    result = TopoDS_Compound()
    builder.MakeCompound(result)
    for shape in shapes:
        builder.Add(result, shape)
    return result


def volume(shape: TopoDS_Shape) -> float:
    """Volume of a shape, mm^3."""
    props = GProp_GProps()
    BRepGProp.VolumeProperties_s(shape, props)
    return float(props.Mass())


def area(shape: TopoDS_Shape) -> float:
    """Surface area of a shape, mm^2."""
    props = GProp_GProps()
    BRepGProp.SurfaceProperties_s(shape, props)
    return float(props.Mass())


def bounding_box(shape: TopoDS_Shape) -> NDArray[np.float64]:
    """``(2, 3)`` exact bounding box (lower and upper corner) of a shape's faces, mm.

    ``BRepBndLib.AddOptimal`` of every face, with the work it needs: the optimal box
    of a B-spline face costs tens of milliseconds (seconds for an impeller), so such a
    face is first bounded by its poles (``BRepBndLib.Add``, which contains it) and
    measured exactly only where that box reaches outside the exact box of the faces
    so far (the analytic faces, then the measured B-spline ones, largest pole box
    first). A skipped face lies inside the result, so the box is the optimal box of
    the whole shape.
    """
    from OCP.Bnd import Bnd_Box
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.BRepBndLib import BRepBndLib
    from OCP.GeomAbs import GeomAbs_SurfaceType

    def corners(box: Bnd_Box) -> NDArray[np.float64]:
        return np.array([box.CornerMin().Coord(), box.CornerMax().Coord()])

    exact = np.array([[np.inf] * 3, [-np.inf] * 3])
    splines = []
    for face in faces_of(shape):
        kind = BRepAdaptor_Surface(face).GetType()
        if kind in (GeomAbs_SurfaceType.GeomAbs_BSplineSurface,
                    GeomAbs_SurfaceType.GeomAbs_BezierSurface):
            poles = Bnd_Box()
            BRepBndLib.Add_s(face, poles, False)
            splines.append((corners(poles), face))
            continue
        box = Bnd_Box()
        BRepBndLib.AddOptimal_s(face, box, False, False)
        if not box.IsVoid():
            found = corners(box)
            exact = np.array([np.minimum(exact[0], found[0]), np.maximum(exact[1], found[1])])
    splines.sort(key=lambda item: -float(np.prod(np.maximum(item[0][1] - item[0][0], 0.0))))
    for poles, face in splines:
        if (poles[0] >= exact[0]).all() and (poles[1] <= exact[1]).all():
            continue  # inside what is known: its optimal box is too
        box = Bnd_Box()
        BRepBndLib.AddOptimal_s(face, box, False, False)
        if not box.IsVoid():
            found = corners(box)
            exact = np.array([np.minimum(exact[0], found[0]), np.maximum(exact[1], found[1])])
    return exact


def face_signature(face: TopoDS_Shape) -> NDArray[np.float64]:
    """``(4,)`` centroid (mm) and area (mm^2) of a face: identifies it across rebuilds."""
    props = GProp_GProps()
    BRepGProp.SurfaceProperties_s(face, props)
    c = props.CentreOfMass()
    return np.array([c.X(), c.Y(), c.Z(), props.Mass()])


def is_valid(shape: TopoDS_Shape) -> bool:
    """``BRepCheck_Analyzer`` verdict."""
    return bool(BRepCheck_Analyzer(shape).IsValid())
