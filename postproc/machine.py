"""The machine model: kinematic type, pivot offsets, axis limits and dynamics (TOML).

A machine is data, never code. ``load_machine`` reads and validates a machine TOML
(format: docs/formats.md) into a frozen ``Machine``; units are converted at
this boundary: TOML has mm, degrees, mm/min (deg/min), mm/s^2 (deg/s^2) and
mm/s^3 (deg/s^3); the ``Machine`` holds mm, rad and seconds.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from impeller_cam.errors import InputError
from impeller_cam.schema import load_toml, suggest, validate
from postproc.kinematics.base import first_over_travel, over_travel_error
from postproc.kinematics.registry import joint_names_for
from postproc.machine_model import MachineModel, model_from_table
from postproc.machine_schema import AxisTable, MachineFile

#: Rotary axis letters; every other axis is linear.
ROTARY_AXES = frozenset({"A", "B", "C"})

#: Optional servo parameters per axis (units: docs/formats.md), stored as given.
SERVO_KEYS: tuple[str, ...] = (
    "Kpp",
    "Kvp",
    "Kvi",
    "J",
    "J1",
    "C",
    "K_FFP",
    "Ts",
    "Ta",
    "Tp",
    "torque_limit",
    "screw_lead",
)



@dataclass(frozen=True)
class AxisSpec:
    """One machine axis: travel and dynamic limits in internal units.

    Attributes
    ----------
    name : str
        ``"X"``, ``"Y"``, ``"Z"``, ``"A"``, ``"B"`` or ``"C"``.
    rotary : bool
        True for A, B, C.
    minimum, maximum : float
        Travel limits, mm or rad; ``-inf``/``inf`` for a continuous rotary axis.
    velocity : float
        Maximum speed, mm/s or rad/s.
    acceleration : float
        Maximum acceleration, mm/s^2 or rad/s^2.
    jerk : float
        Maximum jerk, mm/s^3 or rad/s^3; ``inf`` when the machine gives none.
    servo : Mapping[str, float]
        Optional servo parameters (keys in ``SERVO_KEYS``), possibly empty.
    """

    name: str
    rotary: bool
    minimum: float
    maximum: float
    velocity: float
    acceleration: float
    jerk: float = math.inf
    servo: Mapping[str, float] = field(default_factory=lambda: MappingProxyType({}))

    @property
    def continuous(self) -> bool:
        """True for a rotary axis without travel limits."""
        return self.rotary and math.isinf(self.minimum) and math.isinf(self.maximum)


@dataclass(frozen=True)
class PivotOffsets:
    """Where the rotary axes are, mm (LinuxCNC ``*-trt-kins`` pin names).

    Attributes
    ----------
    x_rot_point, y_rot_point, z_rot_point : float
        The C rotation point in the machine frame; also the origin of the workpiece
        frame W (on the C axis).
    x_offset : float
        B pivot relative to the C rotation point along X (xyzbc-trt only).
    y_offset, z_offset : float
        A pivot relative to the C rotation point along Y and Z (z_offset also for B).
    """

    x_rot_point: float = 0.0
    y_rot_point: float = 0.0
    z_rot_point: float = 0.0
    y_offset: float = 0.0
    z_offset: float = 0.0
    x_offset: float = 0.0


@dataclass(frozen=True)
class TableGeometry:
    """The rotary table as a cylinder for collision checks and verification, mm.

    Attributes
    ----------
    radius : float
        Table radius.
    height : float
        Table thickness (the cylinder extends ``height`` below its top face).
    z_top : float
        Height of the table's top face in W (<= 0 when a fixture lifts the part).
    """

    radius: float
    height: float
    z_top: float = 0.0


@dataclass(frozen=True)
class Machine:
    """A machine tool: kinematics, offsets, axis limits and dynamics.

    Attributes
    ----------
    name : str
        Display name.
    kinematics : str
        Registry key of its kinematics, e.g. ``"xyzac-trt"``.
    axes : Mapping[str, AxisSpec]
        Axes in joint column order (``("X", "Y", "Z", "A", "C")`` for xyzac-trt).
    pivot : PivotOffsets
        Rotation point and pivot offsets.
    conventional_directions : bool
        True: positive rotary motion turns the table clockwise about +X / +Z seen from
        the positive end (ISO 841 directions for a table, A'/C'); False: LinuxCNC's
        default (table turns right-handed about +X / +Z).
    tcp : bool
        The controller supports tool-centre-point control.
    post : str
        Default post-processor name.
    table : TableGeometry or None
        Optional table geometry.
    source : Path or None
        The TOML it was read from.
    description : str
        Free text (provenance of the numbers).
    control_model : str
        The control's model (``[control] model``), free text.
    control_options : Mapping[str, str or bool]
        Options of the control's dialect (``[control.options]``), checked when a
        program is posted with that dialect.
    model : MachineModel or None
        The machine's own solids (``[model]``, docs/machine-model.md).
    """

    name: str
    kinematics: str
    axes: Mapping[str, AxisSpec]
    pivot: PivotOffsets = field(default_factory=PivotOffsets)
    conventional_directions: bool = False
    tcp: bool = False
    post: str = "linuxcnc"
    table: TableGeometry | None = None
    source: Path | None = None
    description: str = ""
    control_model: str = ""
    control_options: Mapping[str, str | bool] = field(
        default_factory=lambda: MappingProxyType({}))
    model: MachineModel | None = None

    @property
    def axis_names(self) -> tuple[str, ...]:
        """Joint column names in order."""
        return tuple(self.axes)

    def limits(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Lower and upper travel limits.

        Returns
        -------
        lower, upper : (5,) float64
            X Y Z in mm, A C (or B C) in rad.
        """
        specs = list(self.axes.values())
        lower = np.array([s.minimum for s in specs], dtype=np.float64)
        upper = np.array([s.maximum for s in specs], dtype=np.float64)
        return lower, upper

    def check_limits(
        self, joints: NDArray[np.float64], records: NDArray[np.int64] | None = None
    ) -> None:
        """Raise ``OverTravelError`` for the first joint row outside the travel limits.

        Parameters
        ----------
        joints : (n, 5) float64
            Joint vectors, internal units.
        records : (n,) int64, optional
            Source record (APT record or NC line) of each row, quoted in the error.

        Raises
        ------
        OverTravelError
            Naming the row index, the record, the axis, the value and the limit (user
            units: mm or degrees). A NaN joint raises ``InputError``.
        """
        joints = np.asarray(joints, dtype=np.float64).reshape(-1, len(self.axes))
        lower, upper = self.limits()
        found = first_over_travel(joints, lower, upper)
        if found is not None:
            raise over_travel_error(self, joints, found[0], found[1], records)


