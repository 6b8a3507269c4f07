"""NC reader: generated programs read back, hand-written ISO / LinuxCNC snippets, arcs,
errors, and a cross-check against LinuxCNC's own interpreter (rs274) when installed."""

from __future__ import annotations

import math
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from impeller_cam.errors import InputError
from postproc.gcode_arcs import arc_centre_from_radius, arc_sweep, chord_count, linearise_arc
from postproc.nc_fast import split_lines
from postproc.nc_reader import parse_nc, parse_nc_document, read_nc
from postproc.program import FeedMode, Motion

RS274 = shutil.which("rs274") or ("/usr/bin/rs274" if Path("/usr/bin/rs274").exists() else None)


def _fmt(value: float) -> str:
    text = f"{value:.4f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


# ----------------------------------------------------------------------------------------
# Property test: a generated program reads back into the blocks it was made from

_ACTIONS = ["move", "move", "move", "move", "units", "distance", "feedmode", "tcp", "tool",
            "comment", "blank"]


@settings(max_examples=80, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), count=st.integers(1, 40))
def test_generated_program_reads_back(seed: int, count: int) -> None:
    rng = np.random.default_rng(seed)
    lines = ["%", "O1001 (generated)", "G17 G21 G90 G94 G40 G49 G80"]
    position = np.zeros(5)
    inch = incremental = inverse = False
    feed_known = False
    g43 = kins = False
    tool = 0
    expected = []  # (joints, motion, feed_mode, feed, line, tcp, tool)
    for _ in range(count):
        action = _ACTIONS[rng.integers(len(_ACTIONS))]
        words = []
        if rng.random() < 0.3:
            words.append(f"N{rng.integers(1, 99999)}")
        if action == "units":
            inch = bool(rng.random() < 0.5)
            words.append("G20" if inch else "G21")
        elif action == "distance":
            incremental = bool(rng.random() < 0.5)
            words.append("G91" if incremental else "G90")
        elif action == "feedmode":
            inverse = bool(rng.random() < 0.5)
            words.append("G93" if inverse else "G94")
            feed_known = False
        elif action == "tcp":
            choice = rng.integers(4)
            words.append(["G43.4 H1", "G49", "M428", "M429"][choice])
            g43 = True if choice == 0 else (False if choice == 1 else g43)
            kins = True if choice == 2 else (False if choice == 3 else kins)
        elif action == "tool":
            tool = int(rng.integers(1, 20))
            words.append(f"T{tool} M6")
        elif action == "comment":
            words.append(rng.choice(["(just a comment)", "; semicolon comment", "(MSG, hi)"]))
        elif action == "move":
            rapid = bool(rng.random() < 0.3)
            words.append("G0" if rapid else "G1")
            axes = [a for a in "XYZAC" if rng.random() < 0.5] or ["X"]
            end = position.copy()
            scale = 25.4 if inch else 1.0
            for a in axes:
                j = "XYZAC".index(a)
                text = _fmt(rng.uniform(-50, 50) if not incremental else rng.uniform(-5, 5))
                value = float(text)
                words.append(f"{a}{text}")
                value = value * scale if j < 3 else math.radians(value)
                end[j] = end[j] + value if incremental else value
            feed = math.nan
            if not rapid:
                if inverse or not feed_known or rng.random() < 0.3:
                    f_text = _fmt(rng.uniform(1, 3000))
                    words.append(f"F{f_text}")
                    feed_value = float(f_text) * (1.0 if inverse else (25.4 if inch else 1.0))
                    feed_known = not inverse
                    if not inverse:
                        last_feed = feed_value
                    feed = feed_value
                else:
                    feed = last_feed
            position = end
            expected.append((end, Motion.RAPID if rapid else Motion.LINEAR,
                             FeedMode.INVERSE_TIME if inverse else FeedMode.UNITS_PER_MINUTE,
                             feed, len(lines) + 1, g43 or kins, tool))
        lines.append(" ".join(words))
    lines += ["M30", "%"]
    program = parse_nc("\n".join(lines) + "\n")
    assert len(program) == len(expected)
    if expected:
        np.testing.assert_allclose(program.joints, np.array([e[0] for e in expected]),
                                   rtol=0, atol=1e-9)
        assert program.motion.tolist() == [int(e[1]) for e in expected]
        assert program.feed_mode.tolist() == [int(e[2]) for e in expected]
        np.testing.assert_allclose(program.feed, [e[3] for e in expected], rtol=1e-12)
        assert program.line.tolist() == [e[4] for e in expected]
        assert program.tcp.tolist() == [e[5] for e in expected]
        assert program.tool_number.tolist() == [e[6] for e in expected]


