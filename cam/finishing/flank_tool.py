"""The cutting flank of a swarf (flank-milling) tool and its exact signed distance.

A view of ``cam.tools.Tool`` (the one tool model: its cutter is what the collision
meshes and the verifier sweep too), giving the flank planner the closed-form
geometry of the cutter below the top of the flutes:

* the **flank**: the flutes' side, a cone (a cylinder when ``half_angle = 0``) of
  radius ``r(h) = r0 + h tan(alpha)`` for ``h_lo <= h <= flute_length``
  (``Tool.flank_r0``, ``Tool.flute_half_angle``, ``Tool.flank_start``);
* below it the **corner**: a ball of radius ``ball_radius`` centred on the axis at
  height ``ball_radius`` (the cone is tangent to it at ``h_lo = R_b (1 - sin
  alpha)``), a bull-nose torus, or a flat end's corner.

The signed distance of a point from the tool is closed form: in the half plane
``(h, rho)`` (height along the axis, distance from it) the flank is a straight line,
so ``d = (rho - r(h)) cos(alpha)`` where the foot of the perpendicular lies on the
flank, and the distance from the corner arc (or the flat bottom) below it. Positive
outside the tool, negative inside. Lengths mm, angles rad.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from cam.tools import Tool

__all__ = ["FlankTool"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class FlankTool:
    """The flank geometry of a ``Tool`` (mm, rad).

    Attributes
    ----------
    tool : Tool
        The cutter (``flute_taper_deg`` the flank's taper, ``flute_length`` its top).
    """

    tool: Tool

    @classmethod
    def from_tool(cls, tool: Tool) -> FlankTool:
        """The flank of a library tool (its flutes' side, tapered or cylindrical)."""
        return cls(tool)

    @classmethod
    def tapered_ball(cls, ball_radius: float, half_angle_deg: float,
                     flute_length: float) -> FlankTool:
        """A tapered ball-end mill without shank or holder (closed-form tests).

        Parameters
        ----------
        ball_radius : float
            Ball radius R_b, mm.
        half_angle_deg : float
            Half taper angle of the flutes, deg.
        flute_length : float
            Flute length from the tip, mm.

        Returns
        -------
        FlankTool
            ``r0 = R_b / cos(alpha) - R_b tan(alpha)`` (the cone tangent to the ball).
        """
        tool = Tool(name="tapered_ball", number=0, shape="ball", diameter=2.0 * ball_radius,
                    corner_radius=ball_radius, flute_length=flute_length,
                    shank_diameter=2.0 * ball_radius, stickout=flute_length,
                    flute_taper_deg=half_angle_deg)
        return cls(tool)

    @classmethod
    def flat(cls, radius: float, flute_length: float, half_angle_deg: float = 0.0
             ) -> FlankTool:
        """A flat end mill (cylindrical or tapered flutes) without shank or holder."""
        tool = Tool(name="flat", number=0, shape="flat", diameter=2.0 * radius,
                    corner_radius=0.0, flute_length=flute_length,
                    shank_diameter=2.0 * radius, stickout=flute_length,
                    flute_taper_deg=half_angle_deg)
        return cls(tool)

    @property
    def r0(self) -> float:
        """Flank radius extrapolated to the tip plane ``h = 0``, mm."""
        return self.tool.flank_r0

    @property
    def half_angle(self) -> float:
        """Half taper angle alpha of the flank, rad."""
        return self.tool.flute_half_angle

    @property
    def flute_length(self) -> float:
        """Height of the top of the cutting flank above the tip, mm."""
        return self.tool.flute_length

    @property
    def ball_radius(self) -> float:
        """Radius of the ball end, mm (0 unless the tool is a ball end mill)."""
        return self.tool.corner_radius if self.tool.shape == "ball" else 0.0

    @property
    def h_lo(self) -> float:
        """Height of the bottom of the flank above the tip, mm."""
        return self.tool.flank_start

    def radius_at(self, height: Array) -> Array:
        """Flank radius ``r0 + h tan(alpha)`` at heights ``h``, mm (any shape)."""
        return self.tool.flank_radius_at(height)

    def signed_distance(self, points: Array, tips: Array, axes: Array) -> Array:
        """Signed distance of points from the tool, mm (> 0 outside, < 0 inside).

        Parameters
        ----------
        points : (..., 3) float64
            Query points, mm.
        tips, axes : (..., 3) float64
            Tool tip and unit axis (tip towards the holder), broadcast with ``points``.

        Returns
        -------
        (...) float64
            Exact distance from the flank cone above ``h_lo`` and from the corner arc
            (or the flat bottom) below it; the flank is extended above
            ``flute_length`` (the caller keeps the cut inside the flutes).
        """
        rel = np.asarray(points) - np.asarray(tips)
        axes = np.asarray(axes)
        h = np.einsum("...i,...i->...", rel, axes)
        rho = np.linalg.norm(rel - h[..., None] * axes, axis=-1)
        ca, sa = math.cos(self.half_angle), math.sin(self.half_angle)
        off = rho - self.radius_at(h)
        d_cone = off * ca
        foot_h = h + off * ca * sa  # height of the perpendicular's foot on the flank line
        rc = self.tool.corner_radius
        inner = self.tool.radius - rc  # the corner arc's centre: (inner, rc)
        arc = np.hypot(rho - inner, h - rc) - rc
        d_low = np.where(rho <= inner, np.maximum(-h, d_cone), arc)
        return np.asarray(np.where(foot_h >= self.h_lo, d_cone, d_low))
