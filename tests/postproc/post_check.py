"""Checks shared by the post-processor tests: rs274 acceptance and dense sampling."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from numpy.typing import NDArray

from postproc.kinematics import kinematics_for
from postproc.linearise import arc_distance, segment_distance
from postproc.posting import PostedProgram, Role
from postproc.program import Motion
from postproc.toolpath import Toolpath
from tests.rs274_runner import Rs274Run, rs274_path, run_rs274

#: rs274 prints 4 decimals; the posts write 4 (the default).
RS274_DECIMALS = 4


def require_rs274() -> None:
    """Skip the calling test when LinuxCNC's rs274 is not installed (CI installs it)."""
    if rs274_path() is None:
        pytest.skip("LinuxCNC's rs274 interpreter is not installed (apt install linuxcnc-uspace)")


def interpret(text: str, tmp_path: Path, name: str = "program.ngc") -> Rs274Run:
    """Write ``text`` and run rs274 on it (skips when rs274 is missing)."""
    require_rs274()
    path = tmp_path / name
    path.write_text(text, encoding="ascii")
    return run_rs274(path)


def cl_poses(toolpaths: list[Toolpath]) -> dict[int, tuple[NDArray, NDArray, int, int]]:
    """APT record -> (tip, axis, operation index, pose index).

    Records must be unique (paths read from a file, or ``with_records``).
    """
    out = {}
    for k, tp in enumerate(toolpaths):
        for i, record in enumerate(tp.source_records):
            out[int(record)] = (tp.tip[i], tp.axis[i], k, i)
    return out


def with_records(toolpaths: list[Toolpath]) -> list[Toolpath]:
    """Give in-memory toolpaths unique fake APT records (1000 k + i + 1)."""
    for k, tp in enumerate(toolpaths):
        tp.source_records = (1000 * k + np.arange(1, len(tp) + 1)).astype(np.int32)
    return toolpaths


def rs274_poses(posted: PostedProgram, run: Rs274Run) -> tuple[NDArray, NDArray, NDArray]:
    """Tool poses in W of every rs274 move, through the forward kinematics.

    Returns tip (n, 3), axis (n, 3) and the joints (n, 5) (mm, rad) of each move;
    TCP moves are mapped back from the world frame (tip) and their rotary joints (axis).
    """
    kins = kinematics_for(posted.machine)
    pos = run.position
    joints = np.column_stack([pos[:, 0], pos[:, 1], pos[:, 2], np.radians(pos[:, 3]),
                              np.radians(pos[:, 5])])
    tip, axis = kins.forward(joints)
    if run.tcp.any():
        rot_point = kins.world_from_workpiece(np.zeros((1, 3)))[0]  # type: ignore[attr-defined]
        tip[run.tcp] = pos[run.tcp, :3] - rot_point
    return tip, axis, joints


def check_against_rs274(
    posted: PostedProgram,
    toolpaths: list[Toolpath],
    run: Rs274Run,
    *,
    dense: int = 40,
) -> dict[str, float]:
    """Assert that rs274's moves reproduce the CL poses and stay within tolerance.

    1. One rs274 move per posted block, G0/G1 as posted, TCP state as posted, and the
       positions equal to the posted words (to rs274's 4 decimals).
    2. Every block that ends on an APT pose reproduces its tip within the chordal
       tolerance and its axis within the angular tolerance.
    3. Dense sampling of every feed block between two CL-segment points (joint
       interpolation in joint mode, tip-linear in TCP mode) keeps the tip within the
       chordal tolerance of the CL segment and the axis within the angular tolerance.

    Returns the worst deviations found (mm, deg).
    """
    options = posted.options
    assert len(run.feed) == len(posted), (len(run.feed), len(posted))
    assert np.array_equal(run.feed, posted.blocks.motion == Motion.LINEAR)
    assert np.array_equal(run.tcp, posted.blocks.tcp)
    words = posted.blocks.joints.copy()
    words[:, 3:] = np.degrees(words[:, 3:])
    reported = run.position[:, [0, 1, 2, 3, 5]]
    known = posted.present & np.isfinite(words)
    rounding = 0.5 * 10.0**-options.decimals + 0.5 * 10.0**-RS274_DECIMALS + 1e-9
    assert np.all(np.abs(reported - words)[known] <= rounding)
    tip, axis, joints = rs274_poses(posted, run)
    poses = cl_poses(toolpaths)
    path = posted.role == Role.PATH
    worst_tip = worst_axis = 0.0
    for i in np.flatnonzero(path):
        cl_tip, cl_axis, _, _ = poses[int(posted.record[i])]
        worst_tip = max(worst_tip, float(np.linalg.norm(tip[i] - cl_tip)))
        angle = np.degrees(np.arccos(np.clip(np.dot(axis[i], cl_axis), -1.0, 1.0)))
        worst_axis = max(worst_axis, float(angle))
    assert worst_tip <= options.chordal_tolerance, worst_tip
    assert worst_axis <= np.degrees(options.angular_tolerance), worst_axis
    # dense sampling of feed blocks that start on the CL segment of their pose
    kins = kinematics_for(posted.machine)
    on_path = np.isin(posted.role, (Role.PATH, Role.INSERTED))
    rows = [i for i in range(1, len(posted))
            if on_path[i] and on_path[i - 1] and posted.blocks.motion[i] == Motion.LINEAR]
    dense_tip = dense_axis = 0.0
    t = np.linspace(0.0, 1.0, dense + 1)
    for i in rows:
        _, _, op, k = poses[int(posted.record[i])]
        if k == 0:
            continue
        tp = toolpaths[op]
        q = joints[i - 1] + t[:, None] * (joints[i] - joints[i - 1])
        s_tip, s_axis = kins.forward(q)
        if posted.blocks.tcp[i]:
            s_tip = tip[i - 1] + t[:, None] * (tip[i] - tip[i - 1])
        d_tip = segment_distance(s_tip[None], tp.tip[k - 1][None], tp.tip[k][None]).max()
        d_axis = arc_distance(s_axis[None], tp.axis[k - 1][None], tp.axis[k][None]).max()
        dense_tip = max(dense_tip, float(d_tip))
        dense_axis = max(dense_axis, float(np.degrees(d_axis)))
    assert dense_tip <= options.chordal_tolerance, dense_tip
    assert dense_axis <= np.degrees(options.angular_tolerance), dense_axis
    return {"tip": worst_tip, "axis": worst_axis, "dense_tip": dense_tip,
            "dense_axis": dense_axis, "checked_blocks": float(len(rows))}
