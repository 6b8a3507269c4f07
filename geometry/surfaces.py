"""Closed-form blade surfaces (M1): camber R(u,v), pressure/suction offsets, rulings.

``R(u, v) = (1 - v) P(u) + v Q(u)`` with P the shroud and Q the hub camber line
(v = 0 on the shroud, v = 1 on the hub). With a mid-span line M the camber surface
is the quadratic through P, M, Q: ``R + 4 v (1 - v) (M - (P + Q)/2)``; its ruled
approximation is still the line P(u) -> Q(u).

The unit normal ``N = R_u x R_v / |R_u x R_v|`` is oriented towards the pressure
side, which we define as the +theta side (the impeller turns in +theta about +Z, so
the pressure side leads). Pressure and suction surfaces are
``R +/- 0.5 d(u) N`` (M1). Every function broadcasts ``u`` and ``v`` like numpy and
returns ``(..., 3)`` arrays in the workpiece frame, mm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from geometry.camber import CamberCurve, camber_curves
from geometry.revolved import RevolvedSurface
from geometry.spec import ImpellerSpec

__all__ = ["BladeSurface", "ImpellerSurfaces", "RevolvedSurface", "build_surfaces"]

#: Parameter step of the central differences used for side-surface normals.
_FD_STEP = 1e-6

PRESSURE = 1
SUCTION = -1


def rotation_z(angle: float) -> NDArray[np.float64]:
    """3x3 rotation matrix about +Z by ``angle`` rad."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _unit(v: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.asarray(v / np.linalg.norm(v, axis=-1, keepdims=True))


