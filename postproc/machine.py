"""The machine model: kinematic type, pivot offsets, axis limits and dynamics (TOML).

A machine is data, never code. ``load_machine`` reads and validates a machine TOML
(format: docs/formats.md) into a frozen ``Machine``; units are converted at
this boundary: TOML has mm, degrees, mm/min (deg/min), mm/s^2 (deg/s^2) and
mm/s^3 (deg/s^3); the ``Machine`` holds mm, rad and seconds.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from impeller_cam.errors import InputError
from postproc.kinematics.base import first_over_travel, over_travel_error
from postproc.kinematics.registry import joint_names_for

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

_TOP_KEYS = (
    "name",
    "description",
    "kinematics",
    "post",
    "tcp",
    "conventional_directions",
    "pivot",
    "axes",
    "table",
)
_PIVOT_KEYS = ("x_rot_point", "y_rot_point", "z_rot_point", "x_offset", "y_offset", "z_offset")
_AXIS_KEYS = ("min", "max", "continuous", "velocity", "acceleration", "jerk", "servo")
_TABLE_KEYS = ("radius", "height", "z_top")


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

    @property
    def axis_names(self) -> tuple[str, ...]:
        """Joint column names in order."""
        return tuple(self.axes)

    def limits(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Lower and upper travel limits, each ``(5,)`` in internal units (mm, rad)."""
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
class _Reader:
    """Typed access to a TOML table with errors naming file and field."""

    def __init__(self, file: Path | None) -> None:
        self.file = file

    def fail(
        self, message: str, field: str, value: Any = None, accepted: str | None = None
    ) -> InputError:
        return InputError(message, file=self.file, field=field, value=value, accepted=accepted)

    def table(
        self, data: Mapping[str, Any], key: str, field: str, keys: tuple[str, ...]
    ) -> Mapping[str, Any]:
        value = data.get(key, {})
        if not isinstance(value, Mapping):
            raise self.fail("must be a table", field, value, "a TOML table [" + field + "]")
        self.known(value, field, keys)
        return value

    def known(self, data: Mapping[str, Any], field: str, keys: tuple[str, ...]) -> None:
        for key in data:
            if key not in keys:
                where = f"{field}.{key}" if field else key
                raise self.fail("unknown key", where, key, ", ".join(keys))

    def text(
        self, data: Mapping[str, Any], key: str, field: str, default: str | None = None
    ) -> str:
        value = data.get(key, default)
        if value is None:
            raise self.fail("is required", field, accepted="a string")
        if not isinstance(value, str) or not value.strip():
            raise self.fail("must be a non-empty string", field, value, "a string")
        return value

    def flag(self, data: Mapping[str, Any], key: str, field: str, default: bool) -> bool:
        value = data.get(key, default)
        if not isinstance(value, bool):
            raise self.fail("must be true or false", field, value, "true, false")
        return value

    def number(
        self,
        data: Mapping[str, Any],
        key: str,
        field: str,
        default: float | None = None,
        positive: bool = False,
        finite: bool = True,
    ) -> float:
        value = data.get(key, default)
        if value is None:
            raise self.fail("is required", field, accepted="a number")
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.fail("must be a number", field, value, "a number")
        value = float(value)
        if math.isnan(value) or (finite and math.isinf(value)):
            raise self.fail("must be a finite number", field, value, "a finite number")
        if positive and not value > 0.0:
            raise self.fail("must be positive", field, value, "a number > 0")
        return value


