"""The pass grid of one passage: ball-centre targets per layer, pass and station.

Passage 0 lies between blade 0's pressure side (+theta) and blade 1's suction side.
Stations ``u_i`` run from the leading to the trailing edge. At each station the first
paths ``OC_P(0)`` and ``OC_S(0)`` (eq. 6) are the hub edges of the two blade sides
offset by ``rho = R + eta`` along the side's normal turned into the hub's tangent
plane, and by ``rho`` along the hub normal (``delta`` of eq. 6 taken along the hub
normal, so the point is the centre of a ball of radius rho touching hub and blade).
The general paths between them follow eq. 9; each path point is carried up the
blended ruling in ``n1`` layers (eq. 2 or by milling depth, ``layers.py``). Every
other passage is this one turned by ``k * pitch`` about +Z.

**Lanes.** Without splitters the passage is one lane (blade 0's pressure side to
blade 1's suction side, the whole camber). With a splitter (leading edge at the
curve parameter ``u_s``) it is three lanes (``passage_lanes``): the inlet lane
between the main blades for ``u <= u_s``, then blade 0's pressure side to the
splitter's suction side, and the splitter's pressure side to blade 1's suction side
for ``u >= u_s``: the passes between a main blade and the splitter are bounded by
the splitter's offset side, so they respect it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from cam.roughing.layers import LAYERINGS, depth_layer_points, layer_count, layer_points
from cam.roughing.passes import interpolated_pass, pass_count, stepover
from geometry.surfaces import PRESSURE, SUCTION, BladeSurface, ImpellerSurfaces

__all__ = ["Lane", "PassageGrid", "passage_grid", "passage_lanes"]


@dataclass(frozen=True)
class Lane:
    """A lane of passage 0 between two blade sides over a camber range.

    ``pressure`` offers its pressure side (+theta), ``suction`` its suction side;
    ``u0, u1`` are parameters of the shared camber curves (a splitter's own u maps
    to ``u_start + u (1 - u_start)``).
    """

    name: str
    pressure: BladeSurface
    suction: BladeSurface
    u0: float
    u1: float


def passage_lanes(surfaces: ImpellerSurfaces) -> list[Lane]:
    """The lanes of passage 0 (see module docstring)."""
    blades = surfaces.blades
    a = blades[0]
    b = blades[1 % len(blades)]
    if not surfaces.splitters:
        return [Lane("passage", a, b, 0.0, 1.0)]
    sp = surfaces.splitters[0]
    start = sp.u_start
    return [Lane("inlet", a, b, 0.0, start), Lane("pressure-splitter", a, sp, start, 1.0),
            Lane("splitter-suction", sp, b, start, 1.0)]


def _own(blade: BladeSurface, uc: NDArray[np.float64]) -> NDArray[np.float64]:
    """A blade's own u at curve parameters ``uc`` (clipped to the blade)."""
    return np.asarray(np.clip((uc - blade.u_start) / (1.0 - blade.u_start), 0.0, 1.0))


@dataclass(frozen=True)
class PassageGrid:
    """Targets of passage 0.

    Attributes
    ----------
    centres : (n1 + 1, n_s + 1, m, 3) float64
        Ball-centre targets: layer k (0 at the shroud, n1 on the hub), pass j
        (0 at the pressure side), station i (leading to trailing edge), mm.
    ruling : (n_s + 1, m, 3) float64
        Blended ruling hub -> shroud at each pass point (``P_s - P_x``), mm.
    u : (m,) float64
        Camber-curve parameter of the stations.
    lam : (n_s + 1,) float64
        Interpolation ratio of the passes.
    floor_area : (n_s + 1, m) float64
        Hub floor area each hub target stands for, mm^2 (sums to the passage floor
        between the first paths).
    step : float
        Stepover w, mm.
    n1, n_s : int
        Layer steps (on the longest ruling) and pass intervals.
    layering : str
        ``"ruling"`` (eq. 2) or ``"depth"`` (``layers.depth_layer_points``).
    """

    centres: NDArray[np.float64]
    ruling: NDArray[np.float64]
    u: NDArray[np.float64]
    lam: NDArray[np.float64]
    floor_area: NDArray[np.float64]
    step: float
    n1: int
    n_s: int
    layering: str = "ruling"

    @property
    def depth(self) -> float:
        """Layer step on the longest ruling, mm (every step of either layering is at
        most this)."""
        return float(np.linalg.norm(self.ruling, axis=-1).max()) / self.n1

    def with_layering(self, layering: str) -> PassageGrid:
        """The same passes (hub paths, rulings, ``n1``) in ``layering``'s layers."""
        if layering == self.layering:
            return self
        return replace(self, centres=_layered(layering)(self.centres[-1], self.ruling, self.n1),
                       layering=layering)


