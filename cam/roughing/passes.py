"""Zigzag passes between the blades (M4 eqs. 4-9).

* Stepover of a ball of diameter ``d`` for the allowed scallop height ``h``:
  ``w = 2 sqrt(h (d - h))`` (the chord of the ball at height h; the extracted eq. 4,
  ``S / (2 sqrt(d - h))``, lost the ``h``); passes ``n_s = ceil(S / w)``.
* Eq. 5, linear interpolation between the first and last path:
  ``O_{i,j} = O_{i,1} + (O_{i,2} - O_{i,1}) j / n_s``.
* Eq. 6, the first path on the pressure side: the hub curve at the blade offset by
  ``d`` (tool radius plus allowance) along its in-hub normal and ``delta`` along the
  tool axis: ``OC_P(0) = L(u) + d V_n + delta V_T``.
* Eqs. 7-8: ``OC(i) = Rz(i theta) OC(0)``.
* Eq. 9: ``TP(theta_P) = (1 - lambda) OC_P(theta_P) + lambda OC_S(theta - theta_P)``,
  ``lambda = theta_P / theta``. Read with the rotations taken *towards each other*
  (pressure curve turned by ``+theta_P``, suction curve by ``-(theta - theta_P)``), both
  rotated copies lie at the same angle, and the general path is their blend: it starts
  on ``OC_P(0)`` (lambda = 0) and ends on ``OC_S(0)`` (lambda = 1). ``theta`` may vary
  along the curves (one value per point).
* Adjacent passes run in opposite directions (``zigzag_order``).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from impeller_cam.errors import InputError

__all__ = [
    "interpolated_pass",
    "linear_passes",
    "offset_curve",
    "pass_count",
    "rotate_z",
    "stepover",
    "zigzag_order",
]


def stepover(diameter: float, scallop: float) -> float:
    """``w = 2 sqrt(h (d - h))``, mm, for a ball of diameter ``d`` and scallop ``h``."""
    if not (0.0 < scallop < diameter):
        raise InputError("scallop height must lie between 0 and the tool diameter",
                         field="scallop_mm", value=scallop,
                         accepted=f"0 < h < {diameter} mm")
    return 2.0 * math.sqrt(scallop * (diameter - scallop))


def pass_count(width: float, step: float) -> int:
    """``n_s = ceil(S / w)``: intervals so that no step exceeds ``w``, >= 1."""
    return max(1, math.ceil(width / step - 1e-9))


def linear_passes(first: NDArray[np.float64], last: NDArray[np.float64],
                  n_s: int) -> NDArray[np.float64]:
    """Eq. 5: ``(n_s + 1, ..., 3)`` paths from ``first`` (j = 0) to ``last`` (j = n_s)."""
    j = (np.arange(n_s + 1, dtype=np.float64) / n_s).reshape((-1,) + (1,) * np.ndim(first))
    return np.asarray(first[None] + (last - first)[None] * j)


def offset_curve(curve: NDArray[np.float64], normal: NDArray[np.float64], d: float,
                 axis: NDArray[np.float64] | None = None, delta: float = 0.0
                 ) -> NDArray[np.float64]:
    """Eq. 6: ``L(u) + d V_n(u) + delta V_T``, ``(..., 3)`` mm."""
    out = np.asarray(curve, dtype=np.float64) + d * np.asarray(normal, dtype=np.float64)
    if axis is not None:
        out = out + delta * np.asarray(axis, dtype=np.float64)
    return np.asarray(out)


def rotate_z(points: NDArray[np.float64], angle: ArrayLike) -> NDArray[np.float64]:
    """Eqs. 7-8: ``Rz(angle) p`` for ``(..., 3)`` points; ``angle`` (rad) broadcasts."""
    p = np.asarray(points, dtype=np.float64)
    a = np.asarray(angle, dtype=np.float64)
    c, s = np.cos(a), np.sin(a)
    return np.stack([c * p[..., 0] - s * p[..., 1], s * p[..., 0] + c * p[..., 1],
                     np.broadcast_to(p[..., 2], np.broadcast(p[..., 0], a).shape)], axis=-1)


def interpolated_pass(oc_p: NDArray[np.float64], oc_s: NDArray[np.float64],
                      theta: ArrayLike, lam: float) -> NDArray[np.float64]:
    """Eq. 9: the general path at ``lambda = theta_P / theta``, ``(..., 3)``.

    Parameters
    ----------
    oc_p, oc_s : (..., 3) float64
        First paths on the pressure and suction side (same parametrisation).
    theta : float or (...,) float64
        Angle from ``oc_p`` to ``oc_s`` about +Z, rad.
    lam : float
        Interpolation ratio in [0, 1].
    """
    if not 0.0 <= lam <= 1.0:
        raise ValueError(f"lambda must lie in [0, 1], not {lam}")
    th = np.asarray(theta, dtype=np.float64)
    theta_p = lam * th
    a = rotate_z(oc_p, theta_p)
    b = rotate_z(oc_s, -(th - theta_p))
    return np.asarray((1.0 - lam) * a + lam * b)


def zigzag_order(n_passes: int, n_points: int) -> NDArray[np.int64]:
    """Flat indices ``(n_passes * n_points,)`` of a ``(n_passes, n_points)`` grid, zigzag.

    Even passes run forwards, odd passes backwards (eq. 4's "cutting directions of
    adjacent two tool paths are opposite").
    """
    index = np.arange(n_passes * n_points, dtype=np.int64).reshape(n_passes, n_points)
    index[1::2] = index[1::2, ::-1]
    return index.reshape(-1)
