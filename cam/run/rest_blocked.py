"""Where the rough stock blocks finishing: the finishing postures the stock obstructs.

Roughing leaves more than its allowance in many places that finishing copes with (its
flutes cut it, its repair tilts the neck away); the rest operation (``cam.run.rest``)
is needed only where the stock's excess stands in the way of the finishing tool's
neck, shank or holder. ``blocked_centres`` takes finishing's passes (passage 0 and
every rotation, ``passes.passage_paths`` with the finishing options), their initial
postures (the C tilt from the ruling, the normal-angle rule: as ``plan._finish_once``
starts), and returns the ball centres, turned back into passage 0, of the postures
whose shank or holder comes closer than ``stock_clearance_mm`` to the excess stock
(``stock_clearance.stock_blocked``). The rest operation then machines the points near
both such a centre (within the flute length plus the ball radius: the material the
neck meets lies within the tool's reach of its ball) and the excess material.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from cam.finishing.options import FinishOptions
    from cam.tools import Tool

__all__ = ["blocked_centres"]


def blocked_centres(impeller: Any, stock_path: Any, distance: Any, tool: Tool,
                    options: FinishOptions) -> NDArray[np.float64]:
    """Ball centres (passage 0's frame, mm) of finishing postures the stock blocks.

    Parameters
    ----------
    impeller : geometry.impeller.Impeller
        The design (its solid's meshes, its surfaces).
    stock_path : Path
        The verified rough stock (``stock.npz``).
    distance : DesignDistance
        Signed distance from ``impeller.mesh()``.
    tool : Tool
        The finishing ball.
    options : FinishOptions
        The finish stage's options (clearances, scallop, spacing, C tilt).

    Returns
    -------
    (k, 3) float64
    """
    from cam.collision import CollisionScene
    from cam.finishing.command import _stock_scene
    from cam.finishing.options import scallop_stepover
    from cam.finishing.passes import passage_paths
    from cam.finishing.posture import enforce_normal_angle, initial_axes, rotate_about_z
    from cam.finishing.scene import solid_meshes
    from cam.finishing.stock_clearance import stock_blocked
    from cam.verify.sources import load_stock

    stock = load_stock(str(stock_path), 0.5 * options.stock_voxel_mm)
    design = CollisionScene(solid_meshes(impeller, options.tessellation_mm))
    scene = _stock_scene(stock, impeller, design, options, distance)
    surfaces = impeller.surfaces
    stepover = scallop_stepover(tool.radius, options.scallop_mm)
    base = passage_paths(surfaces, tool.radius, options.point_spacing_mm, stepover,
                         blade=options.blade_passes, hub=options.hub_passes,
                         reach=max(tool.flute_length - tool.radius, 0.0),
                         chordal=options.chordal_tolerance_mm)
    pitch = float(surfaces.spec.pitch)
    found = []
    for path in base:
        axis, _ = initial_axes(path.reference_axis, path.away,
                               math.radians(options.c_tilt_deg))
        axis, _ = enforce_normal_angle(axis, path.normal, path.tangent,
                                       math.radians(options.min_normal_angle_deg))
        tip = path.centre - tool.radius * axis
        for k in range(int(surfaces.spec.blades)):
            turned_tip = rotate_about_z(tip, k * pitch)
            turned_axis = rotate_about_z(axis, k * pitch)
            blocked = stock_blocked(scene, tool, turned_tip, turned_axis,
                                    options.cutter_allowance_mm, options.stock_clearance_mm)
            found.append(path.centre[blocked])
    return np.vstack(found) if found else np.zeros((0, 3))
