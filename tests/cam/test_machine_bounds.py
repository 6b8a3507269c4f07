"""The machine check's compiled bounds give a plain fcl loop's answers (issue 18).

``MachineClearance`` certifies most (pose, pair) entries with lower bounds
(``cam.verify.machine_bounds``) and measures only the rest with fcl. Here its answers
are compared with fcl on every pose and pair, on the finishing postures of nine_blade
and splitter (the main job's ball6_taper, passage 0 at the chain test's coarse
settings: the starting postures of every path and the candidates of the remedy's C
turns and the repair's cones) and of the small part with the short ball4_taper (which
meets the machine: the hits), and along joint-linear motions through them: the same
hit/miss at every posture and motion sample, the same exact margins below the cap,
bounds that never exceed fcl's distance, and ``smallest`` is the brute-force minimum.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from cam.finishing.machine_reach import candidates, starting_axes
from cam.finishing.posture import c_max
from cam.verify.machine_bounds import GUARD
from cam.verify.machine_query import MachineClearance, joint_path_samples
from cam.verify.machine_scene import _distance
from postproc.machine_model import group_poses
from tests.cam.conftest import ROOT, SMALL_SPEC, finishing_setup

FIXTURES = {
    "nine_blade": (ROOT / "fixtures" / "impellers" / "nine_blade" / "spec.toml", "ball6_taper"),
    "splitter": (ROOT / "fixtures" / "impellers" / "splitter" / "spec.toml", "ball6_taper"),
    "small": (SMALL_SPEC, "ball4_taper"),
}
#: Postures compared per fixture (spread over all of them).
POSTURES = 160


def _postures(spec: Path, tool_name: str) -> dict[str, Any]:
    """Starting postures and remedy/repair candidates of passage 0, and the query."""
    setup = finishing_setup(spec, tool_name)
    options, tool, kins = setup["options"], setup["tool"], setup["kins"]
    tips, axes = [], []
    for path in setup["paths"]:
        axis, sense = starting_axes(path, tool, kins, options)
        turn = np.full(len(axis), sense * float(np.min(
            c_max(path.centre, path.reference_axis, path.opposite_tip))))
        every = candidates(axis, path.away, turn, options)  # (m, k, 3), column 0: axis
        centre = np.repeat(path.centre, every.shape[1], axis=0)
        flat = every.reshape(-1, 3)
        tips.append(centre - tool.radius * flat)
        axes.append(flat)
    tip, axis = np.vstack(tips), np.vstack(axes)
    pick = np.unique(np.linspace(0, len(tip) - 1, POSTURES).round().astype(np.intp))
    return {"tip": tip[pick], "axis": axis[pick], "obstacle": setup["obstacle"],
            "tool": tool, "kins": kins}


@pytest.fixture(scope="module", params=sorted(FIXTURES))
def case(request: pytest.FixtureRequest) -> dict[str, Any]:
    spec, tool = FIXTURES[request.param]
    return {"name": request.param, **_postures(spec, tool)}


def _brute(query: MachineClearance, joints: np.ndarray) -> np.ndarray:
    """fcl's distance of every pair at every joint row, mm ``(n, p)``."""
    poses = group_poses(query.kins, joints, query.scene.gauge, query.scene.tilt)
    return np.array([[_distance(query.scene, poses, i, j, row) for i, j, _ in query.pairs]
                     for row in range(len(joints))]).reshape(len(joints), len(query.pairs))


def _branches(case: dict[str, Any]) -> list[np.ndarray]:
    """Joints of both inverse branches of the postures, inside the tilt limits."""
    kins = case["kins"]
    lower, upper = kins.machine.limits()
    out = []
    for branch in kins.inverse_branches(case["tip"], case["axis"]):
        inside = (branch[:, 3] >= lower[3] - 1e-9) & (branch[:, 3] <= upper[3] + 1e-9)
        out.append(branch[inside])
    return out


@pytest.mark.slow
def test_postures_answer_as_a_plain_fcl_loop(case: dict[str, Any]) -> None:
    obstacle = case["obstacle"]
    query = obstacle.query(case["tool"])
    cap = obstacle.margin
    truth = np.full(len(case["tip"]), math.inf)
    kins = case["kins"]
    lower, upper = kins.machine.limits()
    for branch in kins.inverse_branches(case["tip"], case["axis"]):
        inside = np.flatnonzero((branch[:, 3] >= lower[3] - 1e-9)
                                & (branch[:, 3] <= upper[3] + 1e-9))
        fcl = _brute(query, branch[inside])
        truth[inside] = np.minimum(truth[inside],
                                   (fcl - query.clearance[None, :]).min(axis=1))
    margin, _ = query.postures_margin(case["tip"], case["axis"], cap=cap)
    assert np.array_equal(margin < cap, truth < cap)
    below = truth < cap
    assert np.allclose(margin[below], truth[below], atol=1e-9, rtol=0.0)
    assert np.all(margin[~below] >= cap) and np.all(margin <= truth + 1e-9)
    if case["name"] == "small":  # the short tool meets the machine here
        assert below.sum() >= 5 and (~below).sum() >= 5


@pytest.mark.slow
def test_motions_and_their_minimum_answer_as_a_plain_fcl_loop(
        case: dict[str, Any]) -> None:
    """Joint-linear samples through the postures (a sequence: the advancement
    applies), at cap 0 and at the obstacle's margin; ``smallest`` over them."""
    query = case["obstacle"].query(case["tool"])
    joints = max(_branches(case), key=len)[:40]
    samples = joint_path_samples(joints, query.scene.step, query.rho)
    samples = samples[np.unique(np.linspace(0, len(samples) - 1, 240).round().astype(int))]
    fcl = _brute(query, samples)
    for cap in (0.0, case["obstacle"].margin):
        found = query.query(samples, cap=cap)
        limit = np.broadcast_to(query.clearance[None, :] + cap, fcl.shape)
        below = fcl < limit
        assert np.array_equal(found.exact & below, below)  # every entry below: measured
        assert np.allclose(found.distance[found.exact], fcl[found.exact], atol=1e-9, rtol=0)
        assert np.all(found.distance[~found.exact] >= limit[~found.exact])
        assert np.all(found.distance <= fcl + GUARD)
        assert np.array_equal(found.margin < cap,
                              (fcl - query.clearance[None, :]).min(axis=1) < cap)
    fresh = MachineClearance(query.scene, query.kins, tool_side=True)
    distance, pair, row = fresh.smallest(samples)
    flat = int(np.argmin(fcl))
    assert distance == pytest.approx(float(fcl.flat[flat]), abs=1e-9)
    assert (row, pair) == (flat // fcl.shape[1], fresh.names[flat % fcl.shape[1]])
    assert fresh.queries < fcl.size / 4  # most entries certified without fcl
