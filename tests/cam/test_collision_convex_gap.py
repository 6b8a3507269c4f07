"""Hull distance bounds (``cam.collision.convex_gap``) against fcl on convex meshes."""

from __future__ import annotations

import fcl
import numpy as np
import trimesh
from scipy.spatial.transform import Rotation

from cam.collision.convex_gap import placed_gaps


def _fcl_distance(a: trimesh.Trimesh, b: trimesh.Trimesh, ra: np.ndarray, ta: np.ndarray,
                  rb: np.ndarray, tb: np.ndarray) -> float:
    objects = []
    for mesh, rot, trans in ((a, ra, ta), (b, rb, tb)):
        model = fcl.BVHModel()
        model.beginModel(len(mesh.vertices), len(mesh.faces))
        model.addSubModel(np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int32))
        model.endModel()
        objects.append(fcl.CollisionObject(model, fcl.Transform(rot, trans)))
    result = fcl.DistanceResult()
    return max(float(fcl.distance(objects[0], objects[1], fcl.DistanceRequest(), result)), 0.0)


def test_hull_gaps_bound_and_match_fcl_on_convex_solids() -> None:
    """Cylinders and boxes (the machine model's primitives) at random placements: the
    interval holds fcl's distance; converged, it is fcl's to 1e-6 mm."""
    rng = np.random.default_rng(18)
    a = trimesh.creation.cylinder(radius=70.0, height=100.0, sections=64)
    b = trimesh.creation.box((300.0, 420.0, 60.0))
    m = 60
    ra = Rotation.random(m, random_state=1).as_matrix()
    rb = Rotation.random(m, random_state=2).as_matrix()
    ta = rng.uniform(-150, 150, (m, 3))
    tb = rng.uniform(-150, 150, (m, 3)) + np.array([0.0, 0.0, 250.0])
    guess = rng.normal(size=(m, 3))
    va = np.ascontiguousarray(a.vertices, np.float64)
    vb = np.ascontiguousarray(b.vertices, np.float64)
    lower, upper, direction = placed_gaps(va, ra, ta, vb, rb, tb, guess, np.inf, 1e-9)
    separated = 0
    for i in range(m):
        true = _fcl_distance(a, b, ra[i], ta[i], rb[i], tb[i])
        assert lower[i] <= true + 1e-9
        assert upper[i] >= true - 1e-6
        if true > 0.0:
            separated += 1
            assert abs(lower[i] - true) < 1e-6
            assert abs(np.linalg.norm(direction[i]) - 1.0) < 1e-9
    assert separated > 10


def test_a_pruned_gap_stops_at_the_limit_and_stays_a_bound() -> None:
    """With ``prune`` the lower bound stops at or above it, never above the distance."""
    a = trimesh.creation.box((10.0, 10.0, 10.0))
    b = trimesh.creation.icosphere(subdivisions=2, radius=5.0)
    eye = np.broadcast_to(np.eye(3), (3, 3, 3)).copy()
    ta = np.zeros((3, 3))
    tb = np.array([[0.0, 0.0, 20.0], [30.0, 0.0, 0.0], [0.0, 7.0, 0.0]])
    va = np.ascontiguousarray(a.vertices, np.float64)
    vb = np.ascontiguousarray(b.vertices, np.float64)
    lower, _, _ = placed_gaps(va, eye, ta, vb, eye, tb, np.array([[1.0, 0, 0]] * 3), 2.0, 1e-9)
    assert 2.0 <= lower[0] <= 10.0 + 1e-9   # true 10 (box top at 5, sphere bottom at 15)
    assert 2.0 <= lower[1] <= 20.0 + 1e-9
    assert lower[2] == 0.0                  # overlapping

