"""Parametric impeller design: camber data from design parameters (issue 2).

A designer describes an impeller by

* the meridional hub and shroud contours as Bezier control polygons in ``(z, r)``
  (inlet to outlet; the blade spans a fraction of each contour's length),
* the camber angle law along the normalised meridional length ``m`` in [0, 1] of the
  blade on each contour, either the **wrap angle** ``theta(m)`` or the **blade angle**
  ``beta(m)`` (measured from the meridional direction, positive towards +theta),
  integrated to ``theta(m) = theta_LE + int_0^m tan(beta) / r dm`` (m in mm there),
* the thickness law and the rest of the spec (edges, fillet, splitters, allowances),
* optionally ``midspan_wrap_offset``: a mid-span camber line whose wrap differs from
  the ruled blade's by this angle, which makes the blade non-ruled.

``generate`` turns the parameters into arrays (``GeneratedDesign``);
``geometry.design_files.write_design`` writes the spec TOML and camber CSVs a user
would write by hand (format: docs/formats.md). ``load_design`` reads the TOML form of
the parameters (``design.toml``).
Angles are radians here and degrees in the files.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import tomli_w
from numpy.typing import NDArray
from scipy.integrate import cumulative_trapezoid
from scipy.interpolate import PchipInterpolator

from geometry.camber import cylindrical_to_cartesian
from geometry.design_checks import (
    ANGLE_LAWS,
    CHOICES,
    SCALARS,
    Floats,
    Points,
    check_parameters,
)
from geometry.design_schema import DesignFile
from geometry.machining import read_machining
from geometry.spec import ImpellerSpec
from geometry.validate import check_spec_geometry
from impeller_cam.errors import InputError
from impeller_cam.schema import load_toml, validate

__all__ = [
    "ANGLE_LAWS",
    "DesignParameters",
    "GeneratedDesign",
    "bezier",
    "generate",
    "integrate_blade_angle",
    "load_design",
]

#: Samples along each Bezier contour for arc length and the blade-angle integral.
DENSE_SAMPLES = 4001
#: Decimals written for every length (mm) and angle (deg) in the spec and CSVs.
DECIMALS = 6
#: File names of the written camber lines (``geometry.design_files``).
FILES = {"shroud": "shroud_camber.csv", "hub": "hub_camber.csv", "midspan": "mid_camber.csv"}



@dataclass(frozen=True)
class DesignParameters:
    """Design parameters of one impeller (mm, radians). Validated on construction.

    Attributes
    ----------
    name : str
        Impeller name (letters, digits, ``_ . -``).
    blades : int
        Main blades, 1..64.
    hub_control, shroud_control : tuple of (z, r)
        Bezier control polygons of the meridional contours, mm, inlet to outlet
        (hub: nose to rim; shroud: inlet tip to outlet), >= 2 points each.
    hub_blade, shroud_blade : (float, float)
        Leading and trailing edge of the blade as fractions of each contour's length.
    contour_points, camber_points : int
        Points written for each contour (spec.toml) and each camber line (CSV).
    angle_law : str
        ``"wrap"``: ``*_angle`` are theta at the knots; ``"blade_angle"``: they are beta.
    shroud_knots, hub_knots : tuple of float
        Knots in normalised meridional length m, increasing from 0 to 1.
    shroud_angle, hub_angle : tuple of float
        theta (wrap law) or beta (blade-angle law) at the knots, rad; PCHIP between.
    shroud_theta_le, hub_theta_le : float
        theta at the leading edge for the blade-angle law, rad.
    midspan_wrap_offset : float
        Extra wrap of the mid-span camber line, rad; 0 gives a ruled blade.
    bore_radius, thickness_u, thickness_mm, leading_edge, trailing_edge,
    fillet_radius, splitters, splitter_start, stock_allowance, finishing_allowance
        Passed to the spec unchanged (see ``ImpellerSpec``); a constant thickness is
        ``thickness_u = (0, 1)`` with two equal values.
    machining_toml : str
        The ``[machining]`` table (TOML text, validated by
        ``geometry.machining.read_machining``) copied to the end of the spec.
    """

    name: str
    blades: int
    hub_control: Points
    shroud_control: Points
    shroud_knots: Floats
    shroud_angle: Floats
    hub_knots: Floats
    hub_angle: Floats
    bore_radius: float
    thickness_mm: Floats
    thickness_u: Floats = (0.0, 1.0)
    angle_law: str = "wrap"
    hub_blade: tuple[float, float] = (0.0, 1.0)
    shroud_blade: tuple[float, float] = (0.0, 1.0)
    contour_points: int = 41
    camber_points: int = 21
    shroud_theta_le: float = 0.0
    hub_theta_le: float = 0.0
    midspan_wrap_offset: float = 0.0
    leading_edge: str = "round"
    trailing_edge: str = "cut"
    fillet_radius: float = 0.0
    splitters: int = 0
    splitter_start: float = 0.35
    stock_allowance: float = 2.0
    finishing_allowance: float = 0.5
    machining_toml: str = ""

    def __post_init__(self) -> None:
        check_parameters(self)


@dataclass(frozen=True)
class GeneratedDesign:
    """Arrays made from ``DesignParameters`` (what the spec files will hold).

    Attributes
    ----------
    params : DesignParameters
    hub_contour, shroud_contour : (k, 2) float64
        Meridional contours ``z, r``, mm.
    shroud_camber, hub_camber : (n, 3) float64
        Camber points ``r`` mm, ``theta`` rad (unwrapped), ``z`` mm, LE to TE.
    midspan_camber : (n, 3) float64 or None
        Mid-span camber line (only when ``midspan_wrap_offset != 0``).
    """

    params: DesignParameters
    hub_contour: NDArray[np.float64]
    shroud_contour: NDArray[np.float64]
    shroud_camber: NDArray[np.float64]
    hub_camber: NDArray[np.float64]
    midspan_camber: NDArray[np.float64] | None = field(default=None)

    def to_spec(self, source: Path | None = None) -> ImpellerSpec:
        """The ``ImpellerSpec`` these arrays describe (unrounded, in memory)."""
        p = self.params
        same = (
            "name",
            "blades",
            "bore_radius",
            "leading_edge",
            "trailing_edge",
            "fillet_radius",
            "splitters",
            "splitter_start",
            "stock_allowance",
            "finishing_allowance",
        )
        return ImpellerSpec(
            source=source,
            shroud_camber=self.shroud_camber,
            hub_camber=self.hub_camber,
            midspan_camber=self.midspan_camber,
            hub_contour=self.hub_contour,
            shroud_contour=self.shroud_contour,
            thickness_u=np.asarray(p.thickness_u, dtype=np.float64),
            thickness_mm=np.asarray(p.thickness_mm, dtype=np.float64),
            machining=read_machining(tomllib.loads(p.machining_toml)),
            **{key: getattr(p, key) for key in same},
        )


# ---------------------------------------------------------------------------------
# functional core
# ---------------------------------------------------------------------------------
def bezier(control: NDArray[np.float64], t: NDArray[np.float64]) -> NDArray[np.float64]:
    """Bezier curve of ``(k, d)`` control points at parameters ``t`` ``(n,)`` -> ``(n, d)``.

    ``B(t) = sum_i C(n, i) t^i (1 - t)^(n - i) P_i`` with ``n = k - 1`` (Bernstein form).
    """
    control = np.asarray(control, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)[:, None]
    n = len(control) - 1
    i = np.arange(n + 1)
    basis = np.array([math.comb(n, k) for k in i]) * t**i * (1.0 - t) ** (n - i)
    return np.asarray(basis @ control)


def _dense_contour(control: Points) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Dense ``(N, 2)`` samples of a Bezier contour and their arc length, mm."""
    pts = bezier(np.asarray(control), np.linspace(0.0, 1.0, DENSE_SAMPLES))
    length = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
    return pts, length


