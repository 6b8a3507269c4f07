"""The ``fanuc`` dialect: Fanuc-style ISO G-code (0i/30i family conventions).

Numbers carry a decimal point (``X10.``: on a Fanuc ``X10`` can mean 10 microns),
the program is framed by ``%`` and an ``O`` number, comments are upper case.
Joint mode: ``G43 H<n>`` tool-length compensation, X, Y, Z the tool tip in machine
coordinates, A and C the rotary joints; 3+2 segments are positioned once with ``G0 A
C`` after a safe retract and cut with three-axis ``G94`` blocks. TCP mode:
``G43.4 H<n>`` (tool-centre-point control, type 1: rotary axes programmed as
joints), cancelled with ``G49``. Simultaneous blocks use ``G93`` inverse time.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from postproc.posts.base import register_post
from postproc.posts.gcode import GCodeWriter

if TYPE_CHECKING:
    from postproc.posting import PostedProgram
    from postproc.posts.base import PostOptions


@register_post
class FanucPost(GCodeWriter):
    """Fanuc-style G-code with G43.4 TCP, G93 inverse time and 3+2 positioning."""

    name = "fanuc"
    description = "Fanuc-style ISO G-code; G43.4 TCP or joint mode; G93/G94; 3+2 positioning"
    extension = "nc"
    supports_tcp = True
    upper_comments = True
    trailing_point = True
    max_block_number = 99999

    def program_start(self, program: PostedProgram, options: PostOptions) -> list[str]:
        number = 1 if options.program_number is None else options.program_number
        return ["%", f"O{number:04d} {self.comment(program.machine.name)}"]

    def preamble(self, program: PostedProgram, options: PostOptions) -> list[str]:
        return ["G21 G17 G40 G49 G80 G90 G94 G54"]

    def tcp_on(self, tool: int) -> tuple[list[str], str]:
        return [f"G43.4 H{tool}"], ""

    def tcp_off(self, tool: int) -> tuple[list[str], str]:
        return ["G49"], f"G43 H{tool}"

    def program_end(self, options: PostOptions) -> list[str]:
        return ["M30", "%"]
