"""Shared cases of the build123d and cadquery round trips (tests/geometry/test_interop*.py).

The edit: a keyway in the bore (2 mm wide, to y = 5.5 mm, the whole bore height) and a
balancing groove in the back face (annulus r = 30..38 mm, 1 mm deep) of the small
fixture. Removed volume in closed form: keyway ``h (2 * 5.5 - A)`` with ``A`` the
bore disc's area between x = -1 and 1 (``x/2 sqrt(R^2 - x^2) + R^2/2 asin(x/R)``),
groove ``pi (38^2 - 30^2) * 1``.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from geometry.spec import ImpellerSpec

ROOT = Path(__file__).resolve().parents[2]
SMALL = ROOT / "fixtures" / "impellers" / "small" / "spec.toml"

KEY_WIDTH, KEY_REACH = 2.0, 5.5
GROOVE_INNER, GROOVE_OUTER, GROOVE_DEPTH = 30.0, 38.0, 1.0


def keyway_volume(bore: float, height: float) -> float:
    """Volume the keyway removes from a bore of radius ``bore`` and ``height``, mm^3."""
    half = KEY_WIDTH / 2

    def primitive(x: float) -> float:
        return x / 2 * math.sqrt(bore**2 - x**2) + bore**2 / 2 * math.asin(x / bore)

    return height * (KEY_WIDTH * KEY_REACH - (primitive(half) - primitive(-half)))


def groove_volume() -> float:
    """Volume of the balancing groove, mm^3."""
    return math.pi * (GROOVE_OUTER**2 - GROOVE_INNER**2) * GROOVE_DEPTH


def bore_height(spec: ImpellerSpec) -> float:
    """Height of the bore: from the back face (z = 0) to the hub's inlet, mm."""
    return float(spec.hub_contour[0, 0])


def pappus_volume(profile: NDArray[np.float64]) -> float:
    """Volume of revolution of a closed ``(r, z)`` polygon about Z, mm^3 (Pappus:
    ``2 pi`` times the polygon's first moment about the axis)."""
    r, z = profile[:, 0], profile[:, 1]
    r1, z1 = np.roll(r, -1), np.roll(z, -1)
    cross = r * z1 - r1 * z
    return float(2 * math.pi * np.sum(cross * (r + r1)) / 6)


def hub_points(spec: ImpellerSpec) -> tuple[list[tuple[float, float, float]],
                                            list[tuple[float, float, float]]]:
    """The small fixture's hub as a script draws it in the XZ plane: the contour
    (spline through the spec's points) and the closing polyline (rim, back, bore, nose)."""
    zr = spec.hub_contour
    z_in, r_in = float(zr[0, 0]), float(zr[0, 1])
    z_out, r_out = float(zr[-1, 0]), float(zr[-1, 1])
    bore = float(spec.bore_radius)
    spline = [(float(r), 0.0, float(z)) for z, r in zr]
    closing = [(r_out, 0.0, z_out), (r_out, 0.0, 0.0), (bore, 0.0, 0.0), (bore, 0.0, z_in),
               (r_in, 0.0, z_in)]
    return spline, closing
