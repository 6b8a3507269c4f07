"""The project's tolerances, in one documented frozen dataclass.

Every numerical tolerance that is not a user option lives here and is passed
explicitly; modules do not hide their own magic literals.
"""

from __future__ import annotations

from dataclasses import dataclass
from math import radians


@dataclass(frozen=True)
class Tolerances:
    """Tolerances used across geometry, CAM and post-processing.

    Attributes
    ----------
    length : float
        Geometric coincidence in mm (points, B-rep fuzzy value). 1e-6 mm.
    chordal : float
        Post-processing chordal tolerance in mm: the tool tip must stay this close
        to the straight CL segment between two APT records. 0.01 mm.
    angular : float
        Angular tolerance of linearisation, radians: the tool axis of the
        linearised motion stays this close to the great circle joining the two CL
        records' axes. 0.5 deg.
    tessellation : float
        Linear deflection for meshing B-rep faces, mm. 0.02 mm.
    tessellation_angle : float
        Angular deflection for meshing B-rep faces, radians. 0.25 rad.
    clearance : float
        Minimum clearance of shank and holder from the part, mm. 0.5 mm.
    simulation_resolution : float
        Stock model resolution for verification, mm. 0.1 mm.
    singular_tilt : float
        Tilt (A) below which the C axis is treated as undefined, radians. 1e-9.
    contact : float
        Verification: a rapid cut or a shank/holder overlap counts when longer than
        this along a dexel ray, mm. 0.01 mm.
    gouge : float
        Verification: stock deeper than this inside the design is a gouge (and more
        than allowance + this outside it is excess), mm; it must exceed the design
        mesh's tessellation error. 0.05 mm.
    """

    length: float = 1e-6
    chordal: float = 0.01
    angular: float = radians(0.5)
    tessellation: float = 0.02
    tessellation_angle: float = 0.25
    clearance: float = 0.5
    simulation_resolution: float = 0.1
    singular_tilt: float = 1e-9
    contact: float = 0.01
    gouge: float = 0.05


DEFAULT_TOLERANCES = Tolerances()
