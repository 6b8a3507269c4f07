"""The impeller spec: a TOML file plus camber-line CSVs, validated into ``ImpellerSpec``.

The format is documented in docs/formats.md. Every problem is an ``InputError`` that
names the file, the field, the value and what is accepted; nothing is guessed or
clamped. Angles are degrees in the files and radians in ``ImpellerSpec``.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.interpolate import PchipInterpolator

from geometry.machining import MachiningSettings, settings_of
from geometry.spec_schema import MIN_SPLINE_POINTS, BladeTable, SpecFile
from impeller_cam.errors import InputError
from impeller_cam.schema import load_toml, validate

#: How far (mm) a camber point may lie off its meridional contour.
CONTOUR_TOLERANCE = 0.05
EDGE_SHAPES = ("round", "cut")
CAMBER_COLUMNS = ("r", "theta_deg", "z")


@dataclass(frozen=True)
class ImpellerSpec:
    """A validated impeller description (internal units: mm, radians).

    Attributes
    ----------
    name : str
        Impeller name.
    source : Path or None
        The spec file it was read from.
    blades : int
        Number of main blades, >= 1.
    shroud_camber, hub_camber : (n, 3) float64
        Camber-line points ``r, theta, z`` (mm, rad unwrapped, mm), leading to trailing edge.
    midspan_camber : (n, 3) float64 or None
        Optional mid-span camber line (makes the blade non-ruled).
    hub_contour, shroud_contour : (k, 2) float64
        Meridional contours ``z, r`` in mm, inlet to outlet.
    bore_radius : float
        Radius of the hub bore, mm.
    thickness_u, thickness_mm : (m,) float64
        Knots of the blade thickness law along the camber parameter u.
    leading_edge, trailing_edge : str
        ``"round"`` or ``"cut"``.
    fillet_radius : float
        Blade-to-hub fillet radius, mm (0: none).
    splitters : int
        Splitter blades per passage (0 or 1).
    splitter_start : float
        Camber parameter u where a splitter's leading edge lies.
    stock_allowance : float
        Blank allowance over the shroud envelope, mm.
    finishing_allowance : float
        Finishing allowance eta, mm.
    machining : MachiningSettings
        The optional ``[machining]`` table (tools and job settings of ``run``).
    """

    name: str
    source: Path | None
    blades: int
    shroud_camber: NDArray[np.float64]
    hub_camber: NDArray[np.float64]
    midspan_camber: NDArray[np.float64] | None
    hub_contour: NDArray[np.float64]
    shroud_contour: NDArray[np.float64]
    bore_radius: float
    thickness_u: NDArray[np.float64]
    thickness_mm: NDArray[np.float64]
    leading_edge: str
    trailing_edge: str
    fillet_radius: float
    splitters: int
    splitter_start: float
    stock_allowance: float
    finishing_allowance: float
    machining: MachiningSettings = field(default_factory=MachiningSettings)

    @property
    def pitch(self) -> float:
        """Angular pitch between main blades, rad."""
        return 2.0 * math.pi / self.blades

    def thickness(self, u: ArrayLike) -> NDArray[np.float64]:
        """Blade thickness at camber parameter ``u`` (PCHIP, no overshoot).

        Parameters
        ----------
        u : array_like
            Camber parameters in [0, 1] (any shape; clipped to the thickness knots).

        Returns
        -------
        float64 array, shape of ``u``
            Thickness, mm.
        """
        u = np.asarray(u, dtype=np.float64)
        law = self._thickness_law
        if law is None:
            return np.full(u.shape, float(self.thickness_mm[0]))
        return np.asarray(law(np.clip(u, self.thickness_u[0], self.thickness_u[-1])))

    @cached_property
    def _thickness_law(self) -> PchipInterpolator | None:
        """The PCHIP of the thickness knots, made at the first ``thickness`` call (the
        blade's evaluation asks for it at every point); ``None``: constant thickness."""
        if len(self.thickness_u) == 1 or np.all(self.thickness_mm == self.thickness_mm[0]):
            return None
        return PchipInterpolator(self.thickness_u, self.thickness_mm, extrapolate=True)


def _short(value: Any, limit: int = 60) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def read_camber_csv(path: Path, field: str) -> NDArray[np.float64]:
    """Read a camber-line CSV (``r,theta_deg,z``) into ``(n, 3)`` r, theta (rad), z.

    Raises
    ------
    InputError
        Missing file, wrong header, a non-numeric or non-finite value, fewer than
        ``MIN_SPLINE_POINTS`` points, or r <= 0.
    """
    if not path.is_file():
        raise InputError(
            "camber file not found",
            file=path,
            field=field,
            value=str(path),
            accepted="an existing CSV file with columns r,theta_deg,z",
        )
    with path.open(newline="", encoding="utf-8") as handle:
        rows = [row for row in csv.reader(handle) if row and not row[0].startswith("#")]
    if not rows:
        raise InputError(
            "camber file is empty",
            file=path,
            field=field,
            accepted="a header r,theta_deg,z and data rows",
        )
    header = tuple(cell.strip() for cell in rows[0])
    if header != CAMBER_COLUMNS:
        raise InputError(
            "unexpected header",
            file=path,
            field="header",
            value=",".join(header),
            accepted="r,theta_deg,z",
        )
    data = np.empty((len(rows) - 1, 3))
    for i, row in enumerate(rows[1:]):
        line = i + 2
        if len(row) != 3:
            raise InputError(
                f"line {line}: expected 3 values",
                file=path,
                field=f"line {line}",
                value=",".join(row),
                accepted="three numbers r,theta_deg,z",
            )
        for j, cell in enumerate(row):
            try:
                value = float(cell)
            except ValueError:
                raise InputError(
                    f"line {line}: not a number",
                    file=path,
                    field=CAMBER_COLUMNS[j],
                    value=cell.strip(),
                    accepted="a finite number",
                ) from None
            if not math.isfinite(value):
                raise InputError(
                    f"line {line}: not finite",
                    file=path,
                    field=CAMBER_COLUMNS[j],
                    value=cell.strip(),
                    accepted="a finite number",
                )
            data[i, j] = value
    if len(data) < MIN_SPLINE_POINTS:
        raise InputError(
            f"too few points ({len(data)})",
            file=path,
            field=field,
            accepted=f"at least {MIN_SPLINE_POINTS} points for a cubic spline",
        )
    if np.any(data[:, 0] <= 0):
        bad = int(np.argmax(data[:, 0] <= 0))
        raise InputError(
            f"line {bad + 2}: radius must be positive",
            file=path,
            field="r",
            value=float(data[bad, 0]),
            accepted="r > 0 mm",
        )
    steps = np.linalg.norm(np.diff(_cartesian(data), axis=0), axis=1)
    if np.any(steps < 1e-9):
        bad = int(np.argmax(steps < 1e-9))
        raise InputError(
            f"line {bad + 3}: repeats the previous point",
            file=path,
            field=field,
            accepted="distinct consecutive points",
        )
    out = data.copy()
    out[:, 1] = np.unwrap(np.radians(data[:, 1]))
    return out


def _cartesian(cyl_deg: NDArray[np.float64]) -> NDArray[np.float64]:
    theta = np.radians(cyl_deg[:, 1])
    return np.column_stack(
        [cyl_deg[:, 0] * np.cos(theta), cyl_deg[:, 0] * np.sin(theta), cyl_deg[:, 2]]
    )


def _check_contour(path: Path, field: str, contour: NDArray[np.float64]) -> None:
    """A meridional contour must not repeat points nor double back (turn > 90 deg)."""
    steps = np.diff(contour, axis=0)
    lengths = np.linalg.norm(steps, axis=1)
    if np.any(lengths < 1e-9):
        row = int(np.argmax(lengths < 1e-9))
        raise InputError(
            f"point {row + 1} repeats point {row}",
            file=path,
            field=field,
            value=contour[row + 1].tolist(),
            accepted="distinct points",
        )
    cos_turn = np.einsum("ij,ij->i", steps[1:], steps[:-1]) / (lengths[1:] * lengths[:-1])
    if np.any(cos_turn <= 0):
        row = int(np.argmax(cos_turn <= 0)) + 2
        raise InputError(
            f"the contour turns back at point {row}",
            file=path,
            field=field,
            value=contour[row].tolist(),
            accepted="a contour going one way from inlet to outlet (turns < 90 deg)",
        )


def load_spec(path: str | Path) -> ImpellerSpec:
    """Read and validate an impeller spec TOML and the CSV files it references.

    The document is validated against ``geometry.spec_schema.SpecFile`` (keys, types,
    units, ranges: an unknown key such as ``fillet_radus_mm`` is refused with the
    nearest valid key), then what needs several keys is checked here.

    Parameters
    ----------
    path : str or Path
        The spec file.

    Returns
    -------
    ImpellerSpec
        Validated spec in internal units (mm, rad).

    Raises
    ------
    InputError
        On any bad file, field or value (see module docstring).
    """
    path = Path(path)
    doc = validate(SpecFile, load_toml(path, "spec"), path)
    folder = path.parent
    shroud = read_camber_csv(folder / doc.camber.shroud, "camber.shroud")
    hub = read_camber_csv(folder / doc.camber.hub, "camber.hub")
    mid_name = doc.camber.midspan
    mid = None if mid_name is None else read_camber_csv(folder / mid_name, "camber.midspan")

    hub_contour = np.array(doc.meridional.hub, dtype=np.float64)
    shroud_contour = np.array(doc.meridional.shroud, dtype=np.float64)
    _check_contour(path, "meridional.hub", hub_contour)
    _check_contour(path, "meridional.shroud", shroud_contour)
    if np.any(hub_contour[:, 1] < 0) or np.any(shroud_contour[:, 1] <= 0):
        raise InputError(
            "contour radius must be positive", file=path, field="meridional", accepted="r > 0 mm"
        )
    bore = doc.hub.bore_radius_mm
    if bore >= float(hub_contour[:, 1].min()):
        raise InputError(
            "bore is not inside the hub",
            file=path,
            field="hub.bore_radius_mm",
            value=bore,
            accepted=f"0 < bore < smallest hub contour radius {hub_contour[:, 1].min():g} mm",
        )
    thickness_u, thickness_mm = _thickness(doc.blade, path)
    spec = ImpellerSpec(
        name=doc.impeller.name or path.parent.name,
        source=path,
        blades=doc.impeller.blades,
        shroud_camber=shroud,
        hub_camber=hub,
        midspan_camber=mid,
        hub_contour=hub_contour,
        shroud_contour=shroud_contour,
        bore_radius=bore,
        thickness_u=thickness_u,
        thickness_mm=thickness_mm,
        leading_edge=doc.blade.leading_edge,
        trailing_edge=doc.blade.trailing_edge,
        fillet_radius=doc.blade.fillet_radius_mm,
        splitters=doc.splitters.count,
        splitter_start=doc.splitters.start_fraction,
        stock_allowance=doc.allowances.stock_mm,
        finishing_allowance=doc.allowances.finishing_mm,
        machining=settings_of(doc.machining),
    )
    # Geometric consistency (camber on contours, monotone meridional coordinate,
    # hub and shroud not crossing) needs the interpolated curves and surfaces.
    from geometry.validate import check_spec_geometry

    check_spec_geometry(spec)
    return spec


def _thickness(blade: BladeTable, path: Path) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Knots and values of the thickness law (types and ranges already checked)."""
    if blade.thickness is None:
        d = float(blade.thickness_mm or 0.0)
        return np.array([0.0, 1.0]), np.array([d, d])
    u = np.array(blade.thickness.u, dtype=np.float64)
    mm = np.array(blade.thickness.mm, dtype=np.float64)
    accepted = "u increasing from 0 to 1, mm > 0, equal lengths >= 2"
    if len(u) != len(mm):
        raise InputError(
            "u and mm must have equal lengths",
            file=path,
            field="blade.thickness",
            value=_short({"u": u.tolist(), "mm": mm.tolist()}),
            accepted=accepted,
        )
    if abs(u[0]) > 1e-12 or abs(u[-1] - 1.0) > 1e-12 or np.any(np.diff(u) <= 0):
        raise InputError(
            "u must increase from 0 to 1",
            file=path,
            field="blade.thickness.u",
            value=u.tolist(),
            accepted=accepted,
        )
    if np.any(mm <= 0):
        raise InputError(
            "thickness must be positive",
            file=path,
            field="blade.thickness.mm",
            value=mm.tolist(),
            accepted=accepted,
        )
    return u, mm
