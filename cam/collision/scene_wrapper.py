"""A collision scene built around another one (the finishing planner's wrappers).

``DrivenScene`` (cam.finishing.driven), ``StockScene`` (cam.finishing.stock_clearance)
and ``MachineObstacle`` (cam.finishing.machine_obstacle) each add checks to a wrapped
scene and are used wherever a ``CollisionScene`` is: every attribute one of them does
not define (roles, meshes, grids, ...) is the wrapped scene's, and so is the cached
tool model.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from cam.tools import Tool

__all__ = ["SceneWrapper"]


class SceneWrapper:
    """Delegates what a wrapper does not define to the wrapped scene ``inner``."""

    inner: Any

    def __getattr__(self, name: str) -> Any:
        if name == "inner":  # not set yet: no recursion
            raise AttributeError(name)
        return getattr(self.inner, name)

    def tool_model(self, tool: Tool, cutter_offset: float = 0.0) -> Any:
        """The wrapped scene's (cached) tool model."""
        return self.inner.tool_model(tool, cutter_offset)
