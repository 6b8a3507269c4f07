"""Three-axis (3+2) UMR roughing of impeller passages (docs/roughing.md).

The front door (lazy)::

    from cam.roughing import RoughOptions, plan_roughing, roughing_toolpaths
    from cam.tools import resolve_tool
    from geometry import build_surfaces, load_spec

    surfaces = build_surfaces(load_spec("fixtures/impellers/small/spec.toml"))
    result = plan_roughing(surfaces, resolve_tool("ball6"), RoughOptions(passages=1))
    toolpaths = roughing_toolpaths(result)        # list of postproc.Toolpath, mm

``run_rough`` is ``impeller-cam rough``: the same plan, its checks and times, written
as APT and rough.json.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from impeller_cam.lazy import lazy_exports

if TYPE_CHECKING:
    from cam.roughing.command import RoughResult, plan_roughing, run_rough
    from cam.roughing.command import toolpaths as roughing_toolpaths
    from cam.roughing.options import RoughOptions

_EXPORTS = {
    "RoughOptions": "cam.roughing.options",
    "RoughResult": "cam.roughing.command",
    "plan_roughing": "cam.roughing.command",
    "roughing_toolpaths": "cam.roughing.command:toolpaths",
    "run_rough": "cam.roughing.command",
}

__all__ = ["RoughOptions", "RoughResult", "plan_roughing", "roughing_toolpaths", "run_rough"]

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
