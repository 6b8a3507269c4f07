"""Post-processing: machines, kinematics, dialect plug-ins, APT CLDATA and NC I/O.

The front door (lazy)::

    from postproc import PostOptions, get_post, load_machine, post_toolpaths, read_apt

    machine = load_machine("fixtures/machines/trunnion-500.toml")
    toolpaths = read_apt("fixtures/apt/...")        # or a CAM plan's toolpaths
    options = PostOptions(chordal_tolerance=0.01)   # mm, rad
    posted = post_toolpaths(toolpaths, machine, options)
    text = get_post(machine.post).write(posted, options)

* toolpaths and programs: ``Toolpath``, ``Cutter``, ``MoveKind``, ``MachineProgram``;
* machines and kinematics: ``Machine``, ``load_machine``, ``kinematics_for``;
* posting: ``post_toolpaths``, ``PostedProgram``, ``PostOptions``, ``get_post``,
  ``available_posts``, ``post_text`` and ``run_post`` (``impeller-cam post``);
* files: ``read_apt``, ``parse_apt``, ``write_apt``, ``read_nc``, ``parse_nc``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from impeller_cam.lazy import lazy_exports

if TYPE_CHECKING:
    from postproc.apt import parse_apt, read_apt, write_apt
    from postproc.command import post_text, run_post
    from postproc.kinematics import kinematics_for
    from postproc.machine import Machine, load_machine
    from postproc.nc_reader import parse_nc, read_nc
    from postproc.posting import PostedProgram, post_toolpaths
    from postproc.posts import PostOptions, available_posts, get_post
    from postproc.program import MachineProgram
    from postproc.toolpath import Cutter, MoveKind, Toolpath

_EXPORTS = {
    "parse_apt": "postproc.apt",
    "read_apt": "postproc.apt",
    "write_apt": "postproc.apt",
    "post_text": "postproc.command",
    "run_post": "postproc.command",
    "kinematics_for": "postproc.kinematics",
    "Machine": "postproc.machine",
    "load_machine": "postproc.machine",
    "parse_nc": "postproc.nc_reader",
    "read_nc": "postproc.nc_reader",
    "PostedProgram": "postproc.posting",
    "post_toolpaths": "postproc.posting",
    "PostOptions": "postproc.posts",
    "available_posts": "postproc.posts",
    "get_post": "postproc.posts",
    "MachineProgram": "postproc.program",
    "Cutter": "postproc.toolpath",
    "MoveKind": "postproc.toolpath",
    "Toolpath": "postproc.toolpath",
}

__all__ = [
    "Cutter",
    "Machine",
    "MachineProgram",
    "MoveKind",
    "PostOptions",
    "PostedProgram",
    "Toolpath",
    "available_posts",
    "get_post",
    "kinematics_for",
    "load_machine",
    "parse_apt",
    "parse_nc",
    "post_text",
    "post_toolpaths",
    "read_apt",
    "read_nc",
    "run_post",
    "write_apt",
]

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