class BladeSurface:
    """One blade (main or splitter) at its angular position.

    Parameters
    ----------
    shroud, hub : CamberCurve
        P(u) and Q(u) of the blade at angle 0.
    thickness : callable
        ``d(u)``, mm, of this blade's own parameter u.
    angle : float
        Rotation about +Z of this blade, rad.
    u_start : float
        Camber parameter of this blade's leading edge (0 for main blades); this
        blade's u in [0, 1] maps to ``u_start + u (1 - u_start)`` on the curves.
    midspan : CamberCurve, optional
        Mid-span line M(u) for a non-ruled blade.
    """

    def __init__(
        self,
        shroud: CamberCurve,
        hub: CamberCurve,
        thickness: object,
        angle: float = 0.0,
        u_start: float = 0.0,
        midspan: CamberCurve | None = None,
    ) -> None:
        self.shroud_curve = shroud
        self.hub_curve = hub
        self.midspan_curve = midspan
        self._thickness = thickness
        self.angle = float(angle)
        self.u_start = float(u_start)
        self.rotation = rotation_z(self.angle)
        mid = self._raw_derivatives(np.array(0.5), np.array(0.5))
        n = np.cross(mid[0], mid[1])
        point = self._raw_camber(np.array(0.5), np.array(0.5))
        e_theta = np.array([-point[1], point[0], 0.0])
        self._orientation = 1.0 if float(n @ e_theta) >= 0 else -1.0

    # -- raw (unrotated) evaluation -------------------------------------------------
    def _curve_u(self, u: NDArray[np.float64]) -> NDArray[np.float64]:
        return self.u_start + u * (1.0 - self.u_start)

    def _raw_camber(self, u: NDArray[np.float64], v: NDArray[np.float64]) -> NDArray[np.float64]:
        uc = self._curve_u(u)
        p, q = self.shroud_curve(uc), self.hub_curve(uc)
        v = v[..., None]
        r = (1.0 - v) * p + v * q
        if self.midspan_curve is not None:
            r = r + 4.0 * v * (1.0 - v) * (self.midspan_curve(uc) - 0.5 * (p + q))
        return np.asarray(r)

    def _raw_derivatives(
        self, u: NDArray[np.float64], v: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        return self._raw_point_and_derivatives(u, v)[1:]

    def _raw_point_and_derivatives(
        self, u: NDArray[np.float64], v: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """``(R, R_u, R_v)`` unrotated, each ``(..., 3)``: ``_raw_camber`` and
        ``_raw_derivatives`` from one evaluation of each camber curve."""
        uc = self._curve_u(u)
        scale = 1.0 - self.u_start
        p, dp = self.shroud_curve.point_and_derivative(uc)
        q, dq = self.hub_curve.point_and_derivative(uc)
        v = v[..., None]
        r = (1.0 - v) * p + v * q
        r_u = ((1.0 - v) * dp + v * dq) * scale
        r_v = q - p
        if self.midspan_curve is not None:
            m, dm = self.midspan_curve.point_and_derivative(uc)
            bulge = m - 0.5 * (p + q)
            dbulge = dm - 0.5 * (dp + dq)
            r = r + 4.0 * v * (1.0 - v) * bulge
            r_u = r_u + 4.0 * v * (1.0 - v) * dbulge * scale
            r_v = r_v + (4.0 - 8.0 * v) * bulge
        return np.asarray(r), np.asarray(r_u), np.asarray(r_v)

    def _rotate(self, vectors: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.asarray(vectors @ self.rotation.T)

    # -- public evaluation ------------------------------------------------------------
    def camber(self, u: ArrayLike, v: ArrayLike) -> NDArray[np.float64]:
        """Camber surface R(u, v), ``(..., 3)`` mm; v outside [0, 1] extends the rulings."""
        u, v = np.broadcast_arrays(np.asarray(u, float), np.asarray(v, float))
        return self._rotate(self._raw_camber(u, v))

    def camber_derivatives(
        self, u: ArrayLike, v: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Partial derivatives ``(R_u, R_v)``, each ``(..., 3)``."""
        u, v = np.broadcast_arrays(np.asarray(u, float), np.asarray(v, float))
        r_u, r_v = self._raw_derivatives(u, v)
        return self._rotate(r_u), self._rotate(r_v)

    def normal(self, u: ArrayLike, v: ArrayLike) -> NDArray[np.float64]:
        """Unit camber normal N, towards the pressure (+theta) side, ``(..., 3)``."""
        r_u, r_v = self.camber_derivatives(u, v)
        return _unit(self._orientation * np.cross(r_u, r_v))

    def camber_frame(self, u: ArrayLike, v: ArrayLike
                     ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """``camber(u, v)``, ``camber_derivatives(u, v)[0]`` and ``normal(u, v)``
        (each ``(..., 3)``) from one evaluation of the camber lines."""
        u, v = np.broadcast_arrays(np.asarray(u, float), np.asarray(v, float))
        r, r_u, r_v = self._raw_point_and_derivatives(u, v)
        r_u = self._rotate(r_u)
        normal = _unit(self._orientation * np.cross(r_u, self._rotate(r_v)))
        return self._rotate(r), r_u, normal

    def thickness(self, u: ArrayLike) -> NDArray[np.float64]:
        """Blade thickness d(u), mm, same shape as ``u``."""
        return np.asarray(self._thickness(np.asarray(u, float)))  # type: ignore[operator]

    def side(self, u: ArrayLike, v: ArrayLike, side: int) -> NDArray[np.float64]:
        """Pressure (``side=+1``) or suction (``side=-1``) surface ``R + side d/2 N``."""
        return self._side_and_normal(u, v, side)[0]

    def _side_and_normal(self, u: ArrayLike, v: ArrayLike, side: int
                         ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``side(u, v, side)`` and ``normal(u, v)`` from one evaluation of the
        camber lines."""
        u, v = np.broadcast_arrays(np.asarray(u, float), np.asarray(v, float))
        half = 0.5 * side * self.thickness(u)[..., None]
        r, _, normal = self.camber_frame(u, v)
        return np.asarray(r + half * normal), normal

    def pressure(self, u: ArrayLike, v: ArrayLike) -> NDArray[np.float64]:
        """Pressure surface ``R + d/2 N``, ``(..., 3)``."""
        return self.side(u, v, PRESSURE)

    def suction(self, u: ArrayLike, v: ArrayLike) -> NDArray[np.float64]:
        """Suction surface ``R - d/2 N``, ``(..., 3)``."""
        return self.side(u, v, SUCTION)

    def side_normal(self, u: ArrayLike, v: ArrayLike, side: int) -> NDArray[np.float64]:
        """Outward unit normal of a side surface (away from the blade material).

        From central differences of the side surface (step 1e-6 in u and v); it
        differs from ``side * N`` where the thickness varies or N turns along u, v.
        """
        u, v = np.broadcast_arrays(np.asarray(u, float), np.asarray(v, float))
        h = _FD_STEP
        points: list[NDArray[np.float64]]
        if u.ndim:  # the four shifted side points and the camber normal, stacked
            stacked, normals = self._side_and_normal(np.stack([u + h, u - h, u, u, u]),
                                                     np.stack([v, v, v + h, v - h, v]), side)
            points, normal = list(stacked[:4]), normals[4]
        else:  # a 0-d point keeps its own (vector-matrix) rotations, to the bit
            points = [self.side(u + h, v, side), self.side(u - h, v, side),
                      self.side(u, v + h, side), self.side(u, v - h, side)]
            normal = self.normal(u, v)
        d_u = points[0] - points[1]
        d_v = points[2] - points[3]
        n = _unit(np.cross(d_u, d_v))
        flip = np.sign(np.einsum("...i,...i->...", n, side * normal))
        return np.asarray(n * np.where(flip == 0, 1.0, flip)[..., None])

    def offset(self, u: ArrayLike, v: ArrayLike, side: int, distance: float) -> NDArray[np.float64]:
        """Side surface offset outward by ``distance`` mm (cutter-centre surface of a ball)."""
        return np.asarray(self.side(u, v, side) + distance * self.side_normal(u, v, side))

    def ruling(self, u: ArrayLike) -> NDArray[np.float64]:
        """Unit ruling direction at ``u``, shroud to hub, ``(..., 3)``."""
        u = np.asarray(u, float)
        uc = self._curve_u(u)
        return self._rotate(_unit(self.hub_curve(uc) - self.shroud_curve(uc)))

    def grid(self, nu: int, nv: int, which: str = "camber") -> NDArray[np.float64]:
        """Evaluate on a uniform ``(nu, nv)`` grid of u, v in [0, 1], ``(nu, nv, 3)``."""
        u, v = np.meshgrid(np.linspace(0, 1, nu), np.linspace(0, 1, nv), indexing="ij")
        if which == "camber":
            return self.camber(u, v)
        if which == "pressure":
            return self.pressure(u, v)
        if which == "suction":
            return self.suction(u, v)
        raise ValueError(f"grid `which` must be camber, pressure or suction, not {which!r}")


@dataclass
class ImpellerSurfaces:
    """All closed-form surfaces of an impeller.

    Attributes
    ----------
    spec : ImpellerSpec
    shroud_curve, hub_curve : CamberCurve
        P(u), Q(u) of the blade at angle 0.
    midspan_curve : CamberCurve or None
    hub, shroud : RevolvedSurface
    blades : list of BladeSurface
        Main blades at ``k * pitch``.
    splitters : list of BladeSurface
        Splitters at ``(k + 1/2) * pitch``, leading edge at ``spec.splitter_start``.
    """

    spec: ImpellerSpec
    shroud_curve: CamberCurve
    hub_curve: CamberCurve
    midspan_curve: CamberCurve | None
    hub: RevolvedSurface
    shroud: RevolvedSurface
    blades: list[BladeSurface] = field(default_factory=list)
    splitters: list[BladeSurface] = field(default_factory=list)

    def all_blades(self) -> list[BladeSurface]:
        """Main blades then splitters.

        Returns
        -------
        list of BladeSurface
        """
        return [*self.blades, *self.splitters]


def build_surfaces(spec: ImpellerSpec) -> ImpellerSurfaces:
    """Interpolate the camber lines and place every blade of ``spec``.

    Parameters
    ----------
    spec : ImpellerSpec
        The validated spec (mm, rad).

    Returns
    -------
    ImpellerSurfaces
        Closed-form camber curves, hub and shroud surfaces of revolution, one
        ``BladeSurface`` per main blade and per splitter (mm).
    """
    p, q, m = camber_curves(spec.shroud_camber, spec.hub_camber, spec.midspan_camber)
    hub = RevolvedSurface(spec.hub_contour, passage_side=+1)
    shroud = RevolvedSurface(spec.shroud_contour, passage_side=-1)
    blades = [
        BladeSurface(p, q, spec.thickness, angle=k * spec.pitch, midspan=m)
        for k in range(spec.blades)
    ]
    splitters = [
        BladeSurface(
            p,
            q,
            spec.thickness,
            angle=(k + 0.5) * spec.pitch,
            u_start=spec.splitter_start,
            midspan=m,
        )
        for k in range(spec.blades)
        for _ in range(spec.splitters)
    ]
    return ImpellerSurfaces(spec, p, q, m, hub, shroud, blades, splitters)
