"""The distance grids' build: samples marked as they are made, band distances with a
reach carried from point to point; both give exactly the values of the plain build."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from cam.collision.broad_phase import (
    EXACT_BAND,
    grid_frame,
    surface_grid,
    surface_samples,
)
from cam.collision.distance_grid import DistanceGrid
from cam.collision.scene import CollisionScene
from cam.collision.triangle_bvh import TriangleBVH


def _mesh() -> trimesh.Trimesh:
    """A sphere, a large flat plate (split into many samples) and a thin sliver."""
    sphere = trimesh.creation.icosphere(subdivisions=2, radius=7.0)
    plate = trimesh.Trimesh([[-20.0, -20.0, -9.0], [20.0, -20.0, -9.0], [20.0, 20.0, -9.0],
                             [-20.0, 20.0, -9.0]], [[0, 1, 2], [0, 2, 3]], process=False)
    sliver = trimesh.Trimesh([[0.0, 0.0, 9.0], [13.0, 0.3, 9.2], [0.1, 0.05, 9.1]],
                             [[0, 1, 2]], process=False)
    mesh = trimesh.util.concatenate([sphere, plate, sliver])
    assert isinstance(mesh, trimesh.Trimesh)
    return mesh


def test_surface_grid_is_the_grid_of_the_stored_samples_bit_for_bit() -> None:
    mesh = _mesh()
    bvh = TriangleBVH(np.asarray(mesh.vertices)[np.asarray(mesh.faces)])
    for spacing, sample in ((1.0, 0.5), (0.7, 0.3)):
        origin, shape = grid_frame(np.asarray(mesh.vertices), spacing, 4.0)
        tris = bvh.tris
        points, covering = surface_samples(tris.reshape(-1, 3),
                                           np.arange(3 * len(tris)).reshape(-1, 3), sample)
        plain = DistanceGrid.from_samples(points, covering, origin, shape, spacing,
                                          EXACT_BAND * spacing, bvh.distances)
        built = surface_grid(bvh, sample, origin, shape, spacing)
        np.testing.assert_array_equal(built.bounds, plain.bounds)
        np.testing.assert_array_equal(built.box_lo, plain.box_lo)
        np.testing.assert_array_equal(built.box_hi, plain.box_hi)
        np.testing.assert_array_equal(built.coarse, plain.coarse)


def test_band_distances_do_not_depend_on_the_point_order() -> None:
    """The reach carried from the previous point only prunes: each point alone (no
    previous point) and the points in grid order give the same values."""
    mesh = _mesh()
    bvh = TriangleBVH(np.asarray(mesh.vertices)[np.asarray(mesh.faces)])
    rng = np.random.default_rng(11)
    grid = np.stack(np.meshgrid(*(np.arange(-12.0, 12.0, 0.9),) * 3, indexing="ij"),
                    axis=-1).reshape(-1, 3)
    points = np.vstack([grid, rng.uniform(-25, 25, (500, 3))])
    ordered = bvh.distances(points, 6.0)
    alone = np.array([bvh.distances(p[None], 6.0)[0] for p in points])
    np.testing.assert_array_equal(ordered, alone)
    assert np.isfinite(ordered).sum() > 1000 and np.isinf(ordered).sum() > 10
    # against the closest points of trimesh (a different computation: rounding apart)
    near = np.isfinite(ordered)
    _, expected, _ = trimesh.proximity.closest_point(mesh, points[near][:400])
    np.testing.assert_allclose(ordered[near][:400], expected, atol=1e-9)


def test_outer_grid_bounds_are_lower_bounds_and_tighter_far_out() -> None:
    """Spheres far beyond the scene grid's frame: with the outer grid their bound is
    still at most the true distance, never below the bound without it, and far
    tighter than the bounding-box distance above a cone."""
    from cam.collision.broad_phase import outer_grid

    cone = trimesh.creation.cone(radius=40.0, height=30.0, sections=64)
    tris = np.asarray(cone.vertices)[np.asarray(cone.faces)]
    bvh = TriangleBVH(tris)
    origin, shape = grid_frame(np.asarray(cone.vertices), 1.0, 10.0)
    fine = surface_grid(bvh, 0.5, origin, shape, 1.0)
    outer = outer_grid(tris)
    rng = np.random.default_rng(5)
    tip = rng.uniform([-60, -60, -20], [60, 60, 90], (400, 3))
    axis = rng.normal(size=(400, 3))
    axis /= np.linalg.norm(axis, axis=1)[:, None]
    heights, radii = np.array([0.0, 30.0, 80.0]), np.array([2.0, 5.0, 20.0])
    plain = fine.part_bounds(tip, axis, heights, radii)
    both = fine.part_bounds(tip, axis, heights, radii, outer=outer)
    centres = tip[:, None, :] + heights[None, :, None] * axis[:, None, :]
    _, true, _ = trimesh.proximity.closest_point(cone, centres.reshape(-1, 3))
    exact = (true.reshape(-1, 3) - radii).min(axis=1)
    assert np.all(both >= plain) and np.all(both <= exact + 1e-9)
    assert np.mean(both - plain) > 1.0  # the outer grid decides where the box cannot
    # the early stop of the scan keeps its meaning: the first sphere at or below it
    stopped = fine.part_bounds(tip, axis, heights, radii, 0.0, outer=outer)
    np.testing.assert_array_equal(stopped > 0.0, both > 0.0)


def test_the_scene_builds_the_same_grids_on_threads_as_on_one(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """``CollisionScene`` builds its roles' grids and the outer grid on threads
    (``impeller_cam.threads.run_on_threads``): the same grids as one after the other."""
    mesh = _mesh()
    parts = mesh.split(only_watertight=False)
    meshes = {f"role{i}": part for i, part in enumerate([mesh, *parts[:2]])}
    scenes = []
    for threads in ("1", "3"):
        monkeypatch.setenv("IMPELLER_CAM_THREADS", threads)
        scenes.append(CollisionScene(meshes))
    one, many = scenes
    assert one.roles == many.roles and len(one.roles) == 3
    for a, b in [*zip(one.grids.values(), many.grids.values(), strict=True),
                 (one.outer, many.outer), (one.whole, many.whole)]:
        np.testing.assert_array_equal(a.bounds, b.bounds)
        np.testing.assert_array_equal(a.coarse, b.coarse)
        np.testing.assert_array_equal(a.box_lo, b.box_lo)
        np.testing.assert_array_equal(a.box_hi, b.box_hi)
        np.testing.assert_array_equal(a.origin, b.origin)
        assert np.isfinite(a.bounds).any()
