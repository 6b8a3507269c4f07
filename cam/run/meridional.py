"""Meridional position of points of the part: between the blades' edges, beyond the shroud.

Used by the per-face acceptance (``cam.run.regions``): the hub samples between the
blades' leading and trailing edges are milled (``passage_position`` in [0, 1]), blade
samples beyond the shroud envelope (``shroud_offset`` > 0) are the blank's skin over
the tips, turned on the lathe.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["passage_position", "shroud_offset"]


def _polyline_fraction(zr: NDArray[np.float64], contour: NDArray[np.float64]
                       ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Arc-length position (mm) of the closest point of a (z, r) polyline, and the distance.

    Compiled (``geometry.mesh_query.polyline_projection``): a verified stock has tens of
    millions of samples.

    Parameters
    ----------
    zr : (n, 2) float64
        Points in the meridional plane (z, r), mm.
    contour : (k, 2) float64
        The polyline (z, r), mm.
    """
    from geometry.mesh_query import polyline_projection

    position, distance, _ = polyline_projection(zr, contour)
    return position, distance


def passage_position(points: NDArray[np.float64], hub: NDArray[np.float64],
                     shroud: NDArray[np.float64], hub_edges: NDArray[np.float64],
                     shroud_edges: NDArray[np.float64]) -> NDArray[np.float64]:
    """Meridional position of points between the blades' leading (0) and trailing (1) edge.

    The point's (z, r) is projected on the hub and the shroud contours; on each the
    position is normalised by that contour's leading- and trailing-edge points, and
    the two are blended by the point's relative distance from hub and shroud.

    Parameters
    ----------
    points : (n, 3) float64
        Points in W, mm.
    hub, shroud : (k, 2) float64
        Meridional contours (z, r), mm.
    hub_edges, shroud_edges : (2, 2) float64
        (z, r) of the leading and trailing edge on each contour.

    Returns
    -------
    (n,) float64
        < 0 upstream of the leading edge, > 1 downstream of the trailing edge.
    """
    zr = np.column_stack([points[:, 2], np.hypot(points[:, 0], points[:, 1])])
    m_h, d_h = _polyline_fraction(zr, hub)
    m_s, d_s = _polyline_fraction(zr, shroud)
    e_h, _ = _polyline_fraction(hub_edges, hub)
    e_s, _ = _polyline_fraction(shroud_edges, shroud)
    t_h = (m_h - e_h[0]) / (e_h[1] - e_h[0])
    t_s = (m_s - e_s[0]) / (e_s[1] - e_s[0])
    w = d_h / np.maximum(d_h + d_s, 1e-12)
    return np.asarray((1.0 - w) * t_h + w * t_s)


def shroud_offset(points: NDArray[np.float64], shroud: NDArray[np.float64],
                  hub: NDArray[np.float64]) -> NDArray[np.float64]:
    """Signed meridional distance of points from the shroud contour, mm.

    Positive on the side away from the hub (beyond the shroud envelope the blade tips
    are turned to), negative towards the hub. Beyond the contour's ends the distance
    is to the end point, signed by the end segment.

    Parameters
    ----------
    points : (n, 3) float64
        Points in W, mm.
    shroud, hub : (k, 2) float64
        Meridional contours (z, r), mm; they must not cross.
    """
    from geometry.mesh_query import polyline_projection

    def side(p: NDArray[np.float64]) -> NDArray[np.float64]:
        _, distance, cross = polyline_projection(p, shroud)
        return np.where(cross < 0.0, -1.0, 1.0) * distance

    zr = np.column_stack([points[:, 2], np.hypot(points[:, 0], points[:, 1])])
    hub_side = float(np.sign(side(hub[len(hub) // 2][None])[0]))
    return np.asarray(-hub_side * side(zr))
