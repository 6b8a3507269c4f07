"""What every machine kinematics provides, and the over-travel error they raise.

A kinematics maps machine joints ``(n, 5)`` (X, Y, Z in mm, two rotary axes in
radians, column order of the machine's ``axes``) to tool poses in the workpiece frame
W (tip ``(n, 3)`` mm, unit axis ``(n, 3)`` from tip towards spindle) and back.
Implementations register themselves with ``postproc.kinematics.register_kinematics``.

This module imports nothing from ``postproc.machine`` at run time, so that the machine
model can import the error type from here without an import cycle.
"""

from __future__ import annotations

from math import degrees
from typing import TYPE_CHECKING, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from impeller_cam.errors import InputError

if TYPE_CHECKING:
    from pathlib import Path

    from postproc.machine import Machine

#: Slack allowed beyond an axis limit (internal units: mm or rad) before it counts as
#: over-travel: floating-point noise of the kinematics, far below any machine resolution.
LIMIT_SLACK: float = 1e-9


class OverTravelError(InputError):
    """A pose needs an axis beyond its travel limit.

    Parameters
    ----------
    index : int
        Row of the offending pose or joint vector (0-based).
    axis : str
        Axis name, e.g. ``"A"``.
    value : float
        Value the axis would need, user units (mm or degrees).
    limit : float
        The limit it passes, user units (mm or degrees).
    record : int, optional
        Source record of the pose (APT record or NC line), when known.
    unit : str
        ``"mm"`` or ``"deg"``.
    lower, upper : float
        The axis range, user units (for the "accepted" part of the message).
    file : str or Path, optional
        The machine file the limits came from.
    """

    def __init__(
        self,
        *,
        index: int,
        axis: str,
        value: float,
        limit: float,
        record: int | None = None,
        unit: str = "mm",
        lower: float | None = None,
        upper: float | None = None,
        file: str | Path | None = None,
    ) -> None:
        self.index = int(index)
        self.record = None if record is None else int(record)
        self.axis = axis
        self.limit = float(limit)
        self.unit = unit
        side = "maximum" if value > limit else "minimum"
        where = f"pose {self.index}"
        if self.record is not None:
            where += f" (record {self.record})"
        text = (
            f"{where}: axis {axis} would have to reach {float(value):.6f} {unit}, "
            f"beyond its {side} {self.limit:.6f} {unit}"
        )
        accepted = None
        if lower is not None and upper is not None:
            accepted = f"{axis} in [{lower:.6g}, {upper:.6g}] {unit}"
        self._text = text if accepted is None else f"{text}; accepted: {accepted}"
        if file is not None:
            self._text = f"{file}: {self._text}"
        super().__init__(text, file=file, field=f"axes.{axis}", accepted=accepted)
        # set after InputError.__init__, which stores value=None: __str__ names it already
        self.value = float(value)

    def __str__(self) -> str:
        return self._text


def first_over_travel(
    joints: NDArray[np.float64],
    lower: NDArray[np.float64],
    upper: NDArray[np.float64],
    slack: float = LIMIT_SLACK,
) -> tuple[int, int] | None:
    """Locate the first joint value outside its limits.

    Parameters
    ----------
    joints : (n, m) float64
        Joint vectors, internal units.
    lower, upper : (m,) float64
        Axis limits, internal units (``-inf`` / ``inf`` for unlimited axes).
    slack : float
        Tolerance beyond a limit, internal units.

    Returns
    -------
    (row, column) or None
        The first offending row and, in it, the first offending axis; ``None`` when all
        joints are inside their limits. NaN counts as offending.
    """
    joints = np.asarray(joints, dtype=np.float64)
    bad = ~((joints >= lower - slack) & (joints <= upper + slack))
    rows = np.flatnonzero(bad.any(axis=1))
    if len(rows) == 0:
        return None
    row = int(rows[0])
    return row, int(np.flatnonzero(bad[row])[0])


