"""A pass's plan in another passage as passage 0's plan turned and re-checked
(cam/finishing/turned_plan.py, ``pass_groups.finish_ordered``).

On the small fixture's closed-form surfaces (xyzac-trt without its model): the turned
plan of a clean pass is passage 0's postures turned by the pitch, with the same joints
but C and the same checks; a lump of material that blocks passage 2's turned postures
makes the turn fail there (the pass is then planned in full and steers clear of it).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import trimesh

from cam.collision import CollisionScene
from cam.finishing.options import FinishOptions, scallop_stepover
from cam.finishing.pass_groups import finish_ordered
from cam.finishing.passes import passage_paths
from cam.finishing.paths import rotate_path
from cam.finishing.pieces import finish_runs, offenders
from cam.finishing.posture import rotate_about_z
from cam.finishing.scene import surface_meshes
from cam.finishing.turned_plan import turned_plan
from cam.tools import resolve_tool
from geometry.spec import load_spec
from geometry.surfaces import build_surfaces
from postproc.kinematics import kinematics_for
from postproc.machine import load_machine
from tests.cam.conftest import without_model

ROOT = Path(__file__).resolve().parents[2]
SPEC = ROOT / "fixtures" / "impellers" / "small" / "spec.toml"
MACHINE = without_model(ROOT / "fixtures" / "machines" / "xyzac-trt.toml")


@pytest.fixture(scope="module")
def setup() -> dict[str, Any]:
    """Surfaces, scene, tool, kinematics, options and passage 0's junction, a blade
    pass and a hub pass of the small fixture at coarse settings."""
    options = FinishOptions.from_mapping({**FinishOptions().as_dict(), "scallop_mm": 0.8,
                                          "point_spacing_mm": 1.5})
    surfaces = build_surfaces(load_spec(SPEC))
    tool = resolve_tool("ball4_taper")
    meshes = surface_meshes(surfaces, 1.0)
    paths = passage_paths(surfaces, tool.radius, options.point_spacing_mm,
                          scallop_stepover(tool.radius, options.scallop_mm),
                          blade=options.blade_passes, hub=options.hub_passes,
                          reach=max(tool.flute_length - tool.radius, 0.0))
    chosen = {}
    for op in ("junction", "blade", "hub"):
        of_op = [p for p in paths if p.operation == op]
        chosen[op] = of_op[len(of_op) // 2]
    return {"options": options, "surfaces": surfaces, "tool": tool, "meshes": meshes,
            "scene": CollisionScene(meshes), "paths": chosen,
            "kins": kinematics_for(load_machine(MACHINE))}


def test_turned_plan_is_passage_zero_turned_and_clean(setup: dict[str, Any]) -> None:
    s = setup
    pitch = s["surfaces"].spec.pitch
    for path in s["paths"].values():
        pieces, lost = finish_runs(path, s["tool"], s["kins"], s["scene"], s["options"],
                                   s["surfaces"])
        assert not lost.size and pieces, path.name
        for k in (1, 3):
            other = rotate_path(path, k, pitch)
            turned = turned_plan(pieces, path, other, pitch, s["tool"], s["kins"], s["scene"],
                                 s["options"], s["surfaces"])
            assert turned is not None, other.name
            assert len(turned) == len(pieces)
            for mine, theirs in zip(turned, pieces, strict=True):
                assert mine.path.name.startswith(f"p{k}.")
                assert mine.path.passage == k
                np.testing.assert_allclose(mine.tip, rotate_about_z(theirs.tip, k * pitch),
                                           atol=1e-12)
                np.testing.assert_allclose(mine.path.centre, other.centre[:len(mine.path)],
                                           atol=1e-9)
                assert not offenders(mine).size
                assert mine.reversals_after == theirs.reversals_after
                assert mine.interference.delta_c == theirs.interference.delta_c
                # a table-table machine: the same A, C turned by the pitch (mod 2 pi)
                np.testing.assert_allclose(mine.joints_after[:, 3], theirs.joints_after[:, 3],
                                           atol=1e-9)
                turn = np.angle(np.exp(1j * (mine.joints_after[:, 4]
                                             - theirs.joints_after[:, 4])))
                np.testing.assert_allclose(np.abs(turn), k * pitch if k * pitch <= math.pi
                                           else 2 * math.pi - k * pitch, atol=1e-9)
                # the summary entry holds the same checks
                entry, before = mine.summary(s["options"]), theirs.summary(s["options"])
                for key in ("points", "collisions", "motion_collisions", "delta_c_deg",
                            "reversals_after", "interfering_points"):
                    assert entry[key] == before[key], key


def test_a_lump_in_another_passage_fails_the_turn(setup: dict[str, Any]) -> None:
    s = setup
    pitch = s["surfaces"].spec.pitch
    path = s["paths"]["blade"]
    pieces, _ = finish_runs(path, s["tool"], s["kins"], s["scene"], s["options"],
                            s["surfaces"])
    # a 3 mm ball of material on the neck of passage 2's middle turned posture
    middle = len(pieces[0].tip) // 2
    tip = rotate_about_z(pieces[0].tip[middle:middle + 1], 2 * pitch)[0]
    axis = rotate_about_z(pieces[0].axis[middle:middle + 1], 2 * pitch)[0]
    lump = trimesh.creation.icosphere(subdivisions=2, radius=1.5)
    lump.apply_translation(tip + 14.0 * axis)
    scene = CollisionScene({**s["meshes"], "lump": lump})
    ordered = [rotate_path(path, k, pitch) if k else path for k in range(3)]
    assert turned_plan(pieces, path, ordered[1], pitch, s["tool"], s["kins"], scene,
                       s["options"], s["surfaces"]) is not None
    assert turned_plan(pieces, path, ordered[2], pitch, s["tool"], s["kins"], scene,
                       s["options"], s["surfaces"]) is None
    # finish_ordered plans passage 2 in full: whatever it keeps is clean
    results, cut_short = finish_ordered(ordered, s["tool"], s["kins"], scene, s["options"],
                                        s["surfaces"])
    assert all(not offenders(r).size for r in results)
    second = [r for r in results if r.path.passage == 2]
    assert second
    kept = np.vstack([r.tip for r in second])
    turned = rotate_about_z(np.vstack([p.tip for p in pieces]), 2 * pitch)
    assert kept.shape != turned.shape or not np.allclose(kept, turned, atol=1e-6) \
        or cut_short
