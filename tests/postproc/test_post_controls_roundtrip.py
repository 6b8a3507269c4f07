"""Sinumerik and Heidenhain programs read back reproduce the APT poses.

Property test over random simultaneous 5-axis paths whose tool axis crosses the C axis
(A = 0) while C turns past 360 degrees: each dialect form is posted, read back by the
project's NC reader (``parse_nc`` with the dialect detected from the file name) and
mapped through the machine's kinematics.

* joint forms: the read joints equal the posted joints at every block end to the
  printed digits, and the APT poses within the chordal / angular tolerance;
* tool-centre-point forms (rotary positions and tool vectors): the programmed tip
  and the tool axis reproduce every APT pose within the chordal / angular tolerance.
"""

from __future__ import annotations

from math import radians

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from postproc.kinematics import kinematics_for
from postproc.machine import load_machine
from postproc.nc_reader import parse_nc
from postproc.posting import Role, post_toolpaths
from postproc.posts import PostOptions, get_post
from postproc.toolpath import Cutter, MoveKind, Toolpath
from tests.postproc.golden.cases import SIM, TRUNNION
from tests.postproc.post_check import cl_poses, with_records

#: (dialect, tcp, dialect options, file suffix)
FORMS = [
    ("sinumerik", False, {}, "mpf"),
    ("sinumerik", True, {}, "mpf"),
    ("sinumerik", True, {"orientation": "vector"}, "mpf"),
    ("sinumerik", True, {"orientation": "vector", "feed": "path"}, "mpf"),
    ("heidenhain", False, {}, "h"),
    ("heidenhain", True, {}, "h"),
    ("heidenhain", True, {"orientation": "vector", "tcpm": "m128"}, "h"),
]
MACHINES = {"sim": load_machine(SIM), "trunnion": load_machine(TRUNNION)}


def spiral(n: int, turns: float, tilt0: float, tilt1: float, radius: float, z0: float,
           phase: float) -> Toolpath:
    """A 5-axis pass whose axis tilt goes from ``tilt0`` < 0 to ``tilt1`` > 0 deg
    (through the C axis) while its direction turns ``turns`` degrees."""
    s = np.linspace(0.0, 1.0, n)
    phi = np.radians(phase + turns * s)
    tilt = np.radians(tilt0 + (tilt1 - tilt0) * s)
    axis = np.stack([np.sin(tilt) * np.sin(phi), np.sin(tilt) * np.cos(phi), np.cos(tilt)], 1)
    tip = np.stack([radius * np.cos(phi), radius * np.sin(phi), z0 + 6.0 * s], 1)
    tips = np.vstack([tip[0] + 10.0 * axis[0], tip, tip[-1] + 10.0 * axis[-1]])
    axes = np.vstack([axis[0], axis, axis[-1]])
    kinds = np.array([MoveKind.RAPID, MoveKind.PLUNGE] + [MoveKind.FEED] * (n - 1)
                     + [MoveKind.RETRACT], dtype=np.int8)
    feeds = np.array([np.nan, 400.0] + [1000.0] * (n - 1) + [2000.0])
    return Toolpath(tip=tips, axis=axes, feed=feeds, kind=kinds, name="spiral", tool_number=3,
                    cutter=Cutter(4.0, 2.0, 20.0), spindle_rpm=15000.0)


def _angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.sum(a * b, axis=1))


def check_round_trip(machine_key: str, toolpath: Toolpath) -> None:
    machine = MACHINES[machine_key]
    kins = kinematics_for(machine)
    offset = np.asarray(kins.world_from_workpiece(np.zeros((1, 3))))[0]  # type: ignore[attr-defined]
    toolpaths = with_records([toolpath])
    poses = cl_poses(toolpaths)
    for dialect, tcp, extra, suffix in FORMS:
        options = PostOptions(tcp=tcp, angular_tolerance=radians(0.5), dialect_options=extra)
        posted = post_toolpaths(toolpaths, machine, options, source="spiral.apt")
        text = get_post(dialect).write(posted, options)
        read = parse_nc(text, f"spiral.{suffix}", machine=machine)
        label = f"{dialect} tcp={tcp} {extra}"
        assert len(read) == len(posted), label
        assert np.array_equal(read.tcp, posted.blocks.tcp), label
        path = np.flatnonzero(posted.role == Role.PATH)
        cl_tip = np.array([poses[int(posted.record[i])][0] for i in path])
        cl_axis = np.array([poses[int(posted.record[i])][1] for i in path])
        joints = read.joints[path]
        tip, axis = kins.forward(joints)
        if tcp:
            tip = joints[:, :3] - offset
        else:  # joint forms: the block ends exactly as posted (to the printed digits)
            known = posted.present & np.isfinite(posted.blocks.joints)
            error = np.abs(read.joints - posted.blocks.joints)
            error[:, 3:] = np.degrees(error[:, 3:])
            assert error[known].max() <= 0.5e-4 + 1e-9, label
        assert np.linalg.norm(tip - cl_tip, axis=1).max() <= options.chordal_tolerance, label
        assert np.degrees(_angle(axis, cl_axis)).max() <= 0.5, label


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    machine_key=st.sampled_from(sorted(MACHINES)),
    n=st.integers(12, 50),
    turns=st.floats(365.0, 460.0),
    tilt0=st.floats(-30.0, -5.0),
    tilt1=st.floats(5.0, 30.0),
    radius=st.floats(15.0, 35.0),
    z0=st.floats(8.0, 25.0),
    phase=st.floats(0.0, 360.0),
)
def test_random_paths_round_trip_in_every_form(machine_key: str, n: int, turns: float,
                                               tilt0: float, tilt1: float, radius: float,
                                               z0: float, phase: float) -> None:
    check_round_trip(machine_key, spiral(n, turns, tilt0, tilt1, radius, z0, phase))


@pytest.mark.parametrize("machine_key", sorted(MACHINES))
def test_fixture_like_path_round_trips(machine_key: str) -> None:
    check_round_trip(machine_key, spiral(60, 400.0, -20.0, 20.0, 28.0, 18.0, 0.0))