def _axis(reader: _Reader, name: str, data: Any) -> AxisSpec:
    field_ = f"axes.{name}"
    if not isinstance(data, Mapping):
        raise reader.fail("must be a table", field_, data, f"a TOML table [{field_}]")
    reader.known(data, field_, _AXIS_KEYS)
    rotary = name in ROTARY_AXES
    scale = math.radians(1.0) if rotary else 1.0
    continuous = reader.flag(data, "continuous", f"{field_}.continuous", False)
    if continuous and not rotary:
        raise reader.fail(
            "only a rotary axis can be continuous",
            f"{field_}.continuous",
            True,
            "false (or omit) for a linear axis",
        )
    if continuous:
        for key in ("min", "max"):
            if key in data:
                raise reader.fail(
                    "a continuous axis has no travel limit",
                    f"{field_}.{key}",
                    data[key],
                    "omit min/max or set continuous = false",
                )
        lower, upper = -math.inf, math.inf
    else:
        lower = reader.number(data, "min", f"{field_}.min", finite=not rotary)
        upper = reader.number(data, "max", f"{field_}.max", finite=not rotary)
        if not lower < upper:
            raise reader.fail(
                "min must be below max", f"{field_}.max", upper, f"a number > min ({lower})"
            )
    servo_data = reader.table(data, "servo", f"{field_}.servo", SERVO_KEYS)
    servo = {
        key: reader.number(servo_data, key, f"{field_}.servo.{key}")
        for key in SERVO_KEYS
        if key in servo_data
    }
    for key, value in servo.items():
        if value < 0.0:
            raise reader.fail(
                "must not be negative", f"{field_}.servo.{key}", value, "a number >= 0"
            )
    return AxisSpec(
        name=name,
        rotary=rotary,
        minimum=lower * scale,
        maximum=upper * scale,
        velocity=reader.number(data, "velocity", f"{field_}.velocity", positive=True)
        * scale
        / 60.0,
        acceleration=reader.number(data, "acceleration", f"{field_}.acceleration", positive=True)
        * scale,
        jerk=reader.number(data, "jerk", f"{field_}.jerk", math.inf, positive=True, finite=False)
        * scale,
        servo=MappingProxyType(servo),
    )


def machine_from_dict(data: Mapping[str, Any], source: str | Path | None = None) -> Machine:
    """Validate an already parsed machine TOML document (see ``load_machine``).

    ``source`` is the file named in error messages and kept as ``Machine.source``.
    """
    file = None if source is None else Path(source)
    reader = _Reader(file)
    reader.known(data, "", _TOP_KEYS)
    kinematics = reader.text(data, "kinematics", "kinematics")
    names = joint_names_for(kinematics, file)
    axes_data = reader.table(data, "axes", "axes", names)
    missing = [name for name in names if name not in axes_data]
    if missing:
        raise reader.fail(
            f"kinematics {kinematics!r} needs axis {missing[0]}",
            f"axes.{missing[0]}",
            accepted=f"tables [axes.X] for X in {names}",
        )
    axes = {name: _axis(reader, name, axes_data[name]) for name in names}
    pivot_data = reader.table(data, "pivot", "pivot", _PIVOT_KEYS)
    pivot = PivotOffsets(
        **{key: reader.number(pivot_data, key, f"pivot.{key}", 0.0) for key in _PIVOT_KEYS}
    )
    table = None
    if "table" in data:
        table_data = reader.table(data, "table", "table", _TABLE_KEYS)
        table = TableGeometry(
            radius=reader.number(table_data, "radius", "table.radius", positive=True),
            height=reader.number(table_data, "height", "table.height", positive=True),
            z_top=reader.number(table_data, "z_top", "table.z_top", 0.0),
        )
    description = data.get("description", "")
    if not isinstance(description, str):
        raise reader.fail("must be a string", "description", description, "a string")
    return Machine(
        name=reader.text(data, "name", "name"),
        kinematics=kinematics,
        axes=MappingProxyType(axes),
        pivot=pivot,
        conventional_directions=reader.flag(
            data, "conventional_directions", "conventional_directions", False
        ),
        tcp=reader.flag(data, "tcp", "tcp", False),
        post=reader.text(data, "post", "post", "linuxcnc"),
        table=table,
        source=file,
        description=description,
    )


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
    try:
        text = path.read_bytes().decode("utf-8")
    except FileNotFoundError:
        raise InputError("machine file not found", file=path) from None
    except (OSError, UnicodeDecodeError) as error:
        raise InputError(f"cannot read machine file: {error}", file=path) from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise InputError(f"not valid TOML: {error}", file=path) from None
    return machine_from_dict(data, path)
