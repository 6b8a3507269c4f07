"""Declaration of the TOML tool library (``[[tool]]`` tables), lengths in mm.

``cam.tools.load_tool_library`` validates a library against ``ToolLibraryFile`` and
builds ``Tool`` objects from it. Format: docs/formats.md, "Tool library".
"""

from __future__ import annotations

from typing import Literal

from pydantic import model_validator

from impeller_cam.schema import Strict, quantity

__all__ = ["HolderSegmentTable", "ToolLibraryFile", "ToolTable"]


class HolderSegmentTable(Strict):
    """One ``[[tool.holder]]`` segment: a cylinder or a cone, stacked upwards."""

    length_mm: float = quantity(unit="mm", gt=0, description="segment length along the axis")
    diameter_mm: float | None = quantity(None, unit="mm", gt=0,
                                         description="cylinder diameter")
    bottom_diameter_mm: float | None = quantity(None, unit="mm", gt=0,
                                                description="cone: diameter at the bottom")
    top_diameter_mm: float | None = quantity(None, unit="mm", gt=0,
                                             description="cone: diameter at the top")

    @model_validator(mode="after")
    def _one_shape(self) -> HolderSegmentTable:
        cone = self.bottom_diameter_mm is not None or self.top_diameter_mm is not None
        if self.diameter_mm is not None and cone:
            raise ValueError("give diameter_mm (a cylinder) or bottom_diameter_mm and "
                             "top_diameter_mm (a cone), not both")
        if self.diameter_mm is None and self.bottom_diameter_mm is None:
            raise ValueError("a holder segment needs diameter_mm (a cylinder) or "
                             "bottom_diameter_mm [and top_diameter_mm] (a cone)")
        return self

    @property
    def bottom(self) -> float:
        """Diameter at the bottom, mm."""
        return float(self.bottom_diameter_mm or self.diameter_mm or 0.0)

    @property
    def top(self) -> float:
        """Diameter at the top, mm."""
        return float(self.top_diameter_mm or self.bottom_diameter_mm or self.diameter_mm or 0.0)


class ToolTable(Strict):
    """One ``[[tool]]``: cutter, shank, stick-out and holder."""

    name: str = quantity(min_length=1, description="unique tool name")
    number: int | None = quantity(None, ge=0, description="tool number (T word, LOADTL); "
                                  "default: position in the file")
    type: Literal["ball", "flat", "bullnose"] = quantity("ball", description="cutter end")
    diameter_mm: float = quantity(unit="mm", gt=0, description="cutter diameter")
    corner_radius_mm: float | None = quantity(None, unit="mm", gt=0,
                                              description="corner radius (bullnose only)")
    flute_length_mm: float = quantity(unit="mm", gt=0, description="cutting length from the tip")
    shank_diameter_mm: float | None = quantity(None, unit="mm", gt=0,
                                               description="shank diameter (default: diameter)")
    taper_deg: float = quantity(0.0, unit="deg", ge=0, lt=45,
                                description="half-angle of a tapered neck (0: straight)")
    flute_taper_deg: float = quantity(0.0, unit="deg", ge=0, lt=30,
                                      description="half-angle of tapered flutes, the cone "
                                      "tangent to the corner (0: cylindrical flutes)")
    stickout_mm: float = quantity(unit="mm", gt=0, description="gauge length tip to holder nose")
    spindle_rpm: float | None = quantity(None, unit="1/min", gt=0, description="spindle speed")
    feed_mm_min: float | None = quantity(None, unit="mm/min", gt=0, description="cutting feed")
    holder: list[HolderSegmentTable] = quantity(
        default_factory=list, min_length=1, description="holder segments from the nose upwards")

    @model_validator(mode="after")
    def _corner(self) -> ToolTable:
        if self.type == "bullnose" and self.corner_radius_mm is None:
            raise ValueError("a bullnose tool needs corner_radius_mm")
        if self.type != "bullnose" and self.corner_radius_mm is not None:
            raise ValueError(f"corner_radius_mm is only for type = \"bullnose\" "
                             f"(this tool is {self.type!r})")
        return self


class ToolLibraryFile(Strict):
    """A tool library: one or more ``[[tool]]`` tables."""

    tool: list[ToolTable] = quantity(min_length=1, description="the tools")
