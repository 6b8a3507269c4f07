"""The compiled closest-point kernel against trimesh and closed forms."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from geometry.mesh_query import (
    closest_of_candidates,
    closest_point_on_triangle,
    polyline_projection,
)

coords = arrays(np.float64, (4, 3), elements=st.floats(-50.0, 50.0, allow_nan=False,
                                                       allow_infinity=False))


@settings(max_examples=300, deadline=None, derandomize=True)
@given(coords)
def test_agrees_with_trimesh_on_proper_triangles(data: np.ndarray) -> None:
    triangle, point = data[:3], data[3]
    normal = np.cross(triangle[1] - triangle[0], triangle[2] - triangle[0])
    edges = np.linalg.norm(triangle - np.roll(triangle, 1, axis=0), axis=1)
    if np.linalg.norm(normal) < 1e-3 * edges.max() ** 2:  # slivers: trimesh's own answer
        return                                            # is not exact there (below)
    ours = closest_point_on_triangle(point[None], triangle[None])[0]
    ref = trimesh.triangles.closest_point(triangle[None], point[None])[0]
    assert np.linalg.norm(ours - point) == pytest.approx(np.linalg.norm(ref - point),
                                                         abs=1e-9)


def test_degenerate_triangles_are_their_segments() -> None:
    """A triangle with two equal vertices is a segment: the closest point on it."""
    rng = np.random.default_rng(7)
    a, b = rng.normal(size=(200, 3)), rng.normal(size=(200, 3))
    p = 3.0 * rng.normal(size=(200, 3))
    triangles = np.stack([a, b, a], axis=1)
    ab = b - a
    t = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.einsum("ij,ij->i", ab, ab), 0.0, 1.0)
    expected = np.linalg.norm(p - (a + t[:, None] * ab), axis=1)
    got = np.linalg.norm(p - closest_point_on_triangle(p, triangles), axis=1)
    np.testing.assert_allclose(got, expected, atol=1e-12)


def test_face_region_closed_form() -> None:
    """Above the interior of a triangle in z = 0 the foot is the point's projection."""
    triangle = np.array([[[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [0.0, 10.0, 0.0]]])
    point = np.array([[2.0, 3.0, -4.5]])
    np.testing.assert_allclose(closest_point_on_triangle(point, triangle), [[2.0, 3.0, 0.0]])


def test_closest_of_candidates_sign_and_pick() -> None:
    """The nearer of two parallel unit squares' triangles, signed by its normal; at an
    equally close shared edge the triangle whose normal points at the point decides."""
    rng = np.random.default_rng(3)
    tris = rng.normal(size=(40, 3, 3))
    normals = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    points = 2.0 * rng.normal(size=(100, 3))
    cand = np.tile(np.arange(40), (100, 1))
    signed, pick = closest_of_candidates(points, cand, tris, normals, 0.0)
    feet = trimesh.triangles.closest_point(np.repeat(tris[None], 100, 0).reshape(-1, 3, 3),
                                           np.repeat(points, 40, axis=0))
    dist = np.linalg.norm(np.repeat(points, 40, axis=0) - feet, axis=1).reshape(100, 40)
    np.testing.assert_allclose(np.abs(signed), dist.min(axis=1), atol=1e-9)
    foot = closest_point_on_triangle(points, tris[pick])
    side = np.einsum("ij,ij->i", points - foot, normals[pick])
    assert np.all(np.sign(side[np.abs(side) > 1e-9]) == np.sign(signed[np.abs(side) > 1e-9]))
    # a shared edge: two triangles of a roof, the point above the ridge, nearer the
    # right-hand slope's outside
    roof = np.array([[[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, -1.0, 0.0]],
                     [[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 0.0]]])
    n = np.cross(roof[:, 1] - roof[:, 0], roof[:, 2] - roof[:, 0])
    n /= np.linalg.norm(n, axis=1)[:, None]
    n[n[:, 2] < 0] *= -1.0  # both slopes face up (outward)
    d, which = closest_of_candidates(np.array([[0.5, 0.01, 3.0]]), np.array([[0, 1]]), roof,
                                     n, 1e-6)
    assert d[0] > 0 and which[0] == 1


def _polyline_reference(points: np.ndarray, line: np.ndarray
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Brute force: every segment's clamped projection, the first least distance."""
    a, ab = line[:-1], line[1:] - line[:-1]
    length = np.linalg.norm(ab, axis=1)
    start = np.concatenate([[0.0], np.cumsum(length)])[:-1]
    t = np.clip(np.einsum("nkc,kc->nk", points[:, None] - a[None], ab) / length**2, 0.0, 1.0)
    rel = points[:, None] - (a[None] + t[..., None] * ab[None])
    dist = np.linalg.norm(rel, axis=2)
    best = np.argmin(dist, axis=1)
    rows = np.arange(len(points))
    cross = ab[best, 0] * rel[rows, best, 1] - ab[best, 1] * rel[rows, best, 0]
    # where two segments are equally close (a vertex's region) rounding picks one
    ties = np.sum(dist <= dist[rows, best][:, None] + 1e-9, axis=1) > 1
    return start[best] + t[rows, best] * length[best], dist[rows, best], \
        np.where(ties, np.nan, cross)


def test_polyline_projection_agrees_with_the_brute_force() -> None:
    rng = np.random.default_rng(11)
    line = np.cumsum(rng.normal(size=(30, 2)), axis=0)
    points = 4.0 * rng.normal(size=(5000, 2)) + line.mean(axis=0)
    position, distance, cross = polyline_projection(points, line)
    ref_position, ref_distance, ref_cross = _polyline_reference(points, line)
    assert distance == pytest.approx(ref_distance, abs=1e-12)
    assert position == pytest.approx(ref_position, abs=1e-9)
    unique = ~np.isnan(ref_cross)
    assert unique.sum() > 1000
    assert cross[unique] == pytest.approx(ref_cross[unique], abs=1e-9)


def test_polyline_projection_closed_form() -> None:
    # an L: (0, 0) -> (10, 0) -> (10, 5)
    line = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 5.0]])
    points = np.array([[3.0, 2.0], [3.0, -1.0], [12.0, 4.0], [-3.0, 4.0], [13.0, 9.0]])
    position, distance, cross = polyline_projection(points, line)
    assert position == pytest.approx([3.0, 3.0, 14.0, 0.0, 15.0])
    assert distance == pytest.approx([2.0, 1.0, 2.0, 5.0, 5.0])
    # left of the first segment (+), right of it (-), right of the second (-)
    assert np.sign(cross[:3]).tolist() == [1.0, -1.0, -1.0]