# ----------------------------------------------------------------------------------------
# Hand-written snippets

FANUC = """%
O2001 (IMPELLER FINISH)
N10 G21 G17 G40 G49 G80 G90 G94
N20 T5 M6
N30 S14000 M3
N40 G54 G0 X0 Y0 A0 C0 (positioning)
N50 G43.4 H5 Z90.
N60 G93 G1 X10. Y2. Z60.5 A4. C-30. F250.
N70 X10. Y4. Z61. A8. C-28. F240.
N80 G49 G94 G0 Z100.
N90 G53 G0 Z0.
N100 M5
N110 M30
%
"""


def test_fanuc_snippet_with_tcp_inverse_time_and_g53() -> None:
    doc = parse_nc_document(FANUC, "O2001.nc")
    p = doc.program
    assert p.line.tolist() == [6, 7, 8, 9, 10, 11]
    np.testing.assert_allclose(p.joints[2], [10, 2, 60.5, math.radians(4), math.radians(-30)])
    np.testing.assert_allclose(p.joints[5], [10, 4, 0, math.radians(8), math.radians(-28)])
    assert p.tcp.tolist() == [False, True, True, True, False, False]  # G53: a joint move
    assert p.motion.tolist() == [0, 0, 1, 1, 0, 0]
    assert p.feed_mode.tolist() == [94, 94, 93, 93, 94, 94]
    np.testing.assert_allclose(p.feed[2:4], [250.0, 240.0])
    assert p.tool_number.tolist() == [5] * 6
    assert any("work offset" in n.message for n in doc.notes)


LINUXCNC = """; LinuxCNC xyzac-trt with switchable kinematics
G21 G90 G94 G64 P0.01
T2 M6 G43 H2
M429 (identity kinematics)
G0 X0 Y0 Z50 A0 C0
M428 (TCP kinematics)
G1 X5 Y0 Z10 F600
/G1 X6
G91 G1 X1 C10
G90
M429
G0 Z50
M0
G28 G91 Z0
M2
G0 X99
"""


def test_linuxcnc_snippet_with_switchkins_and_notes() -> None:
    doc = parse_nc_document(LINUXCNC)
    p = doc.program
    assert p.line.tolist() == [5, 7, 8, 9, 12]
    assert p.tcp.tolist() == [False, True, True, True, False]
    np.testing.assert_allclose(p.joints[3], [7, 0, 10, 0, math.radians(10)])
    messages = " | ".join(f"{n.line}:{n.message}" for n in doc.notes)
    assert "8:block-delete" in messages
    assert "13:M0 ignored" in messages
    assert "14:G28/G30 reference return" in messages
    assert "16:block after program end" in messages


def test_units_inch_feed_keeps_its_physical_value() -> None:
    p = parse_nc("G21 G90 G94\nG1 X1 F100\nG20\nG1 X1\nG1 X2 F10\nG21 G91 G1 X1\n")
    np.testing.assert_allclose(p.joints[:, 0], [1.0, 25.4, 50.8, 51.8])
    np.testing.assert_allclose(p.feed, [100.0, 100.0, 254.0, 254.0])


def test_rotary_axes_are_degrees_in_and_radians_out_and_never_scaled_by_g20() -> None:
    p = parse_nc("G20 G0 A90 C-180\nG91 G0 A-45 C360\n")
    np.testing.assert_allclose(p.joints[:, 3:], [[math.pi / 2, -math.pi], [math.pi / 4, math.pi]])


def test_g28_with_known_home_and_g28_followed_by_motion() -> None:
    home = [0.0, 0.0, 400.0, 0.0, 0.0]
    p = parse_nc("G0 X10 Y10 Z50\nG91 G28 Z0\nG90 G0 X20\n", home=home)
    np.testing.assert_allclose(p.joints[1:], [[10, 10, 50, 0, 0], [10, 10, 400, 0, 0],
                                              [20, 10, 400, 0, 0]])
    assert p.line.tolist() == [1, 2, 2, 3]
    with pytest.raises(InputError, match="line 3: motion after the G28/G30 reference return"):
        parse_nc("G0 X10\nG28\nG0 X20\n")


def test_start_position_and_custom_switchkins_mapping() -> None:
    p = parse_nc("G91 G0 X1\nM429\nG0 X1\n", start=[10, 0, 0, 0, 0], switchkins={429: True})
    np.testing.assert_allclose(p.joints[:, 0], [11, 12])
    assert p.tcp.tolist() == [False, True]
    np.testing.assert_allclose(p.start, [10, 0, 0, 0, 0])


