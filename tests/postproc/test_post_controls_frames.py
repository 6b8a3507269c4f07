"""3+2 tilted frames (Sinumerik CYCLE800, Heidenhain PLANE SPATIAL / PLANE AXIAL).

Every Unit Machining Region of the roughing fixture is written as a 3-axis program in
its frame. Checked against the machine's kinematics and the APT, independently of the
frame the post chose:

* the frame's +Z is the UMR's tool axis (APT), and in-frame Z' of every tip is the
  tip's height along that axis (``tip_W . axis``);
* distances between the tips of the frame program equal those of the APT (a frame
  is a rigid motion);
* read back, the frame programs give the same tool poses in W as the simultaneous
  forms (TRAORI / TCPM with rotary positions) for every block of every UMR.
"""

from __future__ import annotations

import numpy as np
import pytest

from postproc.apt import read_apt
from postproc.kinematics import kinematics_for
from postproc.machine import load_machine
from postproc.nc_reader import parse_nc
from postproc.posting import Role, post_toolpaths
from postproc.posts import PostOptions, get_post
from postproc.posts.frames import rotation_from_spatial, spatial_angles, swivel_segments
from tests.postproc.golden.cases import APT, SIM, TRUNNION

FRAME_FORMS = [("sinumerik", "cycle800", "mpf"), ("heidenhain", "plane-spatial", "h"),
               ("heidenhain", "plane-axial", "h")]


def _poses(text: str, name: str, machine_path: object) -> tuple[np.ndarray, np.ndarray]:
    machine = load_machine(machine_path)  # type: ignore[arg-type]
    kins = kinematics_for(machine)
    read = parse_nc(text, name, machine=machine)
    tip, axis = kins.forward(read.joints)
    offset = np.asarray(kins.world_from_workpiece(np.zeros((1, 3))))[0]  # type: ignore[attr-defined]
    tip[read.tcp] = read.joints[read.tcp, :3] - offset
    return tip, axis


@pytest.mark.parametrize(("dialect", "frames", "suffix"), FRAME_FORMS)
@pytest.mark.parametrize("machine_path", [SIM, TRUNNION], ids=["sim", "trunnion"])
@pytest.mark.parametrize("tcp", [False, True], ids=["joint", "tcp"])
def test_frame_programs_give_the_simultaneous_tool_poses(dialect: str, frames: str,
                                                         suffix: str, machine_path: object,
                                                         tcp: bool) -> None:
    machine = load_machine(machine_path)  # type: ignore[arg-type]
    toolpaths = read_apt(APT)
    framed = PostOptions(tcp=tcp, dialect_options={"frames": frames})
    posted = post_toolpaths(toolpaths, machine, framed, source=APT.name)
    swivel = swivel_segments(posted)
    assert len(swivel.rotary) == 2  # the fixture's two UMRs; the spiral is not one
    umr = swivel.frame >= 0
    assert set(posted.operation[umr].tolist()) == {0}
    text = get_post(dialect).write(posted, framed)
    assert text.count({"sinumerik": "CYCLE800(0,", "heidenhain": "PLANE "}[dialect]) >= 2
    # in-frame words: Z' along the UMR's axis, rigid distances (APT geometry only)
    for k in range(2):
        rows = np.flatnonzero(swivel.frame == k)
        path = rows[posted.role[rows] == Role.PATH]
        apt = toolpaths[0]
        index = np.searchsorted(apt.source_records, posted.record[path])
        cl_tip, cl_axis = apt.tip[index], apt.axis[index]
        assert np.allclose(cl_axis, cl_axis[0])
        words = swivel.words[path, :3]
        assert np.allclose(words[:, 2], cl_tip @ cl_axis[0], atol=1e-6)
        assert np.allclose(np.linalg.norm(words[1:] - words[:-1], axis=1),
                           np.linalg.norm(cl_tip[1:] - cl_tip[:-1], axis=1), atol=1e-6)
        assert np.allclose(swivel.rotation[k] @ [0.0, 0.0, 1.0], cl_axis[0], atol=1e-9)
    # read back: the same poses as the program without frames, block by block
    plain = PostOptions(tcp=tcp)
    tip_f, axis_f = _poses(text, f"framed.{suffix}", machine_path)
    tip_p, axis_p = _poses(get_post(dialect).write(posted, plain), f"plain.{suffix}",
                           machine_path)
    rows = np.flatnonzero(umr)
    assert np.abs(tip_f[rows] - tip_p[rows]).max() <= 2e-4  # mm: printed digits
    assert np.degrees(np.abs(axis_f[rows] - axis_p[rows]).max()) <= 1e-4
    assert np.nanmax(np.abs(tip_f - tip_p)) <= 2e-4  # and outside the frames too
    # and as the simultaneous TCP form (TRAORI / TCPM, rotary positions) at every UMR pose
    simultaneous = PostOptions(tcp=True)
    posted_tcp = post_toolpaths(toolpaths, machine, simultaneous, source=APT.name)
    tip_s, axis_s = _poses(get_post(dialect).write(posted_tcp, simultaneous),
                           f"tcp.{suffix}", machine_path)
    here = umr & (posted.role == Role.PATH)
    row_of = {int(r): i for i, r in enumerate(posted_tcp.record)
              if posted_tcp.role[i] == Role.PATH}
    there = np.array([row_of[int(r)] for r in posted.record[here]])
    assert np.abs(tip_f[here] - tip_s[there]).max() <= 2e-4
    assert np.degrees(np.abs(axis_f[here] - axis_s[there]).max()) <= 1e-4


def test_spatial_angles_round_trip() -> None:
    rng = np.random.default_rng(3)
    for _ in range(20):
        angles = rng.uniform([-180, -89, -180], [180, 89, 180])
        rotation = rotation_from_spatial(angles)
        assert np.allclose(spatial_angles(rotation[None])[0], angles, atol=1e-9)


def test_frames_without_tilted_segments_write_no_frame() -> None:
    from tests.postproc.post_paths import finishing_spiral

    machine = load_machine(SIM)
    options = PostOptions(dialect_options={"frames": "cycle800"})
    posted = post_toolpaths([finishing_spiral()], machine, options, source="s.apt")
    assert not (swivel_segments(posted).frame >= 0).any()
    assert "CYCLE800" not in get_post("sinumerik").write(posted, options)
