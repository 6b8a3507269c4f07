"""Declarations of the motion TOML files: the TDOF plant and the feed-drive parameters.

Units: kg, N/m, N s/m for the plant (usable unchanged with mm and s); the feed-drive
keys are those of a machine TOML's ``[axes.N.servo]`` (docs/formats.md, "Motion
formats"). ``cam.motion.plant``, ``cam.motion.positioning`` and
``cam.motion.feeddrive`` build their dataclasses from these.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from impeller_cam.schema import Strict, quantity

__all__ = ["CircleTestTable", "FeedDriveFile", "FeedDriveServo", "PlantFile", "PlantTable",
           "SettlingTable"]

AxisName = Literal["X", "Y", "Z", "A", "B", "C"]


class PlantTable(Strict):
    """``[plant]``: two masses joined by a spring and a damper, PD servo."""

    motor_mass: float = quantity(unit="kg", gt=0, description="rotor + coupling + screw")
    table_mass: float = quantity(unit="kg", gt=0, description="table")
    stiffness: float = quantity(unit="N/m", gt=0, description="spring motor side - table")
    damping: float = quantity(unit="N s/m", ge=0, description="damper motor side - table")
    servo_stiffness: float = quantity(unit="N/m", gt=0, description="position loop")
    servo_damping: float = quantity(unit="N s/m", gt=0, description="velocity loop")
    feedforward: float = quantity(1.0, ge=0, le=1, description="acceleration feed-forward")


class SettlingTable(Strict):
    """``[settling]``: when a positioning move counts as settled."""

    output: Literal["acceleration", "position"] = quantity(
        "acceleration", description="band on table acceleration (mm/s^2) or position (mm)")
    band: float = quantity(840.0, gt=0, unit="mm/s^2 or mm", description="band half-width")
    pid_period: float = quantity(0.00025, gt=0, unit="s", description="PID period")


class PlantFile(Strict):
    """A plant TOML (``motion optimize --plant``)."""

    name: str | None = quantity(None, description="free text")
    plant: PlantTable
    settling: SettlingTable | None = None


class FeedDriveServo(Strict):
    """Servo parameters of one axis (Suzuki et al., Table 1)."""

    Kpp: float = quantity(unit="1/s", gt=0, description="position loop gain")
    Kvp: float = quantity(unit="N m s/rad", gt=0, description="velocity proportional gain")
    Kvi: float = quantity(unit="N m/rad", ge=0, description="velocity integral gain")
    J: float = quantity(unit="kg m^2", gt=0, description="mechanism inertia")
    J1: float = quantity(0.0, unit="kg m^2", ge=0, description="load inertia")
    C: float = quantity(unit="N m s/rad", ge=0, description="viscous damping")
    K_FFP: float = quantity(100.0, unit="%", ge=0, description="Pre-Control coefficient")
    Ts: float = quantity(unit="s", ge=0, description="smoothing time constant")
    Ta: float = quantity(unit="s", ge=0, description="averaging time constant")
    Tp: float = quantity(unit="s", ge=0, description="preceding time")
    torque_limit: Annotated[float, Field(allow_inf_nan=True)] | None = quantity(
        None, unit="N m", ge=0, description="motor torque limit (omitted or 0: none)")
    screw_lead: float | None = quantity(None, unit="mm", gt=0, description="ball-screw lead")


class CircleTestTable(Strict):
    """``[circle_test]``: the circle-with-rotary test of Suzuki et al. (seed 004, sec. 3)."""

    rotary: AxisName = quantity("C", description="the turning table's axis")
    linear: list[AxisName] = quantity(["X", "Y"], min_length=2, max_length=2,
                                      description="the axes moving the tool: x then y")
    r_c: float = quantity(5.0, unit="mm", gt=0, description="workpiece radius R_C")
    r_w: float = quantity(8.0, unit="mm", gt=0, description="tool-centre offset R_W")
    omega: list[float] = quantity(min_length=1, unit="rad/s",
                                  description="angular velocities of the table (each > 0)")
    load_inertia: list[float] = quantity(min_length=1, unit="kg m^2",
                                         description="load inertias J1 of the rotary axis")
    paper_saturation_omega: list[float] | None = quantity(
        None, unit="rad/s", description="reported saturation velocities, per J1 (compare)")
    paper_saturation_acceleration: list[float] | None = quantity(
        None, unit="rad/s^2", description="reported saturation accelerations, per J1")


class FeedDriveFile(Strict):
    """A feed-drive TOML: ``[axes.X]`` tables of servo parameters."""

    name: str | None = quantity(None, description="free text")
    axes: dict[AxisName, FeedDriveServo] = quantity(min_length=1,
                                                    description="axes X, Y, Z, A, B, C")
    circle_test: CircleTestTable | None = quantity(
        None, description="the paper's circle test on these axes (motion circle)")
