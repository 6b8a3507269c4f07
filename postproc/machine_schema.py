"""Declaration of the machine TOML: keys, units (mm, deg, mm/min, mm/s^2), ranges.

``postproc.machine.machine_from_dict`` validates a document against ``MachineFile``
and then checks what depends on the kinematics (which axes, which are rotary) and
converts units. Format: docs/formats.md, "Machine file".
"""

from __future__ import annotations

import math
from typing import Annotated

from pydantic import Field, model_validator

from impeller_cam.schema import Strict, quantity
from postproc.machine_model_schema import ModelTable

__all__ = ["AxisTable", "ControlTable", "MachineFile", "ServoTable"]

#: A bound that may be infinite (rotary travel, jerk) but never NaN.
Unbounded = Annotated[float, Field(allow_inf_nan=True)]


def _no_nan(model: Strict) -> None:
    for name, value in model:
        if isinstance(value, float) and math.isnan(value):
            raise ValueError(f"{name} must be a number, not nan")


class ServoTable(Strict):
    """``[axes.<NAME>.servo]``: feed-drive parameters, all optional, stored as given."""

    Kpp: float | None = quantity(None, unit="1/s", ge=0, description="position-loop gain")
    Kvp: float | None = quantity(None, unit="N m s/rad", ge=0,
                                 description="velocity-loop proportional gain")
    Kvi: float | None = quantity(None, unit="N m s/rad", ge=0,
                                 description="velocity-loop integral gain")
    J: float | None = quantity(None, unit="kg m^2", ge=0, description="mechanism inertia")
    J1: float | None = quantity(None, unit="kg m^2", ge=0, description="load inertia")
    C: float | None = quantity(None, unit="N m s/rad", ge=0, description="viscous damping")
    K_FFP: float | None = quantity(None, unit="%", ge=0, description="feed-forward coefficient")
    Ts: float | None = quantity(None, unit="s", ge=0, description="smoothing time constant")
    Ta: float | None = quantity(None, unit="s", ge=0, description="averaging time constant")
    Tp: float | None = quantity(None, unit="s", ge=0, description="preceding time constant")
    torque_limit: float | None = quantity(None, unit="N m", ge=0, description="torque limit")
    screw_lead: float | None = quantity(None, unit="mm", ge=0, description="ball-screw lead")


class AxisTable(Strict):
    """``[axes.<NAME>]``: linear axes in mm, rotary axes in degrees."""

    min: Unbounded | None = quantity(None, unit="mm or deg", description="lower travel limit")
    max: Unbounded | None = quantity(None, unit="mm or deg", description="upper travel limit")
    continuous: bool = quantity(False, description="rotary only: no travel limit")
    velocity: float = quantity(unit="mm/min or deg/min", gt=0, description="maximum speed")
    acceleration: float = quantity(unit="mm/s^2 or deg/s^2", gt=0,
                                   description="maximum acceleration")
    jerk: Unbounded | None = quantity(None, unit="mm/s^3 or deg/s^3", gt=0,
                                      description="maximum jerk (omitted: no jerk limit)")
    servo: ServoTable | None = quantity(None, description="feed-drive parameters")

    @model_validator(mode="after")
    def _finite_or_infinite(self) -> AxisTable:
        _no_nan(self)
        return self


class PivotTable(Strict):
    """``[pivot]``, mm (LinuxCNC ``*-trt-kins`` pin names)."""

    x_rot_point: float = quantity(0.0, unit="mm", description="C rotation point, X")
    y_rot_point: float = quantity(0.0, unit="mm", description="C rotation point, Y")
    z_rot_point: float = quantity(0.0, unit="mm", description="C rotation point, Z")
    x_offset: float = quantity(0.0, unit="mm", description="xyzbc-trt: B pivot along X")
    y_offset: float = quantity(0.0, unit="mm", description="xyzac-trt: A pivot along Y")
    z_offset: float = quantity(0.0, unit="mm", description="A or B pivot along Z")


class TableTable(Strict):
    """``[table]``: the rotary table as a cylinder, mm."""

    radius: float = quantity(unit="mm", gt=0, description="table radius")
    height: float = quantity(unit="mm", gt=0, description="table thickness")
    z_top: float = quantity(0.0, unit="mm", description="height of the top face in W")


class AxesTable(Strict):
    """``[axes]``: one table per joint of the kinematics (X, Y, Z and two of A, B, C)."""

    X: AxisTable | None = None
    Y: AxisTable | None = None
    Z: AxisTable | None = None
    A: AxisTable | None = None
    B: AxisTable | None = None
    C: AxisTable | None = None

    def given(self) -> dict[str, AxisTable]:
        """The axis tables present, by name."""
        return {name: table for name, table in self if table is not None}


class ControlTable(Strict):
    """``[control]``: the numerical control and the options it has."""

    dialect: str | None = quantity(None, min_length=1,
                                   description="post-processor of the control (sinumerik, "
                                   "heidenhain, linuxcnc, fanuc); sets the default post")
    model: str = quantity("", description="control model, free text (SINUMERIK 840D sl)")
    options: dict[str, str | bool] = quantity(
        default_factory=dict, description="dialect options of this control (impeller-cam "
        "posts lists them), e.g. orientation = \"vector\"")


class MachineFile(Strict):
    """A machine TOML file."""

    name: str = quantity(min_length=1, description="display name")
    description: str = quantity("", description="free text")
    kinematics: str = quantity(min_length=1, description="xyzac-trt or xyzbc-trt")
    post: str = quantity("linuxcnc", min_length=1, description="default post-processor")
    tcp: bool = quantity(False, description="tool-centre-point control available")
    conventional_directions: bool = quantity(False, description="rotary direction convention")
    pivot: PivotTable = quantity(default_factory=PivotTable.defaults)
    axes: AxesTable = quantity(description="one table per joint")
    table: TableTable | None = quantity(None, description="rotary table geometry")
    control: ControlTable | None = quantity(None, description="numerical control and options")
    model: ModelTable | None = quantity(None, description="the machine's own solids")
