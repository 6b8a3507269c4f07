"""Vectorised first pass over APT CLDATA text: find the GOTO records, parse their numbers.

A CL file is mostly ``GOTO/x,y,z[,i,j,k]`` lines. This module finds them with numpy
on the raw bytes (line starts, leading blanks, the ``GOTO`` word in any case, the
slash after optional blanks) and parses all their numbers with one
``numpy.fromstring`` call, so a file with a million GOTO records is read in seconds
with no Python object per record. Every other non-blank line (and any GOTO line
holding a ``$`` comment or continuation) is handed back by line index for the
record-by-record interpreter in ``postproc.apt``.
"""

from __future__ import annotations

import re
import warnings
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from impeller_cam.errors import InputError

#: A number as APT exports write it: optional sign, digits with an optional point, exponent.
NUMBER_RE = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")

#: How many numbers a GOTO record may hold: position only, or position and tool axis.
GOTO_COUNTS = (3, 6)

_PAD = 8  # bytes of zero padding so look-ahead gathers never run off the end


@dataclass
class ScannedLines:
    """Line table of a CL file and its bulk-parsed GOTO records.

    Attributes
    ----------
    data : (nbytes + pad,) uint8
        The text as bytes, line ends normalised to ``\\n``, zero padded.
    line_start, line_end : (m,) int64
        Byte span of each physical line (end exclusive, newline excluded).
    goto_line : (g,) int64
        0-based line index of each GOTO record parsed here.
    goto_values : (g, 6) float64
        Its numbers; columns 3..5 are NaN for three-number records.
    other_lines : (k,) int64
        0-based indices of the remaining non-blank lines, ascending.
    bulk_ok : bool
        False when some GOTO payload did not parse in bulk (a wrong count, a word, a
        non-finite number); the caller then re-reads those records one by one with
        ``parse_numbers`` to name the bad one.
    """

    data: NDArray[np.uint8]
    line_start: NDArray[np.int64]
    line_end: NDArray[np.int64]
    goto_line: NDArray[np.int64]
    goto_values: NDArray[np.float64]
    other_lines: NDArray[np.int64]
    bulk_ok: bool = True

    def line_text(self, index: int) -> str:
        """Text of the physical line ``index`` (0-based), decoded as UTF-8."""
        raw = self.data[self.line_start[index] : self.line_end[index]].tobytes()
        return raw.decode("utf-8", errors="replace")


def normalise_newlines(buf: bytes) -> bytes:
    """Turn ``\\r\\n`` and lone ``\\r`` line ends into ``\\n``."""
    if b"\r" in buf:
        buf = buf.replace(b"\r\n", b"\n").replace(b"\r", b"\n")
    return buf


def _skip_blanks(data: NDArray[np.uint8], pos: NDArray[np.int64], end: NDArray[np.int64]) -> None:
    """Advance ``pos`` in place past spaces and tabs, never beyond ``end``."""
    idx = np.flatnonzero(((data[pos] == 32) | (data[pos] == 9)) & (pos < end))
    while idx.size:
        pos[idx] += 1
        here = data[pos[idx]]
        idx = idx[((here == 32) | (here == 9)) & (pos[idx] < end[idx])]


