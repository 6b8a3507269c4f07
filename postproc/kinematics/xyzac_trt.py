"""``xyzac-trt``: tilting table A (about X) carrying rotary table C (about Z).

Same meaning as LinuxCNC's ``xyzac-trt-kins`` (src/emc/kinematics/xyzac-trt-kins.c,
formulas in src/emc/kinematics/trtfuncs.c ``xyzacKinematicsForward/Inverse``): pins
``x/y/z-rot-point`` (C rotation point), ``y-offset``/``z-offset`` (A pivot relative to
the C rotation point), ``tool-offset`` (our ``tool_length``) and
``conventional-directions``. The core is ``postproc.kinematics.trt``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

import numpy as np
from numpy.typing import NDArray

from postproc.kinematics.registry import register_kinematics
from postproc.kinematics.trt import TableTiltingRotary

if TYPE_CHECKING:
    from postproc.machine import Machine


@register_kinematics("xyzac-trt")
class XyzacTrt(TableTiltingRotary):
    """Tilting table A about X carrying a rotary table C; the tool points along +Z."""

    joint_names: ClassVar[tuple[str, ...]] = ("X", "Y", "Z", "A", "C")
    tilt_about: ClassVar[int] = 0

    @staticmethod
    def pivot_offset(machine: Machine) -> NDArray[np.float64]:
        """A pivot relative to the C rotation point.

        Parameters
        ----------
        machine : Machine

        Returns
        -------
        (3,) float64
            ``(0, y_offset, z_offset)``, mm.
        """
        return np.array([0.0, machine.pivot.y_offset, machine.pivot.z_offset])
