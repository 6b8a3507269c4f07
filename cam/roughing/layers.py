"""Cutting layers along the rulings (M4 eqs. 2-3).

Our reading of the garbled eq. 2: with ``n1 = ceil(L / l)`` layers for the ruling
length ``L`` and the largest cutting depth ``l`` (the milling depth a_p), the cutter
point of pass point ``O_{i,j,0}`` (on the hub) in layer ``k`` is

    O_{i,j,k} = O_{i,j,0} + (P_{s,i} - P_{x,i}) (n1 - k) / n1,   k = 0 .. n1,

so layer 0 lies at the shroud and layer ``n1`` on the hub: equal steps of at most ``l``
down each ruling ``P_{x,i} -> P_{s,i}`` (hub point to shroud point). Eq. 3 gives the
cutter axis of that point for the simultaneous five-axis baseline,

    T_{i,j,k} = (P_{s,i} - O_{i,j,k}) / |P_{s,i} - O_{i,j,k}|.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from impeller_cam.errors import InputError

__all__ = ["layer_axes", "layer_count", "layer_fractions", "layer_points"]


def layer_count(ruling_length: float, max_depth: float) -> int:
    """``n1 = ceil(L / l)``: layers needed so that no step exceeds ``l`` (eq. 2), >= 1.

    Parameters
    ----------
    ruling_length : float
        Longest ruling ``L``, mm.
    max_depth : float
        Largest cutting depth ``l`` (a_p), mm, > 0.
    """
    if not (math.isfinite(max_depth) and max_depth > 0):
        raise InputError("milling depth must be positive", field="max_depth_mm",
                         value=max_depth, accepted="a depth > 0 mm")
    return max(1, math.ceil(ruling_length / max_depth - 1e-9))


def layer_fractions(n1: int) -> NDArray[np.float64]:
    """``(n1 - k) / n1`` for ``k = 0 .. n1``: from 1 (shroud) down to 0 (hub), ``(n1+1,)``."""
    k = np.arange(n1 + 1, dtype=np.float64)
    return (n1 - k) / n1


def layer_points(hub_points: NDArray[np.float64], shroud_minus_hub: NDArray[np.float64],
                 n1: int) -> NDArray[np.float64]:
    """Eq. 2: cutter points of every layer, ``(n1 + 1, ..., 3)``.

    Parameters
    ----------
    hub_points : (..., 3) float64
        ``O_{i,j,0}``, the pass points on (or offset from) the hub, mm.
    shroud_minus_hub : (..., 3) float64
        ``P_{s,i} - P_{x,i}``, the ruling from hub to shroud at each point, mm.
    n1 : int
        Number of layer steps.
    """
    f = layer_fractions(n1).reshape((-1,) + (1,) * np.ndim(hub_points))
    return np.asarray(hub_points[None] + f * shroud_minus_hub[None])


def layer_axes(shroud_points: NDArray[np.float64],
               cutter_points: NDArray[np.float64]) -> NDArray[np.float64]:
    """Eq. 3: unit axes ``(P_s - O) / |P_s - O|``, ``(..., 3)`` (broadcasting)."""
    d = np.asarray(shroud_points, dtype=np.float64) - np.asarray(cutter_points, np.float64)
    n = np.linalg.norm(d, axis=-1, keepdims=True)
    if np.any(n < 1e-12):
        raise ValueError("a cutter point coincides with its shroud point: eq. 3 undefined")
    return np.asarray(d / n)
