"""APT CLDATA reader and writer: round trips, real-world snippets, errors."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from impeller_cam.errors import InputError
from postproc.apt import (
    format_apt,
    parse_apt,
    parse_apt_document,
    read_apt,
    read_apt_document,
    write_apt,
)
from postproc.toolpath import Cutter, MoveKind, Toolpath

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures" / "apt"


def _toolpath(tip, axis=None, feed=None, kind=None, **meta) -> Toolpath:
    tip = np.asarray(tip, float).reshape(-1, 3)
    n = len(tip)
    axis = np.tile([0.0, 0.0, 1.0], (n, 1)) if axis is None else axis
    kind = np.full(n, MoveKind.FEED, np.int8) if kind is None else np.asarray(kind, np.int8)
    if feed is None:
        feed = np.where(kind == MoveKind.RAPID, np.nan, 500.0)
    return Toolpath(tip=tip, axis=axis, feed=feed, kind=kind, **meta)


# ----------------------------------------------------------------------------------------
# Property test: write -> read gives the toolpaths back (within the written decimals)


@st.composite
def toolpaths(draw: st.DrawFn) -> list[Toolpath]:
    count = draw(st.integers(1, 3))
    out = []
    for op in range(count):
        rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
        runs = draw(st.lists(st.tuples(st.integers(1, 6), st.integers(-1, 2)), min_size=1,
                             max_size=5))
        seg_axes = {s: v / np.linalg.norm(v) for s, v in
                    ((s, rng.normal(size=3)) for s in range(3))}
        segment = np.concatenate([np.full(length, s, np.int32) for length, s in runs])
        n = len(segment)
        axis = rng.normal(size=(n, 3))
        axis /= np.linalg.norm(axis, axis=1)[:, None]
        for s, v in seg_axes.items():
            axis[segment == s] = v
        tip = rng.uniform(-500.0, 500.0, (n, 3))
        kind = rng.integers(0, 4, n).astype(np.int8)
        feed = np.round(rng.uniform(1.0, 20000.0, n), 1)
        feed[rng.random(n) < 0.5] = 800.0  # repeated feeds exercise the modal FEDRAT
        feed[kind == MoveKind.RAPID] = np.nan
        tool = draw(st.integers(0, 3))
        cutter = None if tool == 0 else Cutter(2.0 * tool, tool * 0.5, 10.0 * (tool % 2))
        name = draw(st.text(alphabet=st.characters(codec="ascii", categories=("L", "N")),
                            min_size=1, max_size=12)) + f" op{op}"
        out.append(Toolpath(tip=tip, axis=axis, feed=feed, kind=kind, segment=segment,
                            name=name, tool_number=tool, cutter=cutter,
                            spindle_rpm=draw(st.sampled_from([None, 12000.0, -8000.0])),
                            coolant=draw(st.booleans())))
    return out


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(paths=toolpaths(), decimals=st.integers(3, 8))
def test_round_trip_property(paths: list[Toolpath], decimals: int) -> None:
    text = format_apt(paths, decimals=decimals, header="round trip\nsecond line")
    back = parse_apt(text)
    assert len(back) == len(paths)
    lines = text.splitlines()
    position_tol = 0.5 * 10.0**-decimals + 1e-9
    axis_tol = 2.0 * 10.0 ** -max(decimals, 6)
    for a, b in zip(paths, back, strict=True):
        assert len(b) == len(a)
        np.testing.assert_allclose(b.tip, a.tip, rtol=0, atol=position_tol)
        np.testing.assert_allclose(b.axis, a.axis, rtol=0, atol=axis_tol)
        np.testing.assert_allclose(b.feed, a.feed, rtol=0, atol=position_tol)  # NaN == NaN
        np.testing.assert_array_equal(b.kind, a.kind)
        np.testing.assert_array_equal(b.segment, a.segment)
        assert (b.name, b.tool_number, b.spindle_rpm, b.coolant) == (
            a.name, a.tool_number, a.spindle_rpm, a.coolant)
        if a.cutter is None:
            assert b.cutter is None
        else:
            assert b.cutter is not None
            assert (b.cutter.diameter, b.cutter.corner_radius, b.cutter.length) == pytest.approx(
                (a.cutter.diameter, a.cutter.corner_radius, a.cutter.length), abs=position_tol)
        assert all(lines[r - 1].startswith("GOTO/") for r in b.source_records.tolist())


def test_format_is_deterministic_and_write_is_atomic(tmp_path: Path) -> None:
    path = _toolpath([[1, 2, 3], [4, 5, 6]], kind=[0, 1], name="a")
    text = format_apt([path], decimals=4, header="impeller-cam")
    assert text == format_apt([path], decimals=4, header="impeller-cam")
    out = write_apt(tmp_path / "sub" / "p.apt", [path], decimals=4, header="impeller-cam")
    assert out.read_text() == text
    assert sorted(p.name for p in out.parent.iterdir()) == ["p.apt"]


def test_written_text_hand_checked() -> None:
    axis = np.array([[0.0, 0.0, 1.0], [0.0, 0.6, 0.8], [0.0, 0.6, 0.8]])
    path = Toolpath(tip=np.array([[0, 0, 50], [-0.00001, 1.23456, 2], [3, 4, 5]]), axis=axis,
                    feed=np.array([np.nan, 250.0, 250.0]), kind=np.array([0, 2, 1], np.int8),
                    segment=np.array([-1, 0, 0], np.int32),
                    name="side (1)", tool_number=7, cutter=Cutter(6.0, 3.0),
                    spindle_rpm=-9000.0, coolant=True)
    expected = [
        "$$ head", "UNITS/MM", "MULTAX/ON", "$$ OPERATION/side (1)", "LOADTL/7",
        "CUTTER/6,3", "SPINDL/RPM,9000,CCLW", "COOLNT/ON", "RAPID",
        "GOTO/0.000,0.000,50.000,0.000000,0.000000,1.000000",
        "$$ SEGMENT/3+2,0", "$$ MOVE/PLUNGE", "FEDRAT/MMPM,250",
        "GOTO/0.000,1.235,2.000,0.000000,0.600000,0.800000",
        "$$ MOVE/FEED",
        "GOTO/3.000,4.000,5.000,0.000000,0.600000,0.800000",
        "SPINDL/OFF", "COOLNT/OFF", "FINI",
    ]
    assert format_apt([path], decimals=3, header="head").splitlines() == expected


def test_writer_refuses_what_it_cannot_write() -> None:
    with pytest.raises(ValueError, match="positive feed"):
        format_apt([_toolpath([[0, 0, 0]], feed=[np.nan])])
    with pytest.raises(ValueError, match="no poses"):
        format_apt([_toolpath(np.zeros((0, 3)))])
    with pytest.raises(ValueError, match="decimals"):
        format_apt([_toolpath([[0, 0, 0]])], decimals=13)


# ----------------------------------------------------------------------------------------
# Reading real-world shapes


def test_catia_style_fixture() -> None:
    doc = read_apt_document(FIXTURES / "catia_style_isoparametric.apt")
    assert doc.partno == "PART TO BE MACHINED"
    (path,) = doc.toolpaths
    assert path.name == "Isoparametric Machining.1"
    assert path.tool_number == 1
    assert path.cutter == Cutter(6.0, 3.0, 50.0)  # CUTTER/ continued with '$'
    assert path.spindle_rpm == 12000.0 and path.coolant
    assert len(path) == 8
    np.testing.assert_array_equal(path.kind, [0, 1, 1, 1, 1, 1, 1, 1])
    np.testing.assert_array_equal(path.feed[1:], [300, 1500, 1500, 1500, 1500, 1500, 300])
    assert np.isnan(path.feed[0])
    np.testing.assert_allclose(path.tip[2], [39.98630, 0.52357, 61.8])
    np.testing.assert_allclose(path.axis[-1], [0.422618, 0.0, 0.906308], atol=1e-6)
    np.testing.assert_allclose(np.linalg.norm(path.axis, axis=1), 1.0, atol=1e-12)
    assert path.source_records.tolist() == [23, 25, 27, 28, 29, 30, 31, 33]
    assert {n.record for n in doc.notes} >= {"PARTNO", "TPRINT", "REWIND", "END"}


def test_nx_style_fixture_segments_from_multax_off_and_tlaxis() -> None:
    doc = read_apt_document(FIXTURES / "nx_style_two_operations.apt")
    rough, finish = doc.toolpaths
    assert (rough.name, finish.name) == ("ROUGH_3P2_SIDE1", "FINISH_5AX")
    assert rough.tool_number == finish.tool_number == 2
    assert rough.cutter == finish.cutter == Cutter(8.0, 4.0, 60.0)  # same tool: kept
    np.testing.assert_array_equal(rough.segment, [0, 0, 0, 0, 1, 1])
    np.testing.assert_allclose(rough.axis[0], [0, -0.5, math.sqrt(3) / 2], atol=1e-7)
    np.testing.assert_allclose(rough.axis[4], [0, 0.5, math.sqrt(3) / 2], atol=1e-7)
    np.testing.assert_array_equal(rough.kind, [0, 1, 1, 1, 1, 0])
    np.testing.assert_array_equal(rough.feed[1:5], [250, 1200, 1200, 1200])
    np.testing.assert_array_equal(finish.segment, [-1, -1, -1])
    assert finish.spindle_rpm == 9000.0
    assert any(n.record == "PAINT" for n in doc.notes)
    assert any(n.record == "MSYS" for n in doc.notes)


def test_fusion_style_inch_fixture() -> None:
    (path,) = read_apt(FIXTURES / "fusion_style_inch.apt")
    assert path.tool_number == 3 and path.coolant and path.spindle_rpm == 8000.0
    assert path.cutter is not None
    assert path.cutter.diameter == pytest.approx(6.35)
    assert path.cutter.length == pytest.approx(25.4)
    np.testing.assert_allclose(path.tip, [[25.4, 12.7, 25.4], [25.4, 12.7, 5.08],
                                          [30.48, 12.7, 5.08], [30.48, 17.78, 5.08]])
    np.testing.assert_allclose(path.feed[1:], [508.0, 508.0, 1016.0])  # 20 and 40 in/min
    assert path.source_records.tolist() == [10, 12, 13, 15]


def test_case_spacing_continuation_comments_and_crlf() -> None:
    text = (
        "$$ exported by someone\r\n"
        "multax / on\r\n"
        "  fedrat /  mmpm , 500\r\n"
        "\tGoTo  /  1 , 2 , 3 , 0 , 0 , 1   $$ trailing comment\r\n"
        "GOTO/4,5,$\r\n"
        "   6,0,$\r\n"
        "  1,0\r\n"
        "\r\n"
        "GOTO/+7.,-.5,1.0E+01\r\n"
    )
    (path,) = parse_apt(text)
    np.testing.assert_allclose(path.tip, np.array([[1, 2, 3], [4, 5, 6], [7, -0.5, 10.0]]))
    np.testing.assert_allclose(path.axis, [[0, 0, 1], [0, 1, 0], [0, 1, 0]])  # axis stays
    assert path.source_records.tolist() == [4, 5, 9]


def test_three_axis_goto_defaults_to_plus_z_and_tlaxis_sets_axis() -> None:
    text = "FEDRAT/100\nGOTO/0,0,0\nTLAXIS/0,1,0\nGOTO/1,0,0\nGOTO/2,0,0,1,0,0\nGOTO/3,0,0\n"
    (path,) = parse_apt(text)
    np.testing.assert_allclose(path.axis, [[0, 0, 1], [0, 1, 0], [1, 0, 0], [1, 0, 0]])
    np.testing.assert_array_equal(path.segment, [-1, -1, -1, -1])  # MULTAX not OFF


@pytest.mark.parametrize(
    ("record", "feed"),
    [("FEDRAT/MMPM,500", 500.0), ("FEDRAT/500,MMPM", 500.0), ("FEDRAT/500", 500.0),
     ("FEDRAT/IPM,10", 254.0), ("FEDRAT/ 10 , IPM", 254.0),
     ("SPINDL/RPM,1000\nFEDRAT/MMPR,0.2", 200.0), ("SPINDL/1000,RPM\nFEDRAT/IPR,0.01", 254.0)],
)
def test_fedrat_forms(record: str, feed: float) -> None:
    (path,) = parse_apt(f"{record}\nGOTO/0,0,0\n")
    assert path.feed[0] == pytest.approx(feed)


def test_rapid_applies_to_the_next_goto_only() -> None:
    text = "FEDRAT/300\nRAPID\n$$ a comment between\nGOTO/0,0,9\nGOTO/0,0,1\nRAPID\nGOTO/0,0,9\n"
    (path,) = parse_apt(text)
    np.testing.assert_array_equal(path.kind, [0, 1, 0])
    assert np.isnan(path.feed[[0, 2]]).all() and path.feed[1] == 300.0


def test_operations_from_loadtl_and_markers() -> None:
    text = (
        "$$ OPERATION/first\nLOADTL/1\nCUTTER/10,5\nFEDRAT/100\nGOTO/0,0,0\n"
        "LOADTL/2\nGOTO/1,0,0\n"  # a new tool: a new, unnamed operation without cutter
        "$$ OPERATION/third\nGOTO/2,0,0\n"  # same tool, new operation
        "LOADTL/3\n"  # no motion after it: no operation
    )
    first, second, third = parse_apt(text)
    assert (first.name, second.name, third.name) == ("first", "operation-2", "third")
    assert (first.tool_number, second.tool_number, third.tool_number) == (1, 2, 2)
    assert first.cutter == Cutter(10.0, 5.0) and second.cutter is None
    assert third.feed[0] == 100.0  # FEDRAT is modal across operations


def test_segment_markers_and_inconsistent_segment_axis() -> None:
    text = ("FEDRAT/100\n$$ SEGMENT/3+2,4\nGOTO/0,0,0,0,1,0\nGOTO/1,0,0,0,1,0\n"
            "$$ SEGMENT/5AXIS\nGOTO/2,0,0,1,0,0\n")
    (path,) = parse_apt(text)
    np.testing.assert_array_equal(path.segment, [4, 4, -1])
    with pytest.raises(InputError, match="line 4.*segment 4"):
        parse_apt(text.replace("GOTO/1,0,0,0,1,0", "GOTO/1,0,0,1,0,0"))


def test_notes_for_records_without_motion_meaning() -> None:
    text = ("PARTNO/IMPELLER\nUNITS/MM\nCLRSRF/50\nPPRINT/hello/world\nINSERT G54\n"
            "TLAXIS/NORMPS\nCOOLNT/MIST\nWIDGET/3\nFEDRAT/100\nGOTO/0,0,0\nFINI\nPPRINT/late\n")
    doc = parse_apt_document(text)
    records = [n.record for n in doc.notes]
    assert records == ["PARTNO", "UNITS", "CLRSRF", "PPRINT", "INSERT", "TLAXIS", "WIDGET",
                       "PPRINT"]
    assert "unrecognised" in doc.notes[6].message and "after FINI" in doc.notes[7].message
    assert doc.partno == "IMPELLER" and doc.toolpaths[0].coolant


def test_bulk_and_record_by_record_parsing_agree() -> None:
    rng = np.random.default_rng(7)
    n = 2000
    tip = rng.uniform(-100, 100, (n, 3))
    axis = rng.normal(size=(n, 3))
    axis /= np.linalg.norm(axis, axis=1)[:, None]
    path = _toolpath(tip, axis=axis, feed=np.full(n, 1000.0))
    text = format_apt([path], decimals=5)
    slow = text.replace("\nGOTO/", "\nGOTO/ $\n")  # every GOTO continued: record by record
    (fast_read,) = parse_apt(text)
    (slow_read,) = parse_apt(slow)
    np.testing.assert_array_equal(fast_read.tip, slow_read.tip)
    np.testing.assert_array_equal(fast_read.axis, slow_read.axis)
    np.testing.assert_allclose(fast_read.tip, tip, atol=5e-6)


# ----------------------------------------------------------------------------------------
# Errors name the file, line, record and value


@pytest.mark.parametrize(
    ("text", "pattern", "field"),
    [
        ("FEDRAT/100\nGOTO/1,2,abc\n", r"line 2: GOTO/ holds a value", "GOTO"),
        ("FEDRAT/100\nGOTO/1,2,3,4\n", r"line 2: GOTO/ has 4 numbers", "GOTO"),
        ("FEDRAT/100\nGOTO/1,2,3,0,0,2\n", r"line 2: GOTO/ tool axis has length 2", "GOTO"),
        ("FEDRAT/100\nGOTO/1,2,nan\n", r"line 2: GOTO/ holds a value", "GOTO"),
        ("GOTO/1,2,3\n", r"line 1: cutting GOTO/ before any FEDRAT", "GOTO"),
        ("FEDRAT/100\nFINI\nGOTO/1,2,3\n", r"line 3: GOTO/ after FINI", "GOTO"),
        ("FEDRAT/fast\n", r"line 1: FEDRAT/ needs one feed value", "FEDRAT"),
        ("FEDRAT/-5\n", r"line 1: FEDRAT/ feed must be positive", "FEDRAT"),
        ("FEDRAT/MMPR,0.1\n", r"line 1: a per-revolution feed", "FEDRAT"),
        ("CIRCLE/0,0,0,0,0,1,5\n", r"line 1: CIRCLE/ has a motion meaning", "CIRCLE"),
        ("CUTCOM/LEFT\n", r"line 1: cutter compensation", "CUTCOM"),
        ("CUTTER/-6\n", r"line 1: CUTTER/ describes an impossible cutter", "CUTTER"),
        ("LOADTL/A\n", r"line 1: tool number", "LOADTL"),
        ("UNITS/FEET\n", r"line 1: unknown length unit", "UNITS"),
        ("$$ SEGMENT/3+2,x\n", r"line 1: malformed fixed-orientation marker", "$$ SEGMENT"),
        ("FEDRAT/100\nGOTO/1,2,$\n", r"line 2: '\$' continuation at the end", "$"),
        ("MSYS/1,0,0,1,0,0,0,1,0\n", r"line 1: a machine coordinate system", "MSYS"),
        ("12,3\n", r"line 1: a CL record must start with a major word", "record"),
    ],
)
def test_errors_name_line_record_and_value(text: str, pattern: str, field: str) -> None:
    with pytest.raises(InputError, match=pattern) as info:
        parse_apt(text, source="job.apt")
    assert info.value.file == "job.apt"
    assert info.value.field == field
    assert info.value.value is not None


def test_read_apt_missing_file_is_input_error(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="cannot read"):
        read_apt(tmp_path / "missing.apt")


def test_own_sample_fixture_is_a_golden_file() -> None:
    sample = FIXTURES / "impeller_cam_3p2_then_5axis.apt"
    paths = read_apt(sample)
    assert [p.name for p in paths] == ["rough side 1", "finish blade 1"]
    np.testing.assert_array_equal(paths[0].segment, 0)
    np.testing.assert_array_equal(paths[0].kind, [0, 2, 1, 1, 1, 3])
    np.testing.assert_array_equal(paths[1].segment, -1)
    header = "impeller-cam sample: 3+2 roughing then 5-axis finishing\nworkpiece frame W, mm"
    assert format_apt(paths, decimals=4, header=header) == sample.read_text()


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(paths=toolpaths(), seed=st.integers(0, 2**32 - 1))
def test_reader_ignores_case_spacing_comments_and_continuations(paths: list[Toolpath],
                                                                 seed: int) -> None:
    """Rewrite our CL text the way other exporters shape it: the reading is unchanged."""
    rng = np.random.default_rng(seed)
    text = format_apt(paths, decimals=5)
    reshaped = []
    for line in text.splitlines():
        if not line.startswith("$$"):
            if rng.random() < 0.3:
                line = line.lower()
            if rng.random() < 0.3:
                line = line.replace("/", "  /  ", 1).replace(",", " , ")
            if rng.random() < 0.2 and "," in line:
                head, tail = line.split(",", 1)
                line = f"{head},$\n      {tail}"
            if rng.random() < 0.2:
                line = "  " + line + "   $$ note"
        reshaped.append(line)
        if rng.random() < 0.1:
            reshaped.append("$$ an exporter's comment")
    back = parse_apt("\r\n".join(reshaped) + "\r\n")
    plain = parse_apt(text)
    assert len(back) == len(plain)
    for a, b in zip(plain, back, strict=True):
        for name in ("tip", "axis", "feed", "kind", "segment"):
            np.testing.assert_array_equal(getattr(b, name), getattr(a, name), err_msg=name)
        assert (b.name, b.tool_number, b.cutter, b.spindle_rpm, b.coolant) == (
            a.name, a.tool_number, a.cutter, a.spindle_rpm, a.coolant)


def test_utf8_byte_order_mark_is_skipped(tmp_path: Path) -> None:
    path = tmp_path / "bom.apt"
    path.write_bytes(b"\xef\xbb\xbfFEDRAT/100\r\nGOTO/1,2,3\r\n")
    (toolpath,) = read_apt(path)
    np.testing.assert_array_equal(toolpath.tip, [[1.0, 2.0, 3.0]])
