"""Largest roughing ball (M4 eq. 1): ``r_max = (d_min - 2 eta) / (2 k)``.

``d_min`` is the shortest distance between facing blade sides (``geometry.figures``),
``eta`` the finishing allowance and ``k`` the protection factor (1.2 < k < 1.5 in the
paper). A ball larger than ``r_max`` is refused with the numbers in the message; the
roughing never shrinks the tool on its own.
"""

from __future__ import annotations

from cam.tools import Tool
from geometry.figures import max_ball_radius
from impeller_cam.errors import InputError

__all__ = ["check_tool_size"]


def check_tool_size(tool: Tool, d_min: float, eta: float, k: float = 1.2,
                    spec_file: str | None = None) -> float:
    """Refuse a roughing tool that is not a ball or is larger than ``r_max``.

    Parameters
    ----------
    tool : Tool
        The roughing tool (a ball-end mill).
    d_min : float
        Minimum passage width, mm.
    eta : float
        Finishing allowance, mm.
    k : float
        Protection factor.
    spec_file : str, optional
        The impeller spec, quoted in the error.

    Returns
    -------
    float
        ``r_max``, mm.

    Raises
    ------
    InputError
        Not a ball-end mill, or ``tool.radius > r_max`` (message: tool radius,
        d_min, eta, k and r_max).
    """
    if tool.shape != "ball":
        raise InputError("three-axis UMR roughing needs a ball-end mill", field="--tool",
                         value=f"{tool.name} ({tool.shape})", accepted="a tool of type 'ball'")
    r_max = max_ball_radius(d_min, eta, k)
    if tool.radius > r_max:
        raise InputError(
            f"tool {tool.name} (radius {tool.radius:.3f} mm) is larger than the largest "
            f"roughing ball r_max = (d_min - 2 eta) / (2 k) = ({d_min:.3f} - 2 x {eta:.3f}) "
            f"/ (2 x {k:.3f}) = {r_max:.3f} mm (M4 eq. 1)",
            file=spec_file, field="--tool", value=tool.name,
            accepted=f"a ball of radius <= {r_max:.3f} mm (diameter <= {2 * r_max:.3f} mm)",
        )
    return r_max
