"""A run continuing an earlier run's stock reuses the earlier deviation: same answers."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from cam.verify.command import VerifyOptions, run_verify
from cam.verify.deviation import DesignDistance, Deviation, matched_samples, sample_deviation
from cam.verify.stock import Stock

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
