"""Seven-segment asymmetric jerk (S-curve) profiles, vectorised over many parameter sets.

Method M5 (seed 000, section III.A): a point-to-point move of length ``stroke`` is
planned with the jerk

    +J0u, 0, -J0u, 0 (cruise), -J0d, 0, +J0d,   J0u = Amaxu / tj,  J0d = Amaxd / tj,

and ``tj = S * pid_period`` (S factor, PID update period 250 us in the paper). S = 0
gives the trapezoidal profile (jerk segments of zero length).

Degenerate cases (our reading; the paper only says the prescribed maxima are "not
reached" then): the jerk magnitudes J0u, J0d are kept, and the profile is the
time-optimal one under the limits (Vmax, Amaxu, J0u) while accelerating and
(Vmax, Amaxd, J0d) while decelerating. When the acceleration phase would reach Vmax
before Amaxu (``Vmax < Amaxu * tj``) its peak acceleration is ``sqrt(v * J0u)`` and its
jerk segments are shorter than tj; when the stroke is too short for Vmax the cruise
vanishes and the peak velocity ``v < Vmax`` solves ``D(v) = stroke``, with
``D(v) = v / 2 * (T_up(v) + T_down(v))`` the distance covered accelerating to v and
braking from it. ``D`` is increasing and convex, so Newton's method from ``v = Vmax``
converges monotonically; no bisection is needed.

Internal units: mm (or rad), s. Negative strokes move backwards (mirror image).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from impeller_cam.errors import InputError

#: PID update period of the paper's motion card (NI PCI-7344), s.
PAPER_PID_PERIOD = 250e-6

#: Newton iterations for the peak velocity of a move without cruise (quadratic
#: convergence from above; 100 covers strokes down to 1e-12 of Vmax^2 / Amax).
_NEWTON_ITERATIONS = 100

Array = NDArray[np.float64]


@dataclass(frozen=True)
class SCurveProfiles:
    """Planned seven-segment profiles, one row per parameter set.

    Attributes
    ----------
    durations : (n, 7) float64
        Segment durations, s (jerk +, const acc, jerk -, cruise, jerk -, const dec,
        jerk +).
    jerk : (n, 7) float64
        Jerk of each segment, mm/s^3; 0 for segments of zero length (S = 0).
    boundary_acceleration, boundary_velocity, boundary_position : (n, 8) float64
        Acceleration (mm/s^2), velocity (mm/s) and position (mm) at the segment
        boundaries; the last column is the end of the move.
    sign : (n,) float64
        +1 or -1: direction of the move (the arrays above are signed).
    """

    durations: Array
    jerk: Array
    boundary_acceleration: Array
    boundary_velocity: Array
    boundary_position: Array
    sign: Array

    @property
    def switch_times(self) -> Array:
        """Segment boundary times ``(n, 8)``, s, starting at 0."""
        times = np.zeros((len(self.durations), 8))
        np.cumsum(self.durations, axis=1, out=times[:, 1:])
        return times

    @property
    def duration(self) -> Array:
        """Total duration (access time) of each move ``(n,)``, s."""
        total: Array = self.durations.sum(axis=1)
        return total

    @property
    def peak_velocity(self) -> Array:
        """Largest speed reached ``(n,)``, mm/s (>= 0)."""
        return np.abs(self.boundary_velocity[:, 3])

    @property
    def peak_acceleration(self) -> Array:
        """Largest acceleration magnitude reached while speeding up ``(n,)``, mm/s^2."""
        return np.abs(self.boundary_acceleration[:, 1])

    @property
    def peak_deceleration(self) -> Array:
        """Largest deceleration magnitude reached while braking ``(n,)``, mm/s^2."""
        return np.abs(self.boundary_acceleration[:, 5])

    def __len__(self) -> int:
        return len(self.durations)


def _check(name: str, value: Array, *, positive: bool) -> None:
    bad = ~np.isfinite(value) | ((value <= 0.0) if positive else (value < 0.0))
    if np.any(bad):
        first = value[np.flatnonzero(bad)[0]]
        raise InputError(
            "must be a finite number " + ("> 0" if positive else ">= 0"),
            field=name,
            value=float(first),
            accepted="a finite number " + ("> 0" if positive else ">= 0"),
        )


@numba.njit(cache=True)
def _phase_time(v: float, amax: float, tj: float) -> float:  # pragma: no cover
    """Duration of a rest-to-``v`` phase under (amax, jerk amax/tj), s."""
    if v >= amax * tj:
        return v / amax + tj
    return 2.0 * math.sqrt(v * tj / amax)


@numba.njit(cache=True)
def _phase_slope(v: float, amax: float, tj: float) -> float:  # pragma: no cover
    """d(phase time)/dv."""
    if v >= amax * tj:
        return 1.0 / amax
    return math.sqrt(tj / amax / max(v, 1e-300))


@numba.njit(cache=True)
def _peak_velocity(x: float, vmax: float, au: float, ad: float, tj: float) -> float:
    """Peak velocity: Vmax when reachable, else the root of D(v) = x (Newton from above).

    ``D(v) = v / 2 (T_up(v) + T_down(v))`` is increasing, convex and C1, so Newton's
    iterates from ``v = Vmax`` decrease monotonically onto the root.
    """  # pragma: no cover
    if x <= 0.0:
        return 0.0
    v = vmax
    if 0.5 * v * (_phase_time(v, au, tj) + _phase_time(v, ad, tj)) <= x:
        return v
    for _ in range(_NEWTON_ITERATIONS):
        tu, td = _phase_time(v, au, tj), _phase_time(v, ad, tj)
        f = 0.5 * v * (tu + td) - x
        df = 0.5 * (tu + td) + 0.5 * v * (_phase_slope(v, au, tj) + _phase_slope(v, ad, tj))
        new = v - f / df
        if new <= 0.0:
            new = 0.5 * v
        if abs(new - v) <= 4e-16 * v or abs(f) <= 1e-14 * x:
            return new
        v = new
    return v


@numba.njit(cache=True)
def _plan_kernel(
    x: NDArray[np.float64],
    vmax: NDArray[np.float64],
    au: NDArray[np.float64],
    ad: NDArray[np.float64],
    tj: NDArray[np.float64],
    durations: NDArray[np.float64],
    jerk: NDArray[np.float64],
    acc: NDArray[np.float64],
    vel: NDArray[np.float64],
    pos: NDArray[np.float64],
) -> None:  # pragma: no cover - compiled
    for i in range(x.shape[0]):
        s = 1.0 if x[i] >= 0.0 else -1.0
        stroke = abs(x[i])
        t = tj[i]
        v = _peak_velocity(stroke, vmax[i], au[i], ad[i], t)
        pu = pd = ju = jd = cu = cd = 0.0
        if v > 0.0:
            if v >= au[i] * t:
                ju, cu, pu = t, v / au[i] - t, au[i]
            else:
                ju, pu = np.sqrt(v * t / au[i]), np.sqrt(v * au[i] / t)
            if v >= ad[i] * t:
                jd, cd, pd = t, v / ad[i] - t, ad[i]
            else:
                jd, pd = np.sqrt(v * t / ad[i]), np.sqrt(v * ad[i] / t)
        cruise = 0.0
        if v > 0.0:
            covered = 0.5 * v * (_phase_time(v, au[i], t) + _phase_time(v, ad[i], t))
            cruise = max(stroke - covered, 0.0) / v
        d = (ju, cu, ju, cruise, jd, cd, jd)
        a = (0.0, pu, pu, 0.0, 0.0, -pd, -pd, 0.0)
        vel[i, 0] = 0.0
        pos[i, 0] = 0.0
        acc[i, 0] = 0.0
        for k in range(7):
            dk = d[k]
            durations[i, k] = dk
            slope = (a[k + 1] - a[k]) / dk if dk > 0.0 else 0.0
            # a denormal jerk time gives an infinite jerk over no time: treat as a step
            jerk[i, k] = s * slope if np.isfinite(slope) else 0.0
            acc[i, k + 1] = s * a[k + 1]
            vel[i, k + 1] = vel[i, k] + s * 0.5 * (a[k] + a[k + 1]) * dk
            pos[i, k + 1] = pos[i, k] + vel[i, k] * dk + s * dk * dk * (a[k] / 3.0 + a[k + 1] / 6.0)
        vel[i, 3] = s * v  # exact cruise speed (the sums above agree to rounding)
        vel[i, 4] = s * v
        vel[i, 7] = 0.0


def plan_scurve(
    stroke: ArrayLike,
    vmax: ArrayLike,
    amax_up: ArrayLike,
    amax_down: ArrayLike,
    s_factor: ArrayLike,
    pid_period: float = PAPER_PID_PERIOD,
) -> SCurveProfiles:
    """Plan seven-segment asymmetric S-curve moves from rest to rest.

    All array arguments broadcast against each other.

    Parameters
    ----------
    stroke : array_like
        Move length Xmax, mm (negative: move backwards; 0: no move).
    vmax : array_like
        Maximum velocity Vmax, mm/s, > 0.
    amax_up : array_like
        Maximum acceleration Amaxu, mm/s^2, > 0.
    amax_down : array_like
        Magnitude of the maximum deceleration |Amaxd|, mm/s^2, > 0.
    s_factor : array_like
        S factor >= 0; jerk time ``tj = s_factor * pid_period``.
    pid_period : float
        PID update period, s (paper: 250 us).

    Returns
    -------
    SCurveProfiles
        ``n`` planned moves (``n`` = broadcast size).

    Raises
    ------
    InputError
        For a non-finite stroke, a limit <= 0, a negative S factor or PID period <= 0.
    """
    arrays = np.broadcast_arrays(
        *(np.atleast_1d(np.asarray(a, dtype=np.float64)) for a in
          (stroke, vmax, amax_up, amax_down, s_factor))
    )
    x, v_lim, au, ad, s = (np.ascontiguousarray(a).reshape(-1) for a in arrays)
    _check("stroke", np.abs(x), positive=False)
    _check("vmax", v_lim, positive=True)
    _check("amax_up", au, positive=True)
    _check("amax_down", ad, positive=True)
    _check("s_factor", s, positive=False)
    _check("pid_period", np.array([pid_period], dtype=np.float64), positive=True)
    tj = s * pid_period

    n = len(x)
    durations = np.empty((n, 7))
    jerk = np.empty((n, 7))
    acc, vel, pos = np.empty((n, 8)), np.empty((n, 8)), np.empty((n, 8))
    _plan_kernel(x, v_lim, au, ad, tj, durations, jerk, acc, vel, pos)
    return SCurveProfiles(
        durations=durations,
        jerk=jerk,
        boundary_acceleration=acc,
        boundary_velocity=vel,
        boundary_position=pos,
        sign=np.where(x < 0.0, -1.0, 1.0),
    )


def sample_scurve(
    profiles: SCurveProfiles, times: ArrayLike
) -> tuple[Array, Array, Array, Array]:
    """Sample jerk, acceleration, velocity and position of every profile.

    Parameters
    ----------
    profiles : SCurveProfiles
        ``n`` planned moves.
    times : (m,) or (n, m) array_like
        Sample times, s. Before 0 the move is at rest at 0; after its end it rests
        at the stroke.

    Returns
    -------
    jerk, acceleration, velocity, position : (n, m) float64
        mm/s^3, mm/s^2, mm/s, mm.
    """
    t = np.asarray(times, dtype=np.float64)
    n = len(profiles)
    if t.ndim == 1:
        t = np.broadcast_to(t, (n, t.shape[0]))
    if t.shape[0] != n:
        raise ValueError(f"times must be (m,) or ({n}, m), not {t.shape}")
    switch = profiles.switch_times
    seg = np.empty(t.shape, dtype=np.int64)
    for i in range(n):
        seg[i] = np.searchsorted(switch[i, 1:7], t[i], side="right")
    rows = np.arange(n)[:, None]
    tau = np.clip(t - switch[rows, seg], 0.0, profiles.durations[rows, seg])
    j = profiles.jerk[rows, seg]
    a0 = profiles.boundary_acceleration[rows, seg]
    v0 = profiles.boundary_velocity[rows, seg]
    x0 = profiles.boundary_position[rows, seg]
    acc = a0 + j * tau
    vel = v0 + a0 * tau + 0.5 * j * tau**2
    pos = x0 + v0 * tau + 0.5 * a0 * tau**2 + j * tau**3 / 6.0
    before = t < 0.0
    after = t > switch[:, 7:8]
    end = profiles.boundary_position[:, 7:8]
    for arr in (j, acc, vel):
        arr[before | after] = 0.0
    pos = np.where(before, 0.0, np.where(after, np.broadcast_to(end, pos.shape), pos))
    return j, acc, vel, pos
