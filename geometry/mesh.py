"""Tessellation of the B-rep impeller into trimesh meshes, per face role and whole.

``BRepMesh_IncrementalMesh`` meshes every face at the given linear / angular
deflection; edges shared by two faces get one discretisation, so after merging
coincident vertices the whole mesh is watertight. Each triangle remembers the role
of the face it came from.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import trimesh
from numpy.typing import NDArray
from OCP.BRep import BRep_Tool
from OCP.BRepMesh import BRepMesh_IncrementalMesh
from OCP.BRepTools import BRepTools
from OCP.IMeshTools import IMeshTools_Parameters
from OCP.TopAbs import TopAbs_REVERSED
from OCP.TopLoc import TopLoc_Location
from OCP.TopoDS import TopoDS_Face, TopoDS_Shape

from geometry.brep import compound
from impeller_cam.threads import default_threads

__all__ = ["collapse_short_edges", "tessellate", "triangulate_faces"]


def triangulate_faces(
    shape: TopoDS_Shape, faces: Sequence[TopoDS_Face], tolerance: float, angle: float,
    control_surface: bool = True, parallel: bool | None = None,
) -> list[tuple[NDArray[np.float64], NDArray[np.int64]]]:
    """Mesh ``shape`` and return ``(vertices (n,3) mm, triangles (m,3))`` per face.

    Triangles are wound so their normals point out of the solid. With
    ``control_surface=False`` the mesher does not refine face interiors to the
    surface deflection (used only for faces it cannot mesh cleanly otherwise).
    ``parallel``: the faces are meshed on OCCT's thread pool (the edges are
    discretised once, before the faces), the same triangles as one thread
    (tests/geometry/test_mesh_parallel.py); on nine_blade at 0.02 mm 3.4 s -> 1.9 s of
    wall time on 2 cores. Default: when ``impeller_cam.threads.default_threads()`` (the
    CPUs, or ``IMPELLER_CAM_THREADS``) is more than one.
    """
    BRepTools.Clean_s(shape)
    params = IMeshTools_Parameters()
    params.ControlSurfaceDeflection = control_surface
    params.Deflection = float(tolerance)
    params.Angle = float(angle)
    params.Relative = False
    params.InParallel = default_threads() > 1 if parallel is None else bool(parallel)
    BRepMesh_IncrementalMesh(shape, params)
    out = []
    for face in faces:
        location = TopLoc_Location()
        poly = BRep_Tool.Triangulation_s(face, location)
        if poly is None:
            raise RuntimeError("a face could not be triangulated")
        if location.IsIdentity():  # Transformed by the identity is the point itself
            nodes = np.array([poly.Node(i).Coord() for i in range(1, poly.NbNodes() + 1)])
        else:
            transform = location.Transformation()
            nodes = np.array([poly.Node(i).Transformed(transform).Coord()
                              for i in range(1, poly.NbNodes() + 1)])
        tris = np.array(
            [poly.Triangle(i).Get() for i in range(1, poly.NbTriangles() + 1)], dtype=np.int64
        ) - 1
        if face.Orientation() == TopAbs_REVERSED:
            tris = tris[:, ::-1]
        out.append((nodes, tris))
    return out


def tessellate(
    shape: TopoDS_Shape,
    faces: Sequence[TopoDS_Face],
    roles: Sequence[str],
    tolerance: float,
    angle: float,
) -> tuple[trimesh.Trimesh, NDArray[np.str_]]:
    """Whole watertight mesh and the role of each of its triangles.

    Returns
    -------
    mesh : trimesh.Trimesh
        Vertices merged along shared edges.
    face_roles : (len(mesh.faces),) str
    """
    parts = triangulate_faces(shape, faces, tolerance, angle)
    weld = max(1e-5, 4e-7 * max(float(np.abs(v).max()) for v, _ in parts))
    messy = [i for i, (v, t) in enumerate(parts) if _shortest_edge(v, t) < weld]
    if messy:
        # only those faces meshed again (their compound): the same triangles as
        # meshing the whole shape again (checked on every fixture), a fraction of it
        sub = [faces[i] for i in messy]
        plain = triangulate_faces(compound(sub), sub, tolerance, angle, control_surface=False)
        for i, part in zip(messy, plain, strict=True):
            parts[i] = part
    vertices, triangles, labels = [], [], []
    offset = 0
    for (nodes, tris), role in zip(parts, roles, strict=True):
        vertices.append(nodes)
        triangles.append(tris + offset)
        labels.extend([role] * len(tris))
        offset += len(nodes)
    mesh = trimesh.Trimesh(np.vstack(vertices), np.vstack(triangles), process=False)
    mesh.merge_vertices(digits_vertex=6)
    keep = mesh.nondegenerate_faces(height=1e-12)
    label_array = np.array(labels)[keep]
    mesh.update_faces(keep)
    vertices_out = np.asarray(mesh.vertices)
    faces_out, alive = collapse_short_edges(vertices_out, np.asarray(mesh.faces), weld)
    if _manifold(faces_out) or not _manifold(np.asarray(mesh.faces)):
        mesh = trimesh.Trimesh(vertices_out, faces_out, process=False)
        label_array = label_array[alive]
    mesh.remove_unreferenced_vertices()
    return mesh, label_array


def _shortest_edge(vertices: NDArray[np.float64], triangles: NDArray[np.int64]) -> float:
    if len(triangles) == 0:
        return float("inf")
    e = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])
    return float(np.linalg.norm(vertices[e[:, 0]] - vertices[e[:, 1]], axis=1).min())


def _manifold(faces: NDArray[np.int64]) -> bool:
    """Every edge is used by exactly two triangles, once in each direction."""
    directed = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    if not len(directed):
        return True
    # an edge (a, b) as the one integer a * base + b: unique rows, 1-D and faster
    base = np.int64(directed.max()) + 1
    low, high = directed.min(axis=1), directed.max(axis=1)
    _, counts = np.unique(low * base + high, return_counts=True)
    _, once = np.unique(directed[:, 0] * base + directed[:, 1], return_counts=True)
    return bool(np.all(counts == 2) and np.all(once == 1))


def collapse_short_edges(vertices: NDArray[np.float64], faces: NDArray[np.int64],
                         length: float) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
    """Collapse interior edges shorter than ``length`` mm, keeping the mesh manifold.

    The mesher leaves micrometre edges on strongly curved small faces; a binary STL
    stores single-precision coordinates, in which the two ends of such an edge can
    become one point and the file non-manifold. Each short edge (shortest first)
    is collapsed onto its first vertex when the link condition holds (the two
    vertices share exactly the two opposite vertices of the edge's triangles);
    the edge's two triangles disappear. Vertices stay where they are (on the B-rep).

    Parameters
    ----------
    vertices : (n, 3) float64
    faces : (m, 3) int64
    length : float
        Edges shorter than this are collapsed, mm.

    Returns
    -------
    faces : (m', 3) int64
        Remaining triangles.
    alive : (m,) bool
        Which input triangles remain.
    """
    faces = np.array(faces, dtype=np.int64)
    edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    lengths = np.linalg.norm(vertices[edges[:, 0]] - vertices[edges[:, 1]], axis=1)
    short = np.flatnonzero(lengths < length)
    alive = np.ones(len(faces), dtype=bool)
    if len(short) == 0:
        return faces, alive
    short = short[np.argsort(lengths[short], kind="stable")]
    touched = np.unique(faces[short % len(faces)])
    star: dict[int, set[int]] = {int(v): set() for v in touched}
    involved = np.flatnonzero(np.isin(faces, touched).any(axis=1))
    # grow the stars to every vertex that a collapse can reach
    for face in involved:
        for v in faces[face]:
            star.setdefault(int(v), set()).add(int(face))
    for v in list(star):
        if v not in touched:
            star[v] = set()
    for face in np.flatnonzero(np.isin(faces, np.fromiter(star, dtype=np.int64)).any(axis=1)):
        for v in faces[face]:
            if int(v) in star:
                star[int(v)].add(int(face))

    def neighbours(v: int) -> set[int]:
        return {int(w) for f in star[v] for w in faces[f]} - {v}

    for e in short:
        a, b = (int(x) for x in edges[e])
        f0 = int(e % len(faces))
        if not alive[f0] or a not in faces[f0] or b not in faces[f0] or a == b:
            continue
        shared = star[a] & star[b]
        if len(shared) != 2:
            continue
        opposite = {int(w) for f in shared for w in faces[f]} - {a, b}
        if neighbours(a) & neighbours(b) != opposite or len(opposite) != 2:
            continue
        for g in shared:
            alive[g] = False
            for w in faces[g]:
                star.get(int(w), set()).discard(g)
        for g in star[b]:
            faces[g][faces[g] == b] = a
            for w in faces[g]:
                if int(w) not in star:
                    star[int(w)] = {int(h) for h in np.flatnonzero((faces == w).any(axis=1))
                                    if alive[h]}
        star[a] |= star[b]
        star[b] = set()
    return faces[alive], alive
