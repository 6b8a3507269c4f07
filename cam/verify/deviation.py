"""Deviation of the machined stock from the design model; gouge and excess events.

Signed distance
---------------
``DesignDistance`` answers the signed distance of points from a closed design mesh:
positive outside the design (material left over), negative inside (material removed
from the part: a gouge). The mesh is subdivided so no edge is longer than
``max_edge``; a KD-tree over triangle centroids gives ``candidates`` triangles per
point, whose exact closest points (``geometry.mesh_query``, compiled) give the
distance; the sign is that of ``(p - q) . n`` for the closest triangle (among equally
close ones, within ``TIE`` mm, the one whose normal is best aligned with ``p - q``);
inside answers deeper than ``EXACT_BELOW`` are confirmed by the mesh's ray parity
(``cam.verify.inside``: nine_blade's folded trailing-edge fillet made 9 false gouges
of 1.7-2.2 mm at the ends of the suction-side junction paths).
Where the closest point is a vertex or an edge, every triangle there is equally
close, but ``closest_point`` answers them with rounding errors of about 1e-9 mm
(tiny triangles of a tessellated rounded edge): with an exact tie only a fan of tiny
faces nearly parallel to ``p - q`` could be left to give the sign, and a point 5-9 mm
outside a blade's outlet corner came out inside (nine_blade: false gouges of
4.9-9.1 mm). Sliver triangles
(height below 1e-6 of their longest edge: no area, numerically arbitrary normal) are
left out.

Stock surface samples are the dexel interval ends of all three grids (exact points
of the machined surface along each ray). Each end carries the index of the move that
made it, so a gouge is reported at the NC line of the block that cut it.

Limitation: a cut that removes a whole dexel interval inside the design (cutting
through a thin wall) leaves no end to sample on that ray; the neighbouring rays and
the other two grids still see the walls of the cut.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from cam.verify.inside import MeshParity

#: Points per chunk of the distance query (bounds memory).
CHUNK = 100_000
#: Inside answers deeper than this are made exact (``DesignDistance.__call__``), mm;
#: shallower ones lie on the surface either way (far below any gouge tolerance).
EXACT_BELOW = 0.005
#: Triangles whose closest point is this much farther than the closest one's still
#: count as equally close for the sign (rounding of ``closest_point``), mm.
TIE = 1e-6


class DesignDistance:
    """Signed distance from a closed triangle mesh (mm).

    Parameters
    ----------
    vertices : (v, 3) float64
    faces : (f, 3) int64
        A closed, outward-oriented mesh of the designed part.
    max_edge : float
        Longest triangle edge after subdivision, mm.
    candidates : int
        Triangles examined per query point.
    """

    def __init__(
        self,
        vertices: NDArray[np.float64],
        faces: NDArray[np.int64],
        max_edge: float = 2.0,
        candidates: int = 8,
    ) -> None:
        import trimesh

        v, f, source = trimesh.remesh.subdivide_to_size(  # type: ignore[no-untyped-call]
            np.asarray(vertices, np.float64), np.asarray(faces, np.int64), max_edge=max_edge,
            return_index=True,
        )
        self.triangles = np.asarray(v, np.float64)[np.asarray(f, np.int64)]
        normals = np.cross(
            self.triangles[:, 1] - self.triangles[:, 0], self.triangles[:, 2] - self.triangles[:, 0]
        )
        length = np.linalg.norm(normals, axis=1)
        edges = np.stack([self.triangles[:, (i + 1) % 3] - self.triangles[:, i] for i in range(3)])
        longest = np.max(np.linalg.norm(edges, axis=2), axis=0)
        # slivers (height below 1e-6 of the longest edge) have numerically arbitrary
        # normals and no area: they would only corrupt the sign
        keep = length > 2e-6 * longest**2
        self.triangles = np.ascontiguousarray(self.triangles[keep])
        self.normals = np.ascontiguousarray(normals[keep] / length[keep, None])
        #: index of the input face each (subdivided) triangle lies in
        self.source_face = np.asarray(source, np.int64)[keep]
        #: ray-parity confirmation of inside answers (a folded surface's nearest
        #: sheet can face inwards), on the mesh as given
        self.parity = MeshParity(np.asarray(vertices, np.float64)[np.asarray(faces, np.int64)])
        centroids = self.triangles.mean(axis=1)
        self.tree = cKDTree(centroids)
        self.candidates = int(min(candidates, len(self.triangles)))
        #: farthest vertex from its triangle's centroid: a triangle whose centroid lies
        #: farther than ``d + reach`` from a point cannot be closer than ``d`` to it
        self.reach = float(np.linalg.norm(self.triangles - centroids[:, None], axis=2).max())

    def __call__(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        """Signed distances (n,) of points (n, 3), mm: + outside, - inside the design
        (``closest``)."""
        return self.closest(points)[0]

    def closest(self, points: NDArray[np.float64]
                ) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
        """Signed distances (n,) of points (n, 3), mm, and the input face (n,) whose
        triangle is closest (the one that gave the sign): + outside, - inside.

        Inside answers deeper than ``EXACT_BELOW`` (the gouge candidates) are made
        exact: the candidate set grows
        until the ``k``-th nearest centroid lies beyond ``|d| + reach``, so the closest
        triangle cannot be missed (a missed one can flip the sign, e.g. beyond the cut
        edge of a thin blade). Then their sign is confirmed by ray parity
        (``MeshParity``, majority of three axis rays): where the surface folds over
        itself the nearest sheet faces inwards, and a point in the air reads inside.

        Parameters
        ----------
        points : (n, 3) float64
            Query points, mm.

        Returns
        -------
        distance : (n,) float64
            Signed distance, mm (+ outside the design).
        face : (n,) int64
            Index of the closest input face.
        """
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        out = np.empty(len(points))
        face = np.empty(len(points), np.int64)
        for s in range(0, len(points), CHUNK):
            p = points[s : s + CHUNK]
            d, far, tri = self._signed(p, self.candidates)
            k = self.candidates
            todo = np.flatnonzero((d < -EXACT_BELOW) & (far <= np.abs(d) + self.reach))
            while len(todo) and k < len(self.triangles):
                k = min(4 * k, len(self.triangles))
                d_k, far_k, tri_k = self._signed(p[todo], k)
                d[todo] = d_k
                tri[todo] = tri_k
                todo = todo[(d_k < -EXACT_BELOW) & (far_k <= np.abs(d_k) + self.reach)]
            deep = np.flatnonzero(d < -EXACT_BELOW)
            if len(deep):
                outside = deep[~self.parity.inside(p[deep])]
                d[outside] = -d[outside]
            out[s : s + CHUNK] = d
            face[s : s + CHUNK] = self.source_face[tri]
        return out, face

    def _signed(
        self, p: NDArray[np.float64], k: int
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]]:
        """Signed distance over ``k`` candidates, the ``k``-th centroid distance and the
        picked triangle (``geometry.mesh_query.closest_of_candidates``)."""
        from geometry.mesh_query import closest_of_candidates

        far, idx = self.tree.query(p, k=k)
        far = np.asarray(far).reshape(len(p), k)[:, -1]
        idx = np.ascontiguousarray(np.asarray(idx, np.int64).reshape(len(p), k))
        signed, tri = closest_of_candidates(np.ascontiguousarray(p), idx, self.triangles,
                                            self.normals, TIE)
        return np.asarray(signed), far, np.asarray(tri)


@dataclass
class Deviation:
    """Signed deviation of the stock surface samples from the design.

    Attributes
    ----------
    points : (n, 3) float64
        Stock surface samples (dexel ends), mm.
    distance : (n,) float64
        Signed distance from the design, mm (+ material left, - gouged).
    moves : (n,) int32
        Global move index that made each sample (-1: initial stock).
    faces : (n,) int64, optional
        Index of the design mesh face closest to each sample (``DesignDistance.closest``).
    """

    points: NDArray[np.float64]
    distance: NDArray[np.float64]
    moves: NDArray[np.int32]
    faces: NDArray[np.int64] | None = None

    def summary(self) -> dict[str, Any]:
        """Min, max, mean absolute deviation (mm) and sample count for verify.json.

        Returns
        -------
        dict
        """
        if len(self.distance) == 0:
            return {"samples": 0}
        return {
            "samples": int(len(self.distance)),
            "min_mm": round(float(self.distance.min()), 5),
            "max_mm": round(float(self.distance.max()), 5),
            "mean_abs_mm": round(float(np.abs(self.distance).mean()), 5),
        }


def grouped_extremes(
    mask: NDArray[np.bool_], key: NDArray[np.int64], value: NDArray[np.float64]
) -> list[tuple[int, int, float]]:
    """For samples in ``mask``, group by ``key`` and return (key, sample index, value)
    of the largest ``value`` in each group, sorted by key."""
    where = np.flatnonzero(mask)
    if len(where) == 0:
        return []
    keys = key[where]
    order = np.lexsort((-value[where], keys))
    keys_sorted = keys[order]
    firsts = np.flatnonzero(np.r_[True, keys_sorted[1:] != keys_sorted[:-1]])
    picked = where[order[firsts]]
    return [(int(key[i]), int(i), float(value[i])) for i in picked]