def _polyline_scan(points: np.ndarray, line: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The scan over every segment, in the kernel's operations and order (the first
    segment of least distance): what the pruned kernel must give bit for bit."""
    k = len(line) - 1
    ex, ey = line[1:, 0] - line[:-1, 0], line[1:, 1] - line[:-1, 1]
    length2 = ex * ex + ey * ey
    start, run = [], 0.0
    for s in range(k):
        start.append(run)
        run += math.sqrt(length2[s])
    out = np.empty((3, len(points)))
    for i, (px, py) in enumerate(points):
        best, best_s, best_t, best_rx, best_ry = math.inf, 0, 0.0, 0.0, 0.0
        for s in range(k):
            wx, wy = px - line[s, 0], py - line[s, 1]
            t = min(max((wx * ex[s] + wy * ey[s]) / length2[s], 0.0), 1.0)
            rx, ry = wx - t * ex[s], wy - t * ey[s]
            d = math.sqrt(rx * rx + ry * ry)
            if d < best:
                best, best_s, best_t, best_rx, best_ry = d, s, t, rx, ry
        out[:, i] = (start[best_s] + best_t * math.sqrt(length2[best_s]), best,
                     ex[best_s] * best_ry - ey[best_s] * best_rx)
    return out[0], out[1], out[2]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_polyline_projection_is_the_full_scan_bit_for_bit(seed: int) -> None:
    """Runs of segments skipped by their bounding box change no answer: a random walk
    and a zigzag whose vertices and mirror points make exact ties between segments."""
    rng = np.random.default_rng(seed)
    walk = np.cumsum(rng.normal(size=(1 + int(rng.integers(1, 90)), 2)), axis=0)
    zigzag = np.column_stack([np.arange(41.0), np.where(np.arange(41) % 2, 1.0, -1.0)])
    for line in (walk, zigzag):
        lo, hi = line.min(axis=0) - 3.0, line.max(axis=0) + 3.0
        points = np.vstack([lo + (hi - lo) * rng.random((3000, 2)), line,
                            np.column_stack([line[:, 0], -line[:, 1]]),
                            np.round(lo + (hi - lo) * rng.random((500, 2)))])
        got = polyline_projection(points, line)
        for a, b in zip(got, _polyline_scan(points, line), strict=True):
            assert np.array_equal(a, b)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_possibly_within_flags_every_point_within_the_bound(seed: int) -> None:
    """A point within the bound of a centre is always flagged (points placed at
    exactly the bound on an axis and on a diagonal too); the bounded nearest search
    over the flagged points alone gives the answers of the search over all of them."""
    from scipy.spatial import cKDTree

    from geometry.mesh_query import possibly_within

    rng = np.random.default_rng(seed)
    centres = rng.normal(size=(200, 3)) * [20.0, 20.0, 5.0]
    bound = float(rng.uniform(0.5, 4.0))
    offsets = np.vstack([rng.normal(size=(3000, 3)) * bound,
                         np.eye(3) * bound, -np.eye(3) * bound,
                         np.ones((1, 3)) * bound / math.sqrt(3.0)])
    points = np.vstack([centres[rng.integers(0, 200, len(offsets))] + offsets,
                        rng.uniform(-80.0, 80.0, size=(5000, 3))])
    flagged = possibly_within(centres, points, bound)
    nearest, _ = cKDTree(centres).query(points, k=1)
    assert flagged[nearest <= bound].all()
    assert (~flagged).sum() > 1000
    tree = cKDTree(centres)
    every, _ = tree.query(points, k=1, distance_upper_bound=bound)
    some, _ = tree.query(points[flagged], k=1, distance_upper_bound=bound)
    assert np.array_equal(every[flagged], some) and np.isinf(every[~flagged]).all()