def ideal_machine(
    kinematics: str = "xyzac-trt",
    pivot: PivotOffsets | None = None,
    conventional_directions: bool = False,
    limits: Mapping[str, tuple[float, float]] | None = None,
) -> Machine:
    """A machine with unlimited travel and dynamics, for kinematics studies and tests.

    Parameters
    ----------
    kinematics : str
        Registry key; decides the axis names.
    pivot : PivotOffsets, optional
        Rotation point and pivot offsets (default all zero).
    conventional_directions : bool
        Rotary direction convention.
    limits : mapping of axis name -> (min, max), optional
        Travel limits to impose on some axes, internal units (mm, rad).
    """
    limits = {} if limits is None else dict(limits)
    axes = {}
    for name in joint_names_for(kinematics):
        lower, upper = limits.pop(name, (-math.inf, math.inf))
        axes[name] = AxisSpec(name, name in ROTARY_AXES, lower, upper, math.inf, math.inf)
    if limits:
        raise ValueError(f"no axis {sorted(limits)} in kinematics {kinematics!r}")
    return Machine(
        name=f"ideal {kinematics}",
        kinematics=kinematics,
        axes=MappingProxyType(axes),
        pivot=PivotOffsets() if pivot is None else pivot,
        conventional_directions=conventional_directions,
    )


