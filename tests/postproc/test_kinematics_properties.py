"""Property tests: forward(inverse(pose)) == pose over random poses, offsets, conventions.

Acceptance: tip within 1e-9 mm, tool axis within 1e-12 rad, for both table kinematics,
both rotary direction conventions, random pivot offsets, rotation points and tool
lengths. The one documented exception: an axis closer to the C axis than
``DEFAULT_TOLERANCES.singular_tilt`` (C undefined, tilt set to 0) is reproduced within
that distance.
"""

from __future__ import annotations

import numpy as np
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from impeller_cam.tolerances import DEFAULT_TOLERANCES
from postproc.kinematics import kinematics_for
from postproc.machine import PivotOffsets, ideal_machine

TIP_TOLERANCE = 1e-9  # mm
AXIS_TOLERANCE = 1e-12  # rad

lengths = st.floats(-300.0, 300.0, allow_nan=False)
offsets = st.floats(-200.0, 200.0, allow_nan=False)
pivots = st.builds(
    PivotOffsets,
    x_rot_point=lengths,
    y_rot_point=lengths,
    z_rot_point=lengths,
    x_offset=offsets,
    y_offset=offsets,
    z_offset=offsets,
)
kinds = st.sampled_from(["xyzac-trt", "xyzbc-trt"])
tilts = st.one_of(
    st.floats(0.0, np.radians(179.0)),
    st.sampled_from([0.0, 1e-15, 1e-10, 2e-9, 1e-7, np.pi / 2]),
)
poses = st.lists(
    st.tuples(lengths, lengths, lengths, tilts, st.floats(-np.pi, np.pi)),
    min_size=1,
    max_size=12,
)
PROPERTY = settings(max_examples=300, deadline=None, derandomize=True)


def _angle_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.sum(a * b, axis=1))


@PROPERTY
@given(
    kind=kinds,
    conventional=st.booleans(),
    pivot=pivots,
    tool_length=st.floats(0.0, 250.0),
    path=poses,
)
def test_forward_of_inverse_is_the_pose(
    kind: str, conventional: bool, pivot: PivotOffsets, tool_length: float, path: list
) -> None:
    kins = kinematics_for(ideal_machine(kind, pivot, conventional))
    values = np.array(path, dtype=np.float64)
    tip = values[:, :3]
    tilt, azimuth = values[:, 3], values[:, 4]
    axis = np.column_stack(
        [np.sin(tilt) * np.cos(azimuth), np.sin(tilt) * np.sin(azimuth), np.cos(tilt)]
    )
    joints = kins.inverse(tip, axis, tool_length=tool_length)
    tip_back, axis_back = kins.forward(joints, tool_length=tool_length)
    assert np.abs(tip_back - tip).max() <= TIP_TOLERANCE
    off_axis = np.hypot(axis[:, 0], axis[:, 1])
    allowed = np.where(
        off_axis < DEFAULT_TOLERANCES.singular_tilt, off_axis + AXIS_TOLERANCE, AXIS_TOLERANCE
    )
    assert np.all(_angle_between(axis_back, axis) <= allowed)
    # the raw branches reach the same pose too (away from the singular axis)
    branches = kins.inverse_branches(tip, axis, tool_length)
    regular = off_axis >= DEFAULT_TOLERANCES.singular_tilt
    for raw in branches:
        t, a = kins.forward(raw, tool_length=tool_length)
        assert np.abs(t - tip).max() <= TIP_TOLERANCE
        assert np.all(_angle_between(a, axis)[regular] <= AXIS_TOLERANCE)


@PROPERTY
@given(
    kind=kinds,
    conventional=st.booleans(),
    pivot=pivots,
    tool_length=st.floats(0.0, 250.0),
    xyz=st.tuples(lengths, lengths, lengths),
    tilt=st.floats(-np.radians(179.0), np.radians(179.0)),
    c=st.floats(-4 * np.pi, 4 * np.pi),
)
def test_inverse_next_to_the_joints_returns_them(
    kind: str,
    conventional: bool,
    pivot: PivotOffsets,
    tool_length: float,
    xyz: tuple[float, float, float],
    tilt: float,
    c: float,
) -> None:
    assume(abs(np.sin(tilt)) > 1e-6)  # C is defined
    kins = kinematics_for(ideal_machine(kind, pivot, conventional))
    joints = np.array([[*xyz, tilt, c]])
    tip, axis = kins.forward(joints, tool_length=tool_length)
    back = kins.inverse(tip, axis, tool_length=tool_length, previous=joints[0])
    np.testing.assert_allclose(back[:, :3], joints[:, :3], rtol=0, atol=TIP_TOLERANCE)
    np.testing.assert_allclose(back[:, 3:], joints[:, 3:], rtol=0, atol=AXIS_TOLERANCE)


@PROPERTY
@given(kind=kinds, conventional=st.booleans(), seed=st.integers(0, 2**32 - 1))
def test_smooth_paths_give_continuous_joints(kind: str, conventional: bool, seed: int) -> None:
    # a smooth random tool-axis path (tilt up to 80 deg, any azimuth turn) must come out
    # with rotary steps no larger than the path's own turn per pose allows
    rng = np.random.default_rng(seed)
    n = 200
    s = np.linspace(0.0, 1.0, n)
    tilt = np.radians(80.0) * np.abs(np.sin(np.pi * (rng.uniform(0.5, 2.0) * s + rng.uniform())))
    azimuth = rng.uniform(-4 * np.pi, 4 * np.pi) * s + rng.uniform(-np.pi, np.pi)
    axis = np.column_stack(
        [np.sin(tilt) * np.cos(azimuth), np.sin(tilt) * np.sin(azimuth), np.cos(tilt)]
    )
    kins = kinematics_for(
        ideal_machine(kind, PivotOffsets(y_offset=20.0, z_offset=10.0), conventional)
    )
    joints = kins.inverse(np.zeros((n, 3)), axis)
    off_axis = np.sin(tilt)
    regular = off_axis[1:] > 0.05  # well away from the C axis the C rate is bounded
    steps = np.abs(np.diff(joints[:, 3:], axis=0))
    turn = np.abs(np.diff(azimuth)).max()
    assert steps[:, 0].max() <= np.abs(np.diff(tilt)).max() * (1 + 1e-9) + 1e-12
    assert np.all(steps[regular, 1] <= turn * (1 + 1e-9) + 1e-12)
