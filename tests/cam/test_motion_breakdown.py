"""Time by class of block (cam/motion/breakdown.py) on a posted program with a link.

The program of tests/postproc/test_post_links.py: two passes, departures and
approaches at feed, one checked link that turns C by 180 deg. Its rotary-link time is
the one rotary rapid's time (near rest at both ends: the corners to the feed moves
either side admit almost no speed within ``G64 P0.01``), and the classes add up.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from cam.motion.breakdown import block_kinds, program_file_times, time_breakdown
from cam.motion.cycle_time import axis_limits, synchronised_times
from cam.motion.program_servo import program_joints
from postproc.apt import write_apt
from postproc.command import post_text
from postproc.machine import load_machine
from postproc.nc_reader import read_nc
from postproc.program import Motion
from tests.postproc.test_post_links import half_turn_link

ROOT = Path(__file__).resolve().parents[2]
MACHINE = ROOT / "fixtures" / "machines" / "xyzac-trt.toml"


def test_classes_of_a_program_with_a_half_turn_link(tmp_path: Path) -> None:
    machine = load_machine(MACHINE)
    apt = write_apt(tmp_path / "two_sides.apt", [half_turn_link()])
    nc = tmp_path / "two_sides.ngc"
    nc.write_text(post_text(apt, MACHINE))
    program = read_nc(nc)
    kinds = block_kinds(apt, machine, len(program))
    assert kinds is not None
    times = program_file_times(nc, apt, machine, "finish")
    assert times["air_feed_source"] == "apt"
    assert times["rotary_link_blocks"] == 2  # the opening orientation and the link
    assert times["cutting_s"] + times["air_s"] == pytest.approx(times["cycle_time_s"])
    assert times["air_s"] == pytest.approx(times["rapid_s"] + times["approach_departure_s"])
    assert times["approach_departure_s"] > 0 and times["rotary_link_s"] > 0
    assert times["nominal_s"] <= times["cycle_time_s"] <= times["exact_stop_s"]
    # the rotary rapids alone, rest to rest
    joints = program_joints(program, machine)
    step = np.diff(np.vstack([program.start[None], joints]), axis=0)
    step = np.where(np.isfinite(step), step, 0.0)
    turning = np.abs(step[:, 3:]).max(axis=1) > 1e-9
    rows = np.flatnonzero(turning & (program.motion == Motion.RAPID))
    assert len(rows) == 2
    alone = synchronised_times(step[rows], *axis_limits(machine)).sum()
    assert times["rotary_link_s"] == pytest.approx(alone, rel=1e-2)
    # without the APT every feed block counts as cutting
    plain = time_breakdown(program, machine, joints)
    assert plain["approach_departure_s"] == 0.0
    assert plain["cycle_time_s"] == pytest.approx(times["cycle_time_s"])
