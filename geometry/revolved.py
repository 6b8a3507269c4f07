"""Surfaces of revolution about the impeller axis: the hub S(s, phi) and the shroud.

A meridional contour of ``(z, r)`` points (inlet to outlet) is interpolated by a
cubic spline over its normalised chord length s in [0, 1] and revolved about +Z:
``S(s, phi) = (r(s) cos phi, r(s) sin phi, z(s))`` (M1: ``S(u,v) = Rz(v) Q_m(u)``).

The normal is taken towards the passage: out of the hub material for the hub,
towards the hub for the shroud. In the meridional plane, with unit tangent
``t = (t_z, t_r)``, the hub normal is ``(t_r, -t_z)`` and the shroud normal its
opposite.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.interpolate import CubicSpline
from scipy.spatial import cKDTree

_DENSE = 4096
_NEWTON_STEPS = 8


class RevolvedSurface:
    """A contour revolved about +Z.

    Parameters
    ----------
    contour : (k, 2) float64
        Meridional points ``z, r`` in mm, inlet to outlet.
    passage_side : int
        +1 for the hub (normal ``(t_r, -t_z)``), -1 for the shroud.
    """

    def __init__(self, contour: NDArray[np.float64], passage_side: int) -> None:
        self.contour = np.asarray(contour, dtype=np.float64)
        self.passage_side = int(passage_side)
        steps = np.linalg.norm(np.diff(self.contour, axis=0), axis=1)
        s = np.concatenate([[0.0], np.cumsum(steps)])
        self.length = float(s[-1])
        self.nodes = s / s[-1]
        self._spline = CubicSpline(self.nodes, self.contour, axis=0)
        self._d1 = self._spline.derivative(1)
        self._d2 = self._spline.derivative(2)
        self._dense_s = np.linspace(0.0, 1.0, _DENSE)
        self._tree = cKDTree(self._spline(self._dense_s))

    def meridian(self, s: ArrayLike) -> NDArray[np.float64]:
        """``(..., 2)`` contour point ``z, r`` at ``s``."""
        return np.asarray(self._spline(np.asarray(s, dtype=np.float64)))

    def meridian_tangent(self, s: ArrayLike) -> NDArray[np.float64]:
        """``(..., 2)`` unit tangent ``t_z, t_r`` at ``s`` (inlet to outlet)."""
        d = self._d1(np.asarray(s, dtype=np.float64))
        return np.asarray(d / np.linalg.norm(d, axis=-1, keepdims=True))

    def meridian_normal(self, s: ArrayLike) -> NDArray[np.float64]:
        """``(..., 2)`` unit normal ``n_z, n_r`` towards the passage."""
        t = self.meridian_tangent(s)
        return self.passage_side * np.stack([t[..., 1], -t[..., 0]], axis=-1)

    def point(self, s: ArrayLike, phi: ArrayLike) -> NDArray[np.float64]:
        """``(..., 3)`` surface point at contour parameter ``s`` and angle ``phi`` (rad)."""
        s, phi = np.broadcast_arrays(np.asarray(s, float), np.asarray(phi, float))
        zr = self.meridian(s)
        return np.stack([zr[..., 1] * np.cos(phi), zr[..., 1] * np.sin(phi), zr[..., 0]], -1)

    def normal(self, s: ArrayLike, phi: ArrayLike) -> NDArray[np.float64]:
        """``(..., 3)`` unit normal towards the passage."""
        s, phi = np.broadcast_arrays(np.asarray(s, float), np.asarray(phi, float))
        n = self.meridian_normal(s)
        return np.stack([n[..., 1] * np.cos(phi), n[..., 1] * np.sin(phi), n[..., 0]], -1)

    def offset(self, s: ArrayLike, phi: ArrayLike, distance: float) -> NDArray[np.float64]:
        """``(..., 3)`` points of the surface offset by ``distance`` mm towards the passage."""
        return self.point(s, phi) + distance * self.normal(s, phi)

    def closest_s(self, z: ArrayLike, r: ArrayLike) -> NDArray[np.float64]:
        """Contour parameter of the foot point of meridional points ``(z, r)``.

        A nearest dense sample seeds a few Newton steps on ``t(s) . (p - c(s)) = 0``;
        the result is clipped to [0, 1] (points beyond the ends project to an end).

        Returns
        -------
        (...) float64
        """
        z, r = np.broadcast_arrays(np.asarray(z, float), np.asarray(r, float))
        p = np.stack([z, r], axis=-1).reshape(-1, 2)
        _, index = self._tree.query(p)
        s = self._dense_s[index]
        for _ in range(_NEWTON_STEPS):
            c, d1, d2 = self._spline(s), self._d1(s), self._d2(s)
            diff = p - c
            f = np.einsum("ij,ij->i", d1, diff)
            df = np.einsum("ij,ij->i", d2, diff) - np.einsum("ij,ij->i", d1, d1)
            s = np.clip(s - f / np.where(np.abs(df) > 1e-300, df, -1.0), 0.0, 1.0)
        return s.reshape(z.shape)

    def signed_distance(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        """Signed distance of ``(n, 3)`` points to the surface, mm (+ on the passage side).

        Exact (to the Newton tolerance) where the foot point is inside the contour.
        """
        points = np.asarray(points, dtype=np.float64)
        z = points[..., 2]
        r = np.hypot(points[..., 0], points[..., 1])
        s = self.closest_s(z, r)
        c = self.meridian(s)
        n = self.meridian_normal(s)
        return np.asarray((z - c[..., 0]) * n[..., 0] + (r - c[..., 1]) * n[..., 1])
