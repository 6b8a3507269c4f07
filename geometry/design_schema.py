"""Declaration of the design TOML (``design.toml``, docs/design-generator.md).

``geometry.design.load_design`` validates the document against ``DesignFile`` (keys,
types, units), then ``DesignParameters`` checks ranges and what needs several keys.
The tables the spec shares (``[hub]``, ``[blade]``, ``[splitters]``,
``[allowances]``, ``[machining]``) are the spec's declarations.
"""

from __future__ import annotations

from typing import Literal

from geometry.machining import MachiningTable
from geometry.spec_schema import (
    AllowancesTable,
    BladeTable,
    HubTable,
    Pair,
    SplittersTable,
)
from impeller_cam.schema import Strict, quantity

__all__ = ["DesignFile"]


class DesignImpeller(Strict):
    """``[impeller]``."""

    name: str | None = quantity(None, pattern=r"^[A-Za-z0-9_.-]+$",
                                description="default: the folder name")
    blades: int = quantity(ge=1, le=64, description="number of main blades")


class DesignMeridional(Strict):
    """``[meridional]``: Bezier control polygons ``[z, r]``, mm, inlet to outlet."""

    hub: list[Pair] = quantity(min_length=2, unit="mm", description="hub control polygon")
    shroud: list[Pair] = quantity(min_length=2, unit="mm",
                                  description="shroud control polygon")
    hub_blade: Pair | None = quantity(None, description="[le, te] fractions of the hub length")
    shroud_blade: Pair | None = quantity(None,
                                         description="[le, te] fractions of the shroud length")
    points: int | None = quantity(None, ge=4, le=2000, description="contour points written")


class DesignLine(Strict):
    """``[camber.shroud]`` / ``[camber.hub]``: the angle law along m in [0, 1]."""

    m: list[float] = quantity(min_length=2, description="knots, 0 to 1")
    theta_deg: list[float] | None = quantity(None, min_length=1, unit="deg",
                                             description="wrap angle at the knots (law wrap)")
    beta_deg: list[float] | None = quantity(None, min_length=1, unit="deg",
                                            description="blade angle at the knots")
    theta_le_deg: float | None = quantity(None, unit="deg",
                                          description="wrap at the LE (law blade_angle)")


class DesignCamber(Strict):
    """``[camber]``."""

    law: Literal["wrap", "blade_angle"] = quantity("wrap", description="angle law")
    points: int | None = quantity(None, ge=4, le=2000, description="camber points written")
    midspan_wrap_offset_deg: float | None = quantity(None, unit="deg", ge=-45, le=45,
                                                     description="non-ruled blade")
    shroud: DesignLine
    hub: DesignLine


class DesignFile(Strict):
    """The design TOML."""

    impeller: DesignImpeller
    meridional: DesignMeridional
    camber: DesignCamber
    hub: HubTable
    blade: BladeTable
    splitters: SplittersTable | None = None
    allowances: AllowancesTable | None = None
    machining: MachiningTable | None = None
