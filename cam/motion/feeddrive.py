"""Feed-drive (servo) model of one machine axis and the Best K_FFP method (M6, seed 004).

The paper's block diagram (its Fig. 11) is missing from the extraction; this module
uses the standard cascade it describes (Table 1's parameters, refs. [19, 20]), in motor
coordinates ``theta`` (rad; a linear axis converts with ``r = lead / 2 pi``):

    r        = MA_Ts[theta_c]                              smoothing (acc/dec), Ts
    v_ff     = K_FFP/100 * d/dt MA_Ta[r](t + Tp)           Pre-Control: averaged over
                                                           Ta, read Tp ahead
    v_cmd    = Kpp (r - theta) + v_ff                      position loop
    tau      = sat(Kvp e + Kvi int e),  e = v_cmd - theta'  velocity PI, torque limit
    (J + J1) theta'' = tau - C theta'                      mechanism

``MA_T`` is a moving average over the last ``T`` seconds (``(1 - e^{-sT}) / (sT)``): a
velocity step of the command becomes a ramp of length Ts, which is the paper's
``d omega / dt = omega / 0.064`` for Ts = 0.064 s. Without saturation the transfer
function from command to position is

    G(s) = MA_Ts(s) T_v(s) (Kpp + F(s)) / (s + Kpp T_v(s)),
    T_v(s) = (Kvp s + Kvi) / ((J + J1) s^2 + (C + Kvp) s + Kvi),
    F(s) = K_FFP/100 s e^{Tp s} MA_Ta(s).

Reading of the units (document, not the paper's words): Kvp in N m s/rad and Kvi in
N m/rad (torque per velocity error and per integrated velocity error); K_FF of Table 1
is the unit conversion between command and motor angle, which the motor coordinates
already contain. The paper's formulas (Eqs. 12, 17, 18):

    dR_th = (1 - |G_L(j w)|) R_W,
    alpha_th = lim_{s->0} s / (1 + G(s)) * w / s^2 with G = G_R / (1 - G_R)
             = -w G_R'(0) = w (Ts/2 + (1 - K_FFP/100) / Kpp)      (closed form here),
    beta_th = -angle G_L(j w).

Best K_FFP: the K_FFP of a linear axis at which ``alpha_th - beta_th = 0`` (the rotary
axis lags more; lowering the linear axes' pre-control delays them to match).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from cam.motion.schema import FeedDriveFile, FeedDriveServo
from cam.motion.tomlio import read_toml
from impeller_cam.errors import InputError
from impeller_cam.schema import validate

#: Default simulation step, s (divides Table 1's Ts, Ta, Tp exactly).
DEFAULT_DT = 1e-4


@dataclass(frozen=True)
class FeedDriveAxis:
    """Servo parameters of one axis (Table 1 of seed 004), SI units.

    Attributes
    ----------
    name : str
    rotary : bool
    kpp : float
        Position gain, 1/s.
    kvp : float
        Velocity proportional gain, N m s/rad.
    kvi : float
        Velocity integral gain, N m/rad.
    inertia : float
        J, equivalent inertia of the mechanism, kg m^2.
    load_inertia : float
        J1, load (workpiece) inertia, kg m^2.
    viscous : float
        C, viscous damping, N m s/rad.
    k_ffp : float
        Pre-Control coefficient K_FFP, percent.
    ts, ta, tp : float
        Smoothing, averaging and preceding time constants, s.
    torque_limit : float
        Motor torque limit, N m (``inf``: none).
    screw_lead : float or None
        Ball-screw lead, mm (linear axes); ``None``: ``r = 1 m/rad`` as Table 1's Y.
    """

    name: str
    rotary: bool
    kpp: float
    kvp: float
    kvi: float
    inertia: float
    viscous: float
    ts: float
    ta: float
    tp: float
    load_inertia: float = 0.0
    k_ffp: float = 100.0
    torque_limit: float = math.inf
    screw_lead: float | None = None

    @property
    def total_inertia(self) -> float:
        """J + J1, kg m^2."""
        return self.inertia + self.load_inertia

    @property
    def motor_per_unit(self) -> float:
        """Motor angle per axis unit: 1 rad/rad (rotary) or rad/mm (linear)."""
        if self.rotary:
            return 1.0
        if self.screw_lead is None:
            return 1e-3  # r = 1 m/rad: theta = x [m]
        return 2.0 * math.pi / self.screw_lead

    def with_kffp(self, k_ffp: float) -> FeedDriveAxis:
        """A copy with another K_FFP (percent)."""
        return replace(self, k_ffp=float(k_ffp))

    def with_load(self, load_inertia: float) -> FeedDriveAxis:
        """A copy with another load inertia J1, kg m^2."""
        return replace(self, load_inertia=float(load_inertia))


def axis_from_servo(
    name: str, servo: Mapping[str, float], rotary: bool, file: str | Path | None = None
) -> FeedDriveAxis:
    """Build a ``FeedDriveAxis`` from a servo mapping (machine TOML ``servo`` table).

    Raises
    ------
    InputError
        When a required key is missing, a key is unknown or a value is out of range.
    """
    table = validate(FeedDriveServo, dict(servo), file, at=("axes", name, "servo"))
    return _axis_of(name, table, rotary)


def load_feed_drives(path: str | Path) -> dict[str, FeedDriveAxis]:
    """Read a feed-drive TOML (``[axes.X]`` tables of servo keys; A/B/C are rotary)."""
    path = Path(path)
    doc = validate(FeedDriveFile, read_toml(path, "feed-drive"), path)
    return {name: _axis_of(name, table, name in ("A", "B", "C"))
            for name, table in doc.axes.items()}


def _axis_of(name: str, table: FeedDriveServo, rotary: bool) -> FeedDriveAxis:
    """A ``FeedDriveAxis`` from a validated servo table."""
    limit = math.inf if table.torque_limit is None else table.torque_limit
    return FeedDriveAxis(
        name=name, rotary=rotary, kpp=table.Kpp, kvp=table.Kvp,
        kvi=table.Kvi, inertia=table.J, viscous=table.C, ts=table.Ts, ta=table.Ta,
        tp=table.Tp, load_inertia=table.J1, k_ffp=table.K_FFP,
        torque_limit=limit if limit > 0.0 else math.inf, screw_lead=table.screw_lead,
    )


# --------------------------------------------------------------------------- frequency
def _moving_average_tf(s: NDArray[np.complex128], period: float) -> NDArray[np.complex128]:
    x = s * period
    small = np.abs(x) < 1e-6
    safe = np.where(small, 1.0, x)
    return np.where(small, 1.0 - x / 2.0, -np.expm1(-safe) / safe)


def transfer(axis: FeedDriveAxis, s: ArrayLike) -> NDArray[np.complex128]:
    """Closed-loop transfer function command -> position ``G(s)`` (no saturation).

    Parameters
    ----------
    axis : FeedDriveAxis
    s : array_like of complex
        Laplace variable, 1/s.
    """
    s = np.asarray(s, dtype=np.complex128)
    tv = (axis.kvp * s + axis.kvi) / (
        axis.total_inertia * s**2 + (axis.viscous + axis.kvp) * s + axis.kvi)
    ff = axis.k_ffp / 100.0 * s * np.exp(axis.tp * s) * _moving_average_tf(s, axis.ta)
    return _moving_average_tf(s, axis.ts) * tv * (axis.kpp + ff) / (s + axis.kpp * tv)


def radius_decrease(axis: FeedDriveAxis, omega: ArrayLike, r_w: float) -> NDArray[np.float64]:
    """Eq. (12): ``dR_th = (1 - |G_L(j omega)|) R_W``, mm (R_W in mm)."""
    return (1.0 - np.abs(transfer(axis, 1j * np.asarray(omega, dtype=np.float64)))) * r_w


def alpha_th(axis: FeedDriveAxis, omega: ArrayLike) -> NDArray[np.float64]:
    """Eq. (17): steady-state lag of ``axis`` for a ramp of slope ``omega``, rad.

    ``lim_{s->0} s (1 - G(s)) omega / s^2 = -omega G'(0)``; with the model above
    ``G'(0) = -(Ts / 2 + (1 - K_FFP/100) / Kpp)`` (the velocity loop's terms cancel,
    Pre-Control's look-ahead Tp and averaging Ta do not enter a ramp's steady state).
    """
    omega = np.asarray(omega, dtype=np.float64)
    return omega * (axis.ts / 2.0 + (1.0 - axis.k_ffp / 100.0) / axis.kpp)


def beta_th(axis: FeedDriveAxis, omega: ArrayLike) -> NDArray[np.float64]:
    """Eq. (18): phase lag ``-angle G_L(j omega)`` of a sinusoidal command, rad."""
    return -np.angle(transfer(axis, 1j * np.asarray(omega, dtype=np.float64)))


def best_kffp(
    rotary: FeedDriveAxis,
    linear: FeedDriveAxis,
    omega: float,
    bounds: tuple[float, float] = (0.0, 200.0),
) -> float:
    """Best K_FFP method (Eq. 20): the linear axis's K_FFP with alpha_th = beta_th.

    Parameters
    ----------
    rotary : FeedDriveAxis
        The rotary axis at its own K_FFP.
    linear : FeedDriveAxis
        The linear axis whose K_FFP is chosen.
    omega : float
        Angular velocity of the rotary axis = angular frequency of the linear
        axes' circular motion, rad/s.
    bounds : (float, float)
        Search interval of K_FFP, percent.

    Returns
    -------
    float
        K_FFP in percent (``scipy.optimize.brentq``, ``xtol`` 1e-12).

    Raises
    ------
    InputError
        When ``alpha_th - beta_th`` does not change sign inside ``bounds``.
    """
    from scipy.optimize import brentq

    target = float(alpha_th(rotary, omega))

    def mismatch(k: float) -> float:
        return target - float(beta_th(linear.with_kffp(k), omega))

    lo, hi = bounds
    f_lo, f_hi = mismatch(lo), mismatch(hi)
    if f_lo * f_hi > 0.0:
        raise InputError(
            f"no K_FFP in [{lo:g}, {hi:g}] % makes axis {linear.name} lag like "
            f"{rotary.name} at omega {omega:g} rad/s (alpha - beta = {f_lo:.3g} .. "
            f"{f_hi:.3g} rad)", field="K_FFP", value=omega,
            accepted="an angular velocity where the linear axis can be matched")
    return float(brentq(mismatch, lo, hi, xtol=1e-12, maxiter=200))


# --------------------------------------------------------------------------- time
def moving_average(values: NDArray[np.float64], period: float, dt: float) -> NDArray[np.float64]:
    """Causal moving average over ``period`` of a piecewise-linear sampled signal.

    Exact for the linear interpolant of ``values`` (cumulative trapezoid integral,
    interpolated at a fractional shift). Before the first sample the signal is held at
    ``values[0]``.
    """
    if period <= 0.0:
        return values.copy()
    integral = np.concatenate([[0.0], np.cumsum(0.5 * (values[1:] + values[:-1]) * dt)])
    t = np.arange(len(values)) * dt
    shifted = t - period
    before = shifted < 0.0
    # integral up to ``shifted``, exact for the linear interpolant of ``values``
    k = np.clip(np.floor(shifted / dt).astype(np.int64), 0, len(values) - 2)
    frac = shifted / dt - k
    v0, v1 = values[k], values[k + 1]
    lagged = integral[k] + dt * (v0 * frac + 0.5 * (v1 - v0) * frac**2)
    lagged = np.where(before, shifted * values[0], lagged)
    return (integral - lagged) / period


@numba.njit(cache=True)
def _servo_loop(
    reference: NDArray[np.float64], v_ff: NDArray[np.float64], kpp: float, kvp: float,
    kvi: float, inertia: float, viscous: float, limit: float, dt: float,
    position: NDArray[np.float64], torque: NDArray[np.float64],
    saturated: NDArray[np.bool_],
) -> None:  # pragma: no cover - compiled
    a = viscous / inertia
    if a * dt > 1e-8:
        decay = np.exp(-a * dt)
        w_from_t = (1.0 - decay) / viscous
        p_from_w = (1.0 - decay) / a
        p_from_t = (dt - p_from_w) / viscous
    else:
        decay = 1.0
        w_from_t = dt / inertia
        p_from_w = dt
        p_from_t = 0.5 * dt * dt / inertia
    theta = reference[0]
    omega = 0.0
    integral = 0.0
    for k in range(reference.shape[0]):
        position[k] = theta
        v_cmd = kpp * (reference[k] - theta) + v_ff[k]
        err = v_cmd - omega
        demand = kvp * err + kvi * (integral + err * dt)
        if abs(demand) > limit:
            saturated[k] = True
            tau = limit if demand > 0.0 else -limit
        else:
            saturated[k] = False
            tau = demand
            integral += err * dt  # conditional integration: no wind-up
        torque[k] = demand
        theta = theta + p_from_w * omega + p_from_t * tau
        omega = decay * omega + w_from_t * tau


@dataclass(frozen=True)
class AxisResponse:
    """Time response of one axis.

    Attributes
    ----------
    position : (n,) float64
        Actual axis position, axis units (mm or rad).
    torque : (n,) float64
        Torque demanded by the velocity loop, N m (before the limit).
    saturated : (n,) bool
        Demand beyond the torque limit at that sample.
    """

    position: NDArray[np.float64]
    torque: NDArray[np.float64]
    saturated: NDArray[np.bool_]


def simulate_axis(
    axis: FeedDriveAxis, command: ArrayLike, dt: float = DEFAULT_DT
) -> AxisResponse:
    """Simulate the feed drive following a sampled command, with torque saturation.

    Parameters
    ----------
    axis : FeedDriveAxis
    command : (n,) array_like
        Commanded axis position at ``k dt`` (mm or rad), piecewise linear in between;
        the axis starts at rest at ``command[0]``.
    dt : float
        Controller period, s. The mechanism is integrated exactly (zero-order hold
        of the torque); the controller is sampled.

    Returns
    -------
    AxisResponse
    """
    scale = axis.motor_per_unit
    theta_c = np.asarray(command, dtype=np.float64) * scale
    if theta_c.ndim != 1 or len(theta_c) < 3:
        raise ValueError("command must be a 1-D array of at least 3 samples")
    reference = moving_average(theta_c, axis.ts, dt)
    averaged = moving_average(reference, axis.ta, dt)
    # Pre-Control reads ``Tp`` ahead (linear interpolation between samples: exact for
    # the piecewise-linear command; a multiple of dt reads samples); past the last
    # sample the command continues with its last slope (a program's end is a stop)
    shift = axis.tp / dt
    whole = int(math.floor(shift))
    frac = shift - whole
    slope = averaged[-1] - averaged[-2]
    extended = np.concatenate([averaged, averaged[-1] + slope * np.arange(1, whole + 2)])
    n_cmd = len(averaged)
    future = extended[whole:whole + n_cmd] * (1.0 - frac) + \
        extended[whole + 1:whole + 1 + n_cmd] * frac
    v_ff = axis.k_ffp / 100.0 * np.gradient(future, dt)
    n = len(theta_c)
    position, torque = np.empty(n), np.empty(n)
    saturated = np.zeros(n, dtype=np.bool_)
    _servo_loop(reference, v_ff, axis.kpp, axis.kvp, axis.kvi, axis.total_inertia,
                axis.viscous, axis.torque_limit, dt, position, torque, saturated)
    return AxisResponse(position=position / scale, torque=torque, saturated=saturated)


def ramp_command(omega: float, duration: float, dt: float = DEFAULT_DT) -> NDArray[np.float64]:
    """The paper's rotary command: ``omega t`` from rest (rad), samples ``k dt``."""
    return np.asarray(omega * np.arange(int(round(duration / dt)) + 1) * dt, dtype=np.float64)


