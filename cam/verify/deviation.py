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

A stock that continues an earlier run's (the chain's finish run on the rough run's
stock) keeps every end the earlier run left and no later move touched, with the same
point and move id: ``sample_deviation`` with the earlier ``Deviation`` takes those
ends' distances and faces from it (``matched_samples``: an exact match of the point,
so the answer is the one the query would give) and queries only the others.

A deviation can be kept with its stock (``save_deviation`` / ``load_deviation``,
``.npz``): the chain's finish stage verifies the rough programs and measures their
stock; the verify stage reads that measurement back instead of repeating the query
(20 million samples on nine_blade). The file holds the signed distances and closest
faces with digests of the samples and of the ``DesignDistance`` (``fingerprint``);
it is used only when both match, so the answers are those the query would give.

Limitation: a cut that removes a whole dexel interval inside the design (cutting
through a thin wall) leaves no end to sample on that ray; the neighbouring rays and
the other two grids still see the walls of the cut.
"""

from __future__ import annotations

import hashlib
import io
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from cam.verify.inside import MeshParity
from impeller_cam.atomic import write_bytes_atomic
from impeller_cam.threads import default_threads

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
        self._fingerprint: str | None = None

    @property
    def fingerprint(self) -> str:
        """Hex digest of everything the answers depend on (the subdivided triangles,
        their input faces, the parity mesh, the candidate count and the tie and
        confirmation constants): equal fingerprints answer every query alike."""
        if self._fingerprint is None:
            digest = hashlib.blake2b(digest_size=20)
            for array in (self.triangles, self.source_face, self.parity.triangles,
                          np.array([self.candidates, EXACT_BELOW, TIE, CHUNK], np.float64)):
                digest.update(np.ascontiguousarray(array).tobytes())
            self._fingerprint = digest.hexdigest()
        return self._fingerprint

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

        # the query is split over the points: the same answers with any thread count
        far, idx = self.tree.query(p, k=k, workers=default_threads())
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


@njit(cache=True)
def _match(old_points, old_moves, points, moves, earlier):  # type: ignore[no-untyped-def]
    """Index into ``old_points`` of each sample in ``points`` made before ``earlier``
    (move id < ``earlier``) whose point and move id are found there, in order; -1
    elsewhere (a greedy subsequence match: the unchanged ends keep their order; after
    a sample that is not found, which is not expected, the rest are left to the
    query, so the scan stays linear)."""
    n = points.shape[0]
    m = old_points.shape[0]
    out = np.full(n, -1, np.int64)
    j = 0
    for i in range(n):
        if moves[i] >= earlier:
            continue
        x = points[i, 0]
        y = points[i, 1]
        z = points[i, 2]
        k = j
        while k < m and not (old_points[k, 0] == x and old_points[k, 1] == y
                             and old_points[k, 2] == z and old_moves[k] == moves[i]):
            k += 1
        if k == m:  # not there (not expected): the rest are queried
            break
        out[i] = k
        j = k + 1
    return out


def matched_samples(previous: Deviation, points: NDArray[np.float64],
                    moves: NDArray[np.int32], earlier: int) -> NDArray[np.int64]:
    """Samples of a later stock state that an earlier ``Deviation`` already measured.

    Parameters
    ----------
    previous : Deviation
        The deviation of an earlier state of the same stock (same grids), samples in
        ``Stock.surface_samples`` order.
    points : (n, 3) float64
        The later state's samples, mm, in the same order.
    moves : (n,) int32
        Move id of each (ids below ``earlier`` were made before the later run).
    earlier : int
        Number of moves (owners) of the stock when ``previous`` was measured.

    Returns
    -------
    (n,) int64
        Index into ``previous`` of the sample with the identical point and move id;
        -1 where there is none (a new end: to be queried).
    """
    return np.asarray(_match(
        np.ascontiguousarray(previous.points, np.float64),
        np.ascontiguousarray(previous.moves, np.int64),
        np.ascontiguousarray(points, np.float64), np.ascontiguousarray(moves, np.int64),
        int(earlier)))


def sample_deviation(points: NDArray[np.float64], moves: NDArray[np.int32],
                    distance: DesignDistance, previous: Deviation | None = None,
                    earlier: int = 0) -> Deviation:
    """Signed design distance and closest face of stock surface samples.

    Parameters
    ----------
    points : (n, 3) float64
        ``Stock.surface_samples`` points, mm.
    moves : (n,) int32
        Their move ids.
    distance : DesignDistance
    previous : Deviation, optional
        The deviation of an earlier state of this stock, with faces: the samples it
        holds unchanged (``matched_samples``) are taken from it, not queried.
    earlier : int
        Owners of the stock when ``previous`` was measured.

    Returns
    -------
    Deviation
        The same as ``Deviation(points, *distance.closest(points)...)``.
    """
    if previous is None or previous.faces is None or not len(points):
        signed, face = distance.closest(points)
        return Deviation(points, signed, moves, face)
    found = matched_samples(previous, points, moves, earlier)
    hit = found >= 0
    signed = np.empty(len(points))
    face = np.empty(len(points), np.int64)
    signed[hit] = previous.distance[found[hit]]
    face[hit] = previous.faces[found[hit]]
    todo = np.flatnonzero(~hit)
    if len(todo):
        signed[todo], face[todo] = distance.closest(points[todo])
    return Deviation(points, signed, moves, face)


#: Format tag of a saved deviation (``save_deviation``).
DEVIATION_FORMAT = "impeller-cam deviation 1"


def _samples_digest(points: NDArray[np.float64], moves: NDArray[np.int32]) -> str:
    """Hex digest of stock surface samples (points and move ids, as float64/int64)."""
    digest = hashlib.blake2b(digest_size=20)
    digest.update(np.ascontiguousarray(points, np.float64).tobytes())
    digest.update(np.ascontiguousarray(moves, np.int64).tobytes())
    return digest.hexdigest()


def save_deviation(path: str | Path, deviation: Deviation, distance: DesignDistance) -> Path:
    """Write a deviation's distances and faces (``.npz``, atomically) for
    ``load_deviation``.

    Parameters
    ----------
    path : str or Path
        The ``.npz`` file.
    deviation : Deviation
        With faces (``sample_deviation``); its points and moves are stored as a digest.
    distance : DesignDistance
        The design distance that measured it (stored as its ``fingerprint``).

    Returns
    -------
    Path
        ``path``.
    """
    if deviation.faces is None:
        raise ValueError("a deviation without faces cannot be saved")
    buffer = io.BytesIO()
    np.savez(buffer, format=np.array(DEVIATION_FORMAT),
             design=np.array(distance.fingerprint),
             samples=np.array(_samples_digest(deviation.points, deviation.moves)),
             distance=np.asarray(deviation.distance, np.float64),
             faces=np.asarray(deviation.faces, np.int64).astype(np.int32))
    return write_bytes_atomic(path, buffer.getvalue())


def load_deviation(path: str | Path, points: NDArray[np.float64], moves: NDArray[np.int32],
                   distance: DesignDistance) -> Deviation | None:
    """The deviation ``save_deviation`` wrote for these samples and this design distance.

    Parameters
    ----------
    path : str or Path
        The ``.npz`` file.
    points : (n, 3) float64
        The stock's surface samples (``Stock.surface_samples``), mm.
    moves : (n,) int32
        Their move ids.
    distance : DesignDistance
        The design distance the caller would query.

    Returns
    -------
    Deviation or None
        ``Deviation(points, *distance.closest(points))`` as it was saved; ``None`` when
        the file is missing or unreadable, or was made for other samples or another
        design (then the caller queries).
    """
    try:
        with np.load(Path(path), allow_pickle=False) as data:
            if (str(data["format"]) != DEVIATION_FORMAT
                    or str(data["design"]) != distance.fingerprint
                    or len(data["distance"]) != len(points)
                    or str(data["samples"]) != _samples_digest(points, moves)):
                return None
            signed = np.asarray(data["distance"], np.float64)
            faces = np.asarray(data["faces"], np.int64)
    except (OSError, ValueError, KeyError):
        return None
    return Deviation(points, signed, moves, faces)
