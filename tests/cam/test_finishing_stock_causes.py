"""Postures left out because shank or holder come too close to the in-process stock
are named ``"stock"`` (issue 28: the splitter's main-blade inlet).

Against the rough stock the shank of a pass beside excess material keeps less than
``stock_clearance_mm`` from it without touching it: a clearance, not a contact, so the
posture check names no role. The left-out postures were recorded with cause None,
the rest operation (triggered by ``"stock"`` causes only) did not cover them and the
chain kept their plan against the rough stock. ``pieces.finish_runs`` now asks the
stock for such postures (``stock_clearance.stock_blocks``): here a pass runs between
two blocks of stock its shank cannot clear; with the same blocks in the design (a
design clearance: nothing the rest operation removes) the cause stays None.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import trimesh

from cam.collision import CollisionScene
from cam.finishing.driven import DrivenScene
from cam.finishing.options import FinishOptions
from cam.finishing.pass_groups import finish_ordered
from cam.finishing.paths import CutterPath
from cam.finishing.pieces import finish_runs, offenders
from cam.finishing.plan import finish_path
from cam.finishing.stock_clearance import (
    StockScene,
    excess_voxels,
    stock_blocks,
    stock_scene_of,
)
from cam.tools import resolve_tool
from cam.verify.stock import Stock
from postproc.kinematics import Kinematics, kinematics_for
from postproc.machine import load_machine

ROOT = Path(__file__).resolve().parents[2]
TOOL = resolve_tool("ball4_taper")  # R 2; taper shank 2.0-2.2 mm radius from 10 mm up
#: Half the blocks' length along the pass (Y), mm.
BLOCK_HALF = 6.0
#: The options of the chain's splitter run where it matters: 2.5 mm from the design,
#: 0.5 mm from the stock beyond its 2 mm offset.
#: Voxel of the excess stock, mm.
VOXEL = 0.25
OPTIONS = FinishOptions(clearance_mm=2.5, stock_clearance_mm=0.5, clearance_exact_mm=3.0,
                        tilt_search_deg=1.0)


class PlaneDistance:
    """Signed distance from the half-space z <= 1 (the plate's top)."""

    def __call__(self, points: np.ndarray) -> np.ndarray:
        return np.asarray(points)[:, 2] - 1.0


def _blocks() -> trimesh.Trimesh:
    """Two blocks x in +-[2.3, 12], |y| <= BLOCK_HALF, z in [2, 15]: an upright shank
    passes between them 0.13 mm from their excess voxels (``VOXEL``; they reach
    0.05 mm closer), below the 0.5 mm stock clearance, touching neither."""
    parts = []
    for side in (1.0, -1.0):
        box = trimesh.creation.box(extents=[9.7, 2.0 * BLOCK_HALF, 13.0])
        box.apply_translation([side * 7.15, 0.0, 8.5])
        parts.append(box)
    both = trimesh.util.concatenate(parts)
    assert isinstance(both, trimesh.Trimesh)
    return both


def _plate() -> trimesh.Trimesh:
    return trimesh.creation.box(extents=[60.0, 60.0, 2.0])  # top at z = 1


@pytest.fixture(scope="module")
def kins() -> Kinematics:
    return kinematics_for(load_machine(ROOT / "fixtures" / "machines" / "xyzac-trt.toml"))


@pytest.fixture(scope="module")
def stock_scene() -> StockScene:
    blocks = _blocks()
    stock = Stock.from_mesh(np.asarray(blocks.vertices, np.float64),
                            np.asarray(blocks.faces, np.int64), 0.1)
    excess = excess_voxels(stock, PlaneDistance(), OPTIONS.clearance_mm  # type: ignore[arg-type]
                           - OPTIONS.stock_clearance_mm, VOXEL)
    return StockScene(CollisionScene({"hub": _plate()}, grid_spacing=2.0), excess)


def gap_pass(n: int = 21, half: float = 20.0) -> CutterPath:
    """Ball centres 2 mm over the plate along Y through the gap; the axis leaned 2 deg
    along the feed (A not singular); C turns cannot help (Cmax tiny)."""
    centre = np.column_stack([np.zeros(n), np.linspace(-half, half, n), np.full(n, 3.0)])
    lean = math.radians(2.0)
    up = np.tile([0.0, math.sin(lean), math.cos(lean)], (n, 1))
    side = np.tile([1.0, 0.0, 0.0], (n, 1))
    return CutterPath(name="p0.blade.gap.01", operation="blade", passage=0, centre=centre,
                      normal=side, reference_axis=up, away=side,
                      opposite_tip=centre + [0.5, 0.0, 40.0], curve_u=np.linspace(0, 1, n))


def test_stock_blocks_postures_and_the_motion_from_them(stock_scene: StockScene) -> None:
    axis = np.tile([0.0, 0.0, 1.0], (4, 1))
    # far, then far with its motion into the gap, in the gap, far (last: no motion)
    tip = np.array([[0.0, -30.0, 1.0], [0.0, -9.0, 1.0], [0.0, 0.0, 1.0], [0.0, 30.0, 1.0]])
    every = np.arange(4, dtype=np.intp)
    blocked = stock_blocks(stock_scene, TOOL, tip, axis, every, 0.05, OPTIONS.clearance_mm,
                           0.5, 0.5)
    assert blocked.tolist() == [False, True, True, False]
    # posture 1 alone is clear of the stock: it is its motion into the gap
    alone = stock_blocks(stock_scene, TOOL, tip[1:2], axis[1:2], np.array([0]), 0.05,
                         OPTIONS.clearance_mm, 0.5, 0.5)
    assert not alone[0]
    # found through the finishing wrappers; a scene without stock blocks nothing
    driven = DrivenScene(stock_scene, ["hub"], 0.02)
    assert stock_scene_of(driven) is stock_scene
    assert stock_blocks(driven, TOOL, tip, axis, every, 0.05, OPTIONS.clearance_mm,
                        0.5, 0.5).tolist() == blocked.tolist()
    design = stock_scene.design
    assert stock_scene_of(design) is None
    assert not stock_blocks(design, TOOL, tip, axis, every, 0.05, OPTIONS.clearance_mm,
                            0.5, 0.5).any()


def test_left_out_beside_the_stock_names_the_stock(stock_scene: StockScene,
                                                   kins: Kinematics) -> None:
    path = gap_pass()
    # the whole pass's plan: shank too close to the stock, touching nothing
    plan = finish_path(path, TOOL, kins, stock_scene, OPTIONS)
    assert plan.interference.interfering_points.size
    assert all(role is None for role in plan.interference.hit_role)
    causes: list[str | None] = []
    pieces, lost = finish_runs(path, TOOL, kins, stock_scene, OPTIONS, None, causes=causes)
    assert pieces and lost.size
    assert np.abs(path.centre[lost, 1]).max() <= BLOCK_HALF + 2.5  # beside the blocks
    assert len(causes) == lost.size
    assert set(causes) == {"stock"}


def test_the_same_blocks_in_the_design_leave_the_cause_open(kins: Kinematics) -> None:
    design = CollisionScene({"hub": _plate(), "wall": _blocks()}, grid_spacing=2.0)
    path = gap_pass()
    causes: list[str | None] = []
    pieces, lost = finish_runs(path, TOOL, kins, design, OPTIONS, None, causes=causes)
    assert pieces and lost.size and len(causes) == lost.size
    assert set(causes) == {None}


def test_a_pass_planned_again_keeps_the_plan_leaving_fewer_out(stock_scene: StockScene,
                                                               kins: Kinematics) -> None:
    """Planned anew (the chain after the rest operation), a pass keeps its recorded
    plan when that left fewer postures out (here: one made without the blocks)."""
    from cam.finishing.plan_memo import PlanMemo

    path = gap_pass()
    memo = PlanMemo()
    clear, _ = finish_ordered([path], TOOL, kins, stock_scene.design, OPTIONS, None, memo)
    assert len(clear) == 1 and not offenders(clear[0]).size
    again = memo.again([path.name])
    results, cut_short = finish_ordered([path], TOOL, kins, stock_scene, OPTIONS, None, again)
    assert again.recalled == 0  # planned anew ...
    assert results == clear and cut_short == []  # ... and the earlier plan kept
    # without a recorded plan the new plan leaves the postures out
    alone, short = finish_ordered([path], TOOL, kins, stock_scene, OPTIONS, None, PlanMemo())
    assert short and short[0]["left_out"] and set(short[0]["causes"]) == {"stock"}
