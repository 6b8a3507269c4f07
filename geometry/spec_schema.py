"""Declaration of the impeller spec TOML (``spec.toml``): tables, keys, units, ranges.

``geometry.spec.load_spec`` validates the document against ``SpecFile`` and then
checks what needs more than one key (contours, camber lines on them, the bore inside
the hub, the thickness law, the clearances). Format: docs/formats.md.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, model_validator

from geometry.machining import MachiningTable
from impeller_cam.schema import Strict, quantity

__all__ = ["SpecFile"]

#: Fewest points a cubic spline through data needs.
MIN_SPLINE_POINTS = 4

Edge = Literal["round", "cut"]
Pair = Annotated[list[float], Field(min_length=2, max_length=2)]


class ImpellerTable(Strict):
    """``[impeller]``."""

    name: str | None = quantity(None, min_length=1, description="default: the folder name")
    blades: int = quantity(ge=1, le=64, description="number of main blades")


class CamberTable(Strict):
    """``[camber]``: the camber-line CSV files, relative to the spec."""

    shroud: str = quantity(min_length=1, description="CSV r,theta_deg,z of the shroud line")
    hub: str = quantity(min_length=1, description="CSV r,theta_deg,z of the hub line")
    midspan: str | None = quantity(None, min_length=1,
                                   description="CSV of a mid-span line (non-ruled blade)")


class MeridionalTable(Strict):
    """``[meridional]``: the contours as ``[z, r]`` points, mm, inlet to outlet."""

    hub: list[Pair] = quantity(min_length=MIN_SPLINE_POINTS, unit="mm",
                               description="[z, r] points nose to rim")
    shroud: list[Pair] = quantity(min_length=MIN_SPLINE_POINTS, unit="mm",
                                  description="[z, r] points inlet tip to outlet")


class HubTable(Strict):
    """``[hub]``."""

    bore_radius_mm: float = quantity(unit="mm", gt=0, description="radius of the bore")


class ThicknessLaw(Strict):
    """``blade.thickness = { u = [...], mm = [...] }``."""

    u: list[float] = quantity(min_length=2, description="camber parameter, 0 to 1")
    mm: list[float] = quantity(min_length=2, unit="mm", description="thickness at u")


class BladeTable(Strict):
    """``[blade]``."""

    thickness_mm: float | None = quantity(None, unit="mm", gt=0,
                                          description="constant thickness")
    thickness: ThicknessLaw | None = quantity(None, description="thickness law along u")
    leading_edge: Edge = quantity("round", description="half-round cap or ruled face")
    trailing_edge: Edge = quantity("cut", description="half-round cap or ruled face")
    fillet_radius_mm: float = quantity(0.0, unit="mm", ge=0,
                                       description="blade-to-hub fillet radius (0: none)")

    @model_validator(mode="after")
    def _one_thickness(self) -> BladeTable:
        if (self.thickness_mm is None) == (self.thickness is None):
            raise ValueError("give exactly one of thickness_mm = <mm> or "
                             "thickness = { u = [...], mm = [...] }")
        return self


class SplittersTable(Strict):
    """``[splitters]``."""

    count: int = quantity(0, ge=0, le=1, description="splitters per passage")
    start_fraction: float = quantity(0.35, ge=0.05, le=0.9,
                                     description="camber parameter u of the splitter LE")


class AllowancesTable(Strict):
    """``[allowances]``."""

    stock_mm: float = quantity(2.0, unit="mm", ge=0, description="blank over the shroud")
    finishing_mm: float = quantity(0.5, unit="mm", ge=0,
                                   description="finishing allowance eta")


class SpecFile(Strict):
    """The impeller spec TOML."""

    impeller: ImpellerTable
    camber: CamberTable
    meridional: MeridionalTable
    hub: HubTable
    blade: BladeTable
    splitters: SplittersTable = quantity(default_factory=SplittersTable.defaults)
    allowances: AllowancesTable = quantity(default_factory=AllowancesTable.defaults)
    machining: MachiningTable | None = quantity(
        None, description="tools and job settings of impeller-cam run")
