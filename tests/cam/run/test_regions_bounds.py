"""The bounded searches of ``near_faces`` and ``on_tip_edge`` give the answers of the
full candidate query (seeded random meshes and points)."""

from __future__ import annotations

import numpy as np
import pytest

from cam.run.regions import ON_EDGE, closest_roles, near_faces, on_tip_edge


def _surface(rng: np.random.Generator, n: int) -> np.ndarray:
    """``n`` small triangles (edges up to ~2 mm) scattered over a 40 mm cube."""
    corners = rng.uniform(0.0, 40.0, (n, 1, 3))
    return corners + rng.uniform(-1.0, 1.0, (n, 3, 3))


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("within", [0.5, 3.0, 8.0])
def test_near_faces_is_the_candidate_query(seed: int, within: float) -> None:
    rng = np.random.default_rng(seed)
    triangles = _surface(rng, 300)
    points = rng.uniform(-5.0, 45.0, (4000, 3))
    _, distance = closest_roles(triangles, np.zeros(len(triangles), np.int8), points)
    found = near_faces(triangles, points, within)
    assert np.array_equal(found, distance < within)
    assert 0 < found.sum() < len(points)


@pytest.mark.parametrize("seed", [0, 1])
def test_on_tip_edge_is_the_candidate_query(seed: int) -> None:
    rng = np.random.default_rng(seed)
    triangles = _surface(rng, 400)
    roles = np.where(rng.uniform(size=len(triangles)) < 0.3, "shroud", "suction")
    points = rng.uniform(-5.0, 45.0, (3000, 3))
    _, distance = closest_roles(triangles, roles, points)
    tips = triangles[roles == "shroud"]
    _, to_tip = closest_roles(tips, np.full(len(tips), "shroud"), points)
    found = on_tip_edge(triangles, roles, points, distance)
    assert np.array_equal(found, to_tip <= distance + ON_EDGE)
    assert 0 < found.sum() < len(points)
