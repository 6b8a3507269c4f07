"""Table-rotary-tilting kinematics (XYZAC and XYZBC tables), shared core.

The formulas have the same meaning as LinuxCNC's ``xyzac-trt-kins`` and
``xyzbc-trt-kins`` (src/emc/kinematics/trtfuncs.c, ``xyzacKinematicsForward/Inverse``
and ``xyzbcKinematicsForward/Inverse``; src/emc/kinematics/trtfuncs_math.h for the
``conventional-directions`` pin). They are written here in rotation-matrix form (see
docs/kinematics.md for the derivation and the term-by-term match):

    world = Rz(-s c) (Ru(-s t) (J - r - o) + o) + r          (forward)
    J     = r + o + Ru(s t) (Rz(s c) (world - r) - o)         (inverse)

with ``u`` the tilt axis (X for A, Y for B), ``r`` the C rotation point, ``o`` the tilt
pivot relative to it (``(0, y_offset, z_offset)`` for A, ``(x_offset, 0, z_offset)`` for
B), ``s = +1`` for LinuxCNC's default directions and ``s = -1`` for conventional
directions, ``J`` the controlled point of the machine (the tool tip when
``tool_length`` is 0; otherwise the tip is ``tool_length`` below ``J`` along machine Z).
The workpiece frame W is LinuxCNC's world frame moved to the rotation point:
``tip_W = world - r``. The tool axis in W is ``Rz(-s c) Ru(-s t) e_z``.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, ClassVar

import numpy as np
from numpy.typing import NDArray

from impeller_cam.errors import InputError
from impeller_cam.tolerances import DEFAULT_TOLERANCES
from postproc.kinematics.base import (
    LIMIT_SLACK,
    first_over_travel,
    over_travel_error,
)
from postproc.kinematics.branching import least_travel_path, wind_into_range

if TYPE_CHECKING:
    from postproc.machine import Machine


def rotate(vectors: NDArray[np.float64], angle: NDArray[np.float64], about: int
           ) -> NDArray[np.float64]:
    """Rotate each row of ``vectors`` by its own right-handed ``angle`` about a frame axis.

    Parameters
    ----------
    vectors : (n, 3) float64
    angle : (n,) float64
        Rotation angle per row, rad (positive: counter-clockwise looking down the axis).
    about : int
        0 for X, 1 for Y, 2 for Z.

    Returns
    -------
    (n, 3) float64
    """
    cos, sin = np.cos(angle), np.sin(angle)
    vectors = np.asarray(vectors, dtype=np.float64)
    out = vectors.copy()
    i, j = {0: (1, 2), 1: (2, 0), 2: (0, 1)}[about]
    out[:, i] = cos * vectors[:, i] - sin * vectors[:, j]
    out[:, j] = sin * vectors[:, i] + cos * vectors[:, j]
    return out


def wrap_angle(angle: NDArray[np.float64]) -> NDArray[np.float64]:
    """Angles wrapped into ``(-pi, pi]``, rad."""
    return np.pi - np.mod(np.pi - angle, 2.0 * np.pi)


def trt_forward(
    joints: NDArray[np.float64],
    rot_point: NDArray[np.float64],
    offset: NDArray[np.float64],
    tilt_about: int,
    sign: float,
    tool_length: float = 0.0,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Joints -> tool tip and tool axis in W for a table-tilting machine.

    Parameters
    ----------
    joints : (n, 5) float64
        X, Y, Z (mm), tilt, C (rad).
    rot_point : (3,) float64
        C rotation point in the machine frame, mm (LinuxCNC ``x/y/z-rot-point``).
    offset : (3,) float64
        Tilt pivot relative to the rotation point, mm (LinuxCNC ``x/y/z-offset``).
    tilt_about : int
        0 (A about X) or 1 (B about Y).
    sign : float
        +1 for LinuxCNC's default directions, -1 for conventional directions.
    tool_length : float
        Distance from the controlled point to the tool tip along machine -Z, mm.

    Returns
    -------
    tip : (n, 3) float64
        Tool tip in W, mm.
    axis : (n, 3) float64
        Unit tool axis in W.
    """
    joints = np.asarray(joints, dtype=np.float64).reshape(-1, 5)
    machine_tip = joints[:, :3] - np.array([0.0, 0.0, tool_length])
    tilt = -sign * joints[:, 3]
    turn = -sign * joints[:, 4]
    tip = rotate(rotate(machine_tip - rot_point - offset, tilt, tilt_about) + offset, turn, 2)
    spindle = np.zeros_like(machine_tip)
    spindle[:, 2] = 1.0
    axis = rotate(rotate(spindle, tilt, tilt_about), turn, 2)
    return tip, axis


