"""Vectorised G-code words: whole columns of numbers formatted at once.

A block column is a ``(n, w) uint8`` matrix of ASCII bytes, one row per block,
padded with NUL bytes. Columns are stacked side by side and the padding is
squeezed out in one pass (``assemble_lines``), so formatting a million blocks costs
a few array operations per column and no Python loop over the blocks.

Numbers are written in fixed point with at most ``decimals`` digits after the
point, trailing zeros dropped (``X10.5``, ``X-0.25``, ``X3``); with
``trailing_point`` an integral value keeps its point (``X3.``, Fanuc style, where
``X3`` can mean 3 microns on some controls).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

#: Pad byte inside block columns; removed by ``assemble_lines``.
PAD = 0
_MAX_INTEGER_DIGITS = 15


def quantise(values: ArrayLike, decimals: int) -> NDArray[np.int64]:
    """Round values to ``decimals`` digits and return them as scaled integers.

    Parameters
    ----------
    values : (n,) float64
        Values in output units (mm, deg, mm/min, 1/min).
    decimals : int
        Digits after the decimal point, 0..9.

    Returns
    -------
    (n,) int64
        ``round(values * 10**decimals)``; two values print the same exactly when
        their quantised integers are equal.
    """
    if not 0 <= decimals <= 9:
        raise ValueError(f"decimals must be 0..9, not {decimals}")
    scaled = np.rint(np.asarray(values, dtype=np.float64) * 10.0**decimals)
    if not np.all(np.isfinite(scaled)) or np.any(np.abs(scaled) >= 10.0**17):
        raise ValueError("cannot format non-finite or huge numbers")
    return scaled.astype(np.int64)


def number_bytes(
    quantised: NDArray[np.int64], decimals: int, *, trailing_point: bool = False
) -> NDArray[np.uint8]:
    """Format scaled integers as fixed-point text, one padded byte row per value.

    Parameters
    ----------
    quantised : (n,) int64
        Output of ``quantise``.
    decimals : int
        Digits after the point used by ``quantise``.
    trailing_point : bool
        Keep the decimal point of integral values (``3.`` instead of ``3``).

    Returns
    -------
    (n, w) uint8
        ASCII bytes padded with ``PAD``; w = sign + integer digits + point + decimals.
    """
    q = np.asarray(quantised, dtype=np.int64).reshape(-1)
    n = len(q)
    scale = np.int64(10) ** decimals
    magnitude = np.abs(q)
    integer = magnitude // scale
    fraction = magnitude % scale
    top = int(integer.max()) if n else 0
    n_int = max(1, len(str(top)))
    if n_int > _MAX_INTEGER_DIGITS:
        raise ValueError(f"number too large to format: {top}")
    width = 1 + n_int + 1 + decimals
    out = np.zeros((n, width), dtype=np.uint8)
    out[:, 0] = np.where(q < 0, ord("-"), PAD)
    # Integer digits, most significant first; leading zeros become padding.
    significant = np.zeros(n, dtype=bool)
    for k in range(n_int):
        power = np.int64(10) ** (n_int - 1 - k)
        digit = (integer // power) % 10
        significant |= digit > 0
        if k == n_int - 1:
            significant[:] = True
        out[:, 1 + k] = np.where(significant, ord("0") + digit, PAD)
    # Fraction digits, trailing zeros become padding.
    if decimals:
        digits = np.empty((n, decimals), dtype=np.int64)
        rest = fraction.copy()
        for k in range(decimals - 1, -1, -1):
            digits[:, k] = rest % 10
            rest //= 10
        # keep[k] is True when any digit at or after k is non-zero.
        keep = np.flip(np.logical_or.accumulate(np.flip(digits > 0, axis=1), axis=1), axis=1)
        out[:, 2 + n_int :] = np.where(keep, ord("0") + digits, PAD)
        has_fraction = keep[:, 0]
    else:
        has_fraction = np.zeros(n, dtype=bool)
    out[:, 1 + n_int] = np.where(has_fraction | trailing_point, ord("."), PAD)
    return out


def text_bytes(text: str, n: int) -> NDArray[np.uint8]:
    """The same ASCII ``text`` in each of ``n`` rows: ``(n, len(text)) uint8``."""
    row = np.frombuffer(text.encode("ascii"), dtype=np.uint8)
    return np.broadcast_to(row, (n, len(row))).copy()


def choice_bytes(texts: list[str], index: NDArray[np.integer]) -> NDArray[np.uint8]:
    """Per-row pick among a few texts: row i is ``texts[index[i]]``; index -1 gives nothing.

    Returns
    -------
    (n, w) uint8
        Padded ASCII, w = the longest text.
    """
    width = max((len(t) for t in texts), default=0)
    table = np.zeros((len(texts) + 1, max(width, 1)), dtype=np.uint8)
    for i, text in enumerate(texts):
        table[i, : len(text)] = np.frombuffer(text.encode("ascii"), dtype=np.uint8)
    idx = np.asarray(index, dtype=np.int64)
    return table[np.where(idx < 0, len(texts), idx)]


def word_bytes(
    letter: str,
    quantised: NDArray[np.int64],
    decimals: int,
    present: NDArray[np.bool_],
    *,
    trailing_point: bool = False,
) -> NDArray[np.uint8]:
    """A word column ``" X12.5"`` (leading space) where ``present``, padding elsewhere.

    Parameters
    ----------
    letter : str
        Address letter(s), e.g. ``"X"``.
    quantised : (n,) int64
        Scaled values (``quantise``).
    decimals : int
        Decimals used by ``quantise``.
    present : (n,) bool
        Rows that carry the word.
    trailing_point : bool
        See ``number_bytes``.

    Returns
    -------
    (n, w) uint8
    """
    n = len(quantised)
    mask = np.asarray(present, dtype=bool).reshape(-1, 1)
    head = text_bytes(" " + letter, n)
    body = number_bytes(quantised, decimals, trailing_point=trailing_point)
    return np.where(mask, np.hstack([head, body]), np.uint8(PAD)).astype(np.uint8)


def assemble_lines(columns: list[NDArray[np.uint8]]) -> bytes:
    """Join block columns into text lines: drop padding, drop each line's leading space.

    Parameters
    ----------
    columns : list of (n, w_i) uint8
        Byte columns of the same n rows, in word order. Rows that end up empty
        are dropped.

    Returns
    -------
    bytes
        ASCII lines, each ending in ``\\n``.
    """
    if not columns:
        return b""
    matrix = np.hstack(columns)
    if matrix.shape[0] == 0:
        return b""
    nonpad = matrix != PAD
    first = np.argmax(nonpad, axis=1)
    rows = np.arange(matrix.shape[0])
    leading_space = nonpad[rows, first] & (matrix[rows, first] == ord(" "))
    matrix[rows[leading_space], first[leading_space]] = PAD
    nonpad[rows[leading_space], first[leading_space]] = False
    nonempty = nonpad.any(axis=1)
    matrix = matrix[nonempty]
    newline = np.full((matrix.shape[0], 1), ord("\n"), dtype=np.uint8)
    matrix = np.hstack([matrix, newline])
    flat = matrix.ravel()
    return flat[flat != PAD].tobytes()


#: Stands for "value unknown" in modal state (never equal to a quantised value).
UNKNOWN = np.iinfo(np.int64).min


def modal_changes(
    quantised: NDArray[np.int64], present: NDArray[np.bool_], before: int = UNKNOWN
) -> NDArray[np.bool_]:
    """Rows where a modal word must be written: present and different from its last value.

    Parameters
    ----------
    quantised : (n,) int64
        Word values (``quantise``); rows where the word is absent are ignored.
    present : (n,) bool
        Rows that program the word.
    before : int
        Value in force before the first row (``UNKNOWN`` when not known).

    Returns
    -------
    (n,) bool
    """
    q = np.asarray(quantised, dtype=np.int64)
    present = np.asarray(present, dtype=bool)
    n = len(q)
    index = np.where(present, np.arange(n), -1)
    last = np.maximum.accumulate(index) if n else index
    previous_index = np.concatenate([[-1], last[:-1]]) if n else last
    previous = np.where(previous_index >= 0, q[np.maximum(previous_index, 0)], before)
    return present & ((q != previous) | (previous == UNKNOWN))


def last_value(quantised: NDArray[np.int64], present: NDArray[np.bool_], before: int) -> int:
    """Value in force after the rows: the last present value, else ``before``."""
    rows = np.flatnonzero(present)
    return int(quantised[rows[-1]]) if len(rows) else before
