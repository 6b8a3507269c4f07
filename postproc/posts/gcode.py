"""The G-code writer shared by the RS274-family dialects (LinuxCNC, Fanuc).

A dialect subclasses ``GCodeWriter`` and overrides the few places where controls
differ (program start and end, tool-centre-point on/off, number style, comments).
The program's structure (header, operations, tool changes, TCP and tilted-frame
switches) is written here; the motion blocks, a whole run at a time, by
``postproc.posts.blocks.BlockWriter``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from postproc.posts.blocks import BlockWriter, ModalState, WordTable
from postproc.posts.comments import sanitise_comment

if TYPE_CHECKING:
    from postproc.posting import OperationInfo, PostedProgram
    from postproc.posts.base import PostOptions
    from postproc.posts.frames import Swivel

__all__ = ["GCodeWriter"]


class GCodeWriter(BlockWriter):
    """RS274 program writer; subclasses set the dialect's details.

    Class attributes
    ----------------
    name, description, extension, supports_tcp
        See ``PostProcessor``.
    upper_comments : bool
        Upper-case comment text.

    Numbering and number style (``trailing_point``, ``max_block_number``,
    ``unnumbered``, ``axis_letters``): see ``BlockWriter``.
    """

    name = "gcode"
    description = "generic RS274"
    extension = "nc"
    supports_tcp = False
    upper_comments = False

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
        self.start_numbering(options)
        out: list[bytes] = []
        for line in self.program_start(program, options):
            out.append(line.encode("ascii") + b"\n")
        self._lines(out, self.header(program, options) + self.preamble(program, options))
        state = ModalState()
        swivel = self.swivel(program, options)
        words = WordTable.of(program, options, self.feed_words(program, options), swivel)
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
    def _leave_frame(self, state: ModalState) -> list[str]:
        if state.frame < 0:
            return []
        state.frame = -1
        state.forget_position()
        return self.frame_off()

    def _switch_tcp(self, state: ModalState, on: bool, tool: int) -> tuple[list[str], str]:
        if state.tcp == on:
            return [], ""
        state.tcp = on
        state.forget_position()
        return self.tcp_on(tool) if on else self.tcp_off(tool)

    def _tool_change(self, state: ModalState, op: OperationInfo, options: PostOptions) -> list[str]:
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

    def _spindle_coolant(self, state: ModalState, op: OperationInfo,
                         options: PostOptions) -> list[str]:
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

def _role_retract() -> int:
    from postproc.posting import Role

    return int(Role.RETRACT)
