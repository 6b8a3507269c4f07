"""The ``heidenhain`` dialect: HEIDENHAIN TNC conversational (Klartext) ``.h`` programs.

Sources (HEIDENHAIN TNC 640 User's Manual Klartext Programming and its cycle
programming manual; sections in docs/postprocessors.md): ``BEGIN PGM name MM`` /
``END PGM name MM``, a block number on every line, comments ``;``, ``TOOL CALL n Z
S..`` (tool length active from the call), straight lines ``L X.. Y.. Z.. A.. C..
R0 F..`` with signed numbers and ``FMAX`` (rapid, effective in its block only),
``FUNCTION TCPM F TCP AXIS POS PATHCTRL AXIS`` (tool-centre-point: X, Y, Z the tool
tip, A, C axis positions, rotary axes interpolated linearly, F the tip's feed) or
``M128`` / ``M129`` on older controls, ``FUNCTION RESET TCPM``, ``LN X.. Y.. Z.. TX..
TY.. TZ..`` (tool-direction vector, great-circle interpolation with ``PATHCTRL
VECTOR``) as an option, ``CYCL DEF 32`` tolerance (``T`` mm, ``HSC-MODE`` 0 finishing
/ 1 roughing, ``TA`` deg), ``M3``/``M4``/``M5``/``M8``/``M9``/``M30`` in ``L`` blocks.

The TNC has no inverse-time feed: blocks that turn a rotary axis get the path feed
that keeps their posted duration (``postproc.posts.pathfeed``).
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from impeller_cam.errors import InputError
from postproc.kinematics import kinematics_for
from postproc.nc_controls import number_text
from postproc.posts.base import register_post
from postproc.posts.blocks import ModalState, WordTable
from postproc.posts.choices import DialectOption
from postproc.posts.comments import sanitise_comment
from postproc.posts.frames import Swivel, frame_rotation, spatial_angles, swivel_segments
from postproc.posts.gcode import GCodeWriter
from postproc.posts.numbers import (
    PAD,
    assemble_lines,
    last_value,
    modal_changes,
    number_bytes,
    quantise,
    text_bytes,
)
from postproc.posts.pathfeed import path_feeds
from postproc.posts.sinumerik import VECTOR_DECIMALS, program_name
from postproc.program import FeedMode, Motion

if TYPE_CHECKING:
    from postproc.machine import Machine
    from postproc.posting import OperationInfo, PostedProgram
    from postproc.posts.base import PostOptions

TCPM_ON = "FUNCTION TCPM F TCP AXIS POS PATHCTRL AXIS"
TCPM_VECTOR_ON = "FUNCTION TCPM F TCP AXIS POS PATHCTRL VECTOR"
TCPM_OFF = "FUNCTION RESET TCPM"


def _signed(value: float, decimals: int) -> str:
    """``+12.5`` / ``-3``: a TNC number with its sign."""
    text = number_text(float(value), decimals)
    return text if text.startswith("-") else "+" + text


def signed_word(letter: str, quantised: NDArray[np.int64], decimals: int,
                present: NDArray[np.bool_]) -> NDArray[np.uint8]:
    """A column ``" X+12.5"`` / ``" X-3"`` (TNC style: explicit sign) where ``present``."""
    n = len(quantised)
    q = np.asarray(quantised, dtype=np.int64)
    sign = np.where(q < 0, ord("-"), ord("+")).astype(np.uint8)[:, None]
    body = number_bytes(np.abs(q), decimals)[:, 1:]  # no sign column (all positive)
    row = np.hstack([text_bytes(" " + letter, n), sign, body])
    return np.where(np.asarray(present, bool)[:, None], row, np.uint8(PAD)).astype(np.uint8)


@register_post
class HeidenhainPost(GCodeWriter):
    """HEIDENHAIN TNC Klartext: FUNCTION TCPM (or M128) or joint mode, LN vectors."""

    name = "heidenhain"
    description = "HEIDENHAIN TNC 640 Klartext (.h); FUNCTION TCPM / M128 TCP or joint mode"
    extension = "h"
    supports_tcp = True
    upper_comments = False
    trailing_point = False
    unnumbered = ()
    options = (
        DialectOption("tcpm", ("function", "m128"),
                      "tool-centre-point: FUNCTION TCPM (TNC 640) or M128/M129 (older TNC)"),
        DialectOption("orientation", ("rotary", "vector"),
                      "rotary axis positions in L blocks, or LN blocks with the tool "
                      "vector TX TY TZ (needs TCPM: --tcp)"),
        DialectOption("cycl32", ("on", "off"),
                      "CYCL DEF 32 tolerance per operation from the tolerances"),
        DialectOption("frames", ("off", "plane-spatial", "plane-axial"),
                      "3+2 segments as 3-axis programs in a PLANE SPATIAL (spatial angles) "
                      "or PLANE AXIAL (rotary positions) working plane"),
    )

    def check_options(self, options: PostOptions, machine: Machine) -> None:
        """Refuse combinations the control cannot run (LN vectors without TCPM)."""
        if options.option("orientation", "rotary") == "vector" and not options.tcp:
            raise InputError("LN blocks with tool vectors TX TY TZ need FUNCTION TCPM / M128",
                             file=machine.source, field="--post-option orientation",
                             value="vector", accepted="orientation=rotary, or post with "
                             "--tcp on a machine with tcp = true")

    # ------------------------------------------------------------ text
    def comment(self, text: object) -> str:
        return f"; {sanitise_comment(text, upper=self.upper_comments)}"

    def program_start(self, program: PostedProgram, options: PostOptions) -> list[str]:
        return [f"BEGIN PGM {self._name} MM"]

    def preamble(self, program: PostedProgram, options: PostOptions) -> list[str]:
        return [TCPM_OFF] if options.tcp and self._tcpm == "function" else []

    def tcp_on(self, tool: int) -> tuple[list[str], str]:
        if self._tcpm == "m128":
            return ["L M128"], ""
        return [TCPM_VECTOR_ON if self._vectors is not None else TCPM_ON], ""

    def tcp_off(self, tool: int) -> tuple[list[str], str]:
        return (["L M129"] if self._tcpm == "m128" else [TCPM_OFF]), ""

    def tool_call(self, op: OperationInfo, options: PostOptions) -> list[str]:
        speed = "" if op.spindle_rpm is None or not options.spindle else (
            f" S{abs(op.spindle_rpm):.0f}")
        return [f"TOOL CALL {op.tool_number} Z{speed}"]

    def length_prefix(self, tool: int) -> str:
        return ""

    def operation_start(self, program: PostedProgram, index: int,
                        options: PostOptions) -> list[str]:
        if options.option("cycl32", "on") != "on":
            return []
        simultaneous = program.simultaneous(index)
        otol = np.degrees(options.angular_tolerance)
        return ["CYCL DEF 32.0 TOLERANCE", f"CYCL DEF 32.1 T{options.chordal_tolerance:g}",
                f"CYCL DEF 32.2 HSC-MODE:{0 if simultaneous else 1} TA{otol:g}"]

    def program_end(self, options: PostOptions) -> list[str]:
        return ["L M30", f"END PGM {self._name} MM"]

    def feed_words(self, program: PostedProgram,
                   options: PostOptions) -> tuple[NDArray[np.int16], NDArray[np.float64]]:
        return path_feeds(program, options.feed_decimals)

    def _lines(self, out: list[bytes], lines: list[str]) -> None:
        # M functions go in an L block; the S of a speed change in a TOOL CALL
        fixed = []
        for line in lines:
            if line.startswith("TOOL CALL"):
                self._speed = line.rpartition(" ")[2] if " S" in line else ""
            elif line.startswith("M"):
                line = "L " + line
            elif line.startswith("S"):
                speed, _, rest = line.partition(" ")
                if speed != self._speed:
                    fixed.append(f"TOOL CALL {speed}")
                    self._speed = speed
                line = f"L {rest}" if rest else ""
            if line:
                fixed.append(line)
        super()._lines(out, fixed)

    # ------------------------------------------------------------ 3+2 frames
    def swivel(self, program: PostedProgram, options: PostOptions) -> Swivel | None:
        if options.option("frames", "off") == "off":
            return None
        return swivel_segments(program)

    def frame_on(self, swivel: Swivel, frame: int, options: PostOptions) -> list[str]:
        if options.option("frames", "off") == "plane-axial":
            a, c = (np.degrees(v) for v in swivel.rotary[frame])
            return [f"PLANE AXIAL A{_signed(a, options.decimals)} C{_signed(c, options.decimals)}"
                    " TURN MB0 FMAX"]
        # the frame of the rotary positions as written (rounded), as spatial angles
        kins = kinematics_for(self._program.machine)
        rotary = np.radians(np.round(np.degrees(swivel.rotary[frame]), options.decimals))
        spa, spb, spc = spatial_angles(frame_rotation(kins, rotary[None, :]))[0]
        return [f"PLANE SPATIAL SPA{_signed(spa, 7)} SPB{_signed(spb, 7)} SPC{_signed(spc, 7)}"
                " TURN MB0 FMAX"]

    def frame_off(self) -> list[str]:
        return ["PLANE RESET STAY"]

    # ------------------------------------------------------------ program
    def write(self, program: PostedProgram, options: PostOptions) -> str:
        self._name = program_name(program.source, "IMPELLER_CAM" if options.program_number
                                  is None else f"P{options.program_number}")
        self._tcpm = options.option("tcpm", "function")
        self._program = program
        self._speed = ""
        self._vectors: NDArray[np.int64] | None = None
        if options.tcp and options.option("orientation", "rotary") == "vector":
            joints = program.machine_joints
            finite = np.isfinite(joints).all(axis=1)
            axes = np.zeros((len(program), 3))
            if finite.any():
                _, axes[finite] = kinematics_for(program.machine).forward(joints[finite])
            self._vectors = quantise(axes.ravel(), VECTOR_DECIMALS).reshape(-1, 3)
        # the TNC numbers every line itself: number after writing
        text = super().write(program, replace(options, block_numbers=False))
        lines = text.splitlines()
        return "".join(f"{k} {line}\n" for k, line in enumerate(lines))

    def _slice(self, out: list[bytes], words: WordTable, state: ModalState, start: int, stop: int,
               prefix: str, options: PostOptions) -> None:
        program = words.program
        n = stop - start
        q = words.quantised[start:stop]
        p = words.present[start:stop]
        emit = np.stack([modal_changes(q[:, j], p[:, j], state.words[j]) for j in range(5)],
                        axis=1)
        motion = program.blocks.motion[start:stop]
        cutting = motion == Motion.LINEAR
        f = words.f_quant[start:stop]
        f_emit = modal_changes(f, cutting, state.feed)
        vectors = self._vectors is not None and state.tcp
        columns = [text_bytes("LN" if vectors else "L", n)]
        columns += [signed_word(letter, q[:, j], options.decimals, emit[:, j])
                    for j, letter in enumerate("XYZ")]
        if vectors:
            assert self._vectors is not None
            v = self._vectors[start:stop]
            before = np.array(state.vector if state.vector is not None else (1 << 62,) * 3)
            changed = np.any(v != np.vstack([before[None, :], v[:-1]]), axis=1)
            changed |= ~emit[:, :3].any(axis=1)
            columns += [signed_word(letter, v[:, j], VECTOR_DECIMALS, changed)
                        for j, letter in enumerate(("TX", "TY", "TZ"))]
            state.vector = (int(v[-1, 0]), int(v[-1, 1]), int(v[-1, 2]))
        else:
            if not emit.any(axis=1).all():
                row = int(np.flatnonzero(~emit.any(axis=1))[0]) + start
                raise RuntimeError(f"block {row} moves no axis (posting should have dropped it)")
            columns += [signed_word(letter, q[:, j], options.decimals, emit[:, j])
                        for j, letter in ((3, "A"), (4, "C"))]
        rapid = ~cutting
        columns.append(np.where(rapid[:, None], text_bytes(" R0 FMAX", n), np.uint8(PAD))
                       .astype(np.uint8))
        f_column = number_bytes(f, options.feed_decimals)
        columns.append(np.where(f_emit[:, None],
                                np.hstack([text_bytes(" F", n), f_column]), np.uint8(PAD))
                       .astype(np.uint8))
        out.append(assemble_lines(columns))
        for j in range(5):
            state.words[j] = last_value(q[:, j], p[:, j], state.words[j])
        state.motion = int(motion[-1])
        state.feed = last_value(f, cutting, state.feed)
        state.feed_mode = int(FeedMode.UNITS_PER_MINUTE)
