"""The ``linuxcnc`` dialect: RS274/NGC for LinuxCNC, joint mode or switchkins TCP.

Joint mode: X, Y, Z are the tool tip in machine coordinates under ``G43 H<n>``, A and
C the rotary joints (identity kinematics, as LinuxCNC's xyzac-trt sim after
``M429``). TCP mode follows the sim's switchable kinematics
(configs/sim/axis/vismach/5axis/table-rotary-tilting/xyzac-trt.ini,
``KINEMATICS = xyzac-trt-kins sparm=identityfirst``): ``M428`` switches to the
xyzac-trt kinematics (tool-centre-point, X, Y, Z in the world frame), ``M429`` back
to identity kinematics. Both M-codes are remapped in the machine's ini
(``REMAP = M428 modalgroup=10 ngc=428remap``); safety moves always run in joint mode.
Path blending: ``G64 P<tolerance>``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from postproc.posts.base import register_post
from postproc.posts.gcode import GCodeWriter

if TYPE_CHECKING:
    from postproc.posting import PostedProgram
    from postproc.posts.base import PostOptions


@register_post
class LinuxCNCPost(GCodeWriter):
    """LinuxCNC RS274/NGC (joint mode, or TCP through switchkins M428/M429)."""

    name = "linuxcnc"
    description = "LinuxCNC RS274/NGC; joint mode or TCP via switchkins M428/M429; G93/G94"
    extension = "ngc"
    supports_tcp = True
    upper_comments = False
    trailing_point = False

    def header(self, program: PostedProgram, options: PostOptions) -> list[str]:
        lines = super().header(program, options)
        if options.program_number is not None:
            # O-words are subroutine labels in RS274/NGC: the number stays a comment
            lines.insert(1, self.comment(f"program {options.program_number}"))
        return lines

    def preamble(self, program: PostedProgram, options: PostOptions) -> list[str]:
        blend = options.blend_tolerance
        blend = options.chordal_tolerance if blend is None else blend
        lines = ["G21 G17 G40 G80 G90 G94 G54" + (" G49" if options.tool_change else ""),
                 f"G64 P{blend:.4f}".rstrip("0").rstrip(".")]
        if options.tcp:
            lines.append("M429")
        return lines

    def tcp_on(self, tool: int) -> tuple[list[str], str]:
        return ["M428"], ""

    def tcp_off(self, tool: int) -> tuple[list[str], str]:
        return ["M429"], ""

    def program_end(self, options: PostOptions) -> list[str]:
        return ["M2"]
