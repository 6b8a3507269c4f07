"""d_min (closed-form surfaces, figures) against a brute-force mesh-to-mesh distance.

The figures solve the minimum passage width on the analytic blade outlines; here the
blades of the B-rep solid (no fillets: d_min is a blade-to-blade figure) are meshed
finely, split blade by blade, and the exact distance between the two triangle meshes
is taken with python-fcl. The two must agree within 0.05 mm (issue 2).
"""

from __future__ import annotations

from pathlib import Path

import fcl
import numpy as np
import pytest
from scipy.spatial import cKDTree

from geometry.impeller import Impeller

SMALL = Path(__file__).resolve().parents[2] / "fixtures" / "impellers" / "small" / "spec.toml"
BLADE_ROLES = ("pressure", "suction", "leading_edge", "trailing_edge", "shroud")


def _bvh(vertices: np.ndarray, faces: np.ndarray) -> fcl.CollisionObject:
    model = fcl.BVHModel()
    model.beginModel(len(vertices), len(faces))
    model.addSubModel(vertices, faces)
    model.endModel()
    return fcl.CollisionObject(model, fcl.Transform())


def test_d_min_agrees_with_mesh_to_mesh_distance() -> None:
    impeller = Impeller.from_spec(SMALL, fillets=False)
    figures = impeller.figures
    mesh = impeller.mesh(tolerance=0.005)
    roles = impeller.triangle_roles(0.005)
    on_blade = np.isin(roles, BLADE_ROLES)
    faces = mesh.faces[on_blade]
    centroids = mesh.triangles_center[on_blade]
    # which blade each triangle belongs to: nearest camber sample of every blade
    blades = impeller.surfaces.all_blades()
    samples = [b.grid(41, 11).reshape(-1, 3) for b in blades]
    owner_of_sample = np.concatenate([np.full(len(s), k) for k, s in enumerate(samples)])
    _, nearest = cKDTree(np.vstack(samples)).query(centroids)
    owner = owner_of_sample[nearest]
    objects = [_bvh(np.asarray(mesh.vertices), faces[owner == k]) for k in range(len(blades))]
    request = fcl.DistanceRequest(enable_nearest_points=True)
    distances = []
    for k in range(len(blades)):
        result = fcl.DistanceResult()
        distances.append(fcl.distance(objects[k], objects[(k + 1) % len(blades)], request, result))
    brute = float(min(distances))
    print(f"d_min {figures['d_min_mm']:.4f} mm, mesh-to-mesh {brute:.4f} mm")
    assert brute == pytest.approx(figures["d_min_mm"], abs=0.05)
