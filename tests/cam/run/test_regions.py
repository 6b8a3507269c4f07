"""Region classification of verify/regions.json (fast, hand-computed cases)."""

from __future__ import annotations

import numpy as np
import pytest

from cam.run.regions import closest_roles, on_tip_edge, shroud_offset

#: A cylindrical shroud at r = 20 (z from 10 down to 0) over a hub at r = 10.
SHROUD = np.array([[10.0, 20.0], [5.0, 20.0], [0.0, 20.0]])
HUB = np.array([[10.0, 10.0], [0.0, 10.0]])


def point(z: float, r: float, theta: float = 0.7) -> np.ndarray:
    return np.array([r * np.cos(theta), r * np.sin(theta), z])


def test_shroud_offset_is_positive_beyond_the_shroud_envelope() -> None:
    points = np.array([point(5.0, 21.0), point(2.0, 19.5), point(12.0, 21.0),
                       point(13.0, 24.0), point(-3.0, 16.0)])
    # 1 mm outside, 0.5 mm inside; beyond the end (z = 10, r = 20): sqrt(2^2 + 1^2)
    # and 5 mm (a 3, 4 triangle) from the end point outward, 5 mm from the other end
    # (z = 0) inward
    expected = [1.0, -0.5, np.sqrt(5.0), 5.0, -5.0]
    assert shroud_offset(points, SHROUD, HUB) == pytest.approx(expected)


def test_shroud_offset_does_not_depend_on_the_contour_direction() -> None:
    points = np.array([point(5.0, 21.0), point(2.0, 19.5)])
    assert shroud_offset(points, SHROUD[::-1], HUB[::-1]) == pytest.approx([1.0, -0.5])


def test_shroud_offset_of_a_sloped_contour() -> None:
    # shroud from (z, r) = (10, 10) to (0, 20): the outward normal is (-1, -1)/sqrt 2
    # rotated to the side away from a hub at (10, 0)..(0, 10)
    shroud = np.array([[10.0, 10.0], [0.0, 20.0]])
    hub = np.array([[10.0, 0.0], [0.0, 10.0]])
    points = np.array([point(6.0, 16.0), point(4.0, 14.0)])
    assert shroud_offset(points, shroud, hub) == pytest.approx([np.sqrt(2.0),
                                                                -np.sqrt(2.0)])


def test_samples_whose_closest_point_is_a_tip_edge() -> None:
    # a blade side in the plane x = 0 (z <= 10) and its tip, the plane z = 10 for
    # x in [-2, 0]: they share the edge x = 0, z = 10
    side = np.array([[[0, 0, 0], [0, 10, 0], [0, 0, 10]], [[0, 10, 0], [0, 10, 10], [0, 0, 10]]],
                    dtype=float)
    tip = np.array([[[0, 0, 10], [0, 10, 10], [-2, 0, 10]],
                    [[0, 10, 10], [-2, 10, 10], [-2, 0, 10]]], dtype=float)
    triangles = np.concatenate([side, tip])
    roles = np.array(["suction", "suction", "shroud", "shroud"])
    points = np.array([[0.5, 5.0, 9.0],     # over the side: foot (0, 5, 9)
                       [0.5, 5.0, 9.95],    # still over the side, 0.05 below the edge
                       [0.5, 5.0, 10.3],    # beside the tip's corner: foot on the edge
                       [0.2, 5.0, 10.0]])   # level with the tip: foot on the edge
    role, distance = closest_roles(triangles, roles, points)
    assert distance == pytest.approx([0.5, 0.5, np.hypot(0.5, 0.3), 0.2])
    assert list(role[:2]) == ["suction", "suction"]
    assert list(on_tip_edge(triangles, roles, points, distance)) == [False, False, True, True]
