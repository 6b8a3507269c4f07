"""The figures a designer checks after generating a spec (``impeller-cam design``).

Design figures from the generated camber lines (outer diameter D2, outlet width b2,
inlet radii, wrap, blade angles at the leading and trailing edges) and derived figures
from the surfaces (``geometry.figures``: d_min, r_max, the largest fillet the passage
allows). ``check_clearances`` refuses a design whose blades touch or whose fillet
does not fit (``InputError``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from geometry.design import GeneratedDesign
from geometry.figures import check_clearances
from geometry.surfaces import build_surfaces

__all__ = ["blade_angles", "design_figures", "summary_text"]


def blade_angles(camber: NDArray[np.float64]) -> tuple[float, float]:
    """Blade angle at LE and TE, deg from the meridional direction: atan(r dtheta/dm)."""
    r, theta, z = camber[:, 0], camber[:, 1], camber[:, 2]
    dm = np.hypot(np.diff(r), np.diff(z))
    beta = np.degrees(np.arctan(0.5 * (r[1:] + r[:-1]) * np.diff(theta) / dm))
    return float(beta[0]), float(beta[-1])


def design_figures(design: GeneratedDesign) -> dict[str, Any]:
    """JSON-ready figures of a generated design (lengths mm, angles deg).

    Raises
    ------
    InputError
        When the blades touch or the fillet does not fit the passage.
    """
    hub, shroud = design.hub_camber, design.shroud_camber
    fig = check_clearances(build_surfaces(design.to_spec()))
    hub_beta, shroud_beta = blade_angles(hub), blade_angles(shroud)
    return {
        "name": design.params.name,
        "blades": design.params.blades,
        "splitters": design.params.splitters,
        "D2_mm": float(2.0 * shroud[-1, 0]),
        "b2_mm": float(shroud[-1, 2] - hub[-1, 2]),
        "inlet_radius_hub_mm": float(hub[0, 0]),
        "inlet_radius_shroud_mm": float(shroud[0, 0]),
        "wrap_hub_deg": math.degrees(hub[-1, 1] - hub[0, 1]),
        "wrap_shroud_deg": math.degrees(shroud[-1, 1] - shroud[0, 1]),
        "blade_angle_hub_deg": {"le": hub_beta[0], "te": hub_beta[1]},
        "blade_angle_shroud_deg": {"le": shroud_beta[0], "te": shroud_beta[1]},
        "d_min_mm": fig.d_min,
        "d_min_pair": fig.d_min_pair,
        "r_max_mm": fig.r_max,
        "protection_factor_k": fig.k,
        "finishing_allowance_mm": fig.finishing_allowance,
        "min_thickness_mm": fig.min_thickness,
        "rule_deviation_mm": fig.rule_deviation,
        "fillet_radius_mm": design.params.fillet_radius,
        "max_fillet_radius_mm": fig.max_fillet_radius,
    }


def summary_text(f: dict[str, Any]) -> str:
    """The figures as aligned lines for the terminal."""
    hb, sb = f["blade_angle_hub_deg"], f["blade_angle_shroud_deg"]
    lines = [
        f"{f['name']}: {f['blades']} blades, {f['splitters']} splitter(s)",
        f"outer diameter D2           {f['D2_mm']:.1f} mm",
        f"outlet width b2             {f['b2_mm']:.2f} mm",
        f"wrap hub / shroud           {f['wrap_hub_deg']:.1f} / {f['wrap_shroud_deg']:.1f} deg",
        f"blade angle LE -> TE hub    {hb['le']:.1f} -> {hb['te']:.1f} deg",
        f"blade angle LE -> TE shroud {sb['le']:.1f} -> {sb['te']:.1f} deg",
        f"d_min                       {f['d_min_mm']:.2f} mm ({f['d_min_pair']})",
        f"r_max (k={f['protection_factor_k']}, eta={f['finishing_allowance_mm']})"
        f"  {f['r_max_mm']:.2f} mm",
        f"fillet / largest fillet     {f['fillet_radius_mm']:.2f} / "
        f"{f['max_fillet_radius_mm']:.2f} mm",
    ]
    return "\n".join(lines)
