"""Issue 18: a UMR orientation the machine does not admit is replaced or refused.

The mechanism is tested with a synthetic ``admissible`` (a bound on the axis' tilt
from the impeller axis) on the small fixture's closed-form surfaces; the machine's
own check (``machine_pose.OrientationCheck``) against the verifier's pose distance.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cam.roughing.machine_pose import region_targets
from cam.roughing.umr import partition_passage, towards_z
from impeller_cam.errors import InputError

ROOT = Path(__file__).resolve().parents[2]
SMALL = ROOT / "fixtures" / "impellers" / "small" / "spec.toml"
TRUNNION = ROOT / "fixtures" / "machines" / "trunnion-500.toml"


def _tilt(axis: np.ndarray) -> float:
    return math.degrees(math.acos(float(np.clip(axis[2] / np.linalg.norm(axis), -1, 1))))


@settings(max_examples=60, deadline=None)
@given(st.floats(0.0, 179.0), st.floats(-180.0, 180.0), st.floats(0.0, 60.0))
def test_towards_z_turns_by_the_angle_and_keeps_the_azimuth(tilt: float, azimuth: float,
                                                             turn: float) -> None:
    t, p = math.radians(tilt), math.radians(azimuth)
    axis = np.array([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)])
    out = towards_z(axis, turn)
    assert np.linalg.norm(out) == pytest.approx(1.0, abs=1e-12)
    assert _tilt(out) == pytest.approx(max(tilt - turn, 0.0), abs=1e-6)
    if tilt - turn > 1e-3:
        assert math.atan2(out[1], out[0]) == pytest.approx(p, abs=1e-6)


@pytest.fixture(scope="module")
def passage() -> dict[str, Any]:
    from cam.finishing.scene import surface_meshes
    from cam.roughing.passage import passage_grid, passage_lanes
    from geometry.spec import load_spec
    from geometry.surfaces import build_surfaces

    surfaces = build_surfaces(load_spec(SMALL))
    eta = surfaces.spec.finishing_allowance
    radius = 2.0
    lane = passage_lanes(surfaces)[0]
    grid = passage_grid(surfaces, radius, eta, scallop=1.0, max_depth=radius,
                        step_along=2.0, lane=lane)
    meshes = surface_meshes(surfaces, 1.0)
    triangles = np.concatenate([np.asarray(m.triangles) for m in meshes.values()])
    return {"grid": grid, "suction": lane.suction, "triangles": triangles,
            "rho": radius + eta}


def _partition(passage: dict[str, Any], admissible: Any = None) -> list[Any]:
    return partition_passage(passage["grid"], passage["suction"], passage["triangles"],
                             passage["rho"], reach_tolerance=1.0, min_reach=0.8,
                             admissible=admissible)


def test_an_orientation_the_machine_refuses_is_replaced(passage: dict[str, Any]) -> None:
    free = _partition(passage)
    same = _partition(passage, lambda axis, centres: (True, ""))
    assert [u.stations for u in same] == [u.stations for u in free]
    assert all(np.array_equal(a.axis, b.axis) for a, b in zip(same, free, strict=True))
    tilts = [_tilt(u.axis) for u in free]
    bound = max(tilts) - 3.0  # the steepest free orientation is not admitted
    asked: list[np.ndarray] = []

    def admissible(axis: np.ndarray, centres: np.ndarray) -> tuple[bool, str]:
        asked.append(centres)
        return _tilt(axis) <= bound, "too steep"

    bounded = _partition(passage, admissible)
    assert all(_tilt(u.axis) <= bound + 1e-9 for u in bounded)
    # the regions still cover the passage from leading to trailing edge, in order
    assert bounded[0].stations[0] == 0
    assert bounded[-1].stations[1] == len(passage["grid"].u) - 1
    for a, b in zip(bounded, bounded[1:], strict=False):
        assert b.stations[0] == a.stations[1] + 1
    assert all(c.ndim == 2 and c.shape[1] == 3 and len(c) for c in asked)


def test_no_admissible_orientation_is_refused_naming_the_region(
        passage: dict[str, Any]) -> None:
    with pytest.raises(InputError) as err:
        _partition(passage, lambda axis, centres: (False, "spindle_head and rotary_table "
                                                   "0.00 mm apart"))
    text = str(err.value)
    assert "station 0" in text and "spindle_head and rotary_table" in text


def test_region_targets_take_the_deepest_and_top_layers(passage: dict[str, Any]) -> None:
    grid = passage["grid"]
    targets = region_targets(grid.centres, 2, 9)
    assert targets.shape[1] == 3 and len(targets) <= 2 * 6 * 6
    deepest = grid.centres[-1][:, 2:9].reshape(-1, 3)
    # every target of the deepest layer is one of the region's deepest targets
    near = np.min(np.linalg.norm(targets[:, None] - deepest[None], axis=2), axis=1)
    assert np.sum(near < 1e-12) >= len(targets) // 2


def test_the_machine_check_agrees_with_the_pose_distance() -> None:
    from cam.roughing.machine_pose import orientation_check
    from cam.tools import resolve_tool
    from cam.verify.machine_scene import pose_distance
    from postproc.kinematics import kinematics_for
    from postproc.machine import load_machine

    machine = load_machine(TRUNNION)
    kins = kinematics_for(machine)
    tool = resolve_tool("ball6")
    check = orientation_check(machine, kins, tool, SMALL, math.radians(30.0), 2)
    assert check is not None
    centres = np.array([[30.0, 0.0, 10.0], [0.0, 25.0, 5.0]])
    for axis in (np.array([0.0, 0.0, 1.0]), towards_z(np.array([1.0, 0.0, 0.0]), 5.0)):
        clear, why = check(axis, centres)
        joints = check.poses(axis, centres)
        assert joints.shape == (4, 5)
        worst = min(pose_distance(check.scene, kins, i, j, pose) - c
                    for i, j, c in check.scene.pairs for pose in joints)
        assert clear == (worst >= 0.0)
        assert (why == "") == clear
    assert orientation_check(None, kins, tool, SMALL, 0.5, 1) is None
