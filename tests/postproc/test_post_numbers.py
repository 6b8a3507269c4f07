"""Vectorised number formatting, modal word tracking and comment sanitising."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from postproc.posts.comments import FORBIDDEN, sanitise_comment
from postproc.posts.numbers import (
    UNKNOWN,
    assemble_lines,
    choice_bytes,
    modal_changes,
    quantise,
    word_bytes,
)


def _words(values, decimals=4, trailing_point=False, letter="X") -> list[str]:
    q = quantise(np.asarray(values, dtype=float), decimals)
    text = assemble_lines([word_bytes(letter, q, decimals, np.ones(len(q), bool),
                                      trailing_point=trailing_point)])
    return text.decode("ascii").splitlines()


def test_fixed_point_cases() -> None:
    assert _words([0.0, -0.00001, 1.0, 10.5, -0.25, 100.00009, 0.1, -1234.56789]) == [
        "X0", "X0", "X1", "X10.5", "X-0.25", "X100.0001", "X0.1", "X-1234.5679"]


def test_fanuc_trailing_point() -> None:
    assert _words([3.0, -3.0, 0.0, 2.5], trailing_point=True) == ["X3.", "X-3.", "X0.", "X2.5"]


def test_zero_decimals() -> None:
    assert _words([10.0, 20.4, -7.6], decimals=0, letter="N") == ["N10", "N20", "N-8"]


@settings(max_examples=300, deadline=None)
@given(st.lists(st.floats(min_value=-1e5, max_value=1e5, allow_nan=False), min_size=1,
                max_size=40), st.integers(min_value=0, max_value=6))
def test_formatted_numbers_read_back_as_rounded_values(values: list[float], decimals: int) -> None:
    words = _words(values, decimals=decimals)
    read = np.array([float(w[1:]) for w in words])
    expected = np.rint(np.asarray(values) * 10.0**decimals) / 10.0**decimals
    assert np.allclose(read, expected, rtol=0.0, atol=0.5 * 10.0**-decimals + 1e-9)
    assert all(len(w) > 1 and not w.endswith(".") for w in words)


def test_absent_words_and_empty_rows_vanish() -> None:
    q = quantise([1.0, 2.0, 3.0], 4)
    x = word_bytes("X", q, 4, np.array([True, False, True]))
    g = choice_bytes([" G0", " G1"], np.array([0, -1, 1]))
    assert assemble_lines([g, x]) == b"G0 X1\nG1 X3\n"
    assert assemble_lines([choice_bytes([" G0"], np.array([-1, -1]))]) == b""


def test_modal_changes() -> None:
    q = np.array([5, 5, 6, 6, 7, 7])
    present = np.array([True, True, True, False, True, True])
    assert modal_changes(q, present).tolist() == [True, False, True, False, True, False]
    assert modal_changes(q, present, before=5).tolist() == [False, False, True, False, True,
                                                            False]
    assert modal_changes(q, present, before=UNKNOWN)[0]


@pytest.mark.parametrize("text, expected", [
    ("rough (UMR 1)", "rough ?UMR 1?"),
    ("a)\nG0 X0 Y0 Z-50", "a? G0 X0 Y0 Z-50"),
    ("; M30", "? M30"),
    ("MSG, stop here", "_MSG, stop here"),
    ("  debug,#<_x>", "_debug,#<_x>"),
    ("LOGOPEN,/etc/passwd", "_LOGOPEN,/etc/passwd"),
    ("PROBEOPEN out.txt", "_PROBEOPEN out.txt"),
    ("50%\x07 caf\u00e9", "50? caf?"),
])
def test_sanitise_comment_cases(text: str, expected: str) -> None:
    assert sanitise_comment(text) == expected


@settings(max_examples=300, deadline=None)
@given(st.text(max_size=200))
def test_sanitised_comments_cannot_escape(text: str) -> None:
    clean = sanitise_comment(text)
    assert all(32 <= ord(c) <= 126 for c in clean)
    assert not set(clean) & FORBIDDEN
    assert len(clean) <= 72
    assert not clean.lower().lstrip().startswith(("msg,", "debug,", "print,", "log"))
