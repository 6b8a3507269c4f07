"""What an aero-design file describes, in the product's units: the exchange data model.

Readers (:mod:`geometry.exchange.bladegen`, :mod:`geometry.exchange.cftgeo`) turn a
file into an :class:`AeroBlading`; :mod:`geometry.exchange.to_spec` turns that into a
spec folder. Lengths are mm and angles rad once here; the file's unit is kept for the
report.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from impeller_cam.errors import InputError

__all__ = ["AeroBlade", "AeroBlading", "UNITS", "length_factor"]

#: Millimetres per file unit.
UNITS = {"M": 1000.0, "CM": 10.0, "MM": 1.0, "IN": 25.4}

Array = NDArray[np.float64]


def length_factor(unit: str, file: Path, line: int | None = None) -> float:
    """Millimetres per ``unit`` (``M``, ``CM``, ``MM``, ``IN``, any case).

    Raises
    ------
    InputError
        Any other unit (names the file and line).
    """
    key = unit.strip().upper()
    if key not in UNITS:
        where = f"line {line}: " if line is not None else ""
        raise InputError(f"{where}unknown length unit", file=file, field="units",
                         value=unit.strip(), accepted="M, CM, MM or IN")
    return UNITS[key]


@dataclass
class AeroBlade:
    """One blade of a set (main or splitter) as mean lines and a thickness law.

    Attributes
    ----------
    spans : (s,) float64
        Span fraction of each mean line, 0 at the hub, 1 at the shroud, increasing.
    mean_lines : list of (n, 3) float64
        Camber points ``r, theta, z`` (mm, rad unwrapped, mm) per span, leading to
        trailing edge, all with the same n.
    thickness : list of (m_i, 2) float64
        Thickness law per span: ``(fraction along the mean line, thickness mm)``.
    leading_edge, trailing_edge : str
        ``"round"`` or ``"cut"``.
    thickness_at_points : bool
        The thickness laws give one value per mean-line point (sections' gaps); else
        their fractions are the camber parameter u.
    """

    spans: Array
    mean_lines: list[Array]
    thickness: list[Array]
    leading_edge: str = "round"
    trailing_edge: str = "cut"
    thickness_at_points: bool = False


@dataclass
class AeroBlading:
    """A blade row read from an exchange file.

    Attributes
    ----------
    source : Path
        The file read.
    format : str
        ``"bladegen"`` or ``"cft-geo"``.
    unit : str
        The file's length unit as written (``MM``, ``CM``, ...).
    name : str
        Impeller name.
    blade_sets : int
        Number of blade sets (main blades).
    hub, shroud : (k, 2) float64
        Meridional contours ``z, r`` in mm, in the file's order.
    blades : list of AeroBlade
        The main blade, then the splitter when the set has two blades.
    notes : list of str
        What the reader assumed (edge shapes defaulted, ...), for the report.
    section_points : (p, 3) float64 or None
        The file's section points (cartesian mm), when it has sections.
    section_spans : (p,) float64 or None
        The span fraction of each section point.
    """

    source: Path
    format: str
    unit: str
    name: str
    blade_sets: int
    hub: Array
    shroud: Array
    blades: list[AeroBlade]
    notes: list[str] = field(default_factory=list)
    section_points: Array | None = None
    section_spans: Array | None = None
