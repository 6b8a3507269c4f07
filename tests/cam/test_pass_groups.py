"""``cam.finishing.pass_groups``: the passes of one name planned in order, the names on
forked processes, with the results of one process."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from cam.collision import CollisionScene
from cam.collision.scene import scenes_within
from cam.finishing.command import _machine_obstacle
from cam.finishing.options import FinishOptions, scallop_stepover
from cam.finishing.pass_groups import finish_ordered, pass_key
from cam.finishing.passes import passage_paths
from cam.finishing.paths import rotate_path
from cam.finishing.plan_memo import PlanMemo
from cam.finishing.scene import surface_meshes
from cam.tools import resolve_tool
from geometry.spec import load_spec
from geometry.surfaces import build_surfaces
from postproc.kinematics import kinematics_for
from postproc.machine import load_machine

ROOT = Path(__file__).resolve().parents[2]
SPEC = ROOT / "fixtures" / "impellers" / "small" / "spec.toml"
#: LinuxCNC's sim, whose machine model the small part fits (test_machine_chain.py)
XYZAC = ROOT / "fixtures" / "machines" / "xyzac-trt.toml"


@pytest.fixture(scope="module")
def setup() -> dict[str, Any]:
    """Two passages of a junction, a blade and a hub pass of the small fixture (coarse
    finishing), and what builds a fresh scene with the machine model as an obstacle."""
    options = FinishOptions.from_mapping({**FinishOptions().as_dict(), "scallop_mm": 0.8,
                                          "point_spacing_mm": 1.5})
    surfaces = build_surfaces(load_spec(SPEC))
    tool = resolve_tool("ball4_taper")
    machine = load_machine(XYZAC)
    kins = kinematics_for(machine)
    paths = passage_paths(surfaces, tool.radius, options.point_spacing_mm,
                          scallop_stepover(tool.radius, options.scallop_mm),
                          blade=options.blade_passes, hub=options.hub_passes,
                          reach=max(tool.flute_length - tool.radius, 0.0))
    base = []
    for op in ("junction", "blade", "hub"):
        of_op = [p for p in paths if p.operation == op]
        base.append(of_op[len(of_op) // 2])
    pitch = surfaces.spec.pitch
    ordered = [p if k == 0 else rotate_path(p, k, pitch) for k in range(2) for p in base]
    meshes = surface_meshes(surfaces, 1.0)

    def scene() -> Any:
        return _machine_obstacle(machine.model, kins, CollisionScene(meshes), None, SPEC)

    return {"options": options, "surfaces": surfaces, "tool": tool, "kins": kins,
            "ordered": ordered, "scene": scene}


def _plan(s: dict[str, Any], workers: int, memo: PlanMemo) -> tuple[Any, Any, Any]:
    obstacle = s["scene"]()
    done: list[int] = []
    merged: list[Any] = []  # what the children handed back (none from the caller's jobs)
    merge = obstacle.merge_fork_delta
    obstacle.merge_fork_delta = lambda delta: (merged.append(delta), merge(delta))
    results, cut_short = finish_ordered(s["ordered"], s["tool"], s["kins"], obstacle,
                                        s["options"], s["surfaces"], memo,
                                        lambda n, total, name: done.append(n), workers)
    assert done[-1] == len(s["ordered"]) and sorted(done) == done
    assert len(merged) == (0 if workers == 1 else 3)  # three names, each in a child
    return results, cut_short, obstacle


def test_forked_groups_give_the_plans_counts_and_memo_of_one_process(
        setup: dict[str, Any]) -> None:
    s = setup
    ordered = s["ordered"]
    assert len({pass_key(p) for p in ordered}) == 3
    # a memo holding passage 1's hub plan from an earlier run: recalled, not planned
    earlier, _, _ = _plan(s, 1, memo := PlanMemo())
    hub = ordered[-1].name
    runs = {}
    for workers in (1, 2):
        again = memo.again([p.name for p in ordered if p.name != hub])
        again.plans = dict(memo.plans)
        runs[workers] = (*_plan(s, workers, again), again)
    (one, short_one, scene_one, memo_one), (two, short_two, scene_two, memo_two) = \
        runs[1], runs[2]
    assert [r.path.name for r in one] == [r.path.name for r in two]
    for a, b in zip(one, two, strict=True):
        assert np.array_equal(a.tip, b.tip) and np.array_equal(a.axis, b.axis)
        assert np.array_equal(a.joints_after, b.joints_after)
        assert a.summary(s["options"]) == b.summary(s["options"])
    assert short_one == short_two
    # the recalled plan is the memo's own object in both runs
    recalled = memo.plans[(s["tool"].name, hub)][0]
    for results in (one, two):
        assert sum(any(r is x for x in recalled) for r in results) == len(recalled)
    assert memo_one.recalled == memo_two.recalled == 1
    assert list(memo_one.plans) == list(memo_two.plans)
    # what the children's machine queries counted and kept came back
    assert scene_one.stats["poses"] == scene_two.stats["poses"] > 0
    assert scene_one.stats["distance_queries"] == scene_two.stats["distance_queries"]
    # and what the children built on first use was built here too (tool models, the
    # scenes' fcl objects): the next fork inherits it
    assert [s.built() for s in scenes_within(scene_one)] == \
        [s.built() for s in scenes_within(scene_two)]
    assert set(scene_one._blocked) == set(scene_two._blocked)
    for key, blocked in scene_one._blocked.items():
        assert np.array_equal(blocked, scene_two._blocked[key])
    assert len(earlier) == len(one)


def test_scenes_within_finds_each_meshed_scene_once_and_skips_an_absent_stock(
        setup: dict[str, Any]) -> None:
    class Wrapper:  # as StockScene: the design inside, no in-process stock left
        def __init__(self, inner: Any, stock: Any) -> None:
            self.inner = self.design = inner
            self.stock = stock

    obstacle = setup["scene"]()
    design = scenes_within(obstacle)
    assert len(design) == 1 and isinstance(design[0], CollisionScene)
    assert scenes_within(Wrapper(design[0], None)) == design
    assert scenes_within(Wrapper(design[0], None), via="stock") == []
    stock = CollisionScene({"stock": design[0].meshes["hub"]})
    assert scenes_within(Wrapper(design[0], stock)) == [design[0], stock]
    assert scenes_within(Wrapper(design[0], stock), via="stock") == [stock]
