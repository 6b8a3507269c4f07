"""Modal, vectorised motion blocks: the part of the RS274-family writers that formats runs.

``BlockWriter`` holds what the controller keeps between blocks (``ModalState``), the
program's words quantised once (``WordTable``), block numbering, and writes a run of
motion blocks (consecutive blocks of one operation with one TCP state) a slice at a
time through the vectorised word columns of ``postproc.posts.numbers``: words are
modal (written only when their printed value changes), ``G93`` programs get an ``F`` on
every feed block, ``G94`` gets an ``F`` whenever it changes or after ``G93``.
``postproc.posts.gcode.GCodeWriter`` adds the program's structure and the dialect
hooks.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from postproc.posts.numbers import (
    UNKNOWN,
    assemble_lines,
    choice_bytes,
    last_value,
    modal_changes,
    quantise,
    text_bytes,
    word_bytes,
)
from postproc.program import FeedMode, Motion

if TYPE_CHECKING:
    from postproc.posting import PostedProgram
    from postproc.posts.base import PostOptions
    from postproc.posts.frames import Swivel

__all__ = ["AXIS_LETTERS", "SLICE", "BlockWriter", "ModalState", "WordTable"]

#: Word letters of the five joint columns.
AXIS_LETTERS = ("X", "Y", "Z", "A", "C")
#: Blocks formatted together (bounds the memory of the byte matrices).
SLICE = 65536


@dataclass
class ModalState:
    """What the controller holds between runs (quantised values, UNKNOWN if not known)."""

    words: list[int] = field(default_factory=lambda: [UNKNOWN] * 5)
    motion: int = UNKNOWN
    feed_mode: int = UNKNOWN
    feed: int = UNKNOWN
    tcp: bool = False
    spindle: float | None = None  # rev/min in force, None: off / unknown
    coolant: bool = False
    tool: int | None = None
    vector: tuple[int, int, int] | None = None  # tool-direction words (vector dialects)
    frame: int = -1  # active tilted frame (3+2), -1: none

    def forget_position(self, columns: tuple[int, ...] = (0, 1, 2, 3, 4)) -> None:
        for j in columns:
            self.words[j] = UNKNOWN
        if 3 in columns or 4 in columns:
            self.vector = None


@dataclass
class WordTable:
    """The program's words quantised once: axis words (user units) and F words."""

    program: PostedProgram
    quantised: NDArray[np.int64]
    present: NDArray[np.bool_]
    f_quant: NDArray[np.int64]
    feed_mode: NDArray[np.int16]

    @classmethod
    def of(cls, program: PostedProgram, options: PostOptions,
           feeds: tuple[NDArray[np.int16], NDArray[np.float64]] | None = None,
           swivel: Swivel | None = None) -> WordTable:
        """Quantise the program's words; ``feeds`` replaces its (feed mode, F) columns,
        ``swivel`` its words in the 3+2 segments (frame coordinates)."""
        values = (program.blocks.joints if swivel is None else swivel.words).copy()
        present = program.present if swivel is None else swivel.present
        values[:, 3:] = np.degrees(values[:, 3:])
        finite = np.isfinite(values)
        quantised = quantise(np.where(finite, values, 0.0).ravel(), options.decimals)
        mode, f = (program.blocks.feed_mode, program.blocks.feed) if feeds is None else feeds
        return cls(program, quantised.reshape(-1, 5), present & finite,
                   quantise(np.where(np.isfinite(f), f, 0.0), options.feed_decimals),
                   np.asarray(mode, dtype=np.int16))

