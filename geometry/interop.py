"""The impeller in the scripting libraries: build123d and cadquery objects, face roles.

The impeller solid is an OpenCASCADE (OCP) shape; build123d and cadquery wrap the same
OCP classes, so handing it over costs nothing (``impeller_part``,
``impeller_workplane``) and a shape made in either library comes back as its OCP shape
(``occ_shape``), e.g. a script's own blank (``solid_mesh`` -> ``cam.verify.Stock``) or
hub (``geometry.meridional.with_hub``).

Face roles (``geometry.assembly.ROLES``: hub, pressure, suction, fillet, leading_edge,
...) survive an edit in either library: OpenCASCADE's booleans, and build123d's
clean-up after them, keep the *surface* of a face that they split, trim or merge, so
``FaceRoles`` knows a face by its surface. A face that an edit creates (the walls of a
keyway) has no role (``None``).

* build123d: ``impeller_part(impeller)`` is a ``Part``; ``FaceRoles.label(shape)``
  returns its faces with ``Face.label`` set to their role ("" for new faces) and
  ``FaceRoles.select(shape, role)`` those of one role.
* cadquery: ``impeller_workplane(impeller)`` is a ``Workplane`` holding the solid
  with one tag per role, so that ``wp.faces(tag="pressure")`` selects the pressure
  faces (cadquery's idiom for named selections); ``FaceRoles.tag(workplane)`` tags an
  edited one the same way.

build123d is a dependency of impeller-cam and cadquery an optional extra (its OCP
release differs from build123d's: docs/dependencies.md); both are imported only by
the functions that need them.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
import trimesh
from OCP.Bnd import Bnd_Box
from OCP.BRep import BRep_Tool
from OCP.BRepBndLib import BRepBndLib
from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeVertex
from OCP.BRepClass import BRepClass_FaceClassifier
from OCP.BRepExtrema import BRepExtrema_DistShapeShape
from OCP.BRepTools import BRepTools
from OCP.Geom import Geom_Surface
from OCP.gp import gp_Pnt, gp_Pnt2d
from OCP.TopAbs import TopAbs_FACE, TopAbs_IN
from OCP.TopoDS import TopoDS, TopoDS_Face, TopoDS_Shape

from geometry.assembly import ROLES
from geometry.brep import compound, faces_of, solids_of
from geometry.mesh import tessellate
from impeller_cam.errors import InputError
from impeller_cam.tolerances import DEFAULT_TOLERANCES

if TYPE_CHECKING:
    from geometry.impeller import Impeller

__all__ = [
    "FaceRoles",
    "impeller_part",
    "impeller_workplane",
    "occ_shape",
    "solid_mesh",
]

#: A face whose surface an edit rebuilt keeps the role of the original face that a
#: point inside it lies on within this distance, mm.
ON_FACE = 1e-5
#: Parameter grid searched for a point inside a face (``_inner_point``), per direction.
INNER_GRID = 7

#: What ``occ_shape`` accepts, for messages.
SHAPE_KINDS = ("an OCP TopoDS_Shape, a build123d Shape (Part, Solid, Compound...), "
               "a cadquery Shape or a cadquery Workplane holding shapes")


def occ_shape(obj: Any) -> TopoDS_Shape:
    """The OCP shape of an OCP, build123d or cadquery object.

    Parameters
    ----------
    obj : TopoDS_Shape, build123d Shape, cadquery Shape or cadquery Workplane
        A cadquery ``Workplane`` gives the compound of the shapes on its stack (one
        shape: that shape).

    Returns
    -------
    TopoDS_Shape
        The same OpenCASCADE shape (not a copy).

    Raises
    ------
    InputError
        ``obj`` is none of these, or a Workplane with no shape on its stack.
    """
    if isinstance(obj, TopoDS_Shape):
        return obj
    wrapped = getattr(obj, "wrapped", None)
    if isinstance(wrapped, TopoDS_Shape):
        return wrapped
    values = getattr(obj, "vals", None)
    if callable(values):  # a cadquery Workplane
        shapes = [occ_shape(v) for v in values() if isinstance(
            getattr(v, "wrapped", None), TopoDS_Shape)]
        if len(shapes) == 1:
            return shapes[0]
        if shapes:
            return compound(shapes)
    raise InputError("not a shape", field="shape", value=type(obj).__name__,
                     accepted=SHAPE_KINDS)


def _surface(face: TopoDS_Face) -> Geom_Surface:
    return BRep_Tool.Surface_s(face)


class FaceRoles:
    """The role of every face of an impeller solid, found again after edits.

    Parameters
    ----------
    faces : sequence of TopoDS_Face
        The faces of the impeller solid.
    roles : sequence of str
        Their roles (``geometry.assembly.ROLES``), parallel to ``faces``.

    Notes
    -----
    A face is known by its underlying surface: OpenCASCADE's booleans and its
    same-domain unification keep the surface of every face they split, trim or merge.
    The surfaces are kept alive here, so their Python wrappers stay the same objects.
    A face whose surface was rebuilt (build123d's clean-up rebuilds a cylinder it cut)
    takes the role of the original face that a point inside it lies on (``ON_FACE``).
    Roles are found for faces in place: a moved or rotated copy of the impeller is a
    new shape (its faces have no role).
    """

    def __init__(self, faces: Sequence[TopoDS_Face], roles: Sequence[str]) -> None:
        if len(faces) != len(roles):
            raise ValueError("one role per face")
        self._faces = list(faces)
        self._roles = list(roles)
        self._surfaces = [_surface(face) for face in faces]
        self._role = {id(s): r for s, r in zip(self._surfaces, roles, strict=True)}
        self._boxes: list[Bnd_Box] | None = None

    def _on_face(self, face: TopoDS_Face) -> str | None:
        """Role of the original face that a point inside ``face`` lies on (a face whose
        surface an edit rebuilt, e.g. same-domain unification), else ``None``."""
        point = _inner_point(face)
        if point is None:
            return None
        if self._boxes is None:
            self._boxes = []
            for original in self._faces:
                box = Bnd_Box()
                BRepBndLib.Add_s(original, box)
                box.Enlarge(ON_FACE)
                self._boxes.append(box)
        vertex = BRepBuilderAPI_MakeVertex(point).Vertex()
        for original, role, box in zip(self._faces, self._roles, self._boxes, strict=True):
            if box.IsOut(point):
                continue
            dist = BRepExtrema_DistShapeShape(vertex, original)
            if dist.IsDone() and dist.Value() < ON_FACE:
                return role
        return None

    @classmethod
    def of(cls, impeller: Impeller) -> FaceRoles:
        """The face roles of a built impeller (builds its solid on first use).

        Parameters
        ----------
        impeller : Impeller

        Returns
        -------
        FaceRoles
        """
        part = impeller.built.part
        return cls(part.faces, part.roles)

    def role(self, face: Any) -> str | None:
        """Role of one face (OCP, build123d or cadquery), ``None`` for a new face.

        Parameters
        ----------
        face : TopoDS_Face, build123d Face or cadquery Face

        Returns
        -------
        str or None
        """
        occ = _face(occ_shape(face))
        role = self._role.get(id(_surface(occ)))
        return role if role is not None else self._on_face(occ)

    def roles(self, shape: Any) -> list[str | None]:
        """Role of every face of ``shape`` in exploration order.

        Parameters
        ----------
        shape : TopoDS_Shape, build123d Shape, cadquery Shape or Workplane

        Returns
        -------
        list of str or None
            One entry per face (``None``: a face the edit made).
        """
        return [self.role(face) for face in faces_of(occ_shape(shape))]

    def counts(self, shape: Any) -> dict[str | None, int]:
        """Number of faces per role of ``shape`` (key ``None``: new faces).

        Parameters
        ----------
        shape : TopoDS_Shape, build123d Shape, cadquery Shape or Workplane

        Returns
        -------
        dict
            Role -> face count, roles in ``ROLES`` order, ``None`` last.
        """
        found = Counter(self.roles(shape))
        order: list[str | None] = [*ROLES, None]
        return {role: found[role] for role in order if found[role]}

    def faces(self, shape: Any, role: str | None) -> list[TopoDS_Face]:
        """The OCP faces of ``shape`` with ``role`` (``None``: the new faces).

        Parameters
        ----------
        shape : TopoDS_Shape, build123d Shape, cadquery Shape or Workplane
        role : str or None
            One of ``geometry.assembly.ROLES``, or ``None``.

        Returns
        -------
        list of TopoDS_Face

        Raises
        ------
        InputError
            An unknown role.
        """
        if role is not None and role not in ROLES:
            raise InputError("unknown face role", field="role", value=role,
                             accepted=", ".join(ROLES))
        return [f for f in faces_of(occ_shape(shape)) if self.role(f) == role]

    def label(self, shape: Any) -> Any:
        """build123d faces of ``shape``, each labelled with its role.

        Parameters
        ----------
        shape : build123d Shape or anything ``occ_shape`` takes

        Returns
        -------
        build123d.ShapeList of build123d.Face
            Every face, ``Face.label`` its role ("" for a face the edit made).
        """
        import build123d as bd

        out = []
        for face in faces_of(occ_shape(shape)):
            wrapped = bd.Face(face)
            wrapped.label = self.role(face) or ""
            out.append(wrapped)
        return bd.ShapeList(out)

    def select(self, shape: Any, role: str) -> Any:
        """build123d faces of ``shape`` with ``role``, labelled.

        Parameters
        ----------
        shape : build123d Shape or anything ``occ_shape`` takes
        role : str
            One of ``geometry.assembly.ROLES``.

        Returns
        -------
        build123d.ShapeList of build123d.Face
        """
        import build123d as bd

        out = []
        for face in self.faces(shape, role):
            wrapped = bd.Face(face)
            wrapped.label = role
            out.append(wrapped)
        return bd.ShapeList(out)

    def tag(self, workplane: Any) -> Any:
        """A cadquery Workplane holding ``workplane``'s shape with one tag per role.

        Parameters
        ----------
        workplane : cadquery.Workplane or anything ``occ_shape`` takes

        Returns
        -------
        cadquery.Workplane
            The shape on its stack; ``.faces(tag=ROLE)`` selects the faces of a role
            (only the roles present are tagged).
        """
        import cadquery as cq

        shape = occ_shape(workplane)
        result = cq.Workplane("XY").newObject([cq.Shape.cast(shape)])
        for role in ROLES:
            faces = self.faces(shape, role)
            if faces:
                result = result.newObject([cq.Face(f) for f in faces]).tag(role)
        return result.newObject([cq.Shape.cast(shape)])


def _inner_point(face: TopoDS_Face) -> gp_Pnt | None:
    """A point inside ``face`` (not on its boundary): the first of a parameter grid
    over its UV bounds that the face classifier puts inside."""
    umin, umax, vmin, vmax = BRepTools.UVBounds_s(face)
    surface = _surface(face)
    steps = (np.arange(INNER_GRID) + 0.5) / INNER_GRID
    order = np.argsort(np.abs(steps - 0.5), kind="stable")  # from the middle out
    for i in order:
        for j in order:
            u = umin + steps[i] * (umax - umin)
            v = vmin + steps[j] * (vmax - vmin)
            classifier = BRepClass_FaceClassifier(face, gp_Pnt2d(u, v), 1e-9)
            if classifier.State() == TopAbs_IN:
                return surface.Value(u, v)
    return None


def _face(shape: TopoDS_Shape) -> TopoDS_Face:
    if shape.ShapeType() != TopAbs_FACE:
        raise InputError("not a face", field="face", value=str(shape.ShapeType()),
                         accepted="a face")
    return TopoDS.Face(shape)


def impeller_part(impeller: Impeller) -> Any:
    """The impeller solid as a build123d ``Part`` (labelled with the impeller's name).

    Parameters
    ----------
    impeller : Impeller

    Returns
    -------
    build123d.Part
        Wraps the impeller's OCP solid (mm); ``FaceRoles.of(impeller).label(part)``
        gives its faces labelled with their roles.
    """
    import build123d as bd

    solid = bd.Solid(impeller.solid, label=impeller.spec.name)
    return bd.Part([solid], label=impeller.spec.name)


def impeller_workplane(impeller: Impeller) -> Any:
    """The impeller solid as a cadquery ``Workplane`` with one tag per face role.

    Parameters
    ----------
    impeller : Impeller

    Returns
    -------
    cadquery.Workplane
        The solid (mm) on its stack; ``wp.faces(tag="pressure")`` selects the pressure
        faces, and likewise for every role of ``geometry.assembly.ROLES``.
    """
    return FaceRoles.of(impeller).tag(impeller.solid)


def solid_mesh(shape: Any, tolerance: float = DEFAULT_TOLERANCES.tessellation
               ) -> trimesh.Trimesh:
    """Closed triangle mesh of a solid made in any of the libraries (a blank, a hub).

    Parameters
    ----------
    shape : TopoDS_Shape, build123d Shape, cadquery Shape or Workplane
        One or more solids.
    tolerance : float
        Chordal tolerance of the tessellation, mm (> 0).

    Returns
    -------
    trimesh.Trimesh
        Watertight mesh, mm; ``cam.verify.Stock.from_mesh(mesh.vertices, mesh.faces,
        resolution)`` makes a verification stock of it.

    Raises
    ------
    InputError
        No solid in ``shape``, a tolerance <= 0, or a mesh that is not closed.
    """
    if not tolerance > 0:
        raise InputError("tessellation tolerance must be positive", field="tolerance",
                         value=tolerance, accepted="a length > 0 mm")
    occ = occ_shape(shape)
    if not solids_of(occ):
        raise InputError("the shape holds no solid", field="shape",
                         value=str(occ.ShapeType()), accepted="a solid or a compound of solids")
    faces = faces_of(occ)
    mesh, _ = tessellate(occ, faces, [""] * len(faces), tolerance,
                         DEFAULT_TOLERANCES.tessellation_angle)
    if not mesh.is_watertight:
        raise InputError("the solid's mesh is not closed", field="shape",
                         value=f"{len(mesh.faces)} triangles", accepted="a closed solid")
    return mesh