def scan_lines(buf: bytes) -> ScannedLines:
    """Split CL text into lines and bulk-parse its plain GOTO records.

    Parameters
    ----------
    buf : bytes
        The file content (UTF-8 or ASCII; line ends already normalised).

    Returns
    -------
    ScannedLines
        GOTO records without any ``$`` on their line are parsed here; the count of
        numbers on each is checked later (``check_goto_counts``).
    """
    if not buf.endswith(b"\n"):
        buf = buf + b"\n"
    data = np.frombuffer(buf + b"\0" * _PAD, dtype=np.uint8)
    nbytes = len(buf)
    newline = np.flatnonzero(data[:nbytes] == 10).astype(np.int64)
    line_end = newline
    line_start = np.empty_like(newline)
    line_start[0] = 0
    line_start[1:] = newline[:-1] + 1

    first = line_start.copy()
    _skip_blanks(data, first, line_end)
    blank = first >= line_end

    word = data[first[:, None] + np.arange(4)] | 0x20  # ASCII letters folded to lower case
    is_goto = np.all(word == np.frombuffer(b"goto", np.uint8), axis=1) & (first + 4 <= line_end)
    slash = first + 4
    _skip_blanks(data, slash, line_end)
    is_goto &= data[slash] == ord("/")

    dollar = np.flatnonzero(data[:nbytes] == ord("$"))
    has_dollar = np.zeros(len(line_start), bool)
    has_dollar[np.searchsorted(newline, dollar)] = True
    fast = is_goto & ~has_dollar & ~blank

    goto_line = np.flatnonzero(fast).astype(np.int64)
    other_lines = np.flatnonzero(~fast & ~blank).astype(np.int64)
    values = _bulk_goto_values(data, slash[goto_line] + 1, line_end[goto_line], newline, goto_line)
    bulk_ok = values is not None
    if values is None:
        values = np.full((len(goto_line), 6), np.nan)
    return ScannedLines(data, line_start, line_end, goto_line, values, other_lines, bulk_ok)


def _bulk_goto_values(
    data: NDArray[np.uint8],
    begin: NDArray[np.int64],
    end: NDArray[np.int64],
    newline: NDArray[np.int64],
    goto_line: NDArray[np.int64],
) -> NDArray[np.float64] | None:
    """Parse the comma-separated payloads ``data[begin:end]`` of the GOTO lines at once.

    Returns
    -------
    (g, 6) float64 or None
        The numbers, NaN in the axis columns of three-number records; None when any
        payload has a count other than 3 or 6 or does not parse to finite numbers.
    """
    g = len(begin)
    out = np.full((g, 6), np.nan)
    if g == 0:
        return out
    commas = np.flatnonzero(data[: newline[-1] + 1] == ord(","))
    per_line = np.bincount(np.searchsorted(newline, commas), minlength=len(newline))
    count = per_line[goto_line] + 1
    if not np.all((count == 3) | (count == 6)):
        return None
    # Keep only the payload bytes, with each line's newline turned into a separator.
    edges = np.zeros(len(data) + 1, np.int8)
    edges[begin] = 1
    edges[end + 1] = -1
    keep = np.cumsum(edges[:-1], dtype=np.int8).astype(bool)
    keep[end] = True
    text = data.copy()
    text[end] = ord(",")
    payload = text[keep].tobytes()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        try:
            flat = np.fromstring(payload, sep=",")
        except (ValueError, DeprecationWarning):
            return None
    if len(flat) != int(count.sum()) or not np.all(np.isfinite(flat)):
        return None
    offsets = np.cumsum(count) - count
    six = count == 6
    out[:, :3] = flat[offsets[:, None] + np.arange(3)]
    out[six, 3:] = flat[offsets[six, None] + np.arange(3, 6)]
    return out


def parse_numbers(
    payload: str, *, source: str, line: int, record: str, allowed: tuple[int, ...]
) -> list[float]:
    """Parse a comma-separated list of numbers from one record, or raise ``InputError``.

    Parameters
    ----------
    payload : str
        Text after the record's slash.
    source : str
        File name for the message.
    line : int
        1-based line number of the record.
    record : str
        Major word (``GOTO``, ``TLAXIS``...), used as the error's field.
    allowed : tuple of int
        Accepted counts of numbers.
    """
    tokens = [t.strip() for t in payload.split(",")]
    values = []
    for token in tokens:
        if NUMBER_RE.fullmatch(token) is None:
            raise InputError(
                f"line {line}: {record}/ holds a value that is not a number",
                file=source,
                field=record,
                value=token,
                accepted="decimal numbers such as -12.5 or 1.0E+02 separated by commas",
            )
        values.append(float(token))
    if len(values) not in allowed:
        raise InputError(
            f"line {line}: {record}/ has {len(values)} numbers",
            file=source,
            field=record,
            value=payload.strip(),
            accepted=" or ".join(str(n) for n in allowed) + " comma-separated numbers",
        )
    return values
