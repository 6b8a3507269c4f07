"""Checks of design parameters (ranges, and what needs several keys).

``geometry.design.DesignParameters`` calls ``check_parameters`` on construction; the
messages name the ``design.toml`` field (docs/design-generator.md) and show the value in
file units (degrees, mm). Keys and types of the file itself are checked first by
``geometry.design_schema.DesignFile``.
"""

from __future__ import annotations

import math
import re
from typing import TYPE_CHECKING, Any

import numpy as np

from geometry.spec import EDGE_SHAPES
from geometry.spec_schema import MIN_SPLINE_POINTS
from impeller_cam.errors import InputError

if TYPE_CHECKING:
    from geometry.design import DesignParameters

__all__ = ["ANGLE_LAWS", "CHOICES", "MAX_BLADE_ANGLE_DEG", "SCALARS", "check_parameters"]

Points = tuple[tuple[float, float], ...]
Floats = tuple[float, ...]

ANGLE_LAWS = ("wrap", "blade_angle")
#: Largest |blade angle| accepted, deg (tan(beta) grows without bound at 90 deg).
MAX_BLADE_ANGLE_DEG = 85.0
_NAME = re.compile(r"^[A-Za-z0-9_.-]+$")

#: Scalar parameters: attribute -> (design.toml field, kind, lowest, highest).
#: ``kind`` is "int", "float" (mm or fraction) or "deg" (radians here, degrees in the file).
SCALARS: dict[str, tuple[str, str, float, float]] = {
    "blades": ("impeller.blades", "int", 1, 64),
    "contour_points": ("meridional.points", "int", MIN_SPLINE_POINTS, 2000),
    "camber_points": ("camber.points", "int", MIN_SPLINE_POINTS, 2000),
    "shroud_theta_le": ("camber.shroud.theta_le_deg", "deg", -1000.0, 1000.0),
    "hub_theta_le": ("camber.hub.theta_le_deg", "deg", -1000.0, 1000.0),
    "midspan_wrap_offset": ("camber.midspan_wrap_offset_deg", "deg", -45.0, 45.0),
    "bore_radius": ("hub.bore_radius_mm", "float", 0.0, math.inf),
    "fillet_radius": ("blade.fillet_radius_mm", "float", 0.0, math.inf),
    "splitters": ("splitters.count", "int", 0, 1),
    "splitter_start": ("splitters.start_fraction", "float", 0.05, 0.9),
    "stock_allowance": ("allowances.stock_mm", "float", 0.0, math.inf),
    "finishing_allowance": ("allowances.finishing_mm", "float", 0.0, math.inf),
}
CHOICES = {
    "angle_law": ("camber.law", ANGLE_LAWS),
    "leading_edge": ("blade.leading_edge", EDGE_SHAPES),
    "trailing_edge": ("blade.trailing_edge", EDGE_SHAPES),
}


def _fail(message: str, name: str, value: Any, accepted: str) -> None:
    raise InputError(message, field=name, value=value, accepted=accepted)


def _is_number(x: Any) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x)


def _check_scalar(attr: str, value: Any) -> None:
    key, kind, lo, hi = SCALARS[attr]
    shown = math.degrees(value) if kind == "deg" and _is_number(value) else value
    accepted = f"{'an integer' if kind == 'int' else 'a number'} {lo:g}..{hi:g}"
    if not _is_number(value) or (kind == "int" and not isinstance(value, int)):
        _fail("must be a finite number", key, shown, accepted)
    if not lo <= shown <= hi:
        _fail("out of range", key, shown, accepted)


def _check_knots(line: str, knots: Floats, values: Floats, values_key: str) -> None:
    accepted = "knots m increasing from 0 to 1, one finite value per knot, at least 2"
    m = np.asarray(knots, dtype=np.float64)
    if m.ndim != 1 or len(m) < 2 or m[0] != 0.0 or m[-1] != 1.0 or np.any(np.diff(m) <= 0):
        _fail("knots must increase from 0 to 1", f"{line}.m", list(knots), accepted)
    if len(values) != len(m) or not all(map(_is_number, values)):
        deg = values_key.endswith("_deg")
        shown = [round(math.degrees(x), 9) if deg and _is_number(x) else x for x in values]
        _fail("one finite value per knot needed", f"{line}.{values_key}", shown, accepted)


def _check_polygon(key: str, control: Points) -> None:
    try:
        arr = np.asarray(control, dtype=np.float64)
    except (TypeError, ValueError):
        arr = np.empty((0, 0))
    if arr.ndim != 2 or arr.shape[1] != 2 or len(arr) < 2 or not np.all(np.isfinite(arr)):
        _fail("bad control polygon", key, list(control), "at least 2 finite [z, r] points")
    if np.any(arr[:, 1] <= 0):
        _fail("control radius must be positive", key, list(control), "r > 0 mm")
    if np.any(np.linalg.norm(np.diff(arr, axis=0), axis=1) < 1e-9):
        _fail("repeated control point", key, list(control), "distinct consecutive points")


def check_parameters(p: DesignParameters) -> None:
    """Raise ``InputError`` naming the design.toml field of the first bad parameter."""
    if not isinstance(p.name, str) or not _NAME.match(p.name):
        _fail("bad name", "impeller.name", p.name, "letters, digits, '_', '.', '-'")
    for attr in SCALARS:
        _check_scalar(attr, getattr(p, attr))
    for attr, (key, options) in CHOICES.items():
        if getattr(p, attr) not in options:
            _fail("unknown value", key, getattr(p, attr), " or ".join(map(repr, options)))
    values_key = "theta_deg" if p.angle_law == "wrap" else "beta_deg"
    for line in ("hub", "shroud"):
        _check_polygon(f"meridional.{line}", getattr(p, f"{line}_control"))
        span = getattr(p, f"{line}_blade")
        if len(span) != 2 or not (0.0 <= span[0] < span[1] <= 1.0):
            _fail(
                "bad blade span",
                f"meridional.{line}_blade",
                list(span),
                "[le, te] with 0 <= le < te <= 1",
            )
        values = getattr(p, f"{line}_angle")
        _check_knots(f"camber.{line}", getattr(p, f"{line}_knots"), values, values_key)
        steep = math.radians(MAX_BLADE_ANGLE_DEG)
        if p.angle_law == "blade_angle" and max(map(abs, values)) > steep:
            _fail(
                "blade angle too steep",
                f"camber.{line}.beta_deg",
                [round(math.degrees(b), 6) for b in values],
                f"|beta| <= {MAX_BLADE_ANGLE_DEG:g} deg",
            )
    hub_r_min = float(np.min(np.asarray(p.hub_control)[:, 1]))
    if not 0.0 < p.bore_radius < hub_r_min:
        _fail(
            "bore is not inside the hub",
            "hub.bore_radius_mm",
            p.bore_radius,
            f"0 < bore < smallest hub control radius {hub_r_min:g} mm",
        )
    _check_knots("blade.thickness", p.thickness_u, p.thickness_mm, "mm")
    if min(p.thickness_mm) <= 0:
        _fail("thickness must be positive", "blade.thickness.mm", list(p.thickness_mm), "mm > 0")
