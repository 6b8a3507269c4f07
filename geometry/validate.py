"""Geometric consistency of a spec: checks that need the interpolated curves.

* camber points lie on their meridional contour (within ``CONTOUR_TOLERANCE``);
* the meridional coordinate of each camber line increases from leading to
  trailing edge (a line that goes backwards is rejected);
* hub and shroud do not cross: every shroud camber point and the shroud contour
  lie on the passage side of the hub surface.

Clearance checks that need the blades' thickness (blades touching, fillet too
large for the passage) live in ``geometry.figures.check_clearances``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from geometry.camber import cylindrical_to_cartesian
from geometry.revolved import RevolvedSurface
from geometry.spec import CONTOUR_TOLERANCE, ImpellerSpec
from impeller_cam.errors import InputError


def _meridional(cyl: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    return cyl[:, 2], cyl[:, 0]


def check_spec_geometry(spec: ImpellerSpec) -> None:
    """Raise ``InputError`` when the camber lines and contours are inconsistent."""
    hub = RevolvedSurface(spec.hub_contour, passage_side=+1)
    shroud = RevolvedSurface(spec.shroud_contour, passage_side=-1)
    lines = [("camber.hub", spec.hub_camber, hub), ("camber.shroud", spec.shroud_camber, shroud)]
    for field, cyl, surface in lines:
        z, r = _meridional(cyl)
        s = surface.closest_s(z, r)
        foot = surface.meridian(s)
        off = np.hypot(z - foot[:, 0], r - foot[:, 1])
        if np.any(off > CONTOUR_TOLERANCE):
            i = int(np.argmax(off))
            raise InputError(
                f"camber point {i} (line {i + 2}) is {off[i]:.3f} mm off its meridional contour",
                file=spec.source,
                field=field,
                value={"r": float(cyl[i, 0]), "z": float(cyl[i, 2])},
                accepted=f"points on the meridional contour within {CONTOUR_TOLERANCE} mm",
            )
        steps = np.diff(s)
        if np.any(steps <= 0):
            i = int(np.argmax(steps <= 0)) + 1
            raise InputError(
                f"meridional coordinate goes backwards at camber point {i} (line {i + 2})",
                file=spec.source,
                field=field,
                value={"r": float(cyl[i, 0]), "z": float(cyl[i, 2])},
                accepted="points ordered from leading to trailing edge along the contour",
            )
    shroud_pts = cylindrical_to_cartesian(spec.shroud_camber)
    depth = hub.signed_distance(shroud_pts)
    if np.any(depth <= 0):
        i = int(np.argmin(depth))
        raise InputError(
            f"shroud camber point {i} lies {-depth[i]:.3f} mm inside the hub: hub and shroud "
            f"lines cross",
            file=spec.source,
            field="camber.shroud",
            value={"r": float(spec.shroud_camber[i, 0]), "z": float(spec.shroud_camber[i, 2])},
            accepted="a shroud line on the passage side of the hub",
        )
    contour3 = np.column_stack(
        [spec.shroud_contour[:, 1], np.zeros(len(spec.shroud_contour)), spec.shroud_contour[:, 0]]
    )
    inside = (hub.closest_s(contour3[:, 2], contour3[:, 0]) > 0) & (
        hub.closest_s(contour3[:, 2], contour3[:, 0]) < 1
    )
    depth = np.where(inside, hub.signed_distance(contour3), np.inf)
    if np.any(depth <= 0):
        i = int(np.argmin(depth))
        raise InputError(
            f"shroud contour point {i} lies inside the hub: hub and shroud contours cross",
            file=spec.source,
            field="meridional.shroud",
            value=spec.shroud_contour[i].tolist(),
            accepted="a shroud contour on the passage side of the hub contour",
        )