def over_travel_error(
    machine: Machine,
    joints: NDArray[np.float64],
    row: int,
    column: int,
    records: NDArray[np.int64] | None = None,
    index: int | None = None,
) -> InputError:
    """Build the ``OverTravelError`` for ``joints[row, column]`` of ``machine``.

    ``index`` overrides the reported pose index (default ``row``). A NaN joint gives a
    plain ``InputError`` (it is not a travel problem but a broken pose).
    """
    spec = list(machine.axes.values())[column]
    value = float(joints[row, column])
    lower, upper = spec.minimum, spec.maximum
    limit = upper if value > upper else lower
    to_user = degrees if spec.rotary else float
    if np.isnan(value):
        return InputError(
            f"pose {row}: axis {spec.name} is not a number",
            file=machine.source,
            field=f"axes.{spec.name}",
        )
    return OverTravelError(
        index=row if index is None else index,
        axis=spec.name,
        value=to_user(value),
        limit=to_user(limit),
        record=None if records is None else int(records[row]),
        unit="deg" if spec.rotary else "mm",
        lower=to_user(lower),
        upper=to_user(upper),
        file=machine.source,
    )


@runtime_checkable
class Kinematics(Protocol):
    """Forward and inverse kinematics of one machine.

    Attributes
    ----------
    name : str
        Registry key, e.g. ``"xyzac-trt"``.
    joint_names : tuple of str
        Joint column names, e.g. ``("X", "Y", "Z", "A", "C")``.
    machine : Machine
        The machine whose offsets, directions and limits are used.
    """

    name: str
    joint_names: tuple[str, ...]
    machine: Machine

    def forward(
        self, joints: NDArray[np.float64], tool_length: float = 0.0
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Joints -> tool poses in W.

        Parameters
        ----------
        joints : (n, 5) float64
            X, Y, Z (mm) and the two rotary joints (rad).
        tool_length : float
            Tip distance below the controlled point along machine Z, mm (0: the joints
            command the tip).

        Returns
        -------
        tip : (n, 3) float64
            Tool tip in W, mm.
        axis : (n, 3) float64
            Unit tool axis in W (tip towards spindle).
        """
        ...

    def inverse(
        self,
        tip: NDArray[np.float64],
        axis: NDArray[np.float64],
        tool_length: float = 0.0,
        previous: NDArray[np.float64] | None = None,
        *,
        records: NDArray[np.int64] | None = None,
        keep_branch: NDArray[np.bool_] | None = None,
    ) -> NDArray[np.float64]:
        """Tool poses -> joints on the continuous, least-travel branch.

        Parameters
        ----------
        tip : (n, 3) float64
            Tool tips in W, mm.
        axis : (n, 3) float64
            Tool axes in W (normalised).
        tool_length : float
            Tip distance below the controlled point along machine Z, mm.
        previous : (5,) float64, optional
            Joints before the first pose (mm, rad).
        records : (n,) int64, optional
            Source record of each pose, quoted in an ``OverTravelError``.
        keep_branch : (n,) bool, optional
            Moves (into pose i) that must not change the inverse branch: feed moves
            whose tool axis does not pass the C axis (``postproc.pole.keeps_branch``).
            Kinematics with a single branch may ignore it.

        Returns
        -------
        (n, 5) float64
            X, Y, Z (mm) and the rotary joints (rad).
        """
        ...

    def inverse_branches(
        self,
        tip: NDArray[np.float64],
        axis: NDArray[np.float64],
        tool_length: float = 0.0,
    ) -> NDArray[np.float64]:
        """Both raw inverse solutions.

        Parameters
        ----------
        tip : (n, 3) float64
            Tool tips in W, mm.
        axis : (n, 3) float64
            Tool axes in W (normalised).
        tool_length : float
            Tip distance below the controlled point along machine Z, mm.

        Returns
        -------
        (2, n, 5) float64
            Tilt >= 0 first; C in (-pi, pi] (mm, rad).
        """
        ...

    def world_from_workpiece(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        """Controller world coordinates of W points: what a tool-centre-point program
        commands with no work offset active.

        Parameters
        ----------
        points : (n, 3) float64
            Points in W, mm.

        Returns
        -------
        (n, 3) float64
            World coordinates, mm.
        """
        ...
