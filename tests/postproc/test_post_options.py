"""Post options (header/footer, tool change, spindle, coolant, numbering, decimals,
safety) and input errors. Every LinuxCNC program written here also runs through rs274."""

from __future__ import annotations

from dataclasses import replace
from math import radians
from pathlib import Path

import numpy as np
import pytest

from cam.cli import main
from impeller_cam.errors import InputError
from postproc.apt import read_apt
from postproc.machine import load_machine
from postproc.posting import Role, post_toolpaths
from postproc.posts import PostOptions, get_post
from postproc.program import Motion
from postproc.toolpath import MoveKind, Toolpath
from tests.postproc.post_check import check_against_rs274, interpret, with_records
from tests.postproc.post_paths import finishing_spiral, roughing_3p2

ROOT = Path(__file__).resolve().parents[2]
SIM_PATH = ROOT / "fixtures" / "machines" / "xyzac-trt.toml"
SIM = load_machine(SIM_PATH)
OPS = ROOT / "fixtures" / "apt" / "post_impeller_ops.apt"


def _linuxcnc(toolpaths: list[Toolpath], options: PostOptions, tmp_path: Path,
              machine=SIM) -> str:
    """Post with linuxcnc, run rs274 on it and check it against the CL poses."""
    toolpaths = with_records(toolpaths)
    posted = post_toolpaths(toolpaths, machine, options)
    text = get_post("linuxcnc").write(posted, options)
    check_against_rs274(posted, toolpaths, interpret(text, tmp_path))
    return text


def test_header_footer_are_sanitised_comments(tmp_path: Path) -> None:
    options = PostOptions(header=("job 7 (blade) ; M30", "MSG,hello"), footer=("end\nM2",))
    text = _linuxcnc([roughing_3p2()], options, tmp_path)
    lines = text.splitlines()
    assert "(job 7 ?blade? ? M30)" in lines
    assert "(_MSG,hello)" in lines
    assert lines[-2] == "(end M2)" and lines[-1] == "M2"


def test_no_tool_change_no_spindle_no_coolant(tmp_path: Path) -> None:
    options = PostOptions(tool_change=False, spindle=False, coolant=False)
    text = _linuxcnc([roughing_3p2(), finishing_spiral(30)], options, tmp_path)
    for word in ("M6", "M3", "M5", "M8", "M9", "G43 H", "S1"):
        assert word not in text


def test_tool_change_spindle_coolant_sequence(tmp_path: Path) -> None:
    text = _linuxcnc([roughing_3p2(), finishing_spiral(30)], PostOptions(), tmp_path)
    lines = text.splitlines()
    first = lines.index("T1 M6")
    assert lines[first - 1] == "G0 Z120"  # retract (no tool length yet: G49)
    assert lines[first + 1: first + 3] == ["S12000 M3", "M8"]
    assert lines[first + 3].startswith("G43 H1 Z120 A")
    second = lines.index("T2 M6")
    assert lines[second - 3: second] == ["G0 Z120", "M9", "M5"]
    assert lines[-3:] == ["M9", "M5", "M2"]


def test_block_numbers_and_decimals(tmp_path: Path) -> None:
    options = PostOptions(block_numbers=True, block_increment=5, decimals=3)
    text = _linuxcnc([roughing_3p2()], options, tmp_path)
    code = [line for line in text.splitlines() if not line.startswith("(")]
    numbers = [int(line.split()[0][1:]) for line in code]
    assert numbers == list(range(5, 5 * len(code) + 1, 5))
    words = [w for line in code for w in line.split()[1:] if w[0] in "XYZAC"]
    assert all(len(w.split(".")[1]) <= 3 for w in words if "." in w)


def test_program_number_is_a_comment_for_linuxcnc_and_an_o_word_for_fanuc(
    tmp_path: Path,
) -> None:
    options = PostOptions(program_number=77)
    assert "(program 77)" in _linuxcnc([roughing_3p2()], options, tmp_path)
    posted = post_toolpaths([roughing_3p2()], SIM, options)
    assert get_post("fanuc").write(posted, options).startswith("%\nO0077 (")


@pytest.mark.parametrize("tcp", [False, True], ids=["joint", "tcp"])
def test_machine_with_an_offset_c_rotation_point(tmp_path: Path, tcp: bool) -> None:
    """TCP words are world coordinates: W shifted by the C rotation point."""
    machine = replace(SIM, pivot=replace(SIM.pivot, x_rot_point=7.0, y_rot_point=-4.0,
                                         z_rot_point=3.0))
    _linuxcnc(read_apt(OPS), PostOptions(tcp=tcp), tmp_path, machine=machine)


@pytest.mark.parametrize("kwargs, field", [
    ({"program_number": 0}, "--program-number"),
    ({"program_number": 10000}, "--program-number"),
    ({"chordal_tolerance": 0.0}, "--tolerance"),
    ({"angular_tolerance": -1.0}, "--angular-tolerance"),
    ({"decimals": 0}, "decimals"),
])
def test_bad_options_are_input_errors(kwargs: dict, field: str) -> None:
    with pytest.raises(InputError) as error:
        PostOptions(**kwargs)
    assert error.value.field == field


