"""The G-code writer shared by the RS274-family dialects (LinuxCNC, Fanuc).

A dialect subclasses ``GCodeWriter`` and overrides the few places where controls
differ (program start and end, tool-centre-point on/off, number style, comments).
Motion blocks are written a whole run at a time (a run: consecutive blocks of one
operation with one TCP state) through the vectorised word columns of
``postproc.posts.numbers``; words are modal (written only when their printed value
changes), ``G93`` programs get an ``F`` on every feed block, ``G94`` gets an ``F``
whenever it changes or after ``G93``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from postproc.posts.comments import sanitise_comment
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
    from postproc.posting import OperationInfo, PostedProgram
    from postproc.posts.base import PostOptions
    from postproc.posts.frames import Swivel

#: Word letters of the five joint columns.
AXIS_LETTERS = ("X", "Y", "Z", "A", "C")
#: Blocks formatted together (bounds the memory of the byte matrices).
SLICE = 65536


@dataclass
class _State:
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
class _Words:
    """The program's words quantised once: axis words (user units) and F words."""

    program: PostedProgram
    quantised: NDArray[np.int64]
    present: NDArray[np.bool_]
    f_quant: NDArray[np.int64]
    feed_mode: NDArray[np.int16]

    @classmethod
    def of(cls, program: PostedProgram, options: PostOptions,
           feeds: tuple[NDArray[np.int16], NDArray[np.float64]] | None = None,
           swivel: Swivel | None = None) -> _Words:
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


