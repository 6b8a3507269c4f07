"""Vectorised reading of runs of plain motion lines in G-code.

Most lines of a posted program look like ``N120 G1 X12.5 Y-3 Z40 A12 C-80 F350``:
an optional N word, an optional G0/G1, axis words in X Y Z A C order and an optional
F word, nothing else. One regular expression over the whole text splits every line
into those columns (C speed, no Python per line); a run of such lines between two
other lines cannot change any modal state except the motion mode and the feed, so its
end positions are computed at once with forward fills (absolute mode) or cumulative
sums (incremental mode). Anything else (comments, other words, other word orders,
arcs, errors) goes through the block-by-block interpreter in ``postproc.nc_reader``,
which also re-reads a run whenever this module declines it (returns None), so both
paths give the same numbers and the same errors.
"""

from __future__ import annotations

import math
import re
import warnings
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

_NUM = r"([-+]?(?:\d+\.?\d*|\.\d+))"
_WS = r"[ \t]*"
SIMPLE_LINE_RE = re.compile(
    rf"^{_WS}(?:N\d+{_WS})?(?:G0*([01])(?![\d.]){_WS})?"
    + "".join(rf"(?:{letter}{_WS}{_NUM}{_WS})?" for letter in "XYZAC")
    + rf"(?:F{_WS}{_NUM}{_WS})?$|^(.+)$",
    re.MULTILINE | re.IGNORECASE,
)

MM_PER_INCH = 25.4


@dataclass
class SimpleLines:
    """Columns of every source line (0-based index = line - 1).

    Attributes
    ----------
    simple : (m,) bool
        The line is a plain motion line (or blank, or only an N word).
    motion : (m,) int8
        0 for G0, 1 for G1, -1 when the line has no motion word.
    values : (m, 5) float64
        X Y Z A C as written (program units, degrees); NaN when absent.
    feed : (m,) float64
        F as written; NaN when absent.
    """

    simple: NDArray[np.bool_]
    motion: NDArray[np.int8]
    values: NDArray[np.float64]
    feed: NDArray[np.float64]


def _column(strings: tuple[str, ...]) -> NDArray[np.float64] | None:
    """Numbers of one word column (empty string = absent -> NaN); None if one is unreadable."""
    out = np.full(len(strings), np.nan)
    present = np.fromiter(map(len, strings), np.int64, len(strings)) > 0
    count = int(present.sum())
    if count:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            try:
                numbers = np.fromstring(",".join(filter(None, strings)), sep=",")
            except (ValueError, DeprecationWarning):
                return None
        if len(numbers) != count:
            return None
        out[present] = numbers
    return out


def split_lines(text: str, lines: list[str], chunk: int = 100_000) -> SimpleLines | None:
    """Split ``text`` into plain-line columns, ``chunk`` lines per regex pass.

    Parameters
    ----------
    text : str
        The program, ``\\n`` line ends.
    lines : list of str
        ``text.split("\\n")`` (used for the line offsets of the chunks).
    chunk : int
        Lines per pass; bounds the temporary strings to a few tens of MB.

    Returns
    -------
    SimpleLines or None
        None when the text cannot be split this way (the caller then reads every line
        block by block).
    """
    count = len(lines)
    offsets = np.zeros(count + 1, np.int64)
    np.cumsum(np.fromiter(map(len, lines), np.int64, count) + 1, out=offsets[1:])
    parts = []
    for a in range(0, count, chunk):
        b = min(a + chunk, count)
        part = _split_chunk(text, int(offsets[a]), int(offsets[b]) - 1, b - a)
        if part is None:
            return None
        parts.append(part)
    if not parts:
        return None
    return SimpleLines(*(np.concatenate([getattr(p, name) for p in parts])
                         for name in ("simple", "motion", "values", "feed")))


