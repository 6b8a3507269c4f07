"""The cutting flank of a swarf (flank-milling) tool and its exact signed distance.

A flank tool is a solid of revolution about its axis (tip at height 0, axis +h):

* the **flank**: a cone (a cylinder when ``half_angle = 0``) of radius
  ``r(h) = r0 + h tan(alpha)`` for ``h_lo <= h <= flute_length`` -- ``r0`` is the
  flank's radius extrapolated to the tip plane;
* below it either a **ball** of radius ``ball_radius`` centred on the axis at height
  ``ball_radius`` (the cone is tangent to it at ``h_lo = R_b (1 - sin alpha)``), or a
  **flat end** (``ball_radius = 0``, ``h_lo = 0``).

The signed distance of a point from the tool is closed form: in the half plane
``(h, rho)`` (height along the axis, distance from it) the flank is a straight line,
so ``d = (rho - r(h)) cos(alpha)`` where the foot of the perpendicular lies on the
flank, and the distance from the ball (or the flat end's corner) below it. Positive
outside the tool, negative inside. Lengths mm, angles rad.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from cam.tools import Tool
from impeller_cam.errors import InputError

__all__ = ["FlankTool"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class FlankTool:
    """Geometry of a flank cutter (mm, rad).

    Attributes
    ----------
    r0 : float
        Flank radius extrapolated to the tip plane ``h = 0``, mm.
    half_angle : float
        Half taper angle alpha of the flank, rad, ``0 <= alpha < pi/4``.
    flute_length : float
        Height of the top of the cutting flank above the tip, mm.
    ball_radius : float
        Radius of the ball end, mm (0: flat end).
    """

    r0: float
    half_angle: float
    flute_length: float
    ball_radius: float = 0.0

    def __post_init__(self) -> None:
        if not 0.0 <= self.half_angle < math.pi / 4:
            raise InputError("flank half angle out of range", field="half_angle",
                             value=math.degrees(self.half_angle), accepted="0 <= deg < 45")
        if not (self.r0 > 0 and self.flute_length > self.h_lo):
            raise InputError("flank tool needs r0 > 0 and flutes above the ball",
                             field="flute_length", value=self.flute_length,
                             accepted=f"> {self.h_lo:g} mm")

    @classmethod
    def tapered_ball(cls, ball_radius: float, half_angle_deg: float,
                     flute_length: float) -> FlankTool:
        """A tapered ball-end mill: ball of ``ball_radius``, flank tangent to it.

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
        a = math.radians(half_angle_deg)
        r0 = ball_radius / math.cos(a) - ball_radius * math.tan(a)
        return cls(r0=r0, half_angle=a, flute_length=flute_length, ball_radius=ball_radius)

    @classmethod
    def from_tool(cls, tool: Tool) -> FlankTool:
        """The flank of a library tool (its flutes are cylindrical: ``alpha = 0``).

        ``Tool.taper_deg`` is the taper of the neck above the flutes, not of the
        cutting edge, so the flank is the flute cylinder of radius ``tool.radius``;
        a bull-nose is treated as a ball-less flat end above its corner.

        Parameters
        ----------
        tool : Tool

        Returns
        -------
        FlankTool
        """
        ball = tool.radius if tool.shape == "ball" else 0.0
        return cls(r0=tool.radius, half_angle=0.0, flute_length=tool.flute_length,
                   ball_radius=ball)

    @property
    def h_lo(self) -> float:
        """Height of the bottom of the flank above the tip, mm."""
        return self.ball_radius * (1.0 - math.sin(self.half_angle))

    def radius_at(self, height: Array) -> Array:
        """Flank radius ``r0 + h tan(alpha)`` at heights ``h``, mm (any shape)."""
        return np.asarray(self.r0 + np.asarray(height) * math.tan(self.half_angle))

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
            Exact distance from the flank cone above ``h_lo`` and from the ball (or
            the flat end's bottom and corner) below it; the flank is extended above
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
        if self.ball_radius > 0:
            d_low = np.hypot(rho, h - self.ball_radius) - self.ball_radius
        else:
            corner = np.hypot(rho - self.r0, h)
            d_low = np.where(rho <= self.r0, np.maximum(-h, d_cone), corner)
        return np.asarray(np.where(foot_h >= self.h_lo, d_cone, d_low))
