"""The paper's synchronisation test: shape error of a circle cut under a constant feed
speed vector at the cutting point (seed 004, sections 2.3, 3 and 4.1-4.2).

The C table turns at ``omega`` (command ``omega t`` from rest) while X and Y move the
tool on a circle of radius ``R_W`` about the C axis (``R_W cos(omega t)``,
``R_W sin(omega t)``), so that the workpiece contour of radius ``R_C`` is cut with
``F_C / R_C = F / R_W`` (Eq. 3). With the measured (here: simulated) positions

    X_R = R_W cos(theta) + R_C,  Y_R = R_W sin(theta)     commanded cutting point,
                                                           carried by the actual C
    X_L = x + R_C,               Y_L = y                   the tool's cutting point
    eps = (X_L - X_R, Y_L - Y_R)                           Eq. (4)
    (R_C - dR_C)^2 = (R_C - eps_X)^2 + eps_Y^2             Eq. (5)

and ``dR_C ~ -(alpha - beta) R_W sin(omega t) - dR cos(omega t)`` (Eq. 7). As in the
paper, the radius decrease ``dR`` is compensated in the command (``R_W / |G(j omega)|``
per linear axis), so what remains is the relative angle difference. The amplitude is
half the peak-to-peak shape error over the last full period (steady state).

``circle_sweep`` runs the test over the paper's angular velocities and load inertias
with the machine's K_FFP and with the Best K_FFP (Fig. 26's comparison);
``saturation_figures`` gives the torque-saturation figures of section 5.2 from the
torque limit, the inertias and the simulated drive (docs/motion.md, section 5).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from cam.motion.feeddrive import DEFAULT_DT, FeedDriveAxis, simulate_axis, transfer
from cam.motion.schema import CircleTestTable


@dataclass(frozen=True)
class CircleTest:
    """Result of one simulated circle test.

    Attributes
    ----------
    time : (n,) float64
        s.
    shape_error : (n,) float64
        dR_C(t), mm.
    angle_difference : (n,) float64
        alpha - beta: the tool's angular lag about the C axis minus the table's, rad.
    amplitude : float
        Half peak-to-peak of the shape error over the last period, mm.
    saturated : bool
        The rotary axis hit its torque limit.
    """

    time: NDArray[np.float64]
    shape_error: NDArray[np.float64]
    angle_difference: NDArray[np.float64]
    amplitude: float
    saturated: bool


def circle_test(
    rotary: FeedDriveAxis,
    x_axis: FeedDriveAxis,
    y_axis: FeedDriveAxis,
    omega: float,
    r_c: float = 5.0,
    r_w: float = 8.0,
    settle: float = 0.6,
    dt: float = DEFAULT_DT,
    compensate_radius: bool = True,
) -> CircleTest:
    """Simulate the paper's test at angular velocity ``omega`` (rad/s).

    Parameters
    ----------
    rotary, x_axis, y_axis : FeedDriveAxis
        Servo models (with the K_FFP to test).
    omega : float
        rad/s.
    r_c, r_w : float
        Workpiece radius of curvature and tool-centre radius, mm (paper: 5 and 8).
    settle : float
        Time allowed for the start transient before the measured period, s.
    dt : float
        Simulation step, s.
    compensate_radius : bool
        Scale each linear command by ``1 / |G(j omega)|`` (the paper's radius
        compensation).
    """
    period = 2.0 * np.pi / omega
    n = int(np.ceil((settle + period) / dt)) + 1
    t = np.arange(n, dtype=np.float64) * dt
    theta_cmd = omega * t
    gain_x = abs(complex(transfer(x_axis, 1j * omega))) if compensate_radius else 1.0
    gain_y = abs(complex(transfer(y_axis, 1j * omega))) if compensate_radius else 1.0
    rot = simulate_axis(rotary, theta_cmd, dt)
    x = simulate_axis(x_axis, r_w / gain_x * np.cos(theta_cmd), dt).position
    y = simulate_axis(y_axis, r_w / gain_y * np.sin(theta_cmd), dt).position
    theta = rot.position
    eps_x = (x + r_c) - (r_w * np.cos(theta) + r_c)
    eps_y = y - r_w * np.sin(theta)
    shape = r_c - np.sqrt((r_c - eps_x) ** 2 + eps_y**2)
    tool_angle = np.unwrap(np.arctan2(y, x))
    difference = (theta_cmd - theta) - (theta_cmd - tool_angle)
    last = t >= t[-1] - period
    amplitude = 0.5 * float(np.ptp(shape[last]))
    return CircleTest(time=t, shape_error=shape, angle_difference=difference,
                      amplitude=amplitude, saturated=bool(rot.saturated.any()))


@dataclass(frozen=True)
class CirclePoint:
    """One (J1, omega) point of the circle-test sweep.

    Attributes
    ----------
    total_inertia, omega : float
        J + J1 (kg m^2) and rad/s.
    machine_amplitude, best_amplitude : float
        Half-amplitude of the shape error with the axes' own K_FFP and with the Best
        K_FFP of each linear axis, mm.
    best_kffp : dict of str -> float
        Best K_FFP per linear axis, percent.
    saturated : bool
        The rotary axis reached its torque limit (start of the ramp).
    """

    total_inertia: float
    omega: float
    machine_amplitude: float
    best_amplitude: float
    best_kffp: dict[str, float]
    saturated: bool


def circle_sweep(axes: dict[str, FeedDriveAxis], test: CircleTestTable,
                 dt: float = DEFAULT_DT) -> list[CirclePoint]:
    """The paper's Fig. 26 comparison: shape error vs omega, machine vs Best K_FFP.

    Parameters
    ----------
    axes : dict of str -> FeedDriveAxis
        The feed drives (``feeddrive.load_feed_drives``).
    test : CircleTestTable
        Axes, radii, angular velocities and load inertias of the test.
    """
    from cam.motion.feeddrive import best_kffp

    rotary = axes[test.rotary]
    x_axis, y_axis = (axes[name] for name in test.linear)
    out = []
    for load in test.load_inertia:
        table = rotary.with_load(load)
        for omega in test.omega:
            machine = circle_test(table, x_axis, y_axis, omega, test.r_c, test.r_w, dt=dt)
            best = {a.name: best_kffp(table, a, omega) for a in (x_axis, y_axis)}
            tuned = circle_test(table, x_axis.with_kffp(best[x_axis.name]),
                                y_axis.with_kffp(best[y_axis.name]), omega, test.r_c,
                                test.r_w, dt=dt)
            out.append(CirclePoint(total_inertia=table.total_inertia, omega=float(omega),
                                   machine_amplitude=machine.amplitude,
                                   best_amplitude=tuned.amplitude, best_kffp=best,
                                   saturated=machine.saturated))
    return out


@dataclass(frozen=True)
class SaturationFigures:
    """Torque-saturation figures of the rotary axis for one J + J1.

    Attributes
    ----------
    total_inertia : float
        kg m^2.
    limit_acceleration : float
        ``torque_limit / (J + J1)``, rad/s^2: what the limit alone allows.
    limit_omega : float
        ``Ts * limit_acceleration``, rad/s: the ramp speed whose smoothed command
        (acceleration ``omega / Ts``) needs exactly that, ideal following.
    model_omega : float
        First saturating ramp speed of the simulated feed drive, rad/s
        (``feeddrive.saturation_omega``: velocity-loop overshoot included).
    paper_omega, paper_acceleration : float or None
        The paper's figures (quoted in the test table).
    paper_acceleration_from_omega : float or None
        ``paper_omega / Ts``, rad/s^2: the paper's accelerations are its saturation
        speeds over the smoothing time.
    paper_torque : float or None
        ``(J + J1) paper_acceleration``, N m: the inertia torque at the paper's figure.
    """

    total_inertia: float
    limit_acceleration: float
    limit_omega: float
    model_omega: float
    paper_omega: float | None
    paper_acceleration: float | None
    paper_acceleration_from_omega: float | None
    paper_torque: float | None


def saturation_figures(rotary: FeedDriveAxis, test: CircleTestTable,
                       dt: float = DEFAULT_DT) -> list[SaturationFigures]:
    """Saturation figures for every load inertia of ``test`` (docs/motion.md)."""
    from cam.motion.feeddrive import saturation_omega

    out = []
    for i, load in enumerate(test.load_inertia):
        axis = rotary.with_load(load)
        total = axis.total_inertia
        acc = axis.torque_limit / total
        w_paper = test.paper_saturation_omega[i] if test.paper_saturation_omega and \
            i < len(test.paper_saturation_omega) else None
        a_paper = test.paper_saturation_acceleration[i] if \
            test.paper_saturation_acceleration and \
            i < len(test.paper_saturation_acceleration) else None
        out.append(SaturationFigures(
            total_inertia=total, limit_acceleration=acc, limit_omega=acc * axis.ts,
            model_omega=saturation_omega(axis, dt), paper_omega=w_paper,
            paper_acceleration=a_paper,
            paper_acceleration_from_omega=None if w_paper is None else w_paper / axis.ts,
            paper_torque=None if a_paper is None else total * a_paper))
    return out
