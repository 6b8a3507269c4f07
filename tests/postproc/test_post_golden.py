"""Golden files per dialect (byte for byte), determinism, and rs274 on the LinuxCNC ones."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from postproc.apt import read_apt
from postproc.kinematics import kinematics_for
from postproc.machine import load_machine
from postproc.posting import post_toolpaths
from postproc.posts import PostOptions, get_post
from postproc.program import FeedMode
from tests.postproc.golden.cases import APT, CASES, GOLDEN, SIM, render
from tests.postproc.post_check import check_against_rs274, interpret

REGENERATE = "python -m tests.postproc.golden.regenerate"


@pytest.mark.parametrize("name", sorted(CASES))
def test_golden_file(name: str) -> None:
    expected = (GOLDEN / name).read_bytes()
    produced = render(name).encode("ascii")
    assert produced == expected, f"{name} differs from its golden file; if intended: {REGENERATE}"


@pytest.mark.parametrize("name", sorted(CASES))
def test_program_text_is_clean(name: str) -> None:
    text = (GOLDEN / name).read_text(encoding="ascii")
    assert text.endswith("\n") and "\r" not in text
    for line in text.splitlines():
        assert 0 < len(line) <= 120
        assert all(32 <= ord(c) <= 126 for c in line)
        if "(" in line:  # one comment per line, closed, nothing after it
            assert line.count("(") == 1 and line.count(")") == 1 and line.endswith(")")
    if name.startswith("fanuc"):
        assert text.startswith("%\nO") and text.endswith("M30\n%\n")
    elif name.startswith("sinumerik"):
        assert text.startswith("%_N_POST_IMPELLER_OPS_MPF\n;$PATH=/_N_MPF_DIR\n")
        assert text.endswith("M30\n") and text.count("%") == 1
        assert "(" not in re.sub(r"CYCLE8\d\d\(", "", text)
    elif name.startswith("heidenhain"):
        lines = text.splitlines()
        assert lines[0] == "0 BEGIN PGM POST_IMPELLER_OPS MM"
        assert lines[-1] == f"{len(lines) - 1} END PGM POST_IMPELLER_OPS MM"
        assert [int(line.split()[0]) for line in lines] == list(range(len(lines)))
    else:
        assert text.endswith("M2\n") and "%" not in text


@pytest.mark.parametrize("name", sorted(n for n in CASES if n.endswith(".ngc")))
def test_golden_linuxcnc_programs_pass_rs274(name: str, tmp_path: Path) -> None:
    case = CASES[name]
    options = PostOptions(tcp=case.get("tcp", False),
                          chordal_tolerance=case.get("tolerance", 0.01),
                          block_numbers=case.get("block_numbers", False))
    toolpaths = read_apt(APT)
    posted = post_toolpaths(toolpaths, load_machine(case["machine"]), options,
                            source=APT.name)
    text = get_post("linuxcnc").write(posted, options)
    assert text == (GOLDEN / name).read_text(encoding="ascii")
    check_against_rs274(posted, toolpaths, interpret(text, tmp_path, name))


def test_identical_inputs_give_identical_bytes() -> None:
    first = render("linuxcnc_joint.ngc")
    second = render("linuxcnc_joint.ngc")
    assert first == second
    assert "20" not in first.splitlines()[0]  # no date in the header line


def test_same_path_from_another_folder_gives_the_same_program(tmp_path: Path) -> None:
    from postproc.command import post_text

    copy = tmp_path / APT.name
    copy.write_bytes(APT.read_bytes())
    assert post_text(copy, SIM) == render("linuxcnc_joint.ngc")


@pytest.mark.parametrize("name", sorted(CASES))
def test_nc_reader_reads_back_the_posted_blocks(name: str) -> None:
    """The project's NC reader recovers the posted blocks from the written text."""
    from postproc.nc_reader import parse_nc

    case = CASES[name]
    options = PostOptions(tcp=case.get("tcp", False),
                          chordal_tolerance=case.get("tolerance", 0.01),
                          angular_tolerance=np.radians(case.get("angular_tolerance_deg", 0.5)),
                          block_numbers=case.get("block_numbers", False),
                          program_number=case.get("program_number"),
                          dialect_options=case.get("post_options", {}))
    machine = load_machine(case["machine"])
    posted = post_toolpaths(read_apt(APT), machine, options, source=APT.name)
    text = get_post(case["post"]).write(posted, options)
    assert text == (GOLDEN / name).read_text(encoding="ascii")
    read = parse_nc(text, name, machine=machine)
    blocks = posted.blocks
    assert len(read) == len(blocks)
    if "frames" in case.get("post_options", {}):
        # 3+2 frames: tool poses in W as posted (frame blocks read back as TCP blocks)
        kins = kinematics_for(machine)
        tip, axis = kins.forward(read.joints)
        offset = kins.world_from_workpiece(np.zeros((1, 3)))[0]  # type: ignore[attr-defined]
        tip[read.tcp] = read.joints[read.tcp, :3] - offset
        expected_tip, expected_axis = kins.forward(posted.machine_joints)
        assert np.nanmax(np.abs(tip - expected_tip)) <= 2e-4
        assert np.nanmax(np.abs(axis - expected_axis)) <= 2e-6
        assert np.array_equal(read.motion, blocks.motion)
        assert np.array_equal(read.tool_number, blocks.tool_number)
        return
    known = posted.present & np.isfinite(blocks.joints)
    assert np.abs(read.joints - blocks.joints)[known].max() <= 0.51e-4  # mm; rad is finer
    assert np.array_equal(read.motion, blocks.motion)
    assert np.array_equal(read.tcp, blocks.tcp)
    assert np.array_equal(read.tool_number, blocks.tool_number)
    cutting = np.isfinite(blocks.feed)
    dialect = get_post(case["post"])
    feeds = getattr(dialect, "feed_words", lambda *_: None)(posted, options)
    mode, feed = (blocks.feed_mode, blocks.feed) if feeds is None else feeds
    if feeds is None:
        assert np.array_equal(read.feed_mode, blocks.feed_mode)
    else:  # path feed: same block durations as the posted inverse-time feeds
        assert np.all(read.feed_mode == FeedMode.UNITS_PER_MINUTE)
    assert np.allclose(read.feed[cutting], feed[cutting], rtol=1e-5, atol=0.51e-3)
