"""K_FFP advice for a program: the Best K_FFP method generalised (``program_servo``, 5).

The reference is the rotary axis that lags most (largest ``alpha_th / omega``); every
linear axis gets the K_FFP whose phase lag at the program's characteristic angular
frequency equals the reference's ramp lag, every other rotary axis the K_FFP that
gives it the reference's ramp lag. The characteristic frequency is the RMS angular
velocity of the rotary axes during feed blocks (a point on a table turning at omega
moves X/Y sinusoidally at omega).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from cam.motion.cycle_time import rotary_mask
from cam.motion.feeddrive import FeedDriveAxis, alpha_th, best_kffp
from impeller_cam.errors import InputError
from postproc.program import MachineProgram, Motion

if TYPE_CHECKING:
    from postproc.machine import Machine

__all__ = ["characteristic_omega", "recommend_kffp"]


def recommend_kffp(
    axes: dict[int, FeedDriveAxis], omega: float,
    source: dict[str, str] | None = None,
) -> tuple[dict[str, float | None], str | None]:
    """Best K_FFP per axis against the most lagging rotary axis.

    The reference is the rotary axis with the largest ramp lag per unit speed
    (an identified axis before a default one of equal lag). Linear axes get the
    Best K_FFP of Eq. (20) at ``omega``; other rotary axes, which turn in ramps like
    the reference, get the K_FFP that gives them the reference's ramp lag
    (``Ts / 2 + (1 - K / 100) / Kpp`` equal; None when outside 0..200 %).
    """
    rotaries = [a for a in axes.values() if a.rotary]
    if not rotaries:
        return {a.name: None for a in axes.values()}, None
    given = source or {}
    reference = max(rotaries, key=lambda a: (float(alpha_th(a, 1.0)),
                                             given.get(a.name, "identified") == "identified"))
    lag = float(alpha_th(reference, 1.0))
    out: dict[str, float | None] = {reference.name: reference.k_ffp}
    for axis in axes.values():
        if axis is reference:
            continue
        if axis.rotary:
            k = 100.0 * (1.0 - (lag - axis.ts / 2.0) * axis.kpp)
            out[axis.name] = k if 0.0 <= k <= 200.0 else None
            continue
        try:
            out[axis.name] = best_kffp(reference, axis, omega)
        except InputError:
            out[axis.name] = None
    return out, reference.name


def characteristic_omega(program: MachineProgram, machine: Machine,
                         joints: NDArray[np.float64], durations: NDArray[np.float64]
                         ) -> float:
    """RMS angular velocity of the rotary axes over feed blocks, rad/s (module doc)."""
    rotary = rotary_mask(machine)
    feed_rows = program.motion == Motion.LINEAR
    steps = np.diff(np.vstack([program.start[None, :], joints]), axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        rates = np.where(durations[:, None] > 0, steps / durations[:, None], 0.0)[:, rotary]
    weights = durations * feed_rows
    if weights.sum() > 0 and rates.size:
        return float(np.sqrt(np.sum(weights[:, None] * rates**2) / weights.sum()))
    return 0.0
