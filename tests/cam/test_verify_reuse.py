"""A run continuing an earlier run's stock reuses the earlier deviation: same answers."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from cam.tools import resolve_tool
from cam.verify.command import VerifyOptions, run_verify
from cam.verify.deviation import DesignDistance, Deviation, matched_samples, sample_deviation
from cam.verify.stock import Stock
from cam.verify.toolshape import tool_shape

ROOT = Path(__file__).resolve().parents[2]
MACHINE = ROOT / "fixtures" / "machines" / "xyzac-trt.toml"
FAST = VerifyOptions(render=False, allowance=0.0)


def _box_stl(path: Path, lower: list[float], upper: list[float]) -> Path:
    lo, hi = np.array(lower), np.array(upper)
    box = trimesh.creation.box(extents=hi - lo)
    box.apply_translation(0.5 * (lo + hi))
    box.export(path)
    return path


def test_finish_run_reuses_the_rough_deviation_exactly(tmp_path: Path) -> None:
    (tmp_path / "rough.ngc").write_text("\n".join([
        "G21 G90 G94", "G0 X-30 Y0 Z15", "G1 Z-3 F300", "G1 X30", "G0 Z15", "M30"]) + "\n")
    (tmp_path / "finish.ngc").write_text("\n".join([
        "G21 G90 G94", "G0 X-30 Y6 Z15", "G1 Z-4 F300", "G1 X30", "G0 Z15", "M30"]) + "\n")
    stock_stl = _box_stl(tmp_path / "stock.stl", [-20, -20, -10], [20, 20, 0])
    design = _box_stl(tmp_path / "design.stl", [-20, -20, -10], [20, 20, -5])
    mesh: Any = trimesh.load(design)
    distance = DesignDistance(np.asarray(mesh.vertices), np.asarray(mesh.faces))
    stock = Stock.box(np.array([-20.0, -20, -10]), np.array([20.0, 20, 0]), 0.25)
    rough = run_verify([tmp_path / "rough.ngc"], MACHINE, "ball6", str(stock_stl), design,
                       0.25, tmp_path / "rough", options=FAST, progress=False,
                       design_distance=distance, initial_stock=stock)
    assert rough is not None and rough.faces is not None
    earlier = len(stock.owners)
    finish = run_verify([tmp_path / "finish.ngc"], MACHINE, "ball6", "rough.npz", design,
                        0.25, tmp_path / "finish", options=FAST, progress=False,
                        design_distance=distance, initial_stock=stock, previous=rough)
    assert finish is not None and finish.faces is not None
    points, _, moves = stock.surface_samples()
    signed, face = distance.closest(points)
    assert np.array_equal(finish.points, points)
    assert np.array_equal(finish.distance, signed)
    assert np.array_equal(finish.faces, face)
    found = matched_samples(rough, points, moves, earlier)
    # every end the finish program left alone is taken over, and only those
    assert np.array_equal(found >= 0, moves < earlier)
    assert 0 < (found >= 0).sum() < len(points)
    assert np.array_equal(rough.points[found[found >= 0]], points[found >= 0])


def test_a_sample_not_in_the_earlier_deviation_is_queried() -> None:
    triangles = np.array([[[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]])
    old = Deviation(np.array([[0.0, 0, 1], [0, 0, 2], [0, 0, 3]]), np.array([1.0, 2, 3]),
                    np.array([-1, 0, 1], np.int32), np.array([0, 0, 0]))
    points = np.array([[0.0, 0, 1], [0, 0, 2.5], [0, 0, 3]])
    found = matched_samples(old, points, np.array([-1, 0, 1], np.int32), 2)
    # the second sample is not there: it and the rest are left to the query
    assert found.tolist() == [0, -1, -1]
    distance = DesignDistance(triangles.reshape(-1, 3), np.arange(3).reshape(1, 3))
    got = sample_deviation(points, np.array([-1, 0, 1], np.int32), distance, old, 2)
    assert got.distance[0] == 1.0  # taken over (a made-up value, not the query's)
    assert np.allclose(np.abs(got.distance[1:]), [2.5, 3.0])


def test_a_saved_deviation_is_read_back_only_for_its_samples_and_design(
        tmp_path: Path) -> None:
    """``save_deviation`` / ``load_deviation`` (the finish stage's rough run measured
    once, read back by the verify stage: ``rough_stock.stock_deviation``)."""
    from cam.run.rough_stock import stock_deviation
    from cam.verify.deviation import load_deviation, save_deviation

    design: Any = trimesh.load(_box_stl(tmp_path / "design.stl", [-20, -20, -10],
                                        [20, 20, -5]))
    distance = DesignDistance(np.asarray(design.vertices), np.asarray(design.faces))
    stock = Stock.box(np.array([-20.0, -20, -10]), np.array([20.0, 20, 0]), 0.5)
    points, _, moves = stock.surface_samples()
    signed, face = distance.closest(points)
    path = save_deviation(tmp_path / "deviation.npz", Deviation(points, signed, moves, face),
                          distance)
    got = load_deviation(path, points, moves, distance)
    assert got is not None and got.faces is not None
    assert np.array_equal(got.distance, signed) and np.array_equal(got.faces, face)
    assert np.array_equal(got.points, points) and np.array_equal(got.moves, moves)
    # another design (same mesh, moved by 1 um), other samples, no file: not used
    other = DesignDistance(np.asarray(design.vertices) + [0.0, 0.0, 1e-3],
                           np.asarray(design.faces))
    assert other.fingerprint != distance.fingerprint
    assert load_deviation(path, points, moves, other) is None
    moved = points.copy()
    moved[7, 2] += 1e-9
    assert load_deviation(path, moved, moves, distance) is None
    assert load_deviation(path, points[1:], moves[1:], distance) is None
    assert load_deviation(tmp_path / "none.npz", points, moves, distance) is None
    (tmp_path / "bad.npz").write_bytes(b"not a zip")
    assert load_deviation(tmp_path / "bad.npz", points, moves, distance) is None
    # the stock's deviation: read back when it matches, measured otherwise, alike
    for saved in (path, tmp_path / "none.npz", None):
        again = stock_deviation(stock, distance, saved)
        assert again.faces is not None
        assert np.array_equal(again.distance, signed) and np.array_equal(again.faces, face)
    stock.sweep(np.array([[0.0, 0.0, -2.0]]), np.array([[5.0, 0.0, 0.0]]),
                np.array([[0.0, 0.0, 1.0]]), np.zeros(1, np.int32),
                tool_shape(resolve_tool("ball6")))
    cut = stock_deviation(stock, distance, path)  # the samples changed: measured
    points, _, moves = stock.surface_samples()
    assert np.array_equal(cut.distance, distance.closest(points)[0])


def test_surface_points_are_the_surface_samples_without_normals() -> None:
    """The compiled fill gives the same points, move ids, order and dtypes as
    ``surface_samples`` on a stock whose rays hold several intervals (a slot cut
    through a box: rays of the X and Y grids split in two)."""
    stock = Stock.box(np.array([-10.0, -8.0, -6.0]), np.array([10.0, 8.0, 0.0]), 0.5)
    stock.sweep(np.array([[-12.0, 0.3, -3.0], [0.0, -9.0, -4.0]]),
                np.array([[24.0, 0.0, 0.0], [0.0, 18.0, 0.0]]),
                np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]]), np.array([0, 1], np.int32),
                tool_shape(resolve_tool("ball6")))
    assert max(int(g.count.max()) for g in stock.grids) >= 2
    points, _, moves = stock.surface_samples()
    got_points, got_moves = stock.surface_points()
    assert got_points.dtype == points.dtype and got_moves.dtype == moves.dtype
    assert np.array_equal(got_points, points) and np.array_equal(got_moves, moves)
    assert set(np.unique(moves)) == {-1, 0, 1}