# ----------------------------------------------------------------------------------------
# Arcs: formulas against hand-computed cases, then linearisation


def test_arc_centre_from_radius_hand_cases() -> None:
    # G3 (CCW) from (1,0) to (0,1), R1: the quarter circle about the origin.
    assert arc_centre_from_radius(1, 0, 0, 1, 1.0, clockwise=False) == pytest.approx((0, 0))
    # the long way round, centre (1,1).
    assert arc_centre_from_radius(1, 0, 0, 1, -1.0, clockwise=False) == pytest.approx((1, 1))
    # G2 (CW) R1: the short clockwise arc, centre (1,1).
    assert arc_centre_from_radius(1, 0, 0, 1, 1.0, clockwise=True) == pytest.approx((1, 1))
    assert arc_centre_from_radius(0, 0, 4, 0, 1.0, clockwise=True) is None  # R < chord/2
    assert arc_centre_from_radius(0, 0, 0, 0, 1.0, clockwise=True) is None


def test_arc_sweep_and_chord_count_hand_cases() -> None:
    assert arc_sweep(1, 0, 0, 1, 0, 0, clockwise=False) == pytest.approx(math.pi / 2)
    assert arc_sweep(1, 0, 0, 1, 0, 0, clockwise=True) == pytest.approx(-1.5 * math.pi)
    assert arc_sweep(1, 0, 1, 0, 0, 0, clockwise=True) == pytest.approx(-2 * math.pi)
    assert arc_sweep(1, 0, 1, 0, 0, 0, clockwise=False, turns=2) == pytest.approx(4 * math.pi)
    # r = 10, tol = 0.01: dtheta = 2 acos(0.999) ~ 2 sqrt(0.002) (1 + 0.001 / 12) = 0.0894502;
    # pi/2 / dtheta = 17.56 -> 18 chords
    assert 2 * math.acos(0.999) == pytest.approx(0.0894502, abs=1e-7)
    assert chord_count(10.0, math.pi / 2, 0.01) == 18
    assert chord_count(0.001, math.pi, 0.01) == 2  # at most a quarter turn per chord


def test_linearised_arc_stays_within_the_chordal_tolerance() -> None:
    start = np.array([10.0, 0.0, 0.0, 0.0, 0.0])
    end = np.array([0.0, 10.0, 5.0, 0.2, 0.4])
    points = linearise_arc(start, end, 0.0, 0.0, math.pi / 2, 0.01)
    assert len(points) == 18
    np.testing.assert_array_equal(points[-1], end)
    np.testing.assert_allclose(np.hypot(points[:, 0], points[:, 1]), 10.0, atol=1e-12)
    vertices = np.vstack([start, points])
    mid = 0.5 * (vertices[1:, :2] + vertices[:-1, :2])
    sagitta = 10.0 - np.hypot(mid[:, 0], mid[:, 1])
    assert sagitta.max() <= 0.01 and sagitta.max() > 0.005
    np.testing.assert_allclose(np.diff(vertices[:, 2]), 5.0 / 18)  # helix: Z linear in angle


def test_g2_g3_blocks_ij_r_full_circle_and_inverse_time() -> None:
    text = ("G21 G90 G17 G94 G1 X10 Y0 F300\n"
            "G3 X0 Y10 I-10 J0\n"  # quarter circle CCW about the origin
            "G2 X10 Y0 R10\n"  # back, clockwise short arc about the origin
            "G90.1 G3 X10 Y0 I0 J0\n"  # full circle, absolute centre
            "G91.1 G93 G2 X0 Y-10 R10 F2\n")
    p = parse_nc(text, chordal_tolerance=0.01)
    lines = p.line
    quarter = p.joints[lines == 2]
    assert len(quarter) == 18 and np.allclose(quarter[-1, :2], [0, 10])
    assert np.all(quarter[:, 0] >= -1e-12) and np.all(quarter[:, 1] >= -1e-12)
    np.testing.assert_allclose(np.hypot(p.joints[lines == 3, 0], p.joints[lines == 3, 1]), 10)
    full = p.joints[lines == 4]
    assert len(full) == 71 and np.allclose(full[-1, :2], [10, 0])  # ceil(2 pi / 0.0894502)
    inverse = lines == 5
    assert np.all(p.feed_mode[inverse] == FeedMode.INVERSE_TIME)
    assert np.allclose(p.feed[inverse], 2.0 * inverse.sum())  # each chord: 1/(F k) min


# ----------------------------------------------------------------------------------------
# Errors name the file, line, word and value


