"""Finishing against the in-process stock (issue 18, cam/finishing/stock_clearance.py).

* The excess voxels cover every stock point farther than ``offset`` from the design,
  and their mesh is the voxels' closed skin.
* The combined scene gives the design scene's answers when the stock leaves nothing
  beyond ``offset``.
* A lump of stock 2 mm higher than the finishing clearance assumes, beside a blade
  where the neck of a junction path passes: finishing with that stock tilts the tool
  away from it or names the points; an independent check (the lump's material
  points beyond ``offset`` against sample points of the posed shank and holder
  surfaces) finds no posture closer than ``stock_clearance_mm`` that is not named.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import trimesh
from scipy.spatial import cKDTree

from cam.collision import CollisionScene
from cam.collision.tool_mesh import tool_geometry
from cam.finishing import stock_clearance
from cam.finishing.options import FinishOptions
from cam.finishing.plan import plan_finishing
from cam.finishing.stock_clearance import (
    StockExcess,
    StockScene,
    engagement,
    excess_voxels,
    stock_blocked,
    voxel_mesh,
)
from cam.tools import resolve_tool
from cam.verify.stock import Stock

ROOT = Path(__file__).resolve().parents[2]
SMALL = ROOT / "fixtures" / "impellers" / "small" / "spec.toml"
MACHINE = ROOT / "fixtures" / "machines" / "xyzac-trt.toml"


class PlaneDistance:
    """Signed distance from the half-space z <= 0 (a stand-in design)."""

    def __call__(self, points: np.ndarray) -> np.ndarray:
        return np.asarray(points)[:, 2]


def test_excess_voxels_cover_the_material_beyond_the_offset() -> None:
    stock = Stock.box(np.array([-5.0, -5.0, -3.0]), np.array([5.0, 5.0, 2.7]), 0.1)
    excess = excess_voxels(stock, PlaneDistance(), 2.0, 0.5)  # type: ignore[arg-type]
    centres = excess.centres
    # the top skin above z = 2 - half a voxel diagonal is kept; nothing deeper
    assert len(centres) and centres[:, 2].min() > 2.0 - 0.5 * math.sqrt(3) * 0.5
    top = centres[:, 2].max()
    assert top + 0.25 >= 2.7 > top - 0.25
    # every dexel end beyond z = 2 lies in a kept voxel
    points, _, _ = stock.surface_samples()
    beyond = points[points[:, 2] > 2.0]
    index = np.floor((beyond - excess.origin) / excess.pitch).astype(np.int64)
    kept = {tuple(i) for i in excess.index}
    assert all(tuple(i) in kept for i in index)
    mesh = voxel_mesh(excess.index, excess.origin, excess.pitch)
    # closed: every edge is shared by an even number of faces (voxels touching along
    # an edge only share it four times)
    _, counts = np.unique(mesh.edges_sorted, axis=0, return_counts=True)
    assert (counts % 2 == 0).all()
    assert mesh.volume == pytest.approx(len(excess.index) * excess.pitch**3)
    assert excess.summary()["excess_voxels"] == len(excess.index)


def test_no_excess_leaves_the_design_answers_unchanged() -> None:
    box = trimesh.creation.box(extents=(20.0, 20.0, 2.0))
    design = CollisionScene({"part": box})
    empty = StockExcess(np.zeros((0, 3), np.int64), np.zeros(3), 0.5, np.zeros(0), 1.0, 0)
    scene = StockScene(design, empty)
    tool = resolve_tool("ball4_taper")
    tip = np.array([[0.0, 0.0, 1.5], [0.0, 0.0, 8.0]])
    axis = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]])
    a = design.check_postures(tool, tip, axis, cutter_allowance=0.05, clearance_cap=5.0)
    b = scene.check_postures(tool, tip, axis, cutter_allowance=0.05, clearance_cap=5.0)
    assert np.array_equal(a.collides, b.collides)
    assert np.array_equal(a.clearance, b.clearance, equal_nan=True)


def test_stock_clearance_and_rapids_against_a_block() -> None:
    """Shank clearance is ``min(design, stock + offset)``; a cutting cutter may enter
    the stock, a grown (rapid) one may not."""
    design = CollisionScene({"part": trimesh.creation.box(extents=(40.0, 40.0, 2.0))})
    # stock: a block from x = 2.5 (voxel-aligned) up to z = 15 beside the tool
    stock = Stock.box(np.array([2.5, -10.0, -1.0]), np.array([12.0, 10.0, 15.0]), 0.1)
    excess = excess_voxels(stock, PlaneDistance(), 2.0, 0.5)  # type: ignore[arg-type]
    scene = StockScene(design, excess)
    tool = resolve_tool("ball4_taper")
    tip = np.array([[0.0, 0.0, 1.0]])
    axis = np.array([[0.0, 0.0, 1.0]])
    plain = design.check_postures(tool, tip, axis, cutter_allowance=0.05, clearance_cap=20.0)
    both = scene.check_postures(tool, tip, axis, cutter_allowance=0.05, clearance_cap=20.0)
    assert both.clearance[0] < plain.clearance[0]
    # the shank (from 10 mm above the tip, radius 2.0-2.2 mm beside the block) is
    # 0.3-0.5 mm from the block's side at x = 2.5
    assert 0.2 < both.clearance[0] - 2.0 < 0.6
    assert stock_blocked(scene, tool, tip, axis, 0.05, 0.7)[0]
    assert not stock_blocked(scene, tool, tip, axis, 0.05, 0.1)[0]
    assert not both.collides[0]
    # a rapid's cutter grown by 2.5 mm (0.5 mm beyond the offset) is blocked by the stock
    through = np.array([[3.0, 0.0, 4.0]])  # the cutter crosses the block's side
    cut = scene.check_postures(tool, through, axis, parts=("cutter",), cutter_allowance=0.05)
    rapid = scene.check_postures(tool, through, axis, parts=("cutter",), cutter_allowance=-2.5)
    assert not cut.collides[0] and rapid.collides[0] and rapid.hit_role[0] == "stock"
    depth, over = engagement(excess, tool, through, axis)
    assert over[0] and depth[0] > 2.0


def test_engagement_is_the_deepest_voxel_inside_each_cutter() -> None:
    """``engagement`` (one tree for all postures, the pairs tested in chunks) against a
    brute-force test of every voxel centre against every posture's cutter (ball and
    fluted cylinder of the tool's radius): the same depths and flags, over more
    postures than one chunk holds."""
    rng = np.random.default_rng(11)
    index = rng.integers(0, 80, size=(3000, 3))
    excess = StockExcess(index, np.array([-20.0, -20.0, -5.0]), 0.5,
                         rng.uniform(0.0, 4.0, len(index)), 2.0, len(index))
    tool = resolve_tool("ball4_taper")
    n = stock_clearance._ENGAGEMENT_CHUNK + 500
    tip = rng.uniform([-20.0, -20.0, -8.0], [20.0, 20.0, 30.0], size=(n, 3))
    axis = rng.normal(size=(n, 3))
    axis /= np.linalg.norm(axis, axis=1)[:, None]
    depth, over = engagement(excess, tool, tip, axis)
    reach = tool.flute_length - tool.radius
    centre = tip + tool.radius * axis
    rel = excess.centres[None, :, :] - centre[:, None, :]
    along = np.clip(np.einsum("pvk,pk->pv", rel, axis), 0.0, reach)
    radial = np.linalg.norm(rel - along[..., None] * axis[:, None, :], axis=2)
    inside = radial <= tool.radius
    expected = np.where(inside.any(axis=1),
                        np.where(inside, excess.depth[None, :], -np.inf).max(axis=1), np.nan)
    assert 100 < np.isfinite(expected).sum() < n  # some postures meet voxels, some none
    assert np.array_equal(np.isfinite(depth), np.isfinite(expected))
    assert np.allclose(depth[np.isfinite(depth)], expected[np.isfinite(expected)], atol=0.0)
    assert np.array_equal(over, np.isfinite(expected) & (np.nan_to_num(expected) > 2.0))


def test_motion_with_ends_decides_as_without() -> None:
    """``StockScene.check_motion(ends=...)`` (the combined posture report standing for
    the design's end samples) decides every segment as the check without it."""
    design = CollisionScene({"part": trimesh.creation.box(extents=(40.0, 40.0, 2.0))})
    stock = Stock.box(np.array([2.5, -10.0, -1.0]), np.array([12.0, 10.0, 15.0]), 0.1)
    scene = StockScene(design, excess_voxels(stock, PlaneDistance(), 2.0, 0.5))  # type: ignore[arg-type]
    tool = resolve_tool("ball4_taper")
    rng = np.random.default_rng(7)
    n = 40
    # tips wandering over the block's side and the part, axes leaning about z
    tip = np.column_stack([np.linspace(-6.0, 6.0, n), rng.uniform(-3.0, 3.0, n),
                           rng.uniform(0.5, 4.0, n)])
    lean = np.radians(rng.uniform(0.0, 30.0, n))
    turn = rng.uniform(0.0, 2 * math.pi, n)
    axis = np.column_stack([np.sin(lean) * np.cos(turn), np.sin(lean) * np.sin(turn),
                            np.cos(lean)])
    limit = 2.5
    common = {"cutter_allowance": 0.05, "clearance_limits": (limit,)}
    ends = scene.check_postures(tool, tip, axis, clearance_cap=3.0, **common)
    motion = {"max_step_mm": 0.5, "max_step_deg": 2.0, "clearance_cap": limit, **common}
    plain = scene.check_motion(tool, tip, axis, **motion)
    reused = scene.check_motion(tool, tip, axis, ends=ends, **motion)

    def bad(report: object) -> np.ndarray:
        clear = np.asarray(report.clearance)  # type: ignore[attr-defined]
        return np.asarray(report.collides) | (np.isfinite(clear) & (clear < limit))  # type: ignore[attr-defined]

    assert np.array_equal(plain.collides, reused.collides)
    assert np.array_equal(bad(plain), bad(reused))
    assert bad(plain).any() and not bad(plain).all()  # both kinds of segment occur
    below = np.asarray(plain.clearance) < limit
    assert np.allclose(np.asarray(plain.clearance)[below], np.asarray(reused.clearance)[below])


def _body_points(tool_name: str, tip: np.ndarray, axis: np.ndarray) -> list[np.ndarray]:
    """Surface points of the posed shank and holder (their revolved mesh vertices,
    densified along the axis), one array per posture."""
    tool = resolve_tool(tool_name)
    parts = tool_geometry(tool, cutter_offset=0.0, sections=96, arc_step=math.radians(3))
    verts = np.vstack([parts[p].mesh.vertices for p in ("shank", "holder") if p in parts])
    out = []
    for t, a in zip(tip, axis, strict=True):
        z = np.array([0.0, 0.0, 1.0])
        v = np.cross(z, a)
        s, c = np.linalg.norm(v), float(z @ a)
        if s < 1e-12:
            rot = np.eye(3)
        else:
            k = v / s
            kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
            rot = np.eye(3) + s * kx + (1 - c) * kx @ kx
        out.append(t + verts @ rot.T)
    return out


@pytest.mark.slow
def test_finishing_tilts_away_from_a_lump_or_names_the_points(tmp_path: Path) -> None:
    pytest.importorskip("OCP")
    from cam.finishing.scene import solid_meshes
    from cam.verify.deviation import DesignDistance
    from geometry.impeller import Impeller
    from geometry.spec import load_spec
    from postproc.kinematics import kinematics_for
    from postproc.machine import load_machine

    impeller = Impeller(load_spec(SMALL))
    design = CollisionScene(solid_meshes(impeller, 0.05))
    kins = kinematics_for(load_machine(MACHINE))
    tool = resolve_tool("ball4_taper")
    offset, stock_clear = 1.3, 0.5
    options = FinishOptions(passages=1, scallop_mm=0.8, point_spacing_mm=1.5,
                            blade_passes=False, hub_passes=False,
                            clearance_mm=offset + stock_clear,
                            clearance_exact_mm=offset + stock_clear,
                            stock_clearance_mm=stock_clear, tessellation_mm=0.05)
    base = plan_finishing(impeller.surfaces, tool, kins, design, options,
                          scene_source="solid")
    # the posture of the first junction path whose shank comes closest to the design
    path = base.paths[0]
    clear = np.nan_to_num(path.interference.clearance, nan=np.inf)
    i = int(np.argmin(clear))
    mesh = impeller.mesh()
    distance = DesignDistance(np.asarray(mesh.vertices), np.asarray(mesh.faces))
    body = _body_points(tool.name, path.tip[i:i + 1], path.axis[i:i + 1])[0]
    d = distance(body)
    near = body[int(np.argmin(d))]
    # the lump: a 6 x 6 mm block standing on the design below that shank point, its
    # top offset + 2 mm from the design (2 mm more than the clearance assumes)
    foot = near - d.min() * _normal(distance, near)
    normal = _normal(distance, near)
    height = offset + 2.0
    box = trimesh.creation.box(extents=(6.0, 6.0, height + 2.0))
    frame = _frame(normal)
    frame[:3, 3] = foot + normal * (0.5 * height - 1.0)
    box.apply_transform(frame)
    stock = Stock.from_mesh(np.asarray(box.vertices), np.asarray(box.faces), 0.1)
    excess = excess_voxels(stock, distance, offset, options.stock_voxel_mm)
    assert excess.summary()["max_depth_mm"] > offset + 1.5
    scene = StockScene(design, excess)
    lumped = plan_finishing(impeller.surfaces, tool, kins, scene, options,
                            scene_source="solid")
    # independent check: the lump's material beyond offset (sampled at 0.1 mm)
    grid = np.stack(np.meshgrid(*[np.linspace(-0.5, 0.5, 31)] * 3, indexing="ij"), -1)
    local = grid.reshape(-1, 3) * np.array([6.0, 6.0, height + 2.0])
    material = local @ frame[:3, :3].T + frame[:3, 3]
    material = material[distance(material) > offset]
    tree = cKDTree(material)
    changed = named = 0
    for before, after in zip(base.paths, lumped.paths, strict=True):
        bad = set(after.interference.interfering_points.tolist())
        points = _body_points(tool.name, after.tip, after.axis)
        gaps = np.array([tree.query(p)[0].min() for p in points])
        # a posture closer to the lump than the stock clearance (less the 0.1 mm
        # sampling of both) is named
        close = np.flatnonzero(gaps < stock_clear - 0.15)
        assert set(close.tolist()) <= bad, (after.path.name, close, sorted(bad))
        named += len(bad & set(close.tolist()))
        changed += int((np.abs(after.axis - before.axis).max(axis=1) > 1e-6).sum())
    before_gaps = np.array([tree.query(p)[0].min() for p in
                            _body_points(tool.name, path.tip, path.axis)])
    assert (before_gaps < stock_clear).any()  # the lump is in the way without the stock
    assert changed > 0 or named > 0
    print(f"lump: shank/holder {before_gaps.min():.3f} mm from it before, postures "
          f"changed {changed}, named {named}")


def _normal(distance: object, point: np.ndarray) -> np.ndarray:
    """Unit gradient of the signed design distance at ``point`` (central differences)."""
    h = 1e-3
    g = np.array([(distance(np.array([point + h * e]))[0]  # type: ignore[operator]
                   - distance(np.array([point - h * e]))[0]) / (2 * h)  # type: ignore[operator]
                  for e in np.eye(3)])
    return g / np.linalg.norm(g)


def _frame(z: np.ndarray) -> np.ndarray:
    """A rigid transform whose local +Z is ``z``."""
    x = np.cross(z, [0.0, 0.0, 1.0])
    if np.linalg.norm(x) < 1e-6:
        x = np.array([1.0, 0.0, 0.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    out = np.eye(4)
    out[:3, :3] = np.column_stack([x, y, z])
    return out


def test_stock_options_are_checked() -> None:
    from impeller_cam.errors import InputError

    with pytest.raises(InputError, match="stock_clearance_mm"):
        FinishOptions(clearance_mm=0.5, stock_clearance_mm=1.0)
    with pytest.raises(InputError, match="stock_voxel_mm"):
        FinishOptions(stock_voxel_mm=0.0)
    assert replace(FinishOptions(), clearance_mm=2.0, stock_clearance_mm=0.5)


def test_a_missing_stock_is_bad_input_before_any_output(tmp_path: Path) -> None:
    from cam.finishing.command import run_finish
    from impeller_cam.errors import InputError

    out = tmp_path / "out"
    with pytest.raises(InputError, match="stock not found") as error:
        run_finish(SMALL, MACHINE, "ball4_taper", out, stock=tmp_path / "none.npz",
                   progress=False)
    assert "--stock" in str(error.value)
    assert not out.exists()
    with pytest.raises(InputError, match="solid scene"):
        run_finish(SMALL, MACHINE, "ball4_taper", out, stock=tmp_path / "none.npz",
                   scene="surfaces", progress=False)
    assert not out.exists()
