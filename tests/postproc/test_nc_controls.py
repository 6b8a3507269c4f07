"""The NC reader on Sinumerik and Heidenhain programs: variants, detection, refusals."""

from __future__ import annotations

import numpy as np
import pytest

from impeller_cam.errors import InputError
from postproc.machine import load_machine
from postproc.nc_controls import detect_dialect
from postproc.nc_reader import parse_nc, parse_nc_document
from postproc.program import FeedMode, Motion
from tests.postproc.golden.cases import SIM

SIEMENS = """%_N_VARIANTS_MPF
;$PATH=/_N_MPF_DIR
N10 G17 G90 G710 G40 G500 ; metric, frame off
N20 SOFT FFWON G642 COMPCAD
N30 T="MILL6" M6
N40 D1
N50 S8000 M3 M8
N60 CYCLE832(0.02,_ORI_FINISH,1)
N70 G0 X10 Y0 Z50 A10 C20
N80 TRAORI(1)
N90 ORIWKS ORIAXES
N100 G1 X=5 Y=-2.5 Z=40 A=12 C=380 F=300
N110 G93 X6 C=400 F2000
N120 G4 F2
N130 G94 X7 F500
N140 TRAFOOF
N150 MSG("done")
N160 M30
"""


def test_sinumerik_variants_are_read() -> None:
    doc = parse_nc_document(SIEMENS, "variants.mpf")
    prog = doc.program
    assert prog.line.tolist() == [9, 12, 13, 15]
    assert prog.motion.tolist() == [Motion.RAPID, Motion.LINEAR, Motion.LINEAR, Motion.LINEAR]
    assert prog.tcp.tolist() == [False, True, True, True]
    assert prog.tool_number.tolist() == [1001] * 4  # named tool: numbered by first use
    assert np.allclose(prog.joints[1], [5, -2.5, 40, np.radians(12), np.radians(380)])
    assert np.allclose(prog.joints[2, [0, 4]], [6, np.radians(400)])
    assert prog.feed_mode.tolist()[1:] == [FeedMode.UNITS_PER_MINUTE, FeedMode.INVERSE_TIME,
                                          FeedMode.UNITS_PER_MINUTE]
    assert prog.feed.tolist()[1:] == [300.0, 2000.0, 500.0]  # G4 F2 is a dwell, not a feed


HEIDENHAIN = """0 BEGIN PGM VARIANTS MM
1 BLK FORM 0.1 Z X-50 Y-50 Z-20
2 BLK FORM 0.2 X+50 Y+50 Z+0
3 * - roughing
4 TOOL CALL 7 Z S9000 F500 DL+0 DR+0.1
5 CYCL DEF 32.0 TOLERANCE
6 CYCL DEF 32.1 T0.02
7 L Z+100 R0 FMAX M3
8 L X+10 Y+0 A+10 C+20 R0 FMAX M91
9 FUNCTION TCPM F TCP AXIS POS PATHCTRL AXIS
10 L X+1 Y+2 Z+3 F300
11 L X+2 FMAX
12 L X+3 ; comment
13 FUNCTION RESET TCPM
14 L M128
15 L X+4 C+30 F250
16 L M129
17 STOP
18 END PGM VARIANTS MM
"""


def test_heidenhain_variants_are_read() -> None:
    prog = parse_nc(HEIDENHAIN, "variants.h")
    assert prog.line.tolist() == [8, 9, 11, 12, 13, 16]
    assert prog.motion.tolist() == [0, 0, 1, 0, 1, 1]  # FMAX only in its own block
    assert prog.tcp.tolist() == [False, False, True, True, True, True]
    assert prog.feed[[2, 4, 5]].tolist() == [300.0, 300.0, 250.0]
    assert prog.tool_number.tolist() == [7] * 6
    assert np.allclose(prog.joints[1], [10, 0, 100, np.radians(10), np.radians(20)])


def test_dialect_detection() -> None:
    assert detect_dialect("G1 X1\n", "a.mpf") == "sinumerik"
    assert detect_dialect("G1 X1\n", "a.h") == "heidenhain"
    assert detect_dialect("  0  BEGIN PGM X MM\n", "a.nc") == "heidenhain"
    assert detect_dialect("G0 X0\nTRAORI\n", "a.nc") == "sinumerik"
    assert detect_dialect("G0 X0 A10\nM428\n", "a.ngc") == "gcode"
    with pytest.raises(InputError, match="unknown NC dialect"):
        parse_nc("G0 X1\n", dialect="okuma")


@pytest.mark.parametrize(("text", "source", "words"), [
    ("N10 GOTOF LOOP\n", "a.mpf", "GOTOF"),
    ("N10 R1=5\n", "a.mpf", "R1="),
    ("N10 G1 X=IC(5) F100\n", "a.mpf", "expression"),
    ("N10 ORIMKS\n", "a.mpf", "machine frame"),
    ("N10 TRANS X10\n", "a.mpf", "TRANS"),
    ("0 BEGIN PGM A MM\n1 LBL 1\n", "a.h", "LBL"),
    ("0 BEGIN PGM A MM\n1 CALL LBL 1 REP 3\n", "a.h", "repeats"),
    ("0 BEGIN PGM A MM\n1 L X+1 RL F100\n", "a.h", "radius compensation"),
    ("0 BEGIN PGM A MM\n1 CC X+0 Y+0\n", "a.h", "arcs"),
    ("0 BEGIN PGM A MM\n1 FUNCTION TCPM F TCP AXIS SPAT PATHCTRL AXIS\n", "a.h", "SPAT"),
    ("0 BEGIN PGM A MM\n1 Q1 = 5\n", "a.h", "Q parameters"),
    ('N10 CYCLE800(1,"TC1",0,57,0,0,0,30,0,20,0,0,0,1,0,0)\n', "a.mpf", "direct rotary"),
    ("0 BEGIN PGM A MM\n1 PLANE RELATIV SPA+10\n", "a.h", "PLANE function"),
    ("0 BEGIN PGM A MM\n1 PLANE AXIAL A+10 C+0 STAY\n", "a.h", "need the machine"),
    ('N10 CYCLE800(0,"TC1",0,192,0,0,0,30,20,0,0,0,0,1,0,0)\n', "a.mpf", "need the machine"),
])
def test_unsupported_words_are_refused_with_their_line(text: str, source: str,
                                                       words: str) -> None:
    with pytest.raises(InputError, match=words) as error:
        parse_nc(text, source)
    assert f"line {text.count(chr(10))}" in str(error.value)
    assert str(error.value.file) == source