def _split_chunk(text: str, pos: int, endpos: int, count: int) -> SimpleLines | None:
    """Columns of the ``count`` lines in ``text[pos:endpos]``."""
    rows = SIMPLE_LINE_RE.findall(text, pos, endpos)
    if len(rows) != count:
        return None
    columns = list(zip(*rows, strict=True))
    simple = np.fromiter(map(len, columns[7]), np.int64, count) == 0
    g = np.array(columns[0])
    motion = np.full(count, -1, np.int8)
    motion[g == "0"] = 0
    motion[g == "1"] = 1
    numeric = []
    for k in range(6):
        column = _column(columns[1 + k])
        if column is None:
            return None
        numeric.append(column)
    return SimpleLines(simple, motion, np.column_stack(numeric[:5]), numeric[5])


@dataclass
class RunResult:
    """Blocks of one run of plain lines and the modal state after it."""

    index: NDArray[np.int64]  # 0-based line index of each block
    joints: NDArray[np.float64]  # (k, 5) mm, rad
    motion: NDArray[np.int8]
    feed: NDArray[np.float64]  # mm/min (G94) or 1/min (G93); NaN for rapids
    last_motion: int | None
    position: NDArray[np.float64]
    feed_rate: float | None


def read_run(lines: SimpleLines, a: int, b: int, *, motion: int | None,
             position: NDArray[np.float64], feed_rate: float | None, incremental: bool,
             inch: bool, inverse_time: bool) -> RunResult | None:
    """Blocks of plain lines ``a..b-1`` given the modal state before them.

    Returns None when the run needs the block-by-block interpreter: a move with no
    linear motion mode in force, a feed move with no usable feed, a negative F, or a
    non-finite number.
    """
    g = lines.motion[a:b].astype(np.int64)
    values = lines.values[a:b]
    feed = lines.feed[a:b]
    if np.any(np.isinf(values)) or np.any(np.isinf(feed)) or np.any(feed < 0.0):
        return None
    has_axes = ~np.all(np.isnan(values), axis=1)
    # Motion mode in force on each line: forward fill of the G0/G1 words.
    start_motion = -1 if motion is None else motion
    mode = _ffill(np.where(g >= 0, g, -2), start_motion, missing=-2)
    if np.any(has_axes & (mode < 0)):
        return None
    scale = MM_PER_INCH if inch else 1.0
    feed_scale = 1.0 if inverse_time else scale
    cutting = has_axes & (mode == 1)
    if inverse_time:
        if np.any(cutting & ~(feed > 0.0)):
            return None
        rate = feed * feed_scale
        last_rate = feed_rate if np.all(np.isnan(feed)) else float(feed[~np.isnan(feed)][-1])
    else:
        start_rate = np.nan if feed_rate is None else feed_rate
        rate = _ffill(feed * feed_scale, start_rate, missing=np.nan)
        if np.any(cutting & ~(rate > 0.0)):
            return None
        last_rate = None if np.isnan(rate[-1]) else float(rate[-1])
    converted = values.copy()
    converted[:, :3] *= scale
    converted[:, 3:] = np.radians(converted[:, 3:])
    if incremental:
        steps = np.where(np.isnan(converted), 0.0, converted)
        joints = np.cumsum(np.vstack([position[None, :], steps]), axis=0)[1:]
    else:
        joints = np.empty_like(converted)
        for j in range(5):
            joints[:, j] = _ffill(converted[:, j], float(position[j]), missing=np.nan)
    rows = np.flatnonzero(has_axes)
    block_motion = mode[rows].astype(np.int8)
    block_feed = np.where(block_motion == 1, rate[rows], np.nan)
    new_position = joints[-1].copy() if len(joints) else position.copy()
    return RunResult(rows + a, joints[rows], block_motion, block_feed,
                     None if mode[-1] < 0 else int(mode[-1]), new_position, last_rate)


def _ffill(values: NDArray[np.float64] | NDArray[np.int64], start: float,
           missing: float) -> NDArray[np.float64]:
    """Forward fill ``values`` where they equal ``missing`` (NaN allowed), from ``start``."""
    values = np.asarray(values, dtype=np.float64)
    present = ~np.isnan(values) if (isinstance(missing, float) and math.isnan(missing)) else (
        values != missing)
    index = np.where(present, np.arange(len(values)), -1)
    np.maximum.accumulate(index, out=index)
    out = np.where(index >= 0, values[np.maximum(index, 0)], start)
    return out
