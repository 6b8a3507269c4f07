"""The ``sinumerik`` dialect: Siemens SINUMERIK 840D sl (ISO-free Siemens mode).

Sources (SINUMERIK 840D sl, Programming Manual Fundamentals / Job Planning; see
docs/postprocessors.md for the sections): program header ``%_N_NAME_MPF`` and
``;$PATH=/_N_MPF_DIR``, comments after ``;``, ``G71`` metric, ``G642`` blending,
``T="name" M6 D1`` (tool management: tool by name, cutting edge 1 carries the
length), ``G93`` inverse-time / ``G94`` path feed, ``TRAORI`` (5-axis transformation,
tool-centre-point) with ``ORIWKS`` (orientation in the workpiece frame) and either
rotary positions ``A= C=`` under ``ORIAXES`` (rotary axes interpolated linearly,
as the post linearised them) or direction vectors ``A3= B3= C3=`` under ``ORIVECT``
(great-circle interpolation of the tool direction), ``TRAFOOF``, ``CYCLE832(_TOL,
_TOLM, _OTOL)`` (high-speed settings, ``_ORI_FINISH`` for simultaneous operations,
``_ORI_ROUGH`` otherwise), ``M30``.

Joint mode (machine without the TRAORI option, or ``--tcp`` not given): X, Y, Z are
the tool tip in machine coordinates (length compensation through ``D1``), A and C
the rotary axes, as in the LinuxCNC joint mode. Safety moves always run with the
transformation off (``TRAFOOF``).
"""

from __future__ import annotations

import re
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
from postproc.posts.frames import Swivel, swivel_segments
from postproc.posts.gcode import GCodeWriter
from postproc.posts.numbers import quantise, word_bytes
from postproc.posts.pathfeed import path_feeds

if TYPE_CHECKING:
    from postproc.machine import Machine
    from postproc.posting import OperationInfo, PostedProgram
    from postproc.posts.base import PostOptions

#: Digits of the direction-vector components (7: finer than 1e-4 deg).
VECTOR_DECIMALS = 7


def program_name(source: str, fallback: str = "IMPELLER_CAM") -> str:
    """A Sinumerik/TNC program name from a file name: ``A-Z 0-9 _``, a letter first."""
    stem = source.rsplit(".", 1)[0] if source else ""
    name = re.sub(r"[^A-Z0-9_]", "_", stem.upper()).strip("_")[:24]
    if not name or not name[0].isalpha():
        name = (fallback + "_" + name).strip("_")[:24]
    return name