@pytest.mark.parametrize(
    ("text", "pattern", "field"),
    [
        ("G1 X1\n", r"line 1: feed move with no feed rate", "F"),
        ("X1\n", r"line 1: axis words without a motion mode", "G"),
        ("G93 G1 X1 F100\nG1 X2\n", r"line 2: inverse-time \(G93\) feed move without", "F"),
        ("G0 B10\n", r"line 1: axis B is not a joint", "B"),
        ("M430\n", r"line 1: M430 selects user kinematics", "M"),
        ("G1 X1 Y2 X3 F5\n", r"line 1: word X appears twice", "X"),
        ("G0 G1 X1\n", r"line 1: two motion codes", "G"),
        ("G41 D1\n", r"line 1: G41 \(cutter radius compensation\)", "G"),
        ("G81 X1 Y1 Z-1 R1\n", r"line 1: G81 \(canned cycles\)", "G"),
        ("G12.5\n", r"line 1: unknown G code G12.5", "G"),
        ("#1 = 5\n", r"line 1: malformed G-code word", "word"),
        ("o100 sub\n", r"line 1: malformed G-code word", "word"),
        ("G1 X[1+2] F5\n", r"line 1: malformed G-code word", "word"),
        ("G1 X1. Y F5\n", r"line 1: malformed G-code word", "word"),
        ("G0 X1 (unclosed\n", r"line 1: unbalanced comment", "comment"),
        ("G18 G2 X1 Z1 I1 F5\n", r"line 1: arcs outside the XY plane", "G"),
        ("G2 X1 Y1 K1 F5\n", r"line 1: K word in an XY-plane arc", "K"),
        ("G2 X1 Y1 F5\n", r"line 1: arc without I/J or R", "G2/G3"),
        ("G2 X10 Y0 I1 J0 F5\n", r"line 1: radius to the arc end", "I/J"),
        ("G2 X10 Y0 R2 F5\n", r"line 1: no arc of this radius", "R"),
        ("G91 G53 G0 Z0\n", r"line 1: G53 needs G0 or G1 in absolute mode", "G53"),
        ("G1 X1 F-5\n", r"line 1: negative feed", "F"),
        ("O100 G0 X1\n", r"line 1: program number O shares its line", "O"),
    ],
)
def test_errors_name_line_word_and_value(text: str, pattern: str, field: str) -> None:
    with pytest.raises(InputError, match=pattern) as info:
        parse_nc(text, source="job.ngc")
    assert info.value.file == "job.ngc"
    assert info.value.field == field


def test_read_nc_from_file(tmp_path: Path) -> None:
    path = tmp_path / "p.ngc"
    path.write_text("G0 X1\r\nG1 Y2 F100\r\n")
    p = read_nc(path)
    assert p.line.tolist() == [1, 2]
    with pytest.raises(InputError, match="cannot read"):
        read_nc(tmp_path / "missing.ngc")


# ----------------------------------------------------------------------------------------
# Cross-check against LinuxCNC's stand-alone interpreter

_CANON_RE = re.compile(r"(STRAIGHT_TRAVERSE|STRAIGHT_FEED|ARC_FEED)\(([^)]*)\)")


@pytest.mark.skipif(RS274 is None, reason="LinuxCNC rs274 not installed")
def test_end_points_match_linuxcnc_rs274(tmp_path: Path) -> None:
    rng = np.random.default_rng(3)
    lines = ["G21 G17 G90 G94 F500", "G0 X0 Y0 Z0 A0 C0"]
    for _ in range(40):
        r = rng.random()
        if r < 0.15:
            lines.append(rng.choice(["G90", "G91"]))
        elif r < 0.3:
            x0, y0, x1, y1 = (float(_fmt(v)) for v in rng.uniform(-10, 10, 4))
            half_chord = 0.5 * math.hypot(x1 - x0, y1 - y0)
            radius = _fmt((half_chord + rng.uniform(0.5, 10)) * rng.choice([-1, 1]))
            lines.append(f"G90 G0 X{_fmt(x0)} Y{_fmt(y0)}")
            lines.append(f"{rng.choice(['G2', 'G3'])} X{_fmt(x1)} Y{_fmt(y1)} "
                         f"Z{_fmt(rng.uniform(0, 5))} R{radius}")
        else:
            axes = " ".join(f"{a}{_fmt(rng.uniform(-20, 20))}" for a in "XYZAC"
                            if rng.random() < 0.6) or "X1"
            lines.append(f"{rng.choice(['G0', 'G1'])} {axes}")
    lines.append("M2")
    text = "\n".join(lines) + "\n"
    path = tmp_path / "check.ngc"
    path.write_text(text)
    assert RS274 is not None
    result = subprocess.run([RS274, "-g", str(path)], capture_output=True, text=True,
                            timeout=60, check=False)
    canon = _CANON_RE.findall(result.stdout)
    assert canon, result.stdout + result.stderr
    program = parse_nc(text)
    blocks = [program.joints[program.line == line]
              for line in dict.fromkeys(program.line.tolist())]
    assert len(blocks) == len(canon) > 30
    arcs = 0
    for (kind, args), rows in zip(canon, blocks, strict=True):
        v = [float(a) for a in args.split(",")]
        ours = rows[-1]
        if kind == "ARC_FEED":
            arcs += 1
            radius = np.hypot(rows[:, 0] - v[2], rows[:, 1] - v[3])  # about rs274's centre
            np.testing.assert_allclose(radius, radius[-1], atol=2e-4)
            theirs = [v[0], v[1], v[5], v[6], v[8]]
        else:
            theirs = [v[0], v[1], v[2], v[3], v[5]]
        expected = np.array(theirs[:3] + [math.radians(theirs[3]), math.radians(theirs[4])])
        np.testing.assert_allclose(ours, expected, atol=1e-4 + 1e-6)
    assert arcs > 0