def peak_torque_per_omega(axis: FeedDriveAxis, dt: float = DEFAULT_DT) -> float:
    """Peak demanded torque per unit commanded angular velocity (no limit), N m s/rad.

    The response to the ramp command is linear in omega when nothing saturates.
    """
    duration = axis.ts + axis.ta + 10.0 / axis.kpp
    free = replace(axis, torque_limit=math.inf)
    response = simulate_axis(free, ramp_command(1.0, duration, dt), dt)
    return float(np.max(np.abs(response.torque)))


def saturation_omega(axis: FeedDriveAxis, dt: float = DEFAULT_DT) -> float:
    """Smallest commanded angular velocity whose ramp start saturates the torque, rad/s.

    Raises
    ------
    InputError
        When the axis has no torque limit.
    """
    if not math.isfinite(axis.torque_limit):
        raise InputError("the axis has no torque limit", field=f"axes.{axis.name}.servo."
                         "torque_limit", accepted="a torque limit in N m")
    return axis.torque_limit / peak_torque_per_omega(axis, dt)


def smallest_radius(omega_saturation: float, feed_mm_min: float) -> float:
    """Eq. (1) at the limit: ``R_C = F_C / omega``, mm (F_C in mm/min)."""
    if not (feed_mm_min > 0.0 and omega_saturation > 0.0):
        raise InputError("feed and angular velocity must be > 0", field="feed",
                         value=feed_mm_min, accepted="F_C > 0 mm/min")
    return feed_mm_min / 60.0 / omega_saturation
