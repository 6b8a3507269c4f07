"""CAM: tools, collision, roughing, finishing, verification, motion and the CLI.

The front door (lazy: nothing heavy loads until used): the tool library
(``Tool``, ``load_tool_library``, ``resolve_tool``) and the whole chain (``run_chain``,
``run_batch``). Each step has its own package front door: ``cam.roughing``,
``cam.finishing``, ``cam.verify``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from impeller_cam.lazy import lazy_exports

if TYPE_CHECKING:
    from cam.run import run_batch, run_chain
    from cam.tools import Tool, load_tool_library, resolve_tool

_EXPORTS = {
    "Tool": "cam.tools",
    "load_tool_library": "cam.tools",
    "resolve_tool": "cam.tools",
    "run_batch": "cam.run",
    "run_chain": "cam.run",
}

__all__ = ["Tool", "load_tool_library", "resolve_tool", "run_batch", "run_chain"]

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