def trt_inverse_position(
    tip: NDArray[np.float64],
    tilt: NDArray[np.float64],
    c: NDArray[np.float64],
    rot_point: NDArray[np.float64],
    offset: NDArray[np.float64],
    tilt_about: int,
    sign: float,
    tool_length: float = 0.0,
) -> NDArray[np.float64]:
    """Linear joints X, Y, Z (mm) putting the tip at ``tip`` (W) for given rotary joints.

    Parameters as for ``trt_forward``; ``tip`` (n, 3) mm, ``tilt`` and ``c`` (n,) rad.

    Returns
    -------
    (n, 3) float64
    """
    moved = rotate(rotate(tip, sign * c, 2) - offset, sign * tilt, tilt_about)
    return np.asarray(moved + rot_point + offset + np.array([0.0, 0.0, tool_length]),
                      dtype=np.float64)


def tool_axis_angles(
    axis: NDArray[np.float64], tilt_about: int
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Table angles that bring a tool axis in W onto machine +Z (the tilt >= 0 solution).

    Solves ``axis = Rz(-phi) Ru(-theta) e_z`` for ``theta`` in ``[0, pi]``:
    tilt about X: ``axis = (sin phi sin theta, cos phi sin theta, cos theta)``;
    tilt about Y: ``axis = (-cos phi sin theta, sin phi sin theta, cos theta)``.
    The other solution is ``(-theta, phi + pi)``.

    Parameters
    ----------
    axis : (n, 3) float64
        Unit tool axes in W.
    tilt_about : int
        0 (A about X) or 1 (B about Y).

    Returns
    -------
    theta : (n,) float64
        Table tilt, rad, in ``[0, pi]``.
    phi : (n,) float64
        Table rotation, rad, in ``(-pi, pi]`` (0 where the axis lies on Z).
    rho : (n,) float64
        ``sin theta``: distance of the axis from the C axis direction.
    """
    rho = np.hypot(axis[:, 0], axis[:, 1])
    theta = np.arctan2(rho, axis[:, 2])
    if tilt_about == 0:
        phi = np.arctan2(axis[:, 0], axis[:, 1])
    else:
        phi = np.arctan2(axis[:, 1], -axis[:, 0])
    return theta, wrap_angle(phi), rho


def _as_poses(
    tip: NDArray[np.float64], axis: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    tip = np.asarray(tip, dtype=np.float64)
    axis = np.asarray(axis, dtype=np.float64)
    if tip.ndim != 2 or tip.shape[1] != 3 or axis.shape != tip.shape:
        raise InputError(
            "tool tips and axes must both be (n, 3) arrays",
            field="tip/axis",
            value=(tip.shape, axis.shape),
        )
    norm = np.linalg.norm(axis, axis=1)
    bad = ~(np.isfinite(norm) & (norm > 1e-12)) | ~np.isfinite(tip).all(axis=1)
    if bad.any():
        row = int(np.flatnonzero(bad)[0])
        raise InputError(
            f"pose {row} has a non-finite tip or a zero-length tool axis",
            field="tip/axis",
            value=(tip[row].tolist(), axis[row].tolist()),
            accepted="finite tips and non-zero finite axes",
        )
    return tip, axis / norm[:, None]


class TableTiltingRotary:
    """A tilting table (A about X or B about Y) carrying a rotary table C.

    Subclasses set ``tilt_about``, ``joint_names`` and how the pivot offsets map to the
    offset vector.

    Parameters
    ----------
    machine : Machine
        Pivot offsets (mm), axis directions and limits.
    """

    name: ClassVar[str] = ""
    joint_names: ClassVar[tuple[str, ...]] = ()
    tilt_about: ClassVar[int] = 0

    def __init__(self, machine: Machine) -> None:
        self.machine = machine
        pivot = machine.pivot
        self.rot_point = np.array([pivot.x_rot_point, pivot.y_rot_point, pivot.z_rot_point])
        self.offset = self.pivot_offset(machine)
        self.sign = -1.0 if machine.conventional_directions else 1.0
        self.singular_tilt = DEFAULT_TOLERANCES.singular_tilt

    @staticmethod
    def pivot_offset(machine: Machine) -> NDArray[np.float64]:
        """Tilt pivot relative to the C rotation point.

        Parameters
        ----------
        machine : Machine

        Returns
        -------
        (3,) float64
            mm.
        """
        raise NotImplementedError

    # ------------------------------------------------------------------ forward
    def forward(
        self, joints: NDArray[np.float64], tool_length: float = 0.0
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Joints -> tool poses in W.

        Parameters
        ----------
        joints : (n, 5) float64
            X, Y, Z (mm), tilt, C (rad): the machine's controlled point and table angles.
        tool_length : float
            Tip distance below the controlled point along machine Z, mm (0: the joints
            already command the tool tip, as a joint-mode program under G43 does).

        Returns
        -------
        tip : (n, 3) float64
            Tool tip in W, mm.
        axis : (n, 3) float64
            Unit tool axis in W (tip towards spindle).
        """
        return trt_forward(
            joints, self.rot_point, self.offset, self.tilt_about, self.sign, tool_length
        )

    def world_from_workpiece(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        """LinuxCNC world coordinates (kinematics input) of W points, (n, 3) mm.

        This is what a tool-centre-point program commands when no work offset is
        active: ``points + rot_point``.

        Parameters
        ----------
        points : (n, 3) float64
            Points in W, mm.

        Returns
        -------
        (n, 3) float64
            mm.
        """
        return np.asarray(np.asarray(points, dtype=np.float64) + self.rot_point,
                          dtype=np.float64)

    # ------------------------------------------------------------------ inverse
    def _raw_branches(
        self, tip: NDArray[np.float64], axis: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
        """Tilt (2, n) and C (2, n) joints of both branches, and the singular mask."""
        theta, phi, rho = tool_axis_angles(axis, self.tilt_about)
        plus = (theta, phi)
        minus = (-theta, wrap_angle(phi + np.pi))
        # joint = sign * table angle; branch 0 is the one whose tilt joint is >= 0
        first, second = (plus, minus) if self.sign > 0 else (minus, plus)
        tilt = self.sign * np.stack([first[0], second[0]])
        c = wrap_angle(self.sign * np.stack([first[1], second[1]]))
        return tilt, c, rho < self.singular_tilt

    def inverse_branches(
        self,
        tip: NDArray[np.float64],
        axis: NDArray[np.float64],
        tool_length: float = 0.0,
    ) -> NDArray[np.float64]:
        """Both raw inverse solutions, without limits, winding or singularity handling.

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
            ``[0]``: tilt joint >= 0, ``[1]``: tilt joint <= 0; C in ``(-pi, pi]``
            (at a singular pose C is whatever ``atan2`` gives, usually 0).
        """
        tip, axis = _as_poses(tip, axis)
        tilt, c, _ = self._raw_branches(tip, axis)
        return self._branch_joints(tip, tilt, c, tool_length)

    def _branch_joints(
        self,
        tip: NDArray[np.float64],
        tilt: NDArray[np.float64],
        c: NDArray[np.float64],
        tool_length: float,
    ) -> NDArray[np.float64]:
        """Joints (2, n, 5) of both branches from their rotary joints (2, n)."""
        out = np.empty((2, len(tip), 5))
        for b in range(2):
            out[b, :, :3] = trt_inverse_position(
                tip,
                tilt[b],
                c[b],
                self.rot_point,
                self.offset,
                self.tilt_about,
                self.sign,
                tool_length,
            )
            out[b, :, 3] = tilt[b]
            out[b, :, 4] = c[b]
        return out

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
        """Tool poses in W -> joints, continuous and least rotary travel within limits.

        Parameters
        ----------
        tip : (n, 3) float64
            Tool tips in W, mm.
        axis : (n, 3) float64
            Tool axes in W (normalised here).
        tool_length : float
            See ``forward``.
        previous : (5,) float64, optional
            Joints before the first pose; the path starts next to them.
        records : (n,) int64, optional
            Source record of each pose, quoted in an over-travel error.
        keep_branch : (n,) bool, optional
            ``keep_branch[i]``: the move into pose ``i`` stays on the branch of pose
            ``i - 1`` (a feed move whose tool axis does not pass the C axis:
            ``postproc.pole.keeps_branch``). Where the limits allow no such
            sequence the constraint is dropped (the post then refuses the move that
            changes branch, naming its record).

        Returns
        -------
        (n, 5) float64
            X, Y, Z (mm), tilt, C (rad). C is unwound; at singular poses (tool axis on
            the C axis) C keeps its previous value and the tilt is exactly 0.

        Raises
        ------
        OverTravelError
            For the first pose that no branch can reach inside the limits.
        """
        tip, axis = _as_poses(tip, axis)
        n = len(tip)
        if records is not None and len(records) != n:
            raise InputError(
                "one record number per pose is needed",
                field="records",
                value=len(records),
                accepted=f"{n} records",
            )
        lower, upper = self.machine.limits()
        tilt, c_raw, singular = self._raw_branches(tip, axis)
        candidates = self._branch_joints(tip, tilt, c_raw, tool_length)
        # tilt and X, Y, Z inside their limits; C is met through the winding
        inside = (candidates[:, :, :4] >= lower[:4] - LIMIT_SLACK) & (
            candidates[:, :, :4] <= upper[:4] + LIMIT_SLACK
        )
        inside[:, singular, :3] = True  # position depends on the kept C: checked below
        feasible: NDArray[np.bool_] = np.all(inside, axis=2)
        c_range = (lower[4] - LIMIT_SLACK, upper[4] + LIMIT_SLACK)
        start = None
        if previous is not None:
            prev = np.asarray(previous, dtype=np.float64).reshape(5)
            if not np.isfinite(prev).all():
                raise InputError(
                    "previous joints must be finite", field="previous", value=prev.tolist()
                )
            start = (float(prev[3]), float(prev[4]))
        branch, c, failed = least_travel_path(tilt, c_raw, feasible, singular, c_range, start,
                                              keep_branch)
        if failed >= 0 and keep_branch is not None:
            branch, c, failed = least_travel_path(tilt, c_raw, feasible, singular, c_range,
                                                  start)
        if failed >= 0:
            raise self._explain(candidates[:, failed], failed, c_range, records)
        rows = np.arange(n)
        joints = np.empty((n, 5))
        # on the C axis pointing up the tilt is exactly 0 (pointing down it stays +-pi)
        joints[:, 3] = np.where(singular & (axis[:, 2] > 0.0), 0.0, tilt[branch, rows])
        joints[:, 4] = c
        joints[:, :3] = trt_inverse_position(
            tip,
            joints[:, 3],
            c,
            self.rot_point,
            self.offset,
            self.tilt_about,
            self.sign,
            tool_length,
        )
        found = first_over_travel(joints, lower, upper)
        if found is not None:
            raise over_travel_error(self.machine, joints, found[0], found[1], records)
        return joints

    def _explain(
        self,
        candidates: NDArray[np.float64],
        index: int,
        c_range: tuple[float, float],
        records: NDArray[np.int64] | None,
    ) -> Exception:
        """The over-travel error for a pose no branch reaches: the smaller miss wins."""
        lower, upper = self.machine.limits()
        best: tuple[float, Exception] | None = None
        for b in range(2):
            row = candidates[b].copy()
            wound = wind_into_range(row[4], 0.0, c_range)
            if not math.isnan(wound):
                row[4] = wound
            found = first_over_travel(row[None, :], lower, upper)
            if found is None:  # cannot happen for an infeasible pose; be safe
                continue
            column = found[1]
            miss = max(lower[column] - row[column], row[column] - upper[column])
            if column >= 3:
                miss = math.degrees(miss)
            error = over_travel_error(
                self.machine,
                row[None, :],
                0,
                column,
                None if records is None else np.asarray(records)[index : index + 1],
                index=index,
            )
            if best is None or miss < best[0]:
                best = (miss, error)
        if best is None:
            raise RuntimeError(f"pose {index} reported infeasible but inside all limits")
        return best[1]
