"""Which blade a point of the part belongs to: a main blade or a splitter.

The face roles of the design mesh (``Impeller.triangle_roles``) name the kind of face
(pressure, suction, fillet, edges, tip) but not its blade; the acceptance report lists
the splitters' faces apart from the main blades' (``cam.run.regions``). Splitters are
the main blades' camber surface turned by half a pitch about Z
(``geometry.surfaces.build_surfaces``), so a point belongs to a splitter when its
angle about Z, measured from the main blades' camber surface at the same meridional
position (z, r), lies within a quarter pitch of half a pitch; otherwise to a main
blade. A blade's material (sides, round edges, fillet, tip) lies within a few
millimetres of its camber surface, well inside the quarter pitch between the two:
on the splitter fixture's design mesh (136,407 blade-face triangles) the centroids lie
within 7.2 deg of the main camber surface (main blades' faces) and within 6.0 deg of
the splitters' (splitters' faces), the quarter pitch is 12.9 deg.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from geometry.surfaces import ImpellerSurfaces

__all__ = ["CAMBER_GRID", "splitter_points"]

#: Samples of the main blade's camber surface along the chord (u in [0, 1]) and the
#: span (v from beyond the tip to below the hub, where the fillets are).
CAMBER_GRID = (241, 71)
#: Span parameters of the camber grid: the rulings extend past tip (0) and hub (1).
_SPAN = (-0.2, 1.3)


def splitter_points(surfaces: ImpellerSurfaces, points: NDArray[np.float64]
                    ) -> NDArray[np.bool_]:
    """Whether each point lies on a splitter's side of the passage, ``(n,)`` bool.

    Parameters
    ----------
    surfaces : ImpellerSurfaces
        The design's surfaces (main blades at ``k pitch``, splitters at
        ``(k + 1/2) pitch``).
    points : (n, 3) float64
        Points in the part's frame (Z the axis), mm: centroids of blade faces, or
        samples whose closest design face is a blade face.

    Returns
    -------
    (n,) bool
        True where the point's angle from the main camber surface at its (z, r), modulo
        the pitch, lies between a quarter and three quarters of the pitch; all False
        for a design without splitters.
    """
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if not surfaces.splitters or not len(points):
        return np.zeros(len(points), dtype=bool)
    pitch = float(surfaces.spec.pitch)
    u, v = np.meshgrid(np.linspace(0.0, 1.0, CAMBER_GRID[0]),
                       np.linspace(*_SPAN, CAMBER_GRID[1]), indexing="ij")
    camber = surfaces.blades[0].camber(u.ravel(), v.ravel())
    tree = cKDTree(np.column_stack([camber[:, 2], np.hypot(camber[:, 0], camber[:, 1])]))
    _, nearest = tree.query(np.column_stack([points[:, 2],
                                             np.hypot(points[:, 0], points[:, 1])]))
    theta = np.arctan2(camber[nearest, 1], camber[nearest, 0])
    delta = np.mod(np.arctan2(points[:, 1], points[:, 0]) - theta, pitch) / pitch
    return np.asarray((delta > 0.25) & (delta < 0.75))

