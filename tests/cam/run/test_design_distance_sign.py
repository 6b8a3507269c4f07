"""DesignDistance: points beyond the edge of a thin plate are outside, not gouges.

Found on the chain's own programs: beyond the cut trailing edge of a thin blade the
8 nearest triangle centroids can all lie on the blade's far side, whose closest point
is on the edge and whose normal points away, so the sign came out "inside" and a
false 2.9 mm gouge was reported. Closed form: outside a box ``|x| <= a, |z| <= c``
(``|y|`` inside its range) the distance is ``hypot(x - a, max(|z| - c, 0))``.
"""

from __future__ import annotations

import numpy as np
import trimesh

from cam.verify.deviation import DesignDistance


def test_points_beyond_a_thin_edge_are_outside_at_the_closed_form_distance() -> None:
    a, c = 30.0, 0.4
    plate = trimesh.creation.box(extents=(2 * a, 60.0, 2 * c))
    distance = DesignDistance(plate.vertices, plate.faces, max_edge=4.0)
    rng = np.random.default_rng(1)
    n = 20_000
    points = np.column_stack([rng.uniform(a, a + 4.0, n), rng.uniform(-29.0, 29.0, n),
                              rng.uniform(-3.0, 3.0, n)])
    expected = np.hypot(points[:, 0] - a, np.maximum(np.abs(points[:, 2]) - c, 0.0))
    # the case the 8-candidate answer got wrong (inside, -0.157 mm)
    points = np.vstack([points, [[30.15669044, 0.11075373, -0.3998917]]])
    expected = np.append(expected, 0.15669044)
    found = distance(points)
    assert np.all(found > 0.0), points[found <= 0.0]
    # outside answers use 8 candidates: close, not exact (the verification's gouge
    # tolerance is 0.05 mm); the point that was wrong is now exact
    np.testing.assert_allclose(found, expected, atol=0.05)
    np.testing.assert_allclose(found[-1], expected[-1], atol=1e-6)


def test_inside_points_stay_negative() -> None:
    plate = trimesh.creation.box(extents=(40.0, 40.0, 4.0))
    points = np.array([[0.0, 0.0, 1.0], [19.0, 0.0, 0.0], [5.0, -18.5, -1.5]])
    distance = DesignDistance(plate.vertices, plate.faces, max_edge=0.5)(points)
    np.testing.assert_allclose(distance, [-1.0, -1.0, -0.5], atol=1e-9)


def test_a_near_tie_at_a_vertex_takes_the_sign_of_the_aligned_face() -> None:
    """nine_blade: beyond a blade's outlet corner the closest point is a vertex shared
    by a fan of tiny faces nearly parallel to ``p - q`` and a large face facing ``p``;
    ``closest_point`` put the large face 1e-9 mm farther and the fan's sign (inside)
    won: false gouges of 4.9-9.1 mm. Here the large face lies 5e-7 mm farther (below
    ``TIE``); the point at (0, 0, 10) is outside, 10 mm from the vertex."""
    g = 1e-5  # the tiny face: through the origin, normal (0.99875, 0, -0.05)
    k = 0.05 / np.sqrt(1.0 - 0.05 ** 2)
    tiny = [[0.0, 0.0, 0.0], [-k * g, -g, -g], [-k * g, g, -g]]
    h = -5e-7  # the large face: z = h, normal +z, its vertex under the point
    large = [[0.0, 0.0, h], [-10.0, -5.0, h], [-10.0, 5.0, h]]
    vertices = np.array(tiny + large)
    faces = np.array([[0, 1, 2], [3, 5, 4]])
    tri = vertices[faces]
    normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    assert normals[0] @ [0.0, 0.0, 1.0] < -0.04 and normals[1] @ [0.0, 0.0, 1.0] > 0.99
    found = DesignDistance(vertices, faces, max_edge=4.0)(np.array([[0.0, 0.0, 10.0]]))
    np.testing.assert_allclose(found, [10.0], atol=1e-6)