class BlockWriter:
    """Block numbering and the vectorised motion blocks of an RS274-family writer.

    Class attributes
    ----------------
    trailing_point : bool
        Write integral numbers with a point (``X3.``).
    max_block_number : int
        ``N`` numbers wrap after this value.
    unnumbered : tuple of str
        Line starts that get no block number (comments, tape marks).
    axis_letters : tuple of str
        Address of each joint column.
    """

    trailing_point = False
    max_block_number = 99999999
    #: Lines that get no block number (comments, tape marks).
    unnumbered: tuple[str, ...] = ("(", "%")
    #: Address of each joint column (``A=`` style for controls that take it).
    axis_letters: tuple[str, ...] = AXIS_LETTERS
    _numbered: bool
    _increment: int
    _counter: int

    def start_numbering(self, options: PostOptions) -> None:
        """Reset the block counter for a new program (``options.block_numbers``)."""
        self._numbered = options.block_numbers
        self._increment = options.block_increment
        self._counter = 0

    def _lines(self, out: list[bytes], lines: list[str]) -> None:
        for line in lines:
            if self._numbered and not line.startswith(self.unnumbered):
                self._counter += 1
                line = f"N{self._block_number(np.array([self._counter]))[0]} {line}"
            out.append(line.encode("ascii") + b"\n")

    def _block_number(self, counter: NDArray[np.int64]) -> NDArray[np.int64]:
        value = counter * self._increment
        return (value - 1) % self.max_block_number + 1

    def _run(self, out: list[bytes], words: WordTable, state: ModalState, start: int, stop: int,
             prefix: str, options: PostOptions) -> None:
        """Write blocks ``start:stop`` (one operation, one TCP state), vectorised, in
        slices of ``SLICE`` blocks (bounded memory) with the modal state carried over."""
        for first in range(start, stop, SLICE):
            self._slice(out, words, state, first, min(first + SLICE, stop),
                        prefix if first == start else "", options)

    def _slice(self, out: list[bytes], words: WordTable, state: ModalState, start: int, stop: int,
               prefix: str, options: PostOptions) -> None:
        program, quantised, present, f_quant = (words.program, words.quantised,
                                                words.present, words.f_quant)
        n = stop - start
        q = quantised[start:stop]
        p = present[start:stop]
        emit = np.stack([modal_changes(q[:, j], p[:, j], state.words[j]) for j in range(5)],
                        axis=1)
        axis_columns = self.axis_columns(words, state, start, stop, emit, options)
        if not emit.any(axis=1).all():
            row = int(np.flatnonzero(~emit.any(axis=1))[0]) + start
            raise RuntimeError(f"block {row} moves no axis (posting should have dropped it)")
        motion = program.blocks.motion[start:stop].astype(np.int64)
        mode = words.feed_mode[start:stop].astype(np.int64)
        cutting = motion == Motion.LINEAR
        every = np.ones(n, dtype=bool)
        g_emit = modal_changes(motion, every, state.motion)
        mode_emit = modal_changes(mode, cutting, state.feed_mode)
        inverse = mode == FeedMode.INVERSE_TIME
        f = f_quant[start:stop]
        # F under G94: when it changes or after a mode switch (LinuxCNC zeroes F then)
        f_emit_94 = modal_changes(f, cutting & ~inverse, state.feed)
        f_emit = cutting & (inverse | mode_emit | f_emit_94)
        if inverse.any() and np.any(f[inverse & cutting] <= 0):
            raise RuntimeError("inverse-time F rounds to zero")
        columns = []
        if self._numbered:
            counter = self._counter + np.arange(1, n + 1, dtype=np.int64)
            numbers = self._block_number(counter)
            columns.append(word_bytes("N", numbers, 0, every))
            self._counter += n
        columns.append(choice_bytes([" G0", " G1"], np.where(g_emit, motion, -1)))
        if prefix:
            first = np.zeros(n, dtype=bool)
            first[0] = True
            columns.append(np.where(first[:, None], text_bytes(" " + prefix, n), 0)
                           .astype(np.uint8))
        columns.append(choice_bytes([" G93", " G94"],
                                    np.where(mode_emit, np.where(inverse, 0, 1), -1)))
        columns += axis_columns
        columns.append(word_bytes("F", f, options.feed_decimals, f_emit,
                                  trailing_point=self.trailing_point))
        out.append(assemble_lines(columns))
        for j in range(5):
            state.words[j] = last_value(q[:, j], p[:, j], state.words[j])
        state.motion = int(motion[-1])
        state.feed_mode = last_value(mode, cutting, state.feed_mode)
        cut_rows = np.flatnonzero(cutting)
        if len(cut_rows):
            last = int(cut_rows[-1])
            state.feed = int(f[last]) if not inverse[last] else UNKNOWN


    def axis_columns(self, words: WordTable, state: ModalState, start: int, stop: int,
                     emit: NDArray[np.bool_], options: PostOptions) -> list[NDArray[np.uint8]]:
        """Byte columns of the axis words of blocks ``start:stop``.

        ``emit`` (n, 5) says which of X, Y, Z, A, C change; a dialect that writes the
        orientation otherwise (tool-direction vectors) overrides this and may set
        ``emit`` for rows whose orientation words change (in place).

        Parameters
        ----------
        words : WordTable
            The program's quantised words (mm, deg).
        state : ModalState
            The modal state written so far.
        start, stop : int
            The blocks.
        emit : (n, 5) bool
            Which axis words to write.
        options : PostOptions
            The posting options (number format).

        Returns
        -------
        list of (n, k) uint8
            One byte column per axis word.
        """
        q = words.quantised[start:stop]
        return [word_bytes(letter, q[:, j], options.decimals, emit[:, j],
                           trailing_point=self.trailing_point)
                for j, letter in enumerate(self.axis_letters)]