def test_tolerance_finer_than_the_number_format_is_refused() -> None:
    with pytest.raises(InputError, match="decimals"):
        post_toolpaths([finishing_spiral(20)], SIM, PostOptions(chordal_tolerance=1e-4,
                                                                decimals=3))


def test_tcp_needs_a_tcp_machine() -> None:
    machine = replace(SIM, tcp=False)
    with pytest.raises(InputError, match="tool-centre-point"):
        post_toolpaths([roughing_3p2()], machine, PostOptions(tcp=True))


def test_feed_move_without_feed_is_input_error() -> None:
    path = finishing_spiral(10)
    path.feed[4] = np.nan
    with pytest.raises(InputError, match="feed"):
        post_toolpaths([path], SIM, PostOptions())


def test_without_safe_retract_rapids_turn_the_table_directly(tmp_path: Path) -> None:
    options = PostOptions(safe_retract=False)
    posted = post_toolpaths([roughing_3p2()], SIM, options)
    assert not np.isin(posted.role, [Role.RETRACT, Role.ORIENT, Role.POSITION]).any()
    _linuxcnc([roughing_3p2()], options, tmp_path)


def test_same_tool_same_orientation_continues_without_retract(tmp_path: Path) -> None:
    """Two operations with one tool, the second starting where the first ended."""
    spiral = finishing_spiral(30)
    first = Toolpath(tip=spiral.tip[:16], axis=spiral.axis[:16], feed=spiral.feed[:16],
                     kind=spiral.kind[:16], name="part 1", tool_number=2)
    second = Toolpath(tip=spiral.tip[15:], axis=spiral.axis[15:], feed=spiral.feed[15:],
                      kind=np.concatenate([[MoveKind.FEED], spiral.kind[16:]]).astype(np.int8),
                      name="part 2", tool_number=2)
    second.feed[0] = 1000.0
    _linuxcnc([first, second], PostOptions(), tmp_path)
    posted = post_toolpaths([first, second], SIM, PostOptions())
    op2 = posted.operation == 1
    assert not np.isin(posted.role[op2][:-1], [Role.RETRACT, Role.ORIENT]).any()


def test_gauge_length_counts_in_the_z_travel_check() -> None:
    # the spiral's retract and approach poses stay below Z 60; a 100 mm tool breaks Z 120
    options = PostOptions(tool_lengths={2: 100.0})
    with pytest.raises(InputError, match="axis Z"):
        post_toolpaths([finishing_spiral(20)], SIM, options)
    posted = post_toolpaths([finishing_spiral(20)], SIM, PostOptions(tool_lengths={2: 50.0}))
    retract = posted.role == Role.RETRACT
    # the first retract runs before the tool change (G49: no length), the last with it
    assert np.allclose(posted.machine_joints[retract, 2], [120.0, 120.0 - 50.0])


def test_cli_post_writes_the_file_and_rejects_bad_input(tmp_path: Path, capsys) -> None:
    out = tmp_path / "prog.ngc"
    assert main(["post", str(OPS), "-m", str(SIM_PATH), "-o", str(out)]) == 0
    assert out.read_text().endswith("M2\n")
    assert main(["post", str(OPS), "-m", str(SIM_PATH), "-o", str(tmp_path / "x.ngc"),
                 "--post", "nope"]) == 2
    assert "unknown post-processor" in capsys.readouterr().err
    assert main(["post", str(OPS), "-m", str(SIM_PATH), "-o", str(tmp_path / "y.ngc"),
                 "--tolerance", "-1"]) == 2
    assert main(["post", str(OPS), "-m", str(SIM_PATH), "-o", str(tmp_path / "z.nc"),
                 "--post", "fanuc", "--program-number", "123456"]) == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == ["prog.ngc"]
    check_against_rs274(post_toolpaths(read_apt(OPS), SIM, PostOptions()), read_apt(OPS),
                        interpret(out.read_text(), tmp_path, "copy.ngc"))


def test_angular_tolerance_is_respected(tmp_path: Path) -> None:
    """Under TCP only the axis criterion splits blocks."""
    options = PostOptions(tcp=True, angular_tolerance=radians(0.03))
    _linuxcnc(read_apt(OPS), options, tmp_path)
    loose = post_toolpaths(read_apt(OPS), SIM, PostOptions(tcp=True,
                                                           angular_tolerance=radians(2.0)))
    tight = post_toolpaths(read_apt(OPS), SIM, options)
    assert len(tight) > len(loose)
    assert np.count_nonzero(tight.blocks.motion == Motion.LINEAR) > 0


def test_hostile_operation_name_is_defused(tmp_path: Path) -> None:
    path = roughing_3p2()
    path.name = "x) G0 Z-500 (\r\nM30 ; " + "long " * 80
    text = _linuxcnc([path], PostOptions(), tmp_path)
    comment = [line for line in text.splitlines() if line.startswith("(OPERATION 1")][0]
    assert len(comment) <= 80 and comment.count("(") == 1 and comment.endswith(")")
    assert "M30" not in text.replace(comment, "")


def test_nothing_to_post_is_input_error(tmp_path: Path) -> None:
    empty = tmp_path / "empty.apt"
    empty.write_text("UNITS/MM\nFINI\n")
    out = tmp_path / "empty.ngc"
    assert main(["post", str(empty), "-m", str(SIM_PATH), "-o", str(out)]) == 2
    assert not out.exists()