# --------------------------------------------------------------------------- loading
def _axis(file: Path | None, name: str, data: AxisTable) -> AxisSpec:
    """An ``AxisSpec`` in internal units from a validated ``[axes.NAME]`` table."""
    field_ = f"axes.{name}"
    rotary = name in ROTARY_AXES
    scale = math.radians(1.0) if rotary else 1.0
    if data.continuous and not rotary:
        raise InputError("only a rotary axis can be continuous", file=file,
                         field=f"{field_}.continuous", value=True,
                         accepted="false (or omit) for a linear axis")
    if data.continuous:
        for key in ("min", "max"):
            if getattr(data, key) is not None:
                raise InputError("a continuous axis has no travel limit", file=file,
                                 field=f"{field_}.{key}", value=getattr(data, key),
                                 accepted="omit min/max or set continuous = false")
        lower, upper = -math.inf, math.inf
    else:
        for key in ("min", "max"):
            value = getattr(data, key)
            if value is None:
                raise InputError("is required", file=file, field=f"{field_}.{key}",
                                 accepted="a number")
            if not rotary and math.isinf(value):
                raise InputError("must be a finite number", file=file,
                                 field=f"{field_}.{key}", value=value,
                                 accepted="a finite number (mm)")
        lower, upper = float(data.min or 0.0), float(data.max or 0.0)
        if not lower < upper:
            raise InputError("min must be below max", file=file, field=f"{field_}.max",
                             value=upper, accepted=f"a number > min ({lower})")
    servo = {} if data.servo is None else data.servo.model_dump(exclude_none=True)
    jerk = math.inf if data.jerk is None else data.jerk
    return AxisSpec(
        name=name,
        rotary=rotary,
        minimum=lower * scale,
        maximum=upper * scale,
        velocity=data.velocity * scale / 60.0,
        acceleration=data.acceleration * scale,
        jerk=jerk * scale,
        servo=MappingProxyType(servo),
    )


def machine_from_dict(data: Mapping[str, Any], source: str | Path | None = None) -> Machine:
    """Validate an already parsed machine TOML document (see ``load_machine``).

    The document is checked against ``postproc.machine_schema.MachineFile`` (keys,
    types, ranges), then against its kinematics (which axes). ``source`` is the file
    named in error messages and kept as ``Machine.source``.
    """
    file = None if source is None else Path(source)
    doc = validate(MachineFile, dict(data), file)
    names = joint_names_for(doc.kinematics, file)
    given = doc.axes.given()
    for name in given:
        if name not in names:
            near = suggest(name, list(names))
            hint = f": did you mean {near!r}?" if near else ""
            raise InputError(f"unknown key {name!r} in [axes]{hint}", file=file,
                             field=f"axes.{name}", value=name, accepted=", ".join(names))
    missing = [name for name in names if name not in given]
    if missing:
        raise InputError(
            f"kinematics {doc.kinematics!r} needs axis {missing[0]}",
            file=file,
            field=f"axes.{missing[0]}",
            accepted=f"tables [axes.X] for X in {names}",
        )
    post = doc.post
    control = doc.control
    if control is not None and control.dialect is not None:
        if "post" in data and doc.post != control.dialect:
            raise InputError("post and control.dialect name different dialects", file=file,
                             field="control.dialect", value=control.dialect,
                             accepted=f"{doc.post!r} (as post), or leave post out")
        post = control.dialect
    if control is not None and control.options:
        _check_control_options(post, control.options, file)
    table = None
    if doc.table is not None:
        table = TableGeometry(radius=doc.table.radius, height=doc.table.height,
                              z_top=doc.table.z_top)
    return Machine(
        name=doc.name,
        kinematics=doc.kinematics,
        axes=MappingProxyType({name: _axis(file, name, given[name]) for name in names}),
        pivot=PivotOffsets(**doc.pivot.model_dump()),
        conventional_directions=doc.conventional_directions,
        tcp=doc.tcp,
        post=post,
        table=table,
        source=file,
        description=doc.description,
        control_model="" if control is None else control.model,
        control_options=MappingProxyType({} if control is None else dict(control.options)),
        model=None if doc.model is None else model_from_table(doc.model, names, file),
    )


def _check_control_options(post: str, options: Mapping[str, str | bool],
                           file: Path | None) -> None:
    """``[control.options]`` against the options the machine's dialect declares."""
    from postproc.posts import get_post
    from postproc.posts.choices import resolve_dialect_options

    try:
        dialect = get_post(post)
    except (InputError, ImportError):
        return  # unknown or unavailable dialect: reported when posting
    resolve_dialect_options(dialect, options, source=file, field_prefix="control.options")


def load_machine(path: str | Path) -> Machine:
    """Read and validate a machine TOML file.

    Parameters
    ----------
    path : str or Path
        The machine file (format: docs/formats.md).

    Returns
    -------
    Machine
        In internal units (mm, rad, s).

    Raises
    ------
    InputError
        When the file is missing, is not TOML, or a field is missing or invalid; the
        message names the file, the field, the value and what would be accepted.
    """
    path = Path(path)
    return machine_from_dict(load_toml(path, "machine"), path)