def test_vectors_need_the_machine_and_become_joints() -> None:
    text = "N10 TRAORI\nN20 G1 X1 Y2 Z3 A3=0 B3=-0.5 C3=0.8660254 F100\n"
    with pytest.raises(InputError, match="machine"):
        parse_nc(text, "v.mpf")
    prog = parse_nc(text, "v.mpf", machine=load_machine(SIM))
    # sim: axis (0, -sin 30, cos 30) is A -30, C 0 or A +30, C 180; the branch next to
    # the joints before (A = C = 0) is A -30, C 0
    assert np.allclose(np.degrees(prog.joints[0, 3:]), [-30.0, 0.0], atol=1e-5)
    assert prog.tcp.tolist() == [True]
    lines = "0 BEGIN PGM V MM\n1 L M128\n2 LN X+1 Y+2 Z+3 TX+0 TY-0.5 TZ+0.8660254 F100\n"
    assert np.allclose(parse_nc(lines, "v.h", machine=load_machine(SIM)).joints, prog.joints)
    # other word orders take the word-by-word parser: the same block
    other = "N10 TRAORI\nN20 B3=-0.5 C3=0.8660254 G1 F100 X1 Y2 Z3 ; A3 left out = 0\n"
    assert np.allclose(parse_nc(other, "v.mpf", machine=load_machine(SIM)).joints, prog.joints)
    lines = "0 BEGIN PGM V MM\n1 L M128\n2 LN TX+0 TY-0.5 TZ+0.8660254 X+1 Y+2 Z+3 F100 M8\n"
    assert np.allclose(parse_nc(lines, "v.h", machine=load_machine(SIM)).joints, prog.joints)


def test_moves_in_a_tilted_frame_are_checked() -> None:
    machine = load_machine(SIM)
    head = 'N10 CYCLE800(0,"TC1",0,192,0,0,0,30,20,0,0,0,0,1,0,0)\n'
    with pytest.raises(InputError, match="must program X, Y and Z"):
        parse_nc(head + "N20 G1 X1 F100\n", "a.mpf", machine=machine)
    with pytest.raises(InputError, match="inside a tilted frame"):
        parse_nc(head + "N20 G1 X1 Y2 Z3 A=10 F100\n", "a.mpf", machine=machine)
    prog = parse_nc(head + "N20 G1 X1 Y2 Z3 F100\nN30 Z4\nN40 CYCLE800()\nN50 G0 Z100\n",
                    "a.mpf", machine=machine)
    assert prog.tcp.tolist() == [True, True, False]
    assert np.allclose(np.degrees(prog.joints[:2, 3:]), [[30, 20], [30, 20]])
    # the frame's Z' is the tool axis: Z3 -> Z4 moves the tip 1 mm along it
    from postproc.kinematics import kinematics_for

    _, axis = kinematics_for(machine).forward(prog.joints[:1])
    assert np.allclose(prog.joints[1, :3] - prog.joints[0, :3], axis[0])


@pytest.mark.parametrize("name", ["sinumerik_joint.mpf", "sinumerik_traori.mpf",
                                  "heidenhain_joint.h", "heidenhain_tcpm.h"])
def test_plain_lines_read_fast_as_the_word_parser_reads_them(name: str) -> None:
    from postproc.nc_controls import emit_rs274
    from postproc.nc_heidenhain import heidenhain_canons
    from postproc.nc_sinumerik import sinumerik_canons
    from tests.postproc.golden.cases import GOLDEN

    lines = (GOLDEN / name).read_text().split("\n")
    canons = sinumerik_canons if name.endswith(".mpf") else heidenhain_canons
    quick = canons(lines, name, True)
    assert sum(isinstance(entry, str) for entry in quick) > 20  # the fast path was taken
    fast = emit_rs274(quick, name, None)
    slow = emit_rs274(canons(lines, name, False), name, None)
    a, b = parse_nc(fast, name, dialect="gcode"), parse_nc(slow, name, dialect="gcode")
    for column in ("joints", "motion", "feed_mode", "line", "tcp", "tool_number"):
        assert np.array_equal(getattr(a, column), getattr(b, column)), column
    assert np.array_equal(a.feed, b.feed, equal_nan=True)


def test_words_in_comments_do_not_change_the_dialect() -> None:
    assert detect_dialect("(A = 5, TRAORI) G0 X1\n; C=3\n", "a.nc") == "gcode"
    assert detect_dialect("G0 X1 A=5\n", "a.ngc") == "gcode"  # .ngc is LinuxCNC's
    assert detect_dialect("G0 X=1\n", "a.nc") == "sinumerik"