def _layered(layering: str) -> Callable[[NDArray[np.float64], NDArray[np.float64], int],
                                        NDArray[np.float64]]:
    """The layer function of ``layering`` (``layers.LAYERINGS``)."""
    if layering not in LAYERINGS:
        raise ValueError(f"unknown layering {layering!r}")
    return layer_points if layering == "ruling" else depth_layer_points


def _in_hub_normal(surfaces: ImpellerSurfaces, points: NDArray[np.float64],
                   normal: NDArray[np.float64]) -> tuple[NDArray[np.float64], ...]:
    """Blade-side normals turned into the hub tangent plane, and the hub normals."""
    hub = surfaces.hub
    r = np.hypot(points[..., 0], points[..., 1])
    s = hub.closest_s(points[..., 2], r)
    h = hub.normal(s, np.arctan2(points[..., 1], points[..., 0]))
    t = normal - np.einsum("...i,...i->...", normal, h)[..., None] * h
    return t / np.linalg.norm(t, axis=-1, keepdims=True), h


def passage_grid(surfaces: ImpellerSurfaces, radius: float, eta: float, *,
                 scallop: float, max_depth: float, step_along: float,
                 lane: Lane | None = None, layering: str = "ruling") -> PassageGrid:
    """Targets of a lane of passage 0 for a ball of ``radius`` with allowance ``eta`` (mm).

    Parameters
    ----------
    scallop : float
        Allowed scallop height h of the stepover ``w = 2 sqrt(h (d - h))``, mm.
    max_depth : float
        Largest cutting depth per layer (a_p, l of eq. 2), mm.
    step_along : float
        Station spacing along the hub curve, mm.
    lane : Lane, optional
        Default: the first of ``passage_lanes``.
    layering : str
        ``"ruling"``: eq. 2, ``n1`` equal steps down every ruling; ``"depth"``: steps of
        the longest ruling's depth down every ruling, stopping at the hub
        (``layers.depth_layer_points``).
    """
    layered = _layered(layering)
    if lane is None:
        lane = passage_lanes(surfaces)[0]
    a, b = lane.pressure, lane.suction
    pitch = surfaces.spec.pitch
    rho = radius + eta
    u_dense = np.linspace(lane.u0, lane.u1, 257)
    hub_len = float(np.linalg.norm(np.diff(a.side(_own(a, u_dense), 1.0, PRESSURE), axis=0),
                                   axis=1).sum())
    m = max(int(math.ceil(hub_len / step_along)), 4) + 1
    u = np.linspace(lane.u0, lane.u1, m)
    ua, ub = _own(a, u), _own(b, u)
    px_p, ps_p = a.side(ua, 1.0, PRESSURE), a.side(ua, 0.0, PRESSURE)
    px_s, ps_s = b.side(ub, 1.0, SUCTION), b.side(ub, 0.0, SUCTION)
    n_p, h_p = _in_hub_normal(surfaces, px_p, a.side_normal(ua, 1.0, PRESSURE))
    n_s_, h_s = _in_hub_normal(surfaces, px_s, b.side_normal(ub, 1.0, SUCTION))
    oc_p = px_p + rho * n_p + rho * h_p
    oc_s = px_s + rho * n_s_ + rho * h_s
    theta = np.mod(np.arctan2(oc_s[:, 1], oc_s[:, 0]) - np.arctan2(oc_p[:, 1], oc_p[:, 0]),
                   2.0 * math.pi)
    del pitch
    width = float(np.max(np.hypot(oc_p[:, 0], oc_p[:, 1]) * theta))
    w = stepover(2.0 * radius, scallop)
    n_s = pass_count(width, w)
    lam = np.arange(n_s + 1, dtype=np.float64) / n_s
    hub_paths = np.stack([interpolated_pass(oc_p, oc_s, theta, float(x)) for x in lam])
    rul_p, rul_s = ps_p - px_p, ps_s - px_s
    ruling = np.stack([interpolated_pass(rul_p, rul_s, theta, float(x)) for x in lam])
    n1 = layer_count(float(np.linalg.norm(ruling, axis=-1).max()), max_depth)
    centres = layered(hub_paths, ruling, n1)
    # floor area per hub target: quad areas shared out to their four corners
    d_u = np.diff(hub_paths, axis=1)
    d_l = np.diff(hub_paths, axis=0)
    quad = np.linalg.norm(np.cross(d_u[:-1], d_l[:, :-1]), axis=-1)
    area = np.zeros(hub_paths.shape[:2])
    for di in (0, 1):
        for dj in (0, 1):
            area[di:di + quad.shape[0], dj:dj + quad.shape[1]] += 0.25 * quad
    return PassageGrid(centres, ruling, u, lam, area, w, n1, n_s, layering)
