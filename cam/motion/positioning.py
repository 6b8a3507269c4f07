"""Positioning time = access time + settling time (method M5, seed 000, Fig. 1).

The access time is the duration of the commanded move. The settling time is the time
after the end of the move until the table's response stays inside a band for good: on
table acceleration (the paper: +/-840 mm/s^2, calibrated to +/-5 um indexing accuracy)
or on table position (a band in mm about the target).

Closed form (used for millions of profiles): after the move ends at ``T`` the input is
constant, and the deviation from the steady state is a sum of decaying modes,

    e(T + tau) = Re sum_m c_m exp(lambda_m tau),
    c_m = -q_m lambda_m sum_seg da_seg phi(lambda_m d_seg) exp(lambda_m (T - t_seg)),

over the four jerk segments (start ``t_seg``, length ``d_seg``, acceleration change
``da_seg``), with ``phi(x) = (1 - exp(-x)) / x`` (``phi(0) = 1``: the trapezoidal
limit S = 0) and ``q_m`` from ``plant.residual_modes``. The settling time is found on
the controller's sample grid ``k dt`` (the paper's PID period): an envelope
``sum |c_m| exp(Re lambda_m tau)`` bounds where the response is certainly inside the
band; from there the grid is scanned backwards to the last sample outside the band.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import NDArray

from cam.motion.plant import Output, TwoMassPlant, residual_modes
from cam.motion.schema import SettlingTable
from cam.motion.scurve import PAPER_PID_PERIOD, SCurveProfiles
from impeller_cam.errors import InputError
from impeller_cam.schema import validate

#: The paper's settling band on table acceleration, mm/s^2.
PAPER_ACCELERATION_BAND = 840.0


@dataclass(frozen=True)
class Settling:
    """How settling is judged.

    Attributes
    ----------
    output : {"acceleration", "position"}
        Which table response must settle.
    band : float
        Half-width of the band: mm/s^2 for acceleration, mm for position.
    dt : float
        Sample grid of the settling search (controller period), s.
    """

    output: Output = "acceleration"
    band: float = PAPER_ACCELERATION_BAND
    dt: float = PAPER_PID_PERIOD

    def __post_init__(self) -> None:
        if self.output not in ("acceleration", "position"):
            raise InputError("unknown settling output", field="settling.output",
                             value=self.output, accepted="acceleration, position")
        for name in ("band", "dt"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0.0):
                raise InputError("must be a finite number > 0", field=f"settling.{name}",
                                 value=value, accepted="a finite number > 0")


def settling_from_dict(data: dict[str, object], file: object = None) -> Settling:
    """Read the optional ``[settling]`` table of a plant TOML (defaults: the paper's)."""
    if "settling" not in data:
        return Settling()
    where = str(file) if file else None
    table = validate(SettlingTable, data["settling"], where, at=("settling",))
    return Settling(output=table.output, band=table.band, dt=table.pid_period)


@numba.njit(cache=True)
def _phi(x: complex) -> complex:  # pragma: no cover - compiled
    if abs(x) < 1e-4:
        return 1.0 - x / 2.0 + x * x / 6.0
    return (1.0 - np.exp(-x)) / x


@numba.njit(cache=True)
def _residual_coefficients(
    durations: NDArray[np.float64],
    boundary_acceleration: NDArray[np.float64],
    rates: NDArray[np.complex128],
    weights: NDArray[np.complex128],
    out: NDArray[np.complex128],
) -> None:  # pragma: no cover - compiled
    n = durations.shape[0]
    m = rates.shape[0]
    for i in range(n):
        total = 0.0
        for k in range(7):
            total += durations[i, k]
        for j in range(m):
            lam = rates[j]
            acc = 0.0 + 0.0j
            start = 0.0
            for k in range(7):
                d = durations[i, k]
                if k % 2 == 0:
                    da = boundary_acceleration[i, k + 1] - boundary_acceleration[i, k]
                    if da != 0.0:
                        acc += da * _phi(lam * d) * np.exp(lam * (total - start))
                start += d
            out[i, j] = -weights[j] * lam * acc


def residual_coefficients(
    plant: TwoMassPlant, profiles: SCurveProfiles, output: Output = "acceleration"
) -> tuple[NDArray[np.complex128], NDArray[np.complex128]]:
    """Modal coefficients of the response after each move ends.

    Returns
    -------
    coefficients : (n, M) complex128
        ``c_m`` per profile (output units).
    rates : (M,) complex128
        ``lambda_m``, 1/s. ``e(tau) = Re sum_m c_m exp(lambda_m tau)``.
    """
    rates, weights = residual_modes(plant, output)
    out = np.empty((len(profiles), len(rates)), dtype=np.complex128)
    _residual_coefficients(
        np.ascontiguousarray(profiles.durations),
        np.ascontiguousarray(profiles.boundary_acceleration),
        rates, weights, out,
    )
    return out, rates


@numba.njit(cache=True)
def _settle_modal(
    coefficients: NDArray[np.complex128],
    rates: NDArray[np.complex128],
    band: float,
    dt: float,
    out: NDArray[np.float64],
) -> None:  # pragma: no cover - compiled
    n, m = coefficients.shape
    step_back = np.exp(-rates * dt)
    for i in range(n):
        # envelope: tau beyond which sum |c| exp(sigma tau) <= band
        horizon = 0.0
        for j in range(m):
            mag = abs(coefficients[i, j])
            sigma = rates[j].real
            if mag * m > band:
                tau = np.log(mag * m / band) / (-sigma)
                if tau > horizon:
                    horizon = tau
        k = int(np.ceil(horizon / dt)) + 1
        terms = np.empty(m, dtype=np.complex128)
        for j in range(m):
            terms[j] = coefficients[i, j] * np.exp(rates[j] * (k * dt))
        settled = 0.0
        while k >= 0:
            value = 0.0
            for j in range(m):
                value += terms[j].real
            if abs(value) > band:
                settled = (k + 1) * dt
                break
            for j in range(m):
                terms[j] *= step_back[j]
            k -= 1
        out[i] = settled


def settling_time_modal(
    coefficients: NDArray[np.complex128],
    rates: NDArray[np.complex128],
    band: float,
    dt: float,
) -> NDArray[np.float64]:
    """Settling time of ``e(tau) = Re sum_m c_m exp(lambda_m tau)`` on the grid ``k dt``.

    Parameters
    ----------
    coefficients : (n, M) complex128
    rates : (M,) complex128
        All with negative real part (a stable plant).
    band : float
        Band half-width, output units.
    dt : float
        Grid step, s.

    Returns
    -------
    (n,) float64
        ``(k + 1) dt`` for the last grid sample ``k`` outside the band, 0 if none.
    """
    if np.any(rates.real >= 0.0):
        raise InputError("the plant is not stable: a mode does not decay",
                         field="plant", value=[complex(r) for r in rates])
    out = np.empty(len(coefficients))
    _settle_modal(np.ascontiguousarray(coefficients), rates, float(band), float(dt), out)
    return out


def settling_time_sampled(
    response: NDArray[np.float64], end_index: int, target: float, band: float, dt: float
) -> NDArray[np.float64]:
    """Settling time from sampled responses (simulated or measured).

    Parameters
    ----------
    response : (p, n) float64
        Samples at ``k dt``.
    end_index : int
        Sample index where the move ends (``ceil(access / dt)``); settling is judged
        from here on.
    target : float
        Steady-state value (0 for acceleration, the stroke for position).
    band : float
        Band half-width.
    dt : float
        Sample period, s.

    Returns
    -------
    (p,) float64
        ``(k + 1) dt - end_index dt`` for the last sample ``k >= end_index`` outside the
        band (0 when none); ``inf`` when the last sample is still outside.
    """
    resp = np.atleast_2d(response)[:, end_index:]
    outside = np.abs(resp - target) > band
    out = np.zeros(len(resp))
    for i, row in enumerate(outside):
        idx = np.flatnonzero(row)
        if len(idx):
            out[i] = np.inf if idx[-1] == len(row) - 1 else (idx[-1] + 1) * dt
    return out


@dataclass(frozen=True)
class PositioningTimes:
    """Access, settling and positioning times ``(n,)`` of many moves, s."""

    access: NDArray[np.float64]
    settling: NDArray[np.float64]

    @property
    def positioning(self) -> NDArray[np.float64]:
        """Access time + settling time, s."""
        return self.access + self.settling


def positioning_times(
    plant: TwoMassPlant, profiles: SCurveProfiles, settling: Settling | None = None
) -> PositioningTimes:
    """Positioning time of every planned move on ``plant`` (closed form).

    Parameters
    ----------
    plant : TwoMassPlant
    profiles : SCurveProfiles
        ``n`` moves.
    settling : Settling, optional
        Band and grid (default: the paper's +/-840 mm/s^2 on acceleration, 250 us).

    Returns
    -------
    PositioningTimes
    """
    settling = Settling() if settling is None else settling
    coefficients, rates = residual_coefficients(plant, profiles, settling.output)
    settle = settling_time_modal(coefficients, rates, settling.band, settling.dt)
    return PositioningTimes(access=profiles.duration, settling=settle)
