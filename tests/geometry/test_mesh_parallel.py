"""``geometry.mesh.triangulate_faces``: OCCT's parallel face meshing gives the same
triangles as one thread (the product meshes in parallel)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from geometry.impeller import Impeller
from geometry.mesh import triangulate_faces
from geometry.spec import load_spec

ROOT = Path(__file__).resolve().parents[2]


def test_parallel_meshing_gives_the_same_triangles_as_one_thread() -> None:
    part = Impeller(load_spec(ROOT / "fixtures" / "impellers" / "small" / "spec.toml")).built.part
    # a coarser deflection than the product's 0.02 mm keeps the test short; the edges
    # and faces are meshed by the same rules at any deflection
    one = triangulate_faces(part.solid, part.faces, 0.05, 0.25, parallel=False)
    many = triangulate_faces(part.solid, part.faces, 0.05, 0.25, parallel=True)
    assert len(one) == len(many) == len(part.faces)
    assert sum(len(t) for _, t in one) > 1000
    for (v1, t1), (v2, t2) in zip(one, many, strict=True):
        assert np.array_equal(v1, v2)
        assert np.array_equal(t1, t2)
