"""Cutting layers along the rulings (M4 eqs. 2-3).

Our reading of the garbled eq. 2: with ``n1 = ceil(L / l)`` layers for the ruling
length ``L`` and the largest cutting depth ``l`` (the milling depth a_p), the cutter
point of pass point ``O_{i,j,0}`` (on the hub) in layer ``k`` is

    O_{i,j,k} = O_{i,j,0} + (P_{s,i} - P_{x,i}) (n1 - k) / n1,   k = 0 .. n1,

so layer 0 lies at the shroud and layer ``n1`` on the hub: equal steps of at most ``l``
down each ruling ``P_{x,i} -> P_{s,i}`` (hub point to shroud point). Eq. 3 gives the
cutter axis of that point for the simultaneous five-axis baseline,

    T_{i,j,k} = (P_{s,i} - O_{i,j,k}) / |P_{s,i} - O_{i,j,k}|.

With one ``n1`` for the passage (the longest ruling's), a ruling of length ``L_i``
shorter than the longest is cut in steps of ``L_i / n1``, thinner than ``l``: near
the outlet of a centrifugal impeller, where the blades are low, most layers remove a
fraction of the depth the tool could take. The paper's three-axis paths take their
layers "in terms of the milling depth a_p" instead (section 3); ``depth_layer_points``
is that reading: layer ``k`` lies ``k d`` below the shroud along every ruling, with
``d = L_max / n1 <= l`` (the same layers as eq. 2 on the longest ruling), and stops
at the hub,

    O_{i,j,k} = O_{i,j,0} + (P_{s,i} - P_{x,i}) max(0, 1 - k d / L_{i,j}),

so a short ruling reaches the hub after ``ceil(L_{i,j} / d)`` steps of ``d`` and its
deeper layers repeat the hub point (``repeats_layer_above``: nothing left to cut).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from impeller_cam.errors import InputError

__all__ = ["LAYERINGS", "depth_layer_points", "layer_axes", "layer_count", "layer_fractions",
           "layer_points", "repeats_layer_above"]

#: Layerings of the pass grid: eq. 2 (``"ruling"``) and constant depth (``"depth"``).
LAYERINGS = ("ruling", "depth")


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


def depth_layer_points(hub_points: NDArray[np.float64],
                       shroud_minus_hub: NDArray[np.float64], n1: int
                       ) -> NDArray[np.float64]:
    """Layers of constant depth below the shroud, ``(n1 + 1, ..., 3)`` (module docstring).

    Parameters
    ----------
    hub_points : (..., 3) float64
        ``O_{i,j,0}``, mm.
    shroud_minus_hub : (..., 3) float64
        ``P_{s,i} - P_{x,i}`` at each point, mm (not all zero).
    n1 : int
        Number of layer steps on the longest ruling: the step is ``L_max / n1``.
    """
    length = np.linalg.norm(shroud_minus_hub, axis=-1)
    step = float(length.max()) / n1
    k = np.arange(n1 + 1, dtype=np.float64).reshape((-1,) + (1,) * length.ndim)
    with np.errstate(divide="ignore", invalid="ignore"):
        f = np.where(length[None] > 0.0, np.clip(1.0 - k * step / length[None], 0.0, 1.0),
                     0.0)
    f[-1] = 0.0  # layer n1 is the hub (exactly: round-off leaves ~1e-16 on the longest)
    return np.asarray(hub_points[None] + f[..., None] * shroud_minus_hub[None])


def repeats_layer_above(centres: NDArray[np.float64]) -> NDArray[np.bool_]:
    """``(L, ...)`` mask of layer points equal to the layer above's (``centres``
    ``(L, ..., 3)``): a ruling that reached the hub in an earlier layer."""
    same = np.zeros(centres.shape[:-1], dtype=bool)
    same[1:] = np.all(np.abs(centres[1:] - centres[:-1]) <= 1e-9, axis=-1)
    return same


def layer_axes(shroud_points: NDArray[np.float64],
               cutter_points: NDArray[np.float64]) -> NDArray[np.float64]:
    """Eq. 3: unit axes ``(P_s - O) / |P_s - O|``, ``(..., 3)`` (broadcasting)."""
    d = np.asarray(shroud_points, dtype=np.float64) - np.asarray(cutter_points, np.float64)
    n = np.linalg.norm(d, axis=-1, keepdims=True)
    if np.any(n < 1e-12):
        raise ValueError("a cutter point coincides with its shroud point: eq. 3 undefined")
    return np.asarray(d / n)