def _at_length(
    pts: NDArray[np.float64], length: NDArray[np.float64], s: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Contour points ``(n, 2)`` at arc lengths ``s`` (mm) by interpolation of dense samples."""
    return np.column_stack([np.interp(s, length, pts[:, 0]), np.interp(s, length, pts[:, 1])])


def integrate_blade_angle(
    m: NDArray[np.float64],
    r: NDArray[np.float64],
    beta: NDArray[np.float64],
    theta_le: float = 0.0,
) -> NDArray[np.float64]:
    """Wrap angle from the blade angle: ``theta(m) = theta_le + int_0^m tan(beta) / r dm``.

    Parameters
    ----------
    m : (n,) float64
        Meridional length from the leading edge, mm, increasing.
    r : (n,) float64
        Radius at ``m``, mm (> 0).
    beta : (n,) float64
        Blade angle from the meridional direction at ``m``, rad (+ towards +theta).
    theta_le : float
        theta at ``m[0]``, rad.

    Returns
    -------
    (n,) float64
        theta, rad (trapezoidal rule: exact for constant ``tan(beta)/r``).
    """
    integrand = np.tan(beta) / r
    return np.asarray(theta_le + cumulative_trapezoid(integrand, m, initial=0.0))


def _camber_line(
    p: DesignParameters,
    control: Points,
    span: tuple[float, float],
    knots: Floats,
    angle: Floats,
    theta_le: float,
) -> NDArray[np.float64]:
    """``(n, 3)`` r, theta, z camber points of one line, uniform in meridional length."""
    pts, length = _dense_contour(control)
    s0, s1 = span[0] * length[-1], span[1] * length[-1]
    law = PchipInterpolator(np.asarray(knots), np.asarray(angle))
    m_camber = np.linspace(0.0, 1.0, p.camber_points)
    zr = _at_length(pts, length, s0 + m_camber * (s1 - s0))
    if p.angle_law == "wrap":
        theta = np.asarray(law(m_camber))
    else:
        m_dense = np.linspace(0.0, 1.0, DENSE_SAMPLES)
        zr_dense = _at_length(pts, length, s0 + m_dense * (s1 - s0))
        theta_dense = integrate_blade_angle(
            m_dense * (s1 - s0), zr_dense[:, 1], np.asarray(law(m_dense)), theta_le
        )
        theta = np.interp(m_camber, m_dense, theta_dense)
    return np.column_stack([zr[:, 1], theta, zr[:, 0]])


def _midspan_line(
    shroud: NDArray[np.float64], hub: NDArray[np.float64], offset: float
) -> NDArray[np.float64]:
    """Mid-span line: ruling midpoints turned about +Z by ``offset * m`` (m: 0 at LE, 1 at TE).

    With ``offset = 0`` it lies on the rulings; otherwise its wrap exceeds that of the
    ruling midpoints by ``offset`` and the blade is no longer ruled.
    """
    mid = 0.5 * (cylindrical_to_cartesian(shroud) + cylindrical_to_cartesian(hub))
    r = np.hypot(mid[:, 0], mid[:, 1])
    theta = np.unwrap(np.arctan2(mid[:, 1], mid[:, 0]))
    # keep theta on the same turn as the rulings' ends
    theta += 2 * np.pi * np.round((0.5 * (shroud[0, 1] + hub[0, 1]) - theta[0]) / (2 * np.pi))
    theta = theta + offset * np.linspace(0.0, 1.0, len(mid))
    return np.column_stack([r, theta, mid[:, 2]])


def generate(params: DesignParameters) -> GeneratedDesign:
    """Make the contours and camber lines of ``params``.

    Parameters
    ----------
    params : DesignParameters
        The design (mm, rad).

    Returns
    -------
    GeneratedDesign
        Contours sampled uniformly in arc length (``contour_points`` each) and camber
        lines uniform in meridional length (``camber_points`` each).

    Raises
    ------
    InputError
        When the generated geometry is inconsistent (hub and shroud crossing, ...),
        from ``geometry.validate.check_spec_geometry``.
    """
    p = params
    contours = []
    for control in (p.hub_control, p.shroud_control):
        pts, length = _dense_contour(control)
        contours.append(_at_length(pts, length, np.linspace(0, length[-1], p.contour_points)))
    shroud = _camber_line(
        p, p.shroud_control, p.shroud_blade, p.shroud_knots, p.shroud_angle, p.shroud_theta_le
    )
    hub = _camber_line(p, p.hub_control, p.hub_blade, p.hub_knots, p.hub_angle, p.hub_theta_le)
    mid = None if p.midspan_wrap_offset == 0 else _midspan_line(shroud, hub, p.midspan_wrap_offset)
    design = GeneratedDesign(p, contours[0], contours[1], shroud, hub, mid)
    check_spec_geometry(design.to_spec())
    return design


# ---------------------------------------------------------------------------------
# design.toml
# ---------------------------------------------------------------------------------
def _lookup(data: dict[str, Any], dotted: str) -> Any:
    """Value at a dotted key, or ``...`` when it is missing."""
    node: Any = data
    for key in dotted.split("."):
        if not isinstance(node, dict) or key not in node:
            return ...
        node = node[key]
    return node


def _design_kwargs(data: dict[str, Any], path: Path) -> dict[str, Any]:
    """Constructor arguments of ``DesignParameters`` from design.toml data.

    ``data`` has been validated against ``geometry.design_schema.DesignFile`` (keys and
    types); ranges and what needs several keys are checked by ``DesignParameters``.
    """
    values_key = "beta_deg" if _lookup(data, "camber.law") == "blade_angle" else "theta_deg"
    kwargs: dict[str, Any] = {"name": path.parent.name}
    for line in ("shroud", "hub"):
        angle = _lookup(data, f"camber.{line}.{values_key}")
        if angle is ...:
            raise InputError("required field is missing", field=f"camber.{line}.{values_key}",
                             accepted=f"{values_key} = [...] at the knots m (camber.law)")
        kwargs[f"{line}_control"] = tuple(tuple(map(float, p)) for p in data["meridional"][line])
        kwargs[f"{line}_knots"] = tuple(map(float, _lookup(data, f"camber.{line}.m")))
        kwargs[f"{line}_angle"] = tuple(math.radians(x) for x in angle)
        span = _lookup(data, f"meridional.{line}_blade")
        if span is not ...:
            kwargs[f"{line}_blade"] = tuple(map(float, span))
    blade = data["blade"]
    if "thickness_mm" in blade:
        kwargs["thickness_mm"] = (float(blade["thickness_mm"]),) * 2
    else:
        kwargs["thickness_u"] = tuple(map(float, blade["thickness"]["u"]))
        kwargs["thickness_mm"] = tuple(map(float, blade["thickness"]["mm"]))
    for attr, (dotted, kind, _, _) in SCALARS.items():
        value = _lookup(data, dotted)
        if value is not ...:
            kwargs[attr] = math.radians(value) if kind == "deg" else value
    for attr, (dotted, _) in {"name": ("impeller.name", ()), **CHOICES}.items():
        value = _lookup(data, dotted)
        if value is not ...:
            kwargs[attr] = value
    if "machining" in data:
        kwargs["machining_toml"] = tomli_w.dumps({"machining": data["machining"]})
    return kwargs


def load_design(path: str | Path) -> DesignParameters:
    """Read ``design.toml`` (format in docs/design-generator.md) into ``DesignParameters``.

    Parameters
    ----------
    path : str or Path
        The design TOML (lengths mm, angles deg).

    Returns
    -------
    DesignParameters
        Validated; internal units mm, rad.

    Raises
    ------
    InputError
        Naming the file, the dotted field and the value.
    """
    path = Path(path)
    data = load_toml(path, "design")
    validate(DesignFile, data, path)
    try:
        return DesignParameters(**_design_kwargs(data, path))
    except InputError as error:
        raise InputError(
            error.message, file=path, field=error.field, value=error.value, accepted=error.accepted
        ) from None