@register_post
class SinumerikPost(GCodeWriter):
    """SINUMERIK 840D sl: TRAORI (rotary positions or vectors) or joint mode, CYCLE832."""

    name = "sinumerik"
    description = "Siemens SINUMERIK 840D sl; TRAORI TCP (A= C= or A3= B3= C3=) or joint mode"
    extension = "mpf"
    supports_tcp = True
    upper_comments = False
    trailing_point = False
    unnumbered = (";", "%")
    axis_letters = ("X", "Y", "Z", "A=", "C=")
    options = (
        DialectOption("orientation", ("rotary", "vector"),
                      "TRAORI orientation: rotary positions A= C= (ORIAXES) or direction "
                      "vectors A3= B3= C3= (ORIVECT); vectors need TRAORI (--tcp)"),
        DialectOption("feed", ("inverse-time", "path"),
                      "blocks that turn a rotary axis: G93 inverse time or G94 path feed"),
        DialectOption("cycle832", ("on", "off"),
                      "CYCLE832 high-speed settings per operation from the tolerances"),
        DialectOption("frames", ("off", "cycle800"),
                      "3+2 segments as 3-axis programs in a CYCLE800 frame swivelled by the "
                      "rotary positions"),
    )

    def check_options(self, options: PostOptions, machine: Machine) -> None:
        """Refuse combinations the control cannot run (vectors without TRAORI)."""
        if options.option("orientation", "rotary") == "vector" and not options.tcp:
            raise InputError("tool-direction vectors A3= B3= C3= need the TRAORI "
                             "transformation", file=machine.source,
                             field="--post-option orientation", value="vector",
                             accepted="orientation=rotary, or post with --tcp on a machine "
                             "with tcp = true (TRAORI option)")

    # ------------------------------------------------------------ text
    def comment(self, text: object) -> str:
        return f"; {sanitise_comment(text, upper=self.upper_comments)}"

    def program_start(self, program: PostedProgram, options: PostOptions) -> list[str]:
        fallback = ("P" + str(options.program_number)) if options.program_number else (
            "IMPELLER_CAM")
        return [f"%_N_{program_name(program.source, fallback)}_MPF", ";$PATH=/_N_MPF_DIR"]

    def preamble(self, program: PostedProgram, options: PostOptions) -> list[str]:
        lines = ["G17 G90 G71 G40 G94 G54", "TRAFOOF", "G642"]
        if options.tcp:
            vectors = options.option("orientation", "rotary") == "vector"
            lines.append("ORIWKS " + ("ORIVECT" if vectors else "ORIAXES"))
        return lines

    def tcp_on(self, tool: int) -> tuple[list[str], str]:
        return ["TRAORI"], ""

    def tcp_off(self, tool: int) -> tuple[list[str], str]:
        return ["TRAFOOF"], ""

    def tool_call(self, op: OperationInfo, options: PostOptions) -> list[str]:
        return [f'T="T{op.tool_number}"', "M6", "D1"]

    def length_prefix(self, tool: int) -> str:
        return ""

    def operation_start(self, program: PostedProgram, index: int,
                        options: PostOptions) -> list[str]:
        if options.option("cycle832", "on") != "on":
            return []
        simultaneous = program.simultaneous(index)
        mode = "_ORI_FINISH" if simultaneous else "_ORI_ROUGH"
        otol = np.degrees(options.angular_tolerance)
        return [f"CYCLE832({options.chordal_tolerance:g},{mode},{otol:g})"]

    def program_end(self, options: PostOptions) -> list[str]:
        return (["CYCLE832()"] if options.option("cycle832", "on") == "on" else []) + ["M30"]

    def feed_words(self, program: PostedProgram,
                   options: PostOptions) -> tuple[NDArray[np.int16], NDArray[np.float64]] | None:
        if options.option("feed", "inverse-time") == "path":
            return path_feeds(program, options.feed_decimals)
        return None

    # ------------------------------------------------------------ 3+2 frames
    def swivel(self, program: PostedProgram, options: PostOptions) -> Swivel | None:
        if options.option("frames", "off") == "off":
            return None
        return swivel_segments(program)

    def frame_on(self, swivel: Swivel, frame: int, options: PostOptions) -> list[str]:
        a, c = (number_text(np.degrees(v), options.decimals) for v in swivel.rotary[frame])
        # _FR 0 (no retract: done), swivel data record "TC1", _ST 0 (new plane), _MODE 192
        # (rotary axes direct: _A, _B = positions of rotary axes 1, 2), no offsets,
        # _DIR 1, _FR_I 0, _DMODE 0
        return [f'CYCLE800(0,"TC1",0,192,0,0,0,{a},{c},0,0,0,0,1,0,0)']

    def frame_off(self) -> list[str]:
        return ["CYCLE800()"]

    # ------------------------------------------------------------ vectors
    def write(self, program: PostedProgram, options: PostOptions) -> str:
        self._vectors: NDArray[np.int64] | None = None
        if options.tcp and options.option("orientation", "rotary") == "vector":
            joints = program.machine_joints
            finite = np.isfinite(joints).all(axis=1)
            axes = np.zeros((len(program), 3))
            if finite.any():
                _, axes[finite] = kinematics_for(program.machine).forward(joints[finite])
            self._vectors = quantise(axes.ravel(), VECTOR_DECIMALS).reshape(-1, 3)
        return super().write(program, options)

    def axis_columns(self, words: WordTable, state: ModalState, start: int, stop: int,
                     emit: NDArray[np.bool_], options: PostOptions) -> list[NDArray[np.uint8]]:
        if self._vectors is None or not state.tcp:
            return super().axis_columns(words, state, start, stop, emit, options)
        q = words.quantised[start:stop]
        v = self._vectors[start:stop]
        before = np.array(state.vector if state.vector is not None else (1 << 62,) * 3)
        previous = np.vstack([before[None, :], v[:-1]])
        changed = np.any(v != previous, axis=1)
        # an orientation-only change on the C axis (vector unchanged) still needs a word
        changed |= ~emit[:, :3].any(axis=1)
        emit[:, 3] = changed
        emit[:, 4] = False
        state.vector = (int(v[-1, 0]), int(v[-1, 1]), int(v[-1, 2]))
        columns = [word_bytes(letter, q[:, j], options.decimals, emit[:, j])
                   for j, letter in enumerate("XYZ")]
        columns += [word_bytes(letter, v[:, j], VECTOR_DECIMALS, changed)
                    for j, letter in enumerate(("A3=", "B3=", "C3="))]
        return columns