# ----------------------------------------------------------------------------------------
# The bulk path for plain motion lines gives exactly what the block-by-block path gives


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_bulk_runs_equal_block_by_block(seed: int) -> None:
    rng = np.random.default_rng(seed)
    inverse = bool(rng.random() < 0.3)  # G93: every feed move carries its F
    lines = ["G21 G90 G93 G1 F500" if inverse else "G21 G90 G94 G1 F500"]
    for _ in range(300):
        r = rng.random()
        if r < 0.03:
            lines.append(str(rng.choice(["G90", "G91", "G20", "G21", "M428", "M429"])))
        elif r < 0.05:
            lines.append(f"G{rng.choice([2, 3])} X{_fmt(rng.uniform(5, 6))} R1000 F100")
        else:
            words = [f"N{rng.integers(1, 9999)}"] if rng.random() < 0.5 else []
            if rng.random() < 0.5:
                words.append(str(rng.choice(["G0", "G1", "G01", "g1"])))
            words += [f"{a}{_fmt(rng.uniform(-9, 9))}" for a in "XYZAC" if rng.random() < 0.6]
            if inverse or rng.random() < 0.5:
                words.append(f"F{_fmt(rng.uniform(1, 900))}")
            lines.append(" ".join(words))
    text = "\n".join(lines) + "\n"
    commented = "\n".join(f"{line} (slow)" for line in lines) + "\n"
    try:
        bulk = parse_nc(text)
    except InputError as error:
        with pytest.raises(InputError) as again:
            parse_nc(commented)
        assert str(again.value) == str(error)
        return
    slow = parse_nc(commented)
    for name in ("joints", "motion", "feed_mode", "feed", "line", "tcp", "tool_number"):
        np.testing.assert_array_equal(getattr(bulk, name), getattr(slow, name), err_msg=name)


def test_bulk_run_errors_are_the_block_by_block_errors() -> None:
    text = "G21 G90\n" + "".join(f"G1 X{i}\n" for i in range(20))
    with pytest.raises(InputError, match="line 2: feed move with no feed rate"):
        parse_nc(text)


@pytest.mark.parametrize("chunk", [1, 2, 3, 7])
def test_plain_line_columns_do_not_depend_on_the_chunk_size(chunk: int) -> None:
    text = "G1 X1 F5\n\nn7 g0 y-.5 c+2.\n(comment)\nG01X1Y2Z3A4C5F6\nG10 L2 P1\nX1"
    lines = text.split("\n")
    whole = split_lines(text, lines, chunk=10**6)
    parts = split_lines(text, lines, chunk=chunk)
    assert whole is not None and parts is not None
    assert whole.simple.tolist() == [True, True, True, False, True, False, True]
    assert whole.motion.tolist() == [1, -1, 0, -1, 1, -1, -1]
    np.testing.assert_array_equal(whole.values[4], [1, 2, 3, 4, 5])
    assert whole.values[2, 1] == -0.5 and whole.values[2, 4] == 2.0
    for name in ("simple", "motion", "values", "feed"):
        np.testing.assert_array_equal(getattr(parts, name), getattr(whole, name))


def test_utf8_byte_order_mark_is_skipped(tmp_path: Path) -> None:
    path = tmp_path / "bom.ngc"
    path.write_bytes(b"\xef\xbb\xbfG0 X1\n")
    assert read_nc(path).joints[0, 0] == 1.0
