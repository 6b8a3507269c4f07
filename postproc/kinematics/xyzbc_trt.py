"""``xyzbc-trt``: tilting table B (about Y) carrying rotary table C (about Z).

Same meaning as LinuxCNC's ``xyzbc-trt-kins`` (src/emc/kinematics/xyzbc-trt-kins.c,
formulas in src/emc/kinematics/trtfuncs.c ``xyzbcKinematicsForward/Inverse``): pins
``x/y/z-rot-point``, ``x-offset``/``z-offset`` (B pivot relative to the C rotation
point), ``tool-offset`` and ``conventional-directions``. Joint column 3 holds B.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

import numpy as np
from numpy.typing import NDArray

from postproc.kinematics.registry import register_kinematics
from postproc.kinematics.trt import TableTiltingRotary

if TYPE_CHECKING:
    from postproc.machine import Machine


@register_kinematics("xyzbc-trt")
class XyzbcTrt(TableTiltingRotary):
    """Tilting table B about Y carrying a rotary table C; the tool points along +Z."""

    joint_names: ClassVar[tuple[str, ...]] = ("X", "Y", "Z", "B", "C")
    tilt_about: ClassVar[int] = 1

    @staticmethod
    def pivot_offset(machine: Machine) -> NDArray[np.float64]:
        """B pivot relative to the C rotation point.

        Parameters
        ----------
        machine : Machine

        Returns
        -------
        (3,) float64
            ``(x_offset, 0, z_offset)``, mm.
        """
        return np.array([machine.pivot.x_offset, 0.0, machine.pivot.z_offset])
