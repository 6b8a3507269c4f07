"""Camber-line curves P(u) (shroud) and Q(u) (hub): cubic interpolation of (r, theta, z).

The papers interpolate discrete design points given in cylindrical coordinates
(M1). We fit a cubic spline to each of r, theta and z over a common parameter u in
[0, 1], leading edge (u = 0) to trailing edge (u = 1); the curve passes through
every data point exactly.

Parameter choice: the ruling at u joins P(u) and Q(u), so the parametrisation
decides which points the rulings join. When the lines have the same number of points
(the usual case: design data list the rulings' end points), point i of every line
gets the same u_i, the mean of the lines' normalised cumulative chord lengths at i,
so each ruling passes through a data pair. Otherwise each line uses its own
normalised chord length.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.interpolate import CubicSpline


def cylindrical_to_cartesian(cyl: NDArray[np.float64]) -> NDArray[np.float64]:
    """``(..., 3)`` r, theta (rad), z -> ``(..., 3)`` x, y, z."""
    r, theta, z = cyl[..., 0], cyl[..., 1], cyl[..., 2]
    return np.stack([r * np.cos(theta), r * np.sin(theta), z], axis=-1)


def chord_parameter(points: NDArray[np.float64]) -> NDArray[np.float64]:
    """Normalised cumulative chord length of ``(n, 3)`` cartesian points, ``(n,)`` in [0, 1]."""
    steps = np.linalg.norm(np.diff(points, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(steps)])
    return s / s[-1]


class CamberCurve:
    """A cubic camber curve through cylindrical data points.

    Parameters
    ----------
    cylindrical : (n, 3) float64
        Data points r (mm), theta (rad, unwrapped), z (mm), leading to trailing edge.
    nodes : (n,) float64
        Parameter u of each data point, increasing from 0 to 1.

    Attributes
    ----------
    nodes : (n,) float64
    points : (n, 3) float64
        The data points in cartesian coordinates, mm.
    """

    def __init__(self, cylindrical: NDArray[np.float64], nodes: NDArray[np.float64]) -> None:
        self.cylindrical_points = np.asarray(cylindrical, dtype=np.float64)
        self.nodes = np.asarray(nodes, dtype=np.float64)
        self.points = cylindrical_to_cartesian(self.cylindrical_points)
        self._spline = CubicSpline(self.nodes, self.cylindrical_points, axis=0)
        self._d1 = self._spline.derivative(1)

    def cylindrical(self, u: ArrayLike) -> NDArray[np.float64]:
        """``(..., 3)`` r, theta, z at parameter ``u`` (any shape)."""
        return np.asarray(self._spline(np.asarray(u, dtype=np.float64)))

    def __call__(self, u: ArrayLike) -> NDArray[np.float64]:
        """``(..., 3)`` cartesian points at ``u``, mm."""
        return cylindrical_to_cartesian(self.cylindrical(u))

    def derivative(self, u: ArrayLike) -> NDArray[np.float64]:
        """``(..., 3)`` dP/du in cartesian coordinates, mm per unit u."""
        return self.point_and_derivative(u)[1]

    def point_and_derivative(self, u: ArrayLike) -> tuple[NDArray[np.float64],
                                                          NDArray[np.float64]]:
        """``(P(u), dP/du)``, each ``(..., 3)`` cartesian (mm, mm per unit u): the
        values of ``__call__`` and ``derivative`` from one evaluation of the spline."""
        u = np.asarray(u, dtype=np.float64)
        c = self._spline(u)
        return cylindrical_to_cartesian(c), self._cartesian_derivative(c, self._d1(u))

    @staticmethod
    def _cartesian_derivative(c: NDArray[np.float64], d: NDArray[np.float64]
                              ) -> NDArray[np.float64]:
        """dP/du ``(..., 3)`` from the cylindrical point ``c`` and its derivative ``d``."""
        r, theta = c[..., 0], c[..., 1]
        dr, dtheta, dz = d[..., 0], d[..., 1], d[..., 2]
        cos, sin = np.cos(theta), np.sin(theta)
        return np.stack([dr * cos - r * sin * dtheta, dr * sin + r * cos * dtheta, dz], axis=-1)


def common_nodes(lines: Sequence[NDArray[np.float64]]) -> list[NDArray[np.float64]]:
    """Parameter nodes for several camber lines (see module docstring).

    Parameters
    ----------
    lines : sequence of (n_i, 3) float64
        Cylindrical data points of each line.

    Returns
    -------
    list of (n_i,) float64
    """
    chords = [chord_parameter(cylindrical_to_cartesian(line)) for line in lines]
    if len({len(c) for c in chords}) == 1:
        mean = np.mean(chords, axis=0)
        return [mean for _ in chords]
    return chords


def camber_curves(
    shroud: NDArray[np.float64],
    hub: NDArray[np.float64],
    midspan: NDArray[np.float64] | None = None,
) -> tuple[CamberCurve, CamberCurve, CamberCurve | None]:
    """Interpolate shroud P(u), hub Q(u) and optional mid-span M(u) over a common u.

    Parameters
    ----------
    shroud, hub : (n, 3) float64
        Cylindrical camber points (r mm, theta rad, z mm).
    midspan : (n, 3) float64, optional

    Returns
    -------
    (CamberCurve, CamberCurve, CamberCurve or None)
    """
    lines = [shroud, hub] + ([] if midspan is None else [midspan])
    nodes = common_nodes(lines)
    p = CamberCurve(shroud, nodes[0])
    q = CamberCurve(hub, nodes[1])
    m = None if midspan is None else CamberCurve(midspan, nodes[2])
    return p, q, m
