"""``geometry.mesh._manifold``: every edge used by exactly two triangles, once each way."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from geometry.mesh import _manifold


def _rows_manifold(faces: np.ndarray) -> bool:
    """The same test on edge rows (``np.unique(axis=0)``): the definition, slowly."""
    directed = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    _, counts = np.unique(np.sort(directed, axis=1), axis=0, return_counts=True)
    _, once = np.unique(directed, axis=0, return_counts=True)
    return bool(np.all(counts == 2) and np.all(once == 1))


def test_closed_meshes_are_manifold() -> None:
    for mesh in (trimesh.creation.icosphere(2), trimesh.creation.box(),
                 trimesh.creation.annulus(1.0, 2.0, 1.0)):
        assert _manifold(np.asarray(mesh.faces, np.int64))


def test_open_flipped_and_doubled_meshes_are_not() -> None:
    faces = np.asarray(trimesh.creation.icosphere(2).faces, np.int64)
    assert not _manifold(faces[1:])  # a hole: its edges are used once
    flipped = faces.copy()
    flipped[0] = flipped[0, ::-1]  # its edges run the same way as the neighbours'
    assert not _manifold(flipped)
    assert not _manifold(np.concatenate([faces, faces[:1]]))  # three triangles on an edge


@pytest.mark.parametrize("seed", range(8))
def test_same_answer_as_the_edge_rows(seed: int) -> None:
    rng = np.random.default_rng(seed)
    faces = np.asarray(trimesh.creation.icosphere(int(rng.integers(1, 3))).faces, np.int64)
    for _ in range(6):
        trial = faces.copy()
        change = rng.integers(0, 4)
        if change == 1:
            trial = np.delete(trial, rng.integers(len(trial)), axis=0)
        elif change == 2:
            row = rng.integers(len(trial))
            trial[row] = trial[row, ::-1]
        elif change == 3:
            trial[rng.integers(len(trial)), rng.integers(3)] = rng.integers(trial.max() + 1)
        assert _manifold(trial) == _rows_manifold(trial)
    assert _manifold(np.zeros((0, 3), np.int64)) == _rows_manifold(np.zeros((0, 3), np.int64))