class GCodeWriter:
    """RS274 program writer; subclasses set the dialect's details.

    Class attributes
    ----------------
    name, description, extension, supports_tcp
        See ``PostProcessor``.
    upper_comments : bool
        Upper-case comment text.
    trailing_point : bool
        Write integral numbers with a point (``X3.``).
    max_block_number : int
        ``N`` numbers wrap after this value.
    """

    name = "gcode"
    description = "generic RS274"
    extension = "nc"
    supports_tcp = False
    upper_comments = False
    trailing_point = False
    max_block_number = 99999999
    #: Lines that get no block number (comments, tape marks).
    unnumbered: tuple[str, ...] = ("(", "%")
    #: Address of each joint column (``A=`` style for controls that take it).
    axis_letters: tuple[str, ...] = AXIS_LETTERS

    # ------------------------------------------------------------ dialect hooks
    def program_start(self, program: PostedProgram, options: PostOptions) -> list[str]:
        """Lines before the header comments (``%``, ``O`` number).

        Parameters
        ----------
        program : PostedProgram
            The posted program (joints mm, rad).
        options : PostOptions
            The posting options.

        Returns
        -------
        list of str
            NC lines.
        """
        return []

    def preamble(self, program: PostedProgram, options: PostOptions) -> list[str]:
        """Modal set-up lines after the header comments.

        Parameters
        ----------
        program : PostedProgram
            The posted program (joints mm, rad).
        options : PostOptions
            The posting options.

        Returns
        -------
        list of str
            NC lines.
        """
        return ["G21 G17 G40 G49 G80 G90 G94 G54"]

    def tcp_on(self, tool: int) -> tuple[list[str], str]:
        """Lines that switch tool-centre-point control on, and a prefix for the next move.

        Parameters
        ----------
        tool : int
            Tool number (its length compensation).

        Returns
        -------
        lines : list of str
            NC lines.
        prefix : str
            Words for the next move.
        """
        raise NotImplementedError

    def tcp_off(self, tool: int) -> tuple[list[str], str]:
        """Lines that switch tool-centre-point control off, and a prefix for the next move.

        Parameters
        ----------
        tool : int
            Tool number (its length compensation).

        Returns
        -------
        lines : list of str
            NC lines.
        prefix : str
            Words for the next move.
        """
        raise NotImplementedError

    def program_end(self, options: PostOptions) -> list[str]:
        """Lines that end the program.

        Parameters
        ----------
        options : PostOptions
            The posting options.

        Returns
        -------
        list of str
            NC lines.
        """
        return ["M2"]

    def tool_call(self, op: OperationInfo, options: PostOptions) -> list[str]:
        """Lines that load the operation's tool (after spindle and coolant stop).

        Parameters
        ----------
        op : OperationInfo
            The operation (tool number, cutter, name).
        options : PostOptions
            The posting options.

        Returns
        -------
        list of str
            NC lines.
        """
        return [f"T{op.tool_number} M6"]

    def length_prefix(self, tool: int) -> str:
        """Words on the first move after a tool change (tool-length compensation).

        Parameters
        ----------
        tool : int
            Tool number.

        Returns
        -------
        str
        """
        return f"G43 H{tool}"

    def operation_start(self, program: PostedProgram, index: int,
                        options: PostOptions) -> list[str]:
        """Lines after the spindle and coolant words of operation ``index``.

        Parameters
        ----------
        program : PostedProgram
            The posted program (joints mm, rad).
        index : int
            Operation index.
        options : PostOptions
            The posting options.

        Returns
        -------
        list of str
            NC lines.
        """
        return []

    def feed_words(self, program: PostedProgram,
                   options: PostOptions) -> tuple[NDArray[np.int16], NDArray[np.float64]] | None:
        """(feed mode, F) per block when the dialect writes other feeds; None: as posted.

        Parameters
        ----------
        program : PostedProgram
            The posted program (joints mm, rad).
        options : PostOptions
            The posting options.

        Returns
        -------
        (n,) int16 and (n,) float64, or None
            Feed mode and F word (mm/min or inverse time) per block.
        """
        return None

    def swivel(self, program: PostedProgram, options: PostOptions) -> Swivel | None:
        """3+2 segments to write in tilted frames (``postproc.posts.frames``); None: none.

        Parameters
        ----------
        program : PostedProgram
            The posted program (joints mm, rad).
        options : PostOptions
            The posting options.

        Returns
        -------
        Swivel or None
        """
        return None

    def frame_on(self, swivel: Swivel, frame: int, options: PostOptions) -> list[str]:
        """Lines that activate tilted frame ``frame`` (rotary axes already there).

        Parameters
        ----------
        swivel : Swivel
            The 3+2 segments in tilted frames.
        frame : int
            Frame index in ``swivel``.
        options : PostOptions
            The posting options.

        Returns
        -------
        list of str
            NC lines.
        """
        raise NotImplementedError

    def frame_off(self) -> list[str]:
        """Lines that cancel the tilted frame.

        Returns
        -------
        list of str
            NC lines.
        """
        raise NotImplementedError

    # ------------------------------------------------------------ shared text
    def comment(self, text: object) -> str:
        """A sanitised comment line.

        Parameters
        ----------
        text : object
            The comment (its ``str``; characters the control rejects replaced).

        Returns
        -------
        str
        """
        return f"({sanitise_comment(text, upper=self.upper_comments)})"

    def operation_comment(self, index: int, op: OperationInfo) -> str:
        """The comment that opens operation ``index``.

        Parameters
        ----------
        index : int
            Operation index.
        op : OperationInfo
            The operation (name, tool number, cutter in mm).

        Returns
        -------
        str
        """
        text = f"OPERATION {index + 1}: {sanitise_comment(op.name)} - TOOL {op.tool_number}"
        if op.cutter is not None:
            text += f" D{op.cutter.diameter:g} R{op.cutter.corner_radius:g}"
        return self.comment(text)

    def header(self, program: PostedProgram, options: PostOptions) -> list[str]:
        """Comments describing the program (deterministic: no dates, no paths).

        Parameters
        ----------
        program : PostedProgram
            The posted program (joints mm, rad).
        options : PostOptions
            The posting options.

        Returns
        -------
        list of str
            NC lines.
        """
        mode = "TCP" if options.tcp else "joint"
        lines = [
            self.comment(f"impeller-cam post {self.name}"),
            self.comment(f"machine: {program.machine.name}"),
            self.comment(f"kinematics: {program.machine.kinematics}, {mode} mode"),
        ]
        if program.source:
            lines.append(self.comment(f"source: {program.source}"))
        lines.append(self.comment(
            f"chordal tolerance {options.chordal_tolerance:g} mm, angular tolerance "
            f"{np.degrees(options.angular_tolerance):g} deg"))
        lines += [self.comment(text) for text in options.header]
        return lines

    # ------------------------------------------------------------ the program
    def write(self, program: PostedProgram, options: PostOptions) -> str:
        """The program text (ASCII, ``\\n`` line ends, ends with a newline).

        Parameters
        ----------
        program : PostedProgram
            The posted program (joints mm, rad).
        options : PostOptions
            The posting options.

        Returns
        -------
        str
        """
        self._numbered = options.block_numbers
        self._increment = options.block_increment
        self._counter = 0
        out: list[bytes] = []
        for line in self.program_start(program, options):
            out.append(line.encode("ascii") + b"\n")
        self._lines(out, self.header(program, options) + self.preamble(program, options))
        state = _State()
        swivel = self.swivel(program, options)
        words = _Words.of(program, options, self.feed_words(program, options), swivel)
        frame = np.full(len(program), -1) if swivel is None else swivel.frame
        tcp = program.blocks.tcp & (frame < 0)
        bounds = [op.first_block for op in program.operations] + [len(program)]
        for k, op in enumerate(program.operations):
            start, stop = bounds[k], bounds[k + 1]
            self._lines(out, [self.operation_comment(k, op)])
            prefix = ""
            if op.tool_change:
                active = op.tool_number if state.tool is None else state.tool
                lines, prefix = self._switch_tcp(state, False, active)
                self._lines(out, self._leave_frame(state) + lines)
                if start < stop and program.role[start] == _role_retract():
                    self._run(out, words, state, start, start + 1, prefix, options)
                    prefix = ""
                    start += 1
                self._lines(out, self._tool_change(state, op, options))
                prefix = self.length_prefix(op.tool_number)
                state.forget_position((2,))
            self._lines(out, self._spindle_coolant(state, op, options))
            self._lines(out, self.operation_start(program, k, options))
            # runs of one TCP state and one frame
            change = (tcp[start + 1:stop] != tcp[start:stop - 1]) | (
                frame[start + 1:stop] != frame[start:stop - 1])
            edges = [start] + [int(i) for i in np.flatnonzero(change) + start + 1] + [stop]
            for a, b in zip(edges[:-1], edges[1:], strict=True):
                if a >= b:
                    continue
                lines = self._leave_frame(state) if state.frame != frame[a] else []
                tcp_lines, switch_prefix = self._switch_tcp(state, bool(tcp[a]), op.tool_number)
                lines += tcp_lines
                if frame[a] >= 0 and state.frame != frame[a]:
                    assert swivel is not None
                    lines += self.frame_on(swivel, int(frame[a]), options)
                    state.frame = int(frame[a])
                    state.forget_position()
                self._lines(out, lines)
                prefix = " ".join(p for p in (prefix, switch_prefix) if p)
                self._run(out, words, state, a, b, prefix, options)
                prefix = ""
        last_tool = state.tool if state.tool is not None else (
            program.operations[-1].tool_number if program.operations else 0)
        self._lines(out, self._leave_frame(state) + self._switch_tcp(state, False, last_tool)[0])
        end = []
        if options.coolant and state.coolant:
            end.append("M9")
        if options.spindle and state.spindle is not None:
            end.append("M5")
        end += [self.comment(text) for text in options.footer]
        self._lines(out, end + self.program_end(options))
        return b"".join(out).decode("ascii")

    # ------------------------------------------------------------ pieces
    def _leave_frame(self, state: _State) -> list[str]:
        if state.frame < 0:
            return []
        state.frame = -1
        state.forget_position()
        return self.frame_off()

    def _switch_tcp(self, state: _State, on: bool, tool: int) -> tuple[list[str], str]:
        if state.tcp == on:
            return [], ""
        state.tcp = on
        state.forget_position()
        return self.tcp_on(tool) if on else self.tcp_off(tool)

    def _tool_change(self, state: _State, op: OperationInfo, options: PostOptions) -> list[str]:
        lines = []
        if options.coolant and state.coolant:
            lines.append("M9")
            state.coolant = False
        if options.spindle and state.spindle is not None:
            lines.append("M5")
            state.spindle = None
        lines += self.tool_call(op, options)
        state.tool = op.tool_number
        return lines

    def _spindle_coolant(self, state: _State, op: OperationInfo, options: PostOptions) -> list[str]:
        lines = []
        if options.spindle and op.spindle_rpm is not None and op.spindle_rpm != state.spindle:
            rpm = abs(op.spindle_rpm)
            if rpm == 0.0:
                lines.append("M5")
                state.spindle = None
            else:
                lines.append(f"S{rpm:.0f} {'M3' if op.spindle_rpm > 0 else 'M4'}")
                state.spindle = op.spindle_rpm
        if options.coolant and op.coolant != state.coolant:
            lines.append("M8" if op.coolant else "M9")
            state.coolant = op.coolant
        return lines

    def _lines(self, out: list[bytes], lines: list[str]) -> None:
        for line in lines:
            if self._numbered and not line.startswith(self.unnumbered):
                self._counter += 1
                line = f"N{self._block_number(np.array([self._counter]))[0]} {line}"
            out.append(line.encode("ascii") + b"\n")

    def _block_number(self, counter: NDArray[np.int64]) -> NDArray[np.int64]:
        value = counter * self._increment
        return (value - 1) % self.max_block_number + 1

    def _run(self, out: list[bytes], words: _Words, state: _State, start: int, stop: int,
             prefix: str, options: PostOptions) -> None:
        """Write blocks ``start:stop`` (one operation, one TCP state), vectorised, in
        slices of ``SLICE`` blocks (bounded memory) with the modal state carried over."""
        for first in range(start, stop, SLICE):
            self._slice(out, words, state, first, min(first + SLICE, stop),
                        prefix if first == start else "", options)

    def _slice(self, out: list[bytes], words: _Words, state: _State, start: int, stop: int,
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


    def axis_columns(self, words: _Words, state: _State, start: int, stop: int,
                     emit: NDArray[np.bool_], options: PostOptions) -> list[NDArray[np.uint8]]:
        """Byte columns of the axis words of blocks ``start:stop``.

        ``emit`` (n, 5) says which of X, Y, Z, A, C change; a dialect that writes the
        orientation otherwise (tool-direction vectors) overrides this and may set
        ``emit`` for rows whose orientation words change (in place).

        Parameters
        ----------
        words : _Words
            The program's quantised words (mm, deg).
        state : _State
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


def _role_retract() -> int:
    from postproc.posting import Role

    return int(Role.RETRACT)
