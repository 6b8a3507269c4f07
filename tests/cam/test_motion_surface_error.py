"""Where a contour error shapes the part: contact with the design, the normal component."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

from cam.motion.axis_models import machine_axis_models
from cam.motion.contour import ContourError
from cam.motion.program_servo import simulate_program
from cam.motion.surface_error import CONTACT_GAP, block_contact, surface_component
from cam.verify.deviation import DesignDistance
from postproc.kinematics import kinematics_for
from postproc.machine import load_machine
from postproc.program import MachineProgram, Motion

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def machine():  # type: ignore[no-untyped-def]
    return load_machine(ROOT / "fixtures" / "machines" / "trunnion-500.toml")


def _slab(top: float, centre: tuple[float, float] = (0.0, 0.0)) -> DesignDistance:
    """A 200 x 200 x 20 mm box whose top face lies at z = ``top``."""
    box = trimesh.creation.box(extents=(200.0, 200.0, 20.0))
    box.apply_translation((centre[0], centre[1], top - 10.0))
    return DesignDistance(np.asarray(box.vertices, np.float64),
                          np.asarray(box.faces, np.int64))


def test_contact_gap_and_normal_on_a_plane() -> None:
    radius = 3.0
    design = _slab(0.0)
    tip = np.array([[0.0, 0.0, 0.0], [10.0, 5.0, 0.015], [10.0, 5.0, 0.5], [0.0, 0.0, 0.0],
                    [20.0, 0.0, -0.01]])
    axis = np.tile([0.0, 0.0, 1.0], (5, 1))
    feed = np.array([True, True, True, False, True])
    found = block_contact(tip, axis, feed, radius, design)
    np.testing.assert_allclose(found.gap[[0, 1, 2, 4]], [0.0, 0.015, 0.5, -0.01], atol=1e-9)
    assert np.isnan(found.gap[3])  # a rapid: not queried
    np.testing.assert_array_equal(found.contact, [True, True, False, False, True])
    np.testing.assert_allclose(found.normal[found.contact], [[0.0, 0.0, 1.0]] * 3, atol=1e-12)
    assert CONTACT_GAP == pytest.approx(0.02)
    # a tilted tool: the ball centre R along the axis, the gap measured from it
    tilt = np.radians(30.0)
    tilted = block_contact(np.zeros((1, 3)), np.array([[np.sin(tilt), 0.0, np.cos(tilt)]]),
                           np.array([True]), radius, design)
    assert tilted.gap[0] == pytest.approx(radius * (np.cos(tilt) - 1.0), abs=1e-9)


def test_surface_component_is_the_ball_centre_offset_along_the_normal() -> None:
    rng = np.random.default_rng(26)
    m, radius = 200, 2.5
    offset = rng.normal(scale=0.05, size=(m, 3))
    axis_offset = rng.normal(scale=0.003, size=(m, 3))
    error = ContourError(contour=np.linalg.norm(offset, axis=1), tool_axis=np.zeros(m),
                         tracking=np.zeros(m), tip=np.zeros((m, 3)), offset=offset,
                         axis_offset=axis_offset)
    normal = rng.normal(size=(4, 3))
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    from cam.motion.surface_error import BlockContact

    contact = BlockContact(gap=np.zeros(4), normal=normal,
                           contact=np.array([True, True, False, True]), radius=radius)
    block = rng.integers(0, 4, size=m)
    got = surface_component(error, block, contact)
    expected = np.einsum("ij,ij->i", offset + radius * axis_offset, normal[block])
    expected[block == 2] = 0.0  # air: no mark on the part
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-15)
    # an offset along the surface (normal (0, 0, 1)) leaves no mark
    flat = BlockContact(gap=np.zeros(1), normal=np.array([[0.0, 0.0, 1.0]]),
                        contact=np.array([True]), radius=radius)
    along = ContourError(contour=np.ones(1), tool_axis=np.zeros(1), tracking=np.zeros(1),
                         tip=np.zeros((1, 3)), offset=np.array([[0.3, -0.4, 0.0]]),
                         axis_offset=np.zeros((1, 3)))
    assert surface_component(along, np.zeros(1, np.int64), flat)[0] == 0.0


def test_a_corner_in_the_surface_plane_leaves_no_mark(machine) -> None:  # type: ignore[no-untyped-def]
    # a stepover on a flat face: X then Y at constant Z, the table still. The machine's
    # axes (Table 1's X with its slow velocity loop) round the corner in the XY plane:
    # contour error tens of microns, all of it along the surface, none along its
    # normal (Z is commanded still and simulated still; the tool axis does not turn).
    start = np.array([0.0, 0.0, 50.0, 0.0, 0.0])
    joints = np.array([[30.0, 0.0, 50.0, 0.0, 0.0], [30.0, 30.0, 50.0, 0.0, 0.0]])
    n = len(joints)
    program = MachineProgram(joints=joints, motion=np.full(n, Motion.LINEAR),
                             feed_mode=np.full(n, 94), feed=np.full(n, 1200.0),
                             line=np.arange(1, n + 1), tcp=np.zeros(n, dtype=bool),
                             tool_number=np.ones(n, dtype=np.int32), start=start)
    tip, axis = kinematics_for(machine).forward(joints)
    assert np.ptp(tip[:, 2]) < 1e-9 and np.allclose(axis, [0.0, 0.0, 1.0])
    radius = 2.0
    design = _slab(float(tip[0, 2]), centre=(float(tip[:, 0].mean()), float(tip[:, 1].mean())))
    contact = block_contact(tip, axis, np.ones(n, bool), radius, design)
    assert contact.contact.all()
    report = simulate_program(program, machine, dt=1e-3, models=machine_axis_models(machine),
                              contact=contact)
    assert report.surface is not None and report.surface_rms is not None
    assert report.deviation.max() > 0.005  # the corner is rounded in the plane
    assert report.surface.max() < 1e-9
    assert report.surface_rms < 1e-9
    assert report.gouge is not None and report.gouge.max() < 1e-9
