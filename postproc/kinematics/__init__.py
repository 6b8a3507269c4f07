"""Machine kinematics: forward and inverse between joints and tool poses in W.

Registered built-ins: ``xyzac-trt`` (tilting table A about X carrying rotary table
C) and ``xyzbc-trt`` (tilting table B about Y carrying C), both with the meaning of
LinuxCNC's kinematics modules of the same name. See docs/kinematics.md.

Typical use::

    from postproc.machine import load_machine
    from postproc.kinematics import kinematics_for

    machine = load_machine("fixtures/machines/xyzac-trt.toml")
    kins = kinematics_for(machine)
    joints = kins.inverse(tip, axis)          # (n, 5): X Y Z mm, A C rad
    tip2, axis2 = kins.forward(joints)
"""

from __future__ import annotations

from postproc.kinematics import xyzac_trt, xyzbc_trt  # noqa: F401 - register built-ins
from postproc.kinematics.base import Kinematics, OverTravelError, first_over_travel
from postproc.kinematics.registry import (
    ENTRY_POINT_GROUP,
    available_kinematics,
    joint_names_for,
    kinematics_class,
    kinematics_for,
    register_kinematics,
)
from postproc.kinematics.swing import c_swing_report, rotary_rates
from postproc.kinematics.trt import TableTiltingRotary
from postproc.kinematics.xyzac_trt import XyzacTrt
from postproc.kinematics.xyzbc_trt import XyzbcTrt

__all__ = [
    # protocol and errors
    "Kinematics",
    "OverTravelError",
    "first_over_travel",
    # registry
    "ENTRY_POINT_GROUP",
    "available_kinematics",
    "joint_names_for",
    "kinematics_class",
    "kinematics_for",
    "register_kinematics",
    # built-ins
    "TableTiltingRotary",
    "XyzacTrt",
    "XyzbcTrt",
    # diagnostics
    "c_swing_report",
    "rotary_rates",
]
