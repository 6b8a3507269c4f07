"""The finish stage builds the design once: the rough verification and finishing share it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[3]
SMALL = ROOT / "fixtures" / "impellers" / "small" / "spec.toml"


def test_the_shared_design_is_the_verifications_and_finishings() -> None:
    """``verify_rough`` hands ``run_verify`` and ``run_finish`` the mesh each of them
    builds by itself (``load_design``, ``_stock_scene``): their answers are unchanged."""
    pytest.importorskip("OCP")
    from cam.finishing.command import _stock_scene
    from cam.finishing.options import FinishOptions
    from cam.verify.deviation import DesignDistance
    from cam.verify.sources import load_design
    from cam.verify.stock import Stock
    from geometry.impeller import Impeller

    vertices, faces, _ = load_design(SMALL)
    shared = Impeller.from_spec(SMALL)
    mesh = shared.mesh()
    np.testing.assert_array_equal(np.asarray(mesh.vertices, np.float64), vertices)
    np.testing.assert_array_equal(np.asarray(mesh.faces, np.int64), faces)

    # the excess of a block around the part, measured with the handed-on distance and
    # with the one _stock_scene builds itself: the same voxels and depths
    lower, upper = vertices.min(axis=0) - 2.0, vertices.max(axis=0) + 2.0
    stock = Stock.box(lower, upper, 0.5)
    options = FinishOptions(stock_voxel_mm=1.0, clearance_mm=3.0, stock_clearance_mm=0.5)
    distance = DesignDistance(vertices, faces)

    class Design:  # the scene only carries the excess here
        pass

    given = _stock_scene(stock, shared, Design(), options, distance).excess  # type: ignore[arg-type]
    built = _stock_scene(stock, shared, Design(), options).excess  # type: ignore[arg-type]
    assert len(given.index) > 0
    np.testing.assert_array_equal(given.index, built.index)
    np.testing.assert_array_equal(given.depth, built.depth)
